//! `trinocular calibrate`: each camera from a 3-D target (docs/methods.md,
//! Calibration). From one calibration image per camera (markers extracted,
//! then assigned to target ids automatically from the nominal rig,
//! `calib::calibrate_detections`) or from `id,u,v` correspondence files.
//! With a flat field and a dark frame per camera, the lens's relative
//! illumination is fitted (`calib::fit_flat_field`) and stored in `rig.json`;
//! without them the ideal lens is assumed. With images, once a camera
//! estimate exists the blob centroids are recomputed with its model — over
//! undistorted pixel positions, flat-field corrected (`extract::correction`) —
//! and the camera refitted.
//! Writes, all atomically, once every camera is calibrated:
//! - `--out` (`rig.json`, docs/formats.md), with each camera's model, parameter
//!   standard deviations, outliers and DLT figures under extra keys;
//! - `<stem>.cam<ID>.opencv.yml` beside it: OpenCV `FileStorage` YAML;
//! - `<stem>.residuals.csv`: per-point residuals of every camera;
//! - `commissioning.txt` and `commissioning.json`: the rig commissioning report.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use calib::{
    Calibration, CameraInput, CommissionOptions, CorrespondOptions, FlatFieldFit, Model, Optics,
    Options,
};
use clap::ValueEnum;
use extract::{Blob, CameraMap, FrameReader, mapped_centroid};
use formats::{
    Axis, CorrespondenceRow, IlluminationJson, NominalCamera, NominalRig, OutputPlan, Rig,
    RigCamera, TargetRow, read_correspondences, read_json, read_nominal, read_spheres, read_target,
};
use geom::{Illumination, Point2};
use serde::Serialize;
use serde_json::{Value, json};

use crate::cmd::extract::ExtractOptions;
use crate::cmd::{OrUsage, Usage, values};

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
    /// Flat-field frames, one per camera in camera order: a uniform radiance
    /// source filling the view, same lens settings and exposure as the measurement.
    #[arg(long, num_args = 1.., requires = "dark_frames")]
    flat_fields: Vec<PathBuf>,
    /// Dark frames (lens capped), one per camera in camera order.
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
    #[arg(long, value_enum, default_value_t = ModelArg::K1k2p1p2)]
    model: ModelArg,
    /// Also estimate k3 (radial r⁶).
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
        f_number: key("f_number").unwrap_or(calib::DEFAULT_F_NUMBER),
        coc_px: key("coc_px").unwrap_or(calib::DEFAULT_COC_PX),
        focal_mm: key("lens_focal_mm"),
        focus_distance_mm: key("focus_distance_mm"),
    }
}

