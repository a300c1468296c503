//! The 3-D calibration target: small luminous spheres on a Latin-square
//! lattice (non-coplanar; no two aligned along X, Y or Z, so none overlap in
//! any of the three cameras), rendered once per camera.
//!
//! Files: `target.csv` (id, x, y, z, diameter; target frame = world frame),
//! `calib/cam{k}.tif` and `calib/points_cam{k}.csv` (id, u, v: the exact
//! observed image of each marker centre through the full true camera model, for
//! calibration from correspondences), and per camera the radiometric frames a
//! user captures beside the target: `calib/flat_cam{k}.tif` (a uniform
//! radiance source filling the view) and `calib/dark_cam{k}.tif` (lens capped);
//! with `[sensor] calibration_frames = N > 1`, stacks of N frames in the
//! folders `calib/flat_cam{k}/` and `calib/dark_cam{k}/`
//! (`flat_001.tif` … and `dark_001.tif` …).
//!
//! With further placements (`[target] poses_mm`), the target moved by the
//! machine: per pose p ≥ 1 and camera `calib/views/pose{p}_cam{k}.*` and
//! `calib/views/points_pose{p}_cam{k}.csv` (the markers whose image lies
//! inside the frame), and `calib/views.csv` (`image,camera,pose` with the
//! move as `offset_x,offset_y,offset_z`; pose 0 is `calib/cam{k}.*`) and
//! `calib/views_points.csv` (the same views by their correspondence files).

use std::path::Path;

use formats::{CorrespondenceRow, OutputPlan, TargetRow, ViewRow};
use geom::nalgebra::{Point3, Vector3};

use crate::config::{Config, TargetConfig};
use crate::encode::{FrameMetadata, write_image_into};
use crate::rig::{SynthCamera, SynthRig};
use crate::scene::{Sphere, frame_clearance_px};
use crate::sensor::{Image16, NoiseKey};
use crate::{Result, SynthError};

/// Frame number of the calibration images in noise keys (campaign frames count from 0).
pub(crate) const CALIBRATION_FRAME: u64 = u64::MAX;

/// One marker of the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker {
    /// Marker id (row-major over the lattice, from 1).
    pub id: u32,
    /// Centre, world frame (mm).
    pub centre: Point3<f64>,
    /// Diameter (mm).
    pub diameter: f64,
}

/// Purpose tag of the target's jitter (see `sensor::chacha_key`).
const JITTER_PURPOSE: u64 = 3;

/// Fixed pseudo-random jitter of marker `id`: each component uniform in [−1, 1).
fn jitter(id: u32) -> [f64; 3] {
    let key = crate::sensor::chacha_key(JITTER_PURPOSE, &[u64::from(id)]);
    [0, 1, 2].map(|i| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&key[8 * i..8 * i + 8]);
        (u64::from_le_bytes(b) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    })
}

/// The markers of a target configuration: marker (i, j) at
/// `centre + (sx·(i − c), sy·(j − c), 0) + depth_step·(((2i + 3j) mod n) − c)·ẑ`
/// plus its fixed jitter of up to `jitter_mm` per axis.
pub fn markers(t: &TargetConfig) -> Vec<Marker> {
    let n = t.grid;
    let c = (f64::from(n) - 1.0) / 2.0;
    let mut out = Vec::with_capacity((n * n) as usize);
    for i in 0..n {
        for j in 0..n {
            let k = (2 * i + 3 * j) % n;
            let id = i * n + j + 1;
            let [jx, jy, jz] = jitter(id).map(|v| v * t.jitter_mm);
            out.push(Marker {
                id,
                centre: Point3::new(
                    t.centre[0] + t.spacing_mm[0] * (f64::from(i) - c) + jx,
                    t.centre[1] + t.spacing_mm[1] * (f64::from(j) - c) + jy,
                    t.centre[2] + t.depth_step_mm * (f64::from(k) - c) + jz,
                ),
                diameter: t.marker_diameter_mm,
            });
        }
    }
    out
}

/// `target.csv` rows.
pub(crate) fn target_rows(markers: &[Marker]) -> Vec<TargetRow> {
    markers
        .iter()
        .map(|m| TargetRow {
            id: m.id,
            x: m.centre.x,
            y: m.centre.y,
            z: m.centre.z,
            diameter: Some(m.diameter),
            u_mm: None,
        })
        .collect()
}

