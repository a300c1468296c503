//! `trinocular bench`: throughput figures for this machine.
//!
//! `bench extract` renders a seed frame (4096×3072, 16-bit, spheres A/B/C,
//! full noise), then measures, each as the median of repeated runs: a plain
//! sum over the pixel buffer (the memory-bandwidth floor), extraction of the
//! frame held in memory on one thread and on all threads, a pipelined
//! sequence of frames in memory (`Backend::extract_frames`: on a GPU, upload
//! of frame n+1 overlaps the work on frame n), and decode + extract over a
//! folder of such frames written as uncompressed 16-bit TIFF. The last line
//! compares the in-memory rate with the camera rate of the rig.

/// Frames per second a rig of three 180 fps cameras delivers (docs/methods.md).
const CAMERA_RATE_FPS: f64 = 3.0 * 180.0;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use extract::{ExtractParams, FrameReader, FrameView, Threshold};

use crate::cmd::backend::{BackendChoice, select_backend};

/// Arguments of `trinocular bench`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    /// Extraction throughput: in memory against a plain sum, and decode + extract over TIFF files.
    Extract(ExtractArgs),
    /// Laser-tracer multilateration: solve time of 10⁴ grid points × 8 stations.
    Tracer(crate::cmd::probe::tracer::BenchArgs),
    /// `trinocular manifest` on thousands of full-size frames per camera (metadata only).
    Manifest(crate::cmd::manifest::BenchArgs),
    /// `evaluate`'s Monte Carlo: 108 instants × 3 spheres × 200 trials.
    Uncertainty(crate::cmd::evaluate::BenchArgs),
    /// `measure` beside decode only and decode + extract, per image format, with peak memory.
    Measure(crate::cmd::bench_measure::MeasureArgs),
    /// Decode every image of a manifest and nothing else (a phase of `bench measure`).
    #[command(hide = true)]
    Decode(crate::cmd::bench_measure::DecodeArgs),
}

/// Arguments of `trinocular bench extract`.
#[derive(Debug, clap::Args)]
pub struct ExtractArgs {
    /// Compute backend.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
    /// Timed repetitions of each in-memory measurement.
    #[arg(long, default_value_t = 50, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    repeat: usize,
    /// Frames written for the folder measurement.
    #[arg(long, default_value_t = 24, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    frames: usize,
    /// Folder for the frames (kept); default: a temporary folder, removed afterwards.
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Replace frames of an earlier run in --dir.
    #[arg(long)]
    force: bool,
}

/// Median of `repeat` timed calls of `f`.
fn median_time(repeat: usize, mut f: impl FnMut()) -> Duration {
    f(); // warm caches and allocations
    let mut t: Vec<Duration> = (0..repeat.max(1))
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed()
        })
        .collect();
    t.sort();
    t[t.len() / 2]
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Render the seed frame of camera `camera` at the first instant of the default campaign.
fn seed_frame(camera: u8, frame: u64) -> Result<synth::Image16> {
    let config = synth::Config::default();
    let rig = synth::SynthRig::from_config(&config)?;
    let plan = synth::Plan::new(&config)?;
    let spheres = plan.spheres_at(&plan.instants[0]);
    let cam = rig
        .camera(camera)
        .context("the default rig has no such camera")?;
    Ok(cam.render(
        &spheres,
        synth::NoiseKey {
            seed: 1,
            frame,
            camera,
        },
        config.render.max_depth,
    )?)
}

fn write_tiff(output: &formats::OutputPlan, path: &Path, img: &synth::Image16) -> Result<()> {
    let meta = synth::FrameMetadata {
        make: "trinocular".into(),
        model: "bench".into(),
        serial: "BENCH".into(),
        time_s: 1.7e9,
        exposure_s: 0.002,
        f_number: 8.0,
        focal_mm: 40.0,
        description: String::new(),
    };
    let mut bytes = std::io::Cursor::new(Vec::with_capacity(img.len() * 2 + 4096));
    synth::encode_tiff(
        &mut bytes,
        img,
        16,
        &meta,
        synth::config::TiffCompression::None,
        path,
    )?;
    output.write_bytes(path, bytes.get_ref())?;
    Ok(())
}

