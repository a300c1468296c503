//! The lens's relative illumination in rendered images: the image irradiance
//! of a uniform radiance source at observed pixel p, relative to the
//! principal point. With `[optics] illumination = "lens"` it is the physical
//! model
//!
//! `RI(p) = cos⁴θ · V(tan θ) · J(p)`,
//!
//! θ the field angle of p's ray, `V = 1 + v₁·tan²θ + v₂·tan⁴θ` the lens's own
//! vignetting, `J = |∂ideal/∂observed|` the area Jacobian of the undistortion
//! (energy is conserved under distortion: light the pinhole image spreads over
//! dA_ideal lands on dA_observed). The renderer multiplies each sphere's
//! covered area and the background light by RI before the blur and the
//! sensor; the dark offset is not light and is not multiplied.
//!
//! With `illumination = "profile"` it is a lens's measured profile
//! ([`VignettingProfile`], lensfun's "pa" model): `RI(p) = 1 + k₁ρ² + k₂ρ⁴ + k₃ρ⁶`
//! about a centre that may be decentred from the principal point. A measured
//! profile already holds the natural and mechanical vignetting and the
//! distortion's area effect, so no cos⁴θ or J is applied on top.
//!
//! RI is smooth, so it is evaluated exactly (undistortion by Newton) on a
//! grid of nodes every [`NODE_STEP_PX`] px and, between them, by the nearest
//! node's second-order Taylor expansion (value, gradient and Hessian by
//! central differences of the exact function): the third-order remainder is
//! ≈ |∂³RI|·(√2·8 px)³/6 ≈ 1e-8 of RI, far below what a centroid can see.

use geom::illumination::natural;
use geom::nalgebra::Vector2;
use geom::{Camera, Point2};
use rayon::prelude::*;

use crate::coverage::Coverage;
use crate::{Result, SynthError};

/// Spacing of the exactly evaluated nodes (px).
pub(crate) const NODE_STEP_PX: f64 = 16.0;

/// Nodes reach this far past the image (px): coverage extends past the
/// border by the blur radius.
const NODE_MARGIN_PX: f64 = 96.0;

/// Step of the central differences at a node (px).
const DIFF_STEP_PX: f64 = 1.0;

/// The lens's own vignetting `V(tan θ) = 1 + v₁·tan²θ + v₂·tan⁴θ` at the ideal
/// normalised image point `n` (`tan²θ = |n|²`).
pub(crate) fn vignetting(v: [f64; 2], n: Vector2<f64>) -> f64 {
    let t2 = n.norm_squared();
    1.0 + v[0] * t2 + v[1] * t2 * t2
}

/// A lens's measured relative illumination (lensfun's "pa" model, see
/// `crate::lens_profile`): `RI = 1 + k₁ρ² + k₂ρ⁴ + k₃ρ⁶`, `ρ = |p − centre| / radius`
/// at observed pixel p.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VignettingProfile {
    /// Centre of the fall-off (px): the principal point plus the decentring.
    pub centre_px: [f64; 2],
    /// Distance (px) at which ρ = 1.
    pub radius_px: f64,
    /// `[k₁, k₂, k₃]`.
    pub k: [f64; 3],
}

impl VignettingProfile {
    /// RI at observed pixel (u, v).
    pub fn at(&self, u: f64, v: f64) -> f64 {
        let du = (u - self.centre_px[0]) / self.radius_px;
        let dv = (v - self.centre_px[1]) / self.radius_px;
        let r2 = du * du + dv * dv;
        let [k1, k2, k3] = self.k;
        1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    }
}

/// What a [`LensIllumination`] evaluates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IlluminationSource {
    /// `cos⁴θ·V·J` with the lens's own vignetting `V = 1 + v₁·tan²θ + v₂·tan⁴θ`, `[v₁, v₂]`.
    Physical([f64; 2]),
    /// A measured profile.
    Profile(VignettingProfile),
}

