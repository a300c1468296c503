//! `trinocular calibrate`: each camera from a 3-D target (docs/methods.md,
//! Calibration). From one calibration image per camera (markers extracted,
//! then assigned to target ids automatically from the nominal rig,
//! `calib::calibrate_detections`) or from `id,u,v` correspondence files
//! (without a nominal rig: cameras 1, 2, … of the image size given).
//! With a flat field and a dark frame per camera, the lens's relative
//! illumination is fitted (`calib::fit_flat_field`) and stored in `rig.json`;
//! without them the ideal lens is assumed. With images, once a camera
//! estimate exists the blob centroids are recomputed with its model — over
//! undistorted pixel positions, flat-field corrected (`extract::correction`) —
//! and the camera refitted.
//! Writes, all atomically, once every camera is calibrated:
//! - `--out` (`rig.json`, docs/formats.md), with each camera's model, parameter
//!   standard deviations, outliers and DLT figures under extra keys, and its
//!   parameter `covariance` (`calib::parameter_covariance`: image noise and
//!   the target's marker uncertainty, `target.csv u_mm` or
//!   `--target-uncertainty-um`);
//! - `<stem>.cam<ID>.opencv.yml` beside it: OpenCV `FileStorage` YAML;
//! - `<stem>.residuals.csv`: per-point residuals of every camera;
//! - `<stem>.commissioning.txt` and `<stem>.commissioning.json`: the rig
//!   commissioning report.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use calib::{
    Calibration, CameraInput, CommissionOptions, CorrespondOptions, FlatFieldFit, Model, Optics,
    Options,
};
use clap::ValueEnum;
use extract::{Blob, FrameReader, observed_centroids};
use formats::{
    Axis, CalibrationRecord, CorrespondenceRow, IlluminationJson, Matching, NominalCamera,
    NominalRig, OutputPlan, ResidualRow, Rig, RigCamera, TargetRow, read_correspondences,
    read_nominal, read_spheres, read_target,
};
use geom::{Illumination, Point2};

use crate::cmd::extraction::ExtractOptions;
use crate::cmd::sensor::Stack;
use crate::cmd::{OrUsage, Usage, values};

mod views;

/// Distortion model (`--model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModelArg {
    /// k1 k2 p1 p2, and k3 where the data support it (an F test and a
    /// cross-validation over the markers, docs/methods.md).
    Auto,
    /// No distortion.
    Pinhole,
    /// Radial k1, k2.
    K1k2,
    /// Radial k1, k2 and tangential p1, p2.
    K1k2p1p2,
}

/// What the target's markers are (`--markers`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MarkerArg {
    /// Luminous spheres of the target's `diameter`: the model predicts the
    /// centre of each sphere's image ellipse (the perspective bias).
    Sphere,
    /// Points: the centroid is taken as the projection of the marker centre.
    Point,
}

