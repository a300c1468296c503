//! The `measure` batch: every instant of a campaign → sphere centres in
//! `points.csv`, bad instants → `problems.csv`, table poses → `poses.csv`.
//!
//! The manifest is checked in full before work starts ([`crate::plan`]).
//! Instants are measured in parallel, a chunk at a time, and their rows are
//! appended to `points.csv.partial` after each chunk (all rows of an instant
//! in one write), with a fingerprint of the inputs and options beside it. An
//! interrupted run started again with the same inputs resumes: finished
//! instants are kept (a torn last instant is dropped and redone), the rest is
//! measured. At the end the rows are sorted into manifest order and every
//! output is written atomically; the partial files are removed.

use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use extract::{Backend, ExtractParams, FrameReader};
use formats::{
    InstantKey, InstantProblemRow, LineKey, OutputPlan, PointRow, SphereRow, read_csv_from,
};
use geom::{Point2, Point3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::matching::{MatchFailure, assign};
use crate::observe::candidates;
use crate::plan::{InstantPlan, RigModel, plan};
use crate::pose::poses;
use crate::triangulate::{View, seed_displacement, triangulate};
use crate::{FuseError, Result};

/// Allowance for the spheres' layout on the table around its reference point (mm).
pub const SPHERE_LAYOUT_MM: f64 = 50.0;

/// Instants measured between two appends to the partial output.
const CHUNK_INSTANTS: usize = 16;

/// How sphere centres are computed from the cameras' images.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Fusion {
    /// Rigorous triangulation: linear, then least squares on the reprojection error.
    #[default]
    Triangulate,
    /// The seed's pixel-scale fusion relative to the first instant of each line.
    Seed,
}

/// Everything that decides a measurement's result.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeasureOptions {
    /// Fusion method.
    pub fusion: Fusion,
    /// Use every camera, not only those that do not look along the motion.
    pub all_cameras: bool,
    /// Remove the perspective bias of the spheres' images (on by default;
    /// off only to show what it is worth).
    pub bias_correction: bool,
    /// Blob extraction.
    pub extract: ExtractParams,
}

impl Default for MeasureOptions {
    fn default() -> Self {
        Self {
            fusion: Fusion::Triangulate,
            all_cameras: false,
            bias_correction: true,
            extract: ExtractParams::default(),
        }
    }
}

/// The inputs of a measurement.
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    /// `manifest.csv` (image paths relative to it).
    pub manifest: &'a Path,
    /// The calibrated rig.
    pub rig: &'a formats::Rig,
    /// The spheres.
    pub spheres: &'a [SphereRow],
}

/// What a measurement did.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Instants in the campaign.
    pub instants: usize,
    /// Instants with sphere centres in `points.csv`.
    pub measured: usize,
    /// Of those, instants kept from an interrupted earlier run.
    pub resumed: usize,
    /// Instants in `problems.csv`.
    pub problems: usize,
    /// `points.csv`.
    pub points: PathBuf,
    /// `problems.csv`, when there were problems.
    pub problems_file: Option<PathBuf>,
    /// `poses.csv`.
    pub poses: PathBuf,
    /// Cameras whose relative illumination is the assumed ideal lens (no
    /// flat-field model in `rig.json`).
    pub assumed_ideal_lens: Vec<u8>,
}

/// Paths of the outputs beside `points.csv`.
fn beside(out: &Path, name: &str) -> PathBuf {
    out.with_file_name(name)
}

fn with_suffix(out: &Path, suffix: &str) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Fingerprint of a run: what must match for a partial output to be resumed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Fingerprint {
    manifest_crc32: u32,
    rig_crc32: u32,
    spheres_crc32: u32,
    options: MeasureOptions,
}

/// CRC-32 of a value's JSON serialisation.
fn json_crc<T: Serialize + ?Sized>(value: &T) -> u32 {
    crc32fast::hash(&serde_json::to_vec(value).unwrap_or_default())
}

fn fingerprint(inputs: &Inputs<'_>, options: &MeasureOptions) -> Result<Fingerprint> {
    let manifest =
        std::fs::read(inputs.manifest).map_err(|e| formats::FormatError::io(inputs.manifest, e))?;
    Ok(Fingerprint {
        manifest_crc32: crc32fast::hash(&manifest),
        rig_crc32: json_crc(inputs.rig),
        spheres_crc32: json_crc(inputs.spheres),
        options: *options,
    })
}