/// The relative illumination of camera `id` (index `k` in camera order):
/// fitted from its flat field and dark frame when given (model centre started
/// at the nominal image centre, ρ scaled by the nominal focal length), the
/// ideal lens otherwise.
fn illumination(
    args: &Args,
    k: usize,
    nominal: &NominalCamera,
    reader: &mut FrameReader,
) -> Result<(Illumination, Option<FlatFieldFit>)> {
    let (Some(flat), Some(dark)) = (args.flat_fields.get(k), args.dark_frames.get(k)) else {
        return Ok((Illumination::Ideal, None));
    };
    let read = |reader: &mut FrameReader, path: &Path| -> Result<(Vec<u16>, u32, u32, u16)> {
        let (f, _) = reader.read(path)?;
        if (f.width, f.height) != (nominal.width, nominal.height) {
            bail!(
                "{}: the image is {}×{} px, but camera {} is {}×{} px",
                path.display(),
                f.width,
                f.height,
                nominal.id,
                nominal.width,
                nominal.height
            );
        }
        Ok((f.pixels.to_vec(), f.width, f.height, f.max_value()))
    };
    let (f, w, h, max) = read(reader, flat)?;
    let (d, _, _, _) = read(reader, dark)?;
    let flat_pixels = calib::Pixels {
        values: &f,
        width: w,
        height: h,
        saturation: max,
    };
    let dark_pixels = calib::Pixels {
        values: &d,
        ..flat_pixels
    };
    let start = nominal
        .to_camera()
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.nominal.display()))?;
    let k = start.intrinsics;
    let fit = calib::fit_flat_field(&flat_pixels, &dark_pixels, [k.cx, k.cy], k.fx).with_context(
        || {
            format!(
                "camera {}: flat field {} with dark frame {}",
                nominal.id,
                flat.display(),
                dark.display()
            )
        },
    )?;
    Ok((Illumination::Radial(fit.model.clone()), Some(fit)))
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
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
    options.validate().or_usage()?;
    let target: Vec<TargetRow> = read_target(&args.target)?
        .into_iter()
        .map(|r| r.record)
        .collect();
    // Problems of the target are the target file's, not the first camera's.
    calib::check_target(&target).with_context(|| format!("{}", args.target.display()))?;
    let nominal: NominalRig = read_nominal(&args.nominal)?;
    let raw_nominal: Value = read_json(&args.nominal)?;
    let mut cameras = nominal.cameras.clone();
    cameras.sort_by_key(|c| c.id);
    let inputs = if args.images.is_empty() {
        &args.points
    } else {
        &args.images
    };
    if inputs.len() > cameras.len() || (!args.images.is_empty() && inputs.len() != cameras.len()) {
        return Err(Usage::error(format!(
            "{} has {} cameras but {} {} were given (one per camera, in camera order)",
            args.nominal.display(),
            cameras.len(),
            inputs.len(),
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
        if !given.is_empty() && given.len() != inputs.len() {
            return Err(Usage::error(format!(
                "{flag}: {} files for {} cameras (one per camera, in camera order)",
                given.len(),
                inputs.len()
            )));
        }
    }
    let spheres = match args.markers {
        Some(m) => m == MarkerArg::Sphere,
        None => target.iter().all(|t| t.diameter.is_some()),
    };
    if spheres && target.iter().any(|t| t.diameter.is_none()) {
        return Err(Usage::error(format!(
            "{}: --markers sphere needs a diameter for every marker",
            args.target.display()
        )));
    }
    let sphere_set = match &args.spheres {
        Some(path) => read_spheres(path)?
            .into_iter()
            .map(|r| (r.record.name, r.record.diameter))
            .collect(),
        None => CommissionOptions::default().spheres,
    };

    let extraction = if args.images.is_empty() {
        None
    } else {
        Some((args.extract.backend()?, args.extract.params()?))
    };
    let mut output = OutputPlan::new(args.force);
    output
        .inputs([&args.target, &args.nominal])
        .inputs(&args.images)
        .inputs(&args.points)
        .inputs(&args.flat_fields)
        .inputs(&args.dark_frames)
        .inputs(&args.spheres)
        .folder(formats::output::folder_of(&args.out))
        .file(&args.out)
        .file(beside(&args.out, ".residuals.csv"))
        .file(args.out.with_file_name("commissioning.txt"))
        .file(args.out.with_file_name("commissioning.json"));
    for c in cameras.iter().take(inputs.len()) {
        output.file(beside(&args.out, &format!(".cam{}.opencv.yml", c.id)));
    }
    output.check()?;
    if args.flat_fields.is_empty() {
        eprintln!(
            "trinocular: note: no flat fields given: every camera records the ideal-lens assumption \
             (cos⁴θ relative illumination, energy-conserving under distortion); measure a flat field \
             and a dark frame per camera (--flat-fields, --dark-frames) for a real lens"
        );
    }
    let mut reader = FrameReader::new().limit_pixels(args.extract.params()?.max_pixels);
    let mut yaml = Vec::new();
    let mut rig = Rig {
        cameras: Vec::new(),
    };
    let mut residual_rows = Vec::new();
    let mut commissioning = Vec::new();
    for (k, (nominal_camera, input)) in cameras.iter().zip(inputs).enumerate() {
        let id = nominal_camera.id;
        let context = || format!("camera {id} ({})", input.display());
        let start = nominal_camera
            .to_camera()
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.nominal.display()))?;
        let (illumination, flat_fit) = illumination(args, k, nominal_camera, &mut reader)?;
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
            // Centroids with a camera's model: undistorted, flat-field
            // corrected, mapped back through the distortion.
            let denoised = extract::denoise::apply(&frame, params.denoise);
            let view = denoised.as_ref().map_or(frame, |f| f.view());
            let recentroid = |camera: &geom::Camera| -> Vec<Option<Point2<f64>>> {
                let map = CameraMap::new(camera, &illumination);
                blobs
                    .iter()
                    .map(|b| {
                        mapped_centroid(&view, b, &ex.level, params.weighting, &map)
                            .map(|q| camera.distort_pixel(Point2::new(q[0], q[1])))
                    })
                    .collect()
            };
            let result = calib::calibrate_detections(
                &target,
                spheres,
                &detections,
                &start,
                &options,
                &CorrespondOptions::default(),
                &recentroid,
            )
            .with_context(context)?;
            let c = &result.correspondence;
            let info = json!({
                "detections": detections.len(),
                "matched": c.matches.len(),
                "unmatched_detections": c.unmatched_detections.len(),
                "missing_markers": c.missing_markers,
                "assignment_sigma_px": c.sigma_px,
                "corrected_centroids": calib::RECENTROID_ROUNDS,
            });
            (result.observations, result.calibration, info)
        } else {
            let rows: Vec<CorrespondenceRow> = read_correspondences(input)?
                .into_iter()
                .map(|r| r.record)
                .collect();
            let obs = calib::observations(&target, &rows, spheres).with_context(context)?;
            let cal = calib::calibrate(&obs, nominal_camera.width, nominal_camera.height, &options)
                .with_context(context)?;
            (obs, cal, json!({ "points": rows.len() }))
        };
        summarise(id, &cal, &matching);
        if let Some(fit) = &flat_fit {
            println!(
                "camera {id}: relative illumination {:.4}…{:.4} of the centre, fit residual {:.4} % RMS (noise {:.4} %)",
                fit.ri_range[0],
                fit.ri_range[1],
                100.0 * fit.residual_rms,
                100.0 * fit.noise_rms
            );
        }
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
        entry.relative_illumination = illumination_json(&illumination, flat_fit.as_ref(), args, k);
        entry.extra = extra(&cal, input, spheres, matching);
        rig.cameras.push(entry);
        commissioning.push(CameraInput {
            id,
            camera: cal.camera.clone(),
            rms_px: cal.rms_px,
            optics: Some(optics(&raw_nominal, id, nominal_camera.pixel_mm)),
            illumination,
            flat_field: flat_fit,
        });
        yaml.push((
            beside(&args.out, &format!(".cam{id}.opencv.yml")),
            calib::opencv_yaml(id, &cal.camera, cal.rms_px, None),
        ));
    }

    // Every camera is calibrated: only now write the outputs.
    for (path, text) in &yaml {
        output.write_bytes(path, text.as_bytes())?;
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
        &args.out.with_file_name("commissioning.txt"),
        report.text().as_bytes(),
    )?;
    output.write_json(&args.out.with_file_name("commissioning.json"), &report)?;
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

/// `relative_illumination` of one camera in `rig.json`: the model, and for a
/// fitted one the fit's figures and its source frames.
fn illumination_json(
    model: &Illumination,
    fit: Option<&FlatFieldFit>,
    args: &Args,
    k: usize,
) -> IlluminationJson {
    let mut j = IlluminationJson::from_model(model);
    let extra = j.extra_mut();
    match fit {
        Some(f) => {
            if let Value::Object(m) = json!(f) {
                extra.extend(m);
            }
            for (key, files) in [
                ("flat_field", &args.flat_fields),
                ("dark_frame", &args.dark_frames),
            ] {
                if let Some(p) = files.get(k) {
                    extra.insert(key.into(), json!(p.display().to_string()));
                }
            }
        }
        None => {
            extra.insert(
                "note".into(),
                json!("assumed: no flat field was given (cos⁴θ natural vignetting, energy-conserving under distortion)"),
            );
        }
    }
    j
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
