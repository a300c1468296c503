//! Lens profiles as a lens database measures them (lensfun's models,
//! docs/renderer.md): relative illumination in lensfun's "pa" vignetting
//! model and distortion in its "ptlens" model, converted to the renderer's
//! camera (Brown distortion, pixels).
//!
//! lensfun's normalisations (`libs/lensfun/modifier.cpp`, "About coordinate
//! systems in Lensfun"; `mod-color.cpp`): both models are radial about the
//! image centre of the *calibration* sensor — a sensor of diagonal
//! `√(36² + 24²) mm / crop_factor` and aspect ratio `aspect_ratio` (3:2 unless
//! the database says otherwise) — in units of
//! - vignetting: `r = 1` at the calibration sensor's corner, i.e. radius
//!   `R_v = √(36² + 24²)/2 / crop_factor` mm (21.633 mm for crop factor 1);
//!   `RI = 1 + k₁r² + k₂r⁴ + k₃r⁶` at the (distorted) image point;
//! - distortion: `r = 1` at half the calibration sensor's short side,
//!   `R_d = R_v / √(aspect_ratio² + 1)` mm (12 mm for a 3:2 full-frame
//!   sensor); `R_d' = R_u·(a·R_u³ + b·R_u² + c·R_u + 1 − a − b − c)` maps the
//!   undistorted radius to the distorted one.
//!
//! Physically both are functions of the image height in mm, so they carry
//! over to the renderer's sensor through its pixel pitch. ptlens' scale at
//! the centre is `d = 1 − a − b − c` (lensfun's "Hugin focal correction": the
//! real focal length is `d` times Hugin's); the renderer's pinhole has the
//! real principal distance, so an ideal image height ρ (mm) has `R_u = ρ/(d·R_d)`
//! and the Brown radial factor `D(ρ) = (a·R_u³ + b·R_u² + c·R_u + d)/d`.
//! ptlens has odd powers of R_u, Brown only even ones of the normalised
//! radius, and its `c·R_u` term makes the magnification grow linearly from
//! the centre, which no even series follows near the axis: a focal-length
//! scale `s` and `k₁, k₂, k₃` are fitted by linear least squares to the image
//! height, `ρ·D(ρ) ≈ s·ρ·(1 + k₁r² + k₂r⁴ + k₃r⁶)`, over a grid of ideal image
//! points covering the image (each an equal share of its area); the camera
//! takes the focal length `s·f` and `k₁, k₂, k₃`, and the largest residual
//! (px) is kept with the fit.

use geom::Intrinsics;
use geom::nalgebra::{Matrix4, Vector4};
use serde::{Deserialize, Serialize};

use crate::config::{bad, finite, positive};
use crate::illumination::VignettingProfile;
use crate::{Result, SynthError};

/// Diagonal of the 36 × 24 mm frame lensfun's crop factors refer to (mm).
const FULL_FRAME_DIAGONAL_MM: f64 = 43.266_615_305_567_87;

/// Ideal image points per image side in the least-squares fit of Brown to
/// ptlens (a grid from edge to edge).
const FIT_SAMPLES_PER_SIDE: u32 = 128;

/// A lens's measured profile (`[optics.profile]`, or a built-in one named by
/// `[optics] lens`): lensfun's models with their calibration sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LensProfile {
    /// What lens, at what focal length and aperture.
    pub name: String,
    /// Where the numbers come from (database, file, entry).
    pub source: String,
    /// Crop factor of the calibration sensor (lensfun `<cropfactor>`).
    pub crop_factor: f64,
    /// Aspect ratio (long/short side) of the calibration sensor (lensfun
    /// `<aspect-ratio>`, 1.5 when the database gives none).
    pub aspect_ratio: f64,
    /// lensfun "pa" vignetting `[k₁, k₂, k₃]`: `RI = 1 + k₁r² + k₂r⁴ + k₃r⁶`,
    /// r = 1 at the calibration sensor's corner. `None`: not measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vignetting_pa: Option<[f64; 3]>,
    /// lensfun "ptlens" distortion `[a, b, c]`: `R_d = R_u·(a·R_u³ + b·R_u² + c·R_u + 1 − a − b − c)`,
    /// r = 1 at half the calibration sensor's short side. `None`: not measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distortion_ptlens: Option<[f64; 3]>,
}