/// The markers as spheres for the renderer.
pub fn marker_spheres(markers: &[Marker], radiance_e: f64) -> Vec<Sphere> {
    markers
        .iter()
        .map(|m| Sphere {
            centre: m.centre,
            radius: m.diameter / 2.0,
            radiance_e,
        })
        .collect()
}

/// Exact observed image of each marker centre in one camera (full model).
pub(crate) fn correspondences(
    cam: &SynthCamera,
    markers: &[Marker],
) -> Result<Vec<CorrespondenceRow>> {
    markers
        .iter()
        .map(|m| {
            let p = cam
                .camera
                .project(&m.centre)
                .map_err(|e| SynthError::geometry(format!("projecting marker {}", m.id), e))?;
            Ok(CorrespondenceRow {
                id: m.id,
                u: p.x,
                v: p.y,
            })
        })
        .collect()
}

/// The target's placements: pose 0 at home, then pose p moved by
/// `poses_mm[p − 1]` (the machine's move, mm).
pub(crate) fn poses(t: &TargetConfig) -> Vec<(u32, Vector3<f64>)> {
    std::iter::once([0.0; 3])
        .chain(t.poses_mm.iter().copied())
        .zip(0..)
        .map(|(m, p)| (p, Vector3::from(m)))
        .collect()
}

/// The markers of the target moved by `offset` (mm).
fn moved(markers: &[Marker], offset: &Vector3<f64>) -> Vec<Marker> {
    markers
        .iter()
        .map(|m| Marker {
            centre: m.centre + offset,
            ..*m
        })
        .collect()
}

/// Render the target once in one camera.
pub fn render_target(cam: &SynthCamera, config: &Config) -> Result<Image16> {
    render_target_at(cam, config, 0, &Vector3::zeros())
}

/// Render the target at pose `pose`, moved by `offset`, in one camera (the
/// noise of each pose its own).
fn render_target_at(
    cam: &SynthCamera,
    config: &Config,
    pose: u32,
    offset: &Vector3<f64>,
) -> Result<Image16> {
    let m = moved(&markers(&config.target), offset);
    cam.render(
        &marker_spheres(&m, config.target.radiance_e),
        NoiseKey {
            seed: config.seed,
            frame: match pose {
                0 => CALIBRATION_FRAME,
                p => crate::rig::stack_frame(crate::rig::TARGET_POSE_FRAME, p - 1),
            },
            camera: cam.id,
        },
        config.render.max_depth,
    )
}

/// Least clearance (px) of a marker's outline from the frame's edge for it
/// to be listed in a view's exact correspondences.
const VIEW_CLEARANCE_PX: f64 = 2.0;

/// Relative path of camera `id`'s view of pose `pose` ≥ 1 (`what`: "pose"
/// for the image, "points_pose" for its correspondence file).
fn view_path(what: &str, pose: u32, id: u8, ext: &str) -> String {
    format!("calib/views/{what}{pose}_cam{id}.{ext}")
}

/// The rows of `calib/views.csv` (`points`: of `calib/views_points.csv`),
/// paths relative to `calib/`.
fn view_rows(config: &Config, rig: &SynthRig, points: bool) -> Vec<ViewRow> {
    let ext = config.output.format.extension();
    poses(&config.target)
        .into_iter()
        .flat_map(|(pose, offset)| {
            rig.cameras.iter().map(move |cam| {
                let path = match (pose, points) {
                    (0, false) => CalibrationKind::Target.path(config, cam.id, 0),
                    (0, true) => format!("calib/points_cam{}.csv", cam.id),
                    (_, false) => view_path("pose", pose, cam.id, ext),
                    (_, true) => view_path("points_pose", pose, cam.id, "csv"),
                };
                ViewRow {
                    image: path.trim_start_matches("calib/").to_string(),
                    camera: cam.id,
                    pose,
                    offset_x: Some(offset.x),
                    offset_y: Some(offset.y),
                    offset_z: Some(offset.z),
                }
            })
        })
        .collect()
}

/// One kind of calibration frame of a camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CalibrationKind {
    Target,
    FlatField,
    DarkFrame,
}

