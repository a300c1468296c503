//! Optional denoising before thresholding: 3×3 median or Gaussian.

use image::{ImageBuffer, Luma};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::frame::{Frame, FrameView};

/// Denoising filter applied before thresholding.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum Denoise {
    /// No filtering (default: the centroid of a symmetric blob needs none).
    #[default]
    None,
    /// 3×3 median (removes hot pixels and impulse noise).
    Median3,
    /// Gaussian of standard deviation `sigma` px (imageproc).
    Gaussian {
        /// Standard deviation (px).
        sigma: f32,
    },
}

/// Median of nine values by a 19-exchange sorting network (Paeth's `opt_med9`).
#[inline(always)]
fn median9(mut p: [u16; 9]) -> u16 {
    macro_rules! sort2 {
        ($a:expr, $b:expr) => {
            if p[$a] > p[$b] {
                p.swap($a, $b);
            }
        };
    }
    sort2!(1, 2);
    sort2!(4, 5);
    sort2!(7, 8);
    sort2!(0, 1);
    sort2!(3, 4);
    sort2!(6, 7);
    sort2!(1, 2);
    sort2!(4, 5);
    sort2!(7, 8);
    sort2!(0, 3);
    sort2!(5, 8);
    sort2!(4, 7);
    sort2!(3, 6);
    sort2!(1, 4);
    sort2!(2, 5);
    sort2!(4, 7);
    sort2!(4, 2);
    sort2!(6, 4);
    sort2!(4, 2);
    p[4]
}

/// 3×3 median with edge replication. Written here because imageproc's
/// `median_filter` accepts only 8-bit subpixels and the frames are 16-bit.
pub fn median3(frame: &FrameView<'_>) -> Frame {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let mut out = vec![0u16; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let rows =
            [y.saturating_sub(1), y, (y + 1).min(h - 1)].map(|r| &frame.pixels[r * w..(r + 1) * w]);
        for (x, o) in row.iter_mut().enumerate() {
            let cols = [x.saturating_sub(1), x, (x + 1).min(w - 1)];
            let mut p = [0u16; 9];
            for (i, r) in rows.iter().enumerate() {
                for (j, &c) in cols.iter().enumerate() {
                    p[i * 3 + j] = r[c];
                }
            }
            *o = median9(p);
        }
    });
    Frame {
        width: frame.width,
        height: frame.height,
        bit_depth: frame.bit_depth,
        pixels: out,
    }
}

/// Gaussian blur through imageproc (f32 arithmetic, rounded back to DN).
pub fn gaussian(frame: &FrameView<'_>, sigma: f32) -> Frame {
    let img: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_raw(frame.width, frame.height, frame.pixels.to_vec())
            .unwrap_or_else(|| ImageBuffer::new(frame.width, frame.height));
    let blurred = imageproc::filter::gaussian_blur_f32(&img, sigma);
    Frame {
        width: frame.width,
        height: frame.height,
        bit_depth: frame.bit_depth,
        pixels: blurred.into_raw(),
    }
}

/// Apply the filter; `None` when there is nothing to do.
pub fn apply(frame: &FrameView<'_>, denoise: Denoise) -> Option<Frame> {
    match denoise {
        Denoise::None => None,
        Denoise::Median3 => Some(median3(frame)),
        Denoise::Gaussian { sigma } => Some(gaussian(frame, sigma)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn median9_matches_sorting(p in proptest::array::uniform9(any::<u16>())) {
            let mut s = p;
            s.sort_unstable();
            prop_assert_eq!(median9(p), s[4]);
        }
    }

    #[test]
    fn median_removes_a_hot_pixel() {
        let mut px = vec![100u16; 25];
        px[12] = 60_000;
        let f = FrameView::new(5, 5, 16, &px).unwrap();
        assert!(median3(&f).pixels.iter().all(|&p| p == 100));
    }
}
