//! Calibration over many views: one bundle for the whole rig
//! (docs/methods.md §8). Each view is one camera's image of the target at
//! one pose; views of different cameras at the same pose tie the cameras
//! together. The unknowns: per camera its intrinsics and distortion (a
//! [`Layout`]) and its pose in the world frame, per pose but the first the
//! target's pose in the world frame (6 dof). The world frame is the
//! target's frame at the smallest pose id.
//!
//! Start values: per view the camera's pose relative to the target — the
//! DLT for a 3-D target, Zhang's closed form for a planar one (z = 0,
//! [`crate::planar`]) — chained through the view graph from the world pose
//! (a camera the graph does not reach is refused, [`CalibError::CutOff`]).
//! Then Levenberg–Marquardt on every view's reprojection error at once,
//! iterated with the k·σ outlier rejection per view. The Jacobian is dense:
//! at 3 cameras × 20 views × 50 points (≈ 200 unknowns, 6000 residuals) a
//! dense solve takes a fraction of a second; a sparse Schur solve is what
//! larger bundles will need.

use std::collections::{BTreeMap, BTreeSet};

use geom::lm::Residuals;
use geom::nalgebra::{DMatrix, DVector, Isometry3, Rotation3, Translation3, UnitQuaternion};
use geom::{Camera, Point2, Point3, Vector2, Vector3};

use crate::calibration::{
    Observation, Options, Parameter, PointResidual, parameters, residuals_of, rms, split,
};
use crate::dlt::{self, MIN_POINTS};
use crate::model_choice::{FOLDS, ModelChoice, decide};
use crate::outliers::{inliers, robust_sigma};
use crate::planar;
use crate::refine::{Layout, cross_matrix, left_jacobian, project};
use crate::{CalibError, Result};

/// The solver's settings: a relative tolerance of 1e-12 on the cost and the
/// step (far below any figure reported; MINPACK's 1e-15 spends a large
/// bundle's last iterations on round-off); at most 4·(n + 1) evaluations
/// for n unknowns (a consistent bundle converges in a few tens; views that
/// contradict each other would otherwise crawl through 200·(n + 1) dense
/// iterations — minutes — before failing); no covariance per round (it is
/// computed once, re-linearised at the solution).
const BUNDLE_LM: geom::lm::LmOptions = geom::lm::LmOptions {
    tolerance: 1e-12,
    patience: 4,
    covariance: false,
};

/// One camera's image of the target at one pose: its markers' target
/// coordinates and observed pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// The camera's id.
    pub camera: u8,
    /// The target placement (views of one `pose` saw the target in one place).
    pub pose: u32,
    /// The markers seen.
    pub observations: Vec<Observation>,
}

/// A view not used, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct LeftOut {
    /// The camera.
    pub camera: u8,
    /// The pose.
    pub pose: u32,
    /// Why.
    pub reason: String,
}

/// A view's residuals under the solution.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewResidual {
    /// The camera.
    pub camera: u8,
    /// The pose.
    pub pose: u32,
    /// Points used (outliers aside).
    pub points: usize,
    /// RMS residual length of the points used (px).
    pub rms_px: f64,
    /// Largest residual length of the points used (px).
    pub max_px: f64,
    /// Every point's residual, in the view's order.
    pub residuals: Vec<PointResidual>,
}

/// A camera of the rig as the bundle found it.
#[derive(Debug, Clone)]
pub struct RigCamera {
    /// Its id.
    pub id: u8,
    /// The camera (intrinsics, distortion, pose: world → camera).
    pub camera: Camera,
    /// RMS reprojection error over its views' points used (px).
    pub rms_px: f64,
    /// Robust per-coordinate σ of those residuals (px).
    pub sigma_px: f64,
    /// Points used over its views.
    pub points_used: usize,
    /// Views used.
    pub views: usize,
    /// Its parameters in [`Layout::names`] order, σ from the joint solution.
    pub parameters: Vec<Parameter>,
    /// Their covariance from the joint solution, `s²·(JᵀJ)⁻¹` (the image
    /// noise; the target's marker uncertainty not included), in
    /// [`Layout::names`] order; `None` when not determined.
    pub covariance: Option<DMatrix<f64>>,
}

/// The rig from its views.
#[derive(Debug, Clone)]
pub struct Rig {
    /// The cameras, ids ascending.
    pub cameras: Vec<RigCamera>,
    /// Each pose's target frame → world frame (the world pose: identity).
    pub poses: BTreeMap<u32, Isometry3<f64>>,
    /// The pose whose target frame is the world frame.
    pub world_pose: u32,
    /// Whether the target was planar (Zhang's start) or 3-D (DLT).
    pub planar: bool,
    /// Per view used, its residuals, in the order given.
    pub views: Vec<ViewResidual>,
    /// The views left out, and why.
    pub left_out: Vec<LeftOut>,
    /// Fit-and-reject rounds.
    pub rounds: usize,
    /// The layout every camera was estimated with.
    pub layout: Layout,
}

