//! Bad input yields an error that names the file and the problem, and a batch
//! carries on past it: corrupt, truncated, empty, colour, wrong bit depth,
//! missing files.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use extract::{CpuBackend, ExtractParams, FrameReader, Threshold, extract_files};
use image::{ExtendedColorType, ImageFormat};

const W: u32 = 64;
const H: u32 = 48;

/// A 16-bit frame: background 1000, one 12×12 square of 20000 at (20..32, 10..22).
fn frame16() -> Vec<u16> {
    (0..H)
        .flat_map(|y| {
            (0..W).map(move |x| {
                if (20..32).contains(&x) && (10..22).contains(&y) {
                    20_000
                } else {
                    1000
                }
            })
        })
        .collect()
}

fn save16(path: &Path, format: ImageFormat) {
    let bytes: Vec<u8> = frame16().iter().flat_map(|p| p.to_ne_bytes()).collect();
    image::save_buffer_with_format(path, &bytes, W, H, ExtendedColorType::L16, format).unwrap();
}

fn save8(path: &Path) {
    let bytes: Vec<u8> = frame16().iter().map(|&p| (p / 256) as u8).collect();
    image::save_buffer_with_format(path, &bytes, W, H, ExtendedColorType::L8, ImageFormat::Png)
        .unwrap();
}

fn read_err(path: &Path, depth: Option<u8>) -> String {
    let mut r = FrameReader::new().expect_bit_depth(depth);
    let e = r.read(path).expect_err("expected an error").to_string();
    assert!(
        e.contains(&path.display().to_string()),
        "error does not name the file: {e}"
    );
    e
}

#[test]
fn good_frames_decode_in_native_dn() {
    let dir = tempfile::tempdir().unwrap();
    let (tif, png16, png8) = (
        dir.path().join("a.tif"),
        dir.path().join("b.png"),
        dir.path().join("c.png"),
    );
    save16(&tif, ImageFormat::Tiff);
    save16(&png16, ImageFormat::Png);
    save8(&png8);
    let mut r = FrameReader::new();
    for p in [&tif, &png16] {
        let (f, _) = r.read(p).unwrap();
        assert_eq!((f.width, f.height, f.bit_depth), (W, H, 16));
        assert_eq!(f.pixels, &frame16()[..]);
    }
    let (f, _) = r.read(&png8).unwrap();
    assert_eq!(f.bit_depth, 8);
    assert_eq!(f.pixels[0], 1000 / 256);
    assert_eq!(f.max_value(), 255);
}

#[test]
fn bad_files_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();

    let tif = d.join("good.tif");
    save16(&tif, ImageFormat::Tiff);
    let bytes = std::fs::read(&tif).unwrap();

    let truncated = d.join("truncated.tif");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let e = read_err(&truncated, None);
    assert!(e.contains("cannot decode"), "{e}");

    let corrupt = d.join("corrupt.tif");
    let mut c = bytes.clone();
    c[4..8].copy_from_slice(&[0xff, 0xff, 0xff, 0x7f]); // IFD offset far beyond the file
    std::fs::write(&corrupt, &c).unwrap();
    assert!(read_err(&corrupt, None).contains("cannot decode"));

    let garbage = d.join("garbage.tif");
    std::fs::write(&garbage, b"this is not an image at all").unwrap();
    assert!(read_err(&garbage, None).contains("cannot decode"));

    let empty = d.join("empty.png");
    std::fs::write(&empty, b"").unwrap();
    assert!(read_err(&empty, None).contains("empty"));

    let missing = d.join("missing.tif");
    assert!(read_err(&missing, None).contains("No such file"));

    let colour = d.join("colour.png");
    image::save_buffer_with_format(
        &colour,
        &vec![0u8; (W * H * 3) as usize],
        W,
        H,
        ExtendedColorType::Rgb8,
        ImageFormat::Png,
    )
    .unwrap();
    let e = read_err(&colour, None);
    assert!(e.contains("Rgb8") && e.contains("grayscale"), "{e}");

    let png8 = d.join("eight.png");
    save8(&png8);
    let e = read_err(&png8, Some(16));
    assert!(e.contains("8-bit image where 16-bit"), "{e}");

    let jpeg = d.join("photo.jpg");
    std::fs::write(
        &jpeg,
        [0xFF, 0xD8, 0xFF, 0xE0, 0, 16, b'J', b'F', b'I', b'F', 0],
    )
    .unwrap();
    // A JPEG cut after its first header: an error naming the file (JPEG is
    // read, 8-bit, for calibration views), never a panic.
    let e = read_err(&jpeg, None);
    assert!(!e.contains("not supported"), "{e}");
    // A whole colour JPEG: its luma, 8-bit.
    let photo = d.join("whole.jpg");
    image::RgbImage::from_fn(W, H, |x, _| image::Rgb([(x % 256) as u8, 128, 30]))
        .save(&photo)
        .unwrap();
    let mut r = FrameReader::new();
    let (frame, _) = r.read(&photo).unwrap();
    assert_eq!((frame.width, frame.height, frame.bit_depth), (W, H, 8));
    // Rec. 709 luma of (0, 128, 30) ≈ 0.7152·128 + 0.0722·30 ≈ 94 (JPEG's loss aside).
    assert!(frame.pixels[0].abs_diff(94) <= 6, "{}", frame.pixels[0]);
}