/// Arguments of `trinocular calibrate`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["images", "points", "views"])))]
pub struct Args {
    /// Calibration target `target.csv` (`id,x,y,z[,diameter][,u_mm]`, mm).
    #[arg(long, required_unless_present = "board", conflicts_with = "board")]
    target: Option<PathBuf>,
    /// A printed chessboard instead of --target, with --views:
    /// `chessboard:COLSxROWS:SQUARE_MM` (inner corners; one odd and one even
    /// count). Its frame: origin at the first inner corner, x along COLS, y
    /// along ROWS; the square diagonally outside the first corner is black.
    #[arg(long, requires = "views")]
    board: Option<String>,
    /// Nominal rig `nominal.json`: starts the calibration and finds the
    /// correspondences (needed with --images and --flat-fields).
    #[arg(long)]
    nominal: Option<PathBuf>,
    /// Image width (px) of every camera, with --points or --views and no --nominal.
    #[arg(long, conflicts_with = "nominal", requires = "height", value_parser = clap::value_parser!(u32).range(1..=i64::from(formats::limits::MAX_IMAGE_SIDE_PX)))]
    width: Option<u32>,
    /// Image height (px) of every camera, with --points or --views and no --nominal.
    #[arg(long, conflicts_with = "nominal", requires = "width", value_parser = clap::value_parser!(u32).range(1..=i64::from(formats::limits::MAX_IMAGE_SIDE_PX)))]
    height: Option<u32>,
    /// One calibration image per camera, in camera order (the nominal rig's ids, ascending).
    #[arg(long, num_args = 1.., requires = "nominal")]
    images: Vec<PathBuf>,
    /// Correspondence files `id,u,v`, one per camera in camera order, instead
    /// of images (without --nominal: cameras 1, 2, 3 in this order).
    #[arg(long, num_args = 1..)]
    points: Vec<PathBuf>,
    /// Calibration views `views.csv` (`image,camera,pose`, docs/calibrating.md):
    /// any number of views of the target per camera, the target moved
    /// between poses, every camera and pose solved in one bundle. Its files
    /// are images (give --nominal: the markers are found from the nominal
    /// rig, the target moved by the row's offset) or `id,u,v`
    /// correspondence files (give --width and --height, or --nominal).
    #[arg(long)]
    views: Option<PathBuf>,
    /// Flat-field frames, one per camera in camera order, each a file or a
    /// folder holding a stack of frames: a uniform radiance source filling the
    /// view, same lens settings and exposure as the measurement (docs/sensor.md).
    #[arg(long, num_args = 1.., requires = "dark_frames", requires = "nominal")]
    flat_fields: Vec<PathBuf>,
    /// Dark frames (lens capped), one per camera in camera order, each a file
    /// or a folder holding a stack of frames.
    #[arg(long, num_args = 1.., requires = "flat_fields")]
    dark_frames: Vec<PathBuf>,
    /// Sphere set `spheres.csv` (`name,diameter`) whose scale errors the
    /// commissioning report gives (default: A 20, B 15, C 10 mm).
    #[arg(long)]
    spheres: Option<PathBuf>,
    /// Output `rig.json`; the other outputs go beside it (the folder is created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Replace existing outputs (rig.json and the files beside it).
    #[arg(long)]
    force: bool,
    /// Distortion model.
    #[arg(long, value_enum, default_value_t = ModelArg::Auto)]
    model: ModelArg,
    /// Also estimate k3 (radial r⁶), whatever the data say.
    #[arg(long)]
    k3: bool,
    /// Also estimate the skew.
    #[arg(long)]
    skew: bool,
    /// Reject points whose residual exceeds k·σ (robust σ) and refit.
    #[arg(long, default_value_t = calib::DEFAULT_OUTLIER_K, value_parser = values::positive)]
    outlier_k: f64,
    /// Keep every point (no outlier rejection).
    #[arg(long)]
    keep_outliers: bool,
    /// Standard uncertainty (µm) of each coordinate of every marker, for the
    /// cameras' parameter covariance in rig.json (overrides target.csv's
    /// `u_mm`; without either: 1 µm).
    #[arg(long, value_parser = values::non_negative)]
    target_uncertainty_um: Option<f64>,
    /// Marker type; default: spheres when target.csv gives diameters.
    #[arg(long, value_enum)]
    markers: Option<MarkerArg>,
    /// X travel (mm) through the working point checked by the commissioning report.
    #[arg(long, default_value_t = 150.0, value_parser = values::positive)]
    travel_x: f64,
    /// Y travel (mm) checked by the commissioning report.
    #[arg(long, default_value_t = 100.0, value_parser = values::positive)]
    travel_y: f64,
    /// Largest deviation from 90° between optical axes before a warning (deg).
    #[arg(long, default_value_t = 1.0, value_parser = values::positive)]
    perpendicularity_tolerance: f64,
    /// Largest angle between an optical axis and its machine axis before a warning (deg).
    #[arg(long, default_value_t = 1.0, value_parser = values::positive)]
    alignment_tolerance: f64,
    #[command(flatten)]
    extract: ExtractOptions,
}

/// `--target` (clap requires it unless `--board` is given, which only
/// `--views` takes).
fn target_path(args: &Args) -> Result<&Path> {
    args.target
        .as_deref()
        .ok_or_else(|| Usage::error("--target target.csv is needed (--board only with --views)"))
}

/// `--nominal` (empty when not given: only used in messages of steps that need it).
fn nominal_path(args: &Args) -> &Path {
    args.nominal.as_deref().unwrap_or(Path::new(""))
}

/// A file beside `out` named `<stem><suffix>`.
fn beside(out: &Path, suffix: &str) -> PathBuf {
    formats::beside(out, "rig", suffix)
}

/// Optics for the depth of field: pixel pitch and the lens keys of a
/// nominal.json camera (checked when read; defaults: f/8, 2 px, focal length
/// from the lens equation, focus at the working point).
fn optics(nominal: &NominalCamera) -> Optics {
    let o = nominal.optics;
    Optics {
        pixel_mm: nominal.pixel_mm,
        f_number: o.f_number.unwrap_or(calib::DEFAULT_F_NUMBER),
        coc_px: o.coc_px.unwrap_or(calib::DEFAULT_COC_PX),
        focal_mm: o.lens_focal_mm,
        focus_distance_mm: o.focus_distance_mm,
    }
}

