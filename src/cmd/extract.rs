//! `trinocular extract`: blobs of every image into `blobs.csv`; unusable
//! images go to `blobs.problems.csv` beside it (named after the output) and
//! the run carries on.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use extract::Denoise;
use formats::{BlobRow, OutputPlan, ProblemRow};

use crate::cmd::extraction::ExtractOptions;
use crate::cmd::images::{Subfolders, expand_images};
use crate::cmd::output::{print_notes, problems_path};
use crate::cmd::sensor::Stack;
use crate::cmd::{Finished, progress};

/// Arguments of `trinocular extract`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    options: ExtractOptions,
    /// Require this bit depth (8 or 16); other frames are reported as problems.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["8", "16"]))]
    bit_depth: Option<String>,
    /// Output CSV (one row per blob); problems go to <stem>.problems.csv beside it.
    #[arg(long)]
    out: PathBuf,
    /// Replace existing outputs (the CSV and <stem>.problems.csv beside it).
    #[arg(long)]
    force: bool,
    /// Flat-field frame of the camera, or a folder holding a stack of them (a
    /// uniform radiance source filling the view, same settings as the
    /// images): centroids are flat-field corrected by the lens's relative
    /// illumination fitted from it; a stack also gives the per-pixel gain
    /// map and defective pixels (docs/sensor.md).
    #[arg(long, requires = "dark_frame")]
    flat_field: Option<PathBuf>,
    /// Dark frame of the camera (lens capped), or a folder holding a stack of
    /// them, with --flat-field: a stack gives the per-pixel master dark and hot pixels.
    #[arg(long, requires = "flat_field")]
    dark_frame: Option<PathBuf>,
    /// System gain K (DN per electron) of the camera, with --flat-field:
    /// each blob gets its centroid's standard uncertainties
    /// (`u_sigma_px`, `v_sigma_px`, `uv_correlation`). Without it, K comes
    /// from the photon transfer of flat and dark stacks (folders of ≥ 2
    /// frames each); with single frames the columns stay empty.
    #[arg(long, requires = "flat_field", value_parser = crate::cmd::values::positive)]
    gain_dn_per_e: Option<f64>,
    /// Images (8/16-bit grayscale TIFF or PNG) or folders of them (searched
    /// into their subfolders, in the order of their paths).
    #[arg(required = true)]
    images: Vec<PathBuf>,
}

/// A camera's flat field as `extract` applies it: the lens's relative
/// illumination, the sensor's per-pixel calibration (from stacks), and the
/// camera serial its frames' tags name.
struct FlatField {
    illumination: geom::RadialIllumination,
    sensor: Option<sensor::SensorCalibration>,
    serial: Option<String>,
}

/// The lens's relative illumination from a flat field and a dark frame
/// (the first of each stack), without a camera model: centre started at the
/// image centre, ρ scaled by half the image diagonal; then the sensor's
/// per-pixel calibration from the stacks against it. The darks must be the
/// flats' camera's.
fn fit_flat_field(flat: &Path, dark: &Path, max_pixels: u64) -> Result<FlatField> {
    let mut reader = extract::FrameReader::new().limit_pixels(max_pixels);
    let flats = Stack::read(flat, &mut reader, None, "the camera")?;
    let first = flats.first().map(|f| (f.width, f.height));
    let darks = Stack::read(dark, &mut reader, first, "its flat field")?;
    darks.check_camera(
        flats.serial(),
        &format!("the flat field {}", flat.display()),
    )?;
    let Some(view) = flats.first().map(extract::Frame::view) else {
        bail!("{}: an empty stack of flat fields", flat.display());
    };
    let (fit, sensor) =
        super::sensor::fit(&flats, &darks, view.centre_px(), view.half_diagonal_px())?;
    eprintln!(
        "trinocular: flat field: relative illumination {:.4}…{:.4} of its centre ({:.1}, {:.1}) px, \
         fit residual {:.4} % RMS (noise {:.4} %)",
        fit.ri_range[0],
        fit.ri_range[1],
        fit.model.centre[0],
        fit.model.centre[1],
        100.0 * fit.residual_rms,
        100.0 * fit.noise_rms
    );
    if let Some(w) = &fit.warning {
        eprintln!("trinocular: warning: flat field {}: {w}", flat.display());
    }
    if let Some(s) = &sensor {
        eprintln!("trinocular: sensor: {}; {}", s.dark_note, s.gain_note);
    }
    Ok(FlatField {
        illumination: fit.model,
        sensor,
        serial: flats.serial().map(str::to_string),
    })
}

