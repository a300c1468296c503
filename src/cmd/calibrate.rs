//! `trinocular calibrate`: each camera from a 3-D target (METHODS.md §1,
//! Calibration). From one calibration image per camera (markers extracted,
//! then assigned to target ids automatically from the nominal rig) or from
//! `id,u,v` correspondence files. With images, once a distortion estimate
//! exists the blob centroids are recomputed over undistorted pixel positions
//! (area-Jacobian weights, `extract::mapped_centroid`) and the camera refitted.
//! Writes, all atomically, once every camera is calibrated:
//! - `--out` (`rig.json`, INTERFACES.md), with each camera's model, parameter
//!   standard deviations, outliers and DLT figures under extra keys;
//! - `<stem>.cam<ID>.opencv.yml` beside it: OpenCV `FileStorage` YAML;
//! - `<stem>.residuals.csv`: per-point residuals of every camera;
//! - `commissioning.txt` and `commissioning.json`: the rig commissioning report.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use calib::commission::{CameraInput, CommissionOptions, Optics};
use calib::{Calibration, CorrespondOptions, Model, Observation, Options};
use clap::ValueEnum;
use extract::{Blob, FrameReader, PixelMap, mapped_centroid};
use formats::{
    CorrespondenceRow, NominalRig, Rig, RigCamera, TargetRow, read_csv, read_json, write_json,
};
use geom::{Camera, Point2};
use serde::Serialize;
use serde_json::{Value, json};

use crate::cmd::extract::ExtractOptions;

/// Distortion model (`--model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModelArg {
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
#[command(group(clap::ArgGroup::new("input").required(true).args(["images", "points"])))]
pub struct Args {
    /// Calibration target `target.csv` (`id,x,y,z[,diameter]`, mm).
    #[arg(long)]
    target: PathBuf,
    /// Nominal rig `nominal.json`: starts the calibration and finds the correspondences.
    #[arg(long)]
    nominal: PathBuf,
    /// One calibration image per camera, in camera order (the nominal rig's ids, ascending).
    #[arg(long, num_args = 1..)]
    images: Vec<PathBuf>,
    /// Correspondence files `id,u,v`, one per camera in camera order, instead of images.
    #[arg(long, num_args = 1..)]
    points: Vec<PathBuf>,
    /// Output `rig.json`; the other outputs go beside it.
    #[arg(long)]
    out: PathBuf,
    /// Distortion model.
    #[arg(long, value_enum, default_value_t = ModelArg::K1k2p1p2)]
    model: ModelArg,
    /// Also estimate k3 (radial r⁶).
    #[arg(long)]
    k3: bool,
    /// Also estimate the skew.
    #[arg(long)]
    skew: bool,
    /// Reject points whose residual exceeds k·σ (robust σ) and refit.
    #[arg(long, default_value_t = calib::calibration::DEFAULT_OUTLIER_K)]
    outlier_k: f64,
    /// Keep every point (no outlier rejection).
    #[arg(long)]
    keep_outliers: bool,
    /// Marker type; default: spheres when target.csv gives diameters.
    #[arg(long, value_enum)]
    markers: Option<MarkerArg>,
    /// X travel (mm) through the working point checked by the commissioning report.
    #[arg(long, default_value_t = 150.0)]
    travel_x: f64,
    /// Y travel (mm) checked by the commissioning report.
    #[arg(long, default_value_t = 100.0)]
    travel_y: f64,
    /// Largest deviation from 90° between optical axes before a warning (deg).
    #[arg(long, default_value_t = 1.0)]
    perpendicularity_tolerance: f64,
    /// Largest angle between an optical axis and its machine axis before a warning (deg).
    #[arg(long, default_value_t = 1.0)]
    alignment_tolerance: f64,
    #[command(flatten)]
    extract: ExtractOptions,
}

/// One row of `<stem>.residuals.csv`.
#[derive(Debug, Serialize)]
struct ResidualRow {
    camera: u8,
    id: u32,
    x: f64,
    y: f64,
    z: f64,
    u: f64,
    v: f64,
    du: f64,
    dv: f64,
    outlier: bool,
}

