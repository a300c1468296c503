//! The lens's relative illumination from a flat-field frame and a dark frame.
//!
//! A flat field is an image of a uniform radiance source filling the view; a
//! dark frame, one taken with the lens capped (the sensor's offset). Their
//! difference is the relative illumination RI times a constant. The frames are
//! averaged over blocks of pixels (dark subtracted block by block, so a dark
//! pattern such as amplifier glow is removed too), and a smooth radial model
//! is fitted by least squares (Levenberg–Marquardt) to the block means:
//!
//! `RI(p) = Σₖ qₖ·ρ²ᵏ` (k = 0…[`DEGREE`]), `ρ = |p − c|/s`,
//!
//! with the centre c free (started at the principal point) and s the focal
//! length in pixels (so ρ ≈ tan θ) or, without a camera, half the image
//! diagonal. Degree 4 in ρ² follows cos⁴θ·V/J of real lenses to ≈ 1e-6 over
//! a field of ±18°. Seven parameters from ~10⁴ blocks: the noise of one flat
//! (≈ 0.5 % per pixel) reaches the model at ≈ 1e-5, far below what moves a
//! centroid. The fit's residual is compared with the noise of the block means:
//! a residual well above it says the flat has structure a radial lens model
//! does not follow (a non-uniform source, dust, a tilted or decentred lens).

use formats::commissioning::{FlatFieldFit, ProfilePoint};
use geom::lm::{LmOptions, Residuals, minimize};
use geom::nalgebra::{DMatrix, DVector};
use geom::{Camera, Illumination, Point2, Point3, RadialIllumination};

use crate::error::FlatFieldProblem;
use crate::{CalibError, Result};

/// Highest power of ρ² in the model.
pub const DEGREE: usize = 4;
/// Blocks along the shorter image side (the block size follows the image size).
const BLOCKS_ON_SHORT_SIDE: u32 = 96;
/// Largest fraction of saturated pixels in a flat field.
const MAX_SATURATED_FRACTION: f64 = 1e-4;
/// Smallest flat-field level above the dark, as a multiple of the dark's noise.
const MIN_SIGNAL_SIGMAS: f64 = 100.0;
/// A residual above this many times the blocks' noise (and above
/// [`STRUCTURE_FLOOR`]) is reported as structure the model does not follow.
const STRUCTURE_FACTOR: f64 = 3.0;
/// Residual (relative RMS) below which no structure is reported: the model
/// itself follows real lenses to ≈ 1e-6.
const STRUCTURE_FLOOR: f64 = 1e-4;

/// One frame's pixels: row-major values, size and the saturation level.
#[derive(Debug, Clone, Copy)]
pub struct Pixels<'a> {
    /// Values (DN), row-major.
    pub values: &'a [u16],
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// The largest value the sensor gives (saturation, DN).
    pub saturation: u16,
}

/// Block means of `flat − dark` and their noise.
struct Blocks {
    /// Block centres (px) and mean values (DN).
    centres: Vec<[f64; 2]>,
    values: Vec<f64>,
    /// Mean pixel variance of the flat within a block (DN²).
    variance: f64,
    size: u32,
}

fn blocks(flat: &Pixels<'_>, dark: &Pixels<'_>) -> Blocks {
    let size = (flat.width.min(flat.height) / BLOCKS_ON_SHORT_SIDE).max(2);
    let (bw, bh) = (flat.width / size, flat.height / size);
    let mut centres = Vec::with_capacity((bw * bh) as usize);
    let mut values = Vec::with_capacity((bw * bh) as usize);
    let mut variance = 0.0;
    let n = f64::from(size * size);
    for by in 0..bh {
        for bx in 0..bw {
            // Pixel noise from differences of horizontal neighbours, which
            // the smooth fall-off across the block does not inflate.
            let (mut sf, mut sd, mut sdiff) = (0.0, 0.0, 0.0);
            for y in by * size..(by + 1) * size {
                let row = (y * flat.width) as usize;
                let mut last = None;
                for x in bx * size..(bx + 1) * size {
                    let f = f64::from(flat.values[row + x as usize]);
                    sf += f;
                    if let Some(l) = last {
                        sdiff += (f - l) * (f - l);
                    }
                    last = Some(f);
                    sd += f64::from(dark.values[row + x as usize]);
                }
            }
            let mean = sf / n;
            variance += sdiff / (2.0 * f64::from(size * (size - 1)));
            centres.push([
                f64::from(bx * size) + (f64::from(size) - 1.0) / 2.0,
                f64::from(by * size) + (f64::from(size) - 1.0) / 2.0,
            ]);
            values.push(mean - sd / n);
        }
    }
    Blocks {
        variance: variance / values.len().max(1) as f64,
        centres,
        values,
        size,
    }
}

