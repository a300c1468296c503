//! `trinocular synth campaign|target|config`: physically correct synthetic
//! images of the rig with their ground truth (the `synth` crate).

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, Result};
use formats::OutputPlan;
use indicatif::ProgressBar;
use synth::{Config, Overrides};

use crate::cmd::OrUsage;
use crate::cmd::output::print_notes;

/// Arguments of `trinocular synth`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    /// Render a measurement campaign: images, manifest.csv, spheres.csv, nominal.json,
    /// target.csv, the calibration images (calib/: target, flat fields, dark frames, as
    /// `synth target` writes them), truth.json, truth_points.csv.
    Campaign(CampaignArgs),
    /// Render the calibration target once per camera: target.csv, nominal.json,
    /// truth.json, calib/cam{1,2,3}.tif, calib/points_cam{1,2,3}.csv, and each
    /// camera's flat field and dark frame, calib/flat_cam{k}.tif and
    /// calib/dark_cam{k}.tif (stacks calib/flat_cam{k}/flat_001.tif … and
    /// calib/dark_cam{k}/dark_001.tif … with [sensor] calibration_frames > 1).
    Target(TargetArgs),
    /// Render a printed chessboard (`[board]`) placed by hand before the cameras,
    /// 15 views per camera by default: board.csv (its inner corners as a planar
    /// target), nominal.json, truth.json, board/pose{p}_cam{k}.tif with the exact
    /// corners board/points_pose{p}_cam{k}.csv, views.csv and views_points.csv.
    Board(TargetArgs),
    /// Print the default configuration (the seed's rig and procedure), documented, as TOML.
    Config,
    /// Check data for the probe-based methods, with truth.json.
    Probe(crate::cmd::probe::SynthArgs),
}

/// Configuration file and the overrides for quick runs.
#[derive(Debug, clap::Args)]
struct ConfigArgs {
    /// Configuration file (TOML; see `trinocular synth config`). Default: the seed's rig and procedure.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Image width (px); the sensor's physical width and so the field of view are kept.
    #[arg(long)]
    width: Option<u32>,
    /// Image height (px), same square pixels (keep 4:3 to keep the vertical field).
    #[arg(long)]
    height: Option<u32>,
    /// Random seed (noise, repeatability); same seed → same bytes.
    #[arg(long)]
    seed: Option<u64>,
    /// Replace the files of an earlier run in the output directory.
    #[arg(long)]
    force: bool,
}

/// Arguments of `trinocular synth campaign`.
#[derive(Debug, clap::Args)]
struct CampaignArgs {
    #[command(flatten)]
    config: ConfigArgs,
    /// Output directory (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Targets on every axis (same travel).
    #[arg(long)]
    targets: Option<u32>,
    /// Runs.
    #[arg(long)]
    runs: Option<u32>,
    /// Captures per target and approach.
    #[arg(long)]
    captures: Option<u32>,
    /// Write the frames as triggered cameras save them: a folder per camera serial,
    /// numbered files, camera clocks in EXIF ([capture] table; truth_manifest.csv, program.toml).
    #[arg(long)]
    as_captured: bool,
    /// Write the continuous stream of free-running cameras (frames during moves too).
    #[arg(long)]
    continuous: bool,
    /// Frame rate (fps): of a burst of captures, and of free-running cameras, which write
    /// fps × the campaign's duration frames each. Default: the configuration's
    /// procedure.fps (180, the rig's cameras).
    #[arg(long, value_parser = crate::cmd::values::positive)]
    fps: Option<f64>,
}

/// Arguments of `trinocular synth target`.
#[derive(Debug, clap::Args)]
struct TargetArgs {
    #[command(flatten)]
    config: ConfigArgs,
    /// Output directory (created if missing).
    #[arg(long)]
    out: PathBuf,
}

/// The output plan: `--force`, and the configuration file as an input.
fn output_plan(args: &ConfigArgs) -> OutputPlan {
    let mut plan = OutputPlan::new(args.force);
    plan.inputs(&args.config);
    plan
}

fn load(args: &ConfigArgs, overrides: Overrides) -> Result<Config> {
    let mut config = match &args.config {
        Some(path) => Config::from_file(path)?,
        None => Config::default(),
    };
    // The file's configuration is valid (from_file checks it): what the
    // overrides break is a usage error.
    config
        .apply(&Overrides {
            width: args.width,
            height: args.height,
            seed: args.seed,
            ..overrides
        })
        .or_usage()?;
    Ok(config)
}

/// Progress bars on stderr for the library's stages.
struct Bars(Mutex<Option<ProgressBar>>);

impl synth::Progress for Bars {
    fn begin(&self, stage: &str, total: u64) {
        if let Ok(mut b) = self.0.lock() {
            *b = Some(crate::cmd::progress::bar(total, stage));
        }
    }

    fn advance(&self, n: u64) {
        if let Ok(b) = self.0.lock()
            && let Some(b) = b.as_ref()
        {
            b.inc(n);
        }
    }

