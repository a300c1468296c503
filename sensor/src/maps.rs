//! The map files stored beside `rig.json`: a 32-bit float one-channel TIFF
//! per per-pixel map (dark, gain), an 8-bit one-channel TIFF of the defect
//! codes, and the CRC-32 that `rig.json` records for each; a camera's maps
//! as the files its record names ([`encode_maps`]) and back from their bytes,
//! each checked against its record ([`decode_maps`]).
//!
//! Decoding trusts nothing in the file: the size is checked against the
//! limits of any sensor and against what the file's bytes can hold before
//! anything is allocated for it; only uncompressed or deflate data of the
//! expected sample format is accepted.

use std::io::Cursor;

use formats::limits::{DEFAULT_MAX_PIXELS, check_image_size};
use formats::{MapFile, SensorJson, SensorMapFiles};
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::encoder::{Compression, DeflateLevel, TiffEncoder, TiffValue, colortype};
use tiff::tags::{CompressionMethod, SampleFormat, Tag};

use crate::{DefectMap, Result, SensorError, SensorMaps};

/// Deflate (RFC 1951) never expands data more than 1032 : 1 on decoding (a
/// 258-byte match coded in at least 2 bits); a file whose size cannot hold
/// the samples it claims even at that ratio is refused before decoding.
const DEFLATE_MAX_RATIO: u64 = 1032;

/// The sample type of a map file.
#[derive(Clone, Copy)]
enum Sample {
    F32,
    U8,
}

impl Sample {
    fn bytes(self) -> u64 {
        match self {
            Sample::F32 => 4,
            Sample::U8 => 1,
        }
    }

    fn bits(self) -> u8 {
        match self {
            Sample::F32 => 32,
            Sample::U8 => 8,
        }
    }

    fn format(self) -> SampleFormat {
        match self {
            Sample::F32 => SampleFormat::IEEEFP,
            Sample::U8 => SampleFormat::Uint,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Sample::F32 => "32-bit float",
            Sample::U8 => "8-bit unsigned",
        }
    }
}

fn file_error(message: impl Into<String>) -> SensorError {
    SensorError::MapFile(message.into())
}

fn tiff_error(e: tiff::TiffError) -> SensorError {
    let eof = matches!(&e, tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof);
    if eof {
        file_error("truncated file: the data end before the size its header gives")
    } else {
        file_error(format!("not a readable TIFF: {e}"))
    }
}

/// 32-bit float, one-channel, deflate-compressed TIFF of a map.
pub fn encode_f32(values: &[f32], width: u32, height: u32) -> Result<Vec<u8>> {
    encode::<colortype::Gray32Float>(values, width, height)
}

/// The values and size of a 32-bit float one-channel TIFF; refuses another
/// sample format, a size beyond the limits, a truncated or corrupt file and
/// values that are not finite.
pub fn decode_f32(bytes: &[u8]) -> Result<(Vec<f32>, u32, u32)> {
    let (result, width, height) = decode(bytes, Sample::F32)?;
    let DecodingResult::F32(values) = result else {
        return Err(file_error("not a 32-bit float map"));
    };
    check_decoded(values.len(), width, height)?;
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(SensorError::MapValue {
            what: "map file".into(),
            x: (i % width as usize) as u32,
            y: (i / width as usize) as u32,
            value: f64::from(values[i]),
            expected: "a finite value is needed".into(),
        });
    }
    Ok((values, width, height))
}

/// 8-bit one-channel, deflate-compressed TIFF (the defect codes).
pub fn encode_u8(values: &[u8], width: u32, height: u32) -> Result<Vec<u8>> {
    encode::<colortype::Gray8>(values, width, height)
}

/// The values and size of an 8-bit one-channel TIFF; refuses another
/// sample format, a size beyond the limits and a truncated or corrupt file.
pub fn decode_u8(bytes: &[u8]) -> Result<(Vec<u8>, u32, u32)> {
    let (result, width, height) = decode(bytes, Sample::U8)?;
    let DecodingResult::U8(values) = result else {
        return Err(file_error("not an 8-bit map"));
    };
    check_decoded(values.len(), width, height)?;
    Ok((values, width, height))
}

/// CRC-32 (IEEE) of the file's bytes as 8 lower-case hex digits.
pub fn checksum(bytes: &[u8]) -> String {
    format!("{:08x}", crc32fast::hash(bytes))
}

/// A map file of a camera, as its record in `rig.json` names it
/// ([`SensorMapFiles`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapKind {
    /// The master dark (32-bit float, DN).
    Dark,
    /// The relative gain map (32-bit float).
    Gain,
    /// The defect codes (8-bit).
    Defects,
}

