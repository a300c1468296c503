//! Geometry core of trinocular: camera model, rigid and small-angle error
//! transforms, least-squares and minimum-zone fits, Levenberg–Marquardt,
//! interpolation and the statistics the standards use.
//!
//! `geom` does no I/O and cannot fail except on degenerate input, which is
//! reported as a typed [`GeomError`]; [`GeomError::Degenerate`] names its
//! reason, a [`Degeneracy`], with the values that show it.
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
//!
//! # Example
//! A camera 460 mm from a 20 mm sphere 75 mm off its axis: the centre of the
//! sphere's image is pushed outward from the projected centre by the
//! perspective bias `Δ = r_c·R²/(Z² − R²)` (docs/methods.md).
//! ```
//! use geom::sphere_image::ellipse_centre_jacobian;
//! use geom::{Camera, Intrinsics, Point3, Vector3};
//!
//! let k = Intrinsics::centred(7966.0, 4096, 3072);
//! let camera =
//!     Camera::look_at(Point3::new(0.0, 0.0, 460.0), Point3::origin(), Vector3::y(), k, 4096, 3072)
//!         .unwrap();
//! let sphere = Point3::new(75.0, 0.0, 0.0);
//! let projected = camera.project_pinhole(&sphere).unwrap();
//! let (e, _) = ellipse_centre_jacobian(&camera.to_camera(&sphere).coords, 10.0).unwrap();
//! let image = camera.intrinsics.to_pixel(e);
//! let r_c = (projected.x - k.cx).hypot(projected.y - k.cy);
//! let bias = (image - projected).norm();
//! assert!((bias - r_c * 100.0 / (460.0f64.powi(2) - 100.0)).abs() < 1e-9);
//! ```

mod error;

pub mod camera;
pub mod distortion;
pub mod fit;
pub mod illumination;
pub mod interp;
pub mod lm;
pub mod min_zone;
pub mod montecarlo;
pub mod sphere_image;
pub mod stats;
pub mod transform;
pub mod triangulate;

pub use camera::{Camera, Intrinsics};
pub use distortion::Distortion;
pub use error::{Degeneracy, GeomError, PrincipalSpread, Result};
pub use illumination::{Illumination, RadialIllumination};

/// nalgebra types used throughout the workspace, re-exported so every crate
/// uses the same version.
pub use nalgebra;
pub use nalgebra::{Isometry3, Matrix3, Matrix3x4, Point2, Point3, Rotation3, Vector2, Vector3};