/// A file beside `out` named `<stem><suffix>`.
fn beside(out: &Path, suffix: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(|| "rig".into(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}{suffix}"))
}

/// Optics for the depth of field: pixel pitch from nominal.json, and the
/// optional keys `f_number`, `coc_px`, `lens_focal_mm`, `focus_distance_mm`
/// of its camera entry (defaults: f/8, 2 px, focal length from the lens
/// equation, focus at the working point).
fn optics(raw: &Value, id: u8, pixel_mm: f64) -> Optics {
    let entry = raw["cameras"]
        .as_array()
        .and_then(|a| a.iter().find(|c| c["id"].as_u64() == Some(u64::from(id))));
    let key = |k: &str| {
        entry
            .and_then(|e| e[k].as_f64())
            .filter(|v| v.is_finite() && *v > 0.0)
    };
    Optics {
        pixel_mm,
        f_number: key("f_number").unwrap_or(calib::commission::DEFAULT_F_NUMBER),
        coc_px: key("coc_px").unwrap_or(calib::commission::DEFAULT_COC_PX),
        focal_mm: key("lens_focal_mm"),
        focus_distance_mm: key("focus_distance_mm"),
    }
}

/// Rounds of re-centroiding over undistorted pixel positions and refitting.
const UNDISTORTED_ROUNDS: usize = 2;

/// Observed pixel → ideal pixel with the area Jacobian, for [`mapped_centroid`].
struct Undistortion<'a>(&'a Camera);

