//! Lines of a campaign: the sweeps of an axis at fixed off-axis nominal
//! coordinates, their targets and runs, and the per-line evaluation
//! (positioning, straightness, angular errors).

use std::collections::BTreeMap;

use formats::{Axis, Direction};
use geom::{Point2, Point3, Vector3};

use crate::axis_frame::AxisFrame;
use crate::iso230_2::{TargetDeviations, TargetFigures};
use crate::points::{Located, measured_column, nominal_column, row_error};
use crate::{
    EvaluateError, Fitted, LineName, Result, RowProblem, angular, iso230_2, straightness, vdi3441,
};
use formats::evaluation::{
    ANGULAR_CONVENTION, AngularReport, AngularTarget, LineReport, PositioningReport,
    PositioningTarget, StraightnessReport, StraightnessTarget, Vdi3441Report,
};

/// Rows whose off-axis commanded coordinates differ by less than this (mm)
/// belong to the same line.
pub const LINE_TOLERANCE_MM: f64 = 0.01;
/// Rows of one target must agree on its commanded axis coordinate to this (mm).
pub const TARGET_TOLERANCE_MM: f64 = 1e-4;
/// Millimetres → micrometres.
fn um(mm: f64) -> f64 {
    mm * 1e3
}

/// Radians → microradians.
fn urad(rad: f64) -> f64 {
    rad * 1e6
}

/// One sweep of an axis.
#[derive(Debug, Clone)]
pub(crate) struct Line<'a> {
    /// Axis moved.
    pub axis: Axis,
    /// Off-axis commanded coordinates (mm), in the order of `Axis::others` sorted.
    pub off_axis: [(Axis, f64); 2],
    /// Every row of the line, all spheres, in file order.
    pub rows: Vec<Located<'a>>,
}

impl Line<'_> {
    /// The line as messages name it.
    pub fn name(&self) -> LineName {
        LineName {
            axis: self.axis,
            off_axis: self.off_axis,
        }
    }

    /// Distance of the line from the origin in the off-axis coordinates.
    pub fn offset(&self) -> f64 {
        self.off_axis[0].1.hypot(self.off_axis[1].1)
    }
}

/// The off-axis world axes of `axis`, sorted.
fn off_axes(axis: Axis) -> [Axis; 2] {
    let mut o = axis.others();
    o.sort();
    o
}

/// Group rows into lines: per axis, by off-axis commanded coordinates (within
/// [`LINE_TOLERANCE_MM`]); lines ordered by axis, then off-axis coordinates.
pub(crate) fn group<'a>(rows: &[Located<'a>]) -> Vec<Line<'a>> {
    let mut lines: Vec<Line<'a>> = Vec::new();
    for r in rows {
        let axis = r.row.axis;
        let o = off_axes(axis);
        let n = r.row.nominal();
        let coords = [n[o[0].index()], n[o[1].index()]];
        let found = lines.iter_mut().find(|l| {
            l.axis == axis
                && (l.off_axis[0].1 - coords[0]).abs() <= LINE_TOLERANCE_MM
                && (l.off_axis[1].1 - coords[1]).abs() <= LINE_TOLERANCE_MM
        });
        match found {
            Some(l) => l.rows.push(*r),
            None => lines.push(Line {
                axis,
                off_axis: [(o[0], coords[0]), (o[1], coords[1])],
                rows: vec![*r],
            }),
        }
    }
    lines.sort_by(|a, b| {
        a.axis
            .cmp(&b.axis)
            .then(a.off_axis[0].1.total_cmp(&b.off_axis[0].1))
            .then(a.off_axis[1].1.total_cmp(&b.off_axis[1].1))
    });
    lines
}

/// The captures of one approach: (line, position) per capture.
type Approach = Vec<(u64, Point3<f64>)>;

/// A sphere's data on one line: target → (direction, run) → captures.
type SphereData = BTreeMap<u32, BTreeMap<(Direction, u32), Approach>>;

/// Mean of points (non-empty).
fn mean_point<'p>(points: impl Iterator<Item = &'p Point3<f64>>) -> Point3<f64> {
    let (sum, n) = points.fold((Vector3::zeros(), 0usize), |(s, n), p| {
        (s + p.coords, n + 1)
    });
    Point3::from(sum / n.max(1) as f64)
}