/// Calibrate a rig from its views (cameras of the sizes `sizes`, id →
/// width × height), every camera with `options`' model.
pub fn calibrate_views(
    views: &[View],
    sizes: &BTreeMap<u8, (u32, u32)>,
    options: &Options,
) -> Result<Rig> {
    options.validate()?;
    let layout = options.layout();
    for v in views {
        crate::calibration::validate(&v.observations)?;
    }
    connected(views)?;
    let planar = is_planar(views)?;
    // Each view's start: the camera relative to the target at its pose.
    let mut left_out = Vec::new();
    let mut used: Vec<&View> = Vec::new();
    let mut relative: Vec<Camera> = Vec::new();
    let mut homographies: Vec<Option<geom::nalgebra::Matrix3<f64>>> = Vec::new();
    for v in views {
        let Some(&(width, height)) = sizes.get(&v.camera) else {
            return Err(CalibError::Option(crate::OptionProblem::ImageSize {
                width: 0,
                height: 0,
            }));
        };
        match view_start(v, planar, width, height) {
            Ok((camera, h)) => {
                used.push(v);
                relative.push(camera);
                homographies.push(h);
            }
            Err(e) => left_out.push(LeftOut {
                camera: v.camera,
                pose: v.pose,
                reason: e.to_string(),
            }),
        }
    }
    let cameras: BTreeSet<u8> = views.iter().map(|v| v.camera).collect();
    for &c in &cameras {
        let n_views = used.iter().filter(|v| v.camera == c).count();
        let points: usize = used
            .iter()
            .filter(|v| v.camera == c)
            .map(|v| v.observations.len())
            .sum();
        let needed = (layout.len() + 6 * n_views.saturating_sub(1)).div_ceil(2) + 1;
        if n_views == 0 || points < needed {
            return Err(CalibError::TooFewForModel {
                camera: c,
                points,
                views: n_views,
                needed,
            });
        }
    }
    // Planar: each camera's K from all its homographies (Zhang), then each view's pose.
    if planar {
        for &c in &cameras {
            let idx: Vec<usize> = (0..used.len()).filter(|&i| used[i].camera == c).collect();
            let hs: Vec<_> = idx.iter().filter_map(|&i| homographies[i]).collect();
            if hs.is_empty() {
                continue;
            }
            let (w, h) = sizes[&c];
            let k = planar::intrinsics(&hs, w, h)?;
            for &i in &idx {
                if let Some(hm) = homographies[i] {
                    relative[i].intrinsics = k;
                    relative[i].pose = planar::pose(&k, &hm)?;
                }
            }
        }
    }
    let world_pose = used
        .iter()
        .map(|v| v.pose)
        .min()
        .ok_or(CalibError::TooFewPoints {
            what: "a calibration over views",
            needed: MIN_POINTS,
            got: 0,
        })?;
    let (camera_poses, target_poses) = chain(&used, &relative, world_pose, &cameras)?;

    // The unknowns: camera blocks (ids ascending), then the poses but the world's.
    let camera_ids: Vec<u8> = cameras.iter().copied().collect();
    let pose_ids: Vec<u32> = target_poses
        .keys()
        .copied()
        .filter(|&p| p != world_pose)
        .collect();
    let mut start_cameras = Vec::new();
    for &c in &camera_ids {
        // The view with the most points gives the intrinsics' start.
        let best = (0..used.len())
            .filter(|&i| used[i].camera == c)
            .max_by_key(|&i| used[i].observations.len())
            .ok_or(CalibError::CutOff {
                camera: c,
                world_pose,
            })?;
        let mut camera = relative[best].clone();
        if !options.skew {
            camera.intrinsics.skew = 0.0;
        }
        camera.distortion = geom::Distortion::NONE;
        camera.pose = camera_poses[&c];
        start_cameras.push(camera);
    }
    let mut problem = Bundle {
        layout,
        camera_r0: start_cameras.iter().map(Camera::rotation).collect(),
        pose_r0: pose_ids
            .iter()
            .map(|p| target_poses[p].rotation.to_rotation_matrix())
            .collect(),
        points: Vec::new(),
    };
    let mut start = DVector::zeros(camera_ids.len() * layout.len() + 6 * pose_ids.len());
    for (k, camera) in start_cameras.iter().enumerate() {
        start
            .rows_mut(k * layout.len(), layout.len())
            .copy_from(&layout.pack(camera));
    }
    for (k, p) in pose_ids.iter().enumerate() {
        let o = camera_ids.len() * layout.len() + 6 * k;
        start
            .fixed_rows_mut::<3>(o + 3)
            .copy_from(&target_poses[p].translation.vector);
    }
    // Every point of the views used, with its camera and pose blocks.
    let mut all: Vec<BundlePoint> = Vec::new();
    for v in &used {
        let camera = camera_ids.iter().position(|&c| c == v.camera).unwrap_or(0);
        let pose = pose_ids.iter().position(|&p| p == v.pose);
        for o in &v.observations {
            all.push(BundlePoint {
                camera,
                pose,
                world: o.world,
                pixel: o.pixel,
                radius: o.radius(),
            });
        }
    }
    let view_of: Vec<usize> = used
        .iter()
        .enumerate()
        .flat_map(|(i, v)| std::iter::repeat_n(i, v.observations.len()))
        .collect();
    let mut keep = vec![true; all.len()];
    let mut dropped = vec![false; used.len()];
    let mut params = start;
    let mut rounds = 0;
    loop {
        rounds += 1;
        problem.points = all
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(p, _)| *p)
            .collect();
        let solution =
            geom::lm::minimize(&problem, params.clone(), &BUNDLE_LM).map_err(CalibError::geom(
                "the bundle over the views (views that contradict each other — a wrong pose \
                 id, a board seen mirrored, a misread target — keep it from converging)",
            ))?;
        params = solution.params;
        let residuals = problem.residuals_of(&params, &all);
        if let Some((w, sigma_px, median_px)) =
            inconsistent_view(&residuals, &keep, &view_of, &used, &dropped)
        {
            dropped[w] = true;
            for (j, k) in keep.iter_mut().enumerate() {
                if view_of[j] == w {
                    *k = false;
                }
            }
            left_out.push(LeftOut {
                camera: used[w].camera,
                pose: used[w].pose,
                reason: format!(
                    "inconsistent with the other views (a wrong pose id, a misread target?): \
                     residual σ {sigma_px:.2} px against the views' median {median_px:.3} px"
                ),
            });
            continue;
        }
        let Some(k) = options.outlier_k else {
            break;
        };
        // The k·σ rejection, per view.
        let mut next = vec![true; all.len()];
        for (i, &gone) in dropped.iter().enumerate() {
            let idx: Vec<usize> = (0..all.len()).filter(|&j| view_of[j] == i).collect();
            if gone {
                for &j in &idx {
                    next[j] = false;
                }
                continue;
            }
            let r: Vec<Vector2<f64>> = idx.iter().map(|&j| residuals[j]).collect();
            let flags = inliers(&r, robust_sigma(&r), k);
            for (&j, f) in idx.iter().zip(flags) {
                next[j] = f;
            }
        }
        if next == keep || rounds >= options.max_rounds {
            break;
        }
        keep = next;
    }
    // Re-linearised at the solution with ω = 0 (R₀ = R̂): the covariance's
    // rx, ry, rz are a small rotation about the camera's own axes, as in the
    // one-image path's rig.json (`geom::Camera::perturbed`).
    for k in 0..camera_ids.len() {
        let (w, h) = sizes[&camera_ids[k]];
        let block = params.rows(k * layout.len(), layout.len()).into_owned();
        let camera = layout.unpack(&block, &problem.camera_r0[k], w, h);
        problem.camera_r0[k] = camera.rotation();
        params
            .rows_mut(k * layout.len(), layout.len())
            .copy_from(&layout.pack(&camera));
    }
    for k in 0..pose_ids.len() {
        let o = problem.pose_offset(k);
        problem.pose_r0[k] = pose_of(&params, o, &problem.pose_r0[k])
            .rotation
            .to_rotation_matrix();
        params.fixed_rows_mut::<3>(o).fill(0.0);
    }
    let residuals = problem.residuals_of(&params, &all);
    let ssr = problem.residuals(&params).norm_squared();
    let covariance = geom::lm::covariance(
        &problem.jacobian(&params),
        ssr,
        2 * problem.points.len(),
        problem.unknowns(),
    );

    let view_residuals: Vec<ViewResidual> = used
        .iter()
        .enumerate()
        .filter(|(i, _)| !dropped[*i])
        .map(|(i, v)| {
            let idx: Vec<usize> = (0..all.len()).filter(|&j| view_of[j] == i).collect();
            let kept: Vec<Vector2<f64>> = idx
                .iter()
                .filter(|&&j| keep[j])
                .map(|&j| residuals[j])
                .collect();
            ViewResidual {
                camera: v.camera,
                pose: v.pose,
                points: kept.len(),
                rms_px: rms(&kept),
                max_px: kept.iter().map(|r| r.norm()).fold(0.0, f64::max),
                residuals: idx
                    .iter()
                    .zip(&v.observations)
                    .map(|(&j, o)| PointResidual {
                        id: o.id,
                        du: residuals[j].x,
                        dv: residuals[j].y,
                        outlier: !keep[j],
                    })
                    .collect(),
            }
        })
        .collect();
    let rig_cameras = camera_ids
        .iter()
        .enumerate()
        .map(|(k, &id)| {
            let (w, h) = sizes[&id];
            let block = params.rows(k * layout.len(), layout.len()).into_owned();
            let camera = layout.unpack(&block, &problem.camera_r0[k], w, h);
            let kept: Vec<Vector2<f64>> = (0..all.len())
                .filter(|&j| keep[j] && all[j].camera == k)
                .map(|j| residuals[j])
                .collect();
            let block_cov = covariance.as_ref().map(|c| {
                c.view(
                    (k * layout.len(), k * layout.len()),
                    (layout.len(), layout.len()),
                )
                .into_owned()
            });
            let std_devs: Option<Vec<f64>> = block_cov.as_ref().map(|c| {
                (0..layout.len())
                    .map(|i| c[(i, i)].max(0.0).sqrt())
                    .collect()
            });
            RigCamera {
                id,
                parameters: parameters(layout, &camera, std_devs.as_deref()),
                camera,
                rms_px: rms(&kept),
                sigma_px: robust_sigma(&kept),
                points_used: kept.len(),
                views: used
                    .iter()
                    .zip(&dropped)
                    .filter(|(v, d)| v.camera == id && !**d)
                    .count(),
                covariance: block_cov,
            }
        })
        .collect();
    let mut poses = BTreeMap::new();
    poses.insert(world_pose, Isometry3::identity());
    for (k, &p) in pose_ids.iter().enumerate() {
        let o = camera_ids.len() * layout.len() + 6 * k;
        poses.insert(p, pose_of(&params, o, &problem.pose_r0[k]));
    }
    Ok(Rig {
        cameras: rig_cameras,
        poses,
        world_pose,
        planar,
        views: view_residuals,
        left_out,
        rounds,
        layout,
    })
}