fn bench_extract(args: &ExtractArgs) -> Result<()> {
    let backend = select_backend(args.backend)?;
    // The seed threshold on 16-bit frames (docs/methods.md).
    let params = ExtractParams {
        threshold: Threshold::Fixed(6000),
        ..ExtractParams::default()
    };
    eprintln!("rendering a 4096×3072 seed frame …");
    let img = seed_frame(2, 0)?;
    let frame = FrameView::from_image(&img);
    let blobs = backend.extract(frame, &params)?.blobs.len();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;

    let sum = median_time(args.repeat, || {
        let s: u64 = one.install(|| {
            std::hint::black_box(frame.pixels)
                .iter()
                .map(|&p| u64::from(p))
                .sum()
        });
        std::hint::black_box(s);
    });
    let ext1 = median_time(args.repeat, || {
        let r = one.install(|| backend.extract(std::hint::black_box(frame), &params));
        std::hint::black_box(r.is_ok());
    });
    let extn = median_time(args.repeat, || {
        std::hint::black_box(
            backend
                .extract(std::hint::black_box(frame), &params)
                .is_ok(),
        );
    });
    let auto = ExtractParams::default();
    let ext_auto = median_time(args.repeat, || {
        std::hint::black_box(backend.extract(std::hint::black_box(frame), &auto).is_ok());
    });
    // A sequence of frames in memory (the same buffer, uploaded each time on a GPU).
    let sequence = vec![frame; args.repeat.max(8)];
    let mut failures = 0usize;
    backend.extract_frames(&sequence[..2], &params, &mut |_, r| {
        failures += usize::from(r.is_err())
    });
    let start = Instant::now();
    backend.extract_frames(&sequence, &params, &mut |_, r| {
        failures += usize::from(r.is_err())
    });
    let pipelined = sequence.len() as f64 / start.elapsed().as_secs_f64();
    anyhow::ensure!(
        failures == 0,
        "{failures} in-memory benchmark frames failed to extract"
    );

    let temp;
    let dir = match &args.dir {
        Some(d) => d.clone(),
        None => {
            temp = formats::interrupt::ScratchFolder::new()?;
            temp.path().to_path_buf()
        }
    };
    let files: Vec<PathBuf> = (0..args.frames)
        .map(|i| dir.join(format!("bench_{i:04}.tif")))
        .collect();
    let mut output = formats::OutputPlan::new(args.force);
    output.folder(&dir);
    for f in &files {
        output.file(f);
    }
    output.check()?;
    eprintln!("writing {} frames to {} …", args.frames, dir.display());
    for (i, path) in files.iter().enumerate() {
        write_tiff(&output, path, &seed_frame(2, i as u64)?)?;
    }
    // Decode alone, one thread, reused buffers.
    let mut reader = FrameReader::new();
    let start = Instant::now();
    for f in &files {
        reader.read(f)?;
    }
    let decode = start.elapsed() / files.len().max(1) as u32;
    // Decode + extract over the folder (the `extract` command's path).
    let mut failures = 0usize;
    let start = Instant::now();
    extract::extract_files(&files, backend.as_ref(), &params, Some(16), |_, _, r| {
        failures += usize::from(r.is_err())
    });
    let folder = start.elapsed();
    anyhow::ensure!(
        failures == 0,
        "{failures} benchmark frames failed to extract"
    );

    let fps = files.len() as f64 / folder.as_secs_f64();
    let mpx = f64::from(frame.width) * f64::from(frame.height) / 1e6;
    println!("backend: {}", backend.name());
    println!(
        "frame: {}×{} 16-bit, {blobs} blobs, threshold 6000 DN",
        frame.width, frame.height
    );
    println!(
        "plain sum, 1 thread:            {:8.3} ms  ({:.1} GB/s)",
        ms(sum),
        2.0 * mpx / 1e3 / sum.as_secs_f64()
    );
    println!(
        "extract in memory, 1 thread:    {:8.3} ms  ({:.2}× the plain sum)",
        ms(ext1),
        ext1.as_secs_f64() / sum.as_secs_f64()
    );
    println!(
        "extract in memory, {} threads:   {:8.3} ms  ({:.0} frames/s)",
        rayon::current_num_threads(),
        ms(extn),
        1.0 / extn.as_secs_f64()
    );
    println!("  with automatic threshold:     {:8.3} ms", ms(ext_auto));
    println!(
        "pipelined in memory, {} frames: {pipelined:8.1} frames/s",
        sequence.len()
    );
    println!(
        "decode TIFF, 1 thread:          {:8.3} ms per frame (reused buffers)",
        ms(decode)
    );
    println!(
        "decode + extract, folder of {}: {:8.1} frames/s ({:.0} Mpx/s)",
        files.len(),
        fps,
        fps * mpx
    );
    println!(
        "camera rate (3 cameras × 180 fps of 4096×3072 16-bit): {CAMERA_RATE_FPS:.0} frames/s; {}: {pipelined:.1} frames/s in memory ({:.1} % of it)",
        backend.name(),
        100.0 * pipelined / CAMERA_RATE_FPS
    );
    Ok(())
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    match &args.what {
        What::Extract(a) => bench_extract(a),
        What::Tracer(a) => crate::cmd::probe::tracer::bench(a),
        What::Manifest(a) => crate::cmd::manifest::bench(a),
        What::Uncertainty(a) => crate::cmd::evaluate::bench(a),
        What::Measure(a) => crate::cmd::bench_measure::bench(a),
        What::Decode(a) => crate::cmd::bench_measure::decode(a),
    }
}
