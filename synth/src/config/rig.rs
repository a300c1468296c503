//! The `[rig]` table: camera placement, each `[[rig.cameras]]` with its
//! mounting errors, distortion and stray light.

use serde::{Deserialize, Serialize};

use super::check::{bad, finite, non_negative, positive};
use crate::Result;

/// Placement of the cameras.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RigConfig {
    /// World point every nominal camera aims at (mm).
    pub working_point: [f64; 3],
    /// Distance from each nominal camera's projection centre to the working point (mm).
    pub working_distance_mm: f64,
    /// The cameras (ids 1, 2, 3; a subset is allowed).
    pub cameras: Vec<CameraConfig>,
}

/// One camera: its nominal viewing direction and its true deviations from it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraConfig {
    /// Camera number 1, 2 or 3.
    pub id: u8,
    /// Nominal optical-axis direction (world).
    pub view: [f64; 3],
    /// World direction that appears upward in the image.
    pub up: [f64; 3],
    /// Serial number written to the EXIF BodySerialNumber tag.
    pub serial: String,
    /// True rotation relative to nominal, about the camera's x, y, z axes (degrees).
    pub rotation_error_deg: [f64; 3],
    /// True projection centre minus nominal (world, mm).
    pub position_error_mm: [f64; 3],
    /// True principal distance relative to nominal (percent).
    pub focal_error_percent: f64,
    /// True principal point minus the image centre (µm on the sensor, u then v).
    pub principal_point_offset_um: [f64; 2],
    /// True lens distortion (Brown, normalised coordinates, OpenCV signs).
    pub distortion: DistortionConfig,
    /// Stray-light blobs in this camera's images.
    pub stray_light: Vec<StrayLightConfig>,
}

/// Brown distortion coefficients (OpenCV names and signs).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DistortionConfig {
    /// Radial r².
    pub k1: f64,
    /// Radial r⁴.
    pub k2: f64,
    /// Radial r⁶.
    pub k3: f64,
    /// Tangential p1.
    pub p1: f64,
    /// Tangential p2.
    pub p2: f64,
}

impl From<DistortionConfig> for geom::Distortion {
    fn from(d: DistortionConfig) -> Self {
        geom::Distortion {
            k1: d.k1,
            k2: d.k2,
            k3: d.k3,
            p1: d.p1,
            p2: d.p2,
        }
    }
}

/// A Gaussian blob of stray light added to the background.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StrayLightConfig {
    /// Centre, as a fraction of the image width (0 = left edge, 1 = right edge).
    pub u: f64,
    /// Centre, as a fraction of the image height (0 = top, 1 = bottom).
    pub v: f64,
    /// Standard deviation, as a fraction of the image width.
    pub sigma: f64,
    /// Peak (electrons per pixel per exposure).
    pub peak_e: f64,
}

impl Default for StrayLightConfig {
    fn default() -> Self {
        Self {
            u: 0.5,
            v: 0.5,
            sigma: 0.05,
            peak_e: 0.0,
        }
    }
}

