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
//!
//! # Example
//! The main entry point, [`measure`], runs a whole campaign from its files;
//! at its core, a sphere's centre from its images in two cameras
//! ([`triangulate`], with the perspective bias of a 20 mm sphere modelled):
//! ```
//! use fuse::{View, predict, triangulate};
//! use geom::{Camera, Intrinsics, Point2, Point3, Vector3};
//!
//! let k = Intrinsics::centred(7966.0, 4096, 3072);
//! let aim = Point3::new(0.0, 0.0, 30.0);
//! let cameras = [
//!     Camera::look_at(Point3::new(0.0, -460.0, 30.0), aim, Vector3::z(), k, 4096, 3072).unwrap(),
//!     Camera::look_at(Point3::new(0.0, 0.0, 490.0), aim, Vector3::y(), k, 4096, 3072).unwrap(),
//! ];
//! let sphere = Point3::new(60.0, -40.0, 45.0);
//! let views: Vec<View<'_>> = cameras
//!     .iter()
//!     .map(|camera| {
//!         let (centre, _) = predict(camera, &sphere, 10.0).unwrap();
//!         View { camera, ideal_px: Point2::from(centre) }
//!     })
//!     .collect();
//! let found = triangulate(&views, 10.0).unwrap();
//! assert!((found.point - sphere).norm() < 1e-9 && found.residual_px < 1e-9);
//! ```

mod error;
mod matching;
mod measure;
mod noise;
mod observe;
mod plan;
mod plausibility;
mod pose;
mod rig;
mod triangulate;

pub use error::{CampaignProblem, FuseError, Result};
pub use geom::triangulate::{Triangulated, View, predict, triangulate};
pub use measure::{Fusion, Inputs, MeasureOptions, SPHERE_LAYOUT_MM, Saturation, Summary, measure};
pub use noise::{CameraNoise, NoiseSource};
pub use observe::MIN_CIRCULARITY;
pub use plan::RigModel;
pub use plausibility::ResidualGate;
pub use rig::CalibratedRig;
pub use triangulate::seed_displacement;
