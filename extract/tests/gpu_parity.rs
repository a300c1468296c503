//! GPU ↔ CPU parity (issue 8, point 1): on renderer frames of the three
//! sphere sizes, 16-bit and 8-bit, the GPU backend finds the same blobs as the
//! CPU backend — same runs, moments, area, peak, saturation and flags, so the
//! centroids agree exactly (the test allows 1e-4 px and prints the largest
//! difference). Also: every threshold kind, both weightings, band tiling
//! (a small binding limit on a small frame), segment-buffer growth, the CPU
//! labeller for a frame with too many segments, and pipelined batches of files.
//!
//! Runs on whatever Vulkan adapter exists (CI: Mesa's lavapipe). Without any
//! adapter it prints a notice and passes, unless `TRINOCULAR_REQUIRE_ADAPTER=1`.

#![cfg(feature = "gpu")]
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;

use extract::gpu::{GpuOptions, probe};
use extract::{
    Backend, CpuBackend, Denoise, ExtractParams, Extraction, FrameBlobs, FrameView, GpuBackend,
    Threshold, Weighting,
};
use geom::{Camera, Distortion, Intrinsics, Point3};
use synth::{Exposure, Image16, NoiseKey, Optics, Sensor, Sphere, expose, sphere_signals};

const FX: f64 = 7966.0;
const PIXEL_MM: f64 = 0.0055;
/// Centroids must agree to this (px); exact agreement is expected.
const TOLERANCE_PX: f64 = 1e-4;

/// The GPU backend, or `None` (with a notice) when no adapter exists at all.
fn gpu(options: GpuOptions) -> Option<GpuBackend> {
    match probe(&options) {
        Ok(adapter) => {
            let b = GpuBackend::new(&options).unwrap_or_else(|e| {
                panic!(
                    "adapter {} exists but cannot be used: {e}",
                    adapter.describe()
                )
            });
            Some(b)
        }
        Err(reason) => {
            assert!(
                std::env::var_os("TRINOCULAR_REQUIRE_ADAPTER").is_none_or(|v| v != "1"),
                "TRINOCULAR_REQUIRE_ADAPTER=1 but there is no GPU adapter: {reason}"
            );
            eprintln!("NOTICE: GPU parity test skipped: {reason}");
            None
        }
    }
}

/// A window of the seed camera around one sphere of `diameter_mm` (as in
/// tests/accuracy.rs, with room for the automatic threshold's background
/// sample: the sphere covers ≈ 30 % of it), exposed on a `bits`-bit sensor.
fn render(diameter_mm: f64, bits: u8, frame: u64) -> Image16 {
    let centre = Point3::new(60.0, 40.0, 460.0);
    let radius = diameter_mm / 2.0;
    let r_px = FX * radius / centre.z;
    let window = (3.2 * r_px + 48.0).ceil() as u32;
    let mut k = Intrinsics::centred(FX, window, window);
    let c = (f64::from(window) - 1.0) / 2.0;
    k.cx = c - FX * centre.x / centre.z;
    k.cy = c - FX * centre.y / centre.z;
    let cam = Camera {
        intrinsics: k,
        distortion: Distortion::NONE,
        pose: geom::Isometry3::identity(),
        width: window,
        height: window,
    };
    let sphere = Sphere {
        centre,
        radius,
        radiance_e: 12_000.0,
    };
    let optics = Optics {
        psf_sigma_px: 0.55,
        ..Optics::sharp(PIXEL_MM)
    };
    // 16-bit: plateau ≈ 48 400 DN; 8-bit: gain scaled so the plateau saturates at 255.
    let (gain, offset) = if bits == 16 {
        (4.0, 400.0)
    } else {
        (0.022, 2.0)
    };
    let sensor = Sensor {
        width: window,
        height: window,
        bits,
        gain_dn_per_e: gain,
        offset_dn: offset,
        read_noise_e: 5.0,
        shot_noise: true,
        background_e: 200.0,
        gradient_e_per_px: [0.3, -0.2],
        stray_light: vec![],
    };
    let signals = sphere_signals(&cam, &optics, &[sphere], 6, None).unwrap();
    let layers = [Exposure {
        signal: signals[0].as_ref().unwrap(),
        radiance_e: sphere.radiance_e,
    }];
    expose(
        &sensor,
        &layers,
        NoiseKey {
            seed: 11,
            frame,
            camera: 2,
        },
        None,
    )
}

