//! The `[optics]` table.

use serde::{Deserialize, Serialize};

use super::SensorConfig;
use super::check::{bad, finite, non_negative, positive};
use super::is_default;
use crate::Result;
use crate::lens_profile::{BUILT_IN_PROFILES, LensProfile, built_in};

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
    /// A built-in measured lens profile (`crate::lens_profile::built_in`):
    /// its distortion, fitted by a focal-length scale and Brown `k1, k2, k3`,
    /// replaces each camera's radial terms (the camera's `p1, p2` stay); its
    /// vignetting is RI with `illumination = "profile"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lens: Option<String>,
    /// Centre of the profile's relative illumination relative to the
    /// principal point (µm on the sensor, x right, y down; `profile` only).
    #[serde(skip_serializing_if = "is_default")]
    pub profile_centre_offset_um: [f64; 2],
    /// A measured lens profile given inline (`[optics.profile]`), instead of `lens`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub profile: Option<LensProfile>,
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
    /// A real lens as measured: RI is the lens profile's vignetting
    /// (lensfun's "pa" model about a possibly decentred centre), which holds
    /// the natural fall-off and the distortion's area effect already.
    Profile,
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
            lens: None,
            profile_centre_offset_um: [0.0, 0.0],
            profile: None,
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
        self.validate_profile(sensor)?;
        if self.illumination != IlluminationModel::Lens && self.vignetting != [0.0, 0.0] {
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

    /// The lens profile: built-in (`lens`) or inline (`[optics.profile]`).
    pub fn lens_profile(&self) -> Result<Option<LensProfile>> {
        match (&self.lens, &self.profile) {
            (Some(_), Some(_)) => Err(bad(
                "optics.lens",
                "name a built-in profile or give [optics.profile], not both",
            )),
            (Some(name), None) => built_in(name).map(Some).ok_or_else(|| {
                bad(
                    "optics.lens",
                    format!(
                        "\"{name}\" is not a built-in profile (known: {})",
                        BUILT_IN_PROFILES.join(", ")
                    ),
                )
            }),
            (None, p) => Ok(p.clone()),
        }
    }

    /// Check the lens profile against the illumination model; a measured RI
    /// must stay positive out to the field's corner from its centre.
    fn validate_profile(&self, sensor: &SensorConfig) -> Result<()> {
        let profile = self.lens_profile()?;
        let key = if self.lens.is_some() {
            "optics.lens"
        } else {
            "optics.profile"
        };
        if let Some(p) = &profile {
            p.validate(key)?;
        }
        finite(
            "optics.profile_centre_offset_um",
            &self.profile_centre_offset_um,
        )?;
        let is_profile = self.illumination == IlluminationModel::Profile;
        if !is_profile && self.profile_centre_offset_um != [0.0, 0.0] {
            return Err(bad(
                "optics.profile_centre_offset_um",
                "applies to illumination = \"profile\" only",
            ));
        }
        if !is_profile {
            return Ok(());
        }
        let Some(p) = profile else {
            return Err(bad(
                "optics.illumination",
                "\"profile\" needs a lens profile: optics.lens or [optics.profile]",
            ));
        };
        // Farthest image point from the (decentred) centre, in mm.
        let half_diagonal =
            0.5 * sensor.pixel_mm * f64::from(sensor.width).hypot(f64::from(sensor.height));
        let [ox, oy] = self.profile_centre_offset_um;
        let reach_mm = half_diagonal + ox.hypot(oy) / 1000.0;
        match p.min_relative_illumination(reach_mm / p.vignetting_radius_mm()) {
            None => Err(bad(
                key,
                format!(
                    "\"{}\" has no measured vignetting (vignetting_pa): use illumination = \
                     \"lens\" with it (its distortion, the physical cos⁴θ·J fall-off)",
                    p.name
                ),
            )),
            Some(min) if min.is_nan() || min <= 0.0 => Err(bad(
                key,
                format!(
                    "the vignetting_pa relative illumination reaches {min} in the field: it \
                     must stay positive"
                ),
            )),
            Some(_) => Ok(()),
        }
    }
}