impl Default for LensProfile {
    fn default() -> Self {
        Self {
            name: String::new(),
            source: String::new(),
            crop_factor: 1.0,
            aspect_ratio: 1.5,
            vignetting_pa: None,
            distortion_ptlens: None,
        }
    }
}

/// The names of the built-in profiles ([`built_in`]).
pub const BUILT_IN_PROFILES: [&str; 2] = [SEED_LENS, SEED_CLASS_LENS];

/// The seed's lens: Nikon AF-S 24–70 mm f/2.8G ED at 40 mm.
const SEED_LENS: &str = "nikon-af-s-24-70-f2.8g-at-40";

/// A complete measured profile of a lens of the seed's class at the seed's
/// focal length and f-number: Nikon AF 35–70 mm f/2.8 at 40 mm, f/8.
const SEED_CLASS_LENS: &str = "nikon-af-35-70-f2.8-at-40-f8";

/// Source of the lensfun numbers (database licence: CC BY-SA 3.0).
const LENSFUN_NIKON: &str = "lensfun database (CC BY-SA 3.0), data/db/slr-nikon.xml";

/// The ptlens entries `(focal mm, [a, b, c])` of lensfun's
/// "Nikon AF-S Zoom-Nikkor 24-70mm f/2.8G ED" (data/db/slr-nikon.xml, "Taken
/// with Nikon D800", crop factor 1; the entry has no vignetting).
/// lensfun database, CC BY-SA 3.0.
const NIKKOR_24_70_PTLENS: [(f64, [f64; 3]); 5] = [
    (24.0, [0.01436, -0.06611, 0.06436]),
    (28.0, [0.00718, -0.03471, 0.03911]),
    (35.0, [0.01046, -0.03445, 0.04427]),
    (50.0, [0.00843, -0.02693, 0.04576]),
    (70.0, [0.00933, -0.03902, 0.05818]),
];

/// The built-in profile `name`, or `None`.
///
/// - `nikon-af-s-24-70-f2.8g-at-40`: the seed's lens. lensfun measures its
///   distortion only (no vignetting entry exists for it, nor for the
///   24–70 f/2.8E VR); ptlens at 40 mm interpolated from the 28, 35, 50 and
///   70 mm entries by lensfun's own rule ([`lensfun_interpolate`]):
///   a = 0.0096541, b = −0.0303371, c = 0.0433960.
/// - `nikon-af-35-70-f2.8-at-40-f8`: lensfun's "Nikon AF Nikkor 35-70mm
///   f/2.8" (taken with Nikon D3, crop factor 1), the entries at 40 mm:
///   ptlens a = 0.00645, b = −0.02212, c = 0.01511; pa at f/8 (the 10 m and
///   1000 m entries are equal) k₁ = −0.3735, k₂ = 0.1832, k₃ = −0.0571.
pub fn built_in(name: &str) -> Option<LensProfile> {
    match name {
        SEED_LENS => Some(LensProfile {
            name: "Nikon AF-S Zoom-Nikkor 24-70mm f/2.8G ED at 40 mm".into(),
            source: format!(
                "{LENSFUN_NIKON}, lens \"Nikon AF-S Zoom-Nikkor 24-70mm f/2.8G ED\" (taken with \
                 Nikon D800): ptlens interpolated to 40 mm from its 24-70 mm entries by \
                 lensfun's rule; no vignetting in the database"
            ),
            distortion_ptlens: Some(lensfun_interpolate(&NIKKOR_24_70_PTLENS, 40.0)),
            ..LensProfile::default()
        }),
        SEED_CLASS_LENS => Some(LensProfile {
            name: "Nikon AF Nikkor 35-70mm f/2.8 at 40 mm, f/8".into(),
            source: format!(
                "{LENSFUN_NIKON}, lens \"Nikon AF Nikkor 35-70mm f/2.8\" (taken with Nikon D3): \
                 distortion ptlens focal=\"40\", vignetting pa focal=\"40\" aperture=\"8\""
            ),
            vignetting_pa: Some([-0.3735, 0.1832, -0.0571]),
            distortion_ptlens: Some([0.00645, -0.02212, 0.01511]),
            ..LensProfile::default()
        }),
        _ => None,
    }
}

