//! The tags a frame's metadata needs from a TIFF file, read by seeking
//! from its header to its directories (IFD0 and the EXIF sub-IFD): the
//! pixels, tens of megabytes, are never read. Hand-written because the
//! `tiff` and kamadak-exif readers both want the whole file in memory (or
//! decode more than the tags); the tags are interpreted by
//! [`crate::FrameMetadata::from_fields`].

use std::io::{Read, Seek, SeekFrom};

use exif::{Context, Field, In, Rational, Tag, Value};

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
pub fn tiff_fields<R: Read + Seek>(r: &mut R) -> std::result::Result<Vec<Field>, String> {
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