/// What a camera's flat fields and dark frames gave: the lens's relative
/// illumination (the ideal lens without them), its fit, and the sensor's
/// per-pixel calibration from the stacks.
struct Radiometry {
    illumination: Illumination,
    flat_fit: Option<FlatFieldFit>,
    sensor: Option<sensor::SensorCalibration>,
}

/// The radiometry of camera `id` (index `k` in camera order): from its
/// stacks of flat fields and dark frames when given (each a file or a
/// folder): the relative illumination fitted to the first flat and dark
/// (model centre started at the nominal image centre, ρ scaled by the
/// nominal focal length), then the sensor's calibration against it.
fn radiometry(
    args: &Args,
    k: usize,
    nominal: &NominalCamera,
    reader: &mut FrameReader,
) -> Result<Radiometry> {
    let (Some(flat), Some(dark)) = (args.flat_fields.get(k), args.dark_frames.get(k)) else {
        return Ok(Radiometry {
            illumination: Illumination::Ideal,
            flat_fit: None,
            sensor: None,
        });
    };
    let camera = format!("camera {}", nominal.id);
    let size = Some((nominal.width, nominal.height));
    let flats = Stack::read(flat, reader, size, &camera)?;
    let darks = Stack::read(dark, reader, size, &camera)?;
    // The flats and darks are the camera's own: their serials against its
    // calibration image's (when it has one), the darks' against the flats'.
    if let Some(image) = args.images.get(k) {
        let serial = ingest::read_metadata(image).ok().and_then(|m| m.serial);
        let what = format!("{camera}'s image {}", image.display());
        flats.check_camera(serial.as_deref(), &what)?;
        darks.check_camera(serial.as_deref(), &what)?;
    }
    let what = format!("its flat field {}", flat.display());
    darks.check_camera(flats.serial(), &what)?;
    let start = nominal
        .to_camera()
        .map_err(|e| anyhow::anyhow!("{}: {e}", nominal_path(args).display()))?;
    let ki = start.intrinsics;
    let (fit, sensor) = super::sensor::fit(&flats, &darks, [ki.cx, ki.cy], ki.fx)
        .with_context(|| camera.clone())?;
    Ok(Radiometry {
        illumination: Illumination::Radial(fit.model.clone()),
        flat_fit: Some(fit),
        sensor,
    })
}

/// One camera to calibrate: its id and sensor size, and its nominal
/// description when `--nominal` was given.
struct CameraSpec {
    id: u8,
    width: u32,
    height: u32,
    nominal: Option<NominalCamera>,
}

/// What every camera's calibration shares: the fit options, the target and
/// its marker type, the cameras, the commissioning report's sphere set.
struct Setup {
    options: Options,
    /// Whether k3 is chosen by the data (`--model auto` without `--k3`).
    choose: bool,
    target: Vec<TargetRow>,
    cameras: Vec<CameraSpec>,
    spheres: bool,
    sphere_set: Vec<(String, f64)>,
    target_uncertainty: calib::TargetUncertainty,
}

/// One camera calibrated: its `rig.json` entry, residual rows, commissioning
/// input and OpenCV YAML (path, text).
struct Calibrated {
    entry: RigCamera,
    residuals: Vec<ResidualRow>,
    commissioning: CameraInput,
    yaml: (PathBuf, String),
    /// The sensor's per-pixel map files (path, bytes).
    map_files: Vec<super::sensor::MapBytes>,
}

/// Run the command: (1) read and check the inputs, (2) plan the outputs,
/// (3) calibrate each camera, (4) write the outputs once all are calibrated.
pub fn run(args: &Args) -> Result<()> {
    if let Some(views) = &args.views {
        return views::run(args, views);
    }
    let setup = setup(args)?;
    let cameras = &setup.cameras;
    let inputs = inputs(args);
    let extraction = if args.images.is_empty() {
        None
    } else {
        Some((args.extract.backend()?, args.extract.params()?))
    };
    let mut output = plan_outputs(args, &cameras[..inputs.len()])?;
    if args.flat_fields.is_empty() {
        eprintln!(
            "trinocular: note: no flat fields given: every camera records the ideal-lens assumption \
             (cos⁴θ relative illumination, energy-conserving under distortion); measure a flat field \
             and a dark frame per camera (--flat-fields, --dark-frames) for a real lens"
        );
    }
    let mut reader = FrameReader::new().limit_pixels(args.extract.params()?.max_pixels);
    let mut calibrated = Vec::new();
    for (k, (camera, input)) in cameras.iter().zip(inputs).enumerate() {
        calibrated.push(calibrate_camera(
            args,
            &setup,
            k,
            camera,
            input,
            extraction.as_ref(),
            &mut reader,
        )?);
    }
    write_outputs(args, &mut output, calibrated, setup.sphere_set)
}

