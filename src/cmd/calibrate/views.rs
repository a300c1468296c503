//! `trinocular calibrate --views views.csv`: the rig from many views of the
//! target (`calib::calibrate_views`, docs/methods.md §8): any number of
//! cameras and poses, one bundle. Each row's file is an `id,u,v`
//! correspondence file of the target's markers (or a board's corners) seen
//! by that camera at that pose; the target is `--target` (3-D, or planar
//! with z = 0). With `--model auto` (the default) k3 is added for every
//! camera where the data support it (`calib::calibrate_views_choosing`). Writes, atomically, once the bundle is solved:
//! - `--out` (`rig.json`): each camera's model, its parameter covariance
//!   from the joint solution, and the views summary under `views`;
//! - `<stem>.views.csv`: per view and camera the points used, RMS and max
//!   residual, outliers;
//! - `<stem>.residuals.csv`: per point, with its pose;
//! - `<stem>.volume.csv`: the triangulation σ from the calibration alone
//!   over a grid of the poses' span (`calib::volume_uncertainty`);
//! - `<stem>.cam<ID>.opencv.yml`.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use extract::FrameReader;
use formats::{
    CameraCovariance, CorrespondenceRow, IlluminationJson, OutputPlan, Rig, RigCamera, TargetRow,
    ViewResidualRow, ViewRow, VolumeRow, read_correspondences, read_nominal, read_target,
    read_views,
};

use super::{
    Args, MarkerArg, MarkerSearch, ModelArg, beside, detect_markers, fit_options, intrinsics_line,
    model_choice_json, nominal_path, residual_row,
};
use crate::cmd::{OrUsage, Usage};

/// Extensions of the image files a views.csv row may name (others are
/// `id,u,v` correspondence files).
const IMAGE_EXTENSIONS: [&str; 6] = ["tif", "tiff", "png", "jpg", "jpeg", "gif"];

/// Points a side of the volume grid of `<stem>.volume.csv`.
const VOLUME_GRID: usize = 5;

/// The median of non-empty values.
fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Whether `path` names an image (by its extension).
fn is_image(path: &Path) -> bool {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    IMAGE_EXTENSIONS.contains(&extension.as_str())
}

/// One camera of the views: its sensor size and, with `--nominal`, its
/// nominal camera and radiometry.
struct ViewCamera {
    size: Option<(u32, u32)>,
    nominal: Option<(geom::Camera, super::Radiometry)>,
}

/// The cameras the views may name: the nominal rig's (with their
/// radiometry from `--flat-fields`/`--dark-frames`, in camera order), or
/// every camera of the rows at `--width` × `--height`.
fn view_cameras(
    args: &Args,
    rows: &[formats::Row<ViewRow>],
    reader: &mut FrameReader,
) -> Result<BTreeMap<u8, ViewCamera>> {
    if let Some(path) = &args.nominal {
        let mut nominal = read_nominal(path)?.cameras;
        nominal.sort_by_key(|c| c.id);
        for (flag, given) in [
            ("--flat-fields", &args.flat_fields),
            ("--dark-frames", &args.dark_frames),
        ] {
            if !given.is_empty() && given.len() != nominal.len() {
                return Err(Usage::error(format!(
                    "{flag}: {} files for the {} cameras of {} (one per camera, in camera order)",
                    given.len(),
                    nominal.len(),
                    path.display()
                )));
            }
        }
        let mut cameras = BTreeMap::new();
        for (k, c) in nominal.into_iter().enumerate() {
            let radiometry = super::radiometry(args, k, &c, reader)?;
            let start = c
                .to_camera()
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            cameras.insert(
                c.id,
                ViewCamera {
                    size: Some((c.width, c.height)),
                    nominal: Some((start, radiometry)),
                },
            );
        }
        return Ok(cameras);
    }
    let size = args.width.zip(args.height);
    Ok(rows
        .iter()
        .map(|r| {
            (
                r.record.camera,
                ViewCamera {
                    size,
                    nominal: None,
                },
            )
        })
        .collect())
}

