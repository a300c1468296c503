//! Ground truth written by the renderer (`truth.json`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::campaign::{Axis, Direction, SphereRow};
use crate::rig::CameraJson;

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

/// `truth.json`: true cameras, spheres and positions, plus whatever the
/// renderer adds (injected error functions, reference figures).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// The true camera models.
    pub cameras: Vec<CameraJson>,
    /// The spheres.
    pub spheres: Vec<SphereRow>,
    /// Every instant of the campaign.
    pub instants: Vec<TruthInstant>,
    /// Further keys (error functions, figures), kept as JSON.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}
