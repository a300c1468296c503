//! One camera from 3-D ↔ 2-D correspondences: normalised DLT → RQ → K, R, t,
//! then Levenberg–Marquardt on reprojection error with the chosen distortion
//! model, iterated with k·σ outlier rejection (docs/methods.md, Calibration).

use std::collections::{HashMap, HashSet};

use formats::{CorrespondenceRow, TargetRow};

use geom::lm::Residuals;
use geom::{Camera, Matrix3x4, Point2, Point3, Vector2};

use crate::dlt::{self, MIN_POINTS};
use crate::outliers::{inliers, robust_sigma};
use crate::refine::{Layout, Model, Reprojection, refine};
use crate::{CalibError, OptionProblem, Result};

/// Default k of the outlier rejection `|r| > k·σ`.
pub const DEFAULT_OUTLIER_K: f64 = 4.0;
/// Default limit on fit-and-reject rounds.
pub const DEFAULT_MAX_ROUNDS: usize = 10;

/// One marker seen by the camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Marker id on the target.
    pub id: u32,
    /// Marker centre, target frame (mm).
    pub world: Point3<f64>,
    /// Observed centroid (px, centre of the top-left pixel = 0).
    pub pixel: Point2<f64>,
    /// Diameter (mm) when the marker is a sphere whose image centroid was
    /// measured: the model then predicts the centre of its outline ellipse.
    /// `None` for a point-like marker.
    pub sphere_diameter: Option<f64>,
}

impl Observation {
    /// The marker's radius in the model (mm): half its diameter, 0 for a point.
    pub fn radius(&self) -> f64 {
        self.sphere_diameter.map_or(0.0, |d| d / 2.0)
    }
}

/// Observations as the fits take them: marker centres, pixels, radii.
pub(crate) fn split<'a>(
    observations: impl IntoIterator<Item = &'a Observation>,
) -> (Vec<Point3<f64>>, Vec<Point2<f64>>, Vec<f64>) {
    let mut out = (Vec::new(), Vec::new(), Vec::new());
    for o in observations {
        out.0.push(o.world);
        out.1.push(o.pixel);
        out.2.push(o.radius());
    }
    out
}

/// What to estimate and how to treat outliers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Distortion model.
    pub model: Model,
    /// Also estimate k3.
    pub k3: bool,
    /// Also estimate the skew.
    pub skew: bool,
    /// Reject points with `|r| > k·σ` (σ: the robust σ of the residuals) and refit; `None` keeps every point.
    pub outlier_k: Option<f64>,
    /// Most fit-and-reject rounds.
    pub max_rounds: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            model: Model::K1K2P1P2,
            k3: false,
            skew: false,
            outlier_k: Some(DEFAULT_OUTLIER_K),
            max_rounds: DEFAULT_MAX_ROUNDS,
        }
    }
}

impl Options {
    /// The refinement's parameter layout.
    pub fn layout(&self) -> Layout {
        Layout {
            model: self.model,
            k3: self.k3,
            skew: self.skew,
        }
    }

    /// Check the values.
    pub fn validate(&self) -> Result<()> {
        self.layout().validate()?;
        if let Some(k) = self.outlier_k
            && !(k.is_finite() && k >= 1.0)
        {
            return Err(CalibError::Option(OptionProblem::OutlierK(k)));
        }
        if self.max_rounds == 0 {
            return Err(CalibError::Option(OptionProblem::NoRound));
        }
        Ok(())
    }
}

/// A point's reprojection residual under the final camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointResidual {
    /// Marker id.
    pub id: u32,
    /// Predicted − observed u (px).
    pub du: f64,
    /// Predicted − observed v (px).
    pub dv: f64,
    /// Rejected as an outlier (not used in the final fit).
    pub outlier: bool,
}

/// An estimated parameter with its standard deviation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parameter {
    /// Name (`fx`, `fy`, `cx`, `cy`, `skew`, `rx`…`rz`, `tx`…`tz`, `k1`, `k2`, `p1`, `p2`, `k3`).
    pub name: &'static str,
    /// Value: px for K, mm for t, dimensionless for distortion; `rx, ry, rz`
    /// are the rotation vector of R (OpenCV's rvec, rad).
    pub value: f64,
    /// Standard deviation from `s²·(JᵀJ)⁻¹` (for `rx, ry, rz`: of a small
    /// rotation about the camera axes, rad); `None` when not determined.
    pub std_dev: Option<f64>,
}

