//! The crate's error.

use thiserror::Error;

use crate::frame::StackKind;
use crate::maps::MapKind;

/// Result with [`SensorError`].
pub type Result<T> = std::result::Result<T, SensorError>;

/// Why a stack or a map cannot be used. `frame` is the index of the frame
/// in its stack (0-based); the caller names the file.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SensorError {
    /// A stack without frames.
    #[error("the {kind} stack is empty: at least one frame is needed")]
    EmptyStack {
        /// Which stack.
        kind: StackKind,
    },
    /// A frame whose pixel buffer does not hold width × height values.
    #[error("{kind} frame {frame}: {len} values for a {width}×{height} frame")]
    FrameLength {
        /// Which stack.
        kind: StackKind,
        /// Frame index.
        frame: usize,
        /// Values held.
        len: usize,
        /// Width claimed (px).
        width: u32,
        /// Height claimed (px).
        height: u32,
    },
    /// A frame with no pixels or a side beyond any sensor.
    #[error("{kind} frame {frame}: {message}")]
    FrameSize {
        /// Which stack.
        kind: StackKind,
        /// Frame index.
        frame: usize,
        /// What is wrong with the size.
        message: String,
    },
    /// A stack handed to [`crate::master`] whose frames do not share frame 0's
    /// size (check it first with [`crate::check_stack`], which names the
    /// stack).
    #[error("frame {frame} of the stack: {message}")]
    InconsistentStack {
        /// Frame index.
        frame: usize,
        /// What does not fit.
        message: String,
    },
    /// Frames of one stack, or the flat and dark stacks, of different sizes.
    #[error(
        "{kind} frame {frame} is {width}×{height} px where frame 0 of the {first_kind} stack is \
         {first_width}×{first_height} px: a stack must come from one camera with one setting"
    )]
    SizeDiffers {
        /// Stack of the differing frame.
        kind: StackKind,
        /// Its index.
        frame: usize,
        /// Its width (px).
        width: u32,
        /// Its height (px).
        height: u32,
        /// Stack of the reference frame.
        first_kind: StackKind,
        /// Reference width (px).
        first_width: u32,
        /// Reference height (px).
        first_height: u32,
    },
    /// Frames of different container bit depths.
    #[error(
        "{kind} frame {frame} is a {bits}-bit file where frame 0 of the {first_kind} stack is \
         {first_bits}-bit"
    )]
    BitDepthDiffers {
        /// Stack of the differing frame.
        kind: StackKind,
        /// Its index.
        frame: usize,
        /// Its container bit depth.
        bits: u8,
        /// Stack of the reference frame.
        first_kind: StackKind,
        /// Reference container bit depth.
        first_bits: u8,
    },
    /// Frames of one stack taken with different exposure times (EXIF).
    #[error(
        "{kind} frame {frame} has exposure time {} where frame 0 has {}: a stack must be taken \
         with one exposure setting",
        exposure_text(*exposure_s),
        exposure_text(*first_exposure_s)
    )]
    ExposureDiffers {
        /// Which stack.
        kind: StackKind,
        /// Frame index.
        frame: usize,
        /// Its exposure time (s), `None` when the file has none.
        exposure_s: Option<f64>,
        /// Exposure time of frame 0 (s).
        first_exposure_s: Option<f64>,
    },
    /// A stack too small for what is asked of it.
    #[error("the {kind} stack has {frames} frame(s): {what} needs at least {needed}")]
    StackTooSmall {
        /// Which stack.
        kind: StackKind,
        /// Frames in it.
        frames: usize,
        /// Frames needed.
        needed: usize,
        /// What needs them.
        what: String,
    },
    /// A flat stack with saturated pixels.
    #[error(
        "the flat stack is saturated: {:.3} % of the pixels reach {saturation_dn} DN in some \
         frame (limit {:.3} %); shorten the exposure or dim the source",
        fraction * 100.0,
        limit * 100.0
    )]
    SaturatedFlat {
        /// Fraction of pixels at saturation in any frame.
        fraction: f64,
        /// The largest fraction accepted.
        limit: f64,
        /// The saturation value (DN).
        saturation_dn: u16,
    },
    /// A flat too dim for photon transfer or a gain map.
    #[error(
        "the flat stack is under-exposed: its level is {signal_dn:.1} DN above the dark, below \
         {needed_dn:.1} DN ({reason}); lengthen the exposure or brighten the source"
    )]
    UnderexposedFlat {
        /// Mean level of the master flat above the master dark (DN).
        signal_dn: f64,
        /// The smallest level accepted (DN).
        needed_dn: f64,
        /// Which criterion sets it.
        reason: String,
    },
    /// A dark frame stack with light in it.
    #[error(
        "the dark stack has light in it: its mean level {level_dn:.1} DN is {above_dn:.1} DN \
         above its own 1st percentile {percentile1_dn:.1} DN (limit {above_limit_dn:.1} DN, 10 % \
         of the full scale {full_scale_dn} DN) or above {bright_limit_dn:.1} DN (20 % of the full \
         scale); cover the lens"
    )]
    DarkWithLight {
        /// Mean level of the master dark (DN).
        level_dn: f64,
        /// Its 1st percentile (DN).
        percentile1_dn: f64,
        /// `level − percentile1` (DN).
        above_dn: f64,
        /// Largest `level − percentile1` accepted (DN).
        above_limit_dn: f64,
        /// Largest level accepted (DN).
        bright_limit_dn: f64,
        /// Full scale (DN).
        full_scale_dn: u16,
    },
    /// A flat whose level is not above its dark's.
    #[error(
        "the flat stack (mean {flat_dn:.1} DN) is not brighter than the dark stack (mean \
         {dark_dn:.1} DN): were the stacks swapped, or the lens covered?"
    )]
    FlatDarkerThanDark {
        /// Mean level of the master flat (DN).
        flat_dn: f64,
        /// Mean level of the master dark (DN).
        dark_dn: f64,
    },
    /// A flat whose temporal noise is not above the dark's: no shot noise,
    /// no photon transfer.
    #[error(
        "photon transfer: the flat's temporal variance {flat_var_dn2:.2} DN² is not above the \
         dark's {dark_var_dn2:.2} DN²: the flat shows no shot noise (a processed or synthetic \
         image?)"
    )]
    NoShotNoise {
        /// σ²_y of the flat (DN²).
        flat_var_dn2: f64,
        /// σ²_y of the dark (DN²).
        dark_var_dn2: f64,
    },
    /// Repeated captures without two levels far enough apart to show the
    /// rise of the noise with the signal.
    #[error(
        "the repeated captures give no system gain: {pixels} flat pixel differences over levels \
         {low_dn:.0}…{high_dn:.0} DN show no rise of the noise with the signal (they need flat \
         bright regions, e.g. sphere interiors of ≥ 100 px, besides the background)"
    )]
    NoGainFromRepeats {
        /// Lowest level fitted (DN).
        low_dn: f64,
        /// Highest level fitted (DN).
        high_dn: f64,
        /// Pixel differences used.
        pixels: u64,
    },
    /// The smooth model of the flat is not positive and finite at a pixel.
    #[error("the smooth model of the flat is {value} at pixel ({x}, {y}): it must be positive")]
    SmoothModel {
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// The model's value.
        value: f64,
    },
    /// A map or a frame whose size does not fit.
    #[error("{what}: {message}")]
    MapSize {
        /// Which map or frame.
        what: String,
        /// What does not fit.
        message: String,
    },
    /// A map value that cannot be used.
    #[error("{what} at pixel ({x}, {y}) is {value}: {expected}")]
    MapValue {
        /// Which map.
        what: String,
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// The value.
        value: f64,
        /// What it must be.
        expected: String,
    },
    /// A map file that cannot be encoded or decoded.
    #[error("map file: {0}")]
    MapFile(String),
    /// A map file whose bytes are not those its record's checksum was taken of.
    #[error(
        "its checksum is {found}, but the rig records {recorded} (the file was changed or replaced)"
    )]
    MapChecksum {
        /// CRC-32 of the file's bytes.
        found: String,
        /// CRC-32 the record gives.
        recorded: String,
    },
    /// A map file of another size than its camera's.
    #[error("the map is {width}×{height} px, but the camera is {camera_width}×{camera_height} px")]
    MapOfOtherSize {
        /// The map's width (px).
        width: u32,
        /// The map's height (px).
        height: u32,
        /// The camera's width (px).
        camera_width: u32,
        /// The camera's height (px).
        camera_height: u32,
    },
    /// One of a camera's map files cannot be used ([`crate::maps::decode_maps`]).
    #[error("the {kind} map: {fault}")]
    Map {
        /// Which map.
        kind: MapKind,
        /// Why.
        fault: Box<SensorError>,
    },
}

