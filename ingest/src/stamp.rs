//! A frame's camera serial and time of exposure, read from its metadata
//! alone: a TIFF's tag directories are reached by seeking (the pixels, tens
//! of megabytes, are never read), a PNG's chunks are scanned up to its
//! `eXIf` chunk by kamadak-exif. The tags are interpreted by
//! [`extract::FrameMetadata::from_fields`] (the one home of EXIF reading:
//! serial from BodySerialNumber else CameraSerialNumber, time from
//! DateTimeOriginal + SubSecTimeOriginal else DateTime + SubSecTime), and
//! the time is parsed with `jiff` as a civil time (camera clocks keep local
//! time; no zone is applied or needed, since only differences are used).

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use exif::{Context, Field, In, Rational, Tag, Value};
use extract::FrameMetadata;

use crate::{IngestError, Result, TimeError};

/// When a frame was exposed, on its camera's clock.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameTime {
    /// Nanoseconds since 1970-01-01T00:00:00 of the camera's civil clock.
    pub ns: i64,
    /// The resolution of the stamp (ns): 10^−digits s for the sub-second
    /// digits written, 1 s without them.
    pub resolution_ns: i64,
    /// The time as the camera wrote it (ISO 8601).
    pub text: String,
}

/// Parse an ISO 8601 civil time `YYYY-MM-DDTHH:MM:SS[.f…]` (as
/// [`FrameMetadata::datetime`] gives it).
pub fn parse_time(text: &str) -> std::result::Result<FrameTime, TimeError> {
    let dt: jiff::civil::DateTime = text.parse().map_err(|e: jiff::Error| TimeError::Syntax {
        text: text.to_string(),
        reason: e.to_string(),
    })?;
    let ts = jiff::tz::TimeZone::UTC
        .to_timestamp(dt)
        .map_err(|e| TimeError::Timestamp {
            text: text.to_string(),
            reason: e.to_string(),
        })?;
    let ns = i64::try_from(ts.as_nanosecond()).map_err(|_| TimeError::Range(text.to_string()))?;
    let digits = text.split_once('.').map_or(0, |(_, f)| {
        f.chars().take_while(char::is_ascii_digit).count()
    });
    let resolution_ns = 10i64.pow(9u32.saturating_sub(digits.min(9) as u32));
    Ok(FrameTime {
        ns,
        resolution_ns,
        text: text.to_string(),
    })
}

/// The metadata of an image file, read without its pixels.
pub fn read_metadata(path: &Path) -> Result<FrameMetadata> {
    let meta_err = |message: String| IngestError::Metadata {
        path: path.to_path_buf(),
        message,
    };
    let file = File::open(path).map_err(|e| IngestError::io(path, e))?;
    let mut reader = BufReader::with_capacity(4096, file);
    let mut magic = [0u8; 4];
    reader
        .read_exact(&mut magic)
        .map_err(|e| meta_err(format!("too short for an image ({e})")))?;
    reader
        .seek(SeekFrom::Start(0))
        .map_err(|e| IngestError::io(path, e))?;
    match magic {
        [b'I', b'I', 42 | 43, 0] | [b'M', b'M', 0, 42 | 43] => {
            let fields = tiff_fields(&mut reader).map_err(meta_err)?;
            Ok(FrameMetadata::from_fields(&fields))
        }
        [0x89, b'P', b'N', b'G'] => {
            match exif::Reader::new().read_from_container(&mut reader) {
                Ok(e) => Ok(FrameMetadata::from_fields(
                    &e.fields().cloned().collect::<Vec<_>>(),
                )),
                // A PNG without an eXIf chunk has no metadata; a broken one is an error.
                Err(exif::Error::NotFound(_)) => Ok(FrameMetadata::default()),
                Err(e) => Err(meta_err(format!("PNG metadata: {e}"))),
            }
        }
        _ => Err(meta_err("not a TIFF or PNG file".into())),
    }
}

