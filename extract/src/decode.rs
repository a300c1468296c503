//! Reading 8- and 16-bit grayscale TIFF and PNG files into reused buffers.
//!
//! Decoding into a fresh 25 MB buffer per frame costs several times the decode
//! itself (allocation and page faults), so a [`FrameReader`] keeps the file
//! bytes and the pixel buffer between frames. A TIFF file is decoded with the
//! `tiff` crate from the file straight into the reused pixel buffer (its
//! tags read by seeking, `crate::tiff_fields`): the pixels are copied once,
//! from the page cache into the frame, and no buffer holds the file (the
//! `image` crate's TIFF decoder would decode into a fresh buffer and copy).
//! A PNG file is decoded from the file too, through the `image` crate, its
//! metadata from its eXIf chunk (a TIFF-structured block).
//!
//! Nothing is allocated from what a file claims before it is checked: the
//! file's size against the largest frame allowed, the dimensions in its
//! header against [`formats::limits::check_image_size`] (at most
//! [`FrameReader::limit_pixels`] pixels, [`MAX_IMAGE_SIDE_PX`] a side), and
//! the decoders run under the same limits.

use std::io::{BufReader, Cursor, Read, Seek, SeekFrom};
use std::path::Path;

use formats::limits::{DEFAULT_MAX_PIXELS, MAX_IMAGE_SIDE_PX, SizeError, check_image_size};
use image::{ColorType, ImageDecoder, ImageFormat, ImageReader};
use tiff::decoder::{Decoder as TiffDecoder, Limits as TiffLimits};
use tiff::tags::{PhotometricInterpretation, SampleFormat, Tag};

use crate::frame::FrameView;
use crate::metadata::FrameMetadata;
use crate::strips::Strips;
use crate::{ExtractError, Result};

/// The eight bytes a PNG file starts with (PNG §5.2).
const PNG_SIGNATURE: [u8; 8] = [137, 80, 78, 71, 13, 10, 26, 10];

/// Largest image file (bytes) relative to the largest frame's 16-bit pixel
/// bytes: room for metadata, thumbnails and incompressible data.
const FILE_BYTES_PER_FRAME_BYTE: u64 = 4;
/// Bytes an image file may hold beyond that (tags, EXIF, ICC profiles).
const FILE_SLACK_BYTES: u64 = 1 << 20;

/// Reads frames one after another, reusing its buffers.
#[derive(Debug)]
pub struct FrameReader {
    bytes: Vec<u8>,
    frame: Buffers,
}

impl Default for FrameReader {
    fn default() -> Self {
        Self {
            bytes: Vec::new(),
            frame: Buffers {
                pixels: Vec::new(),
                narrow: Vec::new(),
                compressed: Vec::new(),
                expected_depth: None,
                max_pixels: DEFAULT_MAX_PIXELS,
            },
        }
    }
}

impl FrameReader {
    /// A reader with empty buffers and the default limit
    /// ([`DEFAULT_MAX_PIXELS`]).
    pub fn new() -> Self {
        Self::default()
    }

    /// Refuse frames of more than `max_pixels` pixels (before allocating anything for them).
    pub fn limit_pixels(mut self, max_pixels: u64) -> Self {
        self.frame.max_pixels = max_pixels;
        self
    }

    /// Largest file read: [`FILE_BYTES_PER_FRAME_BYTE`] times the largest
    /// frame's 16-bit pixels, plus [`FILE_SLACK_BYTES`].
    fn max_file_bytes(&self) -> u64 {
        self.frame
            .max_pixels
            .saturating_mul(2 * FILE_BYTES_PER_FRAME_BYTE)
            .saturating_add(FILE_SLACK_BYTES)
    }

    /// Require every frame to have this bit depth (8 or 16).
    pub fn expect_bit_depth(mut self, depth: Option<u8>) -> Self {
        self.frame.expected_depth = depth;
        self
    }