/// Per sphere, the ideal-pixel image centre seen by each camera used.
type Observations = Vec<BTreeMap<u8, Point2<f64>>>;

/// Shared, read-only state of a run.
struct Context<'a> {
    rig: RigModel,
    /// How far from the working point the spheres can be (mm): half the
    /// campaign's largest nominal extent plus [`SPHERE_LAYOUT_MM`].
    reach_mm: f64,
    spheres: &'a [SphereRow],
    diameters: Vec<f64>,
    options: MeasureOptions,
    backend: &'a dyn Backend,
    readers: Mutex<Vec<FrameReader>>,
}

/// Why an instant failed: a row for problems.csv.
type Failure = InstantProblemRow;

impl Context<'_> {
    fn failure(
        key: &InstantKey,
        camera: Option<u8>,
        image: Option<&Path>,
        reason: impl Into<String>,
    ) -> Failure {
        InstantProblemRow::new(
            key,
            camera,
            image.map(|p| p.display().to_string()),
            reason.into(),
        )
    }

    /// Extract and match one camera's image: the ideal-pixel centre of each sphere.
    fn observe(
        &self,
        ip: &InstantPlan,
        camera: u8,
    ) -> std::result::Result<Vec<Point2<f64>>, Failure> {
        let key = &ip.key;
        let path = ip.images.get(&camera).ok_or_else(|| {
            Self::failure(
                key,
                Some(camera),
                None,
                format!("no image of camera {camera}"),
            )
        })?;
        let fail = |reason: String| Self::failure(key, Some(camera), Some(path), reason);
        let (cam, illumination) = self
            .rig
            .cameras
            .get(&camera)
            .zip(self.rig.illumination.get(&camera))
            .ok_or_else(|| fail(format!("camera {camera} is not in the rig")))?;
        let mut reader = self
            .readers
            .lock()
            .ok()
            .and_then(|mut r| r.pop())
            .unwrap_or_else(|| FrameReader::new().limit_pixels(self.options.extract.max_pixels));
        let result = (|| {
            let (frame, _) = reader.read(path).map_err(|e| fail(e.to_string()))?;
            let extraction = self
                .backend
                .extract(frame, &self.options.extract)
                .map_err(|e| fail(e.in_file(path).to_string()))?;
            let cands = candidates(
                cam,
                illumination,
                &frame,
                &extraction,
                self.options.extract.weighting,
            );
            let wd = self.rig.working_distance(camera).unwrap_or(1.0);
            let range = ((wd - self.reach_mm).max(0.1 * wd), wd + self.reach_mm);
            match assign(&cands, &self.diameters, cam.intrinsics.fx, range) {
                Ok(pick) => Ok(pick.iter().map(|&c| cands[c].ideal_px).collect()),
                Err(MatchFailure::Missing(m)) => {
                    let names: Vec<&str> =
                        m.iter().map(|&i| self.spheres[i].name.as_str()).collect();
                    Err(fail(format!(
                        "sphere{} {} not found among {} blob{}{}",
                        if names.len() == 1 { "" } else { "s" },
                        names.join(", "),
                        extraction.blobs.len(),
                        if extraction.blobs.len() == 1 { "" } else { "s" },
                        extraction
                            .saturation_note(frame.max_value())
                            .map(|n| format!(" ({n})"))
                            .unwrap_or_default()
                    )))
                }
                Err(MatchFailure::Ambiguous) => Err(fail(format!(
                    "ambiguous: {} blobs fit the sphere diameters in more than one way",
                    extraction.blobs.len()
                ))),
            }
        })();
        if let Ok(mut r) = self.readers.lock() {
            r.push(reader);
        }
        result
    }

    /// Observations of all spheres by the cameras used for this instant.
    fn observe_instant(
        &self,
        ip: &InstantPlan,
    ) -> std::result::Result<(Vec<u8>, Observations), Failure> {
        let cams = self.rig.cameras_for(ip.key.axis, self.options.all_cameras);
        let mut obs: Observations = vec![BTreeMap::new(); self.spheres.len()];
        for &c in &cams {
            let seen = self.observe(ip, c)?;
            for (s, p) in seen.into_iter().enumerate() {
                obs[s].insert(c, p);
            }
        }
        Ok((cams, obs))
    }

    fn radius(&self, sphere: usize) -> f64 {
        if self.options.bias_correction {
            self.diameters[sphere] / 2.0
        } else {
            0.0
        }
    }

    fn views<'c>(&'c self, obs: &BTreeMap<u8, Point2<f64>>) -> Vec<View<'c>> {
        obs.iter()
            .filter_map(|(c, p)| {
                self.rig.cameras.get(c).map(|camera| View {
                    camera,
                    ideal_px: *p,
                })
            })
            .collect()
    }

    /// Triangulated centres and residuals of every sphere.
    fn triangulate_all(
        &self,
        key: &InstantKey,
        obs: &Observations,
    ) -> std::result::Result<Vec<(Point3<f64>, f64)>, Failure> {
        obs.iter()
            .enumerate()
            .map(|(s, o)| {
                triangulate(&self.views(o), self.radius(s))
                    .map(|t| (t.point, t.residual_px))
                    .map_err(|e| {
                        Self::failure(
                            key,
                            None,
                            None,
                            format!("sphere {}: {e}", self.spheres[s].name),
                        )
                    })
            })
            .collect()
    }

    /// Image centres with the perspective bias removed for a sphere at `point`
    /// (projected centre c = e·(1 − r²/Cz²), geom::sphere_image).
    fn debiased(
        &self,
        sphere: usize,
        obs: &BTreeMap<u8, Point2<f64>>,
        point: &Point3<f64>,
    ) -> BTreeMap<u8, Point2<f64>> {
        let r = self.radius(sphere);
        if r == 0.0 {
            return obs.clone();
        }
        obs.iter()
            .filter_map(|(c, p)| {
                let cam = self.rig.cameras.get(c)?;
                let e = cam.intrinsics.to_normalized(*p);
                let n = geom::sphere_image::projected_centre(e, cam.to_camera(point).z, r).ok()?;
                Some((*c, cam.intrinsics.to_pixel(n)))
            })
            .collect()
    }
}