/// TIFF tags read into IFD0 (Context::Tiff).
const IFD0_TAGS: [u16; 4] = [0x010F, 0x0110, 0x0132, 0xC62F];
/// EXIF tags read from the EXIF sub-IFD (Context::Exif).
const EXIF_TAGS: [u16; 5] = [0x829A, 0x9003, 0x9290, 0x9291, 0xA431];
/// ExifIFD pointer tag of IFD0.
const EXIF_IFD: u16 = 0x8769;
/// Largest directory read (entries) and tag value kept (bytes).
const MAX_ENTRIES: u64 = 4096;
const MAX_VALUE: u64 = 1 << 16;

/// Byte order and offset size of a TIFF file.
#[derive(Debug, Clone, Copy)]
struct Layout {
    big_endian: bool,
    big_tiff: bool,
}

impl Layout {
    fn u16(&self, b: &[u8]) -> u16 {
        let a = [b[0], b[1]];
        if self.big_endian {
            u16::from_be_bytes(a)
        } else {
            u16::from_le_bytes(a)
        }
    }

    fn u32(&self, b: &[u8]) -> u32 {
        let a = [b[0], b[1], b[2], b[3]];
        if self.big_endian {
            u32::from_be_bytes(a)
        } else {
            u32::from_le_bytes(a)
        }
    }

    fn u64(&self, b: &[u8]) -> u64 {
        let mut a = [0u8; 8];
        a.copy_from_slice(&b[..8]);
        if self.big_endian {
            u64::from_be_bytes(a)
        } else {
            u64::from_le_bytes(a)
        }
    }

    /// An offset or count field (4 bytes, 8 in BigTIFF).
    fn offset(&self, b: &[u8]) -> u64 {
        if self.big_tiff {
            self.u64(b)
        } else {
            u64::from(self.u32(b))
        }
    }
}

/// One directory entry.
#[derive(Debug, Clone)]
struct Entry {
    tag: u16,
    kind: u16,
    count: u64,
    /// The value field as stored (inline value or offset).
    field: [u8; 8],
}

fn read_at<R: Read + Seek>(
    r: &mut R,
    offset: u64,
    buf: &mut [u8],
) -> std::result::Result<(), String> {
    r.seek(SeekFrom::Start(offset))
        .and_then(|_| r.read_exact(buf))
        .map_err(|e| {
            format!(
                "TIFF: cannot read {} bytes at offset {offset}: {e}",
                buf.len()
            )
        })
}

fn read_directory<R: Read + Seek>(
    r: &mut R,
    layout: Layout,
    offset: u64,
) -> std::result::Result<Vec<Entry>, String> {
    let (count_len, entry_len, value_len) = if layout.big_tiff {
        (8, 20, 8)
    } else {
        (2, 12, 4)
    };
    let mut c = [0u8; 8];
    read_at(r, offset, &mut c[..count_len])?;
    let n = if layout.big_tiff {
        layout.u64(&c)
    } else {
        u64::from(layout.u16(&c))
    };
    if n > MAX_ENTRIES {
        return Err(format!(
            "TIFF: a directory of {n} entries at offset {offset}"
        ));
    }
    let mut raw = vec![0u8; n as usize * entry_len];
    read_at(r, offset + count_len as u64, &mut raw)?;
    Ok(raw
        .chunks_exact(entry_len)
        .map(|e| {
            let mut field = [0u8; 8];
            field[..value_len].copy_from_slice(&e[entry_len - value_len..]);
            Entry {
                tag: layout.u16(&e[0..2]),
                kind: layout.u16(&e[2..4]),
                count: if layout.big_tiff {
                    layout.u64(&e[4..12])
                } else {
                    u64::from(layout.u32(&e[4..8]))
                },
                field,
            }
        })
        .collect())
}

