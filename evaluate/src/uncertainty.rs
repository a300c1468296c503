//! The expanded uncertainty (k = 2) of every figure, by Monte Carlo (GUM
//! Supplement 1; docs/uncertainty.md).
//!
//! A trial redraws what the measurement was computed from and computes the
//! report again: each camera's parameters from its calibration's covariance
//! (`rig.json`; one draw per camera per trial, shared by every instant, so
//! that what the calibration got wrong is not averaged away by runs and
//! captures), split into the least-squares part and the target markers'
//! part; and each sphere image's centre from its covariance
//! (`<stem>.observations.csv`, independent between images). The observed
//! centre moves with a drawn camera as the image it came from would: the
//! ideal centre is distorted back through the calibrated lens to where it was
//! seen and undistorted through the drawn one. Every sphere centre is then
//! triangulated again and every figure evaluated again; U is the half-width
//! of the interval about the reported figure that holds 95 % of the trials
//! (`geom::montecarlo`).

use std::collections::{BTreeMap, HashMap};

use formats::evaluation::{AngularTarget, LineReport};
use formats::uncertainty::{
    BoundKind, FigureKeys, Source, Statement, TRIALS_OFF, Uncertainty, bounded, figures,
};
use formats::{CameraCovariance, InstantKey, ObservationRow, PointRow};
use geom::montecarlo::{COVERAGE_FACTOR, CovarianceRoot, Trial, propagate as monte_carlo};
use geom::nalgebra::DMatrix;
use geom::triangulate::{View, triangulate};
use geom::{Camera, Point2, Point3, Vector2};

use crate::{Options, Report, evaluate};

/// The Monte Carlo's settings, as the command sets them.
pub use geom::montecarlo::{DEFAULT_TRIALS, Propagation};

/// Which numbers of `report.json` are figures: µm and µrad, not the
/// per-target tables nor the rigid fits' residual.
pub const FIGURE_KEYS: FigureKeys = FigureKeys {
    units: &["_um", "_urad"],
    skip: &[
        "targets",
        "points",
        "fit_rms_um",
        "uncertainty",
        "conditions",
        "uncorrected",
        "conformance",
    ],
};

/// Source indices in the propagation; the target's and the temperature's
/// follow when present ([`Sources`]).
const CENTROIDS: usize = 0;
const CALIBRATION: usize = 1;

/// The sources of one propagation and their indices.
struct Sources {
    names: Vec<&'static str>,
    target: Option<usize>,
    temperature: Option<usize>,
}

impl Sources {
    fn new(with_target: bool, with_temperature: bool) -> Self {
        let mut names = vec!["centroids", "calibration"];
        let mut add = |on: bool, name| {
            on.then(|| {
                names.push(name);
                names.len() - 1
            })
        };
        let target = add(with_target, "target");
        let temperature = add(with_temperature, "temperature");
        Sources {
            names,
            target,
            temperature,
        }
    }
}

/// What the figures were measured with: the calibrated cameras by id and
/// their parameters' covariance.
#[derive(Debug, Clone, Copy)]
pub struct Instrument<'a> {
    /// The cameras (`rig.json`), by id.
    pub cameras: &'a BTreeMap<u8, Camera>,
    /// Each camera's parameter covariance, by id.
    pub covariance: &'a BTreeMap<u8, CameraCovariance>,
}

/// One camera's draws: its parameter names and the roots of its covariance
/// without and with only the target's part.
struct CameraDraw<'a> {
    id: u8,
    camera: &'a Camera,
    names: &'a [String],
    fit: CovarianceRoot,
    target: Option<CovarianceRoot>,
}

/// One image of a sphere: the camera, the centre in ideal pixels, where it
/// was seen (observed pixels), and the root of its covariance.
struct Seen {
    camera: u8,
    ideal: Point2<f64>,
    observed: Point2<f64>,
    root: [[f64; 2]; 2],
}

/// One row of `points.csv` with the images it was triangulated from and the
/// centre those images give at the estimate (the trial's shift is added to
/// the row's own coordinates).
struct Sighted {
    row: usize,
    radius: f64,
    images: Vec<Seen>,
    centre: Point3<f64>,
}

/// Lower-triangular root of a 2×2 covariance.
fn root2(c: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    let l11 = c[0][0].max(0.0).sqrt();
    let l21 = if l11 > 0.0 { c[1][0] / l11 } else { 0.0 };
    let l22 = (c[1][1] - l21 * l21).max(0.0).sqrt();
    [[l11, 0.0], [l21, l22]]
}

/// The budget's headline figures: those of each axis's main line and the flatness.
fn headline(path: &str) -> bool {
    (path.starts_with("axes.") && !path.contains(".lines.")) || path.starts_with("flatness.")
}

