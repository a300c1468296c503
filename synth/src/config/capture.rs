//! The `[capture]` table: how the frames of a campaign are written (the
//! renderer's layout, or as triggered or free-running cameras save them).

use serde::{Deserialize, Serialize};

use super::Config;
use super::check::{non_negative, positive};
use crate::{Result, SynthError};

/// How a campaign's frames are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CaptureMode {
    /// `images/<axis><line>/run<r>-<up|down>/t<target>_c<capture>_cam<k>.<ext>`
    /// and `manifest.csv` (the renderer's layout).
    #[default]
    Manifest,
    /// As cameras triggered `captures` times at each dwell save them.
    Triggered,
    /// As free-running cameras save them: every frame of the campaign.
    Continuous,
}

/// A frame a camera failed to save.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DroppedFrame {
    /// Camera number.
    pub camera: u8,
    /// The instant (0-based, campaign order) whose frame of that camera is missing.
    pub instant: u64,
}

/// A stray trigger: one frame taken during a move (triggered mode).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StrayFrame {
    /// Camera number.
    pub camera: u8,
    /// The dwell (0-based, program order, ≥ 1) whose approach move the frame
    /// is taken in, half-way through it.
    pub dwell: usize,
}

/// The `[capture]` table: how the frames of a campaign are written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CaptureConfig {
    /// `manifest` (the renderer's layout), `triggered` or `continuous`.
    pub mode: CaptureMode,
    /// Per camera 1, 2, 3: its clock minus the true time (s), in its EXIF times.
    pub clock_offset_s: [f64; 3],
    /// Per camera 1, 2, 3: the number of its first file.
    pub first_number: [u32; 3],
    /// File names: prefix, the number in 6 digits, the extension.
    pub file_prefix: String,
    /// Real move time = distance/feed × `move_time_factor` + `move_extra_s`.
    pub move_time_factor: f64,
    /// Time added to every move (s): acceleration and deceleration.
    pub move_extra_s: f64,
    /// Frames the cameras failed to save.
    pub dropped: Vec<DroppedFrame>,
    /// Stray triggers during moves (triggered mode).
    pub stray: Vec<StrayFrame>,
    /// Continuous: recording before the first move and after the last dwell (s).
    pub lead_s: f64,
    /// Continuous: extra frames the machine stays still after the last capture.
    pub dwell_extra_frames: u32,
    /// Continuous: sub-positions over each exposure (1: no motion blur).
    pub blur_steps: u32,
}

impl Default for CaptureConfig {
    fn default() -> Self {
        Self {
            mode: CaptureMode::Manifest,
            clock_offset_s: [0.0, 2.375, -3.8125],
            first_number: [1, 4711, 20_017],
            file_prefix: "IMG_".into(),
            move_time_factor: 1.15,
            move_extra_s: 0.0,
            dropped: Vec::new(),
            stray: Vec::new(),
            lead_s: 0.25,
            dwell_extra_frames: 0,
            blur_steps: 1,
        }
    }
}

/// A configuration error naming `capture.{key}`.
pub(crate) fn bad(key: &str, message: impl std::fmt::Display) -> SynthError {
    super::check::bad(&format!("capture.{key}"), message)
}

impl CaptureConfig {
    /// The renderer's own layout (the table can be left out of `config.toml`).
    pub fn is_manifest(&self) -> bool {
        self.mode == CaptureMode::Manifest
    }

    /// Check every value against the rest of the configuration; the error names the key.
    pub fn validate(&self, config: &Config) -> Result<()> {
        for (i, v) in self.clock_offset_s.iter().enumerate() {
            if !v.is_finite() {
                return Err(bad(&format!("clock_offset_s[{i}]"), "not a finite number"));
            }
        }
        positive("capture.move_time_factor", self.move_time_factor)?;
        non_negative("capture.move_extra_s", self.move_extra_s)?;
        non_negative("capture.lead_s", self.lead_s)?;
        if !(1..=64).contains(&self.blur_steps) {
            return Err(bad(
                "blur_steps",
                format!("{} must be 1..=64", self.blur_steps),
            ));
        }
        if !self
            .file_prefix
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return Err(bad(
                "file_prefix",
                format!(
                    "'{}' may hold only letters, digits, _ and -",
                    self.file_prefix
                ),
            ));
        }
        let camera_ok = |c: u8| config.rig.cameras.iter().any(|k| k.id == c);
        for (i, d) in self.dropped.iter().enumerate() {
            if !camera_ok(d.camera) {
                return Err(bad(
                    &format!("dropped[{i}].camera"),
                    format!("camera {} is not in the rig", d.camera),
                ));
            }
        }
        for (i, s) in self.stray.iter().enumerate() {
            if !camera_ok(s.camera) {
                return Err(bad(
                    &format!("stray[{i}].camera"),
                    format!("camera {} is not in the rig", s.camera),
                ));
            }
            if s.dwell == 0 {
                return Err(bad(
                    &format!("stray[{i}].dwell"),
                    "the first dwell has no move before it",
                ));
            }
        }
        if self.mode == CaptureMode::Continuous {
            if !self.stray.is_empty() {
                return Err(bad("stray", "stray triggers apply to triggered capture"));
            }
            if config.sensor.exposure_s > 0.5 / config.procedure.fps {
                return Err(bad(
                    "mode",
                    format!(
                        "continuous capture needs exposures of at most half a frame period: \
                         sensor.exposure_s {} s at {} fps",
                        config.sensor.exposure_s, config.procedure.fps
                    ),
                ));
            }
        }
        if self.mode != CaptureMode::Manifest {
            for c in &config.rig.cameras {
                if c.serial.is_empty()
                    || c.serial == "."
                    || c.serial == ".."
                    || c.serial.contains(['/', '\\'])
                {
                    return Err(super::check::bad(
                        &format!("rig.cameras[id = {}].serial", c.id),
                        format!("'{}' cannot name the camera's folder", c.serial),
                    ));
                }
            }
        }
        Ok(())
    }
}
