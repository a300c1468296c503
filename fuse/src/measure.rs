//! The `measure` batch: every instant of a campaign → sphere centres in
//! `points.csv`, what could not be measured → `points.problems.csv`, table
//! poses → `points.poses.csv` (sidecars named after the output's stem).
//!
//! The manifest is checked in full before work starts ([`crate::plan`]).
//! Instants are measured in parallel, a chunk at a time, and their rows are
//! appended to `points.csv.partial` after each chunk (all rows of an instant
//! in one write), with a fingerprint of the inputs and options beside it. An
//! interrupted run started again with the same inputs resumes: instants with
//! every sphere from every camera are kept, the rest (failed, lacking a
//! sphere or a camera, or torn by the interruption) is measured again. At
//! the end every instant's residual is checked against the campaign's own
//! scatter ([`crate::plausibility`]) —
//! over the rows of the partial file, so a resumed run draws the same line —
//! the rows are sorted into manifest order and every output is written
//! atomically; the partial files are removed.
//!
//! An instant's outcome is one of: every sphere in `points.csv` and its pose
//! in the poses; some spheres in `points.csv` (a sphere clipped by the
//! image border or out of a camera's view), a problems row per missing
//! sphere and camera, no pose; or no rows and one problems row (too few
//! frames that can be read, no sphere seen by enough cameras, an
//! implausible residual).
//!
//! A camera that cannot serve an instant — its frame unreadable, or a sphere
//! it does not find — is left out where the others suffice: each sphere is
//! triangulated from the cameras that found it, two or more (`cameras` in
//! `points.csv` names them), and a `camera` row of the problems file names
//! the camera, its image and why (`missing` = `camera`: nothing is missing
//! from the outputs but that camera's view; the instant is in `points.csv`).
//! With the default two cameras per axis one left out leaves one, too few;
//! with `all_cameras` the other two triangulate the instant (the seed's
//! fusion needs every camera used).

use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use extract::{Backend, Covariance, CovarianceForm, ExtractParams, FrameReader, FrameView};
use formats::{
    InstantKey, InstantProblemRow, LineKey, Missing, ObservationRow, OutputPlan, PointRow,
    SphereRow, read_csv_from,
};
use geom::nalgebra::Matrix2;
use geom::{Matrix3, Point2, Point3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::matching::{SphereMatch, assign};
use crate::noise::{self as noise_model, CameraNoise};
use crate::observe::{Candidate, candidates};
use crate::plan::{InstantPlan, RigModel, plan};
use crate::plausibility::ResidualGate;
use crate::pose::poses;
use crate::triangulate::seed_displacement;
use crate::{FuseError, Result};
use geom::triangulate::{View, centre_covariance, parameter_image_covariance, triangulate};

mod outputs;
use outputs::{Appender, Paths, gated_rows, resume, write_outputs};
mod repeats;

/// Allowance for the spheres' layout on the table around its reference point (mm).
pub const SPHERE_LAYOUT_MM: f64 = 50.0;

/// Instants measured between two appends to the partial output (at most).
const CHUNK_INSTANTS: usize = 16;

/// How sphere centres are computed from the cameras' images.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Fusion {
    /// Rigorous triangulation: linear, then least squares on the reprojection error.
    #[default]
    Triangulate,
    /// The source method's pixel-scale fusion relative to the first instant of each line.
    #[serde(alias = "Seed")]
    PixelScale,
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
    /// Per camera id, the sensor's per-pixel maps every frame of that camera
    /// is corrected with before extraction (`rig.json`'s `sensor`); a camera
    /// without maps is used as it is.
    pub sensor: &'a BTreeMap<u8, sensor::SensorMaps>,
}

/// What a measurement did.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Instants in the campaign.
    pub instants: usize,
    /// Instants with sphere centres in `points.csv` (all spheres or some).
    pub measured: usize,
    /// Of those, instants lacking a sphere (and so their pose).
    pub partial: usize,
    /// Instants with every sphere but without a pose.
    pub without_pose: usize,
    /// Instants measured without one of their cameras (or without it for a
    /// sphere): each has a `camera` row in the problems file.
    pub reduced: usize,
    /// Instants with complete rows kept from an interrupted earlier run.
    pub resumed: usize,
    /// Instants refused as implausible (counted in `instants − measured`).
    pub implausible: usize,
    /// The residual limit the instants were held to; `None` when none was measured.
    pub gate: Option<ResidualGate>,
    /// Rows of the problems file.
    pub problems: usize,
    /// The first problem in manifest order (its image and reason), when there were problems.
    pub first_problem: Option<String>,
    /// `points.csv`.
    pub points: PathBuf,
    /// `<stem>.problems.csv`, when there were problems (it is written
    /// always, its header alone when there were none).
    pub problems_file: Option<PathBuf>,
    /// `<stem>.poses.csv`.
    pub poses: PathBuf,
    /// Cameras whose relative illumination is the assumed ideal lens (no
    /// flat-field model in `rig.json`).
    pub assumed_ideal_lens: Vec<u8>,
    /// Cameras whose lens bends too fast for any lattice of interpolated
    /// nodes (`extract::Lattice::spacing_px`): their pixels are mapped
    /// exactly, one by one, which is many times slower.
    pub mapped_pixel_by_pixel: Vec<u8>,
    /// Each camera's noise model, which the centroids' covariances in
    /// `<stem>.observations.csv` come from.
    pub noise: BTreeMap<u8, CameraNoise>,
    /// Per camera, the sphere images this run measured from and how many of
    /// them are saturated (resumed instants not counted).
    pub saturation: BTreeMap<u8, Saturation>,
    /// Frames this run decoded: each image it uses once.
    pub frames_read: usize,
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

