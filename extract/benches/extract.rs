//! Extraction throughput on a full 4096×3072 16-bit frame with three spheres,
//! against a plain sum over the same buffer (the memory-bandwidth floor); on
//! the GPU backend (feature `gpu`) one frame at a time and pipelined, on the
//! best Vulkan adapter (skipped with a notice when there is none).
//! Run: `cargo bench -p extract`.

#![allow(missing_docs, clippy::unwrap_used)]

use extract::{Backend, CpuBackend, ExtractParams, FrameView, Threshold};

const W: u32 = 4096;
const H: u32 = 3072;

/// A frame like the seed rig's: background ≈ 1000 DN with noise, three
/// uniform discs of 158, 118 and 79 px radius (the 20/15/10 mm spheres at 460 mm).
fn seed_frame() -> Vec<u16> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let discs = [
        (1200.0, 1500.0, 158.0),
        (2300.0, 900.0, 118.0),
        (3100.0, 2200.0, 79.0),
    ];
    (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let noise = (state >> 58) as u16; // 0..63
            let inside = discs.iter().any(|&(cx, cy, r)| {
                let (dx, dy) = (f64::from(x) - cx, f64::from(y) - cy);
                dx * dx + dy * dy <= r * r
            });
            if inside { 40_000 + noise } else { 1000 + noise }
        })
        .collect()
}

fn main() {
    divan::main();
}

#[divan::bench]
fn plain_sum_1_thread(bencher: divan::Bencher) {
    let px = seed_frame();
    bencher
        .counter(divan::counter::BytesCount::of_slice(&px))
        .bench(|| {
            divan::black_box(&px)
                .iter()
                .map(|&p| u64::from(p))
                .sum::<u64>()
        });
}

#[divan::bench(args = [1, 2])]
fn extract_fixed_threshold(bencher: divan::Bencher, threads: usize) {
    let px = seed_frame();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let params = ExtractParams {
        threshold: Threshold::Fixed(6000),
        ..ExtractParams::default()
    };
    bencher
        .counter(divan::counter::BytesCount::of_slice(&px))
        .bench(|| {
            pool.install(|| {
                let f = FrameView::new(W, H, 16, divan::black_box(&px)).unwrap();
                CpuBackend.extract(f, &params).unwrap()
            })
        });
}

#[divan::bench(args = [1, 2])]
fn extract_auto_threshold(bencher: divan::Bencher, threads: usize) {
    let px = seed_frame();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let params = ExtractParams::default();
    bencher
        .counter(divan::counter::BytesCount::of_slice(&px))
        .bench(|| {
            pool.install(|| {
                let f = FrameView::new(W, H, 16, divan::black_box(&px)).unwrap();
                CpuBackend.extract(f, &params).unwrap()
            })
        });
}

/// The GPU backend on the best adapter, or `None` with a notice.
#[cfg(feature = "gpu")]
fn gpu() -> Option<extract::GpuBackend> {
    match extract::GpuBackend::new(&extract::gpu::GpuOptions::default()) {
        Ok(b) => {
            eprintln!("GPU benchmarks on {}", b.name());
            Some(b)
        }
        Err(e) => {
            eprintln!("GPU benchmarks skipped: {e}");
            None
        }
    }
}

#[cfg(feature = "gpu")]
#[divan::bench]
fn extract_gpu_one_frame(bencher: divan::Bencher) {
    let Some(gpu) = gpu() else { return };
    let px = seed_frame();
    let params = ExtractParams {
        threshold: Threshold::Fixed(6000),
        ..ExtractParams::default()
    };
    bencher
        .counter(divan::counter::BytesCount::of_slice(&px))
        .bench(|| {
            let f = FrameView::new(W, H, 16, divan::black_box(&px)).unwrap();
            gpu.extract(f, &params).unwrap()
        });
}

/// Eight frames through the pipeline (upload of frame n+1 overlaps the work on frame n).
#[cfg(feature = "gpu")]
#[divan::bench]
fn extract_gpu_pipelined_8_frames(bencher: divan::Bencher) {
    let Some(gpu) = gpu() else { return };
    let px = seed_frame();
    let params = ExtractParams {
        threshold: Threshold::Fixed(6000),
        ..ExtractParams::default()
    };
    let frames = vec![FrameView::new(W, H, 16, &px).unwrap(); 8];
    bencher
        .counter(divan::counter::BytesCount::new(8 * px.len() * 2))
        .bench(|| {
            let mut blobs = 0;
            gpu.extract_frames(divan::black_box(&frames), &params, &mut |_, r| {
                blobs += r.unwrap().blobs.len()
            });
            blobs
        });
}
