//! Throughput of the renderer: one seed-size frame (4096×3072, 16-bit, three
//! spheres A/B/C, full noise, through the lens) rendered and encoded as
//! uncompressed TIFF in memory, on all cores. `cargo bench -p synth`; docs/synthetic-campaigns.md quotes the median.

#![allow(clippy::expect_used)]

use std::io::Cursor;
use std::path::Path;

use synth::config::TiffCompression;
use synth::{Config, FrameMetadata, NoiseKey, Plan, SynthRig, encode_tiff};

fn main() {
    divan::main();
}

fn setup(camera_id: u8) -> (synth::SynthCamera, Vec<synth::Sphere>, FrameMetadata) {
    let config = Config::default();
    let rig = SynthRig::from_config(&config).expect("default rig");
    let plan = Plan::new(&config).expect("default plan");
    let spheres = plan.spheres_at(&plan.instants[0]);
    let cam = rig.camera(camera_id).expect("camera").clone();
    let meta = FrameMetadata {
        make: "trinocular".into(),
        model: "synth".into(),
        serial: cam.serial.clone(),
        time_s: 1.7e9,
        exposure_s: 0.002,
        f_number: 8.0,
        focal_mm: 40.0,
        description: String::new(),
    };
    (cam, spheres, meta)
}

/// Render + encode one frame of camera 2 (in focus) and camera 1 (defocused
/// spheres at the start of an X sweep: larger blur kernels).
#[divan::bench(args = [2, 1], sample_count = 15, sample_size = 1)]
fn render_and_encode_frame(bencher: divan::Bencher, camera_id: u8) {
    let (cam, spheres, meta) = setup(camera_id);
    let mut frame = 0u64;
    bencher.bench_local(|| {
        frame += 1;
        let img = cam
            .render(
                &spheres,
                NoiseKey {
                    seed: 1,
                    frame,
                    camera: camera_id,
                },
                4,
            )
            .expect("render");
        let mut out = Cursor::new(Vec::with_capacity(img.len() * 2 + 8192));
        encode_tiff(
            &mut out,
            &img,
            16,
            &meta,
            TiffCompression::None,
            Path::new("<bench>"),
        )
        .expect("encode");
        divan::black_box(out.into_inner().len())
    });
}

/// Render only (no encoding), camera 2: through its lens (the default) and
/// as a radiance image (no relative illumination: the uniform background is
/// drawn by the exact DN sampler, 3× faster than a per-pixel normal draw).
#[divan::bench(args = ["lens", "radiance"], sample_count = 15, sample_size = 1)]
fn render_frame(bencher: divan::Bencher, illumination: &str) {
    let (mut cam, spheres, _) = setup(2);
    if illumination == "radiance" {
        cam.lens = None;
    }
    bencher.bench_local(|| {
        let img = cam
            .render(
                &spheres,
                NoiseKey {
                    seed: 1,
                    frame: 0,
                    camera: 2,
                },
                4,
            )
            .expect("render");
        divan::black_box(img.len())
    });
}
