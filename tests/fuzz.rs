//! Fuzzing of every reader of user files, on stable Rust: each reader gets
//! arbitrary bytes and mutations of a small corpus of valid files, from a
//! seeded generator (the same seed gives the same inputs). A reader may
//! refuse an input with an error; a panic is a bug, and an abort (a huge
//! allocation under `ulimit -v`) ends the run.
//!
//! The default test run feeds 10³ inputs per reader; the long run
//! (docs/bad-input.md) 10⁵ or `TRINOCULAR_FUZZ_INPUTS`:
//!
//! ```sh
//! (ulimit -v 4194304; cargo test --test fuzz -- --ignored --nocapture)
//! ```
//!
//! The mutator is written here rather than taken from a fuzzing crate:
//! cargo-fuzz and libFuzzer need nightly Rust, and proptest's shrinking is
//! no use for a throughput run; what is needed is ~60 lines.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use extract::{Backend, CpuBackend, ExtractParams, FrameReader};

/// Inputs per reader in the default test run.
const SHORT_RUN: u64 = 1_000;
/// Inputs per reader in the long run.
const LONG_RUN: u64 = 100_000;
/// Largest frame the fuzzed decoder accepts: a mutated header claiming the
/// default 2²⁸ pixels would cost 512 MiB per input (the limit itself is
/// checked by the corpus case `extract_tiff_header_over_max_pixels`).
const FUZZ_MAX_PIXELS: u64 = 1 << 20;

/// SplitMix64: a seeded stream of 64-bit values.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (n > 0).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// Text that breaks readers: extreme numbers, separators, quotes, bytes
/// that are not UTF-8.
const TOKENS: &[&str] = &[
    "0",
    "-0",
    "1e300",
    "-1e300",
    "1e-320",
    "NaN",
    "inf",
    "-inf",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "18446744073709551616",
    "-1",
    "65536",
    "255",
    ",",
    ",,",
    "\n",
    "\r\n",
    "\r",
    "\"",
    "\"\"",
    " ",
    "\t",
    ";",
    "{",
    "}",
    "[",
    "]",
    ":",
    "=",
    "#",
    "\u{feff}",
    "\u{0}",
    "\u{ff}",
    "µ",
    "[[spheres]]",
    "[procedure]",
    "true",
    "null",
    "\"P\"",
];

/// Binary values that break headers (as little- and big-endian u16/u32).
const WORDS: &[u32] = &[
    0,
    1,
    2,
    3,
    7,
    8,
    16,
    0xFF,
    0x100,
    0x7FFF,
    0x8000,
    0xFFFF,
    0x1_0000,
    0x7FFF_FFFF,
    0x8000_0000,
    0xFFFF_FFFF,
];