/// Per-target mean of a sphere: the mean of its run values (captures of an
/// approach averaged first), over all runs and both directions.
fn target_mean(runs: &BTreeMap<(Direction, u32), Approach>) -> Point3<f64> {
    let values: Vec<Point3<f64>> = runs
        .values()
        .map(|c| mean_point(c.iter().map(|(_, p)| p)))
        .collect();
    mean_point(values.iter())
}

/// The evaluation of one line, and the sphere's per-target mean points (for flatness).
pub(crate) struct LineResult {
    /// The figures.
    pub report: LineReport,
    /// Number of runs (distinct direction and run) of the evaluated sphere.
    pub runs: usize,
    /// Per-target mean positions of the evaluated sphere: (target, point).
    pub means: Vec<(u32, Point3<f64>)>,
    /// Remarks for the report.
    pub warnings: Vec<String>,
}

/// Evaluate one line with `sphere` carrying positioning and straightness:
/// the commanded coordinate of each target, the captures per sphere, the axis
/// frame through the sphere's per-target means, then positioning (ISO 230-2,
/// the 3σ band, VDI/DGQ 3441), straightness and angular errors; the
/// positioning deviations corrected for the machine's expansion
/// (`options.machine`).
pub(crate) fn evaluate_line(
    line: &Line<'_>,
    index: usize,
    sphere: &str,
    all_spheres: &[String],
    options: &crate::Options,
    source: &str,
) -> Result<LineResult> {
    let axis = line.axis;
    let first_line = line.rows.first().map_or(2, |r| r.line);
    let what = line.name();
    let nominal = commanded_targets(line, what, source)?;
    let data = captures(line);
    let Some(main) = data.get(sphere) else {
        return Err(row_error(
            source,
            first_line,
            "sphere",
            RowProblem::NoMainSphere {
                line: what,
                sphere: sphere.to_string(),
            },
        ));
    };
    if main.len() < 2 {
        return Err(row_error(
            source,
            first_line,
            "target",
            RowProblem::SingleTarget(what),
        ));
    }

    let targets: Vec<u32> = main.keys().copied().collect();
    let means: Vec<Point3<f64>> = main.values().map(target_mean).collect();
    let commanded: Vec<f64> = targets
        .iter()
        .map(|t| nominal.get(t).map_or(0.0, |n| n.0))
        .collect();
    let frame = AxisFrame::fit(axis, &means, &commanded).map_err(|e| EvaluateError::Geom {
        what: Fitted::AxisDirection(what),
        source: e,
    })?;
    let sweep = Sweep {
        main,
        targets: &targets,
        commanded: &commanded,
        frame: &frame,
        what,
        strains: strains(line, options.machine.as_ref()),
    };
    let positioning = sweep.positioning(options.vdi3441)?;
    // A reference line through two points is zero by construction: left
    // out, said why (ISO 230-1 §3.4.8; straightness::MIN_TARGETS).
    let straightness_left_out = straightness::left_out(means.len());
    let straightness = match straightness_left_out {
        Some(_) => BTreeMap::new(),
        None => sweep.straightness(&means)?,
    };
    let mut warnings = Vec::new();
    if let Some(reason) = &straightness_left_out {
        warnings.push(format!("{what}: {reason}"));
    }
    let angular = angular_errors(line, &data, all_spheres, &sweep, &mut warnings);

    let off_axis = line
        .off_axis
        .iter()
        .map(|(a, v)| (measured_column(*a).to_string(), *v))
        .collect();
    Ok(LineResult {
        runs: positioning.runs_up + positioning.runs_down,
        report: LineReport {
            line: index,
            off_axis,
            targets: targets.len(),
            direction: [frame.direction.x, frame.direction.y, frame.direction.z],
            positioning,
            straightness,
            straightness_left_out,
            angular,
        },
        means: targets.iter().copied().zip(means).collect(),
        warnings,
    })
}