/// A board's corners in one view's image, as observations of `target`; the
/// image's size recorded for its camera in `sizes` (every view of a camera
/// the same size). `Ok(Err(reason))`: the view is left out.
fn board_view(
    board: &calib::Board,
    target: &[TargetRow],
    row: &ViewRow,
    path: &Path,
    what: &str,
    reader: &mut FrameReader,
    sizes: &mut BTreeMap<u8, (u32, u32)>,
) -> Result<std::result::Result<Vec<calib::Observation>, String>> {
    let (frame, _) = match reader.read(path) {
        Ok(f) => f,
        Err(e) => return Ok(Err(format!("{what}: {e}"))),
    };
    let size = (frame.width, frame.height);
    match sizes.get(&row.camera) {
        Some(&known) if known != size => bail!(
            "{what}: the image is {}×{} px, but camera {}'s other views (or its nominal \
             camera, or --width/--height) are {}×{} px: one camera's views are one size",
            size.0,
            size.1,
            row.camera,
            known.0,
            known.1
        ),
        _ => {
            sizes.insert(row.camera, size);
        }
    }
    Ok(
        match calib::find_board(board, frame.width, frame.height, frame.pixels) {
            Ok(corners) => {
                Ok(calib::observations(target, &corners, false)
                    .with_context(|| what.to_string())?)
            }
            Err(e) => Err(format!("{what}: {e}")),
        },
    )
}

