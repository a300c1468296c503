//! `trinocular manifest`: `manifest.csv` from captured camera folders and the
//! motion program (the `ingest` crate); frames it cannot place go to
//! `<stem>.problems.csv` beside it with the reason (exit status 3). And `trinocular
//! bench manifest`: the metadata-only throughput on thousands of full-size
//! frames per camera.

use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use extract::{ExtractParams, Threshold};
use formats::{ManifestRow, OutputPlan};
use ingest::{Capture, Inputs, Options};

use crate::cmd::Finished;
use crate::cmd::output::{print_notes, problems_path};

/// `SERIAL=ID`.
fn parse_camera(s: &str) -> std::result::Result<(String, u8), String> {
    let (serial, id) = s
        .rsplit_once('=')
        .ok_or_else(|| format!("'{s}' is not SERIAL=ID"))?;
    let id: u8 = id
        .trim()
        .parse()
        .map_err(|_| format!("'{s}': camera number '{id}' is not 1, 2 or 3"))?;
    if serial.trim().is_empty() {
        return Err(format!("'{s}': empty serial"));
    }
    Ok((serial.trim().to_string(), id))
}

/// Arguments of `trinocular manifest`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The motion program: a TOML file with the [procedure] table of the synth
    /// configuration (a campaign's config.toml or program.toml serves).
    #[arg(long)]
    program: PathBuf,
    /// A camera's serial (EXIF BodySerialNumber) and its number in the rig (1 looks
    /// along X, 2 along Y, 3 along Z); once per camera.
    #[arg(long = "camera", value_name = "SERIAL=ID", required = true, value_parser = parse_camera)]
    cameras: Vec<(String, u8)>,
    /// Output manifest.csv (image paths relative to it; <stem>.problems.csv beside it).
    #[arg(long)]
    out: PathBuf,
    /// Folders (or files) holding the frames, searched recursively for TIFF and PNG.
    #[arg(required = true, value_name = "DIR")]
    dirs: Vec<PathBuf>,
    /// The cameras ran free through the campaign: dwells are found in the images.
    #[arg(long)]
    continuous: bool,
    /// Leave out every instant that lacks a camera (its frames go to <stem>.problems.csv).
    #[arg(long)]
    complete_instants: bool,
    /// Continuous: blobs within this many pixels of rest (centre and diameter) are still.
    /// Default: measured per camera and blob measure, 6σ of its still frames' noise.
    #[arg(long, value_parser = crate::cmd::values::positive)]
    still_px: Option<f64>,
    /// Continuous: extraction threshold in DN, or `auto` (background + k·σ).
    #[arg(long, default_value = "auto", value_parser = threshold_arg)]
    threshold: Threshold,
    /// Replace an existing manifest.
    #[arg(long)]
    force: bool,
}