/// Commanded axis coordinate per target, consistent over every row of the
/// line: target → (coordinate mm, line of its first row).
fn commanded_targets(
    line: &Line<'_>,
    what: LineName,
    source: &str,
) -> Result<BTreeMap<u32, (f64, u64)>> {
    let axis = line.axis;
    let mut nominal: BTreeMap<u32, (f64, u64)> = BTreeMap::new();
    for r in &line.rows {
        let n = r.row.nominal()[axis.index()];
        match nominal.get(&r.row.target) {
            Some(&(n0, l0)) if (n - n0).abs() > TARGET_TOLERANCE_MM => {
                return Err(row_error(
                    source,
                    r.line,
                    nominal_column(axis),
                    RowProblem::TargetMoved {
                        target: r.row.target,
                        line: what,
                        here: n,
                        first: n0,
                        first_line: l0,
                    },
                ));
            }
            Some(_) => {}
            None => {
                nominal.insert(r.row.target, (n, r.line));
            }
        }
    }
    Ok(nominal)
}

/// Captures per sphere, target and approach.
fn captures<'a>(line: &Line<'a>) -> BTreeMap<&'a str, SphereData> {
    let mut data: BTreeMap<&str, SphereData> = BTreeMap::new();
    for r in &line.rows {
        data.entry(r.row.sphere.as_str())
            .or_default()
            .entry(r.row.target)
            .or_default()
            .entry((r.row.direction, r.row.run))
            .or_default()
            .push((r.line, Point3::from(r.row.position())));
    }
    data
}

/// The seed's mean and sample deviation of every capture at a target (µm).
type SeedStats = (f64, f64);

/// The sphere carrying positioning and straightness on one line, in its axis frame.
struct Sweep<'a> {
    /// Its captures.
    main: &'a SphereData,
    /// Targets, ascending.
    targets: &'a [u32],
    /// Commanded axis coordinate per target (mm).
    commanded: &'a [f64],
    /// The axis frame through its per-target means.
    frame: &'a AxisFrame,
    /// The line, for messages.
    what: LineName,
    /// The machine scale's nominal differential expansion α·(T − 20 °C) of
    /// each capture, by its line in the points (none: no correction).
    strains: BTreeMap<u64, f64>,
}

/// The strain α·(T − 20 °C) of each row of `line` at its instant's
/// temperature, by the row's line; empty without an expansion.
fn strains(
    line: &Line<'_>,
    machine: Option<&formats::conditions::MachineExpansion>,
) -> BTreeMap<u64, f64> {
    let Some(m) = machine else {
        return BTreeMap::new();
    };
    line.rows
        .iter()
        .filter_map(|r| m.strain_at(&r.row.instant()).map(|e| (r.line, e)))
        .collect()
}