/// The extraction settings tried on every frame.
fn settings(bits: u8) -> Vec<(&'static str, ExtractParams)> {
    let fixed = if bits == 16 { 6000 } else { 40 };
    let p = |threshold, weighting, denoise| ExtractParams {
        threshold,
        weighting,
        denoise,
        min_area: 1,
        ..ExtractParams::default()
    };
    vec![
        (
            "fixed",
            p(
                Threshold::Fixed(fixed),
                Weighting::Subtracted,
                Denoise::None,
            ),
        ),
        (
            "fixed raw",
            p(Threshold::Fixed(fixed), Weighting::Raw, Denoise::None),
        ),
        (
            "auto",
            p(
                Threshold::Auto { k: 8.0 },
                Weighting::Subtracted,
                Denoise::None,
            ),
        ),
        (
            "auto k=2 (noise blobs)",
            p(
                Threshold::Auto { k: 2.0 },
                Weighting::Subtracted,
                Denoise::None,
            ),
        ),
        (
            "local",
            p(
                Threshold::Local { k: 6.0, mesh: 32 },
                Weighting::Subtracted,
                Denoise::None,
            ),
        ),
        (
            "auto, median",
            p(
                Threshold::Auto { k: 8.0 },
                Weighting::Subtracted,
                Denoise::Median3,
            ),
        ),
    ]
}

/// Compare two extractions; returns the largest centroid difference (px).
fn compare(what: &str, gpu: &Extraction, cpu: &Extraction) -> f64 {
    assert_eq!(gpu.blobs.len(), cpu.blobs.len(), "{what}: blob count");
    let mut worst = 0.0f64;
    for (i, (g, c)) in gpu.blobs.iter().zip(&cpu.blobs).enumerate() {
        let d = (g.u - c.u).abs().max((g.v - c.v).abs());
        worst = worst.max(d);
        assert!(
            d <= TOLERANCE_PX,
            "{what}: blob {i} centroid differs by {d} px"
        );
        assert_eq!(
            (g.area_px, g.peak, g.saturated_px, g.touches_border, g.bbox),
            (c.area_px, c.peak, c.saturated_px, c.touches_border, c.bbox),
            "{what}: blob {i}"
        );
        assert_eq!(g.moments, c.moments, "{what}: blob {i} moments");
        assert_eq!(g.runs, c.runs, "{what}: blob {i} runs");
    }
    assert_eq!(
        (&gpu.level, gpu.background, gpu.too_small, gpu.too_large),
        (&cpu.level, cpu.background, cpu.too_small, cpu.too_large),
        "{what}"
    );
    worst
}

fn check_frames(backend: &GpuBackend, label: &str) {
    for (diameter, name) in [(20.0, "A 20 mm"), (15.0, "B 15 mm"), (10.0, "C 10 mm")] {
        for bits in [16u8, 8] {
            let img = render(diameter, bits, 0);
            let frame = FrameView::new(img.width(), img.height(), bits, img.as_raw()).unwrap();
            for (setting, params) in settings(bits) {
                let what = format!(
                    "{label}: {name}, {bits}-bit {}×{}, {setting}",
                    frame.width, frame.height
                );
                let cpu = CpuBackend.extract(frame, &params).unwrap();
                let gpu = backend.extract(frame, &params).unwrap();
                assert!(!cpu.blobs.is_empty(), "{what}: no blob");
                let worst = compare(&what, &gpu, &cpu);
                let saturated: u64 = cpu.blobs.iter().map(|b| b.saturated_px).sum();
                println!(
                    "{what}: {} blobs (largest {} px, {saturated} px saturated), max |Δ centroid| = {worst:e} px",
                    cpu.blobs.len(),
                    cpu.blobs.iter().map(|b| b.area_px).max().unwrap_or(0)
                );
            }
        }
    }
}