/// Exact `RI = cos⁴θ·V·J` at observed pixel (u, v).
pub(crate) fn exact(camera: &Camera, v: [f64; 2], u: f64, w: f64) -> Result<f64> {
    let observed = Point2::new(u, w);
    let n = camera
        .undistort_normalized(observed)
        .map_err(|e| SynthError::geometry(format!("undistorting pixel ({u}, {w})"), e))?;
    let det = camera.distortion.jacobian(n).determinant();
    if det.is_nan() || det <= 0.0 {
        return Err(SynthError::DistortionFolds(u, w));
    }
    Ok(natural(n, 1.0 / det) * vignetting(v, n))
}

/// Second-order expansion of RI about a node.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Node {
    value: f64,
    gradient: [f64; 2],
    /// ∂²/∂u², ∂²/∂u∂v, ∂²/∂v².
    hessian: [f64; 3],
}

/// RI of one camera's lens over its image and a margin around it.
#[derive(Debug, Clone, PartialEq)]
pub struct LensIllumination {
    source: IlluminationSource,
    /// Pixel coordinates of node (0, 0).
    origin: [f64; 2],
    columns: usize,
    rows: usize,
    nodes: Vec<Node>,
}

impl LensIllumination {
    /// Evaluate the lens of `camera` with vignetting `[v₁, v₂]` at the nodes.
    pub fn new(camera: &Camera, vignetting: [f64; 2]) -> Result<Self> {
        Self::from_source(camera, IlluminationSource::Physical(vignetting))
    }

    /// Evaluate `source` over the image of `camera` (and its margin) at the
    /// nodes; a measured profile must stay positive there.
    pub fn from_source(camera: &Camera, source: IlluminationSource) -> Result<Self> {
        let exact_at = |u: f64, w: f64| match source {
            IlluminationSource::Physical(v) => exact(camera, v, u, w),
            IlluminationSource::Profile(p) => {
                let ri = p.at(u, w);
                if ri.is_nan() || ri <= 0.0 {
                    Err(SynthError::config(format!(
                        "optics: the lens profile's relative illumination is {ri} at pixel \
                         ({u}, {w}); it must stay positive over the image"
                    )))
                } else {
                    Ok(ri)
                }
            }
        };
        let origin = [-NODE_MARGIN_PX, -NODE_MARGIN_PX];
        let count = |size: u32| {
            ((f64::from(size) - 1.0 + 2.0 * NODE_MARGIN_PX) / NODE_STEP_PX).ceil() as usize + 1
        };
        let (columns, rows) = (count(camera.width), count(camera.height));
        let h = DIFF_STEP_PX;
        let nodes = (0..rows)
            .into_par_iter()
            .map(|j| {
                (0..columns)
                    .map(|i| {
                        let u = origin[0] + i as f64 * NODE_STEP_PX;
                        let v = origin[1] + j as f64 * NODE_STEP_PX;
                        let f = |du: f64, dv: f64| exact_at(u + du, v + dv);
                        let c = f(0.0, 0.0)?;
                        let (e, w, s, n) = (f(h, 0.0)?, f(-h, 0.0)?, f(0.0, h)?, f(0.0, -h)?);
                        let (ne, nw, se, sw) = (f(h, h)?, f(-h, h)?, f(h, -h)?, f(-h, -h)?);
                        Ok(Node {
                            value: c,
                            gradient: [(e - w) / (2.0 * h), (s - n) / (2.0 * h)],
                            hessian: [
                                (e - 2.0 * c + w) / (h * h),
                                (ne - nw - se + sw) / (4.0 * h * h),
                                (s - 2.0 * c + n) / (h * h),
                            ],
                        })
                    })
                    .collect::<Result<Vec<Node>>>()
            })
            .collect::<Result<Vec<Vec<Node>>>>()?
            .into_iter()
            .flatten()
            .collect();
        Ok(Self {
            source,
            origin,
            columns,
            rows,
            nodes,
        })
    }

    /// The lens's own vignetting `[v₁, v₂]` of the physical model (`[0, 0]`
    /// for a measured profile, which holds all of RI).
    pub fn vignetting(&self) -> [f64; 2] {
        match self.source {
            IlluminationSource::Physical(v) => v,
            IlluminationSource::Profile(_) => [0.0, 0.0],
        }
    }