impl Sweep<'_> {
    /// Positional deviation of the mean of `captures` at target index k
    /// (µm), corrected to 20 °C for the machine scale's nominal
    /// differential expansion ε = α·(T − 20 °C) (ISO 230-2:2014 §3.3, 5.3):
    /// the deviation less ε·(P − P₀), P₀ the line's first target, ε the
    /// captures' mean (the correction is linear in it).
    fn deviation(&self, k: usize, captures: &[(u64, Point3<f64>)]) -> f64 {
        let travel = self.commanded[k] - self.commanded[0];
        let p = mean_point(captures.iter().map(|(_, p)| p));
        let strain = captures
            .iter()
            .map(|(line, _)| self.strains.get(line).copied().unwrap_or(0.0))
            .sum::<f64>()
            / captures.len().max(1) as f64;
        um(self.frame.along(&p) - travel - strain * travel)
    }

    /// Per target: the deviation of each approach (its captures averaged) by
    /// direction (µm).
    fn deviations(&self) -> Vec<TargetDeviations> {
        self.main
            .values()
            .enumerate()
            .map(|(k, runs)| {
                let mut dev = TargetDeviations::default();
                for ((direction, _), captures) in runs {
                    let value = self.deviation(k, captures);
                    match direction {
                        Direction::Up => dev.up.push(value),
                        Direction::Down => dev.down.push(value),
                    }
                }
                dev
            })
            .collect()
    }

    /// Per target: the seed's mean and sample deviation over every capture
    /// of every run and direction (µm).
    fn seed(&self) -> Result<Vec<SeedStats>> {
        self.main
            .values()
            .enumerate()
            .map(|(k, runs)| {
                let all: Vec<f64> = runs
                    .values()
                    .flatten()
                    .map(|c| self.deviation(k, std::slice::from_ref(c)))
                    .collect();
                let m = geom::stats::mean(&all).map_err(|e| positioning_error(self.what, e))?;
                let s =
                    geom::stats::sample_std(&all).map_err(|e| positioning_error(self.what, e))?;
                Ok((m, s))
            })
            .collect()
    }

    /// Distinct runs in direction `d`.
    fn runs_in(&self, d: Direction) -> usize {
        self.main
            .values()
            .flat_map(|runs| runs.keys())
            .filter(|(dir, _)| *dir == d)
            .map(|(_, run)| *run)
            .collect::<std::collections::BTreeSet<u32>>()
            .len()
    }

    /// Whether direction `d` has the [`iso230_2::MIN_RUNS`] runs ISO 230-2
    /// needs at every target; else the first target short of them.
    fn coverage(&self, d: Direction) -> Coverage {
        if self.runs_in(d) == 0 {
            return Coverage::Absent;
        }
        for (&target, runs) in self.main {
            let here: Vec<u32> = runs
                .keys()
                .filter(|(dir, _)| *dir == d)
                .map(|(_, run)| *run)
                .collect();
            if here.len() < iso230_2::MIN_RUNS {
                return Coverage::Short(Shortfall {
                    target,
                    direction: d,
                    runs: here,
                });
            }
        }
        Coverage::Enough
    }

    /// ISO 230-2 from the directions with enough runs, the 3σ band and
    /// (when `vdi`) VDI/DGQ 3441; what is left out, and why, in `left_out`.
    fn positioning(&self, vdi: bool) -> Result<PositioningReport> {
        let deviations = self.deviations();
        let [up, down] = [Direction::Up, Direction::Down].map(|d| self.coverage(d));
        let usable: Vec<TargetDeviations> = deviations
            .iter()
            .map(|t| TargetDeviations {
                up: if up.enough() {
                    t.up.clone()
                } else {
                    Vec::new()
                },
                down: if down.enough() {
                    t.down.clone()
                } else {
                    Vec::new()
                },
            })
            .collect();
        let iso = if up.enough() || down.enough() {
            Some(iso230_2::iso230_2(&usable)?)
        } else {
            None
        };
        let seed = iso.as_ref().map(|_| self.seed()).transpose()?;
        let seed_3sigma = seed.as_ref().map(|seed| {
            seed.iter()
                .map(|(m, s)| m + 3.0 * s)
                .fold(f64::NEG_INFINITY, f64::max)
                - seed
                    .iter()
                    .map(|(m, s)| m - 3.0 * s)
                    .fold(f64::INFINITY, f64::min)
        });
        let figures: Vec<TargetFigures> = match &iso {
            Some(i) => i.targets.clone(),
            None => vec![TargetFigures::default(); self.targets.len()],
        };
        let bi = iso.as_ref().and_then(|i| i.bidirectional);
        let (iso_up, iso_down) = (
            iso.as_ref().and_then(|i| i.up),
            iso.as_ref().and_then(|i| i.down),
        );
        Ok(PositioningReport {
            left_out: left_out(&up, &down, vdi),
            a_um: bi.map(|b| b.a),
            a_up_um: iso_up.map(|u| u.a),
            a_down_um: iso_down.map(|u| u.a),
            e_um: bi.map(|b| b.e),
            e_up_um: iso_up.map(|u| u.e),
            e_down_um: iso_down.map(|u| u.e),
            m_um: bi.map(|b| b.m),
            r_um: bi.map(|b| b.r),
            r_up_um: iso_up.map(|u| u.r),
            r_down_um: iso_down.map(|u| u.r),
            b_um: bi.map(|b| b.b),
            b_mean_um: bi.map(|b| b.b_mean),
            seed_3sigma_um: seed_3sigma,
            runs_up: self.runs_in(Direction::Up),
            runs_down: self.runs_in(Direction::Down),
            targets: self
                .targets
                .iter()
                .zip(self.commanded)
                .zip(&figures)
                .zip(&deviations)
                .enumerate()
                .map(|(k, (((&t, &nominal), f), dev))| {
                    let seed_at = seed.as_ref().map(|s| s[k]);
                    PositioningTarget {
                        target: t,
                        nominal,
                        mean_up_um: f.up.map(|u| u.mean),
                        mean_down_um: f.down.map(|d| d.mean),
                        s_up_um: f.up.map(|u| u.s),
                        s_down_um: f.down.map(|d| d.s),
                        b_um: f.bidirectional.map(|b| b.reversal),
                        mean_um: f.bidirectional.map(|b| b.mean),
                        r_up_um: f.up.map(|u| u.repeatability()),
                        r_down_um: f.down.map(|d| d.repeatability()),
                        r_um: f.bidirectional.map(|b| b.repeatability),
                        runs_up_um: dev.up.clone(),
                        runs_down_um: dev.down.clone(),
                        seed_mean_um: seed_at.map(|s| s.0),
                        seed_s_um: seed_at.map(|s| s.1),
                    }
                })
                .collect(),
            vdi3441: if vdi {
                iso.as_ref()
                    .and_then(vdi3441::vdi3441)
                    .map(|v| Vdi3441Report {
                        p_um: v.p,
                        ps_um: v.ps,
                        u_um: v.u,
                        u_mean_um: v.u_mean,
                        pa_um: v.pa,
                    })
            } else {
                None
            },
        })
    }

    /// Straightness of the per-target `means` in the two perpendicular directions.
    fn straightness(&self, means: &[Point3<f64>]) -> Result<BTreeMap<String, StraightnessReport>> {
        let mut straight = BTreeMap::new();
        for (k, (world, _)) in self.frame.perpendicular.iter().enumerate() {
            let profile: Vec<Point2<f64>> = means
                .iter()
                .map(|p| Point2::new(self.frame.along(p), self.frame.across(p, k)))
                .collect();
            let what = self.what;
            let s = straightness::straightness(&profile).map_err(|e| EvaluateError::Geom {
                what: Fitted::Straightness {
                    world: *world,
                    line: what,
                },
                source: e,
            })?;
            straight.insert(
                world.name().to_string(),
                StraightnessReport {
                    lsq_um: um(s.lsq),
                    min_zone_um: um(s.min_zone),
                    targets: (0..self.targets.len())
                        .map(|i| StraightnessTarget {
                            target: self.targets[i],
                            nominal: self.commanded[i],
                            deviation_um: um(s.deviations[i]),
                            zone_low_um: um(s.zone_low[i]),
                            zone_high_um: um(s.zone_high[i]),
                        })
                        .collect(),
                },
            );
        }
        Ok(straight)
    }
}