/// A view's robust σ above this many times the median view's (and above
/// [`INCONSISTENT_PX`]) makes it inconsistent with the others.
const INCONSISTENT_FACTOR: f64 = 10.0;
/// See [`INCONSISTENT_FACTOR`] (px).
const INCONSISTENT_PX: f64 = 1.0;

/// The view most inconsistent with the others, with its robust σ and the
/// median view's (px): one whose robust σ over its kept points (a few
/// outliers do not move it: those are the k·σ rejection's) exceeds
/// [`INCONSISTENT_FACTOR`] × the median and [`INCONSISTENT_PX`], and whose
/// camera and pose keep other views (so that dropping it leaves the rest
/// determined). `None` when every view agrees.
fn inconsistent_view(
    residuals: &[Vector2<f64>],
    keep: &[bool],
    view_of: &[usize],
    used: &[&View],
    dropped: &[bool],
) -> Option<(usize, f64, f64)> {
    let mut per_view: Vec<Vec<Vector2<f64>>> = vec![Vec::new(); used.len()];
    for (j, r) in residuals.iter().enumerate() {
        if keep[j] {
            per_view[view_of[j]].push(*r);
        }
    }
    let sigma: Vec<(usize, f64)> = per_view
        .iter()
        .enumerate()
        .filter(|(i, r)| !dropped[*i] && !r.is_empty())
        .map(|(i, r)| (i, robust_sigma(r)))
        .collect();
    let mut sorted: Vec<f64> = sigma.iter().map(|r| r.1).collect();
    sorted.sort_by(f64::total_cmp);
    let median = *sorted.get(sorted.len() / 2)?;
    let &(w, worst) = sigma.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    let others = |same: &dyn Fn(&View) -> bool| {
        used.iter()
            .enumerate()
            .any(|(i, v)| i != w && !dropped[i] && same(v))
    };
    let (camera, pose) = (used[w].camera, used[w].pose);
    (worst > INCONSISTENT_FACTOR * median
        && worst > INCONSISTENT_PX
        && others(&|v| v.camera == camera)
        && others(&|v| v.pose == pose))
    .then_some((w, worst, median))
}