#[test]
fn batch_carries_on_past_bad_files_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut files: Vec<PathBuf> = Vec::new();
    for i in 0..40 {
        let p = d.join(format!("f{i:02}.tif"));
        match i {
            7 => std::fs::write(&p, b"corrupt").unwrap(),
            23 => {} // missing
            _ => save16(&p, ImageFormat::Tiff),
        }
        files.push(p);
    }
    let params = ExtractParams {
        threshold: Threshold::Fixed(6000),
        ..ExtractParams::default()
    };
    let mut seen = Vec::new();
    extract_files(&files, &CpuBackend, &params, Some(16), |i, path, result| {
        assert_eq!(path, files[i]);
        match result {
            Ok(f) => {
                assert_eq!(f.blobs.len(), 1);
                // Square over columns 20..=31 and rows 10..=21: centre (25.5, 15.5).
                assert_eq!((f.blobs[0].u, f.blobs[0].v), (25.5, 15.5));
                seen.push((i, true));
            }
            Err(e) => {
                assert!(e.to_string().contains(&path.display().to_string()));
                seen.push((i, false));
            }
        }
    });
    assert_eq!(seen.len(), 40);
    assert!(
        seen.iter().enumerate().all(|(k, (i, _))| k == *i),
        "out of order"
    );
    let bad: Vec<usize> = seen.iter().filter(|(_, ok)| !ok).map(|(i, _)| *i).collect();
    assert_eq!(bad, vec![7, 23]);
}

#[test]
fn threshold_outside_the_bit_depth_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let png8 = dir.path().join("eight.png");
    save8(&png8);
    let mut r = FrameReader::new();
    let params = ExtractParams {
        threshold: Threshold::Fixed(6000),
        ..ExtractParams::default()
    };
    let e = extract::extract_file(&mut r, &png8, &CpuBackend, &params, None)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("eight.png") && e.contains("outside 1..=255"),
        "{e}"
    );
}

/// `frame16()` as a 16-bit TIFF through the `tiff` crate's encoder with
/// `compression`, horizontal differencing and `rows` rows per strip.
fn save_compressed(path: &Path, compression: tiff::encoder::Compression, rows: u32, eight: bool) {
    use tiff::encoder::{Predictor, TiffEncoder, colortype};
    let file = std::fs::File::create(path).unwrap();
    let mut enc = TiffEncoder::new(file)
        .unwrap()
        .with_compression(compression)
        .with_predictor(Predictor::Horizontal);
    if eight {
        let data: Vec<u8> = frame16().iter().map(|&p| (p / 256) as u8).collect();
        let mut img = enc.new_image::<colortype::Gray8>(W, H).unwrap();
        img.rows_per_strip(rows).unwrap();
        img.write_data(&data).unwrap();
    } else {
        let mut img = enc.new_image::<colortype::Gray16>(W, H).unwrap();
        img.rows_per_strip(rows).unwrap();
        img.write_data(&frame16()).unwrap();
    }
}