/// Run the calibration over the views of `views`.
pub fn run(args: &Args, views: &Path) -> Result<()> {
    let options = fit_options(args)?;
    let board = args
        .board
        .as_deref()
        .map(calib::Board::parse)
        .transpose()
        .or_usage()?;
    let target: Vec<TargetRow> = match &board {
        Some(b) => b.target(),
        None => read_target(super::target_path(args)?)?
            .into_iter()
            .map(|r| r.record)
            .collect(),
    };
    let spheres = board.is_none()
        && match args.markers {
            Some(m) => m == MarkerArg::Sphere,
            None => target.iter().all(|t| t.diameter.is_some()),
        };
    // Every row's file checked before any work.
    let rows = read_views(views)?;
    let context = |row: &formats::Row<ViewRow>| {
        format!(
            "{} line {}: camera {} pose {} ({})",
            views.display(),
            row.line,
            row.record.camera,
            row.record.pose,
            row.record.path(views).display()
        )
    };
    for row in &rows {
        if !row.record.path(views).is_file() {
            bail!("{}: no such file", context(row));
        }
    }
    if let Some(row) = rows.iter().find(|r| is_image(&r.record.path(views)))
        && args.nominal.is_none()
        && board.is_none()
    {
        return Err(Usage::error(format!(
            "{}: an image; finding the target's markers in it needs the rig's approximate \
             poses: give --nominal nominal.json",
            context(row)
        )));
    }
    let params = args.extract.params()?;
    let mut reader = FrameReader::new().limit_pixels(params.max_pixels);
    let cameras = view_cameras(args, &rows, &mut reader)?;
    if let Some(row) = rows
        .iter()
        .find(|r| !cameras.contains_key(&r.record.camera))
    {
        bail!(
            "{}: camera {} is not in {}",
            context(row),
            row.record.camera,
            nominal_path(args).display()
        );
    }
    let backend = args.extract.backend()?;

    let mut output = OutputPlan::new(args.force);
    output
        .inputs(&args.target)
        .inputs([views])
        .inputs(&args.nominal)
        .inputs(&args.flat_fields)
        .inputs(&args.dark_frames)
        .inputs(rows.iter().map(|r| r.record.path(views)))
        .file(&args.out)
        .file(beside(&args.out, ".views.csv"))
        .file(beside(&args.out, ".volume.csv"))
        .file(beside(&args.out, ".residuals.csv"));
    for c in cameras.keys() {
        output.file(beside(&args.out, &format!(".cam{c}.opencv.yml")));
    }
    output.check()?;

    // Each view's observations: its correspondence file, or the markers
    // found in its image; a view whose markers are not found is left out.
    let mut sizes: BTreeMap<u8, (u32, u32)> = cameras
        .iter()
        .filter_map(|(&c, v)| v.size.map(|s| (c, s)))
        .collect();
    let mut views_in = Vec::with_capacity(rows.len());
    let mut not_found = Vec::new();
    for row in &rows {
        let r = &row.record;
        let path = r.path(views);
        let what = context(row);
        let camera = &cameras[&r.camera];
        let mut leave_out = |reason: String| {
            eprintln!(
                "trinocular: note: view of camera {} at pose {} left out: {reason}",
                r.camera, r.pose
            );
            not_found.push(calib::LeftOut {
                camera: r.camera,
                pose: r.pose,
                reason,
            });
        };
        let observations = match (&board, &camera.nominal) {
            (Some(b), _) if is_image(&path) => {
                match board_view(b, &target, r, &path, &what, &mut reader, &mut sizes)? {
                    Ok(observations) => observations,
                    Err(reason) => {
                        leave_out(reason);
                        continue;
                    }
                }
            }
            (None, Some((start, radiometry))) if is_image(&path) => {
                let offset = [r.offset_x, r.offset_y, r.offset_z].map(|o| o.unwrap_or(0.0));
                let search = MarkerSearch {
                    target: &target,
                    spheres,
                    backend: backend.as_ref(),
                    params: &params,
                    illumination: &radiometry.illumination,
                    maps: radiometry.sensor.as_ref().map(|s| &s.maps),
                    // A moved target may put two markers on one line of sight.
                    correspond: calib::CorrespondOptions {
                        leave_out_ambiguous: true,
                        ..calib::CorrespondOptions::default()
                    },
                };
                match detect_markers(
                    &search,
                    &calib::seeing_moved_target(start, offset),
                    &path,
                    &what,
                    nominal_path(args),
                    &options,
                    &mut reader,
                    &mut |_| Ok(None),
                ) {
                    Ok((found, _)) => found.observations,
                    Err(e) => {
                        leave_out(format!("{e:#}"));
                        continue;
                    }
                }
            }
            _ => {
                let points: Vec<CorrespondenceRow> = read_correspondences(&path)?
                    .into_iter()
                    .map(|r| r.record)
                    .collect();
                calib::observations(&target, &points, spheres).with_context(|| what.clone())?
            }
        };
        views_in.push(calib::View {
            camera: r.camera,
            pose: r.pose,
            observations,
        });
    }
    if let Some(v) = views_in.iter().find(|v| !sizes.contains_key(&v.camera)) {
        return Err(Usage::error(format!(
            "{}: camera {}'s views are correspondence files: give the image size with --width \
             and --height (or --nominal)",
            views.display(),
            v.camera
        )));
    }
    let context = || format!("calibrating over the views of {}", views.display());
    let (mut rig, choice) = if args.model == ModelArg::Auto && !args.k3 {
        calib::calibrate_views_choosing(&views_in, &sizes, &options).with_context(context)?
    } else {
        (
            calib::calibrate_views(&views_in, &sizes, &options).with_context(context)?,
            None,
        )
    };
    if let Some(c) = &choice {
        println!("distortion model (every camera): {}", c.reason);
    }
    for l in &rig.left_out {
        eprintln!(
            "trinocular: note: view of camera {} at pose {} left out: {}",
            l.camera, l.pose, l.reason
        );
    }
    rig.left_out.extend(not_found);
    let illumination: BTreeMap<u8, IlluminationJson> = cameras
        .iter()
        .filter_map(|(&id, c)| c.nominal.as_ref().map(|(_, r)| (id, r)))
        .enumerate()
        .map(|(k, (id, r))| {
            super::illumination_json(&r.illumination, r.flat_fit.as_ref(), args, k).map(|j| (id, j))
        })
        .collect::<Result<_>>()?;
    // The triangulation σ from the calibration alone over the poses' span.
    let volume = calib::volume_uncertainty(&rig, &views_in, VOLUME_GRID);
    write(
        args,
        &mut output,
        &rig,
        &views_in,
        &volume,
        choice.as_ref(),
        &illumination,
    )?;
    // The two-halves cross-validation, with the model the whole rig has.
    let same_model = calib::Options {
        k3: rig.layout.k3,
        ..options
    };
    match calib::two_halves(&rig, &views_in, &volume, &sizes, &same_model) {
        Ok(h) => {
            let list = |p: &[u32]| p.iter().map(u32::to_string).collect::<Vec<_>>().join(" ");
            println!(
                "two halves (poses {} | {}), each calibrated alone: over {} grid points the \
                 triangulated positions differ by {:.3} µm RMS against {:.3} µm predicted by \
                 their covariances; {} of {} within twice the prediction",
                list(&h.halves[0]),
                list(&h.halves[1]),
                h.points,
                h.rms_difference_um,
                h.rms_predicted_um,
                h.within_2sigma,
                h.points
            );
            // (A floor of 0.01 µm: exact data agree to round-off.)
            if h.rms_difference_um > 2.0 * h.rms_predicted_um && h.rms_difference_um > 0.01 {
                eprintln!(
                    "trinocular: warning: the two halves of the views disagree by more than \
                     twice what their covariances predict: the calibration's uncertainty is \
                     optimistic (a lens model too lean, a target that moved or is not what \
                     target.csv says)"
                );
            }
        }
        Err(e) => eprintln!("trinocular: note: two-halves check not done: {e}"),
    }
    Ok(())
}