#[test]
fn same_blobs_as_the_cpu_on_renderer_frames() {
    let Some(backend) = gpu(GpuOptions::default()) else {
        return;
    };
    println!("adapter: {}", backend.name());
    check_frames(&backend, "one binding");
    let s = backend.stats();
    assert_eq!((s.bands, s.cpu_labelled), (s.frames, 0), "{s:?}");
    println!(
        "{s:?}: {:.0} bytes read back per frame",
        s.bytes_read as f64 / s.frames as f64
    );
}

#[test]
fn same_blobs_when_the_frame_is_cut_into_bands() {
    // 48 KiB per binding: the frames (≈ 330 to 780 KiB) are cut into bands of
    // 40 to 60 rows, with blobs across every seam.
    let options = GpuOptions {
        max_band_bytes: Some(48 << 10),
        ..GpuOptions::default()
    };
    let Some(backend) = gpu(options) else { return };
    assert_eq!(backend.band_bytes(), 48 << 10);
    check_frames(&backend, "bands of 48 KiB");
    let s = backend.stats();
    assert!(s.bands >= 7 * s.frames && s.cpu_labelled == 0, "{s:?}");
}

/// Uniform noise: a threshold at the median gives ≈ 1 run per 4 pixels.
fn noise(width: u32, height: u32) -> Vec<u16> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    (0..width * height)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 48) as u16
        })
        .collect()
}

#[test]
fn same_blobs_with_many_segments() {
    let Some(backend) = gpu(GpuOptions::default()) else {
        return;
    };
    let Some(limited) = gpu(GpuOptions {
        max_segments: Some(50_000),
        ..GpuOptions::default()
    }) else {
        return;
    };
    let (w, h) = (1023, 400);
    let px = noise(w, h);
    let frame = FrameView::new(w, h, 16, &px).unwrap();
    let params = ExtractParams {
        threshold: Threshold::Fixed(32768),
        min_area: 1,
        ..ExtractParams::default()
    };
    let cpu = CpuBackend.extract(frame, &params).unwrap();
    let runs: usize = cpu.blobs.iter().map(|b| b.runs.len()).sum();
    // More segments than a fresh slot holds (65 536): the buffer grows. With
    // at most 50 000 segments allowed, the CPU labeller takes over.
    assert!(runs > 1 << 16, "{runs} runs");
    for (b, name) in [
        (&backend, "growing segment buffer"),
        (&limited, "CPU labeller fallback"),
    ] {
        let worst = compare(name, &b.extract(frame, &params).unwrap(), &cpu);
        println!(
            "noise {w}×{h}, {runs} runs, {} blobs, {name}: max |Δ| = {worst:e} px",
            cpu.blobs.len()
        );
    }
    assert_eq!(
        (backend.stats().rereads, backend.stats().cpu_labelled),
        (1, 0),
        "{:?}",
        backend.stats()
    );
    assert_eq!(limited.stats().cpu_labelled, 1, "{:?}", limited.stats());
    // A quiet frame after the busy one, and the busy one again (readback estimate down and up).
    let quiet = render(10.0, 16, 1);
    let qf = FrameView::from_image(&quiet);
    let qp = ExtractParams::default();
    compare(
        "quiet after busy",
        &backend.extract(qf, &qp).unwrap(),
        &CpuBackend.extract(qf, &qp).unwrap(),
    );
    compare(
        "busy after quiet",
        &backend.extract(frame, &params).unwrap(),
        &cpu,
    );
    // The second busy frame found the buffer grown but read back too little the first time.
    assert_eq!(backend.stats().rereads, 2, "{:?}", backend.stats());
    // Too many runs is the same error as on the CPU.
    let strict = ExtractParams {
        max_runs: 1000,
        ..params
    };
    let e = backend.extract(frame, &strict).unwrap_err();
    assert!(e.to_string().contains("too low"), "{e}");
}