/// lensfun's interpolation of distortion terms between focal lengths
/// (`lfLens::InterpolateDistortion`, `_lf_interpolate`): an entry at `focal`
/// is taken as is; otherwise the nearest entries below and above (y₂, y₃)
/// and the next ones out (y₁, y₄, when present) give a cubic Hermite spline
/// in `t = (focal − f₂)/(f₃ − f₂)` of each term times its focal length
/// (tangents `(y₃ − y₁)/2`, `(y₄ − y₂)/2`, or `y₃ − y₂` at an end), divided by
/// `focal`; outside the entries the nearest one.
pub fn lensfun_interpolate(entries: &[(f64, [f64; 3])], focal: f64) -> [f64; 3] {
    if let Some((_, t)) = entries.iter().find(|(f, _)| *f == focal) {
        return *t;
    }
    // lensfun's order: spline[1] is the nearest entry above the focal length
    // (df = focal − f < 0), spline[2] the nearest below.
    let mut above: Vec<&(f64, [f64; 3])> = entries.iter().filter(|(f, _)| *f > focal).collect();
    let mut below: Vec<&(f64, [f64; 3])> = entries.iter().filter(|(f, _)| *f < focal).collect();
    above.sort_by(|a, b| a.0.total_cmp(&b.0));
    below.sort_by(|a, b| b.0.total_cmp(&a.0));
    match (above.first(), below.first()) {
        (Some(&&(f2, t2)), Some(&&(f3, t3))) => {
            let t = (focal - f2) / (f3 - f2);
            let (y1, y4) = (above.get(1), below.get(1));
            std::array::from_fn(|i| {
                let y2 = t2[i] * f2;
                let y3 = t3[i] * f3;
                let tg2 = y1.map_or(y3 - y2, |e| (y3 - e.1[i] * e.0) * 0.5);
                let tg3 = y4.map_or(y3 - y2, |e| (e.1[i] * e.0 - y2) * 0.5);
                let (t2, t3) = (t * t, t * t * t);
                ((2.0 * t3 - 3.0 * t2 + 1.0) * y2
                    + (t3 - 2.0 * t2 + t) * tg2
                    + (-2.0 * t3 + 3.0 * t2) * y3
                    + (t3 - t2) * tg3)
                    / focal
            })
        }
        (Some(e), None) | (None, Some(e)) => e.1,
        (None, None) => [0.0; 3],
    }
}

/// A Brown camera fitted to a ptlens distortion: image height
/// `s·ρ·(1 + k₁r² + k₂r⁴ + k₃r⁶)` for the ideal image height ρ (px) at the
/// normalised radius r, with the fit's largest radial residual (px).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrownFit {
    /// Scale `s` of the focal length: the lens's focal length over the field
    /// relative to the paraxial one the ptlens model is normalised to.
    pub scale: f64,
    /// `[k₁, k₂, k₃]` (normalised coordinates of the scaled focal length's camera).
    pub k: [f64; 3],
    /// Largest |ptlens − Brown| radial displacement over the fit's points (px).
    pub max_residual_px: f64,
}

impl LensProfile {
    /// Radius (mm on the sensor) at which the vignetting model's r = 1.
    pub fn vignetting_radius_mm(&self) -> f64 {
        FULL_FRAME_DIAGONAL_MM / 2.0 / self.crop_factor
    }

    /// Radius (mm on the sensor) at which the distortion model's r = 1.
    pub fn distortion_radius_mm(&self) -> f64 {
        self.vignetting_radius_mm() / self.aspect_ratio.hypot(1.0)
    }

    /// Check the profile's values; errors name `key`.
    pub(crate) fn validate(&self, key: &str) -> Result<()> {
        let at = |what: &str| format!("{key}.{what}");
        positive(&at("crop_factor"), self.crop_factor)?;
        if !(self.aspect_ratio.is_finite() && self.aspect_ratio >= 1.0) {
            return Err(bad(
                &at("aspect_ratio"),
                format!("{} must be a number ≥ 1", self.aspect_ratio),
            ));
        }
        if let Some(t) = self.vignetting_pa {
            finite(&at("vignetting_pa"), &t)?;
        }
        if let Some(t) = self.distortion_ptlens {
            finite(&at("distortion_ptlens"), &t)?;
            let d = 1.0 - t.iter().sum::<f64>();
            if d <= 0.0 {
                return Err(bad(
                    &at("distortion_ptlens"),
                    format!("1 − a − b − c = {d} must be positive (the scale at the centre)"),
                ));
            }
        }
        if self.vignetting_pa.is_none() && self.distortion_ptlens.is_none() {
            return Err(bad(
                &at("vignetting_pa/distortion_ptlens"),
                "a profile needs at least one of them",
            ));
        }
        Ok(())
    }