/// A calibrated camera and its quality figures.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// The camera (K, distortion, pose: target frame → camera).
    pub camera: Camera,
    /// Options it was estimated with.
    pub options: Options,
    /// Projection matrix of the normalised DLT on all points (before refinement).
    pub dlt: Matrix3x4<f64>,
    /// RMS reprojection error of the DLT on all points, `√(Σ|r|²/N)` (px).
    pub dlt_rms_px: f64,
    /// RMS reprojection error of the final model on the points used, `√(Σ|r|²/N)` (px).
    pub rms_px: f64,
    /// Robust per-coordinate σ of the final residuals (px).
    pub sigma_px: f64,
    /// Residual of every observation, in input order.
    pub residuals: Vec<PointResidual>,
    /// Estimated parameters.
    pub parameters: Vec<Parameter>,
    /// Ids rejected as outliers.
    pub outliers: Vec<u32>,
    /// Fit-and-reject rounds used.
    pub rounds: usize,
}

impl Calibration {
    /// Number of points used in the final fit.
    pub fn points_used(&self) -> usize {
        self.residuals.iter().filter(|r| !r.outlier).count()
    }

    /// The parameter of this name.
    pub fn parameter(&self, name: &str) -> Option<&Parameter> {
        self.parameters.iter().find(|p| p.name == name)
    }
}

/// Check the observations: finite coordinates, unique ids, positive diameters.
pub fn validate(observations: &[Observation]) -> Result<()> {
    let mut seen = HashSet::new();
    for o in observations {
        for (field, value) in [
            ("x", o.world.x),
            ("y", o.world.y),
            ("z", o.world.z),
            ("u", o.pixel.x),
            ("v", o.pixel.y),
        ] {
            if !value.is_finite() {
                return Err(CalibError::NonFinite {
                    id: o.id,
                    field,
                    value,
                });
            }
        }
        if let Some(d) = o.sphere_diameter
            && !(d.is_finite() && d > 0.0)
        {
            return Err(CalibError::NonFinite {
                id: o.id,
                field: "diameter",
                value: d,
            });
        }
        if !seen.insert(o.id) {
            return Err(CalibError::DuplicateId { id: o.id });
        }
    }
    Ok(())
}

/// Check a calibration target on its own, before any camera: at least
/// [`MIN_POINTS`](crate::MIN_POINTS) markers, finite coordinates, each id once, and the
/// markers spanning space (a DLT needs a 3-D target).
pub fn check_target(target: &[TargetRow]) -> Result<()> {
    if target.len() < MIN_POINTS {
        return Err(CalibError::TooFewPoints {
            what: "a calibration target",
            needed: MIN_POINTS,
            got: target.len(),
        });
    }
    let mut ids = HashSet::with_capacity(target.len());
    let mut points = Vec::with_capacity(target.len());
    for t in target {
        for (field, value) in [("x", t.x), ("y", t.y), ("z", t.z)] {
            if !value.is_finite() {
                return Err(CalibError::NonFinite {
                    id: t.id,
                    field,
                    value,
                });
            }
        }
        if !ids.insert(t.id) {
            return Err(CalibError::DuplicateId { id: t.id });
        }
        points.push(Point3::new(t.x, t.y, t.z));
    }
    dlt::Spread::of(&points).check()
}

/// Observations from `target.csv` rows and `id,u,v` correspondences: each
/// correspondence's id must be on the target and occur once; with
/// `spheres`, the target's diameters make the markers spheres.
pub fn observations(
    target: &[TargetRow],
    points: &[CorrespondenceRow],
    spheres: bool,
) -> Result<Vec<Observation>> {
    let mut by_id = HashMap::new();
    for t in target {
        if by_id.insert(t.id, t).is_some() {
            return Err(CalibError::DuplicateId { id: t.id });
        }
    }
    let out: Vec<Observation> = points
        .iter()
        .map(|p| {
            let t = by_id.get(&p.id).ok_or(CalibError::UnknownId { id: p.id })?;
            Ok(Observation {
                id: p.id,
                world: Point3::new(t.x, t.y, t.z),
                pixel: Point2::new(p.u, p.v),
                sphere_diameter: if spheres { t.diameter } else { None },
            })
        })
        .collect::<Result<_>>()?;
    validate(&out)?;
    Ok(out)
}

/// RMS length of 2-D residuals, `√(Σ|r|²/N)` (px).
pub fn rms(residuals: &[Vector2<f64>]) -> f64 {
    if residuals.is_empty() {
        return 0.0;
    }
    (residuals.iter().map(|r| r.norm_squared()).sum::<f64>() / residuals.len() as f64).sqrt()
}