fn write_frames(dir: &std::path::Path) -> Vec<PathBuf> {
    let meta = synth::FrameMetadata {
        make: "trinocular".into(),
        model: "parity".into(),
        serial: "P1".into(),
        time_s: 1.7e9,
        exposure_s: 0.002,
        f_number: 8.0,
        focal_mm: 40.0,
        description: String::new(),
    };
    let mut paths = Vec::new();
    for i in 0..7u64 {
        let diameter = [10.0, 15.0, 20.0][i as usize % 3];
        let path = dir.join(format!("frame_{i:02}.tif"));
        let img = render(diameter, 16, i);
        let mut bytes = std::io::Cursor::new(Vec::new());
        synth::encode_tiff(
            &mut bytes,
            &img,
            16,
            &meta,
            synth::config::TiffCompression::None,
            &path,
        )
        .unwrap();
        std::fs::write(&path, bytes.get_ref()).unwrap();
        paths.push(path);
        if i == 3 {
            // A broken file in the middle: reported in order, the batch goes on.
            let bad = dir.join("frame_03b.tif");
            std::fs::write(&bad, b"not an image").unwrap();
            paths.push(bad);
        }
    }
    paths
}

#[test]
fn pipelined_batches_equal_the_cpu() {
    let Some(backend) = gpu(GpuOptions::default()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let paths = write_frames(dir.path());
    let params = ExtractParams::default();
    let run = |b: &dyn Backend| {
        let mut out: Vec<(usize, PathBuf, Result<FrameBlobs, String>)> = Vec::new();
        extract::extract_files(&paths, b, &params, Some(16), |i, p, r| {
            out.push((i, p.to_path_buf(), r.map_err(|e| e.to_string())))
        });
        out
    };
    let (gpu_out, cpu_out) = (run(&backend), run(&CpuBackend));
    assert_eq!(gpu_out.len(), paths.len());
    assert!(
        gpu_out
            .iter()
            .enumerate()
            .all(|(i, (j, p, _))| i == *j && *p == paths[i]),
        "input order"
    );
    assert_eq!(gpu_out.iter().filter(|r| r.2.is_err()).count(), 1);
    let mut worst = 0.0f64;
    for ((_, p, g), (_, _, c)) in gpu_out.iter().zip(&cpu_out) {
        assert_eq!(g, c, "{}", p.display());
        if let (Ok(g), Ok(c)) = (g, c) {
            for (a, b) in g.blobs.iter().zip(&c.blobs) {
                worst = worst.max((a.u - b.u).abs().max((a.v - b.v).abs()));
            }
        }
    }
    println!(
        "{} files pipelined: max |Δ centroid| = {worst:e} px",
        paths.len()
    );
    // Twice through the same backend: buffers are reused.
    assert_eq!(run(&backend), gpu_out);
}

#[test]
fn pipelined_frames_in_memory_equal_the_cpu() {
    let Some(backend) = gpu(GpuOptions::default()) else {
        return;
    };
    let images: Vec<(Image16, u8)> = (0..6u64)
        .map(|i| ([10.0, 20.0, 15.0][i as usize % 3], i))
        .map(|(d, i)| {
            (
                render(d, if i % 2 == 0 { 16 } else { 8 }, i),
                if i % 2 == 0 { 16 } else { 8 },
            )
        })
        .collect();
    let frames: Vec<FrameView<'_>> = images
        .iter()
        .map(|(img, bits)| FrameView::new(img.width(), img.height(), *bits, img.as_raw()).unwrap())
        .collect();
    let params = ExtractParams::default();
    let mut got = Vec::new();
    backend.extract_sequence(frames.iter().copied(), &params, |i, r| {
        got.push((i, r.unwrap()))
    });
    assert_eq!(got.len(), frames.len());
    for (k, (i, ex)) in got.iter().enumerate() {
        assert_eq!(*i, k);
        compare(
            &format!("in-memory sequence, frame {k}"),
            ex,
            &CpuBackend.extract(frames[k], &params).unwrap(),
        );
    }
}