    /// What this RI evaluates.
    pub fn source(&self) -> IlluminationSource {
        self.source
    }

    /// RI and its gradient (per px) at pixel (u, v).
    pub fn with_gradient(&self, u: f64, v: f64) -> (f64, [f64; 2]) {
        let index = |x: f64, o: f64, n: usize| {
            ((x - o) / NODE_STEP_PX).round().clamp(0.0, n as f64 - 1.0) as usize
        };
        let (i, j) = (
            index(u, self.origin[0], self.columns),
            index(v, self.origin[1], self.rows),
        );
        let node = &self.nodes[j * self.columns + i];
        let du = u - (self.origin[0] + i as f64 * NODE_STEP_PX);
        let dv = v - (self.origin[1] + j as f64 * NODE_STEP_PX);
        let [huu, huv, hvv] = node.hessian;
        let gu = node.gradient[0] + huu * du + huv * dv;
        let gv = node.gradient[1] + huv * du + hvv * dv;
        let value = node.value
            + node.gradient[0] * du
            + node.gradient[1] * dv
            + 0.5 * (huu * du * du + 2.0 * huv * du * dv + hvv * dv * dv);
        (value, [gu, gv])
    }

    /// RI at pixel (u, v).
    pub fn at(&self, u: f64, v: f64) -> f64 {
        self.with_gradient(u, v).0
    }

    /// Multiply `values[u]` by RI at pixel (u, v) for every column u of row
    /// `v` (the same expansion as [`Self::at`], node by node along the row).
    pub fn scale_row(&self, v: f64, values: &mut [f64]) {
        let j = ((v - self.origin[1]) / NODE_STEP_PX)
            .round()
            .clamp(0.0, self.rows as f64 - 1.0) as usize;
        let dv = v - (self.origin[1] + j as f64 * NODE_STEP_PX);
        let nodes = &self.nodes[j * self.columns..(j + 1) * self.columns];
        let half = NODE_STEP_PX / 2.0;
        let mut u0 = 0usize;
        for (i, node) in nodes.iter().enumerate() {
            let centre = self.origin[0] + i as f64 * NODE_STEP_PX;
            // Columns nearest to this node: up to (but not including) centre + half.
            let end = if i + 1 == self.columns {
                values.len()
            } else {
                ((centre + half).ceil().max(0.0) as usize).min(values.len())
            };
            if end <= u0 {
                continue;
            }
            let [huu, huv, hvv] = node.hessian;
            // RI(du) = a + b·du + c·du² along the row.
            let a = node.value + node.gradient[1] * dv + 0.5 * hvv * dv * dv;
            let b = node.gradient[0] + huv * dv;
            let c = 0.5 * huu;
            for (u, x) in values[u0..end].iter_mut().enumerate() {
                let du = (u0 + u) as f64 - centre;
                *x *= a + du * (b + du * c);
            }
            u0 = end;
            if u0 == values.len() {
                break;
            }
        }
    }

    /// Largest RI at a node inside the image.
    pub fn max_in(&self, width: u32, height: u32) -> f64 {
        let (w, h) = (f64::from(width) - 1.0, f64::from(height) - 1.0);
        self.nodes
            .iter()
            .enumerate()
            .filter(|(k, _)| {
                let u = self.origin[0] + (k % self.columns) as f64 * NODE_STEP_PX;
                let v = self.origin[1] + (k / self.columns) as f64 * NODE_STEP_PX;
                (0.0..=w).contains(&u) && (0.0..=h).contains(&v)
            })
            .map(|(_, n)| n.value)
            .fold(0.0, f64::max)
    }