/// One mutation of `input` (the corpus gives `other` to splice from).
fn mutate_once(rng: &mut Rng, data: &mut Vec<u8>, other: &[u8]) {
    let at = |rng: &mut Rng, data: &Vec<u8>| rng.below(data.len() + 1);
    match rng.below(10) {
        0 if !data.is_empty() => {
            let i = rng.below(data.len());
            data[i] ^= 1 << rng.below(8);
        }
        1 if !data.is_empty() => {
            let i = rng.below(data.len());
            data[i] = rng.next() as u8;
        }
        2 => {
            let i = at(rng, data);
            let token = rng.pick(TOKENS).as_bytes();
            data.splice(i..i, token.iter().copied());
        }
        3 if !data.is_empty() => {
            // Replace a run of digits (or any short run) by a token.
            let i = rng.below(data.len());
            let mut j = i;
            while j < data.len() && (data[j].is_ascii_digit() || data[j] == b'.') {
                j += 1;
            }
            let j = j.max((i + 1).min(data.len()));
            let token = rng.pick(TOKENS).as_bytes();
            data.splice(i..j, token.iter().copied());
        }
        4 if data.len() >= 4 => {
            let i = rng.below(data.len() - 3);
            let w = *rng.pick(WORDS);
            let bytes = match rng.below(4) {
                0 => w.to_le_bytes(),
                1 => w.to_be_bytes(),
                2 => {
                    let [a, b] = (w as u16).to_le_bytes();
                    [a, b, data[i + 2], data[i + 3]]
                }
                _ => {
                    let [a, b] = (w as u16).to_be_bytes();
                    [a, b, data[i + 2], data[i + 3]]
                }
            };
            data[i..i + 4].copy_from_slice(&bytes);
        }
        5 if !data.is_empty() => {
            let i = rng.below(data.len());
            let n = rng.below((data.len() - i).min(64)) + 1;
            data.drain(i..i + n);
        }
        6 if !data.is_empty() => {
            let i = rng.below(data.len());
            let n = rng.below((data.len() - i).min(64)) + 1;
            let copy: Vec<u8> = data[i..i + n].to_vec();
            let j = at(rng, data);
            data.splice(j..j, copy);
        }
        7 => {
            let n = rng.below(data.len() + 1);
            data.truncate(n);
        }
        8 if !other.is_empty() => {
            let i = rng.below(other.len());
            let n = rng.below((other.len() - i).min(256)) + 1;
            let j = at(rng, data);
            let k = (j + n).min(data.len());
            data.splice(j..k, other[i..i + n].iter().copied());
        }
        _ => {
            let i = at(rng, data);
            let n = rng.below(16) + 1;
            let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
            data.splice(i..i, bytes);
        }
    }
}

/// The next input of a reader: arbitrary bytes (1 in 10), or mutations of a
/// corpus file — one to three (most inputs: nearly valid files reach the
/// checks behind the parser), or up to eight.
fn input(rng: &mut Rng, corpus: &[Vec<u8>]) -> Vec<u8> {
    if rng.below(10) == 0 {
        let n = rng.below(512);
        return (0..n).map(|_| rng.next() as u8).collect();
    }
    let mut data = rng.pick(corpus).clone();
    let other = rng.pick(corpus).clone();
    let mutations = if rng.below(2) == 0 {
        rng.below(3) + 1
    } else {
        rng.below(8) + 1
    };
    for _ in 0..mutations {
        mutate_once(rng, &mut data, &other);
    }
    data
}

/// A reader under test: its name, its valid files, and a function that
/// reads one input (written to `path`) and returns whether it was accepted.
struct Target {
    name: &'static str,
    file: &'static str,
    corpus: Vec<Vec<u8>>,
    read: Reader,
}

/// A reader under test: the input's path and bytes → accepted.
type Reader = Box<dyn Fn(&Path, &[u8]) -> bool>;

fn testdata(rel: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("testdata")
        .join(rel);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Valid frames: 16- and 8-bit TIFF (plain, Deflate, LZW) and PNG, with
/// the renderer's EXIF tags, 24 × 16 px with a bright disc.
fn frames() -> Vec<Vec<u8>> {
    use synth::config::{ImageFormat, TiffCompression};
    let (w, h) = (24u32, 16u32);
    let pixels: Vec<u16> = (0..w * h)
        .map(|i| {
            let (x, y) = (f64::from(i % w) - 11.5, f64::from(i / w) - 7.5);
            if x.hypot(y) < 5.0 {
                50_000
            } else {
                1000 + (i % 7) as u16
            }
        })
        .collect();
    let image = synth::Image16::from_raw(w, h, pixels).unwrap();
    let meta = synth::FrameMetadata {
        make: "Maker".into(),
        model: "Model 1".into(),
        serial: "SN123".into(),
        time_s: 1.7e9 + 0.25,
        exposure_s: 0.002,
        f_number: 8.0,
        focal_mm: 40.0,
        description: "fuzz".into(),
    };
    let mut out = Vec::new();
    for (format, compression) in [
        (ImageFormat::Tiff, TiffCompression::None),
        (ImageFormat::Tiff, TiffCompression::Deflate),
        (ImageFormat::Tiff, TiffCompression::Lzw),
        (ImageFormat::Png, TiffCompression::None),
    ] {
        for bits in [8, 16] {
            let mut bytes = std::io::Cursor::new(Vec::new());
            let path = Path::new("frame");
            match format {
                ImageFormat::Tiff => {
                    synth::encode_tiff(&mut bytes, &image, bits, &meta, compression, path)
                }
                ImageFormat::Png => synth::encode_png(&mut bytes, &image, bits, &meta, path),
            }
            .unwrap();
            out.push(bytes.into_inner());
        }
    }
    out
}

fn csv_target<T: formats::Record + 'static>(name: &'static str, corpus: Vec<Vec<u8>>) -> Target {
    Target {
        name,
        file: "input.csv",
        corpus,
        read: Box::new(|path, _| formats::read_csv::<T>(path).is_ok()),
    }
}

