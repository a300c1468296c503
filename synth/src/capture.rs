//! Campaigns written the way cameras save them (`trinocular synth campaign
//! --as-captured`, the `[capture]` table): a folder per camera serial, files
//! numbered in the order the camera saved them from any first number, EXIF
//! times on each camera's own clock, moves that take longer than
//! distance/feed, and on request dropped frames and stray triggers; or the
//! continuous stream of free-running cameras (frames during the moves too,
//! optionally blurred by the motion). Beside the frames go the renderer's
//! own manifest of the instants it wrote (`truth_manifest.csv`) and the
//! motion program (`program.toml`), so that building the manifest from the
//! folders is tested against truth.
//!
//! The real timeline: every move of the program takes
//! `distance/feed · move_time_factor + move_extra_s`; the machine then
//! settles `settle_s`. Triggered: the cameras take `captures` frames `1/fps`
//! apart. Continuous: the cameras expose on one frame clock (`1/fps`, from
//! `lead_s` before the first move to `lead_s` after the last dwell); a move
//! ends half-way between two frames (so that the last frame in motion is
//! half a frame's travel from rest and the first still frame is decidable
//! from the images), the instant is the `captures` frames from the first
//! frame at least `settle_s` after the first still one, and the machine
//! leaves half a frame after the last of them (plus `dwell_extra_frames`).

use std::path::Path;
use std::sync::atomic::AtomicU64;

use formats::{Dwell, ManifestRow, OutputPlan};
use geom::nalgebra::Vector3;
use geom::transform::SmallError;
use rayon::prelude::*;
use serde::Serialize;

use crate::config::{CaptureMode, Config, bad_capture as bad};
use crate::machine::{ApproachKey, approach_offset, table_error};
use crate::procedure::Plan;
use crate::progress::Progress;
use crate::rig::SynthRig;
use crate::sensor::{Exposure, NoiseKey};
use crate::{Result, SynthError};

/// One straight move of the table at constant speed.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    from: [f64; 3],
    to: [f64; 3],
    t0: f64,
    t1: f64,
}