/// Why no U can be given, as the report says it.
fn not_given(reason: impl Into<String>) -> Uncertainty {
    Uncertainty::NotGiven {
        reason: reason.into(),
    }
}

/// The report's uncertainty: U of every figure of `report` (evaluated from
/// `points` with `options`) from the images' `observations`, the
/// `instrument` and, when the options' correction to 20 °C gives them, the
/// uncertainties of the machine's temperature and expansion coefficient
/// (Type B, normal, one draw per trial, the temperature's common to every
/// instant), or why there is none. `propagation.trials == 0` turns it off.
pub fn propagate(
    report: &Report,
    points: &[PointRow],
    observations: &[ObservationRow],
    instrument: Instrument<'_>,
    options: &Options,
    propagation: Propagation,
) -> Uncertainty {
    if propagation.trials == 0 {
        return not_given(TRIALS_OFF);
    }
    let cameras = match camera_draws(instrument) {
        Ok(c) => c,
        Err(reason) => return not_given(reason),
    };
    let sighted = match sightings(points, observations, instrument.cameras) {
        Ok(s) => s,
        Err(reason) => return not_given(reason),
    };
    let Ok(nominal) = figures(report, &FIGURE_KEYS) else {
        return not_given("the report's figures cannot be listed");
    };
    let with_target = cameras.iter().any(|c| c.target.is_some());
    let machine = options.machine.as_ref();
    let thermal = machine.filter(|m| m.temperature_u_c > 0.0 || m.alpha_u_um_per_m_k > 0.0);
    let sources = Sources::new(with_target, thermal.is_some());
    let result = monte_carlo(&nominal, &sources.names, propagation, |trial| {
        let rows = trial_points(trial, points, &sighted, &cameras, sources.target)?;
        let drawn;
        let trial_options = match (thermal, sources.temperature.and_then(|i| trial.draws(i))) {
            (Some(m), Some(d)) => {
                let (dt, da) = (
                    d.gaussian(m.temperature_u_c),
                    d.gaussian(m.alpha_u_um_per_m_k),
                );
                drawn = Options {
                    machine: Some(m.drawn(dt, da)),
                    ..options.clone()
                };
                &drawn
            }
            _ => options,
        };
        let r = evaluate(&rows, trial_options).ok()?;
        let mut f = figures(&r, &FIGURE_KEYS).ok()?;
        bound_ranges(report, &r, &nominal, &mut f);
        Some(f)
    });
    let source = |name: &'static str, description: &str| Source {
        name,
        description: description.to_string(),
    };
    let mut notes = vec![
        source(
            "centroids",
            "noise of each sphere image's centre (observations.csv covariance; independent between images)",
        ),
        source(
            "calibration",
            "the cameras' calibrated parameters (rig.json covariance, least-squares part; one draw per camera \
             and trial, shared by every instant)",
        ),
    ];
    if with_target {
        notes.push(source(
            "target",
            "the calibration target's marker coordinates (rig.json covariance, target part; shared by every instant)",
        ));
    }
    if let Some(m) = thermal {
        notes.push(source(
            "temperature",
            &format!(
                "the machine's temperature (u = {} °C) and expansion coefficient (u = {} µm/(m·K)) of the \
                 correction to 20 °C (conditions file; Type B, normal; one draw per trial)",
                m.temperature_u_c, m.alpha_u_um_per_m_k
            ),
        ));
    }
    let statement = Statement {
        method: format!(
            "Monte Carlo (GUM Supplement 1): U = half-width of the interval about the reported value holding 95 % \
             of the trial figures (k = {COVERAGE_FACTOR}); budget: each source alone, standard uncertainty"
        ),
        sources: notes,
        not_included: [
            match (machine, thermal) {
                (None, _) => Some(
                    "temperature: the machine's thermal expansion (no machine temperature and expansion \
                     coefficient given: --conditions)"
                        .to_string(),
                ),
                (Some(_), None) => Some(
                    "temperature: the uncertainty of the machine's temperature and expansion coefficient \
                     (none given in the conditions)"
                        .to_string(),
                ),
                (Some(_), Some(_)) => None,
            },
            (options.target_strain != 0.0).then(|| {
                "the calibration target's temperature: its correction is made, its uncertainty not \
                 included"
                    .to_string()
            }),
            Some("the machine's own scatter is in the figures (R, s), not in U".to_string()),
        ]
        .into_iter()
        .flatten()
        .collect(),
        headline: nominal.keys().filter(|p| headline(p)).cloned().collect(),
    };
    Uncertainty::from_trials(result, &nominal, statement, propagation)
}

