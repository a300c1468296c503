//! The renderer's configuration: rig, optics, sensor, spheres, procedure,
//! injected machine errors, calibration target and output. Read from TOML;
//! every key is optional and defaults to the seed's rig and procedure
//! ([`DEFAULT_TOML`], printed by `trinocular synth config`).
//!
//! Units: lengths in mm unless the key says otherwise (`_um` micrometres,
//! `_deg` degrees, `_urad` microradians, `_e` electrons, `_dn` digital numbers,
//! `_s` seconds). Injected error curves are in µm (translations) and µrad
//! (rotations).

use std::collections::BTreeMap;
use std::path::Path;

use formats::Axis;
/// The `[procedure]` table: one record shared with `program.toml` (`formats::capture`).
pub use formats::{AxisProcedure, ProcedureConfig};
use serde::{Deserialize, Serialize};

use crate::capture::CaptureConfig;
use crate::{Result, SynthError};

/// The documented default configuration (the seed's rig and procedure), as
/// printed by `trinocular synth config`. Parses to [`Config::default`].
pub const DEFAULT_TOML: &str = include_str!("default.toml");

/// Width of the seed sensor (px); `--width` rescales the pixel pitch relative to it.
pub const SEED_WIDTH: u32 = 4096;

/// Everything the renderer needs to produce a campaign.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Seed of every random draw (noise, repeatability); same seed → same bytes.
    pub seed: u64,
    /// The image sensor (shared by the three cameras).
    pub sensor: SensorConfig,
    /// The lens (shared by the three cameras).
    pub optics: OpticsConfig,
    /// Camera placement and per-camera mounting errors.
    pub rig: RigConfig,
    /// Self-luminous spheres on the table.
    pub spheres: Vec<SphereConfig>,
    /// Measurement procedure (targets, runs, directions, captures, lines).
    pub procedure: ProcedureConfig,
    /// Injected geometric errors of the machine axes.
    pub machine: MachineConfig,
    /// 3-D calibration target of luminous markers.
    pub target: TargetConfig,
    /// Image files.
    pub output: OutputConfig,
    /// Rendering accuracy.
    pub render: RenderConfig,
    /// How the frames are written: the renderer's layout with `manifest.csv`
    /// (default), or as triggered or free-running cameras save them.
    #[serde(skip_serializing_if = "CaptureConfig::is_manifest")]
    pub capture: CaptureConfig,
}

/// The image sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorConfig {
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Pixel pitch (mm), square pixels.
    pub pixel_mm: f64,
    /// Output bit depth: 8 or 16.
    pub bits: u8,
    /// Conversion gain (DN per electron) at the output bit depth.
    pub gain_dn_per_e: f64,
    /// Black level (DN) added to every pixel.
    pub offset_dn: f64,
    /// Read noise (electrons RMS).
    pub read_noise_e: f64,
    /// Photon shot noise on (variance = mean electrons).
    pub shot_noise: bool,
    /// Uniform background (electrons per pixel per exposure).
    pub background_e: f64,
    /// Linear background gradient: change of the background (electrons) from
    /// the left to the right edge and from the top to the bottom edge, zero
    /// change at the image centre.
    pub background_gradient_e: [f64; 2],
    /// Exposure time (s), written to the EXIF ExposureTime tag.
    pub exposure_s: f64,
}

/// The lens.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OpticsConfig {
    /// Lens focal length (mm). Focused at `focus_distance_mm`, a thin lens has
    /// the principal distance `f·s/(s − f)`, which is the pinhole's focal length.
    pub focal_mm: f64,
    /// Aperture f-number N (defocus blur diameter ∝ 1/N).
    pub f_number: f64,
    /// Distance (mm, along the optical axis) of the plane in focus.
    pub focus_distance_mm: f64,
    /// Standard deviation of the Gaussian point-spread function in focus (µm on the sensor).
    pub psf_sigma_um: f64,
    /// What a pixel's value is proportional to: the image irradiance of a real
    /// lens, or the radiance a pinhole ray tracer writes.
    pub illumination: IlluminationModel,
    /// The lens's own vignetting beyond cos⁴θ, `V = 1 + v₁·tan²θ + v₂·tan⁴θ`
    /// (`[v₁, v₂]`; `lens` only).
    pub vignetting: [f64; 2],
}

/// The lens's relative illumination in the rendered images.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum IlluminationModel {
    /// A real lens: each pixel's value is radiance × cos⁴θ·V/J (natural
    /// vignetting, the lens's own vignetting V, energy conserved under the
    /// distortion, J the distorted/undistorted area ratio).
    #[default]
    Lens,
    /// Radiance per pixel (RI = 1), as a pinhole ray tracer writes it.
    Radiance,
}