/// The bytes of an entry's value (inline or at its offset).
fn value_bytes<R: Read + Seek>(
    r: &mut R,
    layout: Layout,
    e: &Entry,
    unit: u64,
) -> std::result::Result<Vec<u8>, String> {
    let len = e.count.saturating_mul(unit);
    if len > MAX_VALUE {
        return Err(format!("TIFF: tag {:#06x} holds {len} bytes", e.tag));
    }
    let inline = if layout.big_tiff { 8 } else { 4 };
    if len <= inline {
        Ok(e.field[..len as usize].to_vec())
    } else {
        let mut buf = vec![0u8; len as usize];
        read_at(r, layout.offset(&e.field), &mut buf)?;
        Ok(buf)
    }
}

/// The entry as a kamadak-exif field (ASCII and RATIONAL values; others are skipped).
fn field<R: Read + Seek>(
    r: &mut R,
    layout: Layout,
    e: &Entry,
    context: Context,
) -> std::result::Result<Option<Field>, String> {
    let value = match e.kind {
        2 => {
            let bytes = value_bytes(r, layout, e, 1)?;
            let text: Vec<u8> = bytes.split(|&b| b == 0).next().unwrap_or(&[]).to_vec();
            Value::Ascii(vec![text])
        }
        5 => {
            let bytes = value_bytes(r, layout, e, 8)?;
            Value::Rational(
                bytes
                    .chunks_exact(8)
                    .map(|b| Rational {
                        num: layout.u32(&b[0..4]),
                        denom: layout.u32(&b[4..8]),
                    })
                    .collect(),
            )
        }
        _ => return Ok(None),
    };
    Ok(Some(Field {
        tag: Tag(context, e.tag),
        ifd_num: In::PRIMARY,
        value,
    }))
}

/// The tags of interest of a TIFF file: IFD0's and its EXIF sub-IFD's,
/// reached by seeking from the header.
fn tiff_fields<R: Read + Seek>(r: &mut R) -> std::result::Result<Vec<Field>, String> {
    let mut header = [0u8; 16];
    read_at(r, 0, &mut header[..8])?;
    let big_endian = header[0] == b'M';
    let probe = Layout {
        big_endian,
        big_tiff: false,
    };
    let big_tiff = probe.u16(&header[2..4]) == 43;
    let layout = Layout {
        big_endian,
        big_tiff,
    };
    let ifd0 = if big_tiff {
        read_at(r, 0, &mut header)?;
        layout.u64(&header[8..16])
    } else {
        u64::from(layout.u32(&header[4..8]))
    };
    if ifd0 == 0 {
        return Err("TIFF: no image directory".into());
    }
    let mut fields = Vec::new();
    let mut exif_ifd = None;
    for e in read_directory(r, layout, ifd0)? {
        if e.tag == EXIF_IFD {
            // LONG or IFD (4 bytes), LONG8 or IFD8 (8 bytes, BigTIFF).
            exif_ifd = Some(match e.kind {
                16 | 18 => layout.u64(&e.field),
                _ => u64::from(layout.u32(&e.field)),
            });
        } else if IFD0_TAGS.contains(&e.tag)
            && let Some(f) = field(r, layout, &e, Context::Tiff)?
        {
            fields.push(f);
        }
    }
    if let Some(offset) = exif_ifd.filter(|&o| o != 0) {
        for e in read_directory(r, layout, offset)? {
            if EXIF_TAGS.contains(&e.tag)
                && let Some(f) = field(r, layout, &e, Context::Exif)?
            {
                fields.push(f);
            }
        }
    }
    Ok(fields)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_keep_their_resolution() {
        let t = parse_time("2025-06-02T08:00:00.0125").unwrap();
        assert_eq!(t.resolution_ns, 100_000);
        let u = parse_time("2025-06-02T08:00:01").unwrap();
        assert_eq!(u.resolution_ns, 1_000_000_000);
        assert_eq!(u.ns - t.ns, 987_500_000);
        assert!(parse_time("2025-02-31T00:00:00").is_err());
    }
}
