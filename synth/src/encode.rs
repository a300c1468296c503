//! Image files with camera metadata: 8- or 16-bit grayscale TIFF (what the
//! cameras write) or PNG.
//!
//! TIFF: IFD0 carries Make, Model, DateTime, Software, ImageDescription and a
//! pointer to an EXIF sub-IFD with ExposureTime, FNumber, FocalLength,
//! DateTimeOriginal, SubSecTimeOriginal and BodySerialNumber (EXIF 2.3 tag
//! 0xA431) — readable by any EXIF reader (kamadak-exif) and image library.
//! PNG: the same tags as a TIFF-structured EXIF block in an `eXIf` chunk.

use std::io::{Seek, Write};
use std::path::Path;

use tiff::encoder::{
    Compression, DeflateLevel, Predictor, Rational, TiffEncoder, TiffKind, colortype,
};
use tiff::tags::Tag;

use crate::config::{ImageFormat, TiffCompression};
use crate::sensor::Image16;
use crate::{Result, SynthError};

/// EXIF tag numbers written to the EXIF sub-IFD.
mod exif_tag {
    pub(super) const EXPOSURE_TIME: u16 = 0x829A;
    pub(super) const F_NUMBER: u16 = 0x829D;
    pub(super) const DATE_TIME_ORIGINAL: u16 = 0x9003;
    pub(super) const SUB_SEC_TIME_ORIGINAL: u16 = 0x9291;
    pub(super) const FOCAL_LENGTH: u16 = 0x920A;
    pub(super) const BODY_SERIAL_NUMBER: u16 = 0xA431;
}

/// What a camera writes about one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameMetadata {
    /// Camera maker (TIFF Make).
    pub make: String,
    /// Camera model (TIFF Model).
    pub model: String,
    /// Camera serial number (EXIF BodySerialNumber).
    pub serial: String,
    /// Capture time, seconds since 1970-01-01T00:00:00 (DateTime,
    /// DateTimeOriginal, SubSecTimeOriginal).
    pub time_s: f64,
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Aperture f-number.
    pub f_number: f64,
    /// Lens focal length (mm).
    pub focal_mm: f64,
    /// Free text (TIFF ImageDescription; PNG tEXt "Description").
    pub description: String,
}

/// Software tag.
const SOFTWARE: &str = concat!("trinocular synth ", env!("CARGO_PKG_VERSION"));

/// A positive number as a TIFF RATIONAL (denominator ≤ 10⁶, reduced).
fn rational(x: f64) -> Rational {
    let d: u32 = 1_000_000;
    let n = (x.max(0.0) * f64::from(d)).round().min(f64::from(u32::MAX)) as u32;
    let g = gcd(n, d).max(1);
    Rational { n: n / g, d: d / g }
}

fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

fn ascii(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii() && c != '\0' { c } else { '?' })
        .collect()
}