/// The radial model fitted to block means (relative to `level`).
struct RadialFit<'a> {
    centres: &'a [[f64; 2]],
    values: &'a [f64],
    scale: f64,
}

impl RadialFit<'_> {
    /// Parameters: `[cu, cv, a₀, …, a_DEGREE]`.
    fn rho2(&self, p: &DVector<f64>, c: &[f64; 2]) -> (f64, f64, f64) {
        let (du, dv) = (c[0] - p[0], c[1] - p[1]);
        ((du * du + dv * dv) / (self.scale * self.scale), du, dv)
    }
}

impl Residuals for RadialFit<'_> {
    fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
        DVector::from_iterator(
            self.values.len(),
            self.centres.iter().zip(self.values).map(|(c, v)| {
                let (r2, _, _) = self.rho2(p, c);
                (0..=DEGREE).rev().fold(0.0, |acc, k| acc * r2 + p[2 + k]) - v
            }),
        )
    }

    fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
        let mut j = DMatrix::zeros(self.values.len(), 3 + DEGREE);
        for (i, c) in self.centres.iter().enumerate() {
            let (r2, du, dv) = self.rho2(p, c);
            // d model/d ρ² = Σ k·aₖ·ρ²⁽ᵏ⁻¹⁾; ∂ρ²/∂cu = −2·du/s².
            let slope = (1..=DEGREE)
                .rev()
                .fold(0.0, |acc, k| acc * r2 + k as f64 * p[2 + k]);
            let s2 = self.scale * self.scale;
            j[(i, 0)] = slope * (-2.0 * du / s2);
            j[(i, 1)] = slope * (-2.0 * dv / s2);
            let mut power = 1.0;
            for k in 0..=DEGREE {
                j[(i, 2 + k)] = power;
                power *= r2;
            }
        }
        j
    }
}

fn check(flat: &Pixels<'_>, dark: &Pixels<'_>) -> Result<()> {
    let n = (flat.width as usize) * (flat.height as usize);
    if (dark.width, dark.height) != (flat.width, flat.height) {
        return Err(CalibError::FlatField(FlatFieldProblem::Sizes {
            dark: [dark.width, dark.height],
            flat: [flat.width, flat.height],
        }));
    }
    if flat.values.len() != n || dark.values.len() != n || n == 0 {
        return Err(CalibError::FlatField(FlatFieldProblem::Buffers));
    }
    let saturated = flat
        .values
        .iter()
        .filter(|&&v| v >= flat.saturation)
        .count();
    if saturated as f64 > MAX_SATURATED_FRACTION * n as f64 {
        return Err(CalibError::FlatField(FlatFieldProblem::Saturated {
            pixels: saturated,
            saturation: flat.saturation,
        }));
    }
    Ok(())
}