    /// Read and decode `path`; the frame borrows the reader's buffer until the next call.
    pub fn read(&mut self, path: &Path) -> Result<(FrameView<'_>, FrameMetadata)> {
        self.bytes.clear();
        let io = |source| ExtractError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::open(path).map_err(io)?;
        let limit = self.max_file_bytes();
        let len = file.metadata().map_err(io)?.len();
        if len > limit {
            return Err(unsupported(
                path,
                format!(
                    "the file holds {len} bytes, more than any image of at most {} pixels needs \
                     ({limit} bytes; raise the limit with --max-pixels)",
                    self.frame.max_pixels
                ),
            ));
        }
        // Classic TIFF (the signature `image` recognises) and PNG: straight
        // from the file.
        let mut file = BufReader::new(file);
        let mut magic = [0u8; 8];
        let head = file.read_exact(&mut magic).is_ok();
        let tiff = head && matches!(magic[..4], [b'I', b'I', 42, 0] | [b'M', b'M', 0, 42]);
        file.seek(SeekFrom::Start(0)).map_err(io)?;
        if head && magic == PNG_SIGNATURE {
            let (size, metadata) = self.frame.decode_png(file, path)?;
            return Ok((self.frame.view(size, path)?, metadata));
        }
        if tiff {
            // An unreadable tag block gives empty metadata, as for any file.
            let metadata = crate::tiff_fields(&mut file)
                .map(|f| FrameMetadata::from_fields(&f))
                .unwrap_or_default();
            file.seek(SeekFrom::Start(0)).map_err(io)?;
            let size = self.frame.decode_tiff(file, path)?;
            return Ok((self.frame.view(size, path)?, metadata));
        }
        // The file may grow while it is read: never read past the limit.
        file.take(limit.saturating_add(1))
            .read_to_end(&mut self.bytes)
            .map_err(io)?;
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
        let decode_err = |e: image::ImageError| image_error(path, e);
        if self.bytes.is_empty() {
            return Err(ExtractError::Decode {
                path: path.to_path_buf(),
                message: "the file is empty".into(),
            });
        }
        let format = image::guess_format(&self.bytes).map_err(decode_err)?;
        let metadata = match format {
            ImageFormat::Tiff => FrameMetadata::from_tiff_bytes(&self.bytes),
            ImageFormat::Png => {
                let (size, metadata) = self.frame.decode_png(Cursor::new(&self.bytes[..]), path)?;
                return Ok((self.frame.view(size, path)?, metadata));
            }
            ImageFormat::Jpeg => {
                let (size, metadata) =
                    self.frame.decode_jpeg(Cursor::new(&self.bytes[..]), path)?;
                return Ok((self.frame.view(size, path)?, metadata));
            }
            other => {
                return Err(ExtractError::Unsupported {
                    path: path.to_path_buf(),
                    message: format!(
                        "{other:?} images are not supported (use 8- or 16-bit grayscale TIFF or \
                         PNG, or 8-bit JPEG)"
                    ),
                });
            }
        };
        let size = self.frame.decode_tiff(Cursor::new(&self.bytes[..]), path)?;
        Ok((self.frame.view(size, path)?, metadata))
    }
}

/// The reader's pixel buffers and what a frame must be, apart from the
/// file bytes (so that a frame decodes from them).
#[derive(Debug)]
struct Buffers {
    pixels: Vec<u16>,
    narrow: Vec<u8>,
    /// A compressed TIFF's strips, read from the file ([`Strips`]).
    compressed: Vec<u8>,
    /// Bit depth every frame must have, if set (8 or 16).
    expected_depth: Option<u8>,
    /// Largest frame (pixels) this reader decodes.
    max_pixels: u64,
}

/// A decoder's complaint: a file that ends early is called truncated (the
/// I/O error would say only "failed to fill whole buffer").
fn decode_error(path: &Path, message: String, eof: bool) -> ExtractError {
    ExtractError::Decode {
        path: path.to_path_buf(),
        message: if eof {
            "truncated file: the image data end before the size its header gives".into()
        } else {
            message
        },
    }
}

fn tiff_error(path: &Path, e: tiff::TiffError) -> ExtractError {
    let eof = matches!(&e, tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof);
    decode_error(path, e.to_string(), eof)
}

fn image_error(path: &Path, e: image::ImageError) -> ExtractError {
    let eof = match &e {
        image::ImageError::IoError(io) => io.kind() == std::io::ErrorKind::UnexpectedEof,
        // The png crate reports a missing end as a format error.
        image::ImageError::Decoding(d) => {
            let text = d.to_string().to_ascii_lowercase();
            text.contains("unexpected end") || text.contains("eof")
        }
        _ => false,
    };
    decode_error(path, e.to_string(), eof)
}

fn unsupported(path: &Path, message: String) -> ExtractError {
    ExtractError::Unsupported {
        path: path.to_path_buf(),
        message,
    }
}