/// Placement of the cameras.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RigConfig {
    /// World point every nominal camera aims at (mm).
    pub working_point: [f64; 3],
    /// Distance from each nominal camera's projection centre to the working point (mm).
    pub working_distance_mm: f64,
    /// The cameras (ids 1, 2, 3; a subset is allowed).
    pub cameras: Vec<CameraConfig>,
}

/// One camera: its nominal viewing direction and its true deviations from it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraConfig {
    /// Camera number 1, 2 or 3.
    pub id: u8,
    /// Nominal optical-axis direction (world).
    pub view: [f64; 3],
    /// World direction that appears upward in the image.
    pub up: [f64; 3],
    /// Serial number written to the EXIF BodySerialNumber tag.
    pub serial: String,
    /// True rotation relative to nominal, about the camera's x, y, z axes (degrees).
    pub rotation_error_deg: [f64; 3],
    /// True projection centre minus nominal (world, mm).
    pub position_error_mm: [f64; 3],
    /// True principal distance relative to nominal (percent).
    pub focal_error_percent: f64,
    /// True principal point minus the image centre (µm on the sensor, u then v).
    pub principal_point_offset_um: [f64; 2],
    /// True lens distortion (Brown, normalised coordinates, OpenCV signs).
    pub distortion: DistortionConfig,
    /// Stray-light blobs in this camera's images.
    pub stray_light: Vec<StrayLightConfig>,
}

/// Brown distortion coefficients (OpenCV names and signs).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DistortionConfig {
    /// Radial r².
    pub k1: f64,
    /// Radial r⁴.
    pub k2: f64,
    /// Radial r⁶.
    pub k3: f64,
    /// Tangential p1.
    pub p1: f64,
    /// Tangential p2.
    pub p2: f64,
}

impl From<DistortionConfig> for geom::Distortion {
    fn from(d: DistortionConfig) -> Self {
        geom::Distortion {
            k1: d.k1,
            k2: d.k2,
            k3: d.k3,
            p1: d.p1,
            p2: d.p2,
        }
    }
}

/// A Gaussian blob of stray light added to the background.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StrayLightConfig {
    /// Centre, as a fraction of the image width (0 = left edge, 1 = right edge).
    pub u: f64,
    /// Centre, as a fraction of the image height (0 = top, 1 = bottom).
    pub v: f64,
    /// Standard deviation, as a fraction of the image width.
    pub sigma: f64,
    /// Peak (electrons per pixel per exposure).
    pub peak_e: f64,
}

impl Default for StrayLightConfig {
    fn default() -> Self {
        Self {
            u: 0.5,
            v: 0.5,
            sigma: 0.05,
            peak_e: 0.0,
        }
    }
}

/// A self-luminous sphere fixed to the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SphereConfig {
    /// Name used in files and reports.
    pub name: String,
    /// Diameter (mm).
    pub diameter_mm: f64,
    /// Centre relative to the table reference point, table frame = machine
    /// frame at the nominal zero (mm).
    pub position_mm: [f64; 3],
    /// Signal of a fully covered pixel (electrons per exposure): uniform
    /// radiance gives uniform image irradiance over the silhouette.
    pub radiance_e: f64,
}

impl Default for SphereConfig {
    fn default() -> Self {
        Self {
            name: String::new(),
            diameter_mm: 10.0,
            position_mm: [0.0; 3],
            radiance_e: 12_000.0,
        }
    }
}

/// Injected errors of the moving axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MachineConfig {
    /// Errors of the X axis, as functions of the commanded x.
    #[serde(rename = "X")]
    pub x: AxisErrors,
    /// Errors of the Y axis, as functions of the commanded y.
    #[serde(rename = "Y")]
    pub y: AxisErrors,
}

impl MachineConfig {
    /// The errors of `axis` (Z does not move: none).
    pub fn axis(&self, axis: Axis) -> Option<&AxisErrors> {
        match axis {
            Axis::X => Some(&self.x),
            Axis::Y => Some(&self.y),
            Axis::Z => None,
        }
    }
}

