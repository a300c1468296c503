//! Camera calibration from a 3-D target (docs/methods.md, Calibration).
//!
//! - [`dlt`]: Hartley-normalised DLT and the non-coplanarity check.
//! - [`refine`]: Levenberg–Marquardt on reprojection error (pinhole, k1 k2,
//!   k1 k2 p1 p2, optional k3 and skew), analytic Jacobian, sphere markers.
//! - [`outliers`]: robust σ and k·σ rejection.
//! - [`calibration`]: [`calibrate`], the whole chain for one camera.
//! - [`commission`](mod@commission): the rig commissioning report (axis angles, pixel sizes,
//!   depth of field over each axis's travel).
//! - [`correspond`](mod@correspond): automatic marker ↔ detection assignment from a nominal camera.
//! - [`image`]: one camera from the detections in its calibration image
//!   (assignment, calibration, re-centroiding with the camera's model, refit).
//! - [`illumination`]: the lens's relative illumination from a flat-field and a dark frame.
//! - [`opencv`]: export in OpenCV's `FileStorage` YAML format.
//!
//! # Conventions
//! - Lengths in millimetres, angles in radians, all geometry in `f64`.
//! - Target frame = world frame; poses map target → camera, `x_c = R·X + t`.
//! - Pixels: the centre of the top-left pixel is (0, 0), u right, v down.
//! - Distortion: Brown's model on normalised coordinates with OpenCV's names
//!   and signs ([`geom::Distortion`]).
//! - Reprojection RMS is the RMS length of the 2-D residual vectors,
//!   `√(Σ(du² + dv²)/N)` px.

#![deny(missing_docs)]

mod error;

pub mod calibration;
pub mod commission;
pub mod correspond;
pub mod dlt;
pub mod illumination;
pub mod image;
pub mod opencv;
pub mod outliers;
pub mod refine;

pub use calibration::{
    Calibration, Observation, Options, Parameter, PointResidual, calibrate, check_target,
    observations,
};
pub use commission::{CameraInput, CommissionOptions, Report, commission};
pub use correspond::{CorrespondOptions, Correspondence, Marker, Match, correspond, markers};
pub use error::{CalibError, Result};
pub use illumination::{FlatFieldFit, Pixels, fit_flat_field};
pub use image::{ImageCalibration, RECENTROID_ROUNDS, calibrate_detections};
pub use opencv::opencv_yaml;
pub use refine::{Layout, Model};