/// Fails with [`CalibError::CutOff`] for the first camera that no chain of
/// shared poses links to the views of the smallest pose.
fn connected(views: &[View]) -> Result<()> {
    let Some(world_pose) = views.iter().map(|v| v.pose).min() else {
        return Ok(());
    };
    let mut poses: BTreeSet<u32> = [world_pose].into();
    let mut cameras: BTreeSet<u8> = BTreeSet::new();
    loop {
        let before = (poses.len(), cameras.len());
        for v in views {
            if poses.contains(&v.pose) || cameras.contains(&v.camera) {
                poses.insert(v.pose);
                cameras.insert(v.camera);
            }
        }
        if (poses.len(), cameras.len()) == before {
            break;
        }
    }
    match views.iter().find(|v| !cameras.contains(&v.camera)) {
        Some(v) => Err(CalibError::CutOff {
            camera: v.camera,
            world_pose,
        }),
        None => Ok(()),
    }
}

/// [`calibrate_views`] with the distortion model the data support
/// ([`crate::model_choice`]): `options`' model without k3 and with k3 for
/// every camera; k3 kept when significant (F over the cameras' k3 together)
/// and predicting held-out markers better (5 folds: marker j of every view
/// in fold j mod 5, the rig refitted on the rest).
pub fn calibrate_views_choosing(
    views: &[View],
    sizes: &BTreeMap<u8, (u32, u32)>,
    options: &Options,
) -> Result<(Rig, Option<ModelChoice>)> {
    let lean_options = Options {
        k3: false,
        ..*options
    };
    let lean = calibrate_views(views, sizes, &lean_options)?;
    if options.model == crate::Model::Pinhole {
        return Ok((lean, None));
    }
    let rich_options = Options {
        k3: true,
        ..*options
    };
    let Ok(rich) = calibrate_views(views, sizes, &rich_options) else {
        return Ok((lean, None));
    };
    let points: usize = rich.views.iter().map(|v| v.points).sum();
    let unknowns = rich.cameras.len() * rich_options.layout().len() + 6 * (rich.poses.len() - 1);
    if 2 * points < unknowns + 10 {
        return Ok((lean, None));
    }
    // Sum of squared residuals, and the RMS over every view's points used.
    let ssr = |r: &Rig| {
        r.views
            .iter()
            .map(|v| v.rms_px * v.rms_px * v.points as f64)
            .sum::<f64>()
    };
    let rms_all = |r: &Rig| (ssr(r) / points.max(1) as f64).sqrt();
    // The markers kept by the richer fit, per view (by camera and pose).
    let kept: BTreeMap<(u8, u32), Vec<bool>> = rich
        .views
        .iter()
        .map(|v| {
            (
                (v.camera, v.pose),
                v.residuals.iter().map(|r| !r.outlier).collect(),
            )
        })
        .collect();
    let held = |o: &Options| held_out_views(views, sizes, o, &kept);
    let choice = decide(
        options.model.name(),
        [
            (
                lean_options.layout(),
                rms_all(&lean),
                ssr(&lean),
                held(&lean_options),
            ),
            (
                rich_options.layout(),
                rms_all(&rich),
                ssr(&rich),
                held(&rich_options),
            ),
        ],
        rich.cameras.len(),
        2 * points - unknowns,
    );
    let chosen = if choice.chosen.k3 { rich } else { lean };
    Ok((chosen, Some(choice)))
}

/// Each kept marker's squared residual when the rig is fitted without it
/// (marker j of every view in fold j mod [`FOLDS`]), in a fixed order;
/// `None` where a fold cannot be fitted or a view is lost.
fn held_out_views(
    views: &[View],
    sizes: &BTreeMap<u8, (u32, u32)>,
    options: &Options,
    kept: &BTreeMap<(u8, u32), Vec<bool>>,
) -> Option<Vec<f64>> {
    let mut held = Vec::new();
    for fold in 0..FOLDS {
        let train: Vec<View> = views
            .iter()
            .map(|v| View {
                observations: v
                    .observations
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| j % FOLDS != fold)
                    .map(|(_, o)| *o)
                    .collect(),
                ..v.clone()
            })
            .collect();
        let rig = calibrate_views(&train, sizes, options).ok()?;
        for v in views {
            let Some(keep) = kept.get(&(v.camera, v.pose)) else {
                continue;
            };
            let camera = &rig.cameras.iter().find(|c| c.id == v.camera)?.camera;
            let pose = rig.poses.get(&v.pose)?;
            // The view's held-out markers in the world frame.
            let (world, image, radius) = split(
                v.observations
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| j % FOLDS == fold && keep[*j])
                    .map(|(_, o)| o),
            );
            let world: Vec<Point3<f64>> = world.iter().map(|x| pose * x).collect();
            let residuals = residuals_of(camera, options.layout(), &world, &image, &radius);
            held.extend(residuals.iter().map(|r| r.norm_squared()));
        }
    }
    held.iter().all(|r| r.is_finite()).then_some(held)
}