/// The six error motions of one linear axis (ISO 230-1), plus repeatability.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AxisErrors {
    /// Positioning error along the axis (µm), direction-independent part.
    pub positioning: ErrorCurve,
    /// Reversal error B (µm): the + approach is displaced by +B/2, the − approach by −B/2.
    pub reversal_um: f64,
    /// Straightness errors (µm) in the two other axes, keyed by axis name
    /// (`X` axis: `Y`, `Z`; `Y` axis: `X`, `Z`).
    pub straightness: BTreeMap<String, ErrorCurve>,
    /// Roll: rotation about the moving axis (µrad).
    pub roll: ErrorCurve,
    /// Pitch: rotation about the other horizontal axis (µrad).
    pub pitch: ErrorCurve,
    /// Yaw: rotation about Z (µrad).
    pub yaw: ErrorCurve,
    /// Run-to-run repeatability along the axis: standard deviation of a
    /// random offset drawn per approach (µm).
    pub repeatability_um: f64,
    /// The same, in each of the two perpendicular directions (µm).
    pub repeatability_perp_um: f64,
    /// Standard deviation of a random offset drawn per capture, each direction (µm).
    pub capture_noise_um: f64,
}

/// An error as a function of the commanded position p on a travel
/// `[start, start + L]` with midpoint m:
/// `e(p) = slope·(p − m)/1000 + bow·(1 − (2(p − m)/L)²) + wave·sin(2π(p − start)/period + phase)`.
/// Units: µm for translations, µrad for rotations; `slope` per metre.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ErrorCurve {
    /// Linear part, per metre of travel (µm/m = ppm, or µrad/m).
    pub slope_per_m: f64,
    /// Parabolic bow: value at mid-travel relative to the ends.
    pub bow: f64,
    /// Amplitude of the periodic part.
    pub wave: f64,
    /// Period of the periodic part (mm).
    pub wave_period_mm: f64,
    /// Phase of the periodic part at the start of the travel (degrees).
    pub wave_phase_deg: f64,
}

impl Default for ErrorCurve {
    fn default() -> Self {
        Self {
            slope_per_m: 0.0,
            bow: 0.0,
            wave: 0.0,
            wave_period_mm: 50.0,
            wave_phase_deg: 0.0,
        }
    }
}

impl ErrorCurve {
    /// Value at commanded position `p` on a travel starting at `start` of length `length`.
    pub fn value(&self, p: f64, start: f64, length: f64) -> f64 {
        let mid = start + length / 2.0;
        let x = if length > 0.0 {
            2.0 * (p - mid) / length
        } else {
            0.0
        };
        self.slope_per_m * (p - mid) / 1000.0
            + self.bow * (1.0 - x * x)
            + self.wave
                * (std::f64::consts::TAU * (p - start) / self.wave_period_mm
                    + self.wave_phase_deg.to_radians())
                .sin()
    }
}

/// The 3-D calibration target: markers on a Latin-square lattice, so that no
/// two markers line up along X, Y or Z (each camera sees a full grid).
/// Marker (i, j), i, j = 0..n−1, sits at
/// `centre + spacing·(i − c, j − c) + depth_step·(((2i + 3j) mod n) − c)·ẑ`, c = (n − 1)/2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TargetConfig {
    /// Lattice size n (markers = n²); must be coprime with 6.
    pub grid: u32,
    /// Lattice pitch along X and along Y (mm). The target should span the
    /// volume the spheres travel through: a camera calibrated on a smaller
    /// target is extrapolated at the ends of the travel, which shows first in
    /// the angular errors (a sphere set's lever is only ≈ 8 mm).
    pub spacing_mm: [f64; 2],
    /// Lattice pitch in Z (mm).
    pub depth_step_mm: f64,
    /// Centre of the lattice, world frame (mm).
    pub centre: [f64; 3],
    /// Marker diameter (mm).
    pub marker_diameter_mm: f64,
    /// Largest displacement of a marker from its lattice position along each
    /// axis (mm): a fixed pseudo-random jitter that breaks the lattice's
    /// periodicity, so that no image of the target matches the target
    /// shifted by a lattice step. Below a quarter of either pitch.
    pub jitter_mm: f64,
    /// Marker radiance (electrons per fully covered pixel per exposure).
    pub radiance_e: f64,
}

/// Image file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    /// TIFF (what the cameras write), metadata in TIFF and EXIF tags.
    Tiff,
    /// PNG, metadata in an eXIf chunk.
    Png,
}

impl ImageFormat {
    /// File extension without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            ImageFormat::Tiff => "tif",
            ImageFormat::Png => "png",
        }
    }
}

/// TIFF compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TiffCompression {
    /// Uncompressed (fastest; 2 bytes per pixel at 16 bits).
    None,
    /// Deflate with horizontal differencing.
    Deflate,
    /// LZW with horizontal differencing.
    Lzw,
}

/// Image files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputConfig {
    /// `tiff` or `png`.
    pub format: ImageFormat,
    /// TIFF compression: `none`, `deflate` or `lzw`.
    pub compression: TiffCompression,
    /// EXIF Make.
    pub make: String,
    /// EXIF Model.
    pub model: String,
}

