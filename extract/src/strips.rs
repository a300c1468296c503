//! A TIFF's Deflate- or LZW-compressed strips (TIFF 6.0 §3, §13; Adobe
//! Deflate) decoded in parallel, each straight into its rows of the frame,
//! the horizontal differencing (§14, Predictor = 2) undone row by row.
//!
//! Written here, beside the `tiff` crate that reads the tags, because that
//! crate decodes strips one after the other and inflates through `flate2`'s
//! `miniz_oxide`: `fdeflate` (the `png` crate's inflater) decodes the
//! renderer's full frames 2.1× faster, `weezl` (which the `tiff` crate uses
//! for LZW too) 1.2× faster without the crate's copies
//! (`benches/decoders.rs`, docs/performance.md). Strips are independent
//! streams, so a multi-strip file decodes on every thread. Tiled files and
//! other codecs stay with the `tiff` crate.

use std::io::{Read, Seek, SeekFrom};

use rayon::prelude::*;
use tiff::decoder::{ChunkType, Decoder};
use tiff::tags::Tag;

/// TIFF Compression values decoded here.
const LZW: u16 = 5;
const DEFLATE: u16 = 8;
const ADOBE_DEFLATE: u16 = 32946;

/// How a file's strips are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Codec {
    Deflate,
    Lzw,
}

/// Why strips could not be decoded: the message, and whether the file ends
/// before its data do.
#[derive(Debug)]
pub(crate) struct StripError {
    pub(crate) message: String,
    pub(crate) truncated: bool,
}

impl StripError {
    fn new(message: String) -> Self {
        Self {
            message,
            truncated: false,
        }
    }
}

/// The strips of an image this module decodes.
#[derive(Debug)]
pub(crate) struct Strips {
    codec: Codec,
    /// Predictor 2: each row's samples are differences from the one before.
    differenced: bool,
    big_endian: bool,
    rows_per_strip: usize,
    /// (offset, byte count) of each strip in the file.
    chunks: Vec<(u64, u64)>,
}

impl Strips {
    /// The strips of `dec`'s image of `height` rows, when it is one this
    /// module decodes (stored in strips, Deflate or LZW, no predictor or
    /// predictor 2); `Ok(None)` otherwise.
    pub(crate) fn of<R: Read + Seek>(
        dec: &mut Decoder<R>,
        height: u32,
    ) -> tiff::TiffResult<Option<Self>> {
        if dec.get_chunk_type() != ChunkType::Strip {
            return Ok(None);
        }
        let codec = match dec.find_tag_unsigned::<u16>(Tag::Compression)? {
            Some(DEFLATE | ADOBE_DEFLATE) => Codec::Deflate,
            Some(LZW) => Codec::Lzw,
            _ => return Ok(None),
        };
        let differenced = match dec.find_tag_unsigned::<u16>(Tag::Predictor)? {
            None | Some(1) => false,
            Some(2) => true,
            Some(_) => return Ok(None),
        };
        let offsets = dec.get_tag_u64_vec(Tag::StripOffsets)?;
        let counts = dec.get_tag_u64_vec(Tag::StripByteCounts)?;
        let rows = dec
            .find_tag_unsigned::<u32>(Tag::RowsPerStrip)?
            .unwrap_or(height)
            .clamp(1, height.max(1));
        if offsets.len() != counts.len() || offsets.len() != height.div_ceil(rows) as usize {
            return Ok(None);
        }
        Ok(Some(Self {
            codec,
            differenced,
            big_endian: dec.byte_order() == tiff::tags::ByteOrder::BigEndian,
            rows_per_strip: rows as usize,
            chunks: offsets.into_iter().zip(counts).collect(),
        }))
    }

