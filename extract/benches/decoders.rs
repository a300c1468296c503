//! The decoders of the formats cameras write, on the seed frame (4096×3072,
//! 16-bit, three spheres, full noise) as the renderer writes it: ours
//! (`FrameReader`: an uncompressed TIFF from the file, a compressed one's
//! strips in parallel by `extract::strips`, PNG through `image`/`png`) beside the other maintained Rust decoders of each format, in the same
//! run, each from the file in the page cache to 16-bit pixels in memory:
//! the `tiff` crate's plain decoder, a TIFF's strips inflated by
//! `zune-inflate`, `miniz_oxide` and `fdeflate` or unpacked by `weezl` (the
//! horizontal differencing undone after), the `png` crate and `zune-png`
//! (docs/performance.md states the figures). Run:
//! `cargo bench -p extract --bench decoders`.

#![allow(missing_docs, clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use synth::config::{ImageFormat, TiffCompression};
use tiff::decoder::Decoder;
use tiff::tags::Tag;

mod common;

use common::{H, W};

/// The seed frame written in each format into a folder kept for the run.
struct Files {
    _dir: tempfile::TempDir,
    plain: PathBuf,
    deflate: PathBuf,
    lzw: PathBuf,
    png: PathBuf,
}

fn files() -> &'static Files {
    static FILES: OnceLock<Files> = OnceLock::new();
    FILES.get_or_init(|| {
        let image = common::seed_image();
        let meta = synth::FrameMetadata {
            make: "bench".into(),
            model: "bench".into(),
            serial: "0".into(),
            time_s: 0.0,
            exposure_s: 0.002,
            f_number: 8.0,
            focal_mm: 25.0,
            description: String::new(),
        };
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, format, compression| {
            let path = dir.path().join(name);
            synth::write_image(&path, &image, 16, &meta, format, compression).unwrap();
            path
        };
        Files {
            plain: write("plain.tif", ImageFormat::Tiff, TiffCompression::None),
            deflate: write("deflate.tif", ImageFormat::Tiff, TiffCompression::Deflate),
            lzw: write("lzw.tif", ImageFormat::Tiff, TiffCompression::Lzw),
            png: write("frame.png", ImageFormat::Png, TiffCompression::None),
            _dir: dir,
        }
    })
}

fn main() {
    let f = files();
    for p in [&f.plain, &f.deflate, &f.lzw, &f.png] {
        let n = std::fs::metadata(p).unwrap().len();
        eprintln!(
            "{}: {:.1} MB",
            p.file_name().unwrap().to_string_lossy(),
            n as f64 / 1e6
        );
    }
    eprintln!("strips per TIFF: {}", strips(&f.deflate).0.len());
    // Every decoder here gives the same pixels.
    let reference = ours_pixels(&f.plain);
    for p in [&f.deflate, &f.lzw, &f.png] {
        assert!(ours_pixels(p) == reference, "{}", p.display());
    }
    for p in [&f.plain, &f.deflate, &f.lzw] {
        let mut dec = Decoder::new(std::fs::File::open(p).unwrap()).unwrap();
        match dec.read_image().unwrap() {
            tiff::decoder::DecodingResult::U16(v) => assert!(v == reference),
            _ => panic!("not 16-bit"),
        }
    }
    divan::main();
}

fn ours_pixels(path: &Path) -> Vec<u16> {
    extract::FrameReader::new()
        .read(path)
        .unwrap()
        .0
        .pixels
        .to_vec()
}

/// Ours: a reader kept between frames, as `extract` and `measure` use it
/// (a compressed TIFF's strips on all threads).
fn ours(bencher: divan::Bencher, path: &Path) {
    let mut reader = extract::FrameReader::new();
    bencher.bench_local(|| reader.read(path).unwrap().0.pixels[1000]);
}

/// Ours on one thread, as each thread of a batch decodes its own frame.
fn ours_1_thread(bencher: divan::Bencher, path: &Path) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut reader = extract::FrameReader::new();
    bencher.bench_local(|| pool.install(|| reader.read(path).unwrap().0.pixels[1000]));
}

/// The `tiff` crate's own decoder on the file, into a fresh buffer.
fn tiff_crate(bencher: divan::Bencher, path: &Path) {
    bencher.bench_local(|| {
        let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let mut dec = Decoder::new(file).unwrap();
        match dec.read_image().unwrap() {
            tiff::decoder::DecodingResult::U16(v) => v[1000],
            _ => panic!("not 16-bit"),
        }
    });
}

/// The strips (offset, length) and rows per strip of a TIFF.
fn strips(path: &Path) -> (Vec<(usize, usize)>, usize) {
    let mut dec = Decoder::new(std::fs::File::open(path).unwrap()).unwrap();
    let offsets = dec.get_tag_u64_vec(Tag::StripOffsets).unwrap();
    let counts = dec.get_tag_u64_vec(Tag::StripByteCounts).unwrap();
    let rows = dec.get_tag_u32(Tag::RowsPerStrip).unwrap_or(H) as usize;
    let strips = offsets
        .iter()
        .zip(&counts)
        .map(|(&o, &c)| (o as usize, c as usize))
        .collect();
    (strips, rows)
}

