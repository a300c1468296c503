//! Writing a campaign (docs/formats.md, `trinocular synth campaign`): images,
//! `manifest.csv`, `spheres.csv`, `nominal.json`, `target.csv`, calibration
//! images (target, flat field and dark frame per camera), `truth.json`,
//! `truth_points.csv` and the effective `config.toml`.
//!
//! Streams: instants are rendered in parallel in bounded batches, each image
//! written atomically as soon as it is encoded; only the plan (a few hundred
//! bytes per instant) is held in memory. The manifest and truth are written
//! last, so a complete `manifest.csv` means a complete campaign.
//!
//! Every file is planned in a `formats::OutputPlan` and checked before the
//! first is written (an existing campaign is replaced only with `--force`);
//! the output folder is locked while the campaign is written.

use std::collections::BTreeSet;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use formats::{ManifestRow, OutputPlan, SphereRow};
use rayon::prelude::*;

use crate::config::Config;
use crate::encode::{FrameMetadata, write_image_into};
use crate::procedure::{Instant, Plan};
use crate::progress::Progress;
use crate::rig::SynthRig;
use crate::scene::{frame_clearance_px, separation_px};
use crate::sensor::NoiseKey;
use crate::{Result, SynthError};

/// Instants rendered per batch and thread (bounds the frames in memory).
const BATCH_PER_THREAD: usize = 2;

/// Worst-case geometry of a campaign's scenes, from the analytic silhouettes.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneCheck {
    /// Smallest distance (px) of any sphere's outline from any image border
    /// (negative: a sphere leaves a frame).
    pub min_frame_clearance_px: f64,
    /// Where it occurs.
    pub worst_frame: String,
    /// Smallest gap (px) between two spheres' silhouettes in any camera
    /// (negative: they overlap).
    pub min_separation_px: f64,
    /// Where it occurs.
    pub worst_separation: String,
}

/// Check every instant in every camera: frame clearance and separations.
pub fn check_plan(rig: &SynthRig, plan: &Plan) -> Result<SceneCheck> {
    let per_instant = plan
        .instants
        .par_iter()
        .map(|i| -> Result<(f64, String, f64, String)> {
            let spheres = plan.spheres_at(i);
            let mut best = (f64::INFINITY, String::new(), f64::INFINITY, String::new());
            for cam in &rig.cameras {
                for (k, s) in spheres.iter().enumerate() {
                    let c = frame_clearance_px(&cam.camera, s)?;
                    if c < best.0 {
                        best.0 = c;
                        best.1 = format!(
                            "sphere {} in camera {} at instant {}",
                            plan.spheres[k].name,
                            cam.id,
                            describe(i)
                        );
                    }
                    for (l, t) in spheres.iter().enumerate().skip(k + 1) {
                        let d = separation_px(&cam.camera, s, t)?;
                        if d < best.2 {
                            best.2 = d;
                            best.3 = format!(
                                "spheres {} and {} in camera {} at instant {}",
                                plan.spheres[k].name,
                                plan.spheres[l].name,
                                cam.id,
                                describe(i)
                            );
                        }
                    }
                }
            }
            Ok(best)
        })
        .collect::<Result<Vec<_>>>()?;
    let mut check = SceneCheck {
        min_frame_clearance_px: f64::INFINITY,
        worst_frame: String::new(),
        min_separation_px: f64::INFINITY,
        worst_separation: String::new(),
    };
    for (c, cw, s, sw) in per_instant {
        if c < check.min_frame_clearance_px {
            check.min_frame_clearance_px = c;
            check.worst_frame = cw;
        }
        if s < check.min_separation_px {
            check.min_separation_px = s;
            check.worst_separation = sw;
        }
    }
    Ok(check)
}

fn describe(i: &Instant) -> String {
    format!(
        "{} line {} run {} {} target {} capture {} (nominal {:?})",
        i.axis,
        i.line + 1,
        i.run,
        i.direction,
        i.target,
        i.capture,
        i.nominal
    )
}

/// What a campaign run produced.
#[derive(Debug, Clone, PartialEq)]
pub struct CampaignSummary {
    /// Instants (exposures of all cameras together).
    pub instants: usize,
    /// Image files of the campaign (instants × cameras, or every frame the
    /// cameras saved), calibration images excluded.
    pub frames: usize,
    /// Bytes of all image files written, calibration images included.
    pub image_bytes: u64,
    /// Scene geometry check.
    pub scene: SceneCheck,
}