/// Fit the relative illumination from one flat field and one dark frame of
/// the same camera and exposure settings. `centre`: where to start the
/// model's centre (the principal point, or the image centre); `scale_px`: s.
pub fn fit_flat_field(
    flat: &Pixels<'_>,
    dark: &Pixels<'_>,
    centre: [f64; 2],
    scale_px: f64,
) -> Result<FlatFieldFit> {
    check(flat, dark)?;
    if !(scale_px.is_finite() && scale_px > 0.0 && centre.iter().all(|c| c.is_finite())) {
        return Err(CalibError::FlatField(FlatFieldProblem::Model {
            centre,
            scale_px,
        }));
    }
    let n = dark.values.len() as f64;
    let dark_dn = dark.values.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let dark_sd = (dark
        .values
        .iter()
        .map(|&v| (f64::from(v) - dark_dn).powi(2))
        .sum::<f64>()
        / n)
        .sqrt()
        .max(0.5);
    let b = blocks(flat, dark);
    let level = b.values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if level.is_nan() || level <= MIN_SIGNAL_SIGMAS * dark_sd {
        return Err(CalibError::FlatField(FlatFieldProblem::Unlit {
            level_dn: level,
            noise_dn: dark_sd,
        }));
    }
    let values: Vec<f64> = b.values.iter().map(|v| v / level).collect();
    let problem = RadialFit {
        centres: &b.centres,
        values: &values,
        scale: scale_px,
    };
    // Start: the linear least squares in the coefficients at the given centre.
    let mut start = DVector::zeros(3 + DEGREE);
    start[0] = centre[0];
    start[1] = centre[1];
    let jac = problem.jacobian(&start);
    let design = jac.columns(2, DEGREE + 1).into_owned();
    let coefficients = design
        .svd(true, true)
        .solve(&DVector::from_column_slice(&values), 1e-14)
        .map_err(|e| CalibError::FlatField(FlatFieldProblem::Solve(e)))?;
    start.rows_mut(2, DEGREE + 1).copy_from(&coefficients);
    let solution = minimize(&problem, start, &LmOptions::default())
        .map_err(CalibError::geom("flat-field fit"))?;
    let p = &solution.params;
    let q0 = p[2];
    if q0.is_nan() || q0 <= 0.0 {
        return Err(CalibError::FlatField(FlatFieldProblem::Level(q0)));
    }
    let model = RadialIllumination {
        centre: [p[0], p[1]],
        scale_px,
        coefficients: (0..=DEGREE).map(|k| p[2 + k] / q0).collect(),
    };
    let rel: Vec<f64> = solution
        .residuals
        .iter()
        .zip(&values)
        .map(|(r, v)| r / (v - r))
        .collect();
    let residual_rms = (rel.iter().map(|r| r * r).sum::<f64>() / rel.len() as f64).sqrt();
    let residual_max = rel.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    let noise_rms = (b.variance / f64::from(b.size * b.size)).sqrt() / level;
    let (w, h) = (f64::from(flat.width) - 1.0, f64::from(flat.height) - 1.0);
    let corners = [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)];
    let ri_min = corners
        .iter()
        .map(|&(u, v)| model.at(u, v))
        .chain(b.centres.iter().map(|c| model.at(c[0], c[1])))
        .fold(f64::INFINITY, f64::min);
    let ri_max = b
        .centres
        .iter()
        .map(|c| model.at(c[0], c[1]))
        .fold(1.0, f64::max);
    if ri_min.is_nan() || ri_min <= 0.0 {
        return Err(CalibError::FlatField(FlatFieldProblem::Falls(ri_min)));
    }
    let warning = (residual_rms > STRUCTURE_FACTOR * noise_rms && residual_rms > STRUCTURE_FLOOR)
        .then(|| {
            format!(
                "the flat field departs from a smooth radial fall-off by {:.3} % RMS (noise {:.3} %): \
                 a non-uniform source, dust, or a tilted or decentred lens",
                100.0 * residual_rms,
                100.0 * noise_rms
            )
        });
    Ok(FlatFieldFit {
        model,
        flat_level_dn: q0 * level,
        dark_dn,
        ri_range: [ri_min, ri_max],
        residual_rms,
        residual_max,
        noise_rms,
        blocks: b.values.len(),
        block_px: b.size,
        warning,
    })
}

/// `illumination` at observed pixel `p` of `camera`, with the ideal lens's
/// inputs (ideal normalised coordinates, area Jacobian) computed there.
fn ri_at(camera: &Camera, illumination: &Illumination, p: Point2<f64>) -> Option<f64> {
    let (ideal, j) = camera.undistort_pixel_area(p).ok()?;
    let n = camera.intrinsics.to_normalized(ideal);
    Some(illumination.at([p.x, p.y], n, j))
}

