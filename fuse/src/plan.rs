//! The campaign as a list of instants, checked in full before any work starts:
//! missing files, incomplete camera sets, cameras that disagree on an
//! instant's nominal position, unknown cameras, duplicate rows, one image
//! file given for two frames, spheres that cannot be told apart — every
//! problem is collected into one report.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use formats::{Axis, InstantKey, LineKey, ManifestRow, Row, SphereRow, read_csv};
use geom::{Camera, Illumination, Point3, Vector3};

use crate::{CampaignProblem, FuseError, Result};

/// One instant to measure: its key and one image per camera.
#[derive(Debug, Clone, PartialEq)]
pub struct InstantPlan {
    /// Position in manifest order (first appearance).
    pub index: usize,
    /// The instant.
    pub key: InstantKey,
    /// The sweep line it belongs to.
    pub line: LineKey,
    /// Camera id → image path (resolved against the manifest's folder).
    pub images: BTreeMap<u8, PathBuf>,
}

/// The calibrated rig as the measurement uses it.
#[derive(Debug, Clone)]
pub struct RigModel {
    /// Camera id → model.
    pub cameras: BTreeMap<u8, Camera>,
    /// Camera id → its lens's relative illumination (the ideal lens where
    /// `rig.json` has no flat-field model).
    pub illumination: BTreeMap<u8, Illumination>,
    /// Least-squares intersection of the optical axes (mm): the working point.
    pub working_point: Point3<f64>,
    /// Camera id → its parameters' names and covariance (`rig.json`
    /// `covariance`; absent for a camera calibrated without it).
    pub covariance: BTreeMap<u8, (Vec<String>, geom::nalgebra::DMatrix<f64>)>,
}

impl RigModel {
    /// Build from `rig.json`.
    pub fn new(rig: &formats::Rig) -> Result<Self> {
        let mut cameras = BTreeMap::new();
        let mut illumination = BTreeMap::new();
        let mut covariance = BTreeMap::new();
        for c in &rig.cameras {
            if let Some(cov) = &c.covariance {
                let matrix = cov
                    .to_matrix()
                    .ok_or(FuseError::Covariance { camera: c.model.id })?;
                covariance.insert(c.model.id, (cov.parameters.clone(), matrix));
            }
            let cam = c.model.to_camera().map_err(|source| FuseError::RigCamera {
                camera: c.model.id,
                source,
            })?;
            let ri = c
                .relative_illumination
                .to_model(c.model.width, c.model.height)
                .map_err(|source| FuseError::RigCamera {
                    camera: c.model.id,
                    source,
                })?;
            illumination.insert(c.model.id, ri);
            if cameras.insert(c.model.id, cam).is_some() {
                return Err(FuseError::DuplicateCamera { camera: c.model.id });
            }
        }
        if cameras.len() < 2 {
            return Err(FuseError::TooFewCameras {
                camera: rig.cameras.first().map_or(0, |c| c.model.id),
            });
        }
        // Σ (I − d dᵀ)·p = Σ (I − d dᵀ)·c over the axes (c centre, d direction).
        let (mut a, mut b) = (geom::Matrix3::zeros(), Vector3::zeros());
        for cam in cameras.values() {
            let d = cam.optical_axis().into_inner();
            let m = geom::Matrix3::identity() - d * d.transpose();
            a += m;
            b += m * cam.centre().coords;
        }
        let working_point = a
            .try_inverse()
            .map(|inv| Point3::from(inv * b))
            .ok_or(FuseError::ParallelOpticalAxes)?;
        Ok(Self {
            cameras,
            illumination,
            working_point,
            covariance,
        })
    }

    /// Cameras whose relative illumination is the assumed ideal lens (no flat field measured).
    pub fn assumed_ideal(&self) -> Vec<u8> {
        self.illumination
            .iter()
            .filter(|(_, i)| **i == Illumination::Ideal)
            .map(|(&id, _)| id)
            .collect()
    }

    /// Distance from a camera to the working point (mm).
    pub fn working_distance(&self, id: u8) -> Option<f64> {
        self.cameras
            .get(&id)
            .map(|c| (c.centre() - self.working_point).norm())
    }

    /// Cameras used for motion along `axis`: all, or (default) those not
    /// looking along it by the rig's numbering ([`Axis::of_camera`]).
    pub fn cameras_for(&self, axis: Axis, all: bool) -> Vec<u8> {
        self.cameras
            .iter()
            .filter(|(id, _)| all || Axis::of_camera(**id) != Some(axis))
            .map(|(&id, _)| id)
            .collect()
    }
}