/// What a campaign will write, known before its first frame is rendered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CampaignSize {
    /// Image files of the campaign (as [`CampaignSummary::frames`]).
    pub frames: usize,
    /// Their pixels (bytes, before any compression): frames × width × height
    /// × bytes per sample.
    pub pixel_bytes: u64,
    /// The calibration images' pixels beside them (bytes, before any
    /// compression): per camera the target, its flat fields and dark frames.
    pub calibration_bytes: u64,
    /// Continuous capture: how long the cameras record (s); each records
    /// `fps` frames a second of it.
    pub recording_s: Option<f64>,
}

/// The size of the campaign `config` describes, from its plan alone
/// (nothing is rendered or written): for continuous capture, `fps` × the
/// recording's length per camera.
pub fn campaign_size(config: &Config) -> Result<CampaignSize> {
    let rig = SynthRig::from_config(config)?;
    let plan = Plan::new(config)?;
    let (frames, recording_s) = if config.capture.is_manifest() {
        (plan.instants.len() * rig.cameras.len(), None)
    } else {
        let jobs = crate::capture::plan_frames(config, &rig, &plan)?;
        (jobs.len(), jobs.recording_s())
    };
    let s = &config.sensor;
    let pixel = u64::from(s.width) * u64::from(s.height) * u64::from(s.bits.div_ceil(8));
    let calibration = rig.cameras.len() as u64 * (1 + 2 * u64::from(s.calibration_frames));
    Ok(CampaignSize {
        frames,
        pixel_bytes: frames as u64 * pixel,
        calibration_bytes: calibration * pixel,
        recording_s,
    })
}

fn file_len(path: &Path) -> Result<u64> {
    Ok(std::fs::metadata(path)
        .map_err(|e| SynthError::io(path, e))?
        .len())
}

/// Render and write one instant's images (all cameras).
fn write_instant(
    config: &Config,
    rig: &SynthRig,
    plan: &Plan,
    i: &Instant,
    out: &Path,
    bytes: &AtomicU64,
    output: &OutputPlan,
) -> Result<()> {
    let spheres = plan.spheres_at(i);
    let ext = config.output.format.extension();
    for cam in &rig.cameras {
        let img = cam.render(
            &spheres,
            NoiseKey {
                seed: config.seed,
                frame: i.index,
                camera: cam.id,
            },
            config.render.max_depth,
        )?;
        let path = out.join(i.image_path(cam.id, ext));
        let frame = Frame {
            path: &path,
            serial: &cam.serial,
            time_s: plan.start_time_s + i.time_s,
            description: format!("camera {} {}", cam.id, describe(i)),
        };
        write_frame(config, output, &img, frame, bytes)?;
    }
    Ok(())
}

/// One rendered frame's file and the metadata that differ between frames.
pub(crate) struct Frame<'a> {
    /// The image file.
    pub path: &'a Path,
    /// The camera's serial number.
    pub serial: &'a str,
    /// Capture time (s since 1970-01-01T00:00:00).
    pub time_s: f64,
    /// EXIF image description.
    pub description: String,
}

/// Write a rendered frame through the output plan, with the EXIF metadata
/// of the configured camera, sensor and lens, and count its bytes.
pub(crate) fn write_frame(
    config: &Config,
    output: &OutputPlan,
    img: &crate::sensor::Image16,
    frame: Frame<'_>,
    bytes: &AtomicU64,
) -> Result<()> {
    let meta = FrameMetadata {
        make: config.output.make.clone(),
        model: config.output.model.clone(),
        serial: frame.serial.to_string(),
        time_s: frame.time_s,
        exposure_s: config.sensor.exposure_s,
        f_number: config.optics.f_number,
        focal_mm: config.optics.focal_mm,
        description: frame.description,
    };
    write_image_into(
        output.create(frame.path)?,
        img,
        config.sensor.bits,
        &meta,
        config.output.format,
        config.output.compression,
    )?;
    bytes.fetch_add(file_len(frame.path)?, Ordering::Relaxed);
    Ok(())
}