/// A point of the measuring volume and the σ of its triangulated position
/// from the calibration alone.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumePoint {
    /// The point, world frame (mm).
    pub point: Point3<f64>,
    /// The cameras that see it (in their image), ids ascending.
    pub cameras: Vec<u8>,
    /// σ of x, y, z (µm), `None` where fewer than two cameras see it.
    pub sigma_um: Option<Vector3<f64>>,
}

/// The triangulation uncertainty of the rig over the volume its target
/// poses spanned: a `n × n × n` grid over the bounding box of every pose's
/// target points (world frame); per grid point, each camera that sees it
/// gives its image-centre covariance from its parameter covariance
/// (`geom::triangulate::parameter_image_covariance`, first order), and the
/// point's covariance follows from those (`centre_covariance`). The cameras'
/// errors are taken as independent — the joint solution's correlations
/// between cameras are left out — and the image noise is not included: this
/// is what every measurement inherits from the calibration.
pub fn volume_uncertainty(rig: &Rig, views: &[View], n: usize) -> Vec<VolumePoint> {
    let names: Vec<String> = rig.layout.names().iter().map(|s| s.to_string()).collect();
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for v in views {
        let Some(pose) = rig.poses.get(&v.pose) else {
            continue;
        };
        for o in &v.observations {
            let w = (pose * o.world).coords;
            lo = lo.inf(&w);
            hi = hi.sup(&w);
        }
    }
    if !(lo.iter().all(|v| v.is_finite()) && n >= 2) {
        return Vec::new();
    }
    let step = (hi - lo) / (n - 1) as f64;
    (0..n * n * n)
        .map(|g| {
            let index = Vector3::new((g / (n * n)) as f64, ((g / n) % n) as f64, (g % n) as f64);
            volume_point(rig, &names, Point3::from(lo + step.component_mul(&index)))
        })
        .collect()
}

/// One point of [`volume_uncertainty`]: the cameras that see it in their
/// image (with a covariance), and its σ from theirs when two or more do.
pub(crate) fn volume_point(rig: &Rig, names: &[String], point: Point3<f64>) -> VolumePoint {
    let mut cameras = Vec::new();
    let mut views = Vec::new();
    let mut covariances = Vec::new();
    for c in &rig.cameras {
        let camera = &c.camera;
        let in_image = camera.project(&point).is_ok_and(|p| {
            p.x >= 0.0
                && p.y >= 0.0
                && p.x < f64::from(camera.width)
                && p.y < f64::from(camera.height)
        });
        let (Some(cov), Ok(ideal_px)) = (&c.covariance, camera.project_pinhole(&point)) else {
            continue;
        };
        let image = in_image
            .then(|| {
                geom::triangulate::parameter_image_covariance(
                    camera, names, cov, &point, 0.0, ideal_px,
                )
            })
            .flatten();
        if let Some(image) = image {
            cameras.push(c.id);
            views.push(geom::triangulate::View { camera, ideal_px });
            covariances.push(image);
        }
    }
    let sigma_um = (views.len() >= 2)
        .then(|| geom::triangulate::centre_covariance(&views, 0.0, &point, &covariances))
        .flatten()
        .map(|m| Vector3::new(m[(0, 0)], m[(1, 1)], m[(2, 2)]).map(|v| 1000.0 * v.max(0.0).sqrt()));
    VolumePoint {
        point,
        cameras,
        sigma_um,
    }
}

/// Whether the views' target is planar (every point at z = 0); a target
/// coplanar in another plane, or collinear, is refused as today.
fn is_planar(views: &[View]) -> Result<bool> {
    let mut seen = BTreeMap::new();
    for v in views {
        for o in &v.observations {
            seen.insert(o.id, o.world);
        }
    }
    let points: Vec<Point3<f64>> = seen.into_values().collect();
    let spread = dlt::Spread::of(&points);
    match spread.check() {
        Ok(()) => Ok(false),
        Err(CalibError::Coplanar { kind, .. })
            if kind != "collinear" && points.iter().all(|p| p.z == 0.0) =>
        {
            Ok(true)
        }
        Err(e) => Err(e),
    }
}

/// A view's start: the camera relative to the target (and, for a planar
/// target, the view's homography, its pose set once K is known).
fn view_start(
    v: &View,
    planar: bool,
    width: u32,
    height: u32,
) -> Result<(Camera, Option<geom::nalgebra::Matrix3<f64>>)> {
    let (world, image, _) = split(&v.observations);
    if planar {
        let board: Vec<Point2<f64>> = world.iter().map(|p| Point2::new(p.x, p.y)).collect();
        let h = planar::homography(&board, &image)?;
        let camera = Camera {
            intrinsics: geom::Intrinsics::centred(f64::from(width.max(height)), width, height),
            distortion: geom::Distortion::NONE,
            pose: Isometry3::identity(),
            width,
            height,
        };
        // The pose follows from K, known once all the camera's views are in.
        return Ok((camera, Some(h)));
    }
    if world.len() < MIN_POINTS {
        return Err(CalibError::TooFewPoints {
            what: "a view of a 3-D target",
            needed: MIN_POINTS,
            got: world.len(),
        });
    }
    dlt::Spread::of(&world).check()?;
    let p = dlt::dlt(&world, &image)?;
    let camera = Camera::from_projection_matrix(&p, width, height)
        .map_err(CalibError::geom("decomposing a view's DLT projection"))?;
    Ok((camera, None))
}