/// Angular errors from every sphere present at every target, over the
/// instants at which all of them were measured (an instant lacking a sphere
/// would otherwise shift that sphere's mean against the others'); `None`
/// with a warning when they cannot be had.
fn angular_errors(
    line: &Line<'_>,
    data: &BTreeMap<&str, SphereData>,
    all_spheres: &[String],
    sweep: &Sweep<'_>,
    warnings: &mut Vec<String>,
) -> Option<AngularReport> {
    let (targets, what) = (sweep.targets, sweep.what);
    let complete: Vec<&String> = all_spheres
        .iter()
        .filter(|name| {
            data.get(name.as_str())
                .is_some_and(|d| targets.iter().all(|t| d.contains_key(t)))
        })
        .collect();
    if complete.len() < 3 {
        if all_spheres.len() >= 3 {
            let missing: Vec<&str> = all_spheres
                .iter()
                .filter(|n| !complete.contains(n))
                .map(String::as_str)
                .collect();
            warnings.push(format!(
                "{what}: angular errors left out: sphere(s) {} missing at some targets",
                missing.join(", ")
            ));
        }
        return None;
    }
    let means_at = match common_means(line, &complete, targets) {
        Ok(m) => m,
        Err(target) => {
            warnings.push(format!(
                "{what}: angular errors left out: no instant of target {target} has all of spheres {}",
                complete.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
            ));
            return None;
        }
    };
    match angular_report(line.axis, &complete, &means_at, targets, sweep.commanded) {
        Ok(a) => {
            if a.lever_mm < angular::MIN_LEVER_MM {
                warnings.push(format!(
                    "{what}: spheres {} are nearly in a line (smallest lever {:.2} mm): the rotation about it is \
                     poorly determined, ≈ {:.0} µrad per µm of position error",
                    a.spheres.join(", "),
                    a.lever_mm,
                    1e3 / a.lever_mm.max(1e-6)
                ));
            }
            Some(a)
        }
        Err(e) => {
            warnings.push(format!("{what}: angular errors left out: {e}"));
            None
        }
    }
}

