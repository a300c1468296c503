//! Geometry core of trinocular: camera model, rigid and small-angle error
//! transforms, least-squares and minimum-zone fits, Levenberg–Marquardt,
//! interpolation and the statistics the standards use.
//!
//! `geom` does no I/O and cannot fail except on degenerate input, which is
//! reported as a typed [`GeomError`].
//!
//! # Conventions
//! - Lengths in millimetres, angles in radians, all geometry in `f64`.
//! - World frame = machine frame: right-handed, Z up.
//! - Camera frame: x right, y down, z forward (along the optical axis).
//!   Poses map world → camera: `x_cam = R·x_world + t`.
//! - Pixel coordinates: the centre of the top-left pixel is (0, 0), u to the
//!   right, v down (OpenCV convention). A blob covering pixels 0..=9 in u has
//!   its centre at u = 4.5.
//! - Lens distortion is Brown's model on normalised coordinates, with OpenCV's
//!   coefficient names and signs (k1, k2, k3 radial; p1, p2 tangential).

mod error;

pub mod camera;
pub mod distortion;
pub mod fit;
pub mod illumination;
pub mod interp;
pub mod lm;
pub mod min_zone;
pub mod sphere_image;
pub mod stats;
pub mod transform;

pub use camera::{Camera, Intrinsics};
pub use distortion::Distortion;
pub use error::{GeomError, Result};
pub use illumination::{Illumination, RadialIllumination};

/// nalgebra types used throughout the workspace, re-exported so every crate
/// uses the same version.
pub use nalgebra;
pub use nalgebra::{Isometry3, Matrix3, Matrix3x4, Point2, Point3, Rotation3, Vector2, Vector3};