/// Step 1: the fit options, the target (checked as a whole: its problems are
/// the target file's, not the first camera's), the cameras (one input each),
/// the marker type and the commissioning report's sphere set.
fn setup(args: &Args) -> Result<Setup> {
    let options = fit_options(args)?;
    let target_path = target_path(args)?;
    let target: Vec<TargetRow> = read_target(target_path)?
        .into_iter()
        .map(|r| r.record)
        .collect();
    calib::check_target(&target).with_context(|| format!("{}", target_path.display()))?;
    let target_uncertainty = calib::TargetUncertainty::resolve(&target, args.target_uncertainty_um)
        .with_context(|| format!("{}", target_path.display()))?;
    let cameras = cameras(args)?;
    check_counts(args, cameras.len(), inputs(args).len())?;
    let spheres = match args.markers {
        Some(m) => m == MarkerArg::Sphere,
        None => target.iter().all(|t| t.diameter.is_some()),
    };
    if spheres && target.iter().any(|t| t.diameter.is_none()) {
        return Err(Usage::error(format!(
            "{}: --markers sphere needs a diameter for every marker",
            target_path.display()
        )));
    }
    let sphere_set = match &args.spheres {
        Some(path) => read_spheres(path)?
            .into_iter()
            .map(|r| (r.record.name, r.record.diameter))
            .collect(),
        None => CommissionOptions::default().spheres,
    };
    Ok(Setup {
        options,
        choose: args.model == ModelArg::Auto && !args.k3,
        target,
        cameras,
        spheres,
        sphere_set,
        target_uncertainty,
    })
}

/// The fit options of the command line, checked.
fn fit_options(args: &Args) -> Result<Options> {
    let options = Options {
        model: match args.model {
            ModelArg::Pinhole => Model::Pinhole,
            ModelArg::K1k2 => Model::K1K2,
            ModelArg::K1k2p1p2 | ModelArg::Auto => Model::K1K2P1P2,
        },
        k3: args.k3,
        skew: args.skew,
        outlier_k: (!args.keep_outliers).then_some(args.outlier_k),
        ..Options::default()
    };
    options.validate().or_usage()?;
    Ok(options)
}

/// The cameras in camera order: the nominal rig's (ids ascending), or
/// without one, cameras 1, 2, … of the correspondence files with the image
/// size of `--width` and `--height`.
fn cameras(args: &Args) -> Result<Vec<CameraSpec>> {
    if let Some(path) = &args.nominal {
        let nominal: NominalRig = read_nominal(path)?;
        let mut cameras: Vec<CameraSpec> = nominal
            .cameras
            .into_iter()
            .map(|c| CameraSpec {
                id: c.id,
                width: c.width,
                height: c.height,
                nominal: Some(c),
            })
            .collect();
        cameras.sort_by_key(|c| c.id);
        return Ok(cameras);
    }
    let (Some(width), Some(height)) = (args.width, args.height) else {
        return Err(Usage::error(
            "--points without --nominal needs the image size: give --width and --height",
        ));
    };
    if args.points.len() > 3 {
        return Err(Usage::error(format!(
            "--points: {} correspondence files without --nominal; at most 3 cameras (1, 2, 3)",
            args.points.len()
        )));
    }
    Ok((1..=3)
        .take(args.points.len())
        .map(|id| CameraSpec {
            id,
            width,
            height,
            nominal: None,
        })
        .collect())
}

/// The calibration images, else the correspondence files.
fn inputs(args: &Args) -> &[PathBuf] {
    if args.images.is_empty() {
        &args.points
    } else {
        &args.images
    }
}

/// One input per camera (images: exactly; correspondence files: at most),
/// and as many flat fields and dark frames as inputs.
fn check_counts(args: &Args, cameras: usize, inputs: usize) -> Result<()> {
    if inputs > cameras || (!args.images.is_empty() && inputs != cameras) {
        return Err(Usage::error(format!(
            "{} has {} cameras but {} {} were given (one per camera, in camera order)",
            nominal_path(args).display(),
            cameras,
            inputs,
            if args.images.is_empty() {
                "correspondence files"
            } else {
                "images"
            }
        )));
    }
    for (flag, given) in [
        ("--flat-fields", &args.flat_fields),
        ("--dark-frames", &args.dark_frames),
    ] {
        if !given.is_empty() && given.len() != inputs {
            return Err(Usage::error(format!(
                "{flag}: {} files for {} cameras (one per camera, in camera order)",
                given.len(),
                inputs
            )));
        }
    }
    Ok(())
}