fn targets() -> Vec<Target> {
    use formats::probe::{indexing, rotary, tracer, volumetric};
    let shared = |f: &str| testdata(&format!("bad/_shared/{f}"));
    let probe = |f: &str| testdata(&format!("probe/{f}"));
    let manifest = testdata("bad/_shared/manifest.csv");
    let grid = probe("tracer/grid.csv");
    let default_config = synth::config::DEFAULT_TOML.as_bytes().to_vec();
    let report = {
        // An evaluate report of the shared points, as `probe volumetric --from-report` reads it.
        let report = evaluate::evaluate_file(
            &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("testdata/bad/_shared/points.csv"),
            &evaluate::Options::default(),
        )
        .unwrap();
        serde_json::to_vec_pretty(&report).unwrap()
    };
    let mut t = vec![
        csv_target::<formats::ManifestRow>("manifest.csv", vec![manifest.clone()]),
        Target {
            name: "rig.json",
            file: "rig.json",
            corpus: vec![shared("rig.json")],
            read: Box::new(|p, _| formats::read_rig(p).is_ok()),
        },
        Target {
            name: "nominal.json",
            file: "nominal.json",
            corpus: vec![shared("nominal.json")],
            read: Box::new(|p, _| formats::read_nominal(p).is_ok()),
        },
        Target {
            name: "points.csv (evaluate)",
            file: "points.csv",
            corpus: vec![shared("points.csv")],
            read: Box::new(|p, _| {
                evaluate::evaluate_file(p, &evaluate::Options::default()).is_ok()
            }),
        },
        Target {
            name: "target.csv",
            file: "target.csv",
            corpus: vec![shared("target.csv")],
            read: Box::new(|p, _| {
                formats::read_target(p).is_ok_and(|rows| {
                    let rows: Vec<_> = rows.into_iter().map(|r| r.record).collect();
                    calib::check_target(&rows).is_ok()
                })
            }),
        },
        Target {
            name: "points_camN.csv",
            file: "points_cam1.csv",
            corpus: vec![shared("points_cam1.csv")],
            read: Box::new(|p, _| formats::read_correspondences(p).is_ok()),
        },
        Target {
            name: "views.csv",
            file: "views.csv",
            corpus: vec![
                b"image,camera,pose\nview1.csv,1,0\nview2.csv,2,0\nview3.csv,1,1\n".to_vec(),
                b"image,camera,pose,offset_x,offset_y,offset_z\na.csv,1,0,0,0,0\nb.csv,3,2,10.5,-3,0\n"
                    .to_vec(),
            ],
            read: Box::new(|p, _| formats::read_views(p).is_ok()),
        },
        Target {
            name: "spheres.csv",
            file: "spheres.csv",
            corpus: vec![shared("spheres.csv")],
            read: Box::new(|p, _| formats::read_spheres(p).is_ok()),
        },
        csv_target::<formats::BlobRow>(
            "blobs.csv",
            vec![
                b"image,blob,u,v,area_px,diameter_px,peak,saturated,touches_border,sphere,signal,\
major_px,minor_px,orientation_rad,circularity,threshold,camera_model,camera_serial,datetime,\
exposure_s\nimages/a.tif,0,96.9,68.3,343,20.9,52000,false,false,A,1.5e7,21.0,20.8,0.3,0.99,\
6000 DN,Model 1,SN123,2026-11-21T10:15:30.25,0.002\n"
                    .to_vec(),
            ],
        ),
        Target {
            name: "synth config.toml",
            file: "config.toml",
            corpus: vec![
                default_config.clone(),
                b"seed = 3\n[sensor]\nwidth = 64\nheight = 48\n[procedure]\nruns = 2\n".to_vec(),
            ],
            read: Box::new(|_, bytes| {
                std::str::from_utf8(bytes)
                    .is_ok_and(|text| synth::Config::from_toml_str(text, None).is_ok())
            }),
        },
        Target {
            name: "synth probe rotary config",
            file: "rotary.toml",
            corpus: vec![synth::probe::rotary::DEFAULT_TOML.as_bytes().to_vec()],
            read: Box::new(|_, bytes| {
                std::str::from_utf8(bytes).is_ok_and(|text| {
                    synth::probe::rotary::RotaryConfig::from_toml_str(text, None).is_ok()
                })
            }),
        },
        Target {
            name: "synth probe indexing config",
            file: "indexing.toml",
            corpus: vec![synth::probe::indexing::DEFAULT_TOML.as_bytes().to_vec()],
            read: Box::new(|_, bytes| {
                std::str::from_utf8(bytes).is_ok_and(|text| {
                    synth::probe::indexing::IndexingConfig::from_toml_str(text, None).is_ok()
                })
            }),
        },
        Target {
            name: "probe rotary centres",
            file: "centres.csv",
            corpus: vec![probe("rotary/centres.csv")],
            read: Box::new(|p, _| rotary::read_centres(p).is_ok()),
        },
        Target {
            name: "probe rotary points",
            file: "points.csv",
            corpus: vec![probe("rotary/points.csv")],
            read: Box::new(|p, _| rotary::read_points(p).is_ok()),
        },
        Target {
            name: "probe indexing centres",
            file: "centres.csv",
            corpus: vec![probe("indexing/centres.csv")],
            read: Box::new(|p, _| indexing::read_centres(p).is_ok()),
        },
        Target {
            name: "probe tracer grid",
            file: "grid.csv",
            corpus: vec![grid.clone()],
            read: Box::new(|p, _| tracer::read_grid(p).is_ok()),
        },
        Target {
            name: "probe tracer readings",
            file: "readings.csv",
            corpus: vec![probe("tracer/readings.csv")],
            read: Box::new(move |p, _| {
                let grid_path = p.with_file_name("grid.csv");
                std::fs::write(&grid_path, &grid).unwrap();
                let grid = tracer::read_grid(&grid_path).unwrap();
                tracer::read_readings(p, &grid, &grid_path).is_ok()
            }),
        },
        Target {
            name: "probe tracer query",
            file: "query.csv",
            corpus: vec![b"x,y,z\n10.5,20,30\n-1,0,1e3\n".to_vec()],
            read: Box::new(|p, _| tracer::read_query(p).is_ok()),
        },
        Target {
            name: "probe volumetric errors",
            file: "errors.csv",
            corpus: vec![probe("volumetric/errors.csv")],
            read: Box::new(|p, _| volumetric::read_errors(p).is_ok()),
        },
        Target {
            name: "probe volumetric at",
            file: "at.csv",
            corpus: vec![probe("volumetric/at.csv")],
            read: Box::new(|p, _| volumetric::read_at(p).is_ok()),
        },
        Target {
            name: "probe volumetric report.json",
            file: "report.json",
            corpus: vec![report],
            read: Box::new(|p, _| volumetric::read_evaluate_report(p.parent().unwrap()).is_ok()),
        },
    ];
    let params = ExtractParams {
        max_pixels: FUZZ_MAX_PIXELS,
        ..ExtractParams::default()
    };
    t.push(Target {
        name: "TIFF/PNG decode + metadata + extraction",
        file: "frame.tif",
        corpus: frames(),
        read: Box::new(move |p, bytes| {
            let mut reader = FrameReader::new().limit_pixels(FUZZ_MAX_PIXELS);
            match reader.read_bytes(bytes, p) {
                Ok((frame, _metadata)) => CpuBackend.extract(frame, &params).is_ok(),
                Err(_) => false,
            }
        }),
    });
    // Added after the others: their inputs keep the streams of earlier runs.
    t.push(Target {
        name: "program.toml (manifest)",
        file: "program.toml",
        corpus: vec![default_config.clone()],
        read: Box::new(|p, _| ingest::read_program(p).is_ok()),
    });
    t.push(Target {
        name: "frame metadata alone (manifest)",
        file: "frame.tif",
        corpus: frames(),
        read: Box::new(|p, _| ingest::read_metadata(p).is_ok()),
    });
    t
}