/// What a batch left out, by kind, with a problem row for each.
#[derive(Default)]
struct Tally {
    problems: Vec<ProblemRow>,
    /// Frames that could not be read or extracted.
    failed_frames: usize,
    /// Frames with saturated blobs.
    saturated: usize,
    /// Blobs that kept their plain centroid.
    uncorrected: usize,
    /// Frames without a blob above the threshold.
    without_blobs: usize,
    /// Blobs written.
    blobs: usize,
}

impl Tally {
    /// An error when no image could be used: nothing usable is a failure,
    /// not a batch with a few bad items, and its outputs are not written.
    fn nothing_usable(&self, images: usize) -> Result<()> {
        if self.failed_frames < images {
            return Ok(());
        }
        let first = self.problems.first().map(|p| p.reason.as_str());
        bail!(
            "{}",
            crate::cmd::none_could(images, "image", "be used", first)
        );
    }

    /// The batch's outcome once its problems are written: a finished batch
    /// that names what it left out.
    fn outcome(&self, images: usize, problems_file: &Path) -> Result<()> {
        let Tally {
            failed_frames,
            saturated,
            uncorrected,
            without_blobs,
            ..
        } = *self;
        let mut what = Vec::new();
        if failed_frames > 0 {
            what.push(format!(
                "{failed_frames} of {images} images could not be used"
            ));
        }
        if without_blobs > 0 {
            what.push(format!("{without_blobs} of {images} images without a blob"));
        }
        if saturated > 0 {
            what.push(format!(
                "{saturated} image{} with saturated blobs",
                if saturated == 1 { "" } else { "s" }
            ));
        }
        if uncorrected > 0 {
            what.push(format!(
                "{uncorrected} blob{} kept {} plain centroid",
                if uncorrected == 1 { "" } else { "s" },
                if uncorrected == 1 { "its" } else { "their" }
            ));
        }
        Err(Finished::with_problems(format!(
            "{}; listed in {}",
            what.join("; "),
            problems_file.display()
        )))
    }
}

/// The `blobs.csv` rows of one frame's blobs.
fn blob_rows<'a>(
    name: &'a str,
    frame: &'a extract::FrameBlobs,
) -> impl Iterator<Item = BlobRow> + 'a {
    frame.blobs.iter().enumerate().map(move |(i, b)| {
        let e = b.ellipse();
        let defect_pixels = frame.defect_pixels.get(i).copied();
        let covariance = frame.covariance.get(i).copied().flatten();
        BlobRow {
            image: name.to_string(),
            blob: i as u32,
            u: b.u,
            v: b.v,
            area_px: b.area_px,
            diameter_px: b.diameter_px(),
            peak: b.peak,
            saturated: b.saturated(),
            touches_border: b.touches_border,
            sphere: None,
            signal: b.signal() as f64,
            major_px: e.major_px,
            minor_px: e.minor_px,
            orientation_rad: e.orientation_rad,
            circularity: b.circularity(),
            threshold: frame.threshold.clone(),
            camera_model: frame.metadata.model.clone(),
            camera_serial: frame.metadata.serial.clone(),
            datetime: frame.metadata.datetime.clone(),
            exposure_s: frame.metadata.exposure_s,
            defect_pixels,
            u_sigma_px: covariance.map(|c| c.sigma_u_px()),
            v_sigma_px: covariance.map(|c| c.sigma_v_px()),
            uv_correlation: covariance.map(|c| c.correlation()),
        }
    })
}

