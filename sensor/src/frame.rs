//! Decoded frames and the checks that a stack of them comes from one camera
//! with one setting (issue 24 item 8).

use formats::limits::{DEFAULT_MAX_PIXELS, check_image_size};

use crate::{Result, SensorError};

/// Largest relative difference of two exposure times still "the same
/// setting": EXIF writes them as rationals, which round a time to about 1e-6.
const EXPOSURE_TOLERANCE: f64 = 1e-4;

/// A decoded frame of one camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame<'a> {
    /// Pixel values (DN as stored in the file), row-major, `width × height`.
    pub values: &'a [u16],
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Bit depth of the file: 8 or 16.
    pub container_bits: u8,
    /// EXIF ExposureTime (s) when present.
    pub exposure_s: Option<f64>,
}

impl Frame<'_> {
    /// Number of pixels.
    pub(crate) fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// Which stack a frame belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StackKind {
    /// Flat-field frames: a uniform radiance source.
    Flat,
    /// Dark frames: the lens covered.
    Dark,
    /// Repeated captures of one instant (measurement images), in pairs.
    Repeat,
}

impl std::fmt::Display for StackKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StackKind::Flat => "flat",
            StackKind::Dark => "dark",
            StackKind::Repeat => "repeated-capture",
        })
    }
}

/// The refusals of issue 24 item 8 for one stack: an empty stack; a frame
/// whose buffer does not hold its size or whose size no sensor has; sizes,
/// container bit depths or exposure times that differ within the stack
/// (the error names the first frame that differs from frame 0, and both
/// values).
pub fn check_stack(frames: &[Frame<'_>], kind: StackKind) -> Result<()> {
    let first = frames.first().ok_or(SensorError::EmptyStack { kind })?;
    for (index, frame) in frames.iter().enumerate() {
        check_frame(frame, kind, index)?;
        check_same_camera(frame, kind, index, first, kind)?;
        if !same_exposure(frame.exposure_s, first.exposure_s) {
            return Err(SensorError::ExposureDiffers {
                kind,
                frame: index,
                exposure_s: frame.exposure_s,
                first_exposure_s: first.exposure_s,
            });
        }
    }
    Ok(())
}

/// A frame's own consistency: a size within the limits of any sensor and a
/// buffer of exactly that many values.
pub(crate) fn check_frame(frame: &Frame<'_>, kind: StackKind, index: usize) -> Result<()> {
    check_image_size(
        u64::from(frame.width),
        u64::from(frame.height),
        DEFAULT_MAX_PIXELS,
    )
    .map_err(|e| SensorError::FrameSize {
        kind,
        frame: index,
        message: e.to_string(),
    })?;
    if frame.values.len() != frame.pixels() {
        return Err(SensorError::FrameLength {
            kind,
            frame: index,
            len: frame.values.len(),
            width: frame.width,
            height: frame.height,
        });
    }
    Ok(())
}

/// The same size and container bit depth as the reference frame (frame 0
/// of `first_kind`'s stack).
pub(crate) fn check_same_camera(
    frame: &Frame<'_>,
    kind: StackKind,
    index: usize,
    first: &Frame<'_>,
    first_kind: StackKind,
) -> Result<()> {
    if (frame.width, frame.height) != (first.width, first.height) {
        return Err(SensorError::SizeDiffers {
            kind,
            frame: index,
            width: frame.width,
            height: frame.height,
            first_kind,
            first_width: first.width,
            first_height: first.height,
        });
    }
    if frame.container_bits != first.container_bits {
        return Err(SensorError::BitDepthDiffers {
            kind,
            frame: index,
            bits: frame.container_bits,
            first_kind,
            first_bits: first.container_bits,
        });
    }
    Ok(())
}

/// Two EXIF exposure times of one setting: both absent, or equal within
/// [`EXPOSURE_TOLERANCE`].
pub(crate) fn same_exposure(a: Option<f64>, b: Option<f64>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => (a - b).abs() <= EXPOSURE_TOLERANCE * a.abs().max(b.abs()),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposure_times_match_within_rational_rounding() {
        assert!(same_exposure(Some(0.004), Some(0.004_000_1)));
        assert!(!same_exposure(Some(0.004), Some(0.005)));
        assert!(!same_exposure(Some(0.004), None));
        assert!(same_exposure(None, None));
    }
}