/// Rendering accuracy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderConfig {
    /// Depth of the adaptive pixel subdivision at silhouette edges: leaves are
    /// 2^−depth px squares, cut exactly by the local tangent line.
    pub max_depth: u8,
}

impl Default for RenderConfig {
    fn default() -> Self {
        Self { max_depth: 4 }
    }
}

/// Command-line overrides for quick runs (`--width --height --targets --runs --captures --seed`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Overrides {
    /// Image width (px). The sensor's physical width is kept: the pixel pitch
    /// becomes `pixel_mm·width_before/width`, so the field of view, the lens,
    /// the PSF in µm and the distortion are unchanged and every image-space
    /// length in px scales by `width/width_before`.
    pub width: Option<u32>,
    /// Image height (px), same pixel pitch as the width gives (square pixels);
    /// keep 4:3 to keep the vertical field.
    pub height: Option<u32>,
    /// Number of targets on every axis (segments = targets − 1, same travel).
    pub targets: Option<u32>,
    /// Runs.
    pub runs: Option<u32>,
    /// Captures per target.
    pub captures: Option<u32>,
    /// Random seed.
    pub seed: Option<u64>,
}

pub use formats::MAX_INSTANTS;

/// Largest target grid (markers per side of the Latin square; 49 by default).
pub const MAX_GRID: u32 = 101;

pub(crate) fn bad(key: &str, message: impl std::fmt::Display) -> SynthError {
    SynthError::config(format!("{key}: {message}"))
}

pub(crate) fn positive(key: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(key, format!("{v} must be a positive number")))
    }
}

pub(crate) fn non_negative(key: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad(key, format!("{v} must be a finite number ≥ 0")))
    }
}

pub(crate) fn finite(key: &str, values: &[f64]) -> Result<()> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => Err(bad(key, format!("{v} is not a finite number"))),
        None => Ok(()),
    }
}