impl PixelMap for Undistortion<'_> {
    fn map(&self, u: f64, v: f64) -> Option<([f64; 2], f64)> {
        let (p, area) = self.0.undistort_pixel_area(Point2::new(u, v)).ok()?;
        Some(([p.x, p.y], area))
    }
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let target: Vec<TargetRow> = read_csv(&args.target)?
        .into_iter()
        .map(|r| r.record)
        .collect();
    let nominal: NominalRig = read_json(&args.nominal)?;
    let raw_nominal: Value = read_json(&args.nominal)?;
    let mut cameras = nominal.cameras.clone();
    cameras.sort_by_key(|c| c.id);
    let inputs = if args.images.is_empty() {
        &args.points
    } else {
        &args.images
    };
    if inputs.len() > cameras.len() || (!args.images.is_empty() && inputs.len() != cameras.len()) {
        bail!(
            "{} has {} cameras but {} {} were given (one per camera, in camera order)",
            args.nominal.display(),
            cameras.len(),
            inputs.len(),
            if args.images.is_empty() {
                "correspondence files"
            } else {
                "images"
            }
        );
    }
    let spheres = match args.markers {
        Some(m) => m == MarkerArg::Sphere,
        None => target.iter().all(|t| t.diameter.is_some()),
    };
    if spheres && target.iter().any(|t| t.diameter.is_none()) {
        bail!(
            "{}: --markers sphere needs a diameter for every marker",
            args.target.display()
        );
    }
    let options = Options {
        model: match args.model {
            ModelArg::Pinhole => Model::Pinhole,
            ModelArg::K1k2 => Model::K1K2,
            ModelArg::K1k2p1p2 => Model::K1K2P1P2,
        },
        k3: args.k3,
        skew: args.skew,
        outlier_k: (!args.keep_outliers).then_some(args.outlier_k),
        ..Options::default()
    };
    options.validate()?;
    let markers = calib::markers(&target);
    let by_id: HashMap<u32, &TargetRow> = target.iter().map(|t| (t.id, t)).collect();

    let extraction = if args.images.is_empty() {
        None
    } else {
        Some((args.extract.backend()?, args.extract.params()?))
    };
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    }
    let mut reader = FrameReader::new();
    let mut yaml = Vec::new();
    let mut rig = Rig {
        cameras: Vec::new(),
    };
    let mut residual_rows = Vec::new();
    let mut commissioning = Vec::new();
    for (nominal_camera, input) in cameras.iter().zip(inputs) {
        let id = nominal_camera.id;
        let context = || format!("camera {id} ({})", input.display());
        let start = nominal_camera
            .to_camera()
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.nominal.display()))?;
        let calibrate = |obs: &[Observation]| {
            calib::calibrate(obs, nominal_camera.width, nominal_camera.height, &options)
                .with_context(context)
        };
        let (observations, cal, matching) = if let Some((backend, params)) = &extraction {
            let (frame, _) = reader.read(input).with_context(context)?;
            if frame.width != nominal_camera.width || frame.height != nominal_camera.height {
                bail!(
                    "{}: the image is {}×{} px, but {} gives this camera {}×{} px",
                    context(),
                    frame.width,
                    frame.height,
                    args.nominal.display(),
                    nominal_camera.width,
                    nominal_camera.height
                );
            }
            let ex = backend.extract(frame, params).with_context(context)?;
            let blobs: Vec<&Blob> = ex.blobs.iter().filter(|b| !b.touches_border).collect();
            let detections: Vec<Point2<f64>> =
                blobs.iter().map(|b| Point2::new(b.u, b.v)).collect();
            let c = calib::correspond(&markers, &detections, &start, &CorrespondOptions::default())
                .with_context(context)?;
            let observe = |pixels: &[Point2<f64>]| -> Vec<Observation> {
                c.matches
                    .iter()
                    .filter_map(|m| {
                        by_id.get(&m.id).map(|t| Observation {
                            id: m.id,
                            world: geom::Point3::new(t.x, t.y, t.z),
                            pixel: pixels[m.detection],
                            sphere_diameter: if spheres { t.diameter } else { None },
                        })
                    })
                    .collect()
            };
            let mut obs = observe(&detections);
            let mut cal = calibrate(&obs)?;
            // Centroids over undistorted pixel positions (METHODS.md §1): each
            // blob's light re-weighted by the area Jacobian of the estimated
            // undistortion, its centroid mapped back through the distortion; refit.
            let denoised = extract::denoise::apply(&frame, params.denoise);
            let view = denoised.as_ref().map_or(frame, |f| f.view());
            if !cal.camera.distortion.is_none() {
                for _ in 0..UNDISTORTED_ROUNDS {
                    let map = Undistortion(&cal.camera);
                    let pixels: Vec<Point2<f64>> = blobs
                        .iter()
                        .zip(&detections)
                        .map(|(b, d)| {
                            mapped_centroid(&view, b, &ex.level, params.weighting, &map)
                                .map_or(*d, |q| cal.camera.distort_pixel(Point2::new(q[0], q[1])))
                        })
                        .collect();
                    obs = observe(&pixels);
                    cal = calibrate(&obs)?;
                }
            }
            let info = json!({
                "detections": detections.len(),
                "matched": c.matches.len(),
                "unmatched_detections": c.unmatched_detections.len(),
                "missing_markers": c.missing_markers,
                "assignment_sigma_px": c.sigma_px,
                "undistorted_centroids": !cal.camera.distortion.is_none(),
            });
            (obs, cal, info)
        } else {
            let rows: Vec<CorrespondenceRow> =
                read_csv(input)?.into_iter().map(|r| r.record).collect();
            let obs = calib::observations(&target, &rows, spheres).with_context(context)?;
            let cal = calibrate(&obs)?;
            (obs, cal, json!({ "points": rows.len() }))
        };
        summarise(id, &cal, &matching);
        for (o, r) in observations.iter().zip(&cal.residuals) {
            residual_rows.push(ResidualRow {
                camera: id,
                id: o.id,
                x: o.world.x,
                y: o.world.y,
                z: o.world.z,
                u: o.pixel.x,
                v: o.pixel.y,
                du: r.du,
                dv: r.dv,
                outlier: r.outlier,
            });
        }
        let mut entry = RigCamera::new(id, &cal.camera, cal.rms_px, cal.points_used());
        entry.extra = extra(&cal, input, spheres, matching);
        rig.cameras.push(entry);
        commissioning.push(CameraInput {
            id,
            camera: cal.camera.clone(),
            rms_px: cal.rms_px,
            optics: Some(optics(&raw_nominal, id, nominal_camera.pixel_mm)),
        });
        yaml.push((
            beside(&args.out, &format!(".cam{id}.opencv.yml")),
            calib::opencv_yaml(id, &cal.camera, cal.rms_px, None),
        ));
    }

    // Every camera is calibrated: only now write the outputs.
    for (path, text) in &yaml {
        formats::write_atomic(path, text.as_bytes())?;
    }

    write_json(&args.out, &rig)?;
    formats::write_csv(&beside(&args.out, ".residuals.csv"), &residual_rows)?;
    let report = calib::commission(
        &commissioning,
        &CommissionOptions {
            travel_mm: vec![('X', args.travel_x), ('Y', args.travel_y)],
            perpendicularity_tolerance_deg: args.perpendicularity_tolerance,
            alignment_tolerance_deg: args.alignment_tolerance,
            ..CommissionOptions::default()
        },
    );
    formats::write_atomic(
        args.out.with_file_name("commissioning.txt"),
        report.text().as_bytes(),
    )?;
    write_json(&args.out.with_file_name("commissioning.json"), &report)?;
    for c in &report.cameras {
        println!(
            "camera {}: {:.6} mm/px at {:.1} mm, optical axis {:.3}° from {}",
            c.id, c.pixel_size_mm, c.working_distance_mm, c.axis_angle_deg, c.machine_axis
        );
    }
    for w in &report.warnings {
        eprintln!("trinocular: warning: {w}");
    }
    println!(
        "wrote {} ({} cameras), OpenCV YAML, residuals and the commissioning report beside it",
        args.out.display(),
        rig.cameras.len()
    );
    Ok(())
}