/// Each camera's pose (world → camera) and each pose's target → world,
/// chained through the views from the world pose.
#[allow(clippy::type_complexity)]
fn chain(
    views: &[&View],
    relative: &[Camera],
    world_pose: u32,
    cameras: &BTreeSet<u8>,
) -> Result<(BTreeMap<u8, Isometry3<f64>>, BTreeMap<u32, Isometry3<f64>>)> {
    let mut camera_poses: BTreeMap<u8, Isometry3<f64>> = BTreeMap::new();
    let mut target_poses: BTreeMap<u32, Isometry3<f64>> = BTreeMap::new();
    target_poses.insert(world_pose, Isometry3::identity());
    loop {
        let mut changed = false;
        for (v, r) in views.iter().zip(relative) {
            // x_c = T_{c←p}·X, X_w = T_p·X, x_c = T_c·X_w.
            let t_cp = r.pose;
            match (camera_poses.get(&v.camera), target_poses.get(&v.pose)) {
                (None, Some(t_p)) => {
                    camera_poses.insert(v.camera, t_cp * t_p.inverse());
                    changed = true;
                }
                (Some(t_c), None) => {
                    target_poses.insert(v.pose, t_c.inverse() * t_cp);
                    changed = true;
                }
                _ => {}
            }
        }
        if !changed {
            break;
        }
    }
    if let Some(&camera) = cameras.iter().find(|c| !camera_poses.contains_key(c)) {
        return Err(CalibError::CutOff { camera, world_pose });
    }
    Ok((camera_poses, target_poses))
}

/// A pose block's target → world at `params[o..o + 6]` (ω then t, rotation
/// `exp([ω]×)·r0`).
fn pose_of(params: &DVector<f64>, o: usize, r0: &Rotation3<f64>) -> Isometry3<f64> {
    let omega = Vector3::new(params[o], params[o + 1], params[o + 2]);
    let t = Vector3::new(params[o + 3], params[o + 4], params[o + 5]);
    Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&(Rotation3::new(omega) * r0)),
    )
}

/// One marker of one view in the bundle.
#[derive(Debug, Clone, Copy)]
struct BundlePoint {
    /// Index of its camera block.
    camera: usize,
    /// Index of its pose block (`None`: the world pose).
    pose: Option<usize>,
    world: Point3<f64>,
    pixel: Point2<f64>,
    radius: f64,
}

/// Reprojection residuals of every point of every view.
struct Bundle {
    layout: Layout,
    camera_r0: Vec<Rotation3<f64>>,
    pose_r0: Vec<Rotation3<f64>>,
    points: Vec<BundlePoint>,
}

impl Bundle {
    fn pose_offset(&self, k: usize) -> usize {
        self.camera_r0.len() * self.layout.len() + 6 * k
    }

    /// Point `pt`'s residual (predicted − observed), and when asked its
    /// Jacobian rows at `row`.
    fn point(
        &self,
        p: &DVector<f64>,
        pt: &BundlePoint,
        jac: Option<(&mut DMatrix<f64>, usize)>,
    ) -> Vector2<f64> {
        let (world, pose) = match pt.pose {
            None => (pt.world, None),
            Some(k) => {
                let o = self.pose_offset(k);
                let omega = Vector3::new(p[o], p[o + 1], p[o + 2]);
                let rotated = Rotation3::new(omega) * (self.pose_r0[k] * pt.world.coords);
                let t = Vector3::new(p[o + 3], p[o + 4], p[o + 5]);
                (Point3::from(rotated + t), Some((o, omega, rotated)))
            }
        };
        let col = pt.camera * self.layout.len();
        let r0 = &self.camera_r0[pt.camera];
        let nan = Vector2::new(f64::NAN, f64::NAN);
        match jac {
            None => project(&self.layout, r0, p, col, &world, pt.radius, None)
                .map_or(nan, |(pixel, _)| pixel - pt.pixel.coords),
            Some((jm, row)) => {
                let Some((pixel, dpix_dworld)) = project(
                    &self.layout,
                    r0,
                    p,
                    col,
                    &world,
                    pt.radius,
                    Some((jm, row, col)),
                ) else {
                    return nan;
                };
                if let Some((o, omega, rotated)) = pose {
                    let dw_domega = -cross_matrix(&rotated) * left_jacobian(&omega);
                    let d_omega = dpix_dworld * dw_domega;
                    for k in 0..3 {
                        jm[(row, o + k)] = d_omega[(0, k)];
                        jm[(row + 1, o + k)] = d_omega[(1, k)];
                        jm[(row, o + 3 + k)] = dpix_dworld[(0, k)];
                        jm[(row + 1, o + 3 + k)] = dpix_dworld[(1, k)];
                    }
                }
                pixel - pt.pixel.coords
            }
        }
    }

    fn residuals_of(&self, p: &DVector<f64>, points: &[BundlePoint]) -> Vec<Vector2<f64>> {
        points.iter().map(|pt| self.point(p, pt, None)).collect()
    }

    fn unknowns(&self) -> usize {
        self.pose_offset(self.pose_r0.len())
    }
}