    /// Multiply a coverage layer by RI: per pixel, covered area
    /// `A′ = RI·A + ∇RI·M` and first moment `M′ = RI·M + ∇RI·A/12` (RI to
    /// first order across the pixel; `A/12` the second moment of the covered
    /// part, exact for a full pixel), so that the layer's total and centroid
    /// are those of the irradiance `RI·S` over the silhouette S.
    pub fn weigh(&self, cov: &mut Coverage) {
        for r in 0..cov.height {
            let v = (cov.y0 + r as i64) as f64;
            for c in 0..cov.width {
                let k = r * cov.width + c;
                let a = cov.area[k];
                if a == 0.0 {
                    continue;
                }
                let (ri, [gu, gv]) = self.with_gradient((cov.x0 + c as i64) as f64, v);
                let (mu, mv) = (cov.moment_u[k], cov.moment_v[k]);
                cov.area[k] = ri * a + gu * mu + gv * mv;
                cov.moment_u[k] = ri * mu + gu * a / 12.0;
                cov.moment_v[k] = ri * mv + gv * a / 12.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::{Distortion, Intrinsics, Isometry3};

    fn camera(k1: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics::centred(1990.0, 1024, 768),
            distortion: Distortion {
                k1,
                k2: 0.02,
                p1: 1e-4,
                p2: -1e-4,
                k3: 0.0,
            },
            pose: Isometry3::identity(),
            width: 1024,
            height: 768,
        }
    }

    /// The node expansion reproduces the exact RI between the nodes.
    #[test]
    fn expansion_matches_the_exact_function() {
        let cam = camera(-0.045);
        let lens = LensIllumination::new(&cam, [1.2, -0.5]).unwrap();
        let mut worst: f64 = 0.0;
        for (u, v) in [
            (0.0, 0.0),
            (511.5, 383.5),
            (1023.0, 767.0),
            (7.9, 300.3),
            (-40.0, 800.0),
        ] {
            let e = exact(&cam, [1.2, -0.5], u, v).unwrap();
            worst = worst.max((lens.at(u, v) / e - 1.0).abs());
            // Gradient against a finite difference of the exact function.
            let (_, g) = lens.with_gradient(u, v);
            let d = (exact(&cam, [1.2, -0.5], u + 0.5, v).unwrap()
                - exact(&cam, [1.2, -0.5], u - 0.5, v).unwrap())
                / 1.0;
            assert!((g[0] - d).abs() < 1e-9, "∂RI/∂u {} vs {d}", g[0]);
        }
        assert!(worst < 1e-8, "relative error {worst}");
        // A whole row at once: the same values as pixel by pixel.
        let mut row = vec![1.0; 1024];
        lens.scale_row(300.0, &mut row);
        for (u, r) in row.iter().enumerate() {
            assert!((r - lens.at(u as f64, 300.0)).abs() < 1e-14, "column {u}");
        }
    }

    /// Without distortion or V, RI is cos⁴θ exactly; with distortion the
    /// Jacobian matches the area ratio of the undistortion map by finite
    /// differences (energy conservation).
    #[test]
    fn natural_vignetting_and_energy_conservation() {
        let mut cam = camera(0.0);
        cam.distortion = Distortion::default();
        let k = cam.intrinsics;
        let (u, v) = (1000.0, 700.0);
        let t2 = ((u - k.cx) / k.fx).powi(2) + ((v - k.cy) / k.fy).powi(2);
        let cos4 = 1.0 / (1.0 + t2).powi(2);
        assert!((exact(&cam, [0.0, 0.0], u, v).unwrap() - cos4).abs() < 1e-14);

        let barrel = camera(-0.2);
        let ideal = |du: f64, dv: f64| barrel.undistort_pixel(Point2::new(u + du, v + dv)).unwrap();
        let h = 0.5;
        let (a, b) = (
            ideal(h, 0.0) - ideal(-h, 0.0),
            ideal(0.0, h) - ideal(0.0, -h),
        );
        let area = (a.x * b.y - a.y * b.x) / (4.0 * h * h);
        let n = barrel.intrinsics.to_normalized(ideal(0.0, 0.0));
        let want = geom::illumination::cos4(n) * area;
        let got = exact(&barrel, [0.0, 0.0], u, v).unwrap();
        assert!((got / want - 1.0).abs() < 1e-6, "{got} vs {want}");
        assert!(area > 1.0, "a barrel lens compresses the edge of the image");
    }
}