    /// The smallest RI of the vignetting model out to `r_max` (r = 1 at the
    /// calibration corner), or `None` without vignetting; sampled finely
    /// enough for a cubic in r².
    pub(crate) fn min_relative_illumination(&self, r_max: f64) -> Option<f64> {
        let [k1, k2, k3] = self.vignetting_pa?;
        let steps = 1000;
        Some(
            (0..=steps)
                .map(|i| {
                    let r2 = (r_max * f64::from(i) / f64::from(steps)).powi(2);
                    1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
                })
                .fold(f64::INFINITY, f64::min),
        )
    }

    /// The measured relative illumination in a camera's pixels: pixel pitch
    /// `pixel_mm`, centre the principal point `(cx, cy)` plus
    /// `centre_offset_um` (µm on the sensor, x right, y down). `None` without vignetting.
    pub fn vignetting_in_pixels(
        &self,
        k: &Intrinsics,
        pixel_mm: f64,
        centre_offset_um: [f64; 2],
    ) -> Option<VignettingProfile> {
        Some(VignettingProfile {
            centre_px: [
                k.cx + centre_offset_um[0] / 1000.0 / pixel_mm,
                k.cy + centre_offset_um[1] / 1000.0 / pixel_mm,
            ],
            radius_px: self.vignetting_radius_mm() / pixel_mm,
            k: self.vignetting_pa?,
        })
    }

