//! The `[sensor]` table.

use serde::{Deserialize, Serialize};

use super::check::{bad, finite, non_negative, positive};
use crate::Result;

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

impl SensorConfig {
    /// Check the sensor's values; the error names the key.
    pub(crate) fn validate(&self) -> Result<()> {
        if self.width < 16 || self.height < 16 {
            return Err(bad(
                "sensor.width/height",
                format!("{}×{} px is too small (≥ 16×16)", self.width, self.height),
            ));
        }
        formats::limits::check_image_size(
            u64::from(self.width),
            u64::from(self.height),
            formats::limits::DEFAULT_MAX_PIXELS,
        )
        .map_err(|e| bad("sensor.width/height", e))?;
        positive("sensor.pixel_mm", self.pixel_mm)?;
        if self.bits != 8 && self.bits != 16 {
            return Err(bad("sensor.bits", format!("{} must be 8 or 16", self.bits)));
        }
        positive("sensor.gain_dn_per_e", self.gain_dn_per_e)?;
        non_negative("sensor.offset_dn", self.offset_dn)?;
        non_negative("sensor.read_noise_e", self.read_noise_e)?;
        non_negative("sensor.background_e", self.background_e)?;
        finite("sensor.background_gradient_e", &self.background_gradient_e)?;
        positive("sensor.exposure_s", self.exposure_s)
    }
}
