//! `trinocular bench measure`: `measure` against what it cannot beat, per
//! image format. A full-size campaign (4096×3072, 16-bit, the three
//! cameras) is rendered and calibrated once per format (uncompressed,
//! Deflate and LZW TIFF, 16-bit PNG, and uncompressed TIFF with every
//! instant captured twice, whose system gain `measure` takes from the
//! repeated captures); then, each as a child process timed
//! over `--repeat` runs (median; the commands in turn, one run of each per
//! round, so that a drift of the shared machine meets them all alike) with
//! its peak resident memory (its
//! `VmHWM`, [`record_peak`]): decode only (`bench decode`), decode + extract (`extract`) and
//! `measure --all-cameras`, on the same files, all threads; and `measure` as
//! run by default, which reads two of an instant's three frames (the two
//! cameras across each axis), as instants a second. The plain sum over a
//! frame in memory gives the machine's memory-bandwidth floor in the same run.

use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use rayon::prelude::*;

/// Arguments of `trinocular bench measure`.
#[derive(Debug, clap::Args)]
pub struct MeasureArgs {
    /// Targets per line of the rendered campaign (3 lines, 2 directions, 3 cameras).
    #[arg(long, default_value_t = 4, value_parser = clap::builder::RangedU64ValueParser::<u32>::new().range(2..))]
    targets: u32,
    /// Runs per direction.
    #[arg(long, default_value_t = 1, value_parser = clap::builder::RangedU64ValueParser::<u32>::new().range(1..))]
    runs: u32,
    /// Timed runs of each phase (the median is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    repeat: usize,
    /// Campaigns to measure (default: all five: the four formats, and
    /// uncompressed TIFF captured twice, K from the repeated captures).
    #[arg(long, value_delimiter = ',', value_enum)]
    formats: Vec<Format>,
    /// Folder for the campaigns (kept; a campaign already there, with its
    /// `rig.json`, is taken as it is); default: a temporary folder, removed afterwards.
    #[arg(long)]
    dir: Option<PathBuf>,
}

/// An image format of the benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Format {
    /// Uncompressed 16-bit TIFF.
    Tiff,
    /// Deflate-compressed TIFF (horizontal differencing).
    TiffDeflate,
    /// LZW-compressed TIFF (horizontal differencing).
    TiffLzw,
    /// 16-bit PNG.
    Png,
    /// Uncompressed TIFF, every instant captured twice: without stacks of
    /// flats and darks `measure` takes the system gain K from the repeated
    /// captures (the README's walk-through campaign).
    TiffRepeats,
}

impl Format {
    const ALL: [Format; 5] = [
        Format::Tiff,
        Format::TiffDeflate,
        Format::TiffLzw,
        Format::Png,
        Format::TiffRepeats,
    ];

    fn name(self) -> &'static str {
        match self {
            Format::Tiff => "TIFF",
            Format::TiffDeflate => "TIFF Deflate",
            Format::TiffLzw => "TIFF LZW",
            Format::Png => "PNG",
            Format::TiffRepeats => "TIFF, 2 captures (K from repeats)",
        }
    }

    /// Captures per instant of its campaign.
    fn captures(self) -> &'static str {
        match self {
            Format::TiffRepeats => "2",
            _ => "1",
        }
    }

    /// The renderer's output settings for it.
    fn output(self, config: &mut synth::Config) {
        use synth::config::{ImageFormat, TiffCompression};
        let (format, compression) = match self {
            Format::Tiff | Format::TiffRepeats => (ImageFormat::Tiff, TiffCompression::None),
            Format::TiffDeflate => (ImageFormat::Tiff, TiffCompression::Deflate),
            Format::TiffLzw => (ImageFormat::Tiff, TiffCompression::Lzw),
            Format::Png => (ImageFormat::Png, TiffCompression::None),
        };
        config.output.format = format;
        config.output.compression = compression;
    }

    /// Its campaign's folder: its name on the command line (`tiff-lzw`).
    fn folder(self) -> String {
        use clap::ValueEnum;
        self.to_possible_value()
            .map_or_else(|| format!("{self:?}"), |v| v.get_name().to_string())
    }
}

/// Arguments of the hidden `trinocular bench decode`: decode every image of
/// a manifest on all threads, nothing else (the floor of any pass over them).
#[derive(Debug, clap::Args)]
pub struct DecodeArgs {
    /// The campaign's manifest.
    #[arg(long)]
    manifest: PathBuf,
}

/// Decode every image of the manifest, in parallel, one reader per thread.
pub fn decode(args: &DecodeArgs) -> Result<()> {
    let images = formats::read_manifest_images(&args.manifest)?;
    // One reader (its buffers kept) per thread, each over its share.
    let share = images.len().div_ceil(rayon::current_num_threads()).max(1);
    let pixels: u64 = images
        .par_chunks(share)
        .map(|chunk| {
            let mut reader = extract::FrameReader::new();
            chunk
                .iter()
                .map(|path| {
                    reader
                        .read(path)
                        .map(|(f, _)| f.pixels.len() as u64)
                        .with_context(|| format!("decoding {}", path.display()))
                })
                .sum::<Result<u64>>()
        })
        .sum::<Result<u64>>()?;
    println!("decoded {} frames, {pixels} pixels", images.len());
    Ok(())
}

