//! The renderer's configuration: rig, optics, sensor, spheres, procedure,
//! injected machine errors, calibration target and output. Read from TOML;
//! every key is optional and defaults to the seed's rig and procedure
//! ([`DEFAULT_TOML`], printed by `trinocular synth config`).
//!
//! Units: lengths in mm unless the key says otherwise (`_um` micrometres,
//! `_deg` degrees, `_urad` microradians, `_e` electrons, `_dn` digital numbers,
//! `_s` seconds). Injected error curves are in µm (translations) and µrad
//! (rotations).

mod board;
mod capture;
mod check;
mod machine;
mod optics;
mod output;
mod overrides;
mod rig;
mod sensor;
mod spheres;
mod target;

use std::path::Path;

/// The `[procedure]` table: one record shared with `program.toml` (`formats::capture`).
pub use formats::{AxisProcedure, ProcedureConfig};
use serde::{Deserialize, Serialize};

pub use crate::lens_profile::LensProfile;
pub use board::BoardConfig;
pub(crate) use capture::bad as bad_capture;
pub use capture::{CaptureConfig, CaptureMode, DroppedFrame, StrayFrame};
pub(crate) use check::{bad, finite, non_negative, positive};
pub use machine::{AxisErrors, ErrorCurve, MachineConfig};
pub use optics::{IlluminationModel, OpticsConfig};
pub use output::{ImageFormat, OutputConfig, RenderConfig, TiffCompression};
pub use overrides::Overrides;
pub use rig::{CameraConfig, DistortionConfig, RigConfig, StrayLightConfig};
pub use sensor::SensorConfig;
pub use spheres::SphereConfig;
pub use target::TargetConfig;

use crate::{Result, SynthError};

/// Whether a value is its type's default (zero): keys that are off by
/// default are left out of the serialised configuration, so that a
/// configuration without them reads as before they existed.
pub(crate) fn is_default<T: Default + PartialEq>(x: &T) -> bool {
    *x == T::default()
}

/// The documented default configuration (the seed's rig and procedure), as
/// printed by `trinocular synth config`. Parses to [`Config::default`].
pub const DEFAULT_TOML: &str = include_str!("../default.toml");

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
    /// Printed chessboard (`synth board`).
    pub board: BoardConfig,
    /// Image files.
    pub output: OutputConfig,
    /// Rendering accuracy.
    pub render: RenderConfig,
    /// How the frames are written: the renderer's layout with `manifest.csv`
    /// (default), or as triggered or free-running cameras save them.
    #[serde(skip_serializing_if = "CaptureConfig::is_manifest")]
    pub capture: CaptureConfig,
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

/// Read the TOML file `path` and parse it with `parse` (a configuration's
/// `from_toml_str`); an unreadable file is an error naming it.
pub(crate) fn read_toml<T>(
    path: &Path,
    parse: impl FnOnce(&str, Option<&Path>) -> Result<T>,
) -> Result<T> {
    let text = std::fs::read_to_string(path).map_err(|e| SynthError::io(path, e))?;
    parse(&text, Some(path))
}

/// `value` as TOML.
pub(crate) fn to_toml<T: Serialize>(value: &T) -> Result<String> {
    toml::to_string_pretty(value).map_err(|e| SynthError::config(e.to_string()))
}

impl Config {
    /// Parse a TOML configuration; `path` names the source in errors. Unknown
    /// keys are errors naming the key.
    pub fn from_toml_str(text: &str, path: Option<&Path>) -> Result<Self> {
        parse_toml(text, path, Config::validate)
    }

    /// Read a TOML configuration file.
    pub fn from_file(path: &Path) -> Result<Self> {
        read_toml(path, Self::from_toml_str)
    }

    /// The configuration as TOML (without the comments of [`DEFAULT_TOML`]).
    pub fn to_toml(&self) -> Result<String> {
        to_toml(self)
    }

    /// Check every value, table by table in the order of the file; the
    /// error names the key.
    pub fn validate(&self) -> Result<()> {
        self.sensor.validate()?;
        self.optics.validate(&self.sensor)?;
        self.rig.validate()?;
        SphereConfig::validate_set(&self.spheres)?;
        let p = &self.procedure;
        p.validate().map_err(|e| bad(&e.key, e.message))?;
        crate::datetime::parse(&p.start_time).map_err(|m| bad("procedure.start_time", m))?;
        self.machine.validate()?;
        self.target.validate()?;
        self.board.validate()?;
        self.output.validate()?;
        self.capture.validate(self)?;
        self.render.validate()
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
            board: BoardConfig::default(),
            output: OutputConfig::default(),
            render: RenderConfig::default(),
            capture: CaptureConfig::default(),
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
    fn tables_are_checked_in_file_order() {
        // Every table wrong: the first table's error is the one reported.
        let text = "[sensor]\nbits = 12\n[optics]\nf_number = 0\n[rig]\ncameras = []\n\
                    [target]\ngrid = 4\n[render]\nmax_depth = 0\n";
        let e = Config::from_toml_str(text, None).unwrap_err().to_string();
        assert_eq!(e, "configuration: sensor.bits: 12 must be 8 or 16");
        let e = Config::from_toml_str("[target]\ngrid = 4\n[render]\nmax_depth = 0\n", None)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "configuration: target.grid: 4 must be ≥ 5, at most 101 and coprime with 6 (5, 7, 11, ...)"
        );
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
}
