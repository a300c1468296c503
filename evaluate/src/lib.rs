//! Evaluation of linear-axis measurements (docs/methods.md): ISO 230-2
//! positioning, VDI/DGQ 3441, straightness, flatness and angular errors, and
//! the report people read (`report.json`, CSV tables, `report.html`).
//!
//! The input is `points.csv` (docs/formats.md): one row per sphere per instant.
//! [`evaluate`] takes the rows in memory; [`evaluate_file`] reads the file
//! first, so that every error names its line and column; [`write_outputs`]
//! writes the report files, each atomically.
//!
//! # Conventions
//! - Input in millimetres; figures in micrometres (`_um`), angles in
//!   microradians (`_urad`); commanded (`nominal`) positions in millimetres.
//! - Lines: the runs of an axis with the same off-axis commanded coordinates
//!   (within [`LINE_TOLERANCE_MM`]). Each line is evaluated on its
//!   own; `axes.X` is the line with the most runs (tie: nearest the origin).
//! - Axis frame: the direction of the orthogonal least-squares line through
//!   the sphere's per-target mean positions (free of cosine error); datum the
//!   mean position at the first target (lowest target index).
//! - Positioning (ISO 230-2): the captures of one approach are averaged into
//!   that run's value; `xᵢⱼ` = measured displacement along the axis −
//!   commanded displacement, both from the first target.
//! - Straightness: the per-target mean points in the plane of the axis and
//!   each perpendicular world direction (X → Y, Z; Y → X, Z; Z → X, Y);
//!   orthogonal least squares and minimum zone.
//! - Flatness: the per-target mean points of every X and Y line together;
//!   vertical deviations from `z = aX + bY + c`, and the minimum zone.
//! - Angular: see [`ANGULAR_CONVENTION`].
//! - A figure whose axis or direction is absent is `None` and left out of the
//!   JSON, never zero. A line short of ISO 230-2's runs ([`MIN_RUNS`] per
//!   direction at every target) keeps its straightness, angular errors and
//!   flatness points; its `positioning.left_out` and a warning say which
//!   figures are left out and why.
//!
//! # Example
//! An X axis measured at three targets, two runs each way, with a reversal
//! error of 2 µm (each approach lands 1 µm short): ISO 230-2's B is 2 µm.
//! ```
//! use evaluate::{Options, evaluate};
//! use formats::{Axis, Direction, PointRow};
//!
//! let mut rows = Vec::new();
//! for target in 0..3u32 {
//!     let nominal = 50.0 * f64::from(target);
//!     for (direction, shortfall) in [(Direction::Up, -0.001), (Direction::Down, 0.001)] {
//!         for run in 1..=2 {
//!             rows.push(PointRow {
//!                 axis: Axis::X,
//!                 direction,
//!                 run,
//!                 target,
//!                 capture: 1,
//!                 nominal_x: nominal,
//!                 nominal_y: 0.0,
//!                 nominal_z: 0.0,
//!                 sphere: "A".into(),
//!                 x: nominal + shortfall,
//!                 y: 0.0,
//!                 z: 0.0,
//!                 cameras: "2+3".into(),
//!                 residual_px: 0.0,
//!                 u_x: None,
//!                 u_y: None,
//!                 u_z: None,
//!                 u_cal_x: None,
//!                 u_cal_y: None,
//!                 u_cal_z: None,
//!             });
//!         }
//!     }
//! }
//! let report = evaluate(&rows, &Options::default()).unwrap();
//! let positioning = &report.axes.x.as_ref().unwrap().main.positioning;
//! assert!((positioning.b_um.unwrap() - 2.0).abs() < 1e-9);
//! ```

mod angular;
mod axis_frame;
mod error;
mod flatness;
mod html;
mod iso230_2;
mod lines;
mod output;
mod plot;
mod points;
mod straightness;
pub mod tolerances;
pub mod uncertainty;
mod vdi3441;

use std::path::Path;

use formats::{Axis, PointRow, Row};
use geom::Point3;

pub use angular::MIN_LEVER_MM;
pub use error::{EvaluateError, Fitted, Iso230_2Problem, LineName, Result, RowProblem};
pub use formats::evaluation::{
    ANGULAR_CONVENTION, AngularReport, AngularTarget, Axes, AxisReport, FlatnessPoint,
    FlatnessReport, LineReport, PositioningReport, PositioningTarget, Report, StraightnessReport,
    StraightnessTarget, Vdi3441Report,
};
pub use iso230_2::{
    Bidirectional, DirectionStats, Iso230_2, MIN_RUNS, TargetBidirectional, TargetDeviations,
    TargetFigures, Unidirectional, iso230_2,
};
pub use lines::{LINE_TOLERANCE_MM, TARGET_TOLERANCE_MM};
pub use output::{Printer, REPORT_FILES, write_outputs};
pub use points::{MAX_COORDINATE_MM, UNITS_TOLERANCE_MM, UNITS_TOLERANCE_OF_TRAVEL, read_points};

