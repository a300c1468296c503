//! Synthetic renderer of the trinocular rig: physically correct images of
//! self-luminous spheres seen by three calibrated cameras, with the exact
//! ground truth every later stage is judged by.
//!
//! # Public entry points
//! - Configuration: [`Config`] (TOML, [`config::DEFAULT_TOML`]; the tables'
//!   types in [`config`]) and the command line's [`Overrides`].
//! - Campaigns: [`write_campaign`] (frames, `manifest.csv` or the cameras'
//!   own folders, truth files, reference figures) and its size beforehand
//!   ([`campaign_size`]), [`write_target_scene`]
//!   (the calibration target's images), [`check_plan`]; long jobs report
//!   through [`Progress`] ([`NoProgress`] when nobody listens).
//! - The scene and its frames: [`SynthRig`] / [`SynthCamera`] (nominal and
//!   true cameras, flat field, dark frame), [`Plan`] (the instants of the
//!   procedure and the spheres at each), [`Sphere`] with its analytic image
//!   ([`ellipse_centre_px`], [`separation_px`], [`frame_clearance_px`]),
//!   [`coverage()`] (exact-area coverage through the full camera model),
//!   [`blur`] and [`sphere_signals`] (moment-exact Gaussian PSF and defocus),
//!   [`expose`] with [`Sensor`] and [`NoiseKey`] (background, noise, gain,
//!   quantisation; deterministic per-row random streams), [`expose_through`]
//!   a camera's [`Readout`] (ADC bits, the fixed pattern: PRNU, DSNU, column
//!   and row offsets, hot and dead pixels — [`SynthCamera::defects`],
//!   [`truth::sensor_truth`]), [`LensIllumination`] (cos⁴θ, the lens's own
//!   vignetting, energy conserved under distortion; or a measured
//!   [`VignettingProfile`]), [`lens_profile`] (lensfun's models, the
//!   built-in profiles, ptlens → Brown).
//! - The calibration target: [`markers`], [`marker_spheres`], [`render_target`].
//! - Files: [`encode_tiff`], [`encode_png`], [`write_image`] with
//!   [`FrameMetadata`] (8/16-bit TIFF and PNG with EXIF); [`datetime`] (the
//!   time stamps' calendar).
//! - Truth: [`truth`] (measured against true displacements, scale errors,
//!   reference figures).
//! - Probe methods: [`probe`] (rotary table, indexing head, laser tracer,
//!   volumetric model generators).
//! - Errors: [`SynthError`], one type for the whole crate.
//!
//! # Conventions
//! - Lengths in millimetres, angles in radians, all geometry in `f64`;
//!   injected errors in µm and µrad in the configuration and `truth.json`.
//! - World frame = machine frame: right-handed, Z up. Camera frame: x right,
//!   y down, z forward; `x_cam = R·x_world + t`.
//! - Pixel coordinates: the centre of the top-left pixel is (0, 0).
//! - A pixel's value is the scene radiance times the lens's relative
//!   illumination (`[optics] illumination = "lens"`: cos⁴θ·V/J, see
//!   [`LensIllumination`]; `"profile"`: a measured lens profile) or the
//!   radiance itself (`"radiance"`, a pinhole ray tracer); lens distortion
//!   only moves light.
//! - The library never prints; long jobs report through [`Progress`].

#![deny(missing_docs)]
#![warn(unreachable_pub)]

mod board;
mod campaign;
mod capture;
pub mod config;
mod coverage;
pub mod datetime;
mod encode;
mod error;
mod illumination;
pub mod lens_profile;
mod machine;
mod pattern;
pub mod probe;
mod procedure;
mod progress;
mod psf;
mod render;
mod rig;
mod scene;
mod sensor;
mod target;
pub mod truth;

pub use board::{
    BoardSummary, Placement, corner_images, corners, placements, render_board, write_board_scene,
};
pub use campaign::{
    CampaignSize, CampaignSummary, SceneCheck, TargetSummary, campaign_size, check_plan,
    write_campaign, write_target_scene,
};
pub use config::{Config, IlluminationModel, Overrides};
pub use coverage::{Coverage, PixelRect, coverage};
pub use encode::{FrameMetadata, encode_png, encode_tiff, write_image};
pub use error::{Result, SynthError};
pub use illumination::{IlluminationSource, LensIllumination, VignettingProfile};
pub use pattern::{Defects, FixedPattern, HotPixel, PatternKey, PatternParams, Readout};
pub use procedure::{Instant, Plan, TableSphere};
pub use progress::{NoProgress, Progress};
pub use psf::{Optics, Signal, blur};
pub use render::sphere_signals;
pub use rig::{SynthCamera, SynthRig};
pub use scene::{Sphere, ViewedSphere, ellipse_centre_px, frame_clearance_px, separation_px};
pub use sensor::{Exposure, Image16, NoiseKey, Sensor, expose, expose_through, mean_row};
pub use target::{Marker, marker_spheres, markers, render_target};
