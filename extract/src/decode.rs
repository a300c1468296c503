//! Reading 8- and 16-bit grayscale TIFF and PNG files into reused buffers.
//!
//! Decoding into a fresh 25 MB buffer per frame costs several times the decode
//! itself (allocation and page faults), so a [`FrameReader`] keeps the file
//! bytes and the pixel buffer between frames. The file is read once; the
//! pixels and the metadata tags are both parsed from that one buffer. TIFF is
//! decoded with the `tiff` crate straight into the reused pixel buffer (the
//! `image` crate's TIFF decoder would decode into a fresh buffer and copy);
//! PNG through the `image` crate.

use std::io::{Cursor, Read};
use std::path::Path;

use image::{ColorType, ImageDecoder, ImageFormat, ImageReader};
use tiff::decoder::Decoder as TiffDecoder;
use tiff::tags::{PhotometricInterpretation, SampleFormat, Tag};

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
    pub fn read_bytes(
        &mut self,
        bytes: &[u8],
        path: &Path,
    ) -> Result<(FrameView<'_>, FrameMetadata)> {
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
                    message: format!(
                        "{other:?} images are not supported (use 8- or 16-bit grayscale TIFF or PNG)"
                    ),
                });
            }
        };
        let mut buffers = Buffers {
            pixels: &mut self.pixels,
            narrow: &mut self.narrow,
            expected_depth: self.expected_depth,
        };
        let (width, height, depth) = match format {
            ImageFormat::Tiff => buffers.decode_tiff(&self.bytes, path)?,
            _ => buffers.decode_png(&self.bytes, path)?,
        };
        let view =
            FrameView::new(width, height, depth, &self.pixels).map_err(|e| e.in_file(path))?;
        Ok((view, metadata))
    }
}

/// The reader's pixel buffers, borrowed apart from the file bytes.
struct Buffers<'a> {
    pixels: &'a mut Vec<u16>,
    narrow: &'a mut Vec<u8>,
    expected_depth: Option<u8>,
}

fn unsupported(path: &Path, message: String) -> ExtractError {
    ExtractError::Unsupported {
        path: path.to_path_buf(),
        message,
    }
}

impl Buffers<'_> {
    /// Check the bit depth against the expectation and size the pixel buffer.
    fn prepare(&mut self, path: &Path, width: u32, height: u32, depth: u8) -> Result<usize> {
        if width == 0 || height == 0 {
            return Err(unsupported(path, "image has zero size".into()));
        }
        if let Some(expected) = self.expected_depth.filter(|e| *e != depth) {
            return Err(unsupported(
                path,
                format!("{depth}-bit image where {expected}-bit images are expected"),
            ));
        }
        let n = width as usize * height as usize;
        self.pixels.resize(n, 0);
        if depth == 8 {
            self.narrow.resize(n, 0);
        }
        Ok(n)
    }

    /// Widen the 8-bit scratch buffer into the pixel buffer.
    fn widen(&mut self) {
        for (d, s) in self.pixels.iter_mut().zip(self.narrow.iter()) {
            *d = u16::from(*s);
        }
    }

    fn decode_tiff(&mut self, bytes: &[u8], path: &Path) -> Result<(u32, u32, u8)> {
        let err = |e: tiff::TiffError| ExtractError::Decode {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let mut dec = TiffDecoder::new(Cursor::new(bytes)).map_err(err)?;
        let (width, height) = dec.dimensions().map_err(err)?;
        let depth = match dec.colortype().map_err(err)? {
            tiff::ColorType::Gray(16) => 16,
            tiff::ColorType::Gray(8) => 8,
            other => {
                return Err(unsupported(
                    path,
                    format!(
                        "{other:?} TIFF: only 8- or 16-bit single-channel grayscale is supported"
                    ),
                ));
            }
        };
        let format = dec
            .find_tag_unsigned_vec::<u16>(Tag::SampleFormat)
            .map_err(err)?
            .and_then(|v| v.first().copied())
            .unwrap_or(1);
        if format != SampleFormat::Uint.to_u16() {
            return Err(unsupported(
                path,
                format!("TIFF sample format {format}: only unsigned integer samples are supported"),
            ));
        }
        let photometric = dec
            .find_tag_unsigned::<u16>(Tag::PhotometricInterpretation)
            .map_err(err)?;
        if photometric == Some(PhotometricInterpretation::WhiteIsZero.to_u16()) {
            return Err(unsupported(
                path,
                "WhiteIsZero (inverted) TIFF is not supported".into(),
            ));
        }
        self.prepare(path, width, height, depth)?;
        if depth == 16 {
            dec.read_image_bytes(bytemuck::cast_slice_mut(&mut self.pixels[..]))
                .map_err(err)?;
        } else {
            dec.read_image_bytes(&mut self.narrow[..]).map_err(err)?;
            self.widen();
        }
        Ok((width, height, depth))
    }

    fn decode_png(&mut self, bytes: &[u8], path: &Path) -> Result<(u32, u32, u8)> {
        let err = |e: image::ImageError| ExtractError::Decode {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let decoder = ImageReader::with_format(Cursor::new(bytes), ImageFormat::Png)
            .into_decoder()
            .map_err(err)?;
        let (width, height) = decoder.dimensions();
        let depth = match decoder.color_type() {
            ColorType::L16 => 16,
            ColorType::L8 => 8,
            other => {
                return Err(unsupported(
                    path,
                    format!(
                        "{other:?} image: only 8- or 16-bit single-channel grayscale is supported"
                    ),
                ));
            }
        };
        self.prepare(path, width, height, depth)?;
        if depth == 16 {
            decoder
                .read_image(bytemuck::cast_slice_mut(&mut self.pixels[..]))
                .map_err(err)?;
        } else {
            decoder.read_image(&mut self.narrow[..]).map_err(err)?;
            self.widen();
        }
        Ok((width, height, depth))
    }
}