/// The environment variable naming the file a run writes its peak
/// resident memory into at exit ([`record_peak`]).
pub const PEAK_FILE_VAR: &str = "TRINOCULAR_PEAK_RSS_FILE";

/// At the end of a run, when [`PEAK_FILE_VAR`] names a file: write the
/// process's peak resident memory (`VmHWM` of /proc/self/status, kB) into
/// it, for `bench measure`, which runs each phase as a child process.
pub fn record_peak() {
    let Some(path) = std::env::var_os(PEAK_FILE_VAR) else {
        return;
    };
    let peak = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .map(|v| v.trim().trim_end_matches("kB").trim().to_string())
        })
        .unwrap_or_default();
    // A benchmark's side channel: a failure only loses the figure.
    let _ = std::fs::write(path, peak);
}

/// A child process's wall time and peak resident memory (bytes; `None`
/// where the platform does not say).
fn run_child(args: &[&OsStr]) -> Result<(Duration, Option<u64>)> {
    let exe = std::env::current_exe()?;
    let peak_file = tempfile::NamedTempFile::new()?;
    let start = Instant::now();
    let out = std::process::Command::new(&exe)
        .args(args)
        .env(PEAK_FILE_VAR, peak_file.path())
        .stdout(std::process::Stdio::null())
        .output()?;
    let elapsed = start.elapsed();
    anyhow::ensure!(
        out.status.success(),
        "trinocular {} failed: {}",
        args.iter()
            .map(|a| a.to_string_lossy())
            .collect::<Vec<_>>()
            .join(" "),
        String::from_utf8_lossy(&out.stderr).trim()
    );
    let peak = std::fs::read_to_string(peak_file.path())
        .ok()
        .and_then(|kb| kb.trim().parse::<u64>().ok())
        .map(|kb| kb * 1024);
    Ok((elapsed, peak))
}

/// Per command, the median wall time and the largest peak memory of
/// `repeat` runs, the commands taken in turn (one run of each, `repeat`
/// times over): on a shared machine whose speed drifts, every command meets
/// the same states, so their ratios compare like with like.
fn timed_in_turn(
    repeat: usize,
    commands: &[Vec<OsString>],
) -> Result<Vec<(Duration, Option<u64>)>> {
    let mut runs = vec![(Vec::new(), None); commands.len()];
    for _ in 0..repeat {
        for (command, (times, peak)) in commands.iter().zip(&mut runs) {
            let args: Vec<&OsStr> = command.iter().map(OsString::as_os_str).collect();
            let (t, p) = run_child(&args)?;
            times.push(t);
            *peak = (*peak).max(p);
        }
    }
    Ok(runs
        .into_iter()
        .map(|(mut times, peak)| {
            times.sort();
            (times[times.len() / 2], peak)
        })
        .collect())
}

/// Render a full-size campaign of `format` into `dir` and calibrate its rig.
fn campaign(dir: &Path, format: Format, args: &MeasureArgs) -> Result<()> {
    let mut config = synth::Config::default();
    format.output(&mut config);
    let cfg = dir.join("config.toml");
    std::fs::create_dir_all(dir)?;
    std::fs::write(&cfg, config.to_toml()?)?;
    let os = |s: &str| OsString::from(s);
    let p = |rel: &str| dir.join(rel).into_os_string();
    let (targets, runs) = (args.targets.to_string(), args.runs.to_string());
    let c = dir.join("c");
    let ext = config.output.format.extension();
    let steps: [Vec<OsString>; 2] = [
        ["synth", "campaign", "--width", "4096", "--height", "3072"]
            .map(os)
            .into_iter()
            .chain([
                os("--captures"),
                os(format.captures()),
                os("--targets"),
                os(&targets),
                os("--runs"),
                os(&runs),
                os("--config"),
                cfg.into_os_string(),
                os("--out"),
                c.clone().into_os_string(),
            ])
            .collect(),
        [os("calibrate"), os("--target"), p("c/target.csv")]
            .into_iter()
            .chain([os("--nominal"), p("c/nominal.json"), os("--images")])
            .chain((1..=3).map(|k| p(&format!("c/calib/cam{k}.{ext}"))))
            .chain([os("--flat-fields")])
            .chain((1..=3).map(|k| p(&format!("c/calib/flat_cam{k}.{ext}"))))
            .chain([os("--dark-frames")])
            .chain((1..=3).map(|k| p(&format!("c/calib/dark_cam{k}.{ext}"))))
            .chain([os("--out"), p("rig.json")])
            .collect(),
    ];
    for step in &steps {
        let refs: Vec<&OsStr> = step.iter().map(OsString::as_os_str).collect();
        run_child(&refs)?;
    }
    Ok(())
}

