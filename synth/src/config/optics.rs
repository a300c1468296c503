//! The `[optics]` table.

use serde::{Deserialize, Serialize};

use super::SensorConfig;
use super::check::{bad, finite, non_negative, positive};
use crate::Result;

/// The lens.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OpticsConfig {
    /// Lens focal length (mm). Focused at `focus_distance_mm`, a thin lens has
    /// the principal distance `f·s/(s − f)`, which is the pinhole's focal length.
    pub focal_mm: f64,
    /// Aperture f-number N (defocus blur diameter ∝ 1/N).
    pub f_number: f64,
    /// Distance (mm, along the optical axis) of the plane in focus.
    pub focus_distance_mm: f64,
    /// Standard deviation of the Gaussian point-spread function in focus (µm on the sensor).
    pub psf_sigma_um: f64,
    /// What a pixel's value is proportional to: the image irradiance of a real
    /// lens, or the radiance a pinhole ray tracer writes.
    pub illumination: IlluminationModel,
    /// The lens's own vignetting beyond cos⁴θ, `V = 1 + v₁·tan²θ + v₂·tan⁴θ`
    /// (`[v₁, v₂]`; `lens` only).
    pub vignetting: [f64; 2],
}

/// The lens's relative illumination in the rendered images.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum IlluminationModel {
    /// A real lens: each pixel's value is radiance × cos⁴θ·V/J (natural
    /// vignetting, the lens's own vignetting V, energy conserved under the
    /// distortion, J the distorted/undistorted area ratio).
    #[default]
    Lens,
    /// Radiance per pixel (RI = 1), as a pinhole ray tracer writes it.
    Radiance,
}

impl Default for OpticsConfig {
    fn default() -> Self {
        Self {
            focal_mm: 40.0,
            f_number: 8.0,
            focus_distance_mm: 460.0,
            psf_sigma_um: 3.0,
            illumination: IlluminationModel::Lens,
            vignetting: [0.0, 0.0],
        }
    }
}

impl OpticsConfig {
    /// Check the lens's values; `sensor` bounds the field the vignetting must
    /// stay positive over. The error names the key.
    pub(crate) fn validate(&self, sensor: &SensorConfig) -> Result<()> {
        positive("optics.focal_mm", self.focal_mm)?;
        positive("optics.f_number", self.f_number)?;
        positive("optics.focus_distance_mm", self.focus_distance_mm)?;
        if self.focus_distance_mm <= self.focal_mm {
            return Err(bad(
                "optics.focus_distance_mm",
                "must exceed the focal length",
            ));
        }
        non_negative("optics.psf_sigma_um", self.psf_sigma_um)?;
        finite("optics.vignetting", &self.vignetting)?;
        if self.illumination == IlluminationModel::Radiance && self.vignetting != [0.0, 0.0] {
            return Err(bad(
                "optics.vignetting",
                "applies to illumination = \"lens\" only",
            ));
        }
        // V must stay positive out to the field's corner (tan θ ≤ half-diagonal / f).
        let half_diagonal =
            0.5 * sensor.pixel_mm * f64::from(sensor.width).hypot(f64::from(sensor.height));
        let t2 = (half_diagonal
            / crate::rig::principal_distance_mm(self.focal_mm, self.focus_distance_mm))
        .powi(2);
        let [v1, v2] = self.vignetting;
        let v = |x: f64| 1.0 + v1 * x + v2 * x * x;
        let vertex = -v1 / (2.0 * v2);
        let mut v_min = v(0.0).min(v(t2));
        if v2 > 0.0 && (0.0..t2).contains(&vertex) {
            v_min = v_min.min(v(vertex));
        }
        if v_min.is_nan() || v_min <= 0.0 {
            return Err(bad(
                "optics.vignetting",
                format!(
                    "V = 1 + v1·tan²θ + v2·tan⁴θ reaches {v_min} in the field: it must stay positive"
                ),
            ));
        }
        Ok(())
    }
}