/// The ranges over a line's targets — the angular errors (roll, pitch, yaw)
/// and the straightness (least squares and minimum zone) — take their trial
/// value from the bound on their error (`formats::uncertainty::Bound`):
/// `reported + range(d)`, `d` the per-target change of the trial from the
/// report (for the minimum zone, the minimum zone of `d`, since
/// `|zone(m) − zone(t)| ≤ zone(m − t)`). Their noise biases them upward by
/// about the range of the noise, which re-drawn trials reproduce only in
/// part (docs/uncertainty.md).
fn bound_ranges(
    reported: &Report,
    trial: &Report,
    nominal: &BTreeMap<String, f64>,
    figures: &mut BTreeMap<String, f64>,
) {
    for (axis, r) in reported.axes.iter() {
        let Some(t) = trial.axes.get(axis) else {
            continue;
        };
        let name = axis.name();
        let lines = std::iter::once((format!("axes.{name}"), &r.main, &t.main)).chain(
            r.lines
                .iter()
                .zip(&t.lines)
                .enumerate()
                .map(|(i, (r, t))| (format!("axes.{name}.lines.{i}"), r, t)),
        );
        for (prefix, r, t) in lines {
            bound_line(&prefix, r, t, nominal, figures);
        }
    }
}

/// [`bound_ranges`] for one line; nothing where the trial's targets are not
/// the report's.
fn bound_line(
    prefix: &str,
    r: &LineReport,
    t: &LineReport,
    nominal: &BTreeMap<String, f64>,
    figures: &mut BTreeMap<String, f64>,
) {
    if let (Some(ra), Some(ta)) = (&r.angular, &t.angular)
        && ra
            .targets
            .iter()
            .map(|x| x.target)
            .eq(ta.targets.iter().map(|x| x.target))
    {
        let change = |f: fn(&AngularTarget) -> f64| -> Vec<f64> {
            ra.targets
                .iter()
                .zip(&ta.targets)
                .map(|(a, b)| f(b) - f(a))
                .collect()
        };
        let ranges = [
            ("roll_urad", change(|x| x.roll_urad)),
            ("pitch_urad", change(|x| x.pitch_urad)),
            ("yaw_urad", change(|x| x.yaw_urad)),
        ];
        for (key, d) in ranges {
            let bound = BoundKind::Range.of(d);
            bounded(nominal, &format!("{prefix}.angular.{key}"), bound, figures);
        }
    }
    for (direction, rs) in &r.straightness {
        let Some(ts) = t.straightness.get(direction) else {
            continue;
        };
        if !rs
            .targets
            .iter()
            .map(|x| x.target)
            .eq(ts.targets.iter().map(|x| x.target))
        {
            continue;
        }
        let d: Vec<f64> = rs
            .targets
            .iter()
            .zip(&ts.targets)
            .map(|(a, b)| b.deviation_um - a.deviation_um)
            .collect();
        let path = format!("{prefix}.straightness.{direction}");
        bounded(
            nominal,
            &format!("{path}.lsq_um"),
            BoundKind::Range.of(d.iter().copied()),
            figures,
        );
        // The profile of d, along and across the axis in µm.
        let profile: Vec<Point2<f64>> = rs
            .targets
            .iter()
            .zip(&d)
            .map(|(a, d)| Point2::new(a.nominal * 1e3, *d))
            .collect();
        if let Ok(zone) = geom::min_zone::straightness(&profile) {
            bounded(nominal, &format!("{path}.min_zone_um"), zone.width, figures);
        }
    }
}