/// Parse a TOML configuration of type `T` and check it with `validate`;
/// errors name `path` (when given) and, for a parse error, the line and
/// column, or the key `validate` names. Shared by every generator's configuration.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(
    text: &str,
    path: Option<&Path>,
    validate: impl FnOnce(&T) -> Result<()>,
) -> Result<T> {
    let config: T = toml::from_str(text).map_err(|e| {
        let at = e.span().map(|s| {
            let before = &text[..s.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!("line {line}, column {column}: ")
        });
        SynthError::Config {
            path: path.map(Path::to_path_buf),
            message: format!(
                "{}{}",
                at.unwrap_or_default(),
                e.message().trim_end().replace('\n', " ")
            ),
        }
    })?;
    validate(&config).map_err(|e| match e {
        SynthError::Config { message, .. } => SynthError::Config {
            path: path.map(Path::to_path_buf),
            message,
        },
        other => other,
    })?;
    Ok(config)
}

impl Config {
    /// Parse a TOML configuration; `path` names the source in errors. Unknown
    /// keys are errors naming the key.
    pub fn from_toml_str(text: &str, path: Option<&Path>) -> Result<Self> {
        parse_toml(text, path, Config::validate)
    }

    /// Read a TOML configuration file.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| SynthError::io(path, e))?;
        Self::from_toml_str(&text, Some(path))
    }

    /// The configuration as TOML (without the comments of [`DEFAULT_TOML`]).
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string_pretty(self).map_err(|e| SynthError::config(e.to_string()))
    }

    /// Apply command-line overrides, then validate.
    pub fn apply(&mut self, o: &Overrides) -> Result<()> {
        if let Some(w) = o.width {
            if w == 0 {
                return Err(bad("--width", "must be positive"));
            }
            self.sensor.pixel_mm *= f64::from(self.sensor.width) / f64::from(w);
            self.sensor.width = w;
        }
        if let Some(h) = o.height {
            self.sensor.height = h;
        }
        if let Some(n) = o.targets {
            if n < 2 {
                return Err(bad(
                    "--targets",
                    format!("{n}: at least 2 targets are needed"),
                ));
            }
            for a in &mut self.procedure.axes {
                a.segments = n - 1;
            }
        }
        if let Some(r) = o.runs {
            self.procedure.runs = r;
        }
        if let Some(c) = o.captures {
            self.procedure.captures = c;
        }
        if let Some(s) = o.seed {
            self.seed = s;
        }
        self.validate()
    }

    /// Check every value; the error names the key.
    pub fn validate(&self) -> Result<()> {
        let s = &self.sensor;
        if s.width < 16 || s.height < 16 {
            return Err(bad(
                "sensor.width/height",
                format!("{}×{} px is too small (≥ 16×16)", s.width, s.height),
            ));
        }
        formats::limits::check_image_size(
            u64::from(s.width),
            u64::from(s.height),
            formats::limits::DEFAULT_MAX_PIXELS,
        )
        .map_err(|e| bad("sensor.width/height", e))?;
        positive("sensor.pixel_mm", s.pixel_mm)?;
        if s.bits != 8 && s.bits != 16 {
            return Err(bad("sensor.bits", format!("{} must be 8 or 16", s.bits)));
        }
        positive("sensor.gain_dn_per_e", s.gain_dn_per_e)?;
        non_negative("sensor.offset_dn", s.offset_dn)?;
        non_negative("sensor.read_noise_e", s.read_noise_e)?;
        non_negative("sensor.background_e", s.background_e)?;
        finite("sensor.background_gradient_e", &s.background_gradient_e)?;
        positive("sensor.exposure_s", s.exposure_s)?;

        let o = &self.optics;
        positive("optics.focal_mm", o.focal_mm)?;
        positive("optics.f_number", o.f_number)?;
        positive("optics.focus_distance_mm", o.focus_distance_mm)?;
        if o.focus_distance_mm <= o.focal_mm {
            return Err(bad(
                "optics.focus_distance_mm",
                "must exceed the focal length",
            ));
        }
        non_negative("optics.psf_sigma_um", o.psf_sigma_um)?;
        finite("optics.vignetting", &o.vignetting)?;
        if o.illumination == IlluminationModel::Radiance && o.vignetting != [0.0, 0.0] {
            return Err(bad(
                "optics.vignetting",
                "applies to illumination = \"lens\" only",
            ));
        }
        // V must stay positive out to the field's corner (tan θ ≤ half-diagonal / f).
        let half_diagonal = 0.5 * s.pixel_mm * f64::from(s.width).hypot(f64::from(s.height));
        let t2 = (half_diagonal
            / crate::rig::principal_distance_mm(o.focal_mm, o.focus_distance_mm))
        .powi(2);
        let [v1, v2] = o.vignetting;
        let v = |x: f64| 1.0 + v1 * x + v2 * x * x;
        let vertex = -v1 / (2.0 * v2);
        let mut v_min = v(0.0).min(v(t2));
        if v2 > 0.0 && (0.0..t2).contains(&vertex) {
            v_min = v_min.min(v(vertex));
        }
        if v_min.is_nan() || v_min <= 0.0 {
            return Err(bad(
                "optics.vignetting",
                format!(
                    "V = 1 + v1·tan²θ + v2·tan⁴θ reaches {v_min} in the field: it must stay positive"
                ),
            ));
        }

        finite("rig.working_point", &self.rig.working_point)?;
        positive("rig.working_distance_mm", self.rig.working_distance_mm)?;
        if self.rig.cameras.is_empty() {
            return Err(bad("rig.cameras", "at least one camera is needed"));
        }
        let mut seen = [false; 4];
        for c in &self.rig.cameras {
            let key = format!("rig.cameras[id = {}]", c.id);
            if !(1..=3).contains(&c.id) {
                return Err(bad(&key, "id must be 1, 2 or 3"));
            }
            if std::mem::replace(&mut seen[usize::from(c.id)], true) {
                return Err(bad(&key, "duplicate camera id"));
            }
            finite(&format!("{key}.view"), &c.view)?;
            finite(&format!("{key}.up"), &c.up)?;
            finite(&format!("{key}.rotation_error_deg"), &c.rotation_error_deg)?;
            finite(&format!("{key}.position_error_mm"), &c.position_error_mm)?;
            finite(
                &format!("{key}.focal_error_percent"),
                &[c.focal_error_percent],
            )?;
            finite(
                &format!("{key}.principal_point_offset_um"),
                &c.principal_point_offset_um,
            )?;
            let d = c.distortion;
            finite(
                &format!("{key}.distortion"),
                &[d.k1, d.k2, d.k3, d.p1, d.p2],
            )?;
            if !c.serial.is_ascii() || c.serial.contains('\0') {
                return Err(bad(&format!("{key}.serial"), "must be ASCII without NUL"));
            }
            for (i, b) in c.stray_light.iter().enumerate() {
                let k = format!("{key}.stray_light[{i}]");
                finite(&k, &[b.u, b.v])?;
                positive(&format!("{k}.sigma"), b.sigma)?;
                non_negative(&format!("{k}.peak_e"), b.peak_e)?;
            }
        }

        if self.spheres.is_empty() {
            return Err(bad("spheres", "at least one sphere is needed"));
        }
        for (i, sp) in self.spheres.iter().enumerate() {
            let key = format!("spheres[{i}]");
            if sp.name.trim().is_empty() || sp.name.contains(',') {
                return Err(bad(
                    &format!("{key}.name"),
                    format!("'{}' is empty or contains a comma", sp.name),
                ));
            }
            if self.spheres[..i].iter().any(|o| o.name == sp.name) {
                return Err(bad(
                    &format!("{key}.name"),
                    format!("duplicate sphere name '{}'", sp.name),
                ));
            }
            positive(&format!("{key}.diameter_mm"), sp.diameter_mm)?;
            finite(&format!("{key}.position_mm"), &sp.position_mm)?;
            non_negative(&format!("{key}.radiance_e"), sp.radiance_e)?;
        }
        // The set as `trinocular measure` checks it: spheres one diameter
        // cannot be told apart.
        formats::check_sphere_set(
            self.spheres
                .iter()
                .map(|s| (s.name.as_str(), s.diameter_mm)),
        )
        .map_err(|(i, column, message)| {
            let field = if column == "diameter" {
                "diameter_mm"
            } else {
                column
            };
            bad(&format!("spheres[{i}].{field}"), message)
        })?;

        let p = &self.procedure;
        p.validate().map_err(|e| bad(&e.key, e.message))?;
        crate::datetime::parse(&p.start_time).map_err(|m| bad("procedure.start_time", m))?;

        for (axis, e) in [(Axis::X, &self.machine.x), (Axis::Y, &self.machine.y)] {
            let key = format!("machine.{axis}");
            let others = axis.others().map(Axis::name);
            for (name, c) in &e.straightness {
                if !others.contains(&name.as_str()) {
                    return Err(bad(
                        &format!("{key}.straightness.{name}"),
                        format!(
                            "straightness of {axis} is in {} or {}",
                            others[0], others[1]
                        ),
                    ));
                }
                c.validate(&format!("{key}.straightness.{name}"))?;
            }
            e.positioning.validate(&format!("{key}.positioning"))?;
            e.roll.validate(&format!("{key}.roll"))?;
            e.pitch.validate(&format!("{key}.pitch"))?;
            e.yaw.validate(&format!("{key}.yaw"))?;
            finite(&format!("{key}.reversal_um"), &[e.reversal_um])?;
            non_negative(&format!("{key}.repeatability_um"), e.repeatability_um)?;
            non_negative(
                &format!("{key}.repeatability_perp_um"),
                e.repeatability_perp_um,
            )?;
            non_negative(&format!("{key}.capture_noise_um"), e.capture_noise_um)?;
        }

        let t = &self.target;
        if t.grid < 2 || t.grid.is_multiple_of(2) || t.grid.is_multiple_of(3) || t.grid > MAX_GRID {
            return Err(bad(
                "target.grid",
                format!(
                    "{} must be ≥ 5, at most {MAX_GRID} and coprime with 6 (5, 7, 11, ...)",
                    t.grid
                ),
            ));
        }
        positive("target.spacing_mm[0]", t.spacing_mm[0])?;
        positive("target.spacing_mm[1]", t.spacing_mm[1])?;
        non_negative("target.depth_step_mm", t.depth_step_mm)?;
        finite("target.centre", &t.centre)?;
        positive("target.marker_diameter_mm", t.marker_diameter_mm)?;
        non_negative("target.jitter_mm", t.jitter_mm)?;
        if t.jitter_mm
            >= 0.25
                * t.spacing_mm[0]
                    .min(t.spacing_mm[1])
                    .min(if t.depth_step_mm > 0.0 {
                        t.depth_step_mm
                    } else {
                        f64::INFINITY
                    })
        {
            return Err(bad(
                "target.jitter_mm",
                format!(
                    "{} mm must stay below a quarter of the lattice pitch",
                    t.jitter_mm
                ),
            ));
        }
        non_negative("target.radiance_e", t.radiance_e)?;

        if !self.output.make.is_ascii() || !self.output.model.is_ascii() {
            return Err(bad("output.make/model", "must be ASCII"));
        }
        if self.output.format == ImageFormat::Png
            && self.output.compression != TiffCompression::None
        {
            return Err(bad(
                "output.compression",
                "applies to TIFF only (PNG is always deflated)",
            ));
        }
        self.capture.validate(self)?;
        if !(1..=8).contains(&self.render.max_depth) {
            return Err(bad(
                "render.max_depth",
                format!("{} must be 1..=8", self.render.max_depth),
            ));
        }
        Ok(())
    }
}