/// Read and check the manifest against the rig and spheres; returns the
/// instants in manifest order, or one error listing every problem.
pub fn plan(
    manifest: &Path,
    rig: &RigModel,
    spheres: &[SphereRow],
    all_cameras: bool,
) -> Result<Vec<InstantPlan>> {
    let rows: Vec<Row<ManifestRow>> = read_csv(manifest)?;
    let base = manifest.parent().unwrap_or(Path::new("."));
    let mut problems = Vec::new();

    // The binary refuses such a set when it reads spheres.csv; a library
    // caller gets the same check here.
    if let Err(problem) =
        formats::check_sphere_set(spheres.iter().map(|s| (s.name.as_str(), s.diameter)))
    {
        problems.push(CampaignProblem::Spheres(problem));
    }
    if rows.is_empty() {
        problems.push(CampaignProblem::NoRows);
    }

    // Instant → camera → (line, image); and key-without-nominal groups for consistency.
    let mut order: Vec<InstantKey> = Vec::new();
    let mut images: BTreeMap<InstantKey, BTreeMap<u8, (u64, PathBuf)>> = BTreeMap::new();
    // Each file is one frame: (line, camera, instant) of its first row.
    let mut frames: BTreeMap<PathBuf, (u64, u8, InstantKey)> = BTreeMap::new();
    for r in &rows {
        let m = &r.record;
        if !rig.cameras.contains_key(&m.camera) {
            problems.push(CampaignProblem::UnknownCamera {
                line: r.line,
                camera: m.camera,
            });
            continue;
        }
        let path = base.join(&m.image);
        if !path.is_file() {
            problems.push(CampaignProblem::ImageMissing {
                line: r.line,
                path: path.clone(),
            });
        }
        let key = m.instant();
        let file = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        if let Some((line, camera, instant)) = frames.get(&file) {
            if (*camera, *instant) != (m.camera, key) {
                problems.push(CampaignProblem::OneFileTwoFrames {
                    line: r.line,
                    path: path.clone(),
                    camera: *camera,
                    instant: *instant,
                    first_line: *line,
                });
            }
        } else {
            frames.insert(file, (r.line, m.camera, key));
        }
        let entry = images.entry(key).or_insert_with(|| {
            order.push(key);
            BTreeMap::new()
        });
        if let Some((first, _)) = entry.get(&m.camera) {
            problems.push(CampaignProblem::CameraTwice {
                line: r.line,
                camera: m.camera,
                instant: key,
                first_line: *first,
            });
            continue;
        }
        entry.insert(m.camera, (r.line, path));
    }

    // Instants that share everything but the nominal position: legitimate
    // separate lines when each is complete, a disagreement otherwise.
    let mut by_sweep: BTreeMap<(Axis, formats::Direction, u32, u32, u32), Vec<InstantKey>> =
        BTreeMap::new();
    for k in &order {
        by_sweep
            .entry((k.axis, k.direction, k.run, k.target, k.capture))
            .or_default()
            .push(*k);
    }
    let mut plans = Vec::with_capacity(order.len());
    for (index, key) in order.iter().enumerate() {
        let cams = &images[key];
        let needed = rig.cameras_for(key.axis, all_cameras);
        let missing: Vec<u8> = needed
            .iter()
            .copied()
            .filter(|c| !cams.contains_key(c))
            .collect();
        if !missing.is_empty() {
            let siblings = &by_sweep[&(key.axis, key.direction, key.run, key.target, key.capture)];
            for c in &missing {
                // A sibling that is complete is another line of the sweep; an
                // incomplete one holding the missing camera is a disagreement.
                let complete = |k: &InstantKey| needed.iter().all(|n| images[k].contains_key(n));
                let elsewhere = siblings
                    .iter()
                    .filter(|k| *k != key && !complete(k))
                    .find_map(|k| images[k].get(c).map(|(line, _)| (k, *line)));
                let (first_line, _) = cams.values().next().map_or((0, ()), |(l, _)| (*l, ()));
                problems.push(match elsewhere {
                    Some((other, line)) => CampaignProblem::NominalDisagrees {
                        line: first_line,
                        instant: *key,
                        camera: *c,
                        other_line: line,
                        other_nominal: other.nominal(),
                    },
                    None => CampaignProblem::MissingCamera {
                        line: first_line,
                        instant: *key,
                        camera: *c,
                    },
                });
            }
        }
        if needed.len() < 2 {
            problems.push(CampaignProblem::TooFewCameras { instant: *key });
        }
        plans.push(InstantPlan {
            index,
            key: *key,
            line: key.line(),
            images: cams.iter().map(|(c, (_, p))| (*c, p.clone())).collect(),
        });
    }
    if problems.is_empty() {
        Ok(plans)
    } else {
        problems.dedup();
        Err(FuseError::Campaign {
            manifest: manifest.to_path_buf(),
            problems,
        })
    }
}
