//! What `calibrate` records of a camera's sensor in `rig.json` (`sensor`):
//! the ADC's bit depth, photon transfer (EMVA 1288), the fixed patterns, the
//! defect counts, the stacks they came from, and the per-pixel map files
//! written beside `rig.json` with their checksums. Absent: the camera's
//! frames are used as they are (no per-pixel correction), as before.

use serde::{Deserialize, Serialize};

/// One per-pixel map file beside `rig.json`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MapFile {
    /// File name, relative to the folder of `rig.json`.
    pub file: String,
    /// CRC-32 (IEEE) of the file's bytes, 8 lower-case hex digits.
    pub crc32: String,
}

/// The per-pixel maps a frame of the camera is corrected with.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct SensorMapFiles {
    /// Master dark (32-bit float, DN): subtracted pixel by pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dark: Option<MapFile>,
    /// Relative gain `1 + g` (32-bit float, median 1): divided pixel by pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain: Option<MapFile>,
    /// Defect codes (8-bit: 0 good, 1 hot, 2 dead, 3 weak, 4 strong).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub defects: Option<MapFile>,
}

/// Defective pixels found, by kind, and their 8-connected clusters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DefectCounts {
    /// Hot: the master dark far above its neighbourhood.
    pub hot: usize,
    /// Dead: no response to light.
    pub dead: usize,
    /// Weak: gain below the tolerance.
    pub weak: usize,
    /// Strong: gain above the tolerance.
    pub strong: usize,
    /// Clusters of more than one defective pixel.
    pub clusters: usize,
}

/// The stacks the sensor was calibrated from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StackRecord {
    /// Flat-field frames averaged.
    pub flats: usize,
    /// Dark frames averaged.
    pub darks: usize,
    /// Per-pixel noise of the master flat (DN), when the stack measures it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flat_noise_dn: Option<f64>,
    /// Per-pixel noise of the master dark (DN), when the stack measures it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dark_noise_dn: Option<f64>,
}

/// A camera's sensor as calibrated (`rig.json` → camera → `sensor`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorJson {
    /// Bits of the ADC (values written left-shifted into the file when fewer
    /// than the file's).
    pub adc_bits: u8,
    /// Bits per sample of the files.
    pub container_bits: u8,
    /// System gain K (file DN per electron), from photon transfer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain_dn_per_e: Option<f64>,
    /// Temporal dark noise σ_d (electrons), from photon transfer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub read_noise_e: Option<f64>,
    /// Photo-response non-uniformity: spatial σ of the gain map (relative).
    pub prnu: f64,
    /// Dark-signal non-uniformity: spatial σ of the master dark (DN).
    pub dsnu_dn: f64,
    /// Spatial σ of the master dark's column means (DN).
    pub column_dsnu_dn: f64,
    /// Median of the master dark (DN): the level a corrected frame keeps.
    pub black_level_dn: f64,
    /// The largest value of the files (saturation, DN).
    pub saturation_dn: u16,
    /// Defective pixels.
    pub defects: DefectCounts,
    /// The stacks.
    pub stack: StackRecord,
    /// The map files; a map that is absent is not applied.
    pub maps: SensorMapFiles,
    /// Further keys (the decisions and notes), kept as written.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}