impl ErrorCurve {
    fn validate(&self, key: &str) -> Result<()> {
        finite(
            key,
            &[self.slope_per_m, self.bow, self.wave, self.wave_phase_deg],
        )?;
        positive(&format!("{key}.wave_period_mm"), self.wave_period_mm)
    }
}

fn curve(
    slope_per_m: f64,
    bow: f64,
    wave: f64,
    wave_period_mm: f64,
    wave_phase_deg: f64,
) -> ErrorCurve {
    ErrorCurve {
        slope_per_m,
        bow,
        wave,
        wave_period_mm,
        wave_phase_deg,
    }
}

impl Default for Config {
    /// The seed's rig and procedure; identical to [`DEFAULT_TOML`].
    fn default() -> Self {
        Self {
            seed: 1,
            sensor: SensorConfig::default(),
            optics: OpticsConfig::default(),
            rig: RigConfig::default(),
            spheres: vec![
                SphereConfig {
                    name: "A".into(),
                    diameter_mm: 20.0,
                    position_mm: [0.0, 0.0, 30.0],
                    radiance_e: 12_000.0,
                },
                SphereConfig {
                    name: "B".into(),
                    diameter_mm: 15.0,
                    position_mm: [20.0, 20.0, 50.0],
                    radiance_e: 12_000.0,
                },
                SphereConfig {
                    name: "C".into(),
                    diameter_mm: 10.0,
                    position_mm: [-15.0, -15.0, 45.0],
                    radiance_e: 12_000.0,
                },
            ],
            procedure: ProcedureConfig::default(),
            machine: MachineConfig::default(),
            target: TargetConfig::default(),
            output: OutputConfig::default(),
            render: RenderConfig::default(),
            capture: CaptureConfig::default(),
        }
    }
}