use crate::points::Located;

/// What to evaluate and how.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Options {
    /// Sphere that carries positioning, straightness and flatness; `None`:
    /// `A`, or the first sphere name in the points when there is no `A`.
    pub sphere: Option<String>,
    /// Also compute the VDI/DGQ 3441 figures (P, Ps, U, Pa).
    pub vdi3441: bool,
    /// The machine scale's expansion coefficient and temperature (the
    /// test's or per instant; `None`: no correction): each positioning
    /// deviation is corrected by −ε·(P − P₀), ε = α·(T − 20 °C) at its
    /// instant (`formats::conditions`).
    pub machine: Option<formats::conditions::MachineExpansion>,
    /// The calibration target's expansion α_t·(T_t − 20 °C) during the
    /// calibration (0: none): the rig's lengths are scaled by (1 + ε_t), a
    /// scaling of every centre about the rig's origin.
    pub target_strain: f64,
}

/// Evaluate every axis, line and the flatness from `points.csv` rows given in
/// memory; errors name row `i` (0-based) as line `i + 2` of `points`, its
/// line in a points.csv written in this order.
pub fn evaluate(points: &[PointRow], options: &Options) -> Result<Report> {
    let located: Vec<Located<'_>> = points
        .iter()
        .enumerate()
        .map(|(i, row)| Located {
            line: i as u64 + 2,
            row,
        })
        .collect();
    evaluate_located(&located, "points", options)
}

/// As [`evaluate`], for rows read from `source` with their line numbers.
pub fn evaluate_rows(rows: &[Row<PointRow>], source: &Path, options: &Options) -> Result<Report> {
    let located: Vec<Located<'_>> = rows
        .iter()
        .map(|r| Located {
            line: r.line,
            row: &r.record,
        })
        .collect();
    evaluate_located(&located, &source.display().to_string(), options)
}

/// Read `points.csv` and evaluate it; errors name the file, line and column.
pub fn evaluate_file(path: &Path, options: &Options) -> Result<Report> {
    let rows = read_points(path)?;
    evaluate_rows(&rows, path, options)
}

/// The sphere that carries positioning: the option, else `A`, else the first name.
fn choose_sphere(spheres: &[String], options: &Options) -> Result<String> {
    match &options.sphere {
        Some(name) if spheres.contains(name) => Ok(name.clone()),
        Some(name) => Err(EvaluateError::UnknownSphere {
            name: name.clone(),
            spheres: spheres.to_vec(),
        }),
        None if spheres.iter().any(|s| s == "A") => Ok("A".into()),
        None => spheres.first().cloned().ok_or(EvaluateError::NoSpheres),
    }
}

