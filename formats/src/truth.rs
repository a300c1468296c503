//! Ground truth written by the renderer (`truth.json`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::campaign::{Axis, Direction, InstantKey, SphereRow};
use crate::figures::ReportFigures;
use crate::rig::CameraJson;

/// A true camera in `truth.json`: K, R, t, distortion, size (as in
/// `rig.json`) and the projection `P = K·[R|t]` of the undistorted pinhole,
/// scaled so that its third row's first three entries have unit norm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthCamera {
    /// K, R, t, distortion, size.
    #[serde(flatten)]
    pub model: CameraJson,
    /// 3×4 projection matrix.
    #[serde(rename = "P")]
    pub p: [[f64; 4]; 3],
    /// Anything else the renderer records (serial, nominal pose, optics).
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

impl TruthCamera {
    /// Describe a true camera.
    pub fn new(id: u8, camera: &geom::Camera) -> Self {
        let p = camera.projection_matrix();
        Self {
            model: CameraJson::from_camera(id, camera),
            p: [0, 1, 2].map(|i| [p[(i, 0)], p[(i, 1)], p[(i, 2)], p[(i, 3)]]),
            extra: serde_json::Map::new(),
        }
    }
}

/// The exact sphere centres at one instant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthInstant {
    /// Axis moved.
    pub axis: Axis,
    /// Approach direction.
    pub direction: Direction,
    /// Run number.
    pub run: u32,
    /// Target index.
    pub target: u32,
    /// Capture number.
    pub capture: u32,
    /// Commanded position (mm).
    pub nominal: [f64; 3],
    /// Sphere name → exact centre, world frame (mm).
    pub spheres: BTreeMap<String, [f64; 3]>,
    /// Anything else the renderer records (time, pose errors).
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

impl TruthInstant {
    /// The key of the instant, as the manifest's rows of it give it.
    pub fn instant(&self) -> InstantKey {
        InstantKey::new(
            (self.axis, self.direction),
            [self.run, self.target, self.capture],
            self.nominal,
        )
    }
}

/// `truth.json`: true cameras, spheres and positions, plus whatever the
/// renderer adds (injected error functions, reference figures).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// The true camera models.
    pub cameras: Vec<TruthCamera>,
    /// The spheres.
    pub spheres: Vec<SphereRow>,
    /// Every instant of the campaign.
    pub instants: Vec<TruthInstant>,
    /// Further keys (error functions, figures), kept as JSON.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

impl Truth {
    /// The reference figures (the evaluation on the exact positions, key
    /// `figures`), when the renderer could compute them.
    pub fn figures(&self) -> Option<serde_json::Result<ReportFigures>> {
        self.extra.get("figures").map(ReportFigures::deserialize)
    }
}