/// The extra `rig.json` keys of one camera.
fn extra(
    cal: &Calibration,
    source: &Path,
    spheres: bool,
    matching: Value,
) -> serde_json::Map<String, Value> {
    let std: serde_json::Map<String, Value> = cal
        .parameters
        .iter()
        .filter_map(|p| p.std_dev.map(|s| (p.name.to_string(), json!(s))))
        .collect();
    let mut m = serde_json::Map::new();
    m.insert("model".into(), json!(cal.options.model.name()));
    m.insert("k3_estimated".into(), json!(cal.options.k3));
    m.insert("skew_estimated".into(), json!(cal.options.skew));
    m.insert("sphere_markers".into(), json!(spheres));
    m.insert("std_dev".into(), Value::Object(std));
    m.insert("sigma_px".into(), json!(cal.sigma_px));
    m.insert("dlt_rms_px".into(), json!(cal.dlt_rms_px));
    m.insert("outliers".into(), json!(cal.outliers));
    m.insert("outlier_k".into(), json!(cal.options.outlier_k));
    m.insert("source".into(), json!(source.display().to_string()));
    m.insert("matching".into(), matching);
    m
}

/// One line per camera on stdout.
fn summarise(id: u8, cal: &Calibration, matching: &Value) {
    let k = cal.camera.intrinsics;
    let sd = |n: &str| cal.parameter(n).and_then(|p| p.std_dev).unwrap_or(f64::NAN);
    let matched = matching["matched"]
        .as_u64()
        .map(|m| format!("{m} of {} detections matched, ", matching["detections"]))
        .unwrap_or_default();
    println!(
        "camera {id}: {matched}{} points, RMS {:.4} px (DLT {:.3} px), fx {:.2} ± {:.2}, fy {:.2} ± {:.2}, \
         cx {:.2} ± {:.2}, cy {:.2} ± {:.2} px, outliers {}",
        cal.points_used(),
        cal.rms_px,
        cal.dlt_rms_px,
        k.fx,
        sd("fx"),
        k.fy,
        sd("fy"),
        k.cx,
        sd("cx"),
        k.cy,
        sd("cy"),
        if cal.outliers.is_empty() {
            "none".to_string()
        } else {
            format!("{:?}", cal.outliers)
        }
    );
}