/// One camera's image of a sphere: its centre in ideal pixels, the
/// centre's covariance from the image noise (px²) when the camera's noise
/// is known (its form linear in K while K is being estimated), and whether
/// some of its pixels are at the sensor's maximum.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Observed {
    ideal: Point2<f64>,
    covariance: Option<Matrix2<f64>>,
    covariance_form: Option<CovarianceForm>,
    saturated: bool,
}

/// `[[var u, cov], [cov, var v]]` of a centroid's covariance.
fn covariance_matrix(c: &extract::CentroidCovariance) -> Matrix2<f64> {
    Matrix2::new(c.uu_px2, c.uv_px2, c.uv_px2, c.vv_px2)
}

/// What one camera's image of an instant shows of every sphere
/// ([`Context::observe`]), or why it cannot be used at all.
type Observation = std::result::Result<Vec<std::result::Result<Observed, Failure>>, Failure>;

/// Of one camera's sphere images that the points were measured from, how
/// many have saturated pixels: their flat tops bias the centre and hide the
/// noise's rise with the signal (no covariance), so a run with any is said
/// to need a lower exposure.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Saturation {
    /// Sphere images used.
    pub images: usize,
    /// Of those, images with saturated pixels.
    pub saturated: usize,
}

/// The image of one sphere seen by each camera used.
type Seen = BTreeMap<u8, Observed>;

/// Ideal-pixel centres of a sphere's images.
fn ideal_centres(seen: &Seen) -> BTreeMap<u8, Point2<f64>> {
    seen.iter().map(|(&c, o)| (c, o.ideal)).collect()
}

/// Fewest cameras a sphere is triangulated from.
const MIN_VIEWS: usize = 2;

/// What the cameras of an instant saw: how many cameras are used, those
/// whose frames could not be used at all (the row saying why), how many
/// could, and per sphere its image centres in the cameras that found it with
/// a row per camera that did not.
#[derive(Clone)]
struct Sight {
    cams: usize,
    left_out: Vec<Failure>,
    usable: usize,
    spheres: Vec<(Seen, Vec<Failure>)>,
}

/// `2+3`: the cameras of a `points.csv` row.
fn camera_set<'a>(cams: impl IntoIterator<Item = &'a u8>) -> String {
    cams.into_iter()
        .map(u8::to_string)
        .collect::<Vec<_>>()
        .join("+")
}

/// The note for a camera left out of an instant that is measured without it:
/// `row` (why the camera could not serve it, or a sphere of it) as a
/// `camera` row; `measured` says from what the rest was measured.
fn left_out(row: Failure, measured: &str) -> Failure {
    let camera = row
        .camera
        .map(|c| format!("camera {c} "))
        .unwrap_or_default();
    InstantProblemRow {
        missing: Missing::Camera,
        reason: format!("{camera}left out: {}; {measured}", row.reason),
        ..row
    }
}

/// A sphere's reference for the pixel-scale fusion: its image centres and
/// triangulated centre at the first instant of the line that measured it.
type SphereReference = std::result::Result<(Seen, Point3<f64>), String>;

/// The pixel-scale fusion's references per line and sphere, and what the
/// instants looked at to find them saw: each is measured from that, not
/// decoded again.
#[derive(Default)]
struct References {
    lines: HashMap<LineKey, Vec<SphereReference>>,
    seen: Mutex<HashMap<InstantKey, Sight>>,
}

impl References {
    /// What `ip`'s cameras see: as seen while finding the references, or
    /// looked at now.
    fn sight(&self, ctx: &Context<'_>, ip: &InstantPlan) -> Sight {
        self.seen
            .lock()
            .ok()
            .and_then(|mut seen| seen.remove(&ip.key))
            .unwrap_or_else(|| ctx.observe_instant(ip))
    }
}

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
    /// Frames decoded so far.
    frames_read: std::sync::atomic::AtomicUsize,
    sensor: &'a BTreeMap<u8, sensor::SensorMaps>,
    /// Each camera's noise model (the centroids' covariances).
    noise: BTreeMap<u8, CameraNoise>,
    /// Cameras' images observed ahead of their instants (while reading
    /// them for K, [`Context::noise_models`]), taken by
    /// [`Context::observe`] instead of reading them again.
    observed: Mutex<HashMap<(InstantKey, u8), Observation>>,
    /// Each camera's lattice of exactly mapped nodes, solved once a run
    /// (`extract::Lattice`).
    lattices: BTreeMap<u8, extract::Lattice>,
}

impl<'a> Context<'a> {
    fn new(
        rig: RigModel,
        plans: &[InstantPlan],
        inputs: &Inputs<'a>,
        options: &MeasureOptions,
        backend: &'a dyn Backend,
    ) -> Self {
        let spheres = inputs.spheres;
        let lattices = rig
            .cameras
            .iter()
            .map(|(&id, camera)| (id, extract::Lattice::new(camera)))
            .collect();
        Self {
            lattices,
            reach_mm: 0.5 * extent(plans) + SPHERE_LAYOUT_MM,
            rig,
            spheres,
            diameters: spheres.iter().map(|s| s.diameter).collect(),
            options: *options,
            backend,
            readers: Mutex::new(Vec::new()),
            frames_read: std::sync::atomic::AtomicUsize::new(0),
            sensor: inputs.sensor,
            noise: BTreeMap::new(),
            observed: Mutex::new(HashMap::new()),
        }
    }
}