/// `--threshold`: `auto` or a level of 1..=65535 DN; anything else is a
/// usage error while the command line is parsed.
fn threshold_arg(text: &str) -> std::result::Result<Threshold, String> {
    match text {
        "auto" => Ok(Threshold::default()),
        t => match t.parse::<u16>() {
            Ok(level) if level >= 1 => Ok(Threshold::Fixed(level)),
            _ => Err(format!(
                "expected a level of 1..={} DN or 'auto', got '{t}'",
                u16::MAX
            )),
        },
    }
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let program = ingest::read_program(&args.program)?;
    let problems_path = problems_path(&args.out);
    let mut plan = OutputPlan::new(args.force);
    plan.input(&args.program)
        .inputs(&args.dirs)
        .file(&args.out)
        .file(&problems_path);
    plan.lock(formats::folder_of(&args.out), "manifest")?;
    print_notes(&plan);
    plan.check()?;
    let options = Options {
        capture: if args.continuous {
            Capture::Continuous
        } else {
            Capture::Triggered
        },
        complete_only: args.complete_instants,
        still_px: args.still_px,
        extract: ExtractParams {
            threshold: args.threshold,
            ..ExtractParams::default()
        },
        ..Options::default()
    };
    let start = Instant::now();
    let built = ingest::build(
        &Inputs {
            program: &program,
            cameras: &args.cameras,
            dirs: &args.dirs,
            manifest: &args.out,
        },
        &options,
    )?;
    let elapsed = start.elapsed();
    plan.write_csv(&args.out, &built.rows)?;
    if built.problems.is_empty() {
        // A stale problems file from an earlier run (replaced with --force) would mislead.
        plan.remove(&problems_path)?;
    } else {
        plan.write_records(&problems_path, &built.problems)?;
    }
    let s = &built.summary;
    let scales: Vec<String> = s
        .scales
        .iter()
        .map(|(c, k)| format!("camera {c} {k:.3}×"))
        .collect();
    eprintln!(
        "{} frames placed at {} instants ({} with every camera) of {} dwells × {} captures, \
         from {} image files in {:.2} s{} → {}",
        s.placed,
        s.instants,
        s.complete_instants,
        s.dwells,
        program.captures,
        s.files,
        elapsed.as_secs_f64(),
        if s.other_files > 0 {
            format!(" ({} other files ignored)", s.other_files)
        } else {
            String::new()
        },
        args.out.display()
    );
    if !scales.is_empty() {
        eprintln!(
            "time between dwells against the program's: {}",
            scales.join(", ")
        );
    }
    if args.continuous {
        eprintln!(
            "{} frames at no instant (in motion, or at rest but not taken); {} frames decoded",
            s.not_at_instants, s.decoded
        );
        let still: Vec<String> = s
            .still_px
            .iter()
            .map(|(c, e)| format!("camera {c} {e:.3} px"))
            .collect();
        eprintln!("at rest within: {}", still.join(", "));
    }
    if built.problems.is_empty() {
        Ok(())
    } else {
        Err(Finished::with_problems(format!(
            "{} frames, cameras or instants left out (listed in {})",
            built.problems.len(),
            problems_path.display()
        )))
    }
}

/// Arguments of `trinocular bench manifest`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Frames per camera (three cameras).
    #[arg(long, default_value_t = 3000)]
    frames: usize,
    /// Frame width (px); the files are full-size 16-bit TIFFs, written sparse
    /// (their pixels are zero, so they take little disk).
    #[arg(long, default_value_t = 4096)]
    width: u32,
    /// Frame height (px).
    #[arg(long, default_value_t = 3072)]
    height: u32,
    /// Folder for the frames (kept); default: a temporary folder, removed afterwards.
    #[arg(long)]
    dir: Option<PathBuf>,
}

/// Positions of `needle` in `hay`.
fn find_all(hay: &[u8], needle: &[u8]) -> Vec<usize> {
    hay.windows(needle.len())
        .enumerate()
        .filter(|(_, w)| *w == needle)
        .map(|(i, _)| i)
        .collect()
}

/// A frame written from `template` with its time fields replaced, zero runs
/// of 64 KiB and more left as holes.
fn write_sparse(path: &Path, template: &[u8]) -> Result<()> {
    const BLOCK: usize = 1 << 16;
    let mut f = std::fs::File::create(path).with_context(|| format!("{}", path.display()))?;
    f.set_len(template.len() as u64)?;
    for (i, chunk) in template.chunks(BLOCK).enumerate() {
        if chunk.iter().any(|&b| b != 0) {
            f.seek(SeekFrom::Start((i * BLOCK) as u64))?;
            f.write_all(chunk)?;
        }
    }
    Ok(())
}