/// Every output of the solved rig, and the summary on stdout.
fn write(
    args: &Args,
    output: &mut OutputPlan,
    rig: &calib::Rig,
    views: &[calib::View],
    volume: &[calib::VolumePoint],
    choice: Option<&calib::ModelChoice>,
    illumination: &BTreeMap<u8, IlluminationJson>,
) -> Result<()> {
    let names: Vec<String> = rig.layout.names().iter().map(|n| n.to_string()).collect();
    let mut file = Rig {
        cameras: Vec::new(),
    };
    for c in &rig.cameras {
        let mut entry = RigCamera::new(c.id, &c.camera, c.rms_px, c.points_used);
        if let Some(j) = illumination.get(&c.id) {
            entry.relative_illumination = j.clone();
        }
        entry.covariance = c.covariance.as_ref().map(|m| CameraCovariance {
            parameters: names.clone(),
            matrix: (0..m.nrows())
                .map(|i| m.row(i).iter().copied().collect())
                .collect(),
            target: None,
            target_uncertainty_um: 0.0,
            target_uncertainty_source: "not included: the bundle over views propagates the image \
                                        noise only"
                .into(),
        });
        let std_dev: serde_json::Map<String, serde_json::Value> = c
            .parameters
            .iter()
            .filter_map(|p| p.std_dev.map(|s| (p.name.to_string(), s.into())))
            .collect();
        let camera_views: Vec<serde_json::Value> = rig
            .views
            .iter()
            .filter(|v| v.camera == c.id)
            .map(|v| {
                serde_json::json!({
                    "pose": v.pose, "points": v.points, "rms_px": v.rms_px, "max_px": v.max_px
                })
            })
            .collect();
        entry.extra.insert(
            "calibration".into(),
            serde_json::json!({
                "method": "views",
                "model": rig.layout.model.name(),
                "k3_estimated": rig.layout.k3,
                "skew_estimated": rig.layout.skew,
                "target": if rig.planar { "planar" } else { "3-D" },
                "world_pose": rig.world_pose,
                "sigma_px": c.sigma_px,
                "std_dev": std_dev,
            }),
        );
        entry
            .extra
            .insert("views".into(), serde_json::Value::Array(camera_views));
        let left_out: Vec<serde_json::Value> = rig
            .left_out
            .iter()
            .filter(|l| l.camera == c.id)
            .map(|l| serde_json::json!({"pose": l.pose, "reason": l.reason}))
            .collect();
        if !left_out.is_empty() {
            entry
                .extra
                .insert("views_left_out".into(), serde_json::Value::Array(left_out));
        }
        if let Some(c) = choice {
            entry
                .extra
                .insert("model_choice".into(), model_choice_json(c));
        }
        file.cameras.push(entry);
    }
    file.validate()
        .map_err(|e| anyhow::anyhow!("the calibrated rig cannot be written as rig.json: {e}"))?;
    let view_rows: Vec<ViewResidualRow> = rig
        .views
        .iter()
        .map(|v| ViewResidualRow {
            camera: v.camera,
            pose: v.pose,
            points: v.points,
            rms_px: v.rms_px,
            max_px: v.max_px,
            outliers: v.residuals.iter().filter(|r| r.outlier).count(),
        })
        .collect();
    let mut residual_rows = Vec::new();
    for v in &rig.views {
        let Some(input) = views
            .iter()
            .find(|i| i.camera == v.camera && i.pose == v.pose)
        else {
            continue;
        };
        residual_rows.extend(
            input
                .observations
                .iter()
                .zip(&v.residuals)
                .map(|(o, r)| residual_row(v.camera, Some(v.pose), o, r)),
        );
    }
    for c in &rig.cameras {
        output.write_bytes(
            &beside(&args.out, &format!(".cam{}.opencv.yml", c.id)),
            calib::opencv_yaml(c.id, &c.camera, c.rms_px, None).as_bytes(),
        )?;
    }
    output.write_json(&args.out, &file)?;
    output.write_csv(&beside(&args.out, ".views.csv"), &view_rows)?;
    let volume_rows: Vec<VolumeRow> = volume
        .iter()
        .map(|v| VolumeRow {
            x: v.point.x,
            y: v.point.y,
            z: v.point.z,
            cameras: v
                .cameras
                .iter()
                .map(u8::to_string)
                .collect::<Vec<_>>()
                .join("+"),
            sigma_x_um: v.sigma_um.map(|s| s.x),
            sigma_y_um: v.sigma_um.map(|s| s.y),
            sigma_z_um: v.sigma_um.map(|s| s.z),
        })
        .collect();
    output.write_csv(&beside(&args.out, ".volume.csv"), &volume_rows)?;
    let largest: Vec<f64> = volume
        .iter()
        .filter_map(|v| v.sigma_um.map(|s| s.max()))
        .collect();
    if largest.is_empty() {
        println!("triangulation σ over the volume: no grid point is seen by two cameras");
    } else {
        println!(
            "triangulation σ from the calibration over the poses' span ({} of {} grid points \
             seen by two or more cameras): largest axis σ {:.3} µm, median {:.3} µm",
            largest.len(),
            volume.len(),
            largest.iter().copied().fold(0.0, f64::max),
            median(&largest)
        );
    }
    output.write_csv(&beside(&args.out, ".residuals.csv"), &residual_rows)?;
    for c in &rig.cameras {
        let d = c.camera.distortion;
        println!(
            "camera {}: {} views, {} points, RMS {:.4} px, {}, k1 {:.5}, k2 {:.5}",
            c.id,
            c.views,
            c.points_used,
            c.rms_px,
            intrinsics_line(&c.parameters),
            d.k1,
            d.k2
        );
    }
    println!(
        "wrote {} ({} camera{}, {} poses, the world frame the target at pose {}), the views' \
         residuals and OpenCV YAML beside it",
        args.out.display(),
        rig.cameras.len(),
        if rig.cameras.len() == 1 { "" } else { "s" },
        rig.poses.len(),
        rig.world_pose
    );
    Ok(())
}