/// `frame16()` as a big-endian ("MM") 16-bit TIFF of Deflate strips of
/// `rows` rows with horizontal differencing, written field by field (TIFF
/// 6.0 §2), the `tiff` crate's encoder writing only little-endian files.
fn big_endian_deflate(rows: u32) -> Vec<u8> {
    let pixels = frame16();
    let strips: Vec<Vec<u8>> = pixels
        .chunks((W * rows) as usize)
        .map(|strip| {
            let mut raw = Vec::new();
            for row in strip.chunks(W as usize) {
                let mut previous = 0u16;
                for &p in row {
                    raw.extend_from_slice(&p.wrapping_sub(previous).to_be_bytes());
                    previous = p;
                }
            }
            miniz_oxide::deflate::compress_to_vec_zlib(&raw, 6)
        })
        .collect();
    let n = strips.len() as u32;
    let entries: [(u16, u16, u32, u32); 10] = [
        (256, 4, 1, W),
        (257, 4, 1, H),
        (258, 3, 1, 16 << 16),
        (259, 3, 1, 8 << 16),
        (262, 3, 1, 1 << 16),
        (273, 4, n, 0), // offsets: filled below
        (277, 3, 1, 1 << 16),
        (278, 4, 1, rows),
        (279, 4, n, 0), // byte counts: filled below
        (317, 3, 1, 2 << 16),
    ];
    let ifd_len = 2 + 12 * entries.len() as u32 + 4;
    let (offsets_at, counts_at) = (8 + ifd_len, 8 + ifd_len + 4 * n);
    let mut data_at = counts_at + 4 * n;
    let mut out = b"MM\0\x2a\0\0\0\x08".to_vec();
    out.extend_from_slice(&(entries.len() as u16).to_be_bytes());
    for (tag, kind, count, value) in entries {
        let value = match tag {
            273 => offsets_at,
            279 => counts_at,
            _ => value,
        };
        for b in [
            &tag.to_be_bytes()[..],
            &kind.to_be_bytes(),
            &count.to_be_bytes(),
            &value.to_be_bytes(),
        ] {
            out.extend_from_slice(b);
        }
    }
    out.extend_from_slice(&[0; 4]);
    for s in &strips {
        out.extend_from_slice(&data_at.to_be_bytes());
        data_at += s.len() as u32;
    }
    for s in &strips {
        out.extend_from_slice(&(s.len() as u32).to_be_bytes());
    }
    for s in &strips {
        out.extend_from_slice(s);
    }
    out
}

/// Deflate and LZW strips, 8- and 16-bit, one strip or many, little- and
/// big-endian, decode to the frame written; a strip cut short or spoilt is
/// a named error.
#[test]
fn compressed_strips_decode_to_the_pixels_written() {
    use tiff::encoder::{Compression, DeflateLevel};
    let dir = tempfile::tempdir().unwrap();
    let mut r = FrameReader::new();
    for (name, compression) in [
        ("deflate", Compression::Deflate(DeflateLevel::Balanced)),
        ("lzw", Compression::Lzw),
    ] {
        for rows in [1, 5, H] {
            for eight in [false, true] {
                let path = dir.path().join(format!("{name}_{rows}_{eight}.tif"));
                save_compressed(&path, compression, rows, eight);
                let (f, _) = r.read(&path).unwrap();
                let want: Vec<u16> = if eight {
                    frame16().iter().map(|&p| p / 256).collect()
                } else {
                    frame16()
                };
                assert_eq!(f.pixels, &want[..], "{}", path.display());
            }
        }
    }
    let big = dir.path().join("big_endian.tif");
    let bytes = big_endian_deflate(7);
    std::fs::write(&big, &bytes).unwrap();
    assert_eq!(r.read(&big).unwrap().0.pixels, &frame16()[..]);

    // The last strip's data cut short: the file ends before them.
    let cut = dir.path().join("cut.tif");
    std::fs::write(&cut, &bytes[..bytes.len() - 20]).unwrap();
    let e = read_err(&cut, None);
    assert!(e.contains("truncated"), "{e}");
    // A strip's data spoilt.
    let spoilt = dir.path().join("spoilt.tif");
    let mut s = bytes.clone();
    let at = s.len() - 30;
    s[at..at + 12].fill(0xff);
    std::fs::write(&spoilt, &s).unwrap();
    let e = read_err(&spoilt, None);
    assert!(e.contains("cannot decode") && e.contains("strip"), "{e}");
}

/// A PNG's eXIf metadata is read whether the frame comes from its file
/// (decoded from the file) or from bytes in memory.
#[test]
fn png_metadata_from_the_file_and_from_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame.png");
    let image = synth::Image16::from_raw(W, H, frame16()).unwrap();
    let meta = synth::FrameMetadata {
        make: "Maker".into(),
        model: "Model 7".into(),
        serial: "SN-42".into(),
        time_s: 1.0e9,
        exposure_s: 0.004,
        f_number: 8.0,
        focal_mm: 25.0,
        description: String::new(),
    };
    synth::write_image(
        &path,
        &image,
        16,
        &meta,
        synth::config::ImageFormat::Png,
        synth::config::TiffCompression::None,
    )
    .unwrap();
    let mut r = FrameReader::new();
    let (f, from_file) = r.read(&path).unwrap();
    assert_eq!(f.pixels, &frame16()[..]);
    assert_eq!(from_file.serial.as_deref(), Some("SN-42"));
    assert_eq!(from_file.model.as_deref(), Some("Model 7"));
    assert_eq!(from_file.exposure_s, Some(0.004));
    let bytes = std::fs::read(&path).unwrap();
    let (_, from_bytes) = r.read_bytes(&bytes, &path).unwrap();
    assert_eq!(from_bytes, from_file);
}