/// The plain sum over one frame in memory on all threads: the memory floor.
fn plain_sum(frame: &[u16]) -> Duration {
    let mut times: Vec<Duration> = (0..21)
        .map(|_| {
            let start = Instant::now();
            let s: u64 = std::hint::black_box(frame)
                .par_chunks(1 << 16)
                .map(|c| c.iter().map(|&v| u64::from(v)).sum::<u64>())
                .sum();
            std::hint::black_box(s);
            start.elapsed()
        })
        .collect();
    times.sort();
    times[times.len() / 2]
}

/// Megabytes, as printed.
fn mb(bytes: Option<u64>) -> String {
    bytes.map_or("—".into(), |b| format!("{:.0} MB", b as f64 / 1e6))
}

/// Run the benchmark.
pub fn bench(args: &MeasureArgs) -> Result<()> {
    let tmp;
    let root = match &args.dir {
        Some(d) => d.clone(),
        None => {
            tmp = tempfile::tempdir()?;
            tmp.path().to_path_buf()
        }
    };
    let formats = if args.formats.is_empty() {
        Format::ALL.to_vec()
    } else {
        args.formats.clone()
    };
    let threads = rayon::current_num_threads();
    println!(
        "measure: full-size campaigns (4096×3072, 16-bit, 3 cameras), {threads} threads, median of {} runs taken in turn",
        args.repeat
    );
    for format in formats {
        let dir = root.join(format.folder());
        if dir.join("c/manifest.csv").is_file() && dir.join("rig.json").is_file() {
            eprintln!("taking the {} campaign in {}", format.name(), dir.display());
        } else {
            eprintln!("rendering and calibrating the {} campaign …", format.name());
            campaign(&dir, format, args)?;
        }
        let files: Vec<OsString> = formats::read_manifest_images(&dir.join("c/manifest.csv"))?
            .into_iter()
            .map(PathBuf::into_os_string)
            .collect();
        let frames = files.len() as f64;
        let first = extract::FrameReader::new()
            .read(Path::new(&files[0]))
            .map(|(f, _)| f.pixels.to_vec())?;
        let sum = plain_sum(&first);
        let os = |s: &str| OsString::from(s);
        let manifest = dir.join("c/manifest.csv").into_os_string();
        let decode: Vec<OsString> = vec![
            os("bench"),
            os("decode"),
            os("--manifest"),
            manifest.clone(),
        ];
        let mut extract: Vec<OsString> = vec![
            os("extract"),
            os("--force"),
            os("--out"),
            dir.join("blobs.csv").into_os_string(),
        ];
        extract.extend(files.iter().cloned());
        // Over the same frames as extract: every camera of every instant
        // (by default measure reads two cameras an axis, 2/3 of the frames).
        let measure: Vec<OsString> = vec![
            os("measure"),
            os("--all-cameras"),
            os("--force"),
            os("--rig"),
            dir.join("rig.json").into_os_string(),
            os("--manifest"),
            manifest,
            os("--spheres"),
            dir.join("c/spheres.csv").into_os_string(),
            os("--out"),
            dir.join("points.csv").into_os_string(),
        ];
        let default_cameras: Vec<OsString> = measure
            .iter()
            .filter(|a| a.as_os_str() != "--all-cameras")
            .cloned()
            .collect();
        let names = [
            "decode",
            "decode + extract",
            "measure",
            "measure, 2 cameras",
        ];
        let timed = timed_in_turn(args.repeat, &[decode, extract, measure, default_cameras])?;
        let rows: Vec<(&str, f64, Option<u64>)> = names
            .into_iter()
            .zip(timed)
            .map(|(what, (t, peak))| (what, frames / t.as_secs_f64(), peak))
            .collect();
        let bytes: u64 = files
            .iter()
            .map(|f| std::fs::metadata(f).map(|m| m.len()).unwrap_or(0))
            .sum();
        println!(
            "{}: {} frames, {:.1} MB a file; plain sum over a frame in memory {:.2} ms",
            format.name(),
            files.len(),
            bytes as f64 / frames / 1e6,
            sum.as_secs_f64() * 1e3
        );
        for (what, fps, peak) in &rows[..3] {
            println!("  {what:<17} {fps:>7.1} frames/s   peak RSS {}", mb(*peak));
        }
        let ratio = rows[2].1 / rows[1].1;
        println!("  measure / (decode + extract): {ratio:.2}");
        // The default reads 2 of the 3 frames of an instant: its rate over
        // the frames it reads.
        let (_, fps, peak) = rows[3];
        println!(
            "  measure with its default two cameras an axis: {:.1} instants/s ({:.1} of the frames it reads a second), peak RSS {}",
            fps / 3.0,
            fps * 2.0 / 3.0,
            mb(peak)
        );
        if args.dir.is_none() {
            std::fs::remove_dir_all(&dir)?;
        }
    }
    Ok(())
}