impl MapKind {
    /// Every kind, in the order the files are written and read.
    pub const ALL: [MapKind; 3] = [MapKind::Dark, MapKind::Gain, MapKind::Defects];

    /// `dark`, `gain` or `defects`: how file names and messages name the map.
    pub fn name(self) -> &'static str {
        match self {
            MapKind::Dark => "dark",
            MapKind::Gain => "gain",
            MapKind::Defects => "defects",
        }
    }

    /// The record's entry of this map, when it has one.
    pub fn entry(self, files: &SensorMapFiles) -> Option<&MapFile> {
        match self {
            MapKind::Dark => files.dark.as_ref(),
            MapKind::Gain => files.gain.as_ref(),
            MapKind::Defects => files.defects.as_ref(),
        }
    }

    fn entry_mut(self, files: &mut SensorMapFiles) -> &mut Option<MapFile> {
        match self {
            MapKind::Dark => &mut files.dark,
            MapKind::Gain => &mut files.gain,
            MapKind::Defects => &mut files.defects,
        }
    }
}

impl std::fmt::Display for MapKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One map file: its kind and its bytes.
pub type MapBytes = (MapKind, Vec<u8>);

/// The files of `maps` — the maps that are applied (dark, gain) and the
/// defect map — encoded, in [`MapKind::ALL`] order, and the record that
/// names them: each kind's `file_name`, with the CRC-32 of its bytes.
pub fn encode_maps(
    maps: &SensorMaps,
    file_name: impl Fn(MapKind) -> String,
) -> Result<(Vec<MapBytes>, SensorMapFiles)> {
    let (width, height) = (maps.width, maps.height);
    let mut files = Vec::new();
    let mut record = SensorMapFiles::default();
    for kind in MapKind::ALL {
        let bytes = match kind {
            MapKind::Dark => maps.dark.as_deref().map(|d| encode_f32(d, width, height)),
            MapKind::Gain => maps.gain.as_deref().map(|g| encode_f32(g, width, height)),
            MapKind::Defects => Some(encode_u8(&maps.defects.codes(), width, height)),
        };
        if let Some(bytes) = bytes.transpose()? {
            *kind.entry_mut(&mut record) = Some(MapFile {
                file: file_name(kind),
                crc32: checksum(&bytes),
            });
            files.push((kind, bytes));
        }
    }
    Ok((files, record))
}

/// A camera's maps from its `sensor` record and the bytes of the files the
/// record names (`files`, by kind), each file checked in [`MapKind::ALL`]
/// order: its bytes against the recorded CRC-32, then decoded
/// ([`decode_f32`], [`decode_u8`]) and of the camera's `size` (px). Without a
/// defect map, no pixel is defective. A fault is [`SensorError::Map`], naming
/// the map's kind for the caller to name the file.
pub fn decode_maps(
    record: &SensorJson,
    size: (u32, u32),
    files: &[MapBytes],
) -> Result<SensorMaps> {
    let checked = |kind: MapKind| -> Result<Option<&[u8]>> {
        let Some(entry) = kind.entry(&record.maps) else {
            return Ok(None);
        };
        let Some((_, bytes)) = files.iter().find(|(k, _)| *k == kind) else {
            return Err(file_error("named in the record, but not given"));
        };
        let found = checksum(bytes);
        if found != entry.crc32 {
            return Err(SensorError::MapChecksum {
                found,
                recorded: entry.crc32.clone(),
            });
        }
        Ok(Some(bytes))
    };
    let of_size = |width: u32, height: u32| -> Result<()> {
        if (width, height) != size {
            return Err(SensorError::MapOfOtherSize {
                width,
                height,
                camera_width: size.0,
                camera_height: size.1,
            });
        }
        Ok(())
    };
    let f32_map = |kind: MapKind| -> Result<Option<Vec<f32>>> {
        let Some(bytes) = checked(kind)? else {
            return Ok(None);
        };
        let (values, width, height) = decode_f32(bytes)?;
        of_size(width, height)?;
        Ok(Some(values))
    };
    let defect_map = || -> Result<DefectMap> {
        let Some(bytes) = checked(MapKind::Defects)? else {
            return Ok(DefectMap::empty(size.0, size.1));
        };
        let (codes, width, height) = decode_u8(bytes)?;
        of_size(width, height)?;
        DefectMap::from_codes(width, height, &codes)
    };
    let in_map = |kind: MapKind| {
        move |e: SensorError| SensorError::Map {
            kind,
            fault: Box::new(e),
        }
    };
    Ok(SensorMaps {
        width: size.0,
        height: size.1,
        black_level_dn: record.black_level_dn as f32,
        dark: f32_map(MapKind::Dark).map_err(in_map(MapKind::Dark))?,
        gain: f32_map(MapKind::Gain).map_err(in_map(MapKind::Gain))?,
        defects: defect_map().map_err(in_map(MapKind::Defects))?,
        saturation: record.saturation_dn,
    })
}