impl Default for SensorConfig {
    fn default() -> Self {
        Self {
            width: 4096,
            height: 3072,
            pixel_mm: 0.0055,
            bits: 16,
            gain_dn_per_e: 4.0,
            offset_dn: 400.0,
            read_noise_e: 5.0,
            shot_noise: true,
            background_e: 200.0,
            background_gradient_e: [0.0, 0.0],
            exposure_s: 0.002,
        }
    }
}

impl Default for OpticsConfig {
    fn default() -> Self {
        Self {
            focal_mm: 40.0,
            f_number: 8.0,
            focus_distance_mm: 460.0,
            psf_sigma_um: 3.0,
            illumination: IlluminationModel::Lens,
            vignetting: [0.0, 0.0],
        }
    }
}

impl Default for RigConfig {
    fn default() -> Self {
        Self {
            working_point: [0.0, 0.0, 30.0],
            working_distance_mm: 460.0,
            cameras: vec![
                CameraConfig {
                    id: 1,
                    view: [1.0, 0.0, 0.0],
                    up: [0.0, 0.0, 1.0],
                    serial: "TRN-SYN-0001".into(),
                    rotation_error_deg: [0.35, -0.5, 0.25],
                    position_error_mm: [1.2, -1.5, 0.8],
                    focal_error_percent: 0.4,
                    principal_point_offset_um: [27.5, -16.5],
                    distortion: DistortionConfig {
                        k1: -0.045,
                        k2: 0.03,
                        k3: 0.0,
                        p1: 1.5e-4,
                        p2: -1.0e-4,
                    },
                    stray_light: Vec::new(),
                },
                CameraConfig {
                    id: 2,
                    view: [0.0, 1.0, 0.0],
                    up: [0.0, 0.0, 1.0],
                    serial: "TRN-SYN-0002".into(),
                    rotation_error_deg: [-0.3, 0.4, -0.45],
                    position_error_mm: [-1.0, 1.4, -0.6],
                    focal_error_percent: -0.3,
                    principal_point_offset_um: [-22.0, 33.0],
                    distortion: DistortionConfig {
                        k1: 0.035,
                        k2: -0.02,
                        k3: 0.0,
                        p1: -1.2e-4,
                        p2: 0.8e-4,
                    },
                    stray_light: Vec::new(),
                },
                CameraConfig {
                    id: 3,
                    view: [0.0, 0.0, -1.0],
                    up: [0.0, 1.0, 0.0],
                    serial: "TRN-SYN-0003".into(),
                    rotation_error_deg: [0.25, 0.3, 0.6],
                    position_error_mm: [0.9, 0.7, -1.8],
                    focal_error_percent: 0.25,
                    principal_point_offset_um: [11.0, 22.0],
                    distortion: DistortionConfig {
                        k1: -0.03,
                        k2: 0.015,
                        k3: 0.0,
                        p1: 0.5e-4,
                        p2: 1.3e-4,
                    },
                    stray_light: Vec::new(),
                },
            ],
        }
    }
}