impl Residuals for Bundle {
    fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
        let mut out = DVector::zeros(2 * self.points.len());
        for (i, pt) in self.points.iter().enumerate() {
            let r = self.point(p, pt, None);
            out[2 * i] = r.x;
            out[2 * i + 1] = r.y;
        }
        out
    }

    fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
        let mut j = DMatrix::zeros(2 * self.points.len(), self.unknowns());
        for (i, pt) in self.points.iter().enumerate() {
            self.point(p, pt, Some((&mut j, 2 * i)));
        }
        j
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Model;
    use geom::lm::jacobian_error;
    use geom::{Distortion, Intrinsics};

    fn camera(fx: f64, rotation: Vector3<f64>, translation: Vector3<f64>) -> Camera {
        Camera {
            intrinsics: Intrinsics {
                fx,
                fy: fx * 0.998,
                cx: 650.0,
                cy: 470.0,
                skew: 0.0,
            },
            distortion: Distortion {
                k1: -0.12,
                k2: 0.05,
                k3: 0.0,
                p1: 4e-4,
                p2: -3e-4,
            },
            pose: Isometry3::new(translation, rotation),
            width: 1280,
            height: 960,
        }
    }

    /// A board of 9×6 points 20 mm apart, z = 0.
    fn board() -> Vec<Point3<f64>> {
        (0..9)
            .flat_map(|i| {
                (0..6).map(move |j| Point3::new(20.0 * f64::from(i), 20.0 * f64::from(j), 0.0))
            })
            .collect()
    }

    /// Two cameras 120 mm apart looking along +z at a board near z = 500;
    /// 6 board poses, each seen by both.
    fn scene() -> (Vec<Camera>, Vec<Isometry3<f64>>) {
        let cams = vec![
            camera(1400.0, Vector3::zeros(), Vector3::new(-80.0, -50.0, 0.0)),
            camera(
                1350.0,
                Vector3::new(0.0, -0.2, 0.0),
                Vector3::new(-180.0, -50.0, 10.0),
            ),
        ];
        let poses = (0..6)
            .map(|k| {
                let a = f64::from(k);
                Isometry3::new(
                    Vector3::new(-10.0 * a, 5.0 * a, 480.0 + 15.0 * a),
                    Vector3::new(
                        0.35 * (a * 1.3).sin(),
                        0.35 * (a * 0.7 + 1.0).cos(),
                        0.1 * a,
                    ),
                )
            })
            .collect();
        (cams, poses)
    }

    fn views_of(cams: &[Camera], poses: &[Isometry3<f64>], noise: f64) -> Vec<View> {
        views_seeded(cams, poses, noise, 1)
    }

    fn views_seeded(cams: &[Camera], poses: &[Isometry3<f64>], noise: f64, seed: u64) -> Vec<View> {
        let mut views = Vec::new();
        let mut seed = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut gauss = move || {
            // Box–Muller on a 64-bit LCG: reproducible noise.
            let mut u = || {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        for (p, pose) in poses.iter().enumerate() {
            for (c, cam) in cams.iter().enumerate() {
                let observations = board()
                    .iter()
                    .enumerate()
                    .filter_map(|(id, x)| {
                        let px = cam.project(&(pose * x)).ok()?;
                        Some(Observation {
                            id: id as u32,
                            world: *x,
                            pixel: Point2::new(px.x + noise * gauss(), px.y + noise * gauss()),
                            sphere_diameter: None,
                        })
                    })
                    .collect();
                views.push(View {
                    camera: c as u8 + 1,
                    pose: p as u32 + 10,
                    observations,
                });
            }
        }
        views
    }

    fn sizes() -> BTreeMap<u8, (u32, u32)> {
        [(1, (1280, 960)), (2, (1280, 960))].into_iter().collect()
    }

    #[test]
    fn exact_views_give_the_rig_back() {
        let (cams, poses) = scene();
        let views = views_of(&cams, &poses, 0.0);
        let rig = calibrate_views(&views, &sizes(), &Options::default()).unwrap();
        assert!(rig.planar);
        assert_eq!(rig.world_pose, 10);
        // The world frame is the board at the first pose.
        let world = poses[0];
        for (got, want) in rig.cameras.iter().zip(&cams) {
            let k = got.camera.intrinsics;
            assert!((k.fx - want.intrinsics.fx).abs() < 1e-4, "fx {}", k.fx);
            assert!((k.cy - want.intrinsics.cy).abs() < 1e-4, "cy {}", k.cy);
            assert!((got.camera.distortion.k1 - want.distortion.k1).abs() < 1e-7);
            let true_pose = want.pose * world;
            assert!(
                (got.camera.pose.translation.vector - true_pose.translation.vector).norm() < 1e-4
            );
            assert!(got.rms_px < 1e-6, "rms {}", got.rms_px);
        }
        for (p, pose) in poses.iter().enumerate() {
            let got = rig.poses[&(p as u32 + 10)];
            let want = world.inverse() * pose;
            assert!((got.translation.vector - want.translation.vector).norm() < 1e-4);
        }
    }

    #[test]
    fn noisy_views_within_their_sigma_and_outliers_rejected_per_view() {
        let (cams, poses) = scene();
        let mut views = views_of(&cams, &poses, 0.1);
        // A gross outlier in one view.
        views[3].observations[7].pixel.x += 25.0;
        let rig = calibrate_views(&views, &sizes(), &Options::default()).unwrap();
        assert!(rig.views[3].residuals[7].outlier);
        for (got, want) in rig.cameras.iter().zip(&cams) {
            let sd = |n: &str| {
                got.parameters
                    .iter()
                    .find(|p| p.name == n)
                    .and_then(|p| p.std_dev)
                    .unwrap()
            };
            let k = got.camera.intrinsics;
            assert!(
                (k.fx - want.intrinsics.fx).abs() < 4.0 * sd("fx"),
                "fx {} σ {}",
                k.fx,
                sd("fx")
            );
            assert!((k.cx - want.intrinsics.cx).abs() < 4.0 * sd("cx"));
            assert!(
                (got.rms_px - 0.1 * 2f64.sqrt()).abs() < 0.02,
                "rms {}",
                got.rms_px
            );
        }
    }

    #[test]
    fn the_joint_covariance_covers_the_truth() {
        // 40 noise draws of the 2-camera rig: each camera's fx, fy, cx, cy,
        // k1 and its position relative to the first pose within 2σ of the
        // truth in about 95 % of the draws (90–99 % accepted: 40 × 12
        // figures, binomial spread ≈ 1 %).
        let (cams, poses) = scene();
        let world = poses[0];
        let (mut inside, mut total) = (0, 0);
        for seed in 0..40 {
            let views = views_seeded(&cams, &poses, 0.2, seed);
            let rig = calibrate_views(&views, &sizes(), &Options::default()).unwrap();
            for (got, want) in rig.cameras.iter().zip(&cams) {
                let k = want.intrinsics;
                let t = (want.pose * world).translation.vector;
                let truth = [
                    ("fx", k.fx),
                    ("fy", k.fy),
                    ("cx", k.cx),
                    ("cy", k.cy),
                    ("k1", want.distortion.k1),
                    ("tz", t.z),
                ];
                for (name, value) in truth {
                    let p = got.parameters.iter().find(|p| p.name == name).unwrap();
                    total += 1;
                    if (p.value - value).abs() <= 2.0 * p.std_dev.unwrap() {
                        inside += 1;
                    }
                }
            }
        }
        let share = f64::from(inside) / f64::from(total);
        assert!(
            (0.90..=0.99).contains(&share),
            "{inside} of {total} within 2σ"
        );
    }

    #[test]
    fn the_data_choose_k3_where_the_lens_has_it() {
        let (mut cams, poses) = scene();
        let lean =
            calibrate_views_choosing(&views_of(&cams, &poses, 0.1), &sizes(), &Options::default())
                .unwrap()
                .1
                .unwrap();
        assert!(!lean.chosen.k3, "{}", lean.reason);
        for c in &mut cams {
            c.distortion.k3 = 0.3;
        }
        let (rig, rich) =
            calibrate_views_choosing(&views_of(&cams, &poses, 0.1), &sizes(), &Options::default())
                .unwrap();
        let rich = rich.unwrap();
        assert!(rich.chosen.k3 && rig.layout.k3, "{}", rich.reason);
        // k3 is poorly separated from k1, k2 over this field: judged by its σ.
        for c in &rig.cameras {
            let sd = c
                .parameters
                .iter()
                .find(|p| p.name == "k3")
                .and_then(|p| p.std_dev)
                .unwrap();
            let k3 = c.camera.distortion.k3;
            assert!((k3 - 0.3).abs() < 4.0 * sd, "k3 {k3} ± {sd}");
        }
    }

    #[test]
    fn the_volume_uncertainty_covers_the_triangulation_error() {
        // 40 noise draws of the 2-camera rig: the true pixels of points of
        // the volume (the true cameras' projections) triangulated with each
        // draw's cameras, against the truth (the world frame: the board at
        // the first pose), within 2σ of volume_uncertainty's figures.
        let (cams, poses) = scene();
        let world = poses[0];
        let truth: Vec<Camera> = cams
            .iter()
            .map(|c| {
                let mut c = c.clone();
                c.pose *= world;
                c
            })
            .collect();
        let (mut inside, mut total) = (0, 0);
        for seed in 0..40 {
            let views = views_seeded(&cams, &poses, 0.2, seed + 100);
            let rig = calibrate_views(&views, &sizes(), &Options::default()).unwrap();
            for v in volume_uncertainty(&rig, &views, 3) {
                let Some(sigma) = v.sigma_um else { continue };
                let tri: Vec<geom::triangulate::View<'_>> = rig
                    .cameras
                    .iter()
                    .zip(&truth)
                    .map(|(c, t)| {
                        let observed = t.project(&v.point).unwrap();
                        geom::triangulate::View {
                            camera: &c.camera,
                            ideal_px: c.camera.undistort_pixel(observed).unwrap(),
                        }
                    })
                    .collect();
                let got = geom::triangulate::triangulate(&tri, 0.0).unwrap().point;
                let error = 1000.0 * (got - v.point);
                for a in 0..3 {
                    total += 1;
                    if error[a].abs() <= 2.0 * sigma[a] {
                        inside += 1;
                    }
                }
            }
        }
        let share = f64::from(inside) / f64::from(total);
        // Measured: 1769 of 1800 (98.3 %): the cameras' errors taken as
        // independent leave the figure on the safe side here.
        assert!(
            (0.90..=0.99).contains(&share),
            "{inside} of {total} within 2σ"
        );
    }

    #[test]
    fn bundle_jacobian_matches_central_differences() {
        let (cams, poses) = scene();
        let views = views_of(&cams, &poses, 0.0);
        let layout = Layout {
            model: Model::K1K2P1P2,
            k3: true,
            skew: false,
        };
        // In the world frame of the first pose.
        let world = poses[0];
        let cams: Vec<Camera> = cams
            .into_iter()
            .map(|mut c| {
                c.pose *= world;
                c
            })
            .collect();
        let poses: Vec<Isometry3<f64>> = poses.iter().map(|p| world.inverse() * p).collect();
        let problem = Bundle {
            layout,
            camera_r0: cams.iter().map(Camera::rotation).collect(),
            pose_r0: poses[1..]
                .iter()
                .map(|p| p.rotation.to_rotation_matrix())
                .collect(),
            points: views
                .iter()
                .flat_map(|v| {
                    v.observations.iter().take(5).map(move |o| BundlePoint {
                        camera: usize::from(v.camera - 1),
                        pose: (v.pose > 10).then(|| (v.pose - 11) as usize),
                        world: o.world,
                        pixel: o.pixel,
                        radius: 0.0,
                    })
                })
                .collect(),
        };
        let mut p = DVector::zeros(problem.unknowns());
        for (k, c) in cams.iter().enumerate() {
            p.rows_mut(k * layout.len(), layout.len())
                .copy_from(&layout.pack(c));
            p[k * layout.len() + 4] = 0.05;
        }
        for k in 0..poses.len() - 1 {
            let o = problem.pose_offset(k);
            p.fixed_rows_mut::<3>(o + 3)
                .copy_from(&poses[k + 1].translation.vector);
            p[o] = 0.02;
            p[o + 2] = -0.03;
        }
        let err = jacobian_error(&problem, &p);
        assert!(err < 1e-6, "Jacobian error {err}");
    }

    #[test]
    fn a_camera_sharing_no_pose_is_cut_off() {
        let (cams, poses) = scene();
        let mut views = views_of(&cams, &poses, 0.0);
        // Camera 2 sees only poses camera 1 never sees.
        for v in &mut views {
            if v.camera == 2 {
                v.pose += 100;
            }
        }
        let err = calibrate_views(&views, &sizes(), &Options::default()).unwrap_err();
        assert!(matches!(err, CalibError::CutOff { camera: 2, .. }), "{err}");
    }
}