/// The reference of a line for the seed's fusion: its first instant's
/// observations and triangulated centres.
struct Reference {
    observations: Observations,
    points: Vec<(Point3<f64>, f64)>,
}

fn rows_for(
    key: &InstantKey,
    spheres: &[SphereRow],
    cams: &[u8],
    centres: &[(Point3<f64>, f64)],
) -> Vec<PointRow> {
    let [nx, ny, nz] = key.nominal();
    let cameras = cams.iter().map(u8::to_string).collect::<Vec<_>>().join("+");
    spheres
        .iter()
        .zip(centres)
        .map(|(s, (p, res))| PointRow {
            axis: key.axis,
            direction: key.direction,
            run: key.run,
            target: key.target,
            capture: key.capture,
            nominal_x: nx,
            nominal_y: ny,
            nominal_z: nz,
            sphere: s.name.clone(),
            x: p.x,
            y: p.y,
            z: p.z,
            cameras: cameras.clone(),
            residual_px: *res,
        })
        .collect()
}

fn measure_one(
    ctx: &Context<'_>,
    ip: &InstantPlan,
    references: &HashMap<LineKey, std::result::Result<Reference, String>>,
) -> std::result::Result<Vec<PointRow>, Failure> {
    let (cams, obs) = ctx.observe_instant(ip)?;
    let centres = match ctx.options.fusion {
        Fusion::Triangulate => ctx.triangulate_all(&ip.key, &obs)?,
        Fusion::Seed => {
            let reference = match references.get(&ip.line) {
                Some(Ok(r)) => r,
                Some(Err(reason)) => {
                    return Err(Context::failure(
                        &ip.key,
                        None,
                        None,
                        format!("the first instant of the line could not be measured: {reason}"),
                    ));
                }
                None => {
                    return Err(Context::failure(
                        &ip.key,
                        None,
                        None,
                        "no reference instant for the line",
                    ));
                }
            };
            let mut out = Vec::with_capacity(obs.len());
            for (s, o) in obs.iter().enumerate() {
                let (p0, _) = reference.points[s];
                let r0 = ctx.debiased(s, &reference.observations[s], &p0);
                let r1 = ctx.debiased(s, o, &p0);
                let depths: Vec<f64> = r0
                    .keys()
                    .filter_map(|c| ctx.rig.cameras.get(c).map(|cam| cam.to_camera(&p0).z))
                    .collect();
                let (d, res) = seed_displacement(&ctx.views(&r0), &ctx.views(&r1), &depths)
                    .map_err(|e| {
                        Context::failure(
                            &ip.key,
                            None,
                            None,
                            format!("sphere {}: {e}", ctx.spheres[s].name),
                        )
                    })?;
                out.push((p0 + d, res));
            }
            out
        }
    };
    Ok(rows_for(&ip.key, ctx.spheres, &cams, &centres))
}