/// RI of `illumination` against the ideal lens at `points` positions from
/// the principal point to the image corner farthest from it.
pub fn profile(camera: &Camera, illumination: &Illumination, points: usize) -> Vec<ProfilePoint> {
    let k = camera.intrinsics;
    let pp = Point2::new(k.cx, k.cy);
    let (w, h) = (
        f64::from(camera.width) - 1.0,
        f64::from(camera.height) - 1.0,
    );
    let corner = [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
        .into_iter()
        .map(|(u, v)| Point2::new(u, v))
        .max_by(|a, b| (a - pp).norm().total_cmp(&(b - pp).norm()))
        .unwrap_or(pp);
    let (Some(ri0), Some(ideal0)) = (
        ri_at(camera, illumination, pp),
        ri_at(camera, &Illumination::Ideal, pp),
    ) else {
        return Vec::new();
    };
    (0..points)
        .filter_map(|i| {
            let t = i as f64 / (points.max(2) - 1) as f64;
            let p = pp + (corner - pp) * t;
            let ri = ri_at(camera, illumination, p)? / ri0;
            let ideal = ri_at(camera, &Illumination::Ideal, p)? / ideal0;
            let n = camera
                .intrinsics
                .to_normalized(camera.undistort_pixel(p).ok()?);
            Some(ProfilePoint {
                field_angle_deg: n.norm().atan().to_degrees(),
                radius_px: (p - pp).norm(),
                ri,
                ideal,
                ratio: ri / ideal,
            })
        })
        .collect()
}

/// Scale error (ppm) of a sphere's measured position when pixels are
/// corrected with `assumed` while the lens is `actual`: the corrected image
/// keeps the weight `actual/assumed`, whose radial log-gradient g (per px)
/// moves the centroid of the sphere's image (an ellipse of semi-axes ρ and,
/// radially, ρ·sec θ: radial variance ρ²·(1 + tan²θ)/4) by
/// `δ = g·ρ²·(1 + tan²θ)/4` outward; for a fall-off symmetric about the
/// principal point δ grows in proportion to the image radius r_c of the
/// sphere, so displacements are scaled by `δ/r_c`. `None` on the optical
/// axis or outside the lens model.
pub fn scale_error_ppm(
    camera: &Camera,
    actual: &Illumination,
    assumed: &Illumination,
    centre: &Point3<f64>,
    radius_mm: f64,
) -> Option<f64> {
    let k = camera.intrinsics;
    let pp = Point2::new(k.cx, k.cy);
    let ideal = camera.project_pinhole(centre).ok()?;
    let r_c = (ideal - pp).norm();
    if r_c < 1.0 {
        return None;
    }
    let e = (ideal - pp) / r_c;
    let q = camera.project(centre).ok()?;
    let log_ratio = |p: Point2<f64>| -> Option<f64> {
        Some((ri_at(camera, actual, p)? / ri_at(camera, assumed, p)?).ln())
    };
    let step = 2.0;
    let g = (log_ratio(q + e * step)? - log_ratio(q - e * step)?) / (2.0 * step);
    let z = camera.to_camera(centre).z;
    let rho = k.fx * radius_mm / (z * z - radius_mm * radius_mm).sqrt();
    // Radially the image is stretched by sec θ: variance ρ²·(1 + tan²θ)/4.
    let t2 = (r_c / k.fx).powi(2);
    Some(g * rho * rho * (1.0 + t2) / 4.0 / r_c * 1e6)
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::lm::jacobian_error;

    /// Assuming no fall-off for an ideal cos⁴θ lens costs the whole
    /// perspective bias, −R²/(Z² − R²); assuming the right lens costs nothing.
    #[test]
    fn scale_error_of_a_wrong_assumption() {
        let camera = Camera::look_at(
            Point3::new(0.0, 0.0, 490.0),
            Point3::new(0.0, 0.0, 30.0),
            geom::Vector3::y(),
            geom::Intrinsics::centred(7966.0, 4096, 3072),
            4096,
            3072,
        )
        .unwrap();
        let centre = Point3::new(75.0, 0.0, 30.0);
        let z = camera.to_camera(&centre).z;
        let r: f64 = 10.0;
        let want = -r * r / (z * z - r * r) * 1e6;
        let got = scale_error_ppm(
            &camera,
            &Illumination::Ideal,
            &Illumination::Uniform,
            &centre,
            r,
        )
        .unwrap();
        // First order in the weight's gradient across the image: ≈ 0.2 % here.
        assert!((got / want - 1.0).abs() < 0.005, "{got} ppm vs {want}");
        let none = scale_error_ppm(
            &camera,
            &Illumination::Ideal,
            &Illumination::Ideal,
            &centre,
            r,
        )
        .unwrap();
        assert!(none.abs() < 1e-9);
        let p = profile(&camera, &Illumination::Ideal, 5);
        assert_eq!(p.len(), 5);
        assert!((p[0].ri - 1.0).abs() < 1e-12 && (p[4].ratio - 1.0).abs() < 1e-12);
        // The corner of a 22.5 × 16.9 mm sensor behind a 43.8 mm lens: θ ≈ 17.8°.
        assert!(
            (p[4].field_angle_deg - 17.8).abs() < 0.1,
            "{}",
            p[4].field_angle_deg
        );
    }

    #[test]
    fn analytic_jacobian_matches_finite_differences() {
        let centres: Vec<[f64; 2]> = (0..40)
            .map(|i| [f64::from(i) * 25.0, f64::from(i % 7) * 40.0])
            .collect();
        let values = vec![1.0; 40];
        let problem = RadialFit {
            centres: &centres,
            values: &values,
            scale: 800.0,
        };
        let p = DVector::from_vec(vec![480.0, 130.0, 1.0, -1.9, 2.5, -3.0, 3.2]);
        assert!(jacobian_error(&problem, &p) < 1e-6);
    }

    /// A synthetic flat with a decentred radial fall-off, a dark pattern and
    /// no noise: the model, its centre and the dark level come back exactly.
    #[test]
    fn recovers_a_radial_fall_off() {
        let (w, h) = (640u32, 480u32);
        let truth = RadialIllumination {
            centre: [331.0, 228.5],
            scale_px: 1200.0,
            coefficients: vec![1.0, -1.8, 2.2, -1.5, 0.4],
        };
        let mut flat = vec![0u16; (w * h) as usize];
        let mut dark = vec![0u16; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let glow = if x < 64 { 40 } else { 0 };
                let d = 400 + glow;
                dark[(y * w + x) as usize] = d;
                flat[(y * w + x) as usize] =
                    (f64::from(d) + 40_000.0 * truth.at(f64::from(x), f64::from(y))).round() as u16;
            }
        }
        fn px(v: &[u16], w: u32, h: u32) -> Pixels<'_> {
            Pixels {
                values: v,
                width: w,
                height: h,
                saturation: u16::MAX,
            }
        }
        let fit =
            fit_flat_field(&px(&flat, w, h), &px(&dark, w, h), [319.5, 239.5], 1200.0).unwrap();
        for (u, v) in [(0.0, 0.0), (639.0, 479.0), (320.0, 240.0), (100.0, 400.0)] {
            let err = fit.model.at(u, v) / truth.at(u, v) - 1.0;
            // Rounding to integer DN: ±0.5 of 40000 per pixel, averaged.
            assert!(err.abs() < 2e-6, "at ({u}, {v}): {err}");
        }
        assert!(
            (fit.model.centre[0] - 331.0).abs() < 0.05,
            "{:?}",
            fit.model.centre
        );
        assert!((fit.flat_level_dn - 40_000.0).abs() < 1.0);
        assert!(fit.warning.is_none());
        // A source that is not uniform (one half 1 % brighter, the edge of a
        // panel) is not a radial lens fall-off: the fit says so. (A smooth
        // gradient is not told apart: the free centre absorbs it, as it
        // absorbs a decentred lens; the report gives the centre's offset.)
        let uneven: Vec<u16> = flat
            .iter()
            .enumerate()
            .map(|(k, &f)| {
                let step = if k as u32 % w < w / 2 { 1.0 } else { 1.01 };
                let d = f64::from(dark[k]);
                (d + (f64::from(f) - d) * step).round() as u16
            })
            .collect();
        let flagged =
            fit_flat_field(&px(&uneven, w, h), &px(&dark, w, h), [319.5, 239.5], 1200.0).unwrap();
        assert!(
            flagged.warning.is_some(),
            "residual {}",
            flagged.residual_rms
        );
        // Saturation is refused.
        let mut sat = flat.clone();
        sat.iter_mut().take(100).for_each(|v| *v = u16::MAX);
        assert!(matches!(
            fit_flat_field(&px(&sat, w, h), &px(&dark, w, h), [319.5, 239.5], 1200.0),
            Err(CalibError::FlatField(FlatFieldProblem::Saturated { .. }))
        ));
        // A flat that is not lit is refused.
        assert!(
            fit_flat_field(&px(&dark, w, h), &px(&dark, w, h), [319.5, 239.5], 1200.0).is_err()
        );
    }
}