/// How far one direction of a line goes for ISO 230-2 (at least
/// [`iso230_2::MIN_RUNS`] runs at every target).
#[derive(Debug, Clone, PartialEq)]
enum Coverage {
    /// No approach in the direction.
    Absent,
    /// Enough runs at every target.
    Enough,
    /// A target short of runs.
    Short(Shortfall),
}

impl Coverage {
    /// ISO 230-2 can use the direction.
    fn enough(&self) -> bool {
        *self == Coverage::Enough
    }
}

/// The first target of a line short of runs in a direction.
#[derive(Debug, Clone, PartialEq)]
struct Shortfall {
    /// The target.
    target: u32,
    /// The direction.
    direction: Direction,
    /// Its runs in the direction (fewer than [`iso230_2::MIN_RUNS`]).
    runs: Vec<u32>,
}

impl std::fmt::Display for Shortfall {
    /// `target 0 has 1 ↑ run (run 51)`, `target 2 has no ↓ run`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (target, arrow) = (self.target, arrow(self.direction));
        let plural = if self.runs.len() == 1 { "" } else { "s" };
        let list: Vec<String> = self.runs.iter().map(u32::to_string).collect();
        match self.runs.len() {
            0 => write!(f, "target {target} has no {arrow} run"),
            n => write!(
                f,
                "target {target} has {n} {arrow} run{plural} (run{plural} {})",
                list.join(", ")
            ),
        }
    }
}

/// `↑` or `↓`, as ISO 230-2 writes the directions.
fn arrow(d: Direction) -> &'static str {
    match d {
        Direction::Up => "↑",
        Direction::Down => "↓",
    }
}

/// What of ISO 230-2 a line's coverage leaves out and why; `None` when both
/// directions have the runs. The bidirectional figures (A, E, M, R, B, B̄ and
/// VDI/DGQ 3441 when `vdi`) need both directions; a direction's own figures
/// (A↑, E↑, R↑) only its runs.
fn left_out(up: &Coverage, down: &Coverage, vdi: bool) -> Option<String> {
    let both = if vdi {
        "A, E, M, R, B, B̄ and VDI/DGQ 3441"
    } else {
        "A, E, M, R, B and B̄"
    };
    let needs = format!(
        "ISO 230-2 needs at least {} runs per direction at every target",
        iso230_2::MIN_RUNS
    );
    let one_way = |d: &str| {
        format!(
            "{both} left out: measured in {d} only, and they need both directions (ISO 230-2); the {d} figures are given"
        )
    };
    match (up, down) {
        (Coverage::Enough, Coverage::Enough) => None,
        (Coverage::Enough, Coverage::Absent) => Some(one_way("↑")),
        (Coverage::Absent, Coverage::Enough) => Some(one_way("↓")),
        (Coverage::Enough, Coverage::Short(short)) => {
            Some(format!("↓ figures and {both} left out: {needs}; {short}"))
        }
        (Coverage::Short(short), Coverage::Enough) => {
            Some(format!("↑ figures and {both} left out: {needs}; {short}"))
        }
        (up, down) => {
            let why = |c: &Coverage, d: &str| match c {
                Coverage::Short(short) => short.to_string(),
                _ => format!("no {d} run"),
            };
            Some(format!(
                "positioning left out: {needs}; {} and {}",
                why(up, "↑"),
                why(down, "↓")
            ))
        }
    }
}

/// A failed statistic of a line's positioning.
fn positioning_error(line: LineName, e: geom::GeomError) -> EvaluateError {
    EvaluateError::Geom {
        what: Fitted::Positioning(line),
        source: e,
    }
}