    /// The Brown camera of the profile's ptlens distortion in a camera of
    /// intrinsics `k` (focal length in px, principal point), `width × height`
    /// px of pitch `pixel_mm`: linear least squares of the image height (px)
    /// over a grid of ideal image points spanning the image, each point an
    /// equal share of the image's area, in a focal-length scale and
    /// `k₁, k₂, k₃` (module docs). `None` without distortion.
    pub fn brown_in_pixels(
        &self,
        k: &Intrinsics,
        width: u32,
        height: u32,
        pixel_mm: f64,
    ) -> Option<Result<BrownFit>> {
        let [a, b, c] = self.distortion_ptlens?;
        let d = 1.0 - a - b - c;
        let unit_mm = d * self.distortion_radius_mm();
        // Ideal image height ρ (px), normalised radius r, and the ptlens
        // image height minus ρ (px), at each grid point.
        let points: Vec<(f64, f64, f64)> = (0..FIT_SAMPLES_PER_SIDE)
            .flat_map(|i| (0..FIT_SAMPLES_PER_SIDE).map(move |j| (i, j)))
            .map(|(i, j)| {
                // From the image's outer edge to the opposite one, corners included.
                let at = |n: u32, size: u32| {
                    f64::from(n) / f64::from(FIT_SAMPLES_PER_SIDE - 1) * f64::from(size) - 0.5
                };
                let r = ((at(i, width) - k.cx) / k.fx).hypot((at(j, height) - k.cy) / k.fy);
                let rho = r * k.fx;
                let ru = rho * pixel_mm / unit_mm;
                let factor = (ru * (ru * (a * ru + b) + c) + d) / d;
                (rho, r, rho * (factor - 1.0))
            })
            .collect();
        // Basis ρ·(1, t², t⁴, t⁶), t = r/r_max (conditioning); y ≈ basis·e.
        let r_max = points.iter().map(|p| p.1).fold(f64::MIN_POSITIVE, f64::max);
        let basis = |rho: f64, r: f64| {
            let t2 = (r / r_max).powi(2);
            Vector4::new(rho, rho * t2, rho * t2 * t2, rho * t2 * t2 * t2)
        };
        let (mut normal, mut rhs) = (Matrix4::zeros(), Vector4::zeros());
        for &(rho, r, y) in &points {
            let x = basis(rho, r);
            normal += x * x.transpose();
            rhs += x * y;
        }
        let Some(e) = normal.lu().solve(&rhs) else {
            return Some(Err(SynthError::config(format!(
                "optics: the distortion of lens profile \"{}\" cannot be fitted (singular)",
                self.name
            ))));
        };
        let scale = 1.0 + e[0];
        let k = [1, 2, 3].map(|i| e[i] / scale / r_max.powi(2 * i as i32));
        let max_residual_px = points
            .iter()
            .map(|&(rho, r, y)| (y - basis(rho, r).dot(&e)).abs())
            .fold(0.0, f64::max);
        Some(Ok(BrownFit {
            scale,
            k,
            max_residual_px,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// lensfun's rule at a knot returns the entry, between knots the Hermite
    /// spline of term × focal (values computed by hand from the rule).
    #[test]
    fn interpolation_follows_lensfun() {
        assert_eq!(
            lensfun_interpolate(&NIKKOR_24_70_PTLENS, 35.0),
            NIKKOR_24_70_PTLENS[2].1
        );
        // Outside the entries: the nearest.
        assert_eq!(
            lensfun_interpolate(&NIKKOR_24_70_PTLENS, 20.0),
            NIKKOR_24_70_PTLENS[0].1
        );
        assert_eq!(
            lensfun_interpolate(&NIKKOR_24_70_PTLENS, 80.0),
            NIKKOR_24_70_PTLENS[4].1
        );
        // 40 mm: t = (40 − 50)/(35 − 50) = 2/3 between 50 (y₂) and 35 (y₃),
        // with 70 and 28 as the outer points; a: y = 0.59010, 0.42150,
        // 0.36610, 0.20104 (× focal), tangents (0.36610 − 0.59010)/2 and
        // (0.20104 − 0.42150)/2 → 0.386164 / 40.
        let [a, b, c] = lensfun_interpolate(&NIKKOR_24_70_PTLENS, 40.0);
        assert!((a - 0.009_654_092_6).abs() < 1e-10, "{a}");
        assert!((b + 0.030_337_120_4).abs() < 1e-10, "{b}");
        assert!((c - 0.043_396_009_3).abs() < 1e-10, "{c}");
    }

    /// lensfun's radii: 21.633 mm (half the 43.27 mm diagonal) and 12 mm
    /// (half the 24 mm short side) for a 3:2 full-frame calibration.
    #[test]
    fn normalisations_are_lensfuns() {
        let p = built_in(SEED_LENS).unwrap();
        assert!((p.vignetting_radius_mm() - 21.633_307_652_8).abs() < 1e-9);
        assert!((p.distortion_radius_mm() - 12.0).abs() < 1e-12);
        let crop = LensProfile {
            crop_factor: 1.5,
            aspect_ratio: 4.0 / 3.0,
            ..p
        };
        // Half the short side of a 4:3 sensor of diagonal 43.27/1.5 mm.
        assert!((crop.distortion_radius_mm() - 43.266_615_3 / 1.5 / 2.0 * 0.6).abs() < 1e-6);
    }

    /// A ptlens model with only b is Brown with only k₁ exactly:
    /// `D = 1 + (b/d³)·(f·r/R_d)²`, so the fit recovers scale 1 and
    /// `k₁ = b·(f/R_d)²/d³` with a residual at rounding level.
    #[test]
    fn brown_fit_is_exact_where_brown_can_be() {
        let b = -0.03;
        let p = LensProfile {
            distortion_ptlens: Some([0.0, b, 0.0]),
            ..LensProfile::default()
        };
        let pixel_mm = 0.0055;
        let k = Intrinsics::centred(7966.0, 4096, 3072);
        let fit = p
            .brown_in_pixels(&k, 4096, 3072, pixel_mm)
            .unwrap()
            .unwrap();
        assert!((fit.scale - 1.0).abs() < 1e-12, "{}", fit.scale);
        let d = 1.0 - b;
        let f_mm = 7966.0 * pixel_mm;
        let want = b * (f_mm / 12.0).powi(2) / d.powi(3);
        assert!(
            (fit.k[0] / want - 1.0).abs() < 1e-9,
            "{:?} vs {want}",
            fit.k
        );
        assert!(
            fit.k[1].abs() < 1e-6 && fit.k[2].abs() < 1e-4,
            "{:?}",
            fit.k
        );
        assert!(fit.max_residual_px < 1e-8, "{}", fit.max_residual_px);
    }

    #[test]
    fn built_in_profiles_are_valid() {
        for name in BUILT_IN_PROFILES {
            built_in(name).unwrap().validate("optics.lens").unwrap();
        }
        assert!(built_in("no-such-lens").is_none());
    }
}