/// Step 2: every output declared and checked against the inputs and the
/// files that exist, before any work.
fn plan_outputs(args: &Args, cameras: &[CameraSpec]) -> Result<OutputPlan> {
    let mut output = OutputPlan::new(args.force);
    output
        .inputs(&args.target)
        .inputs(&args.nominal)
        .inputs(&args.images)
        .inputs(&args.points)
        .inputs(&args.flat_fields)
        .inputs(&args.dark_frames)
        .inputs(&args.spheres)
        .file(&args.out)
        .file(beside(&args.out, ".residuals.csv"))
        .file(beside(&args.out, ".commissioning.txt"))
        .file(beside(&args.out, ".commissioning.json"));
    for c in cameras {
        output.file(beside(&args.out, &format!(".cam{}.opencv.yml", c.id)));
        if !args.flat_fields.is_empty() {
            super::sensor::plan_maps(&mut output, &args.out, c.id);
        }
    }
    output.check()?;
    Ok(output)
}

/// Step 3, one camera (index `k` in camera order): its relative
/// illumination, its calibration from its image or correspondence file, a
/// summary on stdout, and what the outputs hold of it.
fn calibrate_camera(
    args: &Args,
    setup: &Setup,
    k: usize,
    camera: &CameraSpec,
    input: &Path,
    extraction: Option<&(Arc<dyn extract::Backend>, extract::ExtractParams)>,
    reader: &mut FrameReader,
) -> Result<Calibrated> {
    let id = camera.id;
    let radiometry = match &camera.nominal {
        Some(nominal) => radiometry(args, k, nominal, reader)?,
        None => Radiometry {
            illumination: Illumination::Ideal,
            flat_fit: None,
            sensor: None,
        },
    };
    let Radiometry {
        illumination,
        flat_fit,
        sensor,
    } = radiometry;
    let maps = sensor.as_ref().map(|s| &s.maps);
    let (observations, cal, matching, choice) = match (extraction, &camera.nominal) {
        (Some((backend, params)), Some(nominal)) => {
            let search = MarkerSearch {
                target: &setup.target,
                spheres: setup.spheres,
                backend: backend.as_ref(),
                params,
                illumination: &illumination,
                maps,
                correspond: CorrespondOptions::default(),
            };
            from_image(args, setup, nominal, input, &search, reader)?
        }
        _ => from_points(setup, camera, input)?,
    };
    summarise(id, &cal, &matching);
    if let Some(c) = &choice {
        println!("camera {id}: distortion model {}", c.reason);
    }
    let covariance = covariance(setup, id, input, &cal, &observations)?;
    if let Some(fit) = &flat_fit {
        println!(
            "camera {id}: relative illumination {:.4}…{:.4} of the centre, fit residual {:.4} % RMS (noise {:.4} %)",
            fit.ri_range[0],
            fit.ri_range[1],
            100.0 * fit.residual_rms,
            100.0 * fit.noise_rms
        );
    }
    let residuals = observations
        .iter()
        .zip(&cal.residuals)
        .map(|(o, r)| residual_row(id, None, o, r))
        .collect();
    let mut entry = RigCamera::new(id, &cal.camera, cal.rms_px, cal.points_used());
    entry.relative_illumination = illumination_json(&illumination, flat_fit.as_ref(), args, k)?;
    let mut map_files = Vec::new();
    if let Some(cal) = &sensor {
        let (files, names) = super::sensor::encode_maps(cal, &args.out, id)?;
        entry.sensor = Some(super::sensor::record(cal, names));
        map_files = files;
    }
    entry.extra = record(&cal, input, setup.spheres, matching).to_keys()?;
    if let Some(c) = &choice {
        entry
            .extra
            .insert("model_choice".into(), model_choice_json(c));
    }
    entry.covariance = covariance;
    let sensor_record = entry.sensor.clone();
    let covariance_record = entry.covariance.clone();
    let yaml = (
        beside(&args.out, &format!(".cam{id}.opencv.yml")),
        calib::opencv_yaml(id, &cal.camera, cal.rms_px, None),
    );
    Ok(Calibrated {
        entry,
        residuals,
        commissioning: CameraInput {
            id,
            camera: cal.camera.clone(),
            rms_px: cal.rms_px,
            optics: camera.nominal.as_ref().map(optics),
            illumination,
            flat_field: flat_fit,
            sensor: sensor_record,
            covariance: covariance_record,
        },
        yaml,
        map_files,
    })
}