fn tiff_err(path: &Path) -> impl Fn(tiff::TiffError) -> SynthError + '_ {
    move |e| SynthError::Encode {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Write the EXIF sub-IFD; returns its offset for IFD0's ExifDirectory tag.
fn write_exif_ifd<W: Write + Seek, K: TiffKind>(
    enc: &mut TiffEncoder<W, K>,
    meta: &FrameMetadata,
    path: &Path,
) -> Result<K::OffsetType> {
    let (date, subsec) = crate::datetime::exif(meta.time_s);
    let mut dir = enc.extra_directory().map_err(tiff_err(path))?;
    dir.write_tag(
        Tag::Unknown(exif_tag::EXPOSURE_TIME),
        rational(meta.exposure_s),
    )
    .map_err(tiff_err(path))?;
    if meta.f_number.is_finite() {
        dir.write_tag(Tag::Unknown(exif_tag::F_NUMBER), rational(meta.f_number))
            .map_err(tiff_err(path))?;
    }
    dir.write_tag(Tag::Unknown(exif_tag::DATE_TIME_ORIGINAL), date.as_str())
        .map_err(tiff_err(path))?;
    dir.write_tag(
        Tag::Unknown(exif_tag::FOCAL_LENGTH),
        rational(meta.focal_mm),
    )
    .map_err(tiff_err(path))?;
    dir.write_tag(
        Tag::Unknown(exif_tag::SUB_SEC_TIME_ORIGINAL),
        subsec.as_str(),
    )
    .map_err(tiff_err(path))?;
    dir.write_tag(
        Tag::Unknown(exif_tag::BODY_SERIAL_NUMBER),
        ascii(&meta.serial).as_str(),
    )
    .map_err(tiff_err(path))?;
    let offsets = dir.finish_with_offsets().map_err(tiff_err(path))?;
    Ok(offsets.offset)
}

/// IFD0 metadata tags (everything but the image structure).
fn write_ifd0_tags<W: Write + Seek, K: TiffKind>(
    dir: &mut tiff::encoder::DirectoryEncoder<'_, W, K>,
    meta: &FrameMetadata,
    exif: K::OffsetType,
    path: &Path,
) -> Result<()> {
    let (date, _) = crate::datetime::exif(meta.time_s);
    dir.write_tag(Tag::Make, ascii(&meta.make).as_str())
        .map_err(tiff_err(path))?;
    dir.write_tag(Tag::Model, ascii(&meta.model).as_str())
        .map_err(tiff_err(path))?;
    dir.write_tag(Tag::Software, SOFTWARE)
        .map_err(tiff_err(path))?;
    dir.write_tag(Tag::DateTime, date.as_str())
        .map_err(tiff_err(path))?;
    if !meta.description.is_empty() {
        dir.write_tag(Tag::ImageDescription, ascii(&meta.description).as_str())
            .map_err(tiff_err(path))?;
    }
    dir.write_tag(Tag::ExifDirectory, exif)
        .map_err(tiff_err(path))?;
    Ok(())
}

/// Encode a grayscale TIFF of `bits` (8 or 16) per sample; `path` names the
/// destination in errors.
pub fn encode_tiff<W: Write + Seek>(
    sink: W,
    image: &Image16,
    bits: u8,
    meta: &FrameMetadata,
    compression: TiffCompression,
    path: &Path,
) -> Result<()> {
    let (comp, pred) = match compression {
        TiffCompression::None => (Compression::Uncompressed, Predictor::None),
        TiffCompression::Deflate => (
            Compression::Deflate(DeflateLevel::Fast),
            Predictor::Horizontal,
        ),
        TiffCompression::Lzw => (Compression::Lzw, Predictor::Horizontal),
    };
    let mut enc = TiffEncoder::new(sink)
        .map_err(tiff_err(path))?
        .with_compression(comp)
        .with_predictor(pred);
    let exif = write_exif_ifd(&mut enc, meta, path)?;
    let (w, h) = image.dimensions();
    match bits {
        16 => {
            let mut img = enc
                .new_image::<colortype::Gray16>(w, h)
                .map_err(tiff_err(path))?;
            write_ifd0_tags(img.encoder(), meta, exif, path)?;
            img.write_data(image.as_raw()).map_err(tiff_err(path))?;
        }
        8 => {
            let data = to_u8(image);
            let mut img = enc
                .new_image::<colortype::Gray8>(w, h)
                .map_err(tiff_err(path))?;
            write_ifd0_tags(img.encoder(), meta, exif, path)?;
            img.write_data(&data).map_err(tiff_err(path))?;
        }
        b => {
            return Err(SynthError::Encode {
                path: path.to_path_buf(),
                message: format!("{b} bits per sample: only 8 and 16 are written"),
            });
        }
    }
    Ok(())
}

fn to_u8(image: &Image16) -> Vec<u8> {
    image.as_raw().iter().map(|&v| v.min(255) as u8).collect()
}

/// The metadata as a TIFF-structured EXIF block (IFD0 + EXIF sub-IFD, no image),
/// for PNG's `eXIf` chunk.
pub(crate) fn exif_block(meta: &FrameMetadata) -> Result<Vec<u8>> {
    let path = Path::new("<exif>");
    let mut cursor = std::io::Cursor::new(Vec::new());
    {
        let mut enc = TiffEncoder::new(&mut cursor).map_err(tiff_err(path))?;
        let exif = write_exif_ifd(&mut enc, meta, path)?;
        let mut dir = enc.image_directory().map_err(tiff_err(path))?;
        write_ifd0_tags(&mut dir, meta, exif, path)?;
        dir.finish().map_err(tiff_err(path))?;
    }
    Ok(cursor.into_inner())
}

/// Encode a grayscale PNG of `bits` (8 or 16) per sample with an `eXIf` chunk.
pub fn encode_png<W: Write>(
    sink: W,
    image: &Image16,
    bits: u8,
    meta: &FrameMetadata,
    path: &Path,
) -> Result<()> {
    let png_err = |e: png::EncodingError| SynthError::Encode {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let (w, h) = image.dimensions();
    let mut enc = png::Encoder::new(sink, w, h);
    enc.set_color(png::ColorType::Grayscale);
    let data: Vec<u8> = match bits {
        16 => {
            enc.set_depth(png::BitDepth::Sixteen);
            image
                .as_raw()
                .iter()
                .flat_map(|v| v.to_be_bytes())
                .collect()
        }
        8 => {
            enc.set_depth(png::BitDepth::Eight);
            to_u8(image)
        }
        b => {
            return Err(SynthError::Encode {
                path: path.to_path_buf(),
                message: format!("{b} bits per sample: only 8 and 16 are written"),
            });
        }
    };
    enc.set_compression(png::Compression::Fast);
    if !meta.description.is_empty() {
        enc.add_text_chunk("Description".into(), ascii(&meta.description))
            .map_err(png_err)?;
    }
    let mut writer = enc.write_header().map_err(png_err)?;
    writer
        .write_chunk(png::chunk::eXIf, &exif_block(meta)?)
        .map_err(png_err)?;
    writer.write_image_data(&data).map_err(png_err)?;
    writer.finish().map_err(png_err)
}

/// Write an image file atomically (temporary file, then rename), replacing
/// an existing one (the commands write their images through an `OutputPlan` instead).
pub fn write_image(
    path: &Path,
    image: &Image16,
    bits: u8,
    meta: &FrameMetadata,
    format: ImageFormat,
    compression: TiffCompression,
) -> Result<()> {
    write_image_into(
        formats::AtomicFile::create(path)?,
        image,
        bits,
        meta,
        format,
        compression,
    )
}

/// Encode an image into `file` (from an output plan) and commit it.
pub(crate) fn write_image_into(
    mut file: formats::AtomicFile,
    image: &Image16,
    bits: u8,
    meta: &FrameMetadata,
    format: ImageFormat,
    compression: TiffCompression,
) -> Result<()> {
    let path = file.target().to_path_buf();
    match format {
        ImageFormat::Tiff => encode_tiff(&mut file, image, bits, meta, compression, &path)?,
        ImageFormat::Png => encode_png(&mut file, image, bits, meta, &path)?,
    }
    file.commit()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rationals_are_reduced() {
        let r = rational(0.002);
        assert_eq!((r.n, r.d), (1, 500));
        let r = rational(8.0);
        assert_eq!((r.n, r.d), (8, 1));
    }
}