/// Files of a campaign beside its images and calibration files; the
/// manifest (renderer's layout) or the program and the renderer's own
/// manifest (captured) follow.
const CAMPAIGN_FILES: [&str; 5] = [
    "config.toml",
    "spheres.csv",
    "nominal.json",
    "truth_points.csv",
    "truth.json",
];

/// Plan the calibration files under `out` ([`crate::target::target_files`]),
/// then lock `out`, refuse (without `--force`) a rendering that an earlier run
/// left incomplete, and check the plan. `last` is the file the rendering
/// writes last and `first` the one it writes first: `first` without `last` is
/// the rest of a run that stopped.
fn plan_target(
    config: &Config,
    rig: &SynthRig,
    out: &Path,
    output: &mut OutputPlan,
    command: &str,
    [first, last]: [&str; 2],
) -> Result<()> {
    output.folder(out).folder(out.join("calib"));
    for d in crate::target::target_folders(config, rig) {
        output.folder(out.join(d));
    }
    for f in crate::target::target_files(config, rig) {
        output.file(out.join(f));
    }
    output.lock(out, command)?;
    if !output.force() && out.join(first).exists() && !out.join(last).exists() {
        return Err(SynthError::Incomplete {
            folder: out.to_path_buf(),
            last: out.join(last),
        });
    }
    output.check()?;
    Ok(())
}

/// Write a whole campaign under `out` (created if needed) through `output`,
/// where the caller declared its inputs (the configuration file) and
/// whether an existing campaign may be replaced (`--force`): in the
/// renderer's layout with `manifest.csv`, or, with a `[capture]` mode, as the
/// cameras save the frames (`crate::capture`), with `truth_manifest.csv` and
/// `program.toml` instead of `manifest.csv`.
pub fn write_campaign(
    config: &Config,
    out: &Path,
    output: &mut OutputPlan,
    progress: &dyn Progress,
) -> Result<CampaignSummary> {
    config.validate()?;
    let rig = SynthRig::from_config(config)?;
    let plan = Plan::new(config)?;
    if plan.instants.is_empty() {
        return Err(SynthError::config(
            "procedure.axes: the procedure has no instants",
        ));
    }
    let ext = config.output.format.extension();
    for f in CAMPAIGN_FILES {
        output.file(out.join(f));
    }
    let frame_jobs = if config.capture.is_manifest() {
        output.file(out.join("manifest.csv"));
        let dirs: BTreeSet<String> = plan.instants.iter().map(Instant::image_dir).collect();
        for d in &dirs {
            output.folder(out.join(d));
        }
        for i in &plan.instants {
            for cam in &rig.cameras {
                output.file(out.join(i.image_path(cam.id, ext)));
            }
        }
        None
    } else {
        output
            .file(out.join("program.toml"))
            .file(out.join("truth_manifest.csv"));
        for cam in &rig.cameras {
            output.folder(out.join(&cam.serial));
        }
        let jobs = crate::capture::plan_frames(config, &rig, &plan)?;
        for p in jobs.paths() {
            output.file(out.join(p));
        }
        Some(jobs)
    };
    let last = if frame_jobs.is_some() {
        "truth_manifest.csv"
    } else {
        "manifest.csv"
    };
    plan_target(
        config,
        &rig,
        out,
        output,
        "synth campaign",
        ["config.toml", last],
    )?;

    progress.begin("checking scenes", 1);
    let scene = check_plan(&rig, &plan)?;
    progress.advance(1);
    progress.finish();

    output.write_bytes(&out.join("config.toml"), config.to_toml()?.as_bytes())?;
    let sphere_rows: Vec<SphereRow> = plan
        .spheres
        .iter()
        .map(|s| SphereRow {
            name: s.name.clone(),
            diameter: 2.0 * s.radius,
        })
        .collect();
    output.write_csv(&out.join("spheres.csv"), &sphere_rows)?;
    output.write_json(&out.join("nominal.json"), &rig.nominal())?;

    let bytes = AtomicU64::new(0);
    progress.begin("calibration images", rig.cameras.len() as u64);
    let calib = crate::target::write_target_files(config, &rig, out, plan.start_time_s, output)?;
    for p in &calib {
        bytes.fetch_add(file_len(&out.join(p))?, Ordering::Relaxed);
    }
    progress.advance(rig.cameras.len() as u64);
    progress.finish();

    let (frames, captured) = match &frame_jobs {
        Some(jobs) => {
            let c = crate::capture::write_frames(
                config, &rig, &plan, jobs, out, output, progress, &bytes,
            )?;
            (c.frames, Some(c))
        }
        None => {
            let frames = plan.instants.len() * rig.cameras.len();
            progress.begin("rendering frames", frames as u64);
            let batch = BATCH_PER_THREAD * rayon::current_num_threads().max(1);
            for chunk in plan.instants.chunks(batch) {
                chunk.par_iter().try_for_each(|i| -> Result<()> {
                    write_instant(config, &rig, &plan, i, out, &bytes, output)?;
                    progress.advance(rig.cameras.len() as u64);
                    Ok(())
                })?;
            }
            progress.finish();
            (frames, None)
        }
    };

    progress.begin("truth and manifest", 1);
    let points = plan.truth_points();
    output.write_csv(&out.join("truth_points.csv"), &points)?;
    let mut truth = crate::truth::campaign_truth(config, &rig, &plan, &points)?;
    truth.extra.insert(
        "scene".into(),
        serde_json::json!({
            "min_frame_clearance_px": scene.min_frame_clearance_px,
            "worst_frame": scene.worst_frame,
            "min_separation_px": scene.min_separation_px,
            "worst_separation": scene.worst_separation,
        }),
    );
    match captured {
        Some(c) => {
            // What the cameras saved carries no manifest: the renderer's own
            // goes beside the frames, with the motion program the machine ran.
            truth.extra.insert("capture".into(), c.info);
            output.write_json(&out.join("truth.json"), &truth)?;
            output.write_bytes(
                &out.join("program.toml"),
                crate::capture::program_toml(config)?.as_bytes(),
            )?;
            output.write_csv(&out.join("truth_manifest.csv"), &c.manifest)?;
        }
        None => {
            output.write_json(&out.join("truth.json"), &truth)?;
            let manifest: Vec<ManifestRow> = plan
                .instants
                .iter()
                .flat_map(|i| rig.cameras.iter().map(move |c| i.manifest_row(c.id, ext)))
                .collect();
            output.write_csv(&out.join("manifest.csv"), &manifest)?;
        }
    }
    progress.advance(1);
    progress.finish();

    Ok(CampaignSummary {
        instants: plan.instants.len(),
        frames,
        image_bytes: bytes.into_inner(),
        scene,
    })
}