/// Each camera's draws; every camera must carry its covariance.
fn camera_draws(instrument: Instrument<'_>) -> Result<Vec<CameraDraw<'_>>, String> {
    instrument
        .cameras
        .iter()
        .map(|(&id, camera)| {
            let cov = instrument.covariance.get(&id).ok_or_else(|| {
                format!(
                    "camera {id} of the rig has no parameter covariance (a rig.json calibrated before \
                     uncertainties were recorded: calibrate again)"
                )
            })?;
            let bad = |what: &str| format!("camera {id}: the rig's {what} is not a covariance matrix");
            let total = cov.to_matrix().ok_or_else(|| bad("covariance"))?;
            let target = cov.target_matrix();
            let fit = match &target {
                Some(t) => &total - t,
                None => total.clone(),
            };
            Ok(CameraDraw {
                id,
                camera,
                names: &cov.parameters,
                fit: CovarianceRoot::new(&fit).map_err(|_| bad("covariance"))?,
                target: match target {
                    Some(t) if t.iter().any(|v| *v != 0.0) => {
                        Some(CovarianceRoot::new(&t).map_err(|_| bad("target covariance"))?)
                    }
                    _ => None,
                },
            })
        })
        .collect()
}

/// Every row of `points` with its images; every row must have its images
/// and each image its covariance.
fn sightings(
    points: &[PointRow],
    observations: &[ObservationRow],
    cameras: &BTreeMap<u8, Camera>,
) -> Result<Vec<Sighted>, String> {
    let mut by_row: HashMap<(InstantKey, &str), Vec<&ObservationRow>> = HashMap::new();
    for o in observations {
        by_row
            .entry((o.instant(), o.sphere.as_str()))
            .or_default()
            .push(o);
    }
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let name = || {
                format!(
                    "sphere {} at {} run {} target {} capture {}",
                    p.sphere,
                    p.axis.name(),
                    p.run,
                    p.target,
                    p.capture
                )
            };
            let obs = by_row
                .get(&(p.instant(), p.sphere.as_str()))
                .filter(|o| o.len() >= 2)
                .ok_or_else(|| format!("{} has no observations of two cameras to propagate", name()))?;
            let radius = obs[0].radius_mm;
            let images = obs
                .iter()
                .map(|o| {
                    let camera = cameras
                        .get(&o.camera)
                        .ok_or_else(|| format!("{}: camera {} is not in the rig", name(), o.camera))?;
                    let cov = o.covariance().ok_or_else(|| {
                        format!(
                            "the noise of the image centres is unknown ({}, camera {}): no noise model \
                             (flat and dark stacks, or repeated captures)",
                            name(),
                            o.camera
                        )
                    })?;
                    let ideal = Point2::new(o.u, o.v);
                    Ok(Seen {
                        camera: o.camera,
                        ideal,
                        observed: camera.distort_pixel(ideal),
                        root: root2(cov),
                    })
                })
                .collect::<Result<Vec<_>, String>>()?;
            let views: Vec<View<'_>> = images
                .iter()
                .filter_map(|s| {
                    cameras.get(&s.camera).map(|camera| View {
                        camera,
                        ideal_px: s.ideal,
                    })
                })
                .collect();
            let centre = triangulate(&views, radius)
                .map_err(|e| format!("{}: its images do not triangulate ({e})", name()))?
                .point;
            Ok(Sighted {
                row: i,
                radius,
                images,
                centre,
            })
        })
        .collect()
}

/// The points of one trial: cameras drawn, image centres drawn and moved
/// with their camera, every sphere centre triangulated again.
fn trial_points(
    trial: &mut Trial,
    points: &[PointRow],
    sighted: &[Sighted],
    cameras: &[CameraDraw<'_>],
    target: Option<usize>,
) -> Option<Vec<PointRow>> {
    let mut drawn: BTreeMap<u8, Option<Camera>> = BTreeMap::new();
    for c in cameras {
        let mut delta = DMatrix::<f64>::zeros(c.fit.dim(), 1).column(0).into_owned();
        let mut moved = false;
        if let Some(d) = trial.draws(CALIBRATION) {
            delta += c.fit.draw(d);
            moved = true;
        }
        if let (Some(d), Some(t)) = (target.and_then(|i| trial.draws(i)), &c.target) {
            delta += t.draw(d);
            moved = true;
        }
        let camera = if moved {
            Some(c.camera.perturbed(c.names, delta.as_slice()).ok()?)
        } else {
            None
        };
        drawn.insert(c.id, camera);
    }
    let mut rows = points.to_vec();
    for s in sighted {
        let mut ideal = Vec::with_capacity(s.images.len());
        for image in &s.images {
            let mut p = match drawn.get(&image.camera)? {
                Some(camera) => camera.undistort_pixel(image.observed).ok()?,
                None => image.ideal,
            };
            if let Some(d) = trial.draws(CENTROIDS) {
                let z = Vector2::new(d.normal(), d.normal());
                let l = image.root;
                p += Vector2::new(l[0][0] * z.x, l[1][0] * z.x + l[1][1] * z.y);
            }
            ideal.push(p);
        }
        let views: Vec<View<'_>> = s
            .images
            .iter()
            .zip(&ideal)
            .filter_map(|(image, &p)| {
                let camera = match drawn.get(&image.camera)? {
                    Some(c) => c,
                    None => cameras.iter().find(|c| c.id == image.camera)?.camera,
                };
                Some(View {
                    camera,
                    ideal_px: p,
                })
            })
            .collect();
        let centre = triangulate(&views, s.radius).ok()?.point;
        let shift = centre - s.centre;
        let row = &mut rows[s.row];
        row.x += shift.x;
        row.y += shift.y;
        row.z += shift.z;
    }
    Some(rows)
}