impl CalibrationKind {
    const ALL: [Self; 3] = [Self::Target, Self::FlatField, Self::DarkFrame];

    /// File stem (`calib/{stem}{k}.ext` or the stack folder `calib/{stem}{k}/`).
    fn stem(self) -> &'static str {
        match self {
            Self::Target => "cam",
            Self::FlatField => "flat_cam",
            Self::DarkFrame => "dark_cam",
        }
    }

    /// Name of a stack's frames (`{prefix}_{i}.ext`).
    fn prefix(self) -> &'static str {
        match self {
            Self::Target => "cam",
            Self::FlatField => "flat",
            Self::DarkFrame => "dark",
        }
    }

    fn what(self) -> &'static str {
        match self {
            Self::Target => "calibration target",
            Self::FlatField => "flat field",
            Self::DarkFrame => "dark frame",
        }
    }

    /// Frames of this kind per camera: the target once, flats and darks
    /// `[sensor] calibration_frames` times.
    fn frames(self, config: &Config) -> u32 {
        match self {
            Self::Target => 1,
            _ => config.sensor.calibration_frames,
        }
    }

    /// The stack folder of camera `id` when the kind is written as a stack.
    fn folder(self, config: &Config, id: u8) -> Option<String> {
        (self.frames(config) > 1).then(|| format!("calib/{}{id}", self.stem()))
    }

    /// Relative path of frame `index` (0-based) of camera `id`.
    fn path(self, config: &Config, id: u8, index: u32) -> String {
        let ext = config.output.format.extension();
        let n = self.frames(config);
        match self.folder(config, id) {
            None => format!("calib/{}{id}.{ext}", self.stem()),
            Some(dir) => {
                let width = n.to_string().len().max(3);
                format!("{dir}/{}_{:0width$}.{ext}", self.prefix(), index + 1)
            }
        }
    }
}

/// The stack folders [`write_target_files`] writes into, relative to the
/// output folder (none with one flat and one dark per camera).
pub(crate) fn target_folders(config: &Config, rig: &SynthRig) -> Vec<String> {
    let mut folders: Vec<String> = rig
        .cameras
        .iter()
        .flat_map(|cam| {
            CalibrationKind::ALL
                .iter()
                .filter_map(|kind| kind.folder(config, cam.id))
        })
        .collect();
    if !config.target.poses_mm.is_empty() {
        folders.push("calib/views".into());
    }
    folders
}

/// The files [`write_target_files`] writes, relative to the output folder:
/// `target.csv`, then per camera its calibration frames and `calib/points_cam{k}.csv`.
pub(crate) fn target_files(config: &Config, rig: &SynthRig) -> Vec<String> {
    let mut files = vec!["target.csv".to_string()];
    for cam in &rig.cameras {
        for kind in CalibrationKind::ALL {
            for i in 0..kind.frames(config) {
                files.push(kind.path(config, cam.id, i));
            }
        }
        files.push(format!("calib/points_cam{}.csv", cam.id));
    }
    if !config.target.poses_mm.is_empty() {
        let ext = config.output.format.extension();
        for (pose, _) in poses(&config.target).into_iter().skip(1) {
            for cam in &rig.cameras {
                files.push(view_path("pose", pose, cam.id, ext));
                files.push(view_path("points_pose", pose, cam.id, "csv"));
            }
        }
        files.push("calib/views.csv".into());
        files.push("calib/views_points.csv".into());
    }
    files
}

/// Render frame `index` of a calibration kind in one camera.
fn render_calibration(
    kind: CalibrationKind,
    cam: &SynthCamera,
    config: &Config,
    index: u32,
) -> Result<Image16> {
    Ok(match kind {
        CalibrationKind::Target => render_target(cam, config)?,
        CalibrationKind::FlatField => cam.flat_field_at(config.seed, index),
        CalibrationKind::DarkFrame => cam.dark_frame_at(config.seed, index),
    })
}