    fn finish(&self) {
        if let Ok(mut b) = self.0.lock()
            && let Some(b) = b.take()
        {
            b.finish_and_clear();
        }
    }
}

fn campaign(args: &CampaignArgs) -> Result<()> {
    let mut config = load(
        &args.config,
        Overrides {
            targets: args.targets,
            runs: args.runs,
            captures: args.captures,
            ..Overrides::default()
        },
    )?;
    if args.continuous {
        config.capture.mode = synth::config::CaptureMode::Continuous;
    } else if args.as_captured && config.capture.is_manifest() {
        config.capture.mode = synth::config::CaptureMode::Triggered;
    }
    if let Some(fps) = args.fps {
        config.procedure.fps = fps;
    }
    config.validate()?;
    print_size(&config, &args.out)?;
    let bars = Bars(Mutex::new(None));
    let mut output = output_plan(&args.config);
    let written = synth::write_campaign(&config, &args.out, &mut output, &bars);
    print_notes(&output);
    let s = written.with_context(|| format!("writing the campaign into {}", args.out.display()))?;
    println!(
        "{} instants, {} frames of {}×{} px ({:.2} GB of images with the calibration images) in {}",
        s.instants,
        s.frames,
        config.sensor.width,
        config.sensor.height,
        s.image_bytes as f64 / 1e9,
        args.out.display()
    );
    println!(
        "closest approach of a sphere to a frame border: {:.1} px; of two spheres: {:.1} px",
        s.scene.min_frame_clearance_px, s.scene.min_separation_px
    );
    if s.scene.min_frame_clearance_px < 0.0 {
        eprintln!(
            "trinocular: warning: a sphere leaves the frame: {}",
            s.scene.worst_frame
        );
    }
    if s.scene.min_separation_px < 0.0 {
        eprintln!(
            "trinocular: warning: two spheres overlap: {}",
            s.scene.worst_separation
        );
    }
    Ok(())
}

/// The frames and bytes the campaign will write, on stderr before the first
/// frame; a campaign the file system holding `out` has no room for is
/// refused (compressed images are counted at half their pixels: noise
/// compresses little, so a campaign refused would not have fitted).
fn print_size(config: &Config, out: &Path) -> Result<()> {
    let size = synth::campaign_size(config)?;
    let pixels = size.pixel_bytes + size.calibration_bytes;
    let compressed = config.output.format == synth::config::ImageFormat::Png
        || config.output.compression != synth::config::TiffCompression::None;
    let (needed, what) = if compressed {
        (pixels / 2, "the compressed images")
    } else {
        (pixels, "the images")
    };
    crate::cmd::output::check_room(
        out,
        needed,
        &format!(
            "{} frames of {}×{} px: {what}",
            size.frames, config.sensor.width, config.sensor.height
        ),
    )?;
    let recording = size.recording_s.map_or(String::new(), |s| {
        format!(
            "; {} cameras recording {s:.1} s at {} fps (--fps)",
            config.rig.cameras.len(),
            config.procedure.fps
        )
    });
    eprintln!(
        "{} frames of {}×{} px to write ({:.2} GB of {}-bit pixels){recording}",
        size.frames,
        config.sensor.width,
        config.sensor.height,
        size.pixel_bytes as f64 / 1e9,
        config.sensor.bits
    );
    Ok(())
}

fn board(args: &TargetArgs) -> Result<()> {
    let config = load(&args.config, Overrides::default())?;
    let bars = Bars(Mutex::new(None));
    let mut output = output_plan(&args.config);
    let written = synth::write_board_scene(&config, &args.out, &mut output, &bars);
    print_notes(&output);
    let s =
        written.with_context(|| format!("writing the board scene into {}", args.out.display()))?;
    println!(
        "{} placements of a {}×{} chessboard, {} views in {}",
        s.placements,
        config.board.inner[0],
        config.board.inner[1],
        s.views,
        Path::new(&args.out).display()
    );
    Ok(())
}

fn target(args: &TargetArgs) -> Result<()> {
    let config = load(&args.config, Overrides::default())?;
    let bars = Bars(Mutex::new(None));
    let mut output = output_plan(&args.config);
    let written = synth::write_target_scene(&config, &args.out, &mut output, &bars);
    print_notes(&output);
    let s =
        written.with_context(|| format!("writing the target scene into {}", args.out.display()))?;
    println!(
        "{} markers; images {} in {}",
        s.markers,
        s.images.join(", "),
        Path::new(&args.out).display()
    );
    Ok(())
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    match &args.what {
        What::Campaign(a) => campaign(a),
        What::Target(a) => target(a),
        What::Board(a) => board(a),
        What::Probe(a) => crate::cmd::probe::synth(a),
        What::Config => {
            print!("{}", synth::config::DEFAULT_TOML);
            Ok(())
        }
    }
}