    /// Decode into `out`, rows of `row_samples` samples of `depth` bits (8
    /// or 16; 16-bit samples in native order), reading the strips from
    /// `source` into `compressed` (reused between frames).
    pub(crate) fn decode<R: Read + Seek>(
        &self,
        source: &mut R,
        compressed: &mut Vec<u8>,
        out: &mut [u8],
        row_samples: usize,
        depth: u8,
    ) -> Result<(), StripError> {
        let io = |e: std::io::Error| StripError {
            truncated: e.kind() == std::io::ErrorKind::UnexpectedEof,
            message: e.to_string(),
        };
        let file_len = source.seek(SeekFrom::End(0)).map_err(io)?;
        let row_bytes = row_samples * usize::from(depth / 8);
        let strip_bytes = (self.rows_per_strip * row_bytes).max(1);
        // A few strips per thread at a time: the compressed bytes held stay
        // a fraction of the file's.
        let batch = 2 * rayon::current_num_threads();
        let mut spans = Vec::with_capacity(batch);
        for (b, (group, rows)) in self
            .chunks
            .chunks(batch)
            .zip(out.chunks_mut(batch * strip_bytes))
            .enumerate()
        {
            // The group's bytes, one strip after another; never more than
            // the file holds.
            compressed.clear();
            spans.clear();
            for (i, &(offset, count)) in group.iter().enumerate() {
                if offset.checked_add(count).is_none_or(|end| end > file_len) {
                    return Err(StripError {
                        message: format!(
                            "strip {} ({count} bytes at {offset}) ends beyond the file's {file_len} bytes",
                            b * batch + i
                        ),
                        truncated: true,
                    });
                }
                let start = compressed.len();
                let count = usize::try_from(count).map_err(|e| StripError::new(e.to_string()))?;
                compressed.resize(start + count, 0);
                source.seek(SeekFrom::Start(offset)).map_err(io)?;
                source.read_exact(&mut compressed[start..]).map_err(io)?;
                spans.push(start..start + count);
            }
            let bytes = &compressed[..];
            rows.par_chunks_mut(strip_bytes)
                .zip(spans.par_iter())
                .enumerate()
                .try_for_each(|(i, (rows, span))| {
                    self.decode_strip(b * batch + i, &bytes[span.clone()], rows, row_bytes, depth)
                })?;
        }
        Ok(())
    }

    /// Decompress strip `k` into its `rows`, and finish them.
    fn decode_strip(
        &self,
        k: usize,
        input: &[u8],
        rows: &mut [u8],
        row_bytes: usize,
        depth: u8,
    ) -> Result<(), StripError> {
        let n = self
            .inflate(input, rows)
            .map_err(|e| StripError::new(format!("strip {k}: {} data: {e}", self.name())))?;
        if n != rows.len() {
            return Err(StripError {
                message: format!(
                    "strip {k} decodes to {n} bytes where its {} rows need {}",
                    rows.len() / row_bytes,
                    rows.len()
                ),
                truncated: true,
            });
        }
        self.finish_rows(rows, row_bytes, depth);
        Ok(())
    }

    fn name(&self) -> &'static str {
        match self.codec {
            Codec::Deflate => "Deflate",
            Codec::Lzw => "LZW",
        }
    }

    /// Decompress one strip into `out`; the bytes written (at most `out.len()`).
    fn inflate(&self, input: &[u8], out: &mut [u8]) -> Result<usize, String> {
        match self.codec {
            Codec::Deflate => {
                let mut d = fdeflate::Decompressor::new();
                let (mut i, mut o) = (0, 0);
                while o < out.len() && !d.is_done() {
                    let (read, written) = d
                        .read(&input[i..], out, o, true)
                        .map_err(|e| format!("{e:?}"))?;
                    (i, o) = (i + read, o + written);
                    if read == 0 && written == 0 {
                        break;
                    }
                }
                Ok(o.min(out.len()))
            }
            Codec::Lzw => {
                let mut d = weezl::decode::Decoder::with_tiff_size_switch(weezl::BitOrder::Msb, 8);
                let (mut i, mut o) = (0, 0);
                while o < out.len() {
                    let r = d.decode_bytes(&input[i..], &mut out[o..]);
                    (i, o) = (i + r.consumed_in, o + r.consumed_out);
                    match r.status.map_err(|e| e.to_string())? {
                        weezl::LzwStatus::Ok if r.consumed_in + r.consumed_out > 0 => {}
                        _ => break,
                    }
                }
                Ok(o)
            }
        }
    }

    /// 16-bit samples to native order, then the differencing undone.
    fn finish_rows(&self, rows: &mut [u8], row_bytes: usize, depth: u8) {
        for row in rows.chunks_exact_mut(row_bytes) {
            if depth == 16 {
                let mut previous = 0u16;
                for sample in row.chunks_exact_mut(2) {
                    let bytes = [sample[0], sample[1]];
                    let mut value = if self.big_endian {
                        u16::from_be_bytes(bytes)
                    } else {
                        u16::from_le_bytes(bytes)
                    };
                    if self.differenced {
                        value = value.wrapping_add(previous);
                        previous = value;
                    }
                    sample.copy_from_slice(&value.to_ne_bytes());
                }
            } else if self.differenced {
                for x in 1..row.len() {
                    row[x] = row[x].wrapping_add(row[x - 1]);
                }
            }
        }
    }
}