fn evaluate_located(rows: &[Located<'_>], source: &str, options: &Options) -> Result<Report> {
    points::check(rows, source)?;
    if options.target_strain != 0.0 {
        // A target warmer than 20 °C was larger than its file says: every
        // length the rig measured is short by 1/(1 + ε_t).
        let scale = 1.0 + options.target_strain;
        let scaled: Vec<PointRow> = rows
            .iter()
            .map(|r| PointRow {
                x: r.row.x * scale,
                y: r.row.y * scale,
                z: r.row.z * scale,
                ..r.row.clone()
            })
            .collect();
        let located: Vec<Located<'_>> = rows
            .iter()
            .zip(&scaled)
            .map(|(r, row)| Located { line: r.line, row })
            .collect();
        let unscaled = Options {
            target_strain: 0.0,
            ..options.clone()
        };
        return evaluate_located(&located, source, &unscaled);
    }
    let mut spheres: Vec<String> = Vec::new();
    for r in rows {
        if !spheres.contains(&r.row.sphere) {
            spheres.push(r.row.sphere.clone());
        }
    }
    let sphere = choose_sphere(&spheres, options)?;

    let mut report = Report {
        axes: Axes::default(),
        flatness: None,
        sphere: sphere.clone(),
        spheres: spheres.clone(),
        source: source.to_string(),
        rows: rows.len(),
        conventions: conventions(&sphere),
        warnings: Vec::new(),
        uncertainty: None,
        uncorrected: None,
        correction: None,
        signoff: Default::default(),
    };
    let lines = lines::group(rows);
    let mut flat_points: Vec<(Axis, usize, u32, Point3<f64>)> = Vec::new();
    for axis in [Axis::X, Axis::Y, Axis::Z] {
        let of_axis: Vec<&lines::Line<'_>> = lines.iter().filter(|l| l.axis == axis).collect();
        if of_axis.is_empty() {
            continue;
        }
        let mut results = Vec::with_capacity(of_axis.len());
        for (index, line) in of_axis.iter().enumerate() {
            let result = lines::evaluate_line(line, index, &sphere, &spheres, options, source)?;
            if axis != Axis::Z {
                flat_points.extend(result.means.iter().map(|(t, p)| (axis, index, *t, *p)));
            }
            results.push((line.offset(), result));
        }
        // The main line: most runs, then nearest the origin, then first.
        let main = (0..results.len())
            .min_by(|&i, &j| {
                results[j]
                    .1
                    .runs
                    .cmp(&results[i].1.runs)
                    .then(results[i].0.total_cmp(&results[j].0))
                    .then(i.cmp(&j))
            })
            .unwrap_or(0);
        let mut line_reports = Vec::with_capacity(results.len());
        for (index, (_, r)) in results.into_iter().enumerate() {
            report.warnings.extend(r.warnings);
            if let Some(reason) = &r.report.positioning.left_out {
                report.warnings.push(positioning_warning(
                    of_axis[index].name(),
                    index == main,
                    reason,
                ));
            }
            line_reports.push(r.report);
        }
        *report.axes.slot(axis) = Some(AxisReport {
            main: line_reports[main].clone(),
            lines: line_reports,
        });
    }
    report.flatness = flatness_report(&flat_points, &mut report.warnings)?;
    Ok(report)
}

/// The warning for a line whose positioning is (partly) left out; the main
/// line of the axis, whose figures `axes.X` shows, is named as such.
fn positioning_warning(line: LineName, main: bool, reason: &str) -> String {
    let role = if main {
        " (the main line of the axis: the most runs)"
    } else {
        ""
    };
    format!("{line}{role}: {reason}")
}

/// Flatness of the X and Y lines' per-target mean points; `None` (with a
/// warning) with fewer than two lines or when they do not span a plane.
fn flatness_report(
    points: &[(Axis, usize, u32, Point3<f64>)],
    warnings: &mut Vec<String>,
) -> Result<Option<FlatnessReport>> {
    let mut lines: Vec<(Axis, usize)> = points.iter().map(|p| (p.0, p.1)).collect();
    lines.dedup();
    if lines.len() < 2 {
        // One line is a curve, not a surface: its plane fit would be a guess.
        if !points.is_empty() {
            warnings.push("flatness left out: it needs at least two lines (an X and a Y line, or two X lines)".into());
        }
        return Ok(None);
    }
    let cloud: Vec<Point3<f64>> = points.iter().map(|p| p.3).collect();
    let f = match flatness::flatness(&cloud) {
        Ok(f) => f,
        Err(geom::GeomError::Degenerate(_) | geom::GeomError::TooFewPoints { .. }) => {
            warnings.push(
                "flatness left out: the X- and Y-run points do not span a plane (a single line?)"
                    .into(),
            );
            return Ok(None);
        }
        Err(e) => {
            return Err(EvaluateError::Geom {
                what: Fitted::Flatness,
                source: e,
            });
        }
    };
    Ok(Some(FlatnessReport {
        lsq_um: f.lsq * 1e3,
        min_zone_um: f.min_zone * 1e3,
        a: f.a,
        b: f.b,
        c: f.c,
        points: points
            .iter()
            .zip(f.lsq_deviations.iter().zip(&f.zone_deviations))
            .map(|(&(axis, line, target, p), (l, z))| FlatnessPoint {
                axis: axis.name().to_string(),
                line,
                target,
                x: p.x,
                y: p.y,
                z: p.z,
                lsq_um: l * 1e3,
                min_zone_um: z * 1e3,
            })
            .collect(),
    }))
}

/// The conventions written into every report.
fn conventions(sphere: &str) -> Vec<String> {
    vec![
        "units: figures in µm, angles in µrad, commanded (nominal) positions in mm".into(),
        format!("sphere {sphere} carries positioning, straightness and flatness"),
        "axis direction: orthogonal least-squares line through the per-target mean positions; \
         datum: the mean position at the first target"
            .into(),
        "positioning (ISO 230-2): captures of one approach averaged into the run's value; \
         x_ij = measured displacement along the axis − commanded displacement"
            .into(),
        "seed_3sigma_um: per target, mean and sample standard deviation of every capture of every run \
         and direction; max(x̄ + 3s) − min(x̄ − 3s)"
            .into(),
        "straightness: orthogonal residuals of the per-target mean points in the plane of the axis and \
         the named world direction; least squares (range) and minimum zone (ISO 12780)"
            .into(),
        "flatness: vertical deviations of the per-target mean points of all X and Y lines from the \
         least-squares plane z = aX + bY + c (range), and the minimum zone"
            .into(),
        ANGULAR_CONVENTION.into(),
    ]
}