/// Run the command: plan and lock the outputs, fit the flat field, extract
/// every image into `blobs.csv` (a bad frame is a problem row, never the end
/// of the batch), then write the problems and say what was left out.
pub fn run(args: &Args) -> Result<()> {
    let params = args.options.params()?;
    let backend = args.options.backend()?;
    let depth = args
        .bit_depth
        .as_deref()
        .map(|d| if d == "8" { 8 } else { 16 });
    let files = expand_images(&args.images, Subfolders::Searched)?;
    let problems_file = problems_path(&args.out);
    let mut plan = OutputPlan::new(args.force);
    plan.inputs(&args.images)
        .inputs(&files)
        .inputs(&args.flat_field)
        .inputs(&args.dark_frame)
        .file(&args.out)
        .file(&problems_file);
    plan.lock(formats::folder_of(&args.out), "extract")?;
    print_notes(&plan);
    plan.check()?;
    let flat_field = match (&args.flat_field, &args.dark_frame) {
        (Some(flat), Some(dark)) => Some(fit_flat_field(flat, dark, params.max_pixels)?),
        _ => None,
    };
    let radiometry = flat_field.as_ref().map(|f| extract::Radiometry {
        illumination: &f.illumination,
        sensor: f.sensor.as_ref().map(|s| &s.maps),
        gain_dn_per_e: args.gain_dn_per_e.or_else(|| {
            f.sensor
                .as_ref()
                .and_then(|s| s.transfer.map(|t| t.gain_dn_per_e))
        }),
    });
    let flat_serial = flat_field.as_ref().and_then(|f| f.serial.as_deref());
    if radiometry.is_some_and(|r| r.gain_dn_per_e.is_some()) && params.denoise != Denoise::None {
        eprintln!(
            "trinocular: note: no centroid uncertainties with --denoise (its pixels' noise is \
             correlated)"
        );
    }
    let mut out = plan.create(&args.out)?;
    let mut csv = csv::Writer::from_writer(&mut out);
    let mut tally = Tally::default();
    let mut write_error: Option<anyhow::Error> = None;
    let bar = progress::bar(files.len() as u64, "extract");
    let sink = |_: usize, path: &Path, result: extract::Result<extract::FrameBlobs>| {
        bar.inc(1);
        let name = path.display().to_string();
        // A frame of another camera than the flat field's is corrected with
        // the wrong lens and sensor: it is left out.
        let result = result.and_then(|frame| match (&frame.metadata.serial, flat_serial) {
            (Some(got), Some(want)) if got != want => Err(extract::ExtractError::Unsupported {
                path: path.to_path_buf(),
                message: format!(
                    "taken by the camera of serial {got}, but the flat field is serial \
                     {want}: a flat field corrects its own camera's frames only"
                ),
            }),
            _ => Ok(frame),
        });
        match result {
            Ok(frame) => {
                if frame.blobs.is_empty() {
                    tally.without_blobs += 1;
                    let reason = format!(
                        "no blob above the threshold ({}, at least {} px)",
                        frame.threshold, params.min_area
                    );
                    bar.suspend(|| eprintln!("trinocular: warning: {name}: {reason}"));
                    tally.problems.push(ProblemRow {
                        item: name.clone(),
                        reason,
                    });
                }
                if let Some(reason) = &frame.saturation {
                    tally.saturated += 1;
                    bar.suspend(|| eprintln!("trinocular: warning: {name}: {reason}"));
                    tally.problems.push(ProblemRow {
                        item: name.clone(),
                        reason: reason.clone(),
                    });
                }
                for (i, reason) in &frame.uncorrected {
                    tally.uncorrected += 1;
                    tally.problems.push(ProblemRow {
                        item: format!("{name}#blob{i}"),
                        reason: reason.clone(),
                    });
                }
                for row in blob_rows(&name, &frame) {
                    tally.blobs += 1;
                    if let Err(e) = csv.serialize(row) {
                        write_error.get_or_insert(e.into());
                    }
                }
            }
            Err(e) => {
                tally.failed_frames += 1;
                bar.suspend(|| eprintln!("trinocular: warning: {e}"));
                tally.problems.push(ProblemRow {
                    item: name,
                    reason: e.to_string(),
                });
            }
        }
    };
    match radiometry {
        Some(r) => extract::extract_files_flat(&files, backend.as_ref(), &params, depth, r, sink),
        None => extract::extract_files(&files, backend.as_ref(), &params, depth, sink),
    }
    bar.finish_and_clear();
    if let Some(e) = write_error {
        return Err(e.context(format!("{}", args.out.display())));
    }
    tally.nothing_usable(files.len())?;
    if tally.blobs == 0 {
        // The header alone: a file of no blobs still says what it holds.
        csv.write_record(BlobRow::HEADER)
            .with_context(|| format!("{}", args.out.display()))?;
    }
    csv.flush()
        .with_context(|| format!("{}", args.out.display()))?;
    drop(csv);
    out.commit()?;
    let used = files.len() - tally.failed_frames;
    println!(
        "extract: {} blob{} from {used} of {} image{} → {}",
        tally.blobs,
        if tally.blobs == 1 { "" } else { "s" },
        files.len(),
        if files.len() == 1 { "" } else { "s" },
        args.out.display()
    );
    // Written whatever it holds: a file of no problems says none were found.
    plan.write_records(&problems_file, &tally.problems)?;
    if tally.problems.is_empty() {
        return Ok(());
    }
    tally.outcome(files.len(), &problems_file)
}