/// An exposure time for a message: `1/250 s`, `0.004 s` or `absent`.
fn exposure_text(exposure_s: Option<f64>) -> String {
    match exposure_s {
        None => "absent".into(),
        Some(t) if t > 0.0 && t < 1.0 && ((1.0 / t) - (1.0 / t).round()).abs() < 1e-6 => {
            format!("1/{} s", (1.0 / t).round())
        }
        Some(t) => format!("{t} s"),
    }
}

impl SensorError {
    /// The index of the frame at fault in its stack, when one frame is.
    pub fn frame(&self) -> Option<usize> {
        match self {
            SensorError::FrameLength { frame, .. }
            | SensorError::FrameSize { frame, .. }
            | SensorError::InconsistentStack { frame, .. }
            | SensorError::SizeDiffers { frame, .. }
            | SensorError::BitDepthDiffers { frame, .. }
            | SensorError::ExposureDiffers { frame, .. } => Some(*frame),
            _ => None,
        }
    }

    /// The stack at fault, when one is.
    pub fn stack(&self) -> Option<StackKind> {
        match self {
            SensorError::EmptyStack { kind }
            | SensorError::FrameLength { kind, .. }
            | SensorError::FrameSize { kind, .. }
            | SensorError::SizeDiffers { kind, .. }
            | SensorError::BitDepthDiffers { kind, .. }
            | SensorError::ExposureDiffers { kind, .. }
            | SensorError::StackTooSmall { kind, .. } => Some(*kind),
            SensorError::SaturatedFlat { .. } | SensorError::UnderexposedFlat { .. } => {
                Some(StackKind::Flat)
            }
            SensorError::DarkWithLight { .. } => Some(StackKind::Dark),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposure_times_read_as_cameras_write_them() {
        assert_eq!(exposure_text(Some(0.004)), "1/250 s");
        assert_eq!(exposure_text(Some(0.0042)), "0.0042 s");
        assert_eq!(exposure_text(None), "absent");
    }
}
