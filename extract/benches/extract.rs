//! Extraction throughput on a full 4096×3072 16-bit frame with three spheres,
//! against a plain sum over the same buffer (the memory-bandwidth floor); on
//! the GPU backend (feature `gpu`) one frame at a time and pipelined, on the
//! best Vulkan adapter (skipped with a notice when there is none).
//! Run: `cargo bench -p extract`.

#![allow(missing_docs, clippy::unwrap_used)]

use extract::{Backend, CpuBackend, ExtractParams, FrameView, Threshold};

mod common;

use common::{H, W};

/// The seed rig's frame's pixels.
fn seed_frame() -> Vec<u16> {
    common::seed_image().into_raw()
}

/// The seed's fixed threshold on 16-bit frames (docs/methods.md).
fn seed_params() -> ExtractParams {
    ExtractParams {
        threshold: Threshold::Fixed(6000),
        ..ExtractParams::default()
    }
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

/// Extract the seed frame with `params` on a pool of `threads` threads.
fn extract_on_threads(bencher: divan::Bencher, threads: usize, params: &ExtractParams) {
    let px = seed_frame();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    bencher
        .counter(divan::counter::BytesCount::of_slice(&px))
        .bench(|| {
            pool.install(|| {
                let f = FrameView::new(W, H, 16, divan::black_box(&px)).unwrap();
                CpuBackend.extract(f, params).unwrap()
            })
        });
}

#[divan::bench(args = [1, 2])]
fn extract_fixed_threshold(bencher: divan::Bencher, threads: usize) {
    extract_on_threads(bencher, threads, &seed_params());
}

#[divan::bench(args = [1, 2])]
fn extract_auto_threshold(bencher: divan::Bencher, threads: usize) {
    extract_on_threads(bencher, threads, &ExtractParams::default());
}

/// The corrected light (`mapped_light`: background ring, flat-field and
/// undistortion through the camera's lattice, moments) of the seed frame's
/// three spheres on one thread, the lattice solved beforehand as in a run:
/// what `measure` adds to extraction per frame; with the centroids'
/// covariance (the system gain K known) and without.
#[divan::bench(args = [false, true])]
fn corrected_light_1_thread(bencher: divan::Bencher, covariance: bool) {
    let px = seed_frame();
    let params = seed_params();
    let frame = FrameView::new(W, H, 16, &px).unwrap();
    let ex = CpuBackend.extract(frame, &params).unwrap();
    let config = synth::Config::default();
    let rig = synth::SynthRig::from_config(&config).unwrap();
    let camera = &rig.camera(2).unwrap().camera;
    let illumination = geom::Illumination::Ideal;
    let lattice = extract::Lattice::new(camera);
    let map = extract::CameraMap::with_lattice(camera, &illumination, &lattice);
    let gain = extract::Covariance::at_gain(covariance.then_some(4.0));
    let light = || {
        ex.blobs
            .iter()
            .map(|b| {
                extract::mapped_light(&frame, b, &ex.level, params.weighting, &map, gain)
                    .unwrap()
                    .centroid[0]
            })
            .sum::<f64>()
    };
    light();
    let pixels: u64 = ex.blobs.iter().map(|b| b.area_px).sum();
    bencher
        .counter(divan::counter::ItemsCount::new(pixels))
        .bench_local(light);
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
    let params = seed_params();
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
    let params = seed_params();
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