/// What `trinocular synth target` produced.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetSummary {
    /// Markers on the target.
    pub markers: usize,
    /// Calibration images written (per camera: target, flat field, dark frame), relative paths.
    pub images: Vec<String>,
}

/// Write the calibration target scene under `out` (created if needed)
/// through `output`: `target.csv`, `nominal.json`, `truth.json` (true
/// cameras; no spheres or instants), `calib/cam{k}.*` and
/// `calib/points_cam{k}.csv`.
pub fn write_target_scene(
    config: &Config,
    out: &Path,
    output: &mut OutputPlan,
    progress: &dyn Progress,
) -> Result<TargetSummary> {
    config.validate()?;
    let rig = SynthRig::from_config(config)?;
    let start = crate::datetime::parse(&config.procedure.start_time)?;
    output
        .file(out.join("nominal.json"))
        .file(out.join("truth.json"));
    plan_target(
        config,
        &rig,
        out,
        output,
        "synth target",
        ["target.csv", "truth.json"],
    )?;
    progress.begin("calibration images", rig.cameras.len() as u64);
    let images = crate::target::write_target_files(config, &rig, out, start, output)?;
    progress.advance(rig.cameras.len() as u64);
    progress.finish();
    output.write_json(&out.join("nominal.json"), &rig.nominal())?;
    let mut extra = serde_json::Map::new();
    extra.insert("seed".into(), serde_json::json!(config.seed));
    crate::truth::insert_target_poses(&mut extra, config);
    let truth = crate::truth::cameras_truth(&rig, config, extra);
    output.write_json(&out.join("truth.json"), &truth)?;
    Ok(TargetSummary {
        markers: crate::target::markers(&config.target).len(),
        images,
    })
}
