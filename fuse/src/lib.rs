//! From blobs to sphere centres: matching blobs to spheres by diameter,
//! centroids in undistorted coordinates, the perspective bias of a sphere's
//! image removed, fusion of the cameras (rigorous triangulation or the seed's
//! pixel-scale fusion), the table's pose, and the resumable `measure` batch.
//!
//! # Conventions
//! - World frame = machine frame (mm, Z up); cameras from `rig.json`
//!   (`x_cam = R·x_world + t`). Pixel centre of the top-left pixel = (0, 0).
//! - "Ideal pixels" are undistorted: the pinhole image `P·X` of the rig.
//! - Cameras used for a motion axis: by default those not looking along it
//!   (|cos| ≤ 0.7 between optical axis and motion), i.e. 2 + 3 for X, 1 + 3
//!   for Y, 1 + 2 for Z; all three on request.

mod error;

pub mod matching;
pub mod measure;
pub mod observe;
pub mod plan;
pub mod plausibility;
pub mod pose;
pub mod triangulate;

pub use error::{FuseError, Result};
pub use measure::{Fusion, Inputs, MeasureOptions, Summary, measure};
pub use plan::RigModel;
pub use plausibility::ResidualGate;