/// The covariance of camera `id`'s parameters (`calib::parameter_covariance`),
/// with a warning when it is not determined or the stated target uncertainty
/// exceeds what the residuals show.
fn covariance(
    setup: &Setup,
    id: u8,
    input: &Path,
    cal: &Calibration,
    observations: &[calib::Observation],
) -> Result<Option<formats::CameraCovariance>> {
    let target = &setup.target_uncertainty;
    let covariance = calib::parameter_covariance(cal, observations, target)
        .with_context(|| format!("camera {id} ({})", input.display()))?;
    match &covariance {
        None => eprintln!(
            "trinocular: warning: camera {id}: the parameters' covariance is not determined \
             (too few points for the model, or a degenerate target): figures measured with \
             this rig carry no calibration uncertainty"
        ),
        Some(c) if c.target_exceeds_residuals() => eprintln!(
            "trinocular: note: camera {id}: the target uncertainty ({}) explains more than the \
             reprojection residuals show (σ {:.4} px); the covariance rests on it alone",
            target.source, c.residual_sigma_px
        ),
        Some(_) => {}
    }
    Ok(covariance.as_ref().map(calib::ParameterCovariance::record))
}

/// What finding the target's markers in an image needs besides the image:
/// the target, its marker kind, the extraction, the camera's radiometry and
/// the assignment's options.
struct MarkerSearch<'a> {
    target: &'a [TargetRow],
    spheres: bool,
    backend: &'a dyn extract::Backend,
    params: &'a extract::ExtractParams,
    illumination: &'a Illumination,
    maps: Option<&'a sensor::SensorMaps>,
    correspond: CorrespondOptions,
}

/// The target's markers in image `input`: blobs extracted, assigned to
/// target ids from the camera `start` (the nominal camera, in the target's
/// frame), the camera calibrated with `options` and the centroids
/// recomputed with it (`calib::calibrate_detections`); then, where
/// `again(result)` asks for other options, calibrated again from the same
/// blobs. `nominal` names the file the sensor size came from; errors are
/// prefixed with `what` (the camera and file). Returns the result and how
/// many blobs were detected.
#[allow(clippy::too_many_arguments)]
fn detect_markers(
    search: &MarkerSearch,
    start: &geom::Camera,
    input: &Path,
    what: &str,
    nominal: &Path,
    options: &Options,
    reader: &mut FrameReader,
    again: &mut dyn FnMut(&calib::ImageCalibration) -> Result<Option<Options>>,
) -> Result<(calib::ImageCalibration, usize)> {
    let context = || what.to_string();
    let (raw, _) = reader.read(input).with_context(context)?;
    let corrected = raw.corrected(search.maps).with_context(context)?;
    let frame = corrected.as_ref().map_or(raw, extract::Frame::view);
    if frame.width != start.width || frame.height != start.height {
        bail!(
            "{}: the image is {}×{} px, but {} gives this camera {}×{} px",
            context(),
            frame.width,
            frame.height,
            nominal.display(),
            start.width,
            start.height
        );
    }
    let params = search.params;
    let ex = search
        .backend
        .extract(frame, params)
        .with_context(context)?;
    let blobs: Vec<&Blob> = ex.blobs.iter().filter(|b| !b.touches_border).collect();
    let detections: Vec<Point2<f64>> = blobs.iter().map(|b| Point2::new(b.u, b.v)).collect();
    let denoised = extract::denoise(&frame, params.denoise);
    let view = denoised.as_ref().map_or(frame, |f| f.view());
    let recentroid = |camera: &geom::Camera| {
        observed_centroids(
            &view,
            &blobs,
            &ex.level,
            params.weighting,
            camera,
            search.illumination,
        )
    };
    let detect = |options: &Options| {
        calib::calibrate_detections(
            search.target,
            search.spheres,
            &detections,
            start,
            options,
            &search.correspond,
            &recentroid,
        )
        .with_context(context)
    };
    let mut result = detect(options)?;
    if let Some(other) = again(&result)? {
        result = detect(&other)?;
    }
    Ok((result, detections.len()))
}