impl Default for RigConfig {
    fn default() -> Self {
        Self {
            working_point: [0.0, 0.0, 30.0],
            working_distance_mm: 460.0,
            cameras: vec![
                CameraConfig {
                    id: 1,
                    view: [1.0, 0.0, 0.0],
                    up: [0.0, 0.0, 1.0],
                    serial: "TRN-SYN-0001".into(),
                    rotation_error_deg: [0.35, -0.5, 0.25],
                    position_error_mm: [1.2, -1.5, 0.8],
                    focal_error_percent: 0.4,
                    principal_point_offset_um: [27.5, -16.5],
                    distortion: DistortionConfig {
                        k1: -0.045,
                        k2: 0.03,
                        k3: 0.0,
                        p1: 1.5e-4,
                        p2: -1.0e-4,
                    },
                    stray_light: Vec::new(),
                },
                CameraConfig {
                    id: 2,
                    view: [0.0, 1.0, 0.0],
                    up: [0.0, 0.0, 1.0],
                    serial: "TRN-SYN-0002".into(),
                    rotation_error_deg: [-0.3, 0.4, -0.45],
                    position_error_mm: [-1.0, 1.4, -0.6],
                    focal_error_percent: -0.3,
                    principal_point_offset_um: [-22.0, 33.0],
                    distortion: DistortionConfig {
                        k1: 0.035,
                        k2: -0.02,
                        k3: 0.0,
                        p1: -1.2e-4,
                        p2: 0.8e-4,
                    },
                    stray_light: Vec::new(),
                },
                CameraConfig {
                    id: 3,
                    view: [0.0, 0.0, -1.0],
                    up: [0.0, 1.0, 0.0],
                    serial: "TRN-SYN-0003".into(),
                    rotation_error_deg: [0.25, 0.3, 0.6],
                    position_error_mm: [0.9, 0.7, -1.8],
                    focal_error_percent: 0.25,
                    principal_point_offset_um: [11.0, 22.0],
                    distortion: DistortionConfig {
                        k1: -0.03,
                        k2: 0.015,
                        k3: 0.0,
                        p1: 0.5e-4,
                        p2: 1.3e-4,
                    },
                    stray_light: Vec::new(),
                },
            ],
        }
    }
}

impl Default for CameraConfig {
    fn default() -> Self {
        Self {
            id: 1,
            view: [1.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            serial: "TRN-SYN-0000".into(),
            rotation_error_deg: [0.0; 3],
            position_error_mm: [0.0; 3],
            focal_error_percent: 0.0,
            principal_point_offset_um: [0.0; 2],
            distortion: DistortionConfig::default(),
            stray_light: Vec::new(),
        }
    }
}

impl RigConfig {
    /// Check the placement and every camera; the error names the key.
    pub(crate) fn validate(&self) -> Result<()> {
        finite("rig.working_point", &self.working_point)?;
        positive("rig.working_distance_mm", self.working_distance_mm)?;
        if self.cameras.is_empty() {
            return Err(bad("rig.cameras", "at least one camera is needed"));
        }
        let mut seen = [false; 4];
        for c in &self.cameras {
            let key = format!("rig.cameras[id = {}]", c.id);
            if !(1..=3).contains(&c.id) {
                return Err(bad(&key, "id must be 1, 2 or 3"));
            }
            if std::mem::replace(&mut seen[usize::from(c.id)], true) {
                return Err(bad(&key, "duplicate camera id"));
            }
            c.validate(&key)?;
        }
        Ok(())
    }
}

impl CameraConfig {
    /// Check one camera's values under `key` (`rig.cameras[id = …]`).
    fn validate(&self, key: &str) -> Result<()> {
        finite(&format!("{key}.view"), &self.view)?;
        finite(&format!("{key}.up"), &self.up)?;
        finite(
            &format!("{key}.rotation_error_deg"),
            &self.rotation_error_deg,
        )?;
        finite(&format!("{key}.position_error_mm"), &self.position_error_mm)?;
        finite(
            &format!("{key}.focal_error_percent"),
            &[self.focal_error_percent],
        )?;
        finite(
            &format!("{key}.principal_point_offset_um"),
            &self.principal_point_offset_um,
        )?;
        let d = self.distortion;
        finite(
            &format!("{key}.distortion"),
            &[d.k1, d.k2, d.k3, d.p1, d.p2],
        )?;
        if !self.serial.is_ascii() || self.serial.contains('\0') {
            return Err(bad(&format!("{key}.serial"), "must be ASCII without NUL"));
        }
        for (i, b) in self.stray_light.iter().enumerate() {
            b.validate(&format!("{key}.stray_light[{i}]"))?;
        }
        Ok(())
    }
}

impl StrayLightConfig {
    /// Check one stray-light blob under `key`.
    fn validate(&self, key: &str) -> Result<()> {
        finite(key, &[self.u, self.v])?;
        positive(&format!("{key}.sigma"), self.sigma)?;
        non_negative(&format!("{key}.peak_e"), self.peak_e)
    }
}