/// Feed `count` inputs to every reader; returns the lines of the summary
/// and the panics found (reader, input number, message).
fn fuzz(count: u64, seed: u64) -> (Vec<String>, Vec<String>) {
    static QUIET: AtomicBool = AtomicBool::new(false);
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !QUIET.load(Ordering::Relaxed) {
            default_hook(info);
        }
    }));
    // A memory file system where there is one: every input is a file.
    let dir = if Path::new("/dev/shm").is_dir() {
        tempfile::tempdir_in("/dev/shm").unwrap()
    } else {
        tempfile::tempdir().unwrap()
    };
    let failures_dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-panics");
    let mut summary = Vec::new();
    let mut panics = Vec::new();
    // One reader or a few: TRINOCULAR_FUZZ_ONLY=<part of their names>.
    let only = std::env::var("TRINOCULAR_FUZZ_ONLY").ok();
    for (t, target) in targets().iter().enumerate() {
        if only.as_deref().is_some_and(|o| !target.name.contains(o)) {
            continue;
        }
        let start = Instant::now();
        let mut rng = Rng(seed ^ (t as u64).wrapping_mul(0xA076_1D64_78BD_642F));
        let path = dir.path().join(target.file);
        let mut accepted = 0u64;
        let mut found = 0u64;
        for k in 0..count {
            let data = input(&mut rng, &target.corpus);
            std::fs::write(&path, &data).unwrap();
            QUIET.store(true, Ordering::Relaxed);
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                (target.read)(&path, &data)
            }));
            QUIET.store(false, Ordering::Relaxed);
            match result {
                Ok(ok) => accepted += u64::from(ok),
                Err(payload) => {
                    found += 1;
                    let message = payload
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_string()))
                        .unwrap_or_default();
                    std::fs::create_dir_all(&failures_dir).unwrap();
                    let saved = failures_dir.join(format!("{t:02}-{k}-{}", target.file));
                    std::fs::write(&saved, &data).unwrap();
                    panics.push(format!(
                        "{}: input {k}: {message} (saved as {})",
                        target.name,
                        saved.display()
                    ));
                }
            }
        }
        summary.push(format!(
            "{:<42} {count:>7} inputs, {accepted:>6} accepted, {found} panics, {:.1} s",
            target.name,
            start.elapsed().as_secs_f64()
        ));
    }
    let _ = std::panic::take_hook();
    (summary, panics)
}

fn run(count: u64) {
    let seed = std::env::var("TRINOCULAR_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(12);
    let (summary, panics) = fuzz(count, seed);
    eprintln!("fuzzing, seed {seed}:\n  {}", summary.join("\n  "));
    assert!(
        panics.is_empty(),
        "{} panics:\n  {}",
        panics.len(),
        panics.join("\n  ")
    );
}

/// 10³ inputs per reader, in every test run.
#[test]
fn every_reader_survives_mutated_input() {
    run(SHORT_RUN);
}

/// 10⁵ inputs per reader (or `TRINOCULAR_FUZZ_INPUTS`): run under `ulimit -v`.
#[test]
#[ignore = "long: 10⁵ inputs per reader (docs/bad-input.md)"]
fn every_reader_survives_mutated_input_long() {
    let count = std::env::var("TRINOCULAR_FUZZ_INPUTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(LONG_RUN);
    run(count);
}
