//! The `[sensor]` table.

use serde::{Deserialize, Serialize};

use super::check::{bad, finite, non_negative, positive};
use super::is_default;
use crate::Result;
use crate::pattern::PatternParams;

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
    /// Resolution of the ADC (bits): 8 for 8-bit files; 10, 12, 14 or 16 for
    /// 16-bit files, the ADC's value written shifted left into the 16-bit
    /// file (a 12-bit value v is stored as 16·v). The ADC quantises in its
    /// own DN; `gain_dn_per_e` and `offset_dn` stay in the file's DN.
    /// 0 (default): the file's own depth.
    #[serde(skip_serializing_if = "is_default")]
    pub adc_bits: u8,
    /// Photo-response non-uniformity: relative σ of each pixel's gain
    /// (Gaussian, the gain `1 + g` clamped at 0). 0: off.
    #[serde(skip_serializing_if = "is_default")]
    pub prnu: f64,
    /// Dark-signal non-uniformity: σ of each pixel's dark offset (file DN). 0: off.
    #[serde(skip_serializing_if = "is_default")]
    pub dsnu_dn: f64,
    /// σ of an offset shared by each column (file DN). 0: off.
    #[serde(skip_serializing_if = "is_default")]
    pub column_offset_dn: f64,
    /// σ of an offset shared by each row (file DN). 0: off.
    #[serde(skip_serializing_if = "is_default")]
    pub row_offset_dn: f64,
    /// Hot pixels per camera, at distinct uniformly drawn positions. 0: none.
    #[serde(skip_serializing_if = "is_default")]
    pub hot_pixels: u32,
    /// `[min, max]` extra dark electrons per exposure of a hot pixel, drawn
    /// uniformly per pixel (shot noise on them; in dark frames too).
    #[serde(skip_serializing_if = "is_default")]
    pub hot_pixel_e: [f64; 2],
    /// Dead pixels per camera (no response to light: offset and read noise
    /// only), at positions distinct from the hot pixels. 0: none.
    #[serde(skip_serializing_if = "is_default")]
    pub dead_pixels: u32,
    /// Flat-field and dark frames per camera: 1 (default) writes
    /// `calib/flat_cam{k}.EXT` and `calib/dark_cam{k}.EXT`; N > 1 a stack of
    /// N frames in each of the folders `calib/flat_cam{k}/` and
    /// `calib/dark_cam{k}/` (independent temporal noise, the same fixed pattern).
    #[serde(skip_serializing_if = "is_one")]
    pub calibration_frames: u32,
}

fn is_one(n: &u32) -> bool {
    *n == 1
}

/// Most calibration frames of a stack.
const MAX_CALIBRATION_FRAMES: u32 = 1000;

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
            adc_bits: 0,
            prnu: 0.0,
            dsnu_dn: 0.0,
            column_offset_dn: 0.0,
            row_offset_dn: 0.0,
            hot_pixels: 0,
            hot_pixel_e: [0.0, 0.0],
            dead_pixels: 0,
            calibration_frames: 1,
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
        positive("sensor.exposure_s", self.exposure_s)?;
        self.validate_readout()
    }

    /// Check the ADC and fixed-pattern keys.
    fn validate_readout(&self) -> Result<()> {
        let adc_ok = match self.bits {
            8 => matches!(self.adc_bits, 0 | 8),
            _ => matches!(self.adc_bits, 0 | 10 | 12 | 14 | 16),
        };
        if !adc_ok {
            return Err(bad(
                "sensor.adc_bits",
                format!(
                    "{} must be 8 for 8-bit files, 10, 12, 14 or 16 for 16-bit files (or 0: the \
                     file's depth)",
                    self.adc_bits
                ),
            ));
        }
        non_negative("sensor.prnu", self.prnu)?;
        if self.prnu > 0.5 {
            return Err(bad(
                "sensor.prnu",
                format!("{} must be at most 0.5", self.prnu),
            ));
        }
        non_negative("sensor.dsnu_dn", self.dsnu_dn)?;
        non_negative("sensor.column_offset_dn", self.column_offset_dn)?;
        non_negative("sensor.row_offset_dn", self.row_offset_dn)?;
        let [lo, hi] = self.hot_pixel_e;
        if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi) {
            return Err(bad(
                "sensor.hot_pixel_e",
                format!("[{lo}, {hi}] must be finite with 0 ≤ min ≤ max"),
            ));
        }
        if self.hot_pixels > 0 && hi <= 0.0 {
            return Err(bad(
                "sensor.hot_pixel_e",
                "hot pixels need a positive maximum of extra dark electrons",
            ));
        }
        let pixels = u64::from(self.width) * u64::from(self.height);
        let defects = u64::from(self.hot_pixels) + u64::from(self.dead_pixels);
        if 2 * defects > pixels {
            return Err(bad(
                "sensor.hot_pixels/dead_pixels",
                format!("{defects} defective pixels exceed half of the {pixels} pixels"),
            ));
        }
        if !(1..=MAX_CALIBRATION_FRAMES).contains(&self.calibration_frames) {
            return Err(bad(
                "sensor.calibration_frames",
                format!(
                    "{} must be between 1 and {MAX_CALIBRATION_FRAMES}",
                    self.calibration_frames
                ),
            ));
        }
        Ok(())
    }

    /// The fixed-pattern parameters.
    pub fn pattern(&self) -> PatternParams {
        PatternParams {
            prnu: self.prnu,
            dsnu_dn: self.dsnu_dn,
            column_offset_dn: self.column_offset_dn,
            row_offset_dn: self.row_offset_dn,
            hot_pixels: self.hot_pixels,
            hot_pixel_e: self.hot_pixel_e,
            dead_pixels: self.dead_pixels,
        }
    }

    /// Whether anything beyond the ideal readout is configured (an ADC of
    /// its own depth, a fixed pattern or calibration stacks).
    pub fn has_readout_model(&self) -> bool {
        (self.adc_bits != 0 && self.adc_bits != self.bits)
            || !self.pattern().is_none()
            || self.calibration_frames != 1
    }
}