/// A deflate-compressed one-channel TIFF of colour type `C`, its size
/// checked first.
fn encode<C: colortype::ColorType>(values: &[C::Inner], width: u32, height: u32) -> Result<Vec<u8>>
where
    [C::Inner]: TiffValue,
{
    check_encode(values.len(), width, height)?;
    let mut bytes = Cursor::new(Vec::new());
    let mut encoder = TiffEncoder::new(&mut bytes)
        .map_err(tiff_error)?
        .with_compression(Compression::Deflate(DeflateLevel::default()));
    encoder
        .write_image::<C>(width, height, values)
        .map_err(tiff_error)?;
    Ok(bytes.into_inner())
}

/// The size of a map to encode: within the limits, with its values.
fn check_encode(len: usize, width: u32, height: u32) -> Result<()> {
    check_image_size(u64::from(width), u64::from(height), DEFAULT_MAX_PIXELS)
        .map_err(|e| file_error(e.to_string()))?;
    if len != width as usize * height as usize {
        return Err(SensorError::MapSize {
            what: "map to encode".into(),
            message: format!("{len} values for {width}×{height} px"),
        });
    }
    Ok(())
}

/// The decoded buffer holds exactly the claimed pixels.
fn check_decoded(len: usize, width: u32, height: u32) -> Result<()> {
    if len != width as usize * height as usize {
        return Err(file_error(format!(
            "{len} samples decoded for a {width}×{height} map"
        )));
    }
    Ok(())
}

/// Decode one single-channel image of `sample` type, every claim checked
/// before the pixel buffer is allocated.
fn decode(bytes: &[u8], sample: Sample) -> Result<(DecodingResult, u32, u32)> {
    let max_bytes = DEFAULT_MAX_PIXELS.saturating_mul(sample.bytes());
    let mut limits = Limits::default();
    limits.decoding_buffer_size = usize::try_from(max_bytes).unwrap_or(usize::MAX);
    limits.intermediate_buffer_size = limits.decoding_buffer_size;
    let mut decoder = Decoder::new(Cursor::new(bytes))
        .map_err(tiff_error)?
        .with_limits(limits);
    let (width, height) = decoder.dimensions().map_err(tiff_error)?;
    check_image_size(u64::from(width), u64::from(height), DEFAULT_MAX_PIXELS)
        .map_err(|e| file_error(e.to_string()))?;
    let colour = decoder.colortype().map_err(tiff_error)?;
    let format = decoder
        .find_tag_unsigned_vec::<u16>(Tag::SampleFormat)
        .map_err(tiff_error)?
        .and_then(|v| v.first().copied())
        .unwrap_or(SampleFormat::Uint.to_u16());
    if colour != tiff::ColorType::Gray(sample.bits()) || format != sample.format().to_u16() {
        return Err(file_error(format!(
            "a {colour:?} TIFF of sample format {format} where a {} one-channel map is expected",
            sample.name()
        )));
    }
    check_compression_and_length(&mut decoder, bytes.len(), width, height, sample)?;
    let result = decoder.read_image().map_err(tiff_error)?;
    Ok((result, width, height))
}

/// Only uncompressed or deflate data, and no more samples claimed than the
/// file's bytes can hold (uncompressed: one sample's bytes each; deflate: at
/// [`DEFLATE_MAX_RATIO`]).
fn check_compression_and_length(
    decoder: &mut Decoder<Cursor<&[u8]>>,
    file_len: usize,
    width: u32,
    height: u32,
    sample: Sample,
) -> Result<()> {
    let method = decoder
        .find_tag_unsigned::<u16>(Tag::Compression)
        .map_err(tiff_error)?
        .unwrap_or(CompressionMethod::None.to_u16());
    let ratio = if method == CompressionMethod::None.to_u16() {
        1
    } else if method == CompressionMethod::Deflate.to_u16()
        || method == CompressionMethod::OldDeflate.to_u16()
    {
        DEFLATE_MAX_RATIO
    } else {
        return Err(file_error(format!(
            "TIFF compression {method}: a map is uncompressed or deflate"
        )));
    };
    let needed = u64::from(width) * u64::from(height) * sample.bytes();
    if needed > (file_len as u64).saturating_mul(ratio) {
        return Err(file_error(format!(
            "a {width}×{height} map needs {needed} bytes of samples, more than a file of \
             {file_len} bytes can hold: truncated or damaged"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checksum_is_crc32_ieee() {
        // The CRC-32 check value of "123456789" (ISO 3309 / ITU-T V.42).
        assert_eq!(checksum(b"123456789"), "cbf43926");
    }
}