/// Read the file, decompress each strip with `inflate` into its rows of
/// the frame (little-endian 16-bit), then undo the horizontal differencing.
fn by_strips(bencher: divan::Bencher, path: &Path, inflate: impl Fn(&[u8], &mut [u8]) -> usize) {
    let (strips, rows) = strips(path);
    let mut frame = vec![0u16; (W * H) as usize];
    bencher.bench_local(|| {
        let bytes = std::fs::read(path).unwrap();
        for (k, &(o, c)) in strips.iter().enumerate() {
            let first = k * rows * W as usize;
            let last = ((k + 1) * rows).min(H as usize) * W as usize;
            let out = bytemuck::cast_slice_mut(&mut frame[first..last]);
            assert_eq!(inflate(&bytes[o..o + c], out), out.len());
        }
        for row in frame.chunks_exact_mut(W as usize) {
            for x in 1..row.len() {
                row[x] = row[x].wrapping_add(row[x - 1]);
            }
        }
        frame[1000]
    });
}

#[divan::bench_group(sample_count = 20)]
mod uncompressed_tiff {
    use super::*;

    #[divan::bench]
    fn ours(b: divan::Bencher) {
        super::ours(b, &files().plain);
    }

    #[divan::bench]
    fn tiff_crate(b: divan::Bencher) {
        super::tiff_crate(b, &files().plain);
    }

    /// The floor: the file's bytes read into a kept buffer.
    #[divan::bench]
    fn read_only(b: divan::Bencher) {
        use std::io::Read;
        let mut buf = Vec::new();
        b.bench_local(|| {
            buf.clear();
            std::fs::File::open(&files().plain)
                .unwrap()
                .read_to_end(&mut buf)
                .unwrap()
        });
    }
}

#[divan::bench_group(sample_count = 10)]
mod deflate_tiff {
    use super::*;

    #[divan::bench]
    fn ours(b: divan::Bencher) {
        super::ours(b, &files().deflate);
    }

    #[divan::bench]
    fn ours_1_thread(b: divan::Bencher) {
        super::ours_1_thread(b, &files().deflate);
    }

    #[divan::bench]
    fn tiff_crate(b: divan::Bencher) {
        super::tiff_crate(b, &files().deflate);
    }

    #[divan::bench]
    fn strips_zune_inflate(b: divan::Bencher) {
        by_strips(b, &files().deflate, |src, out| {
            let v = zune_inflate::DeflateDecoder::new(src)
                .decode_zlib()
                .unwrap();
            out.copy_from_slice(&v);
            v.len()
        });
    }

    #[divan::bench]
    fn strips_miniz_oxide(b: divan::Bencher) {
        by_strips(b, &files().deflate, |src, out| {
            let flags = miniz_oxide::inflate::core::inflate_flags::TINFL_FLAG_PARSE_ZLIB_HEADER
                | miniz_oxide::inflate::core::inflate_flags::TINFL_FLAG_USING_NON_WRAPPING_OUTPUT_BUF;
            let mut state = miniz_oxide::inflate::core::DecompressorOxide::new();
            let (_, _, n) = miniz_oxide::inflate::core::decompress(&mut state, src, out, 0, flags);
            n
        });
    }

    #[divan::bench]
    fn strips_fdeflate(b: divan::Bencher) {
        by_strips(b, &files().deflate, |src, out| {
            let mut d = fdeflate::Decompressor::new();
            let (_, n) = d.read(src, out, 0, true).unwrap();
            n
        });
    }
}

#[divan::bench_group(sample_count = 10)]
mod lzw_tiff {
    use super::*;

    #[divan::bench]
    fn ours(b: divan::Bencher) {
        super::ours(b, &files().lzw);
    }

    #[divan::bench]
    fn ours_1_thread(b: divan::Bencher) {
        super::ours_1_thread(b, &files().lzw);
    }

    #[divan::bench]
    fn tiff_crate(b: divan::Bencher) {
        super::tiff_crate(b, &files().lzw);
    }

    #[divan::bench]
    fn strips_weezl(b: divan::Bencher) {
        by_strips(b, &files().lzw, |src, out| {
            let mut d = weezl::decode::Decoder::with_tiff_size_switch(weezl::BitOrder::Msb, 8);
            let (mut i, mut o) = (0, 0);
            while o < out.len() {
                let r = d.decode_bytes(&src[i..], &mut out[o..]);
                (i, o) = (i + r.consumed_in, o + r.consumed_out);
                match r.status.unwrap() {
                    weezl::LzwStatus::Ok => {}
                    _ => break,
                }
            }
            o
        });
    }
}

#[divan::bench_group(sample_count = 10)]
mod png {
    use super::*;

    #[divan::bench]
    fn ours(b: divan::Bencher) {
        super::ours(b, &files().png);
    }

    #[divan::bench]
    fn zune_png(b: divan::Bencher) {
        b.bench_local(|| {
            let bytes = std::fs::read(&files().png).unwrap();
            let mut dec = zune_png::PngDecoder::new(zune_png::zune_core::bytestream::ZCursor::new(
                &bytes[..],
            ));
            match dec.decode().unwrap() {
                zune_png::zune_core::result::DecodingResult::U16(v) => v[1000],
                _ => panic!("not 16-bit"),
            }
        });
    }

    #[divan::bench]
    fn png_crate(b: divan::Bencher) {
        let mut buf = Vec::new();
        b.bench_local(|| {
            let file = std::io::BufReader::new(std::fs::File::open(&files().png).unwrap());
            let mut reader = ::png::Decoder::new(file).read_info().unwrap();
            buf.resize(reader.output_buffer_size().unwrap(), 0);
            reader.next_frame(&mut buf).unwrap();
            buf[1000]
        });
    }
}