impl Segment {
    fn at(&self, t: f64) -> [f64; 3] {
        let f = if self.t1 > self.t0 {
            ((t - self.t0) / (self.t1 - self.t0)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let p = Vector3::from(self.from) + (Vector3::from(self.to) - Vector3::from(self.from)) * f;
        [p.x, p.y, p.z]
    }
}

/// A dwell on the real timeline (true seconds from the campaign start).
#[derive(Debug, Clone, PartialEq)]
struct RealDwell {
    /// The moves that bring the table here.
    moves: Vec<Segment>,
    /// Arrival (end of the last move).
    arrive_s: f64,
    /// Time of the first capture.
    first_capture_s: f64,
    /// Departure (start of the next move).
    depart_s: f64,
    /// Continuous: frame-clock slot of the first capture.
    first_slot: i64,
}

/// The moves of `dwell` from `at` (advanced), starting at `time`; returns
/// the moves and the time at their end.
fn moves(
    dwell: &Dwell,
    at: &mut Option<[f64; 3]>,
    mut time: f64,
    config: &Config,
) -> (Vec<Segment>, f64) {
    let c = &config.capture;
    let mut out = Vec::new();
    for &to in &dwell.path {
        if let Some(from) = *at {
            let d = (Vector3::from(to) - Vector3::from(from)).norm();
            let dur = d / config.procedure.feed_mm_per_s * c.move_time_factor
                + if d > 0.0 { c.move_extra_s } else { 0.0 };
            out.push(Segment {
                from,
                to,
                t0: time,
                t1: time + dur,
            });
            time += dur;
        }
        *at = Some(to);
    }
    (out, time)
}

/// The real timeline of triggered capture.
fn triggered_timeline(dwells: &[Dwell], config: &Config) -> Vec<RealDwell> {
    let p = &config.procedure;
    let mut at = None;
    let mut time = 0.0;
    dwells
        .iter()
        .map(|d| {
            let (moves, arrive_s) = moves(d, &mut at, time, config);
            let first_capture_s = arrive_s + p.settle_s;
            time = first_capture_s;
            for _ in 0..p.captures {
                time += 1.0 / p.fps;
            }
            RealDwell {
                moves,
                arrive_s,
                first_capture_s,
                depart_s: time,
                first_slot: 0,
            }
        })
        .collect()
}

/// The real timeline of continuous capture on the frame clock `k/fps`.
fn continuous_timeline(dwells: &[Dwell], config: &Config) -> Vec<RealDwell> {
    let p = &config.procedure;
    let period = 1.0 / p.fps;
    let settle_frames = (p.settle_s * p.fps - 1e-9).ceil().max(0.0) as i64;
    let mut at = None;
    let mut time = 0.0;
    dwells
        .iter()
        .map(|d| {
            let (mut moves, end) = moves(d, &mut at, time, config);
            // The move ends half-way between two frames: slot k_s is the first still one.
            let k_s = (end / period + 0.5).ceil() as i64;
            let arrive_s = (k_s as f64 - 0.5) * period;
            if let Some(last) = moves.last_mut() {
                last.t1 = arrive_s;
            }
            let first_slot = k_s + settle_frames;
            let last_slot = first_slot + i64::from(p.captures) - 1;
            let depart_s =
                (last_slot as f64 + 0.5 + f64::from(config.capture.dwell_extra_frames)) * period;
            time = depart_s;
            RealDwell {
                moves,
                arrive_s,
                first_capture_s: first_slot as f64 * period,
                depart_s,
                first_slot,
            }
        })
        .collect()
}

/// What one frame shows.
#[derive(Debug, Clone)]
enum Scene {
    /// A campaign instant, exactly as the renderer's own layout renders it.
    Instant(usize),
    /// Poses over the exposure (one: no blur), with the noise frame number.
    Poses(Vec<([f64; 3], SmallError)>, u64),
}

/// A frame to render and write.
#[derive(Debug, Clone)]
struct Job {
    camera: u8,
    time_s: f64,
    scene: Scene,
    /// Path relative to the campaign root (set once numbered).
    path: String,
}

/// Noise frame numbers of frames that are not instants (strays, continuous).
const OTHER_FRAMES: u64 = 1 << 48;

/// The pose of the table at true time `t` on the timeline (no random
/// offsets in moves; the approach's repeatability offset at a dwell).
fn pose_at(
    t: f64,
    dwells: &[Dwell],
    real: &[RealDwell],
    config: &Config,
) -> Option<([f64; 3], SmallError)> {
    let j = real.partition_point(|r| r.arrive_s <= t);
    // Still at dwell j − 1 until it departs; moving towards dwell j after.
    let (dwell, position) = if j == 0 {
        let d = dwells.first()?;
        let r = real.first()?;
        let pos = r
            .moves
            .iter()
            .find(|s| t < s.t1)
            .map_or(d.nominal, |s| s.at(t));
        (d, pos)
    } else if t <= real[j - 1].depart_s || j == dwells.len() {
        let d = &dwells[j - 1];
        let errors = config.machine.axis(d.axis)?;
        let key = ApproachKey {
            axis: d.axis,
            line: d.line,
            run: d.run,
            direction: d.direction,
            target: d.target,
        };
        let random = approach_offset(config.seed, &key, errors);
        return Some((
            d.nominal,
            table_error(config, d.axis, d.direction, d.nominal, random),
        ));
    } else {
        let d = &dwells[j];
        let pos = real[j]
            .moves
            .iter()
            .find(|s| t < s.t1)
            .map_or(d.nominal, |s| s.at(t));
        (d, pos)
    };
    Some((
        position,
        table_error(
            config,
            dwell.axis,
            dwell.direction,
            position,
            Vector3::zeros(),
        ),
    ))
}

/// Poses over the exposure starting at `t` (`blur_steps` sub-positions,
/// one pose when they all agree).
fn exposure_poses(
    t: f64,
    dwells: &[Dwell],
    real: &[RealDwell],
    config: &Config,
) -> Result<Vec<([f64; 3], SmallError)>> {
    let n = config.capture.blur_steps.max(1);
    let mut poses = Vec::with_capacity(n as usize);
    for i in 0..n {
        let ti = t + (f64::from(i) + 0.5) / f64::from(n) * config.sensor.exposure_s;
        let t_i = if n == 1 { t } else { ti };
        let pose = pose_at(t_i, dwells, real, config)
            .ok_or_else(|| SynthError::config("procedure.axes: the procedure has no dwells"))?;
        poses.push(pose);
    }
    if poses.windows(2).all(|w| w[0] == w[1]) {
        poses.truncate(1);
    }
    Ok(poses)
}

/// Everything a captured campaign wrote besides its frames.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CapturedFrames {
    /// Image files written.
    pub frames: usize,
    /// The renderer's own manifest of the instants' frames (paths relative to the campaign root).
    pub manifest: Vec<ManifestRow>,
    /// What was done, for `truth.json` (`capture`).
    pub info: serde_json::Value,
}

fn is_dropped(config: &Config, camera: u8, instant: usize) -> bool {
    config
        .capture
        .dropped
        .iter()
        .any(|d| d.camera == camera && d.instant == instant as u64)
}

/// The frames of a triggered or continuous campaign, numbered as each
/// camera saves them: what [`write_frames`] renders.
#[derive(Debug, Clone)]
pub(crate) struct FrameJobs {
    jobs: Vec<Job>,
    /// Frames taken while the table moved (continuous capture).
    moving: usize,
    /// Continuous capture: how long the cameras record (s).
    recording_s: Option<f64>,
}

impl FrameJobs {
    /// The files, relative to the campaign root (`{serial}/{prefix}{number}.{ext}`).
    pub(crate) fn paths(&self) -> impl Iterator<Item = &str> {
        self.jobs.iter().map(|j| j.path.as_str())
    }