/// Largest extent of the commanded positions along any axis (mm).
fn extent(plans: &[InstantPlan]) -> f64 {
    (0..3)
        .map(|a| {
            let (lo, hi) = plans
                .iter()
                .map(|p| p.key.nominal()[a])
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                });
            if hi >= lo { hi - lo } else { 0.0 }
        })
        .fold(0.0, f64::max)
}

/// Rows of complete instants in a partial output (a torn tail is dropped).
fn load_partial(path: &Path, spheres: usize) -> Result<Vec<PointRow>> {
    let bytes = std::fs::read(path).map_err(|e| formats::FormatError::io(path, e))?;
    let end = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let rows = read_csv_from::<PointRow, _>(&bytes[..end], path).map_err(FuseError::Format)?;
    let mut count: BTreeMap<InstantKey, usize> = BTreeMap::new();
    let key = PointRow::instant;
    for r in &rows {
        *count.entry(key(&r.record)).or_default() += 1;
    }
    Ok(rows
        .into_iter()
        .map(|r| r.record)
        .filter(|p| count[&key(p)] == spheres)
        .collect())
}

/// Measure a campaign into `out` (`points.csv`), with `poses.csv` and
/// `problems.csv` beside it, through `output`: the caller has declared its
/// inputs there and whether existing outputs may be replaced (`--force`,
/// which also discards a partial output); this adds the campaign's manifest
/// and images as inputs and the outputs, locks the output folder for the
/// run, resumes a partial output of the same inputs and options, and checks
/// the plan before writing. `progress(done, total)` is called as instants
/// finish.
pub fn measure(
    inputs: &Inputs<'_>,
    out: &Path,
    options: &MeasureOptions,
    backend: &dyn Backend,
    output: &mut OutputPlan,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Summary> {
    options.extract.validate()?;
    let rig = RigModel::new(inputs.rig)?;
    let assumed_ideal = rig.assumed_ideal();
    let plans = plan(inputs.manifest, &rig, inputs.spheres, options.all_cameras)?;
    let partial = with_suffix(out, ".partial");
    let sidecar = with_suffix(out, ".resume.json");
    let poses_path = beside(out, "poses.csv");
    let problems_path = beside(out, "problems.csv");
    output
        .input(inputs.manifest)
        .inputs(plans.iter().flat_map(|p| p.images.values()))
        .file(out)
        .file(&poses_path)
        .file(&problems_path)
        .state(&partial)
        .state(&sidecar);
    output.lock(formats::output::folder_of(out), "measure")?;
    let print = fingerprint(inputs, options)?;

    // Resume or start afresh.
    let mut done_rows: Vec<PointRow> = Vec::new();
    if partial.exists() && !output.force() {
        let previous: Option<Fingerprint> = formats::read_json(&sidecar).ok();
        if previous.as_ref() != Some(&print) {
            return Err(FuseError::ResumeMismatch(partial));
        }
        output.resume();
        done_rows = load_partial(&partial, inputs.spheres.len())?;
    }
    output.check()?;
    output.write_json(&sidecar, &print)?;
    // Rewrite the partial with the complete instants only, then append to it.
    output.write_records(&partial, &done_rows)?;
    let index_of: HashMap<InstantKey, usize> = plans.iter().map(|p| (p.key, p.index)).collect();
    let done: std::collections::HashSet<InstantKey> = done_rows
        .iter()
        .map(PointRow::instant)
        .filter(|k| index_of.contains_key(k))
        .collect();
    let resumed = done.len();

    let reach_mm = 0.5 * extent(&plans) + SPHERE_LAYOUT_MM;
    let ctx = Context {
        reach_mm,
        rig,
        spheres: inputs.spheres,
        diameters: inputs.spheres.iter().map(|s| s.diameter).collect(),
        options: *options,
        backend,
        readers: Mutex::new(Vec::new()),
    };
    let todo: Vec<&InstantPlan> = plans.iter().filter(|p| !done.contains(&p.key)).collect();

    // References of the seed's fusion: the first instant of each line.
    let mut references: HashMap<LineKey, std::result::Result<Reference, String>> = HashMap::new();
    if options.fusion == Fusion::Seed {
        let mut firsts: BTreeMap<LineKey, &InstantPlan> = BTreeMap::new();
        for p in &plans {
            firsts.entry(p.line).or_insert(p);
        }
        let computed: Vec<(LineKey, std::result::Result<Reference, String>)> = firsts
            .into_par_iter()
            .map(|(line, ip)| {
                let r = ctx
                    .observe_instant(ip)
                    .and_then(|(_, observations)| {
                        ctx.triangulate_all(&ip.key, &observations)
                            .map(|points| Reference {
                                observations,
                                points,
                            })
                    })
                    .map_err(|f| f.reason);
                (line, r)
            })
            .collect();
        references.extend(computed);
    }

    let total = plans.len() as u64;
    progress(resumed as u64, total);
    let mut appender = std::fs::OpenOptions::new()
        .append(true)
        .open(&partial)
        .map_err(|e| formats::FormatError::io(&partial, e))?;
    let mut problems: Vec<(usize, InstantProblemRow)> = Vec::new();
    let mut finished = resumed as u64;
    for chunk in todo.chunks(CHUNK_INSTANTS) {
        let results: Vec<std::result::Result<Vec<PointRow>, Failure>> = chunk
            .par_iter()
            .map(|ip| measure_one(&ctx, ip, &references))
            .collect();
        let mut bytes = Vec::new();
        {
            let mut w = csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(&mut bytes);
            for (ip, r) in chunk.iter().zip(results) {
                match r {
                    Ok(rows) => {
                        for row in rows {
                            w.serialize(row)
                                .map_err(|e| formats::FormatError::file(&partial, e.to_string()))?;
                        }
                    }
                    Err(problem) => problems.push((ip.index, problem)),
                }
            }
            w.flush()
                .map_err(|e| formats::FormatError::io(&partial, e))?;
        }
        appender
            .write_all(&bytes)
            .and_then(|()| appender.sync_data())
            .map_err(|e| formats::FormatError::io(&partial, e))?;
        finished += chunk.len() as u64;
        progress(finished, total);
    }
    drop(appender);

    // Final outputs, in manifest order, atomically.
    let mut rows = load_partial(&partial, inputs.spheres.len())?;
    let sphere_rank: HashMap<&str, usize> = inputs
        .spheres
        .iter()
        .enumerate()
        .map(|(i, s)| (s.name.as_str(), i))
        .collect();
    let rank = |p: &PointRow| {
        let key = p.instant();
        (
            index_of.get(&key).copied().unwrap_or(usize::MAX),
            sphere_rank
                .get(p.sphere.as_str())
                .copied()
                .unwrap_or(usize::MAX),
        )
    };
    rows.sort_by_key(rank);
    output.write_records(out, &rows)?;
    let names: Vec<String> = inputs.spheres.iter().map(|s| s.name.clone()).collect();
    output.write_records(&poses_path, &poses(&rows, &names))?;
    problems.sort_by_key(|(i, _)| *i);
    let problems_file = if problems.is_empty() {
        // One left by the interrupted run this one resumed, or replaced with --force.
        output.remove(&problems_path)?;
        None
    } else {
        let list: Vec<InstantProblemRow> = problems.iter().map(|(_, p)| p.clone()).collect();
        output.write_records(&problems_path, &list)?;
        Some(problems_path)
    };
    for f in [&partial, &sidecar] {
        std::fs::remove_file(f).map_err(|e| formats::FormatError::io(f, e))?;
    }
    Ok(Summary {
        instants: plans.len(),
        measured: rows.len() / inputs.spheres.len().max(1),
        resumed,
        problems: problems.len(),
        points: out.to_path_buf(),
        problems_file,
        poses: poses_path,
        assumed_ideal_lens: assumed_ideal,
    })
}