/// Write `target.csv` and, per camera, `calib/cam{k}.{ext}`, its flat
/// field(s) and dark frame(s) (one each, or stacks) and
/// `calib/points_cam{k}.csv` under `out`, through `output`, where
/// [`target_files`], [`target_folders`] and the folder `calib` are planned.
/// Frame i of a stack is stamped i/fps after the first. Returns the image
/// paths (relative).
pub(crate) fn write_target_files(
    config: &Config,
    rig: &SynthRig,
    out: &Path,
    time_s: f64,
    output: &OutputPlan,
) -> Result<Vec<String>> {
    let m = markers(&config.target);
    output.write_csv(&out.join("target.csv"), &target_rows(&m))?;
    let mut paths = Vec::new();
    for cam in &rig.cameras {
        for kind in CalibrationKind::ALL {
            let n = kind.frames(config);
            for i in 0..n {
                let img = render_calibration(kind, cam, config, i)?;
                let rel = kind.path(config, cam.id, i);
                let stack = if n > 1 {
                    format!(" {}/{n}", i + 1)
                } else {
                    String::new()
                };
                write_calibration_frame(
                    config,
                    cam,
                    &img,
                    &out.join(&rel),
                    time_s + f64::from(i) / config.procedure.fps,
                    format!("{}{stack}, camera {}", kind.what(), cam.id),
                    output,
                )?;
                paths.push(rel);
            }
        }
        output.write_csv(
            &out.join(format!("calib/points_cam{}.csv", cam.id)),
            &correspondences(cam, &m)?,
        )?;
    }
    if !config.target.poses_mm.is_empty() {
        paths.extend(write_views(config, rig, out, time_s, output)?);
    }
    Ok(paths)
}

/// Write one calibration frame of camera `cam` at `path` (its EXIF: the
/// configuration's camera, lens and exposure, `time_s`, `description`).
pub(crate) fn write_calibration_frame(
    config: &Config,
    cam: &SynthCamera,
    img: &Image16,
    path: &Path,
    time_s: f64,
    description: String,
    output: &OutputPlan,
) -> Result<()> {
    let meta = FrameMetadata {
        make: config.output.make.clone(),
        model: config.output.model.clone(),
        serial: cam.serial.clone(),
        time_s,
        exposure_s: config.sensor.exposure_s,
        f_number: config.optics.f_number,
        focal_mm: config.optics.focal_mm,
        description,
    };
    write_image_into(
        output.create(path)?,
        img,
        config.sensor.bits,
        &meta,
        config.output.format,
        config.output.compression,
    )
}

/// Seconds between two placements of the target (the machine moving it).
const POSE_INTERVAL_S: f64 = 60.0;

/// The target at every further pose in every camera (images and the exact
/// images of the markers inside the frame), and `calib/views.csv` and
/// `calib/views_points.csv`. Returns the image paths (relative).
fn write_views(
    config: &Config,
    rig: &SynthRig,
    out: &Path,
    time_s: f64,
    output: &OutputPlan,
) -> Result<Vec<String>> {
    let ext = config.output.format.extension();
    let home = markers(&config.target);
    let mut paths = Vec::new();
    for (pose, offset) in poses(&config.target).into_iter().skip(1) {
        let m = moved(&home, &offset);
        for cam in &rig.cameras {
            let img = render_target_at(cam, config, pose, &offset)?;
            let rel = view_path("pose", pose, cam.id, ext);
            write_calibration_frame(
                config,
                cam,
                &img,
                &out.join(&rel),
                time_s + POSE_INTERVAL_S * f64::from(pose),
                format!("calibration target at pose {pose}, camera {}", cam.id),
                output,
            )?;
            paths.push(rel);
            // The markers whose whole outline lies inside the frame.
            let seen: Vec<Marker> = m
                .iter()
                .zip(marker_spheres(&m, config.target.radiance_e))
                .filter(|(_, s)| {
                    frame_clearance_px(&cam.camera, s).is_ok_and(|c| c >= VIEW_CLEARANCE_PX)
                })
                .map(|(k, _)| *k)
                .collect();
            output.write_csv(
                &out.join(view_path("points_pose", pose, cam.id, "csv")),
                &correspondences(cam, &seen)?,
            )?;
        }
    }
    output.write_csv(&out.join("calib/views.csv"), &view_rows(config, rig, false))?;
    output.write_csv(
        &out.join("calib/views_points.csv"),
        &view_rows(config, rig, true),
    )?;
    Ok(paths)
}
