//! Camera calibration from a 3-D target (docs/methods.md, Calibration).
//!
//! The main entry point is [`calibrate`]: one camera from its marker
//! correspondences (Hartley-normalised DLT with the non-coplanarity check,
//! then Levenberg–Marquardt on reprojection error — pinhole, k1 k2,
//! k1 k2 p1 p2, optional k3 and skew — with k·σ outlier rejection). Around it:
//! - [`correspond`]: automatic marker ↔ detection assignment from a nominal camera;
//! - [`calibrate_detections`]: one camera from the detections in its
//!   calibration image (assignment, calibration, re-centroiding with the
//!   camera's model through a callback, refit);
//! - [`parameter_covariance`]: the covariance of a camera's parameters from
//!   the image noise and the target's marker uncertainty ([`TargetUncertainty`]);
//! - [`commission`]: the rig commissioning report (axis angles, pixel sizes,
//!   depth of field over each axis's travel);
//! - [`fit_flat_field`]: the lens's relative illumination from a flat-field and a dark frame;
//! - [`opencv_yaml`]: export in OpenCV's `FileStorage` YAML format.
//!
//! # Example
//! A camera 500 mm above a target of 5×5 markers at three heights, seen
//! exactly: the calibration gives the camera back.
//! ```
//! use calib::{Model, Observation, Options, calibrate};
//! use geom::{Camera, Intrinsics, Point3, Vector3};
//!
//! let k = Intrinsics::centred(1500.0, 1280, 960);
//! let camera =
//!     Camera::look_at(Point3::new(40.0, -30.0, 500.0), Point3::origin(), Vector3::y(), k, 1280, 960)
//!         .unwrap();
//! let mut observations = Vec::new();
//! for i in 0..5 {
//!     for j in 0..5 {
//!         let world = Point3::new(
//!             40.0 * f64::from(i) - 80.0,
//!             40.0 * f64::from(j) - 80.0,
//!             25.0 * f64::from((i + 2 * j) % 3),
//!         );
//!         observations.push(Observation {
//!             id: (5 * i + j) as u32,
//!             world,
//!             pixel: camera.project(&world).unwrap(),
//!             sphere_diameter: None,
//!         });
//!     }
//! }
//! let options = Options { model: Model::Pinhole, ..Options::default() };
//! let calibration = calibrate(&observations, 1280, 960, &options).unwrap();
//! assert!((calibration.camera.intrinsics.fx - 1500.0).abs() < 1e-6);
//! assert!((calibration.camera.centre() - camera.centre()).norm() < 1e-6);
//! ```
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

mod board;
mod bundle;
mod calibration;
mod commission;
mod correspond;
mod covariance;
mod dlt;
mod error;
mod halves;
mod illumination;
mod image;
mod model_choice;
mod opencv;
mod outliers;
mod planar;
mod refine;

pub use board::{Board, find_board};
pub use bundle::{
    LeftOut, Rig, RigCamera, View, ViewResidual, VolumePoint, calibrate_views,
    calibrate_views_choosing, volume_uncertainty,
};
pub use calibration::{
    Calibration, DEFAULT_MAX_ROUNDS, DEFAULT_OUTLIER_K, Observation, Options, Parameter,
    PointResidual, calibrate, check_target, observations,
};
pub use commission::{
    CameraInput, CommissionOptions, DEFAULT_COC_PX, DEFAULT_F_NUMBER, Optics, commission,
    depth_of_field,
};
pub use correspond::{
    CorrespondOptions, Correspondence, GATE_SIGMAS, MIN_GATE_PX, Marker, Match, correspond, markers,
};
pub use covariance::{
    DEFAULT_TARGET_UNCERTAINTY_UM, ParameterCovariance, TargetUncertainty, parameter_covariance,
};
pub use dlt::{MIN_POINTS, residuals as dlt_residuals};
pub use error::{Ambiguity, BoardProblem, CalibError, FlatFieldProblem, OptionProblem, Result};
pub use formats::commissioning::{
    AxisPair, CameraReport, DepthOfField, FLAT_FIELD_ADVICE, FlatFieldFit, IlluminationReport,
    ParameterSd, ParameterUncertainty, ProfilePoint, Report, ScaleCost, TravelCamera, TravelReport,
};
pub use halves::{HalvesCheck, two_halves};
pub use illumination::{Pixels, fit_flat_field};
pub use image::{ImageCalibration, RECENTROID_ROUNDS, calibrate_detections, seeing_moved_target};
pub use model_choice::{Candidate, F_LEVEL, FOLDS, ModelChoice, calibrate_choosing, choose_model};
pub use opencv::opencv_yaml;
pub use planar::{
    MAX_ZHANG_CONDITION, MIN_HOMOGRAPHY_POINTS, homography, intrinsics as planar_intrinsics,
    pose as planar_pose,
};
pub use refine::{Layout, Model};