    /// Image files planned.
    pub(crate) fn len(&self) -> usize {
        self.jobs.len()
    }

    /// Continuous capture: how long the cameras record (s), from `lead_s`
    /// before the first move to `lead_s` after the last dwell.
    pub(crate) fn recording_s(&self) -> Option<f64> {
        self.recording_s
    }
}

/// Plan the frames of a triggered or continuous campaign: which camera
/// exposes what at which time, and the file each goes to.
pub(crate) fn plan_frames(config: &Config, rig: &SynthRig, plan: &Plan) -> Result<FrameJobs> {
    let c = &config.capture;
    let p = &config.procedure;
    let dwells = p.dwells();
    let captures = p.captures as usize;
    if plan.instants.len() != dwells.len() * captures {
        return Err(SynthError::config(format!(
            "procedure: {} instants for {} dwells of {captures} captures",
            plan.instants.len(),
            dwells.len()
        )));
    }
    for (i, d) in c.dropped.iter().enumerate() {
        if d.instant >= plan.instants.len() as u64 {
            return Err(bad(
                &format!("dropped[{i}].instant"),
                format!("{} beyond the {} instants", d.instant, plan.instants.len()),
            ));
        }
    }
    for (i, s) in c.stray.iter().enumerate() {
        if s.dwell >= dwells.len() {
            return Err(bad(
                &format!("stray[{i}].dwell"),
                format!("{} beyond the {} dwells", s.dwell, dwells.len()),
            ));
        }
    }

    let mut jobs: Vec<Job> = Vec::new();
    let mut moving = 0usize;
    let mut recording_s = None;
    let real = match c.mode {
        CaptureMode::Continuous => continuous_timeline(&dwells, config),
        _ => triggered_timeline(&dwells, config),
    };
    match c.mode {
        CaptureMode::Continuous => {
            let period = 1.0 / p.fps;
            let lead = (c.lead_s * p.fps).ceil() as i64;
            let end = real.last().map_or(0.0, |r| r.depart_s);
            let (k0, k1) = (-lead, (end / period).ceil() as i64 + lead);
            recording_s = Some((k1 - k0 + 1) as f64 * period);
            let mut instant_of_slot = std::collections::BTreeMap::new();
            for (j, r) in real.iter().enumerate() {
                for k in 0..captures {
                    instant_of_slot.insert(r.first_slot + k as i64, j * captures + k);
                }
            }
            for k in k0..=k1 {
                let t = k as f64 * period;
                let scene = match instant_of_slot.get(&k) {
                    Some(&i) => Scene::Instant(i),
                    None => Scene::Poses(
                        exposure_poses(t, &dwells, &real, config)?,
                        OTHER_FRAMES + (k - k0) as u64,
                    ),
                };
                for cam in &rig.cameras {
                    if let Scene::Instant(i) = scene
                        && is_dropped(config, cam.id, i)
                    {
                        continue;
                    }
                    if !matches!(scene, Scene::Instant(_)) {
                        moving += 1;
                    }
                    jobs.push(Job {
                        camera: cam.id,
                        time_s: t,
                        scene: scene.clone(),
                        path: String::new(),
                    });
                }
            }
        }
        _ => {
            for (i, instant) in plan.instants.iter().enumerate() {
                let r = &real[i / captures];
                let t = r.first_capture_s + (instant.time_s - dwells[i / captures].time_s);
                for cam in &rig.cameras {
                    if !is_dropped(config, cam.id, i) {
                        jobs.push(Job {
                            camera: cam.id,
                            time_s: t,
                            scene: Scene::Instant(i),
                            path: String::new(),
                        });
                    }
                }
            }
            for (n, s) in c.stray.iter().enumerate() {
                let (before, r) = (&real[s.dwell - 1], &real[s.dwell]);
                if r.arrive_s <= before.depart_s {
                    return Err(bad(
                        &format!("stray[{n}].dwell"),
                        format!("dwell {} has no move before it", s.dwell),
                    ));
                }
                let t = 0.5 * (before.depart_s + r.arrive_s);
                jobs.push(Job {
                    camera: s.camera,
                    time_s: t,
                    scene: Scene::Poses(
                        exposure_poses(t, &dwells, &real, config)?,
                        OTHER_FRAMES + n as u64,
                    ),
                    path: String::new(),
                });
            }
        }
    }

    // Number each camera's files in the order it saved them.
    let ext = config.output.format.extension();
    let mut per_camera: Vec<usize> = (0..jobs.len()).collect();
    per_camera.sort_by(|&a, &b| {
        (jobs[a].camera, jobs[a].time_s)
            .partial_cmp(&(jobs[b].camera, jobs[b].time_s))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut count = [0u32; 4];
    for &j in &per_camera {
        let cam = jobs[j].camera;
        let serial = rig
            .camera(cam)
            .map(|k| k.serial.clone())
            .ok_or_else(|| SynthError::config(format!("camera {cam} is not in the rig")))?;
        let number =
            u64::from(c.first_number[usize::from(cam - 1)]) + u64::from(count[usize::from(cam)]);
        count[usize::from(cam)] += 1;
        jobs[j].path = format!("{serial}/{}{number:06}.{ext}", c.file_prefix);
    }
    Ok(FrameJobs {
        jobs,
        moving,
        recording_s,
    })
}

/// Render and write the planned frames under `out` through `output`, one
/// folder per camera serial (declared in the plan with the files).
#[allow(clippy::too_many_arguments)]
pub(crate) fn write_frames(
    config: &Config,
    rig: &SynthRig,
    plan: &Plan,
    frames: &FrameJobs,
    out: &Path,
    output: &OutputPlan,
    progress: &dyn Progress,
    bytes: &AtomicU64,
) -> Result<CapturedFrames> {
    let c = &config.capture;
    let ext = config.output.format.extension();
    let FrameJobs { jobs, moving, .. } = frames;
    progress.begin("rendering frames", jobs.len() as u64);
    let batch = 2 * rayon::current_num_threads().max(1);
    for chunk in jobs.chunks(batch) {
        chunk.par_iter().try_for_each(|job| -> Result<()> {
            write_job(config, rig, plan, job, out, output, bytes)?;
            progress.advance(1);
            Ok(())
        })?;
    }
    progress.finish();

    // The renderer's own manifest: every instant frame written, campaign order.
    let mut path_of = std::collections::HashMap::new();
    for j in jobs {
        if let Scene::Instant(i) = j.scene {
            path_of.insert((i, j.camera), j.path.clone());
        }
    }
    let mut manifest = Vec::new();
    for (i, instant) in plan.instants.iter().enumerate() {
        for cam in &rig.cameras {
            if let Some(path) = path_of.get(&(i, cam.id)) {
                let mut row = instant.manifest_row(cam.id, ext);
                row.image = path.clone();
                manifest.push(row);
            }
        }
    }
    let dropped: Vec<serde_json::Value> = c
        .dropped
        .iter()
        .filter_map(|d| {
            let i = plan.instants.get(d.instant as usize)?;
            Some(serde_json::json!({
                "camera": d.camera, "instant": d.instant, "axis": i.axis, "direction": i.direction,
                "run": i.run, "target": i.target, "capture": i.capture,
            }))
        })
        .collect();
    let stray: Vec<serde_json::Value> = c
        .stray
        .iter()
        .enumerate()
        .filter_map(|(n, s)| {
            let job = jobs.iter().find(|j| {
                matches!(j.scene, Scene::Poses(_, f) if f == OTHER_FRAMES + n as u64)
                    && j.camera == s.camera
            })?;
            Some(serde_json::json!({"camera": s.camera, "dwell": s.dwell, "image": job.path}))
        })
        .collect();
    let info = serde_json::json!({
        "mode": c.mode,
        "clock_offset_s": c.clock_offset_s,
        "move_time_factor": c.move_time_factor,
        "move_extra_s": c.move_extra_s,
        "frames": jobs.len(),
        "frames_not_at_instants": *moving,
        "dropped": dropped,
        "stray": stray,
    });
    Ok(CapturedFrames {
        frames: jobs.len(),
        manifest,
        info,
    })
}

/// Render and write one frame.
fn write_job(
    config: &Config,
    rig: &SynthRig,
    plan: &Plan,
    job: &Job,
    out: &Path,
    output: &OutputPlan,
    bytes: &AtomicU64,
) -> Result<()> {
    let cam = rig
        .camera(job.camera)
        .ok_or_else(|| SynthError::config(format!("camera {} is not in the rig", job.camera)))?;
    let img = match &job.scene {
        Scene::Instant(i) => {
            let instant = &plan.instants[*i];
            cam.render(
                &plan.spheres_at(instant),
                NoiseKey {
                    seed: config.seed,
                    frame: instant.index,
                    camera: cam.id,
                },
                config.render.max_depth,
            )?
        }
        Scene::Poses(poses, frame) => {
            let key = NoiseKey {
                seed: config.seed,
                frame: *frame,
                camera: cam.id,
            };
            if let [(nominal, error)] = poses.as_slice() {
                cam.render(
                    &plan.spheres_at_pose(*nominal, error),
                    key,
                    config.render.max_depth,
                )?
            } else {
                let weight = 1.0 / poses.len() as f64;
                let mut signals = Vec::new();
                for (nominal, error) in poses {
                    let spheres = plan.spheres_at_pose(*nominal, error);
                    let s = crate::render::sphere_signals(
                        &cam.camera,
                        &cam.optics,
                        &spheres,
                        config.render.max_depth,
                        cam.lens.as_ref(),
                    )?;
                    signals.extend(
                        s.into_iter()
                            .zip(&spheres)
                            .filter_map(|(sig, sp)| sig.map(|g| (g, sp.radiance_e * weight))),
                    );
                }
                let layers: Vec<Exposure<'_>> = signals
                    .iter()
                    .map(|(signal, radiance_e)| Exposure {
                        signal,
                        radiance_e: *radiance_e,
                    })
                    .collect();
                cam.expose(&layers, key)
            }
        }
    };
    let path = out.join(&job.path);
    let frame = crate::campaign::Frame {
        path: &path,
        serial: &cam.serial,
        time_s: plan.start_time_s
            + job.time_s
            + config.capture.clock_offset_s[usize::from(cam.id - 1)],
        description: String::new(),
    };
    crate::campaign::write_frame(config, output, &img, frame, bytes)?;
    Ok(())
}

/// `program.toml`: the `[procedure]` table of the configuration, what the
/// machine ran.
pub(crate) fn program_toml(config: &Config) -> Result<String> {
    #[derive(Serialize)]
    struct Program<'a> {
        procedure: &'a formats::ProcedureConfig,
    }
    crate::config::to_toml(&Program {
        procedure: &config.procedure,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(mode: CaptureMode) -> Config {
        let mut c = Config::default();
        c.apply(&crate::Overrides {
            targets: Some(3),
            runs: Some(1),
            captures: Some(2),
            ..crate::Overrides::default()
        })
        .unwrap();
        c.procedure.fps = 20.0;
        c.capture.mode = mode;
        c
    }

    #[test]
    fn triggered_moves_take_longer() {
        let c = config(CaptureMode::Triggered);
        let dwells = c.procedure.dwells();
        let real = triggered_timeline(&dwells, &c);
        for j in 1..dwells.len() {
            let programmed = dwells[j].time_s - dwells[j - 1].time_s - 2.0 / 20.0 - 0.3;
            let actual = real[j].first_capture_s - real[j - 1].first_capture_s - 2.0 / 20.0 - 0.3;
            assert!((actual / programmed - 1.15).abs() < 1e-9, "dwell {j}");
        }
    }

    #[test]
    fn continuous_moves_end_between_frames() {
        let c = config(CaptureMode::Continuous);
        let dwells = c.procedure.dwells();
        let real = continuous_timeline(&dwells, &c);
        let period = 1.0 / 20.0;
        for (j, (d, r)) in dwells.iter().zip(&real).enumerate() {
            let half = r.arrive_s / period - 0.5;
            assert!((half - half.round()).abs() < 1e-9);
            // The first capture is the first frame at least settle_s after the first still one.
            let first_still = r.arrive_s + 0.5 * period;
            assert!(r.first_capture_s - first_still >= 0.3 - 1e-9);
            assert!(r.first_capture_s - first_still < 0.3 + period);
            // Still at the dwell for every capture, moving half a frame later.
            let pose = pose_at(r.first_capture_s + period, &dwells, &real, &c).unwrap();
            assert_eq!(pose.0, d.nominal);
            if j + 1 < dwells.len() {
                let leave = pose_at(r.depart_s + 0.5 * period, &dwells, &real, &c).unwrap();
                assert_ne!(leave.0, d.nominal);
            }
        }
    }
}