/// Run `trinocular bench manifest`.
pub fn bench(args: &BenchArgs) -> Result<()> {
    let captures = 10u32;
    let runs = 2u32;
    let dwells_needed = args.frames.div_ceil(captures as usize).max(2);
    let targets = dwells_needed.div_ceil(2 * runs as usize).max(2) as u32;
    let program = formats::ProcedureConfig {
        axes: vec![formats::AxisProcedure {
            axis: formats::Axis::X,
            start_mm: -75.0,
            length_mm: 150.0,
            segments: targets - 1,
            lines_mm: vec![0.0],
        }],
        runs,
        captures,
        ..formats::ProcedureConfig::default()
    };
    let dwells = program.dwells();
    let temp;
    let dir = match &args.dir {
        Some(d) => d.clone(),
        None => {
            temp = tempfile::tempdir()?;
            temp.path().to_path_buf()
        }
    };
    let serials = ["BENCH-0001", "BENCH-0002", "BENCH-0003"];
    let offsets = [0.0, 2.375, -3.8125];
    let image = synth::Image16::new(args.width, args.height);
    eprintln!(
        "writing {} sparse {}×{} 16-bit TIFFs per camera under {} …",
        dwells.len() * captures as usize,
        args.width,
        args.height,
        dir.display()
    );
    let start_s = 1.75e9 + 0.123_456_7;
    let mut files = 0usize;
    for (c, serial) in serials.iter().enumerate() {
        let folder = dir.join(serial);
        std::fs::create_dir_all(&folder)?;
        let mut meta = synth::FrameMetadata {
            make: "trinocular".into(),
            model: "bench".into(),
            serial: (*serial).into(),
            time_s: start_s,
            exposure_s: 0.002,
            f_number: 8.0,
            focal_mm: 40.0,
            description: String::new(),
        };
        let mut template = std::io::Cursor::new(Vec::new());
        synth::encode_tiff(
            &mut template,
            &image,
            16,
            &meta,
            synth::config::TiffCompression::None,
            Path::new("<bench>"),
        )?;
        let mut template = template.into_inner();
        let (date0, sub0) = synth::datetime::exif(start_s);
        let date_at = find_all(&template, date0.as_bytes());
        let sub_at = find_all(&template, format!("{sub0}\0").as_bytes());
        anyhow::ensure!(
            date_at.len() == 2 && sub_at.len() == 1,
            "bench: the template's time fields are not where expected"
        );
        let mut n = 0usize;
        for (j, d) in dwells.iter().enumerate() {
            // Moves 15 % slower than programmed, a camera clock offset.
            let t_dwell = if j == 0 { d.time_s } else { d.time_s * 1.15 };
            for k in 0..captures {
                meta.time_s = start_s + offsets[c] + t_dwell + f64::from(k) / program.fps;
                let (date, sub) = synth::datetime::exif(meta.time_s);
                for &at in &date_at {
                    template[at..at + date.len()].copy_from_slice(date.as_bytes());
                }
                template[sub_at[0]..sub_at[0] + sub.len()].copy_from_slice(sub.as_bytes());
                n += 1;
                write_sparse(&folder.join(format!("IMG_{:06}.tif", 500 + n)), &template)?;
                files += 1;
            }
        }
    }
    let cameras: Vec<(String, u8)> = serials
        .iter()
        .enumerate()
        .map(|(i, s)| ((*s).to_string(), i as u8 + 1))
        .collect();
    let out = dir.join("manifest.csv");
    let start = Instant::now();
    let built = ingest::build(
        &Inputs {
            program: &program,
            cameras: &cameras,
            dirs: std::slice::from_ref(&dir),
            manifest: &out,
        },
        &Options::default(),
    )?;
    let took = start.elapsed().as_secs_f64();
    anyhow::ensure!(
        built.problems.is_empty() && built.rows.len() == files,
        "bench: {} rows and {} problems for {files} frames",
        built.rows.len(),
        built.problems.len()
    );
    let rows: &[ManifestRow] = &built.rows;
    // For scale: reading whole files, as a reader that does not seek must.
    let sample: Vec<PathBuf> = rows.iter().take(30).map(|r| dir.join(&r.image)).collect();
    let whole = Instant::now();
    let mut bytes = 0usize;
    for p in &sample {
        bytes += std::fs::read(p)?.len();
    }
    let whole_s = whole.elapsed().as_secs_f64() / sample.len().max(1) as f64;
    let frame_mb = bytes as f64 / sample.len().max(1) as f64 / 1e6;
    println!(
        "manifest of {} frames ({} per camera, 3 cameras, {}×{} 16-bit TIFF, {:.1} MB each): \
         {took:.2} s, {:.0} frames/s (metadata only, page cache warm, {} threads)",
        files,
        files / 3,
        args.width,
        args.height,
        frame_mb,
        files as f64 / took,
        rayon::current_num_threads()
    );
    println!(
        "reading whole files instead: {:.2} ms per frame → {:.1} s for these frames",
        whole_s * 1e3,
        whole_s * files as f64
    );
    Ok(())
}