/// Per target, the mean position of each of `spheres` (in that order) over
/// the instants of the line at which every one of them was measured — the
/// captures of an approach averaged first, as for positioning. `Err(target)`
/// names a target without such an instant.
fn common_means(
    line: &Line<'_>,
    spheres: &[&String],
    targets: &[u32],
) -> std::result::Result<BTreeMap<u32, Vec<Point3<f64>>>, u32> {
    type Instant = (u32, Direction, u32, u32);
    let instant =
        |r: &Located<'_>| -> Instant { (r.row.target, r.row.direction, r.row.run, r.row.capture) };
    let mut present: BTreeMap<Instant, Vec<&str>> = BTreeMap::new();
    for r in &line.rows {
        present
            .entry(instant(r))
            .or_default()
            .push(r.row.sphere.as_str());
    }
    let complete = |i: &Instant| {
        present
            .get(i)
            .is_some_and(|have| spheres.iter().all(|s| have.contains(&s.as_str())))
    };
    let mut out = BTreeMap::new();
    for &t in targets {
        let mut at = Vec::with_capacity(spheres.len());
        for s in spheres {
            let mut runs: BTreeMap<(Direction, u32), Approach> = BTreeMap::new();
            for r in line
                .rows
                .iter()
                .filter(|r| r.row.target == t && r.row.sphere == **s && complete(&instant(r)))
            {
                runs.entry((r.row.direction, r.row.run))
                    .or_default()
                    .push((r.line, Point3::from(r.row.position())));
            }
            if runs.is_empty() {
                return Err(t);
            }
            at.push(target_mean(&runs));
        }
        out.insert(t, at);
    }
    Ok(out)
}

/// Roll, pitch and yaw per target from the rigid motion of `spheres`, whose
/// mean positions per target `means_at` holds (in the order of `spheres`).
fn angular_report(
    axis: Axis,
    spheres: &[&String],
    means_at: &BTreeMap<u32, Vec<Point3<f64>>>,
    targets: &[u32],
    commanded: &[f64],
) -> geom::Result<AngularReport> {
    let at = |t: u32| -> Vec<Point3<f64>> { means_at.get(&t).cloned().unwrap_or_default() };
    let first = at(targets[0]);
    let (lever_mm, _) = angular::lever(&first);
    let mut rows = Vec::with_capacity(targets.len());
    let mut ss = 0.0;
    for (i, &t) in targets.iter().enumerate() {
        let pose = geom::transform::rigid_fit_rms(&first, &at(t))?;
        ss += pose.rms * pose.rms;
        let [roll, pitch, yaw] = axis.roll_pitch_yaw(&pose.rotation);
        rows.push(AngularTarget {
            target: t,
            nominal: commanded[i],
            roll_urad: urad(roll),
            pitch_urad: urad(pitch),
            yaw_urad: urad(yaw),
        });
    }
    let range = |f: fn(&AngularTarget) -> f64| {
        let v: Vec<f64> = rows.iter().map(f).collect();
        geom::stats::range(&v)
    };
    Ok(AngularReport {
        roll_urad: range(|r| r.roll_urad)?,
        pitch_urad: range(|r| r.pitch_urad)?,
        yaw_urad: range(|r| r.yaw_urad)?,
        spheres: spheres.iter().map(|s| s.to_string()).collect(),
        fit_rms_um: um((ss / rows.len() as f64).sqrt()),
        lever_mm,
        convention: ANGULAR_CONVENTION.to_string(),
        targets: rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn short(target: u32, direction: Direction, runs: &[u32]) -> Coverage {
        Coverage::Short(Shortfall {
            target,
            direction,
            runs: runs.to_vec(),
        })
    }

    #[test]
    fn left_out_names_the_figures_and_the_shortfall() {
        assert_eq!(left_out(&Coverage::Enough, &Coverage::Enough, true), None);
        assert_eq!(
            left_out(&short(0, Direction::Up, &[7]), &Coverage::Absent, false).unwrap(),
            "positioning left out: ISO 230-2 needs at least 2 runs per direction at every \
             target; target 0 has 1 ↑ run (run 7) and no ↓ run"
        );
        assert_eq!(
            left_out(&Coverage::Enough, &short(3, Direction::Down, &[]), true).unwrap(),
            "↓ figures and A, E, M, R, B, B̄ and VDI/DGQ 3441 left out: ISO 230-2 needs at \
             least 2 runs per direction at every target; target 3 has no ↓ run"
        );
        assert_eq!(
            left_out(&Coverage::Enough, &Coverage::Absent, false).unwrap(),
            "A, E, M, R, B and B̄ left out: measured in ↑ only, and they need both directions \
             (ISO 230-2); the ↑ figures are given"
        );
    }
}