impl Buffers {
    /// The decoded frame of `(width, height, depth)`.
    fn view(&self, (width, height, depth): (u32, u32, u8), path: &Path) -> Result<FrameView<'_>> {
        FrameView::new(width, height, depth, &self.pixels).map_err(|e| e.in_file(path))
    }

    /// Check the size the header claims (before anything is allocated for it).
    fn check_size(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        check_image_size(u64::from(width), u64::from(height), self.max_pixels).map_err(|e| {
            let hint = match e {
                SizeError::Pixels { .. } => {
                    " (raise the limit with --max-pixels if this machine can hold such frames)"
                }
                _ => "",
            };
            unsupported(path, format!("{e}{hint}"))
        })
    }

    /// Check the bit depth against the expectation and size the pixel buffer.
    fn prepare(&mut self, path: &Path, width: u32, height: u32, depth: u8) -> Result<usize> {
        self.check_size(path, width, height)?;
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

    fn decode_tiff<R: Read + Seek>(&mut self, source: R, path: &Path) -> Result<(u32, u32, u8)> {
        let err = |e: tiff::TiffError| tiff_error(path, e);
        // The decoder's buffers never exceed the largest frame allowed.
        let frame_bytes = usize::try_from(self.max_pixels.saturating_mul(2)).unwrap_or(usize::MAX);
        let mut limits = TiffLimits::default();
        limits.decoding_buffer_size = frame_bytes;
        limits.intermediate_buffer_size = frame_bytes;
        let mut dec = TiffDecoder::new(source).map_err(err)?.with_limits(limits);
        let (width, height) = dec.dimensions().map_err(err)?;
        self.check_size(path, width, height)?;
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
        let out: &mut [u8] = if depth == 16 {
            bytemuck::cast_slice_mut(&mut self.pixels[..])
        } else {
            &mut self.narrow[..]
        };
        match Strips::of(&mut dec, height).map_err(err)? {
            Some(strips) => strips
                .decode(
                    dec.inner(),
                    &mut self.compressed,
                    out,
                    width as usize,
                    depth,
                )
                .map_err(|e| decode_error(path, e.message, e.truncated))?,
            None => dec.read_image_bytes(out).map_err(err)?,
        }
        if depth == 8 {
            self.widen();
        }
        Ok((width, height, depth))
    }

    /// An `image` decoder of `format` over `source`, its allocations held to
    /// this reader's largest frame at `bytes_per_pixel` decoded, and the
    /// metadata of its EXIF (empty where unreadable, as for any file).
    fn decoder<'a, R: std::io::BufRead + Seek + 'a>(
        &self,
        source: R,
        format: ImageFormat,
        bytes_per_pixel: u64,
        path: &Path,
    ) -> Result<(impl ImageDecoder + 'a, FrameMetadata)> {
        let mut reader = ImageReader::with_format(source, format);
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_IMAGE_SIDE_PX);
        limits.max_image_height = Some(MAX_IMAGE_SIDE_PX);
        limits.max_alloc = Some(
            self.max_pixels
                .saturating_mul(bytes_per_pixel * FILE_BYTES_PER_FRAME_BYTE)
                .saturating_add(FILE_SLACK_BYTES),
        );
        reader.limits(limits);
        let mut decoder = reader.into_decoder().map_err(|e| image_error(path, e))?;
        let metadata = decoder
            .exif_metadata()
            .ok()
            .flatten()
            .map(|exif| FrameMetadata::from_tiff_bytes(&exif))
            .unwrap_or_default();
        Ok((decoder, metadata))
    }

    /// Decode an 8-bit JPEG (as phones and DSLRs write calibration views)
    /// from `source`, with its EXIF: grayscale as it is, colour to its luma
    /// (`image`'s Rec. 709 weights). Lossy: for views of a board, not for
    /// frames that are measured.
    fn decode_jpeg<R: std::io::BufRead + Seek>(
        &mut self,
        source: R,
        path: &Path,
    ) -> Result<((u32, u32, u8), FrameMetadata)> {
        let err = |e: image::ImageError| image_error(path, e);
        // Colour JPEGs decode to three bytes a pixel.
        let (decoder, metadata) = self.decoder(source, ImageFormat::Jpeg, 3, path)?;
        let (width, height) = decoder.dimensions();
        self.check_size(path, width, height)?;
        let image = image::DynamicImage::from_decoder(decoder).map_err(err)?;
        let gray = image.to_luma8();
        self.prepare(path, width, height, 8)?;
        self.narrow.copy_from_slice(gray.as_raw());
        self.widen();
        Ok(((width, height, 8), metadata))
    }

    /// Decode a PNG from `source` (a file or bytes), with the metadata of
    /// its eXIf chunk, which writers put before the image data.
    fn decode_png<R: std::io::BufRead + Seek>(
        &mut self,
        mut source: R,
        path: &Path,
    ) -> Result<((u32, u32, u8), FrameMetadata)> {
        let err = |e: image::ImageError| image_error(path, e);
        // The size in the IHDR chunk, which must come first (PNG §5.6), is
        // checked before the decoder sizes any buffer from it.
        let mut head = [0u8; 24];
        if source.read_exact(&mut head).is_ok() && &head[12..16] == b"IHDR" {
            let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
            self.check_size(path, be(&head[16..20]), be(&head[20..24]))?;
        }
        source
            .seek(SeekFrom::Start(0))
            .map_err(|e| image_error(path, image::ImageError::IoError(e)))?;
        let (decoder, metadata) = self.decoder(source, ImageFormat::Png, 2, path)?;
        let (width, height) = decoder.dimensions();
        self.check_size(path, width, height)?;
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
        Ok(((width, height, depth), metadata))
    }
}