/// A camera from its calibration image: markers extracted, assigned to the
/// target from the nominal camera, centroids recomputed with each camera
/// estimate (undistorted, flat-field corrected) and the camera refitted
/// ([`detect_markers`]); with `--model auto` the model the data support.
fn from_image(
    args: &Args,
    setup: &Setup,
    nominal: &NominalCamera,
    input: &Path,
    search: &MarkerSearch,
    reader: &mut FrameReader,
) -> Result<CameraFit> {
    let id = nominal.id;
    let context = || format!("camera {id} ({})", input.display());
    let nominal_path = nominal_path(args);
    let start = nominal
        .to_camera()
        .map_err(|e| anyhow::anyhow!("{}: {e}", nominal_path.display()))?;
    // The model the data support, judged on the final centroids; with k3
    // chosen, the image path again (its centroids follow the model).
    let mut choice = None;
    let mut choose = |result: &calib::ImageCalibration| -> Result<Option<Options>> {
        if !setup.choose {
            return Ok(None);
        }
        // The image path's own calibration is the lean model's.
        let (_, chosen) = calib::choose_model(
            &result.observations,
            nominal.width,
            nominal.height,
            &setup.options,
            result.calibration.clone(),
        )
        .with_context(context)?;
        let k3 = chosen.as_ref().is_some_and(|c| c.chosen.k3);
        choice = chosen;
        Ok(k3.then_some(Options {
            k3: true,
            ..setup.options
        }))
    };
    let what = context();
    let (result, detections) = detect_markers(
        search,
        &start,
        input,
        &what,
        nominal_path,
        &setup.options,
        reader,
        &mut choose,
    )?;
    let c = &result.correspondence;
    let matching = Matching::Detected {
        detections,
        matched: c.matches.len(),
        unmatched_detections: c.unmatched_detections.len(),
        missing_markers: c.missing_markers.clone(),
        assignment_sigma_px: c.sigma_px,
        corrected_centroids: calib::RECENTROID_ROUNDS,
    };
    Ok((result.observations, result.calibration, matching, choice))
}

/// A camera fitted from its input: its observations, its calibration, how
/// the markers were matched, and the model choice (`--model auto`).
type CameraFit = (
    Vec<calib::Observation>,
    Calibration,
    Matching,
    Option<calib::ModelChoice>,
);

/// A camera from its correspondence file `id,u,v`.
fn from_points(setup: &Setup, camera: &CameraSpec, input: &Path) -> Result<CameraFit> {
    let context = || format!("camera {} ({})", camera.id, input.display());
    let rows: Vec<CorrespondenceRow> = read_correspondences(input)?
        .into_iter()
        .map(|r| r.record)
        .collect();
    let obs = calib::observations(&setup.target, &rows, setup.spheres).with_context(context)?;
    let (cal, choice) = if setup.choose {
        calib::calibrate_choosing(&obs, camera.width, camera.height, &setup.options)
    } else {
        calib::calibrate(&obs, camera.width, camera.height, &setup.options).map(|c| (c, None))
    }
    .with_context(context)?;
    Ok((obs, cal, Matching::Given { points: rows.len() }, choice))
}

/// Step 4: every camera is calibrated; only now write the outputs (YAML,
/// `rig.json`, residuals, the commissioning report) and print the summary.
fn write_outputs(
    args: &Args,
    output: &mut OutputPlan,
    calibrated: Vec<Calibrated>,
    sphere_set: Vec<(String, f64)>,
) -> Result<()> {
    for c in &calibrated {
        output.write_bytes(&c.yaml.0, c.yaml.1.as_bytes())?;
        for (path, bytes) in &c.map_files {
            output.write_bytes(path, bytes)?;
        }
    }
    let mut rig = Rig {
        cameras: Vec::new(),
    };
    let mut residual_rows = Vec::new();
    let mut commissioning = Vec::new();
    for c in calibrated {
        rig.cameras.push(c.entry);
        residual_rows.extend(c.residuals);
        commissioning.push(c.commissioning);
    }
    output.write_json(&args.out, &rig)?;
    output.write_csv(&beside(&args.out, ".residuals.csv"), &residual_rows)?;
    let report = calib::commission(
        &commissioning,
        &CommissionOptions {
            travel_mm: vec![(Axis::X, args.travel_x), (Axis::Y, args.travel_y)],
            perpendicularity_tolerance_deg: args.perpendicularity_tolerance,
            alignment_tolerance_deg: args.alignment_tolerance,
            spheres: sphere_set,
            ..CommissionOptions::default()
        },
    );
    output.write_bytes(
        &beside(&args.out, ".commissioning.txt"),
        report.text().as_bytes(),
    )?;
    output.write_json(&beside(&args.out, ".commissioning.json"), &report)?;
    for c in &report.cameras {
        let scale = match (c.pixel_size_mm, c.working_distance_mm) {
            (Some(p), Some(z)) => format!("{p:.6} mm/px at {z:.1} mm, "),
            _ => String::new(),
        };
        println!(
            "camera {}: {scale}optical axis {:.3}° from {}",
            c.id, c.axis_angle_deg, c.machine_axis
        );
    }
    if report.working_point_mm.is_none() {
        println!("{}", formats::commissioning::NO_WORKING_POINT);
    }
    for w in &report.warnings {
        eprintln!("trinocular: warning: {w}");
    }
    let n = rig.cameras.len();
    println!(
        "wrote {} ({n} camera{}), OpenCV YAML, residuals and the commissioning report beside it",
        args.out.display(),
        if n == 1 { "" } else { "s" }
    );
    Ok(())
}