/// A row for problems.csv.
type Failure = InstantProblemRow;

/// Why a frame's blobs were rejected as sphere images, for messages:
/// `; rejected: touches the image border (1)`.
fn rejections(cands: &[Candidate]) -> String {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for c in cands {
        if let Some(r) = c.rejected {
            *counts.entry(r).or_default() += 1;
        }
    }
    if counts.is_empty() {
        return String::new();
    }
    let list: Vec<String> = counts.iter().map(|(r, n)| format!("{r} ({n})")).collect();
    format!("; rejected: {}", list.join(", "))
}

fn plural(n: usize, word: &str) -> String {
    format!("{n} {word}{}", if n == 1 { "" } else { "s" })
}

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

    /// A row for a sphere of the instant that camera `camera` did not find.
    fn sphere_failure(
        &self,
        key: &InstantKey,
        sphere: usize,
        camera: Option<u8>,
        image: Option<&Path>,
        reason: &str,
    ) -> Failure {
        let name = &self.spheres[sphere].name;
        InstantProblemRow::of(
            key,
            Missing::Sphere,
            Some(name.clone()),
            camera,
            image.map(|p| p.display().to_string()),
            format!("sphere {name} {reason}"),
        )
    }

    /// Extract and match one camera's image: per sphere its ideal-pixel
    /// centre, or the row saying why the image does not show it. A frame
    /// that cannot be used at all fails the whole instant. An image
    /// observed already (read for K) is not read again.
    fn observe(&self, ip: &InstantPlan, camera: u8) -> Observation {
        let ahead = self
            .observed
            .lock()
            .ok()
            .and_then(|mut o| o.remove(&(ip.key, camera)));
        if let Some(observation) = ahead {
            return observation;
        }
        let covariance = Covariance::at_gain(self.noise.get(&camera).and_then(|n| n.gain_dn_per_e));
        self.with_frame(ip, camera, |path, raw, _| {
            self.observe_frame(ip, camera, path, raw, covariance)
        })
    }

    /// Camera `camera`'s image of `ip` decoded (with a reader of the pool)
    /// and given to `then` with its path and metadata; the failure of the
    /// whole instant when there is no such image or it cannot be read.
    fn with_frame<R>(
        &self,
        ip: &InstantPlan,
        camera: u8,
        then: impl FnOnce(
            &Path,
            FrameView<'_>,
            &extract::FrameMetadata,
        ) -> std::result::Result<R, Failure>,
    ) -> std::result::Result<R, Failure> {
        let key = &ip.key;
        let path = ip.images.get(&camera).ok_or_else(|| {
            Self::failure(
                key,
                Some(camera),
                None,
                format!("no image of camera {camera}"),
            )
        })?;
        if self.camera_model(camera).is_none() {
            return Err(Self::failure(
                key,
                Some(camera),
                Some(path),
                format!("camera {camera} is not in the rig"),
            ));
        }
        let mut reader = self
            .readers
            .lock()
            .ok()
            .and_then(|mut r| r.pop())
            .unwrap_or_else(|| FrameReader::new().limit_pixels(self.options.extract.max_pixels));
        let result = match reader.read(path) {
            Ok((raw, metadata)) => {
                self.frames_read
                    .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                then(path, raw, &metadata)
            }
            Err(e) => Err(Self::failure(key, Some(camera), Some(path), e.to_string())),
        };
        if let Ok(mut r) = self.readers.lock() {
            r.push(reader);
        }
        result
    }

    /// Camera `camera`'s model, its lens's relative illumination and its
    /// lattice.
    fn camera_model(
        &self,
        camera: u8,
    ) -> Option<(&geom::Camera, &geom::Illumination, &extract::Lattice)> {
        let ((cam, illumination), lattice) = self
            .rig
            .cameras
            .get(&camera)
            .zip(self.rig.illumination.get(&camera))
            .zip(self.lattices.get(&camera))?;
        Some((cam, illumination, lattice))
    }

    /// [`Context::observe`] of the decoded image `raw` (from `path`), its
    /// centroids' covariances as wanted.
    fn observe_frame(
        &self,
        ip: &InstantPlan,
        camera: u8,
        path: &Path,
        raw: FrameView<'_>,
        covariance: Covariance,
    ) -> Observation {
        let key = &ip.key;
        let fail = |reason: String| Self::failure(key, Some(camera), Some(path), reason);
        let (cam, illumination, lattice) = self
            .camera_model(camera)
            .ok_or_else(|| fail(format!("camera {camera} is not in the rig")))?;
        let corrected = raw
            .corrected(self.sensor.get(&camera))
            .map_err(|e| fail(e.in_file(path).to_string()))?;
        let frame = corrected.as_ref().map_or(raw, extract::Frame::view);
        let extraction = self
            .backend
            .extract(frame, &self.options.extract)
            .map_err(|e| fail(e.in_file(path).to_string()))?;
        let cands = candidates(
            cam,
            illumination,
            lattice,
            &frame,
            &extraction,
            self.options.extract.weighting,
            covariance,
        );
        let wd = self.rig.working_distance(camera).unwrap_or(1.0);
        let range = ((wd - self.reach_mm).max(0.1 * wd), wd + self.reach_mm);
        let blobs = plural(extraction.blobs.len(), "blob");
        Ok(assign(&cands, &self.diameters, cam.intrinsics.fx, range)
            .into_iter()
            .enumerate()
            .map(|(s, m)| match m {
                SphereMatch::Found(c) => Ok(Observed {
                    ideal: cands[c].ideal_px,
                    // Candidates are the extraction's blobs, in order.
                    saturated: extraction
                        .blobs
                        .get(c)
                        .is_some_and(extract::Blob::saturated),
                    covariance: cands[c].covariance.as_ref().map(covariance_matrix),
                    covariance_form: cands[c].covariance_form,
                }),
                SphereMatch::Missing => Err(self.sphere_failure(
                    key,
                    s,
                    Some(camera),
                    Some(path),
                    &format!(
                        "not found among {blobs}{}{}",
                        rejections(&cands),
                        extraction
                            .saturation_note(frame.max_value())
                            .map(|n| format!(" ({n})"))
                            .unwrap_or_default()
                    ),
                )),
                SphereMatch::Ambiguous => Err(self.sphere_failure(
                    key,
                    s,
                    Some(camera),
                    Some(path),
                    &format!("ambiguous: {blobs} fit the sphere diameters in more than one way"),
                )),
            })
            .collect())
    }

    /// What the cameras used for this instant see of every sphere. A
    /// camera whose frame cannot be used is left out; once fewer cameras
    /// than a sphere needs can remain, the rest are not looked at.
    fn observe_instant(&self, ip: &InstantPlan) -> Sight {
        let cams = self.rig.cameras_for(ip.key.axis, self.options.all_cameras);
        let mut sight = Sight {
            cams: cams.len(),
            left_out: Vec::new(),
            usable: 0,
            spheres: vec![(BTreeMap::new(), Vec::new()); self.spheres.len()],
        };
        for &c in &cams {
            if cams.len() - sight.left_out.len() < self.views_needed(cams.len()) {
                break;
            }
            match self.observe(ip, c) {
                Ok(seen) => {
                    sight.usable += 1;
                    for ((views, misses), outcome) in sight.spheres.iter_mut().zip(seen) {
                        match outcome {
                            Ok(p) => {
                                views.insert(c, p);
                            }
                            Err(f) => misses.push(f),
                        }
                    }
                }
                Err(f) => sight.left_out.push(f),
            }
        }
        sight
    }

    /// Cameras a sphere is measured from, of the `cams` used: two or more
    /// for triangulation; every one for the pixel-scale fusion, whose pixel-scale
    /// model fails for the camera that looks along the motion, which is what
    /// would remain of `all_cameras` without one of the others.
    fn views_needed(&self, cams: usize) -> usize {
        match self.options.fusion {
            Fusion::Triangulate => MIN_VIEWS,
            Fusion::PixelScale => cams,
        }
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

    /// Triangulated centre and residual of one sphere.
    fn triangulate_one(
        &self,
        sphere: usize,
        seen: &Seen,
    ) -> std::result::Result<(Point3<f64>, f64), String> {
        triangulate(&self.views(&ideal_centres(seen)), self.radius(sphere))
            .map(|t| (t.point, t.residual_px))
            .map_err(|e| e.to_string())
    }

    /// Standard uncertainties (mm) of a sphere centre `x` from its images'
    /// noise (when every image's covariance is known) and from the cameras'
    /// calibration (when every camera's covariance is in the rig), to first
    /// order (`geom::triangulate::centre_covariance`).
    fn centre_uncertainty(
        &self,
        sphere: usize,
        seen: &Seen,
        x: &Point3<f64>,
    ) -> (Option<[f64; 3]>, Option<[f64; 3]>) {
        let views = self.views(&ideal_centres(seen));
        let radius = self.radius(sphere);
        let sd = |c: Matrix3<f64>| [0, 1, 2].map(|i| c[(i, i)].max(0.0).sqrt());
        let noise: Option<Vec<Matrix2<f64>>> = seen.values().map(|o| o.covariance).collect();
        let random = noise
            .and_then(|n| centre_covariance(&views, radius, x, &n))
            .map(sd);
        let calibration: Option<Vec<Matrix2<f64>>> = seen
            .iter()
            .map(|(c, o)| {
                let camera = self.rig.cameras.get(c)?;
                let (names, cov) = self.rig.covariance.get(c)?;
                parameter_image_covariance(camera, names, cov, x, radius, o.ideal)
            })
            .collect();
        let calibration = calibration
            .and_then(|c| centre_covariance(&views, radius, x, &c))
            .map(sd);
        (random, calibration)
    }

    /// The pixel-scale fusion of one sphere against its reference: the reference
    /// centre plus the pixel-scale displacement. The residual is, as for
    /// triangulation, the RMS reprojection residual of this instant's images
    /// at their least-squares centre: how well the images agree, whatever the
    /// seed's model makes of them.
    fn seed_one(
        &self,
        sphere: usize,
        seen: &Seen,
        reference: &SphereReference,
    ) -> std::result::Result<(Point3<f64>, f64), String> {
        let (seen0, p0) = reference.as_ref().map_err(Clone::clone)?;
        let r0 = self.debiased(sphere, &ideal_centres(seen0), p0);
        let r1 = self.debiased(sphere, &ideal_centres(seen), p0);
        let depths: Vec<f64> = r0
            .keys()
            .filter_map(|c| self.rig.cameras.get(c).map(|cam| cam.to_camera(p0).z))
            .collect();
        let (d, _) = seed_displacement(&self.views(&r0), &self.views(&r1), &depths)
            .map_err(|e| e.to_string())?;
        let (_, residual) = self.triangulate_one(sphere, seen)?;
        Ok((p0 + d, residual))
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

/// A sphere's fused centre: the point, its residual (px), the cameras it
/// was measured from (`2+3`), the images it was fused from and its standard
/// uncertainties (mm) from the images' noise and from the calibration.
#[derive(Debug, Clone)]
struct Fused {
    point: Point3<f64>,
    residual_px: f64,
    cameras: String,
    seen: Seen,
    u_random: Option<[f64; 3]>,
    u_calibration: Option<[f64; 3]>,
}

fn rows_for(key: &InstantKey, spheres: &[SphereRow], centres: &[Option<Fused>]) -> Vec<PointRow> {
    spheres
        .iter()
        .zip(centres)
        .filter_map(|(s, c)| c.as_ref().map(|f| (s, f)))
        .map(|(s, f)| {
            let centre = [f.point.x, f.point.y, f.point.z];
            PointRow::new(*key, &s.name, centre, &f.cameras, f.residual_px)
                .with_uncertainty(f.u_random, f.u_calibration)
        })
        .collect()
}

/// The `observations.csv` rows of an instant's fused spheres: each image a
/// centre was fused from, with the radius its image model used.
fn observations_for(
    key: &InstantKey,
    spheres: &[SphereRow],
    centres: &[Option<Fused>],
    radius: impl Fn(usize) -> f64,
) -> Vec<ObservationRow> {
    let [nx, ny, nz] = key.nominal();
    let mut rows = Vec::new();
    for (i, (s, f)) in spheres.iter().zip(centres).enumerate() {
        let Some(f) = f else { continue };
        for (&camera, o) in &f.seen {
            let (su, sv, rho) = match o.covariance {
                Some(c) => {
                    let (su, sv) = (c[(0, 0)].max(0.0).sqrt(), c[(1, 1)].max(0.0).sqrt());
                    let rho = if su > 0.0 && sv > 0.0 {
                        (c[(0, 1)] / (su * sv)).clamp(-1.0, 1.0)
                    } else {
                        0.0
                    };
                    (Some(su), Some(sv), Some(rho))
                }
                None => (None, None, None),
            };
            rows.push(ObservationRow {
                axis: key.axis,
                direction: key.direction,
                run: key.run,
                target: key.target,
                capture: key.capture,
                nominal_x: nx,
                nominal_y: ny,
                nominal_z: nz,
                sphere: s.name.clone(),
                camera,
                radius_mm: radius(i),
                u: o.ideal.x,
                v: o.ideal.y,
                u_sigma_px: su,
                v_sigma_px: sv,
                uv_correlation: rho,
            });
        }
    }
    rows
}

/// One problem row for an instant none of whose spheres could be measured,
/// from the rows of its cameras and spheres: the spheres that share a camera
/// and a reason are named together (`spheres A, B not found among 1 blob`);
/// a camera's own row (a frame that cannot be used) keeps its reason.
fn whole_instant(key: &InstantKey, misses: Vec<Failure>) -> Failure {
    // (camera, image, reason, spheres)
    type Group = (Option<u8>, Option<String>, String, Vec<String>);
    let mut groups: Vec<Group> = Vec::new();
    for m in misses {
        let (tail, name) = match m.sphere {
            Some(name) => (
                m.reason
                    .strip_prefix(&format!("sphere {name} "))
                    .unwrap_or(&m.reason)
                    .to_string(),
                Some(name),
            ),
            None => (m.reason, None),
        };
        match groups
            .iter_mut()
            .find(|g| g.0 == m.camera && g.1 == m.image && g.2 == tail)
        {
            Some(g) => g.3.extend(name),
            None => groups.push((m.camera, m.image, tail, name.into_iter().collect())),
        }
    }
    let one_camera = groups
        .windows(2)
        .all(|w| w[0].0 == w[1].0 && w[0].1 == w[1].1);
    let text: Vec<String> = groups
        .iter()
        .map(|(camera, _, tail, names)| {
            let what = match names.len() {
                0 => tail.clone(),
                1 => format!("sphere {} {tail}", names[0]),
                _ => format!("spheres {} {tail}", names.join(", ")),
            };
            match camera {
                Some(c) if !one_camera => format!("camera {c}: {what}"),
                _ => what,
            }
        })
        .collect();
    let (camera, image) = match groups.first() {
        Some((c, i, ..)) if one_camera => (*c, i.clone()),
        _ => (None, None),
    };
    InstantProblemRow::new(key, camera, image, text.join("; "))
}

/// What measuring one instant gave: its rows, the images they were fused
/// from and its problems.
struct Outcome {
    rows: Vec<PointRow>,
    observations: Vec<ObservationRow>,
    problems: Vec<Failure>,
    saturation: BTreeMap<u8, Saturation>,
}

fn measure_one(ctx: &Context<'_>, ip: &InstantPlan, references: &References) -> Outcome {
    let sight = references.sight(ctx, ip);
    let needed = ctx.views_needed(sight.cams);
    if sight.usable < needed {
        return Outcome {
            rows: Vec::new(),
            observations: Vec::new(),
            problems: vec![whole_instant(&ip.key, sight.left_out)],
            saturation: BTreeMap::new(),
        };
    }
    let (mut problems, mut notes) = (Vec::new(), Vec::new());
    let mut centres = vec![None; ctx.spheres.len()];
    for (s, (seen, misses)) in sight.spheres.into_iter().enumerate() {
        if seen.len() < needed {
            problems.extend(misses);
            continue;
        }
        let centre = match ctx.options.fusion {
            Fusion::Triangulate => ctx.triangulate_one(s, &seen),
            Fusion::PixelScale => match references.lines.get(&ip.line).and_then(|r| r.get(s)) {
                Some(reference) => ctx.seed_one(s, &seen, reference),
                None => Err("no reference instant for the line".into()),
            },
        };
        match centre {
            Ok((point, residual_px)) => {
                let cameras = camera_set(seen.keys());
                let measured = format!(
                    "sphere {} measured from cameras {cameras}",
                    ctx.spheres[s].name
                );
                notes.extend(misses.into_iter().map(|m| left_out(m, &measured)));
                let (u_random, u_calibration) = ctx.centre_uncertainty(s, &seen, &point);
                centres[s] = Some(Fused {
                    point,
                    residual_px,
                    cameras,
                    seen,
                    u_random,
                    u_calibration,
                });
            }
            Err(e) => {
                problems.extend(misses);
                problems.push(ctx.sphere_failure(
                    &ip.key,
                    s,
                    None,
                    None,
                    &format!("cannot be fused: {e}"),
                ));
            }
        }
    }
    let mut saturation: BTreeMap<u8, Saturation> = BTreeMap::new();
    for (&camera, o) in centres.iter().flatten().flat_map(|c| &c.seen) {
        let tally = saturation.entry(camera).or_default();
        tally.images += 1;
        tally.saturated += usize::from(o.saturated);
    }
    let rows = rows_for(&ip.key, ctx.spheres, &centres);
    let observations = observations_for(&ip.key, ctx.spheres, &centres, |s| ctx.radius(s));
    if rows.is_empty() {
        problems = vec![whole_instant(
            &ip.key,
            sight.left_out.into_iter().chain(problems).collect(),
        )];
    } else {
        let others = "the instant measured from the other cameras";
        problems = sight
            .left_out
            .into_iter()
            .map(|f| left_out(f, others))
            .chain(notes)
            .chain(problems)
            .collect();
    }
    Outcome {
        rows,
        observations,
        problems,
        saturation,
    }
}

/// References of the pixel-scale fusion: per line and sphere, the first instant
/// of the line (manifest order) at which the sphere was measured; with what
/// the instants looked at for them saw.
fn seed_references(ctx: &Context<'_>, plans: &[InstantPlan]) -> References {
    let mut lines: BTreeMap<LineKey, Vec<&InstantPlan>> = BTreeMap::new();
    for p in plans {
        lines.entry(p.line).or_default().push(p);
    }
    let lines: Vec<(LineKey, Vec<&InstantPlan>)> = lines.into_iter().collect();
    let seen = Mutex::new(HashMap::new());
    let lines = in_parallel(&lines, |(line, instants)| {
            let n = ctx.spheres.len();
            let mut found: Vec<Option<(Seen, Point3<f64>)>> = vec![None; n];
            let mut first_failure: Option<String> = None;
            for ip in instants {
                if found.iter().all(Option::is_some) {
                    break;
                }
                let sight = ctx.observe_instant(ip);
                if let Ok(mut seen) = seen.lock() {
                    seen.insert(ip.key, sight.clone());
                }
                if let Some(f) = sight.left_out.into_iter().next() {
                    first_failure.get_or_insert(f.reason);
                    continue;
                }
                for (s, (seen, misses)) in sight.spheres.into_iter().enumerate() {
                    if found[s].is_some() {
                        continue;
                    }
                    if !misses.is_empty() {
                        first_failure.get_or_insert(
                            misses.into_iter().map(|f| f.reason).collect::<Vec<_>>().join("; "),
                        );
                        continue;
                    }
                    match ctx.triangulate_one(s, &seen) {
                        Ok((p, _)) => found[s] = Some((seen, p)),
                        Err(e) => {
                            first_failure.get_or_insert(e);
                        }
                    }
                }
            }
            let refs = found
                .into_iter()
                .enumerate()
                .map(|(s, f)| {
                    f.ok_or_else(|| {
                        format!(
                            "no instant of the line measured sphere {}, which the pixel-scale fusion needs as its reference{}",
                            ctx.spheres[s].name,
                            first_failure
                                .as_deref()
                                .map(|r| format!(" (first problem: {r})"))
                                .unwrap_or_default()
                        )
                    })
                })
                .collect();
            (*line, refs)
        })
        .into_iter()
        .collect();
    References { lines, seen }
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

/// Each instant's residual — the largest of its spheres', with that sphere
/// and the cameras — in instant order.
fn instant_residuals(rows: &[PointRow]) -> BTreeMap<InstantKey, (f64, &str, &str)> {
    let mut worst: BTreeMap<InstantKey, (f64, &str, &str)> = BTreeMap::new();
    for r in rows {
        let w = worst
            .entry(r.instant())
            .or_insert((f64::NEG_INFINITY, "", ""));
        // Larger, or NaN: a NaN residual is the worst.
        if !matches!(
            r.residual_px.partial_cmp(&w.0),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        ) {
            *w = (r.residual_px, r.sphere.as_str(), r.cameras.as_str());
        }
    }
    worst
}

/// The instants the gate refuses, with the problem row of each: residuals
/// above the campaign's limit and above the limit of their commanded
/// position (the other instants of the same axis at the same nominal
/// coordinates), or above the ceiling.
fn implausible(
    residuals: &BTreeMap<InstantKey, (f64, &str, &str)>,
    gate: &ResidualGate,
) -> BTreeMap<InstantKey, Failure> {
    // (axis, commanded position bits) → the instants there with their residuals.
    type AtPosition = BTreeMap<(formats::Axis, [u64; 3]), Vec<(InstantKey, f64)>>;
    let mut at_position: AtPosition = BTreeMap::new();
    for (key, (r, ..)) in residuals {
        at_position
            .entry((key.axis, key.nominal_bits))
            .or_default()
            .push((*key, *r));
    }
    let mut refused = BTreeMap::new();
    for (key, (residual, sphere, cameras)) in residuals {
        let others: Vec<f64> = at_position[&(key.axis, key.nominal_bits)]
            .iter()
            .filter(|(k, _)| k != key)
            .map(|(_, r)| *r)
            .collect();
        let limit = gate.limit_at(&others);
        if *residual <= limit.limit_px {
            continue;
        }
        let reason = format!(
            "implausible: reprojection residual {residual:.4} px (sphere {sphere}, cameras {cameras}) \
             above the {}: images of another instant or camera?",
            gate.explain(&limit)
        );
        refused.insert(*key, InstantProblemRow::new(key, None, None, reason));
    }
    refused
}

/// Measure a campaign into `out` (`points.csv`), with `<stem>.poses.csv` and
/// `<stem>.problems.csv` beside it, through `output`: the caller has declared its
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
    // The plan, checked in full before any work.
    options.extract.validate()?;
    let rig = RigModel::new(inputs.rig)?;
    let assumed_ideal = rig.assumed_ideal();
    let plans = plan(inputs.manifest, &rig, inputs.spheres, options.all_cameras)?;
    let paths = Paths::of(out);
    output
        .input(inputs.manifest)
        .inputs(plans.iter().flat_map(|p| p.images.values()))
        .file(out)
        .file(&paths.poses)
        .file(&paths.problems)
        .file(&paths.observations)
        .state(&paths.partial)
        .state(&paths.observations_partial)
        .state(&paths.sidecar);
    output.lock(formats::folder_of(out), "measure")?;
    // Resume or start afresh.
    let done_rows = resume(inputs, options, &rig, &paths, output)?;
    let index_of: HashMap<InstantKey, usize> = plans.iter().map(|p| (p.key, p.index)).collect();
    let done: std::collections::HashSet<InstantKey> = done_rows
        .iter()
        .map(PointRow::instant)
        .filter(|k| index_of.contains_key(k))
        .collect();
    let resumed = done.len();

    // Every instant not done, in parallel chunks appended to the partial file.
    let ctx = {
        let mut ctx = Context::new(rig, &plans, inputs, options, backend);
        ctx.noise_models(inputs.rig, &plans, &done);
        ctx
    };
    let todo: Vec<&InstantPlan> = plans.iter().filter(|p| !done.contains(&p.key)).collect();
    let references = if options.fusion == Fusion::PixelScale {
        seed_references(&ctx, &plans)
    } else {
        References::default()
    };
    let total = plans.len() as u64;
    progress(resumed as u64, total);
    let mut saturation = BTreeMap::new();
    let mut problems = measure_chunks(
        &ctx,
        &todo,
        &references,
        &paths,
        &mut saturation,
        |finished| progress(resumed as u64 + finished, total),
    )?;

    // The plausibility gate over every row written, this run's and the resumed one's.
    let (mut rows, gate, refused) = gated_rows(&paths.partial, &index_of)?;
    let implausible_count = refused.len();
    // A refused instant is not in points.csv: no note of a camera left out of it.
    problems.retain(|(_, p)| !(p.missing == Missing::Camera && refused.contains_key(&p.instant())));
    let reduced = problems
        .iter()
        .filter(|(_, p)| p.missing == Missing::Camera)
        .map(|(_, p)| p.instant())
        .collect::<std::collections::HashSet<_>>()
        .len();
    problems.extend(refused.into_iter().map(|(key, p)| (index_of[&key], p)));

    // Final outputs, in manifest order, atomically.
    let written = write_outputs(&mut rows, problems, &index_of, inputs, out, &paths, output)?;
    let mut per_instant: HashMap<InstantKey, usize> = HashMap::new();
    for r in &rows {
        *per_instant.entry(r.instant()).or_default() += 1;
    }
    Ok(Summary {
        instants: plans.len(),
        measured: per_instant.len(),
        partial: per_instant
            .values()
            .filter(|&&n| n < inputs.spheres.len())
            .count(),
        without_pose: written.without_pose,
        reduced,
        resumed,
        implausible: implausible_count,
        gate,
        problems: written.problems,
        first_problem: written.first_problem,
        points: out.to_path_buf(),
        problems_file: written.problems_file,
        poses: paths.poses,
        assumed_ideal_lens: assumed_ideal,
        mapped_pixel_by_pixel: ctx
            .lattices
            .iter()
            .filter(|(_, lattice)| lattice.spacing_px().is_none())
            .map(|(&id, _)| id)
            .collect(),
        noise: ctx.noise.clone(),
        saturation,
        frames_read: ctx.frames_read.into_inner(),
    })
}

/// Measure `todo` a chunk at a time in parallel, appending each chunk's
/// images to the observations' partial file and then its rows to the
/// points' (each synced; a kept instant so has its images) and calling
/// `finished(instants so far)`; returns the problems with their instants'
/// manifest indices, and adds each camera's saturated images to `saturation`.
fn measure_chunks(
    ctx: &Context<'_>,
    todo: &[&InstantPlan],
    references: &References,
    paths: &Paths,
    saturation: &mut BTreeMap<u8, Saturation>,
    finished: impl Fn(u64),
) -> Result<Vec<(usize, InstantProblemRow)>> {
    let mut points = Appender::open(&paths.partial)?;
    let mut images = Appender::open(&paths.observations_partial)?;
    let mut problems: Vec<(usize, InstantProblemRow)> = Vec::new();
    let mut count = 0u64;
    // Appended as they are done, CHUNK_INSTANTS at a time: no worker waits
    // for the others at the end of a chunk.
    let mut done: Vec<(usize, Outcome)> = Vec::new();
    let mut result = Ok(());
    let mut append = |done: &mut Vec<(usize, Outcome)>| -> Result<()> {
        done.sort_by_key(|(i, _)| *i);
        let mut rows = Vec::new();
        let mut observations = Vec::new();
        for (i, outcome) in done.drain(..) {
            rows.extend(outcome.rows);
            observations.extend(outcome.observations);
            problems.extend(outcome.problems.into_iter().map(|p| (todo[i].index, p)));
            for (camera, s) in outcome.saturation {
                let tally = saturation.entry(camera).or_default();
                tally.images += s.images;
                tally.saturated += s.saturated;
            }
            count += 1;
        }
        images.append(&observations)?;
        points.append(&rows)?;
        finished(count);
        Ok(())
    };
    for_each_parallel(
        todo,
        |ip| measure_one(ctx, ip, references),
        |i, outcome| {
            done.push((i, outcome));
            if done.len() == CHUNK_INSTANTS && result.is_ok() {
                result = append(&mut done);
            }
            result.is_ok()
        },
    );
    result?;
    if !done.is_empty() {
        append(&mut done)?;
    }
    Ok(problems)
}

/// `f` over `items` on as many worker threads as the rayon pool has
/// threads, each taking the next item when it is done with one; results in
/// the order of `items` ([`for_each_parallel`]).
fn in_parallel<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let mut done: Vec<(usize, R)> = Vec::with_capacity(items.len());
    for_each_parallel(items, f, |i, r| {
        done.push((i, r));
        true
    });
    done.sort_by_key(|(i, _)| *i);
    done.into_iter().map(|(_, r)| r).collect()
}

/// `f` over `items` on the rayon pool's threads, each taking the next item
/// when it is done with one; each result handed to `done` (with its item's
/// index) on this thread as soon as it is ready (a worker with a result to
/// hand over waits while as many as there are workers are waiting); once
/// `done` says `false`, no item is begun. Each worker is one job of the
/// pool that loops over the items, so the extraction inside `f` runs its
/// parallel parts (the labelling's bands) on the same threads, with no
/// threads besides the pool's to share the cores with; no item is left
/// queued for a thread waiting inside a parallel part to take up, so at
/// most one item per worker holds a frame: frames in flight ≤ threads.
fn for_each_parallel<T: Sync, R: Send>(
    items: &[T],
    f: impl Fn(&T) -> R + Sync,
    mut done: impl FnMut(usize, R) -> bool,
) {
    let workers = rayon::current_num_threads().min(items.len());
    if workers <= 1 {
        for (i, item) in items.iter().enumerate() {
            if !done(i, f(item)) {
                break;
            }
        }
        return;
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    // Bounded: a worker does not run more than a few results ahead of `done`.
    let (send, receive) = std::sync::mpsc::sync_channel(workers);
    rayon::in_place_scope(|scope| {
        for _ in 0..workers {
            let send = send.clone();
            let (next, f) = (&next, &f);
            scope.spawn(move |_| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(item) = items.get(i) else { break };
                    if send.send((i, f(item))).is_err() {
                        break;
                    }
                }
            });
        }
        drop(send);
        for (i, r) in receive {
            if !done(i, r) {
                next.store(items.len(), std::sync::atomic::Ordering::Relaxed);
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every item's result reaches `done` once, with its index, on any
    /// number of workers; once `done` says stop, no further item is begun.
    #[test]
    fn each_result_is_handed_over_once_and_a_stop_is_kept() {
        let items: Vec<u32> = (0..200).collect();
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let squares = pool.install(|| in_parallel(&items, |x| x * x));
            assert!(squares.iter().zip(&items).all(|(s, x)| *s == x * x));
            let begun = std::sync::atomic::AtomicUsize::new(0);
            let mut seen = 0;
            pool.install(|| {
                for_each_parallel(
                    &items,
                    |_| begun.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
                    |_, _| {
                        seen += 1;
                        seen < 10
                    },
                );
            });
            // The stop comes at the tenth result; by then each worker had
            // at most one result waiting and one item under way.
            let begun = begun.into_inner();
            assert!(
                (10..=10 + 2 * threads).contains(&begun),
                "{threads} threads: {begun} begun"
            );
            assert_eq!(seen, begun);
        }
    }
}
