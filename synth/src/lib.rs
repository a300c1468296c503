//! Synthetic renderer of the trinocular rig: physically correct images of
//! self-luminous spheres seen by three calibrated cameras, with the exact
//! ground truth every later stage is judged by.
//!
//! - [`scene`]: spheres and their analytic images (silhouette cone, ellipse
//!   centre with its perspective bias, separations, frame clearance).
//! - [`coverage`]: exact-area coverage of each visible silhouette by adaptive
//!   subdivision through the full camera model (pinhole + Brown distortion),
//!   with occlusion, and each pixel's first moment of covered area.
//! - [`psf`]: Gaussian PSF + thin-lens defocus, applied per sphere with a
//!   moment-exact blur (centroids are exact, not just unbiased).
//! - [`sensor`]: background, gradient, stray light, shot/read noise, gain,
//!   quantisation, saturation; deterministic per-row random streams.
//! - [`illumination`]: the lens's relative illumination (natural vignetting,
//!   the lens's own vignetting, energy conservation under distortion).
//! - [`render`]: one frame from the above; [`rig`]: nominal and true cameras.
//! - [`encode`]: 8/16-bit TIFF and PNG with EXIF metadata.
//! - [`machine`], [`procedure`], [`campaign`], [`target`], [`truth`]: the
//!   simulated machine with injected errors, the measurement procedure, the
//!   streamed campaign writer, the calibration target and the truth files;
//!   [`capture`]: the frames written as cameras save them (folders per
//!   serial, camera clocks, real move times, faults, continuous streams).
//!
//! # Conventions
//! - Lengths in millimetres, angles in radians, all geometry in `f64`;
//!   injected errors in µm and µrad in the configuration and `truth.json`.
//! - World frame = machine frame: right-handed, Z up. Camera frame: x right,
//!   y down, z forward; `x_cam = R·x_world + t`.
//! - Pixel coordinates: the centre of the top-left pixel is (0, 0).
//! - A pixel's value is the scene radiance times the lens's relative
//!   illumination (`[optics] illumination = "lens"`: cos⁴θ·V/J, see
//!   [`illumination`]) or the radiance itself (`"radiance"`, a pinhole ray
//!   tracer); lens distortion only moves light.
//! - The library never prints; long jobs report through [`progress::Progress`].

#![deny(missing_docs)]

mod error;

pub mod campaign;
pub mod capture;
pub mod config;
pub mod coverage;
pub mod datetime;
pub mod encode;
pub mod illumination;
pub mod machine;
pub mod probe;
pub mod procedure;
pub mod progress;
pub mod psf;
pub mod render;
pub mod rig;
pub mod scene;
pub mod sensor;
pub mod target;
pub mod truth;

pub use config::{Config, IlluminationModel, Overrides};
pub use error::{Result, SynthError};
pub use illumination::LensIllumination;
pub use psf::{Optics, Signal};
pub use rig::{SynthCamera, SynthRig};
pub use scene::Sphere;
pub use sensor::{Image16, NoiseKey, Sensor};