impl Default for CameraConfig {
    fn default() -> Self {
        Self {
            id: 1,
            view: [1.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            serial: "TRN-SYN-0000".into(),
            rotation_error_deg: [0.0; 3],
            position_error_mm: [0.0; 3],
            focal_error_percent: 0.0,
            principal_point_offset_um: [0.0; 2],
            distortion: DistortionConfig::default(),
            stray_light: Vec::new(),
        }
    }
}

impl Default for MachineConfig {
    fn default() -> Self {
        let x = AxisErrors {
            positioning: curve(6.0, 1.5, 1.2, 36.0, 20.0),
            reversal_um: 2.5,
            straightness: BTreeMap::from([
                ("Y".to_string(), curve(0.0, 3.0, 0.6, 50.0, 0.0)),
                ("Z".to_string(), curve(4.0, -2.0, 0.4, 75.0, 30.0)),
            ]),
            roll: curve(0.0, 12.0, 3.0, 60.0, 0.0),
            pitch: curve(40.0, 8.0, 0.0, 50.0, 0.0),
            yaw: curve(0.0, -10.0, 4.0, 45.0, 90.0),
            repeatability_um: 0.8,
            repeatability_perp_um: 0.3,
            capture_noise_um: 0.1,
        };
        let y = AxisErrors {
            positioning: curve(-8.0, 1.0, 0.9, 25.0, 0.0),
            reversal_um: 3.5,
            straightness: BTreeMap::from([
                ("X".to_string(), curve(0.0, -1.5, 0.5, 40.0, 45.0)),
                ("Z".to_string(), curve(0.0, 2.5, 0.0, 50.0, 0.0)),
            ]),
            roll: curve(0.0, 9.0, 0.0, 50.0, 0.0),
            pitch: curve(-30.0, 0.0, 3.0, 50.0, 0.0),
            yaw: curve(0.0, 6.0, 0.0, 50.0, 0.0),
            repeatability_um: 1.0,
            repeatability_perp_um: 0.3,
            capture_noise_um: 0.1,
        };
        Self { x, y }
    }
}

impl Default for TargetConfig {
    fn default() -> Self {
        Self {
            grid: 7,
            spacing_mm: [28.0, 20.0],
            depth_step_mm: 18.0,
            centre: [0.0, 0.0, 30.0],
            marker_diameter_mm: 3.0,
            jitter_mm: 3.0,
            radiance_e: 12_000.0,
        }
    }
}

impl Default for OutputConfig {
    fn default() -> Self {
        Self {
            format: ImageFormat::Tiff,
            compression: TiffCompression::None,
            make: "trinocular".into(),
            model: "synth".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn documented_default_is_the_default() {
        let parsed = Config::from_toml_str(DEFAULT_TOML, None).unwrap();
        assert_eq!(parsed, Config::default());
        // And the serialised default reads back to itself.
        let text = Config::default().to_toml().unwrap();
        assert_eq!(
            Config::from_toml_str(&text, None).unwrap(),
            Config::default()
        );
    }

    #[test]
    fn unknown_key_is_named() {
        let e = Config::from_toml_str("[sensor]\nwidht = 10\n", Some(Path::new("c.toml")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("c.toml") && e.contains("widht"), "{e}");
    }

    #[test]
    fn bad_value_is_named() {
        let e = Config::from_toml_str("[sensor]\nbits = 12\n", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("sensor.bits"), "{e}");
        let e = Config::from_toml_str("[machine.X.straightness.X]\nbow = 1.0\n", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("machine.X.straightness.X"), "{e}");
    }

    #[test]
    fn width_override_keeps_the_field_of_view() {
        let mut c = Config::default();
        let field = f64::from(c.sensor.width) * c.sensor.pixel_mm;
        c.apply(&Overrides {
            width: Some(512),
            height: Some(384),
            targets: Some(3),
            ..Overrides::default()
        })
        .unwrap();
        assert!((f64::from(c.sensor.width) * c.sensor.pixel_mm - field).abs() < 1e-12);
        assert!(c.procedure.axes.iter().all(|a| a.targets() == 3));
    }

    #[test]
    fn curve_has_its_documented_shape() {
        let c = curve(10.0, 2.0, 0.0, 50.0, 0.0);
        // Ends: ∓ slope·L/2; middle: bow.
        assert!((c.value(0.0, 0.0, 100.0) + 0.5).abs() < 1e-12);
        assert!((c.value(100.0, 0.0, 100.0) - 0.5).abs() < 1e-12);
        assert!((c.value(50.0, 0.0, 100.0) - 2.0).abs() < 1e-12);
        let w = curve(0.0, 0.0, 1.0, 40.0, 90.0);
        assert!((w.value(0.0, 0.0, 100.0) - 1.0).abs() < 1e-12);
        assert!((w.value(20.0, 0.0, 100.0) + 1.0).abs() < 1e-12);
    }
}