/// `relative_illumination` of one camera in `rig.json`: the model, and for a
/// fitted one the fit's figures and its source frames.
fn illumination_json(
    model: &Illumination,
    fit: Option<&FlatFieldFit>,
    args: &Args,
    k: usize,
) -> Result<IlluminationJson> {
    let mut j = IlluminationJson::from_model(model);
    j.record_source(
        fit,
        args.flat_fields.get(k).map(PathBuf::as_path),
        args.dark_frames.get(k).map(PathBuf::as_path),
    )?;
    Ok(j)
}

/// A `<stem>.residuals.csv` row: camera `camera`'s marker `o` (at `pose`,
/// for a calibration over views) and its residual `r`.
fn residual_row(
    camera: u8,
    pose: Option<u32>,
    o: &calib::Observation,
    r: &calib::PointResidual,
) -> ResidualRow {
    ResidualRow {
        camera,
        pose,
        id: o.id,
        x: o.world.x,
        y: o.world.y,
        z: o.world.z,
        u: o.pixel.x,
        v: o.pixel.y,
        du: r.du,
        dv: r.dv,
        outlier: r.outlier,
    }
}

/// `model_choice` of a camera in `rig.json`: the models tried, their fit
/// and held-out RMS, the F test, and the choice in words.
fn model_choice_json(c: &calib::ModelChoice) -> serde_json::Value {
    let name = |l: &calib::Layout| format!("{}{}", l.model.name(), if l.k3 { "+k3" } else { "" });
    serde_json::json!({
        "chosen": name(&c.chosen),
        "reason": c.reason,
        "f": c.f.0,
        "f_critical": c.f.1,
        "candidates": c.candidates.iter().map(|k| serde_json::json!({
            "model": name(&k.layout),
            "rms_px": k.rms_px,
            "held_out_rms_px": k.held_out_rms_px,
        })).collect::<Vec<_>>(),
    })
}

/// How camera `cal` was calibrated, as recorded in `rig.json`.
fn record(
    cal: &Calibration,
    source: &Path,
    spheres: bool,
    matching: Matching,
) -> CalibrationRecord {
    // The camera and the time from the image's own metadata (a
    // correspondence file has none; an image without tags names nothing).
    let meta = match matching {
        Matching::Detected { .. } => ingest::read_metadata(source).unwrap_or_default(),
        Matching::Given { .. } => Default::default(),
    };
    CalibrationRecord {
        model: cal.options.model.name(),
        k3_estimated: cal.options.k3,
        skew_estimated: cal.options.skew,
        sphere_markers: spheres,
        std_dev: cal
            .parameters
            .iter()
            .filter_map(|p| p.std_dev.map(|s| (p.name, s)))
            .collect(),
        sigma_px: cal.sigma_px,
        dlt_rms_px: cal.dlt_rms_px,
        outliers: cal.outliers.clone(),
        outlier_k: cal.options.outlier_k,
        source: source.display().to_string(),
        matching,
        camera_make: meta.make,
        camera_model: meta.model,
        camera_serial: meta.serial,
        captured: meta.datetime,
    }
}

/// `fx … ± …, fy …, cx …, cy … px` of a summary line: the intrinsics among
/// a camera's parameters and their standard deviations (NaN where not
/// determined).
fn intrinsics_line(parameters: &[calib::Parameter]) -> String {
    let part = |n: &str| {
        let p = parameters.iter().find(|p| p.name == n);
        format!(
            "{n} {:.2} ± {:.2}",
            p.map_or(f64::NAN, |p| p.value),
            p.and_then(|p| p.std_dev).unwrap_or(f64::NAN)
        )
    };
    format!(
        "{}, {}, {}, {} px",
        part("fx"),
        part("fy"),
        part("cx"),
        part("cy")
    )
}

/// One line per camera on stdout.
fn summarise(id: u8, cal: &Calibration, matching: &Matching) {
    let matched = match matching {
        Matching::Detected {
            detections,
            matched,
            ..
        } => format!("{matched} of {detections} detections matched, "),
        Matching::Given { .. } => String::new(),
    };
    println!(
        "camera {id}: {matched}{} points, RMS {:.4} px (DLT {:.3} px), {}, outliers {}",
        cal.points_used(),
        cal.rms_px,
        cal.dlt_rms_px,
        intrinsics_line(&cal.parameters),
        if cal.outliers.is_empty() {
            "none".to_string()
        } else {
            format!("{:?}", cal.outliers)
        }
    );
}