/// Calibrate one camera of a `width × height` sensor from its observations:
/// normalised DLT (Hartley & Zisserman Algorithm 7.1), RQ decomposition into
/// K, R, t, then Levenberg–Marquardt on the reprojection error from the DLT
/// camera with zero distortion, rejecting `|r| > k·σ` and refitting until the
/// set of points used no longer changes.
pub fn calibrate(
    observations: &[Observation],
    width: u32,
    height: u32,
    options: &Options,
) -> Result<Calibration> {
    options.validate()?;
    validate(observations)?;
    if width == 0 || height == 0 {
        return Err(CalibError::Option(OptionProblem::ImageSize {
            width,
            height,
        }));
    }
    if observations.len() < MIN_POINTS {
        return Err(CalibError::TooFewPoints {
            what: "calibration",
            needed: MIN_POINTS,
            got: observations.len(),
        });
    }
    let (world, image, radius) = split(observations);

    let p_dlt = dlt::dlt(&world, &image)?;
    let dlt_res: Vec<Vector2<f64>> = dlt::residuals(&p_dlt, &world, &image)
        .into_iter()
        .zip(observations)
        .map(|(r, o)| {
            r.ok_or_else(|| CalibError::BehindCamera {
                id: o.id,
                depth_mm: (p_dlt * o.world.to_homogeneous()).z,
            })
        })
        .collect::<Result<_>>()?;
    let dlt_rms_px = rms(&dlt_res);
    let mut camera = Camera::from_projection_matrix(&p_dlt, width, height)
        .map_err(CalibError::geom("decomposing the DLT projection"))?;
    if !options.skew {
        camera.intrinsics.skew = 0.0;
    }
    let layout = options.layout();

    let mut used = vec![true; observations.len()];
    let mut rounds = 0;
    let (refined, all_res) = loop {
        rounds += 1;
        let (w, i, r) = (
            subset(&world, &used),
            subset(&image, &used),
            subset(&radius, &used),
        );
        if w.len() < MIN_POINTS {
            return Err(CalibError::TooFewPoints {
                what: "calibration after outlier rejection",
                needed: MIN_POINTS,
                got: w.len(),
            });
        }
        let refined = refine(layout, &camera, &w, &i, &r)?;
        camera = refined.camera.clone();
        let all_res = residuals_of(&camera, layout, &world, &image, &radius);
        let Some(k) = options.outlier_k else {
            break (refined, all_res);
        };
        let next = inliers(&all_res, robust_sigma(&all_res), k);
        if next == used || rounds >= options.max_rounds {
            break (refined, all_res);
        }
        used = next;
    };

    let used_res = subset(&all_res, &used);
    let parameters = parameters(layout, &camera, refined.std_devs.as_deref());
    let residuals = observations
        .iter()
        .zip(&all_res)
        .zip(&used)
        .map(|((o, r), u)| PointResidual {
            id: o.id,
            du: r.x,
            dv: r.y,
            outlier: !u,
        })
        .collect();
    Ok(Calibration {
        camera,
        options: *options,
        dlt: p_dlt,
        dlt_rms_px,
        rms_px: rms(&used_res),
        sigma_px: robust_sigma(&used_res),
        residuals,
        parameters,
        outliers: observations
            .iter()
            .zip(&used)
            .filter(|(_, u)| !**u)
            .map(|(o, _)| o.id)
            .collect(),
        rounds,
    })
}

/// A camera's parameters in `layout`'s order with their standard
/// deviations (`rx, ry, rz` the rotation vector of R).
pub(crate) fn parameters(
    layout: Layout,
    camera: &Camera,
    std_devs: Option<&[f64]>,
) -> Vec<Parameter> {
    let rvec = camera.rotation().scaled_axis();
    let values = layout.pack(camera);
    let names = layout.names();
    let rot = names.iter().position(|n| *n == "rx").unwrap_or(0);
    names
        .iter()
        .enumerate()
        .map(|(j, &name)| Parameter {
            name,
            value: if (rot..rot + 3).contains(&j) {
                rvec[j - rot]
            } else {
                values[j]
            },
            std_dev: std_devs.map(|s| s[j]),
        })
        .collect()
}

/// The elements whose flag is set.
fn subset<T: Copy>(values: &[T], flags: &[bool]) -> Vec<T> {
    values
        .iter()
        .zip(flags)
        .filter(|(_, f)| **f)
        .map(|(v, _)| *v)
        .collect()
}

/// Residuals of every point under a camera (non-finite for a point behind it).
pub(crate) fn residuals_of(
    camera: &Camera,
    layout: Layout,
    world: &[Point3<f64>],
    image: &[Point2<f64>],
    radius: &[f64],
) -> Vec<Vector2<f64>> {
    let problem = Reprojection {
        layout,
        r0: camera.rotation(),
        world,
        image,
        radius,
    };
    let r = problem.residuals(&layout.pack(camera));
    (0..world.len())
        .map(|i| Vector2::new(r[2 * i], r[2 * i + 1]))
        .collect()
}
