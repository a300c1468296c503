//! Grayscale frames: pixel values in native DN (8-bit frames keep 0..=255),
//! stored as `u16`, row-major, no padding.

use image::{ImageBuffer, Luma};

use crate::{ParameterProblem, Result};

/// A borrowed grayscale frame.
#[derive(Debug, Clone, Copy)]
pub struct FrameView<'a> {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Bits per sample of the source: 8 or 16 (sets the saturation level).
    pub bit_depth: u8,
    /// Row-major pixels, `width × height` values.
    pub pixels: &'a [u16],
}

impl<'a> FrameView<'a> {
    /// A view over `pixels`; fails unless the sizes agree and the depth is 8 or 16.
    pub fn new(width: u32, height: u32, bit_depth: u8, pixels: &'a [u16]) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(ParameterProblem::ZeroSize.into());
        }
        if pixels.len() != width as usize * height as usize {
            return Err(ParameterProblem::PixelCount {
                width,
                height,
                got: pixels.len(),
            }
            .into());
        }
        if bit_depth != 8 && bit_depth != 16 {
            return Err(ParameterProblem::BitDepth(bit_depth).into());
        }
        Ok(Self {
            width,
            height,
            bit_depth,
            pixels,
        })
    }

    /// A view of a 16-bit image buffer.
    pub fn from_image(img: &'a ImageBuffer<Luma<u16>, Vec<u16>>) -> Self {
        Self {
            width: img.width(),
            height: img.height(),
            bit_depth: 16,
            pixels: img.as_raw(),
        }
    }

    /// Largest representable value, `2^bit_depth − 1` (saturation).
    pub fn max_value(&self) -> u16 {
        if self.bit_depth == 8 {
            u8::MAX as u16
        } else {
            u16::MAX
        }
    }

    /// Row `y`.
    pub fn row(&self, y: u32) -> &'a [u16] {
        let w = self.width as usize;
        &self.pixels[y as usize * w..(y as usize + 1) * w]
    }

    /// The image centre (px, pixel-centre convention): `((W − 1)/2, (H − 1)/2)`.
    pub fn centre_px(&self) -> [f64; 2] {
        [
            (f64::from(self.width) - 1.0) / 2.0,
            (f64::from(self.height) - 1.0) / 2.0,
        ]
    }

    /// Half the image diagonal (px): `√(W² + H²)/2`.
    pub fn half_diagonal_px(&self) -> f64 {
        f64::from(self.width).hypot(f64::from(self.height)) / 2.0
    }

    /// The frame corrected pixel by pixel with a camera's sensor maps
    /// (master dark, gain map, defective pixels replaced: `sensor::SensorMaps::correct`),
    /// before its blobs are extracted; `None` without maps or with maps that
    /// change nothing (the frame is used as it is). Fails when the maps are
    /// of another size.
    pub fn corrected(&self, maps: Option<&sensor::SensorMaps>) -> Result<Option<Frame>> {
        let Some(maps) = maps.filter(|m| !m.is_identity()) else {
            return Ok(None);
        };
        let mut pixels = Vec::new();
        maps.correct(self.pixels, self.width, self.height, &mut pixels)
            .map_err(ParameterProblem::Sensor)?;
        Ok(Some(Frame {
            width: self.width,
            height: self.height,
            bit_depth: self.bit_depth,
            pixels,
        }))
    }
}

/// An owned grayscale frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Bits per sample: 8 or 16.
    pub bit_depth: u8,
    /// Row-major pixels.
    pub pixels: Vec<u16>,
}

impl Frame {
    /// Borrow as a view.
    pub fn view(&self) -> FrameView<'_> {
        FrameView {
            width: self.width,
            height: self.height,
            bit_depth: self.bit_depth,
            pixels: &self.pixels,
        }
    }

    /// A 16-bit frame from an image buffer.
    pub fn from_image(img: ImageBuffer<Luma<u16>, Vec<u16>>) -> Self {
        Self {
            width: img.width(),
            height: img.height(),
            bit_depth: 16,
            pixels: img.into_raw(),
        }
    }

    /// An 8-bit frame (values kept as 0..=255).
    pub fn from_image8(img: &ImageBuffer<Luma<u8>, Vec<u8>>) -> Self {
        Self {
            width: img.width(),
            height: img.height(),
            bit_depth: 8,
            pixels: img.as_raw().iter().map(|&p| u16::from(p)).collect(),
        }
    }
}
