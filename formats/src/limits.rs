//! Limits on sizes that untrusted files claim, checked before anything is
//! allocated from them: an image header may claim 4294967295 × 4294967295
//! pixels in a file of a few hundred bytes.

/// Largest image side (px) any stage accepts: 65 536, beyond any camera
/// sensor. It keeps the exact integer sums of extraction in range: the
/// second moment of a saturated run across a whole row,
/// `Σ 65535·dx² < 65535·65536³/3 < 2⁶⁴`, fits the `u64` of a run.
pub const MAX_IMAGE_SIDE_PX: u32 = 1 << 16;

/// Default largest image (pixels): 2²⁸ = 268 435 456 px, 21 times the
/// seed's 4096 × 3072 frame; such a frame takes 512 MiB as 16-bit
/// values, which every reader of a parallel batch must be able to hold.
/// Commands that read images override it with `--max-pixels`.
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 28;

/// Why an image size is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SizeError {
    /// No pixels.
    Empty {
        /// Width claimed (px).
        width: u64,
        /// Height claimed (px).
        height: u64,
    },
    /// A side beyond [`MAX_IMAGE_SIDE_PX`].
    Side {
        /// Width claimed (px).
        width: u64,
        /// Height claimed (px).
        height: u64,
    },
    /// More pixels than the limit.
    Pixels {
        /// Width claimed (px).
        width: u64,
        /// Height claimed (px).
        height: u64,
        /// The limit (pixels).
        max_pixels: u64,
    },
}

impl std::fmt::Display for SizeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            SizeError::Empty { width, height } => {
                write!(f, "the image claims {width}×{height} px: it has no pixels")
            }
            SizeError::Side { width, height } => write!(
                f,
                "the image claims {width}×{height} px, more than {MAX_IMAGE_SIDE_PX} px a side \
                 (no camera sensor is that large: a damaged or hostile header?)"
            ),
            SizeError::Pixels {
                width,
                height,
                max_pixels,
            } => write!(
                f,
                "the image claims {width}×{height} px = {} pixels, more than the limit of \
                 {max_pixels}",
                width * height
            ),
        }
    }
}

/// Check an image size read from a header before anything is allocated for
/// it: each side in `1..=MAX_IMAGE_SIDE_PX` and `width × height ≤ max_pixels`.
pub fn check_image_size(width: u64, height: u64, max_pixels: u64) -> Result<(), SizeError> {
    if width == 0 || height == 0 {
        return Err(SizeError::Empty { width, height });
    }
    let side = u64::from(MAX_IMAGE_SIDE_PX);
    if width > side || height > side {
        return Err(SizeError::Side { width, height });
    }
    if width * height > max_pixels {
        return Err(SizeError::Pixels {
            width,
            height,
            max_pixels,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_checked_without_overflow() {
        assert!(check_image_size(4096, 3072, DEFAULT_MAX_PIXELS).is_ok());
        assert!(check_image_size(65536, 4096, DEFAULT_MAX_PIXELS).is_ok());
        let e = check_image_size(u64::from(u32::MAX), u64::from(u32::MAX), DEFAULT_MAX_PIXELS)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("4294967295×4294967295") && e.contains("a side"),
            "{e}"
        );
        let e = check_image_size(20000, 20000, DEFAULT_MAX_PIXELS)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("400000000 pixels") && e.contains("268435456"),
            "{e}"
        );
        assert!(check_image_size(0, 5, DEFAULT_MAX_PIXELS).is_err());
        assert!(check_image_size(3, 3, 8).is_err());
        assert!(check_image_size(2, 4, 8).is_ok());
    }
}
