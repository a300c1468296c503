//! Reading 8- and 16-bit grayscale TIFF and PNG files into reused buffers.
//!
//! Decoding into a fresh 25 MB buffer per frame costs several times the decode
//! itself (allocation and page faults), so a [`FrameReader`] keeps the file
//! bytes and the pixel buffer between frames. The file is read once; the
//! pixels and the metadata tags are both parsed from that one buffer.

use std::io::{Cursor, Read};
use std::path::Path;

use image::{ColorType, ImageDecoder, ImageFormat, ImageReader};

use crate::frame::FrameView;
use crate::metadata::FrameMetadata;
use crate::{ExtractError, Result};

/// Reads frames one after another, reusing its buffers.
#[derive(Debug, Default)]
pub struct FrameReader {
    bytes: Vec<u8>,
    pixels: Vec<u16>,
    narrow: Vec<u8>,
    /// Bit depth every frame must have, if set (8 or 16).
    expected_depth: Option<u8>,
}

impl FrameReader {
    /// A reader with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Require every frame to have this bit depth (8 or 16).
    pub fn expect_bit_depth(mut self, depth: Option<u8>) -> Self {
        self.expected_depth = depth;
        self
    }

    /// Read and decode `path`; the frame borrows the reader's buffer until the next call.
    pub fn read(&mut self, path: &Path) -> Result<(FrameView<'_>, FrameMetadata)> {
        self.bytes.clear();
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_end(&mut self.bytes))
            .map_err(|source| ExtractError::Io {
                path: path.to_path_buf(),
                source,
            })?;
        self.decode(path)
    }

    /// Decode image bytes already in memory (`path` names them in errors).
    pub fn read_bytes(&mut self, bytes: &[u8], path: &Path) -> Result<(FrameView<'_>, FrameMetadata)> {
        self.bytes.clear();
        self.bytes.extend_from_slice(bytes);
        self.decode(path)
    }

    fn decode(&mut self, path: &Path) -> Result<(FrameView<'_>, FrameMetadata)> {
        let decode_err = |e: image::ImageError| ExtractError::Decode {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        if self.bytes.is_empty() {
            return Err(ExtractError::Decode {
                path: path.to_path_buf(),
                message: "the file is empty".into(),
            });
        }
        let format = image::guess_format(&self.bytes).map_err(decode_err)?;
        let metadata = match format {
            ImageFormat::Tiff => FrameMetadata::from_tiff_bytes(&self.bytes),
            ImageFormat::Png => FrameMetadata::from_png_bytes(&self.bytes),
            other => {
                return Err(ExtractError::Unsupported {
                    path: path.to_path_buf(),
                    message: format!("{other:?} images are not supported (use 8- or 16-bit grayscale TIFF or PNG)"),
                });
            }
        };
        let decoder = ImageReader::with_format(Cursor::new(&self.bytes[..]), format)
            .into_decoder()
            .map_err(decode_err)?;
        let (width, height) = decoder.dimensions();
        if width == 0 || height == 0 {
            return Err(ExtractError::Unsupported {
                path: path.to_path_buf(),
                message: "image has zero size".into(),
            });
        }
        let depth = match decoder.color_type() {
            ColorType::L16 => 16,
            ColorType::L8 => 8,
            other => {
                return Err(ExtractError::Unsupported {
                    path: path.to_path_buf(),
                    message: format!(
                        "{other:?} image: only 8- or 16-bit single-channel grayscale is supported"
                    ),
                });
            }
        };
        if let Some(expected) = self.expected_depth.filter(|e| *e != depth) {
            return Err(ExtractError::Unsupported {
                path: path.to_path_buf(),
                message: format!("{depth}-bit image where {expected}-bit images are expected"),
            });
        }
        let n = width as usize * height as usize;
        self.pixels.resize(n, 0);
        if depth == 16 {
            decoder
                .read_image(bytemuck::cast_slice_mut(&mut self.pixels[..]))
                .map_err(decode_err)?;
        } else {
            self.narrow.resize(n, 0);
            decoder.read_image(&mut self.narrow[..]).map_err(decode_err)?;
            for (d, s) in self.pixels.iter_mut().zip(&self.narrow) {
                *d = u16::from(*s);
            }
        }
        let view = FrameView::new(width, height, depth, &self.pixels).map_err(|e| e.in_file(path))?;
        Ok((view, metadata))
    }
}
