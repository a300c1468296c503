//! Writing the report: `report.json` (docs/formats.md), CSV tables per axis
//! (`positioning_X.csv`, `straightness_X.csv`, `angular_X.csv`,
//! `flatness.csv`) and `report.html`, written as one set: into a fresh
//! staging folder that then takes the place of the old report in one
//! exchange (`formats::OutputPlan::set`), so no table of an earlier report
//! stands beside a new one and a failure leaves the old report whole.

use std::path::{Path, PathBuf};

use formats::OutputPlan;
use serde::Serialize;

use crate::{Result, html};
use formats::evaluation::{AxisReport, Report};

/// The files a report folder may hold (`*`: an axis name); a folder holding
/// anything else is never replaced.
pub const REPORT_FILES: &[&str] = &[
    "report.json",
    "report.html",
    "positioning_*.csv",
    "straightness_*.csv",
    "angular_*.csv",
    "flatness.csv",
];

/// One row of `positioning_<axis>.csv` (µm; nominal in mm).
#[derive(Debug, Serialize)]
struct PositioningRow {
    line: usize,
    target: u32,
    nominal_mm: f64,
    mean_up_um: Option<f64>,
    s_up_um: Option<f64>,
    mean_down_um: Option<f64>,
    s_down_um: Option<f64>,
    #[serde(rename = "B_um")]
    b_um: Option<f64>,
    mean_um: Option<f64>,
    #[serde(rename = "R_up_um")]
    r_up_um: Option<f64>,
    #[serde(rename = "R_down_um")]
    r_down_um: Option<f64>,
    #[serde(rename = "R_um")]
    r_um: Option<f64>,
    runs_up: usize,
    runs_down: usize,
    seed_mean_um: f64,
    seed_s_um: f64,
}

/// One row of `straightness_<axis>.csv`: one target of one direction's profile.
#[derive(Debug, Serialize)]
struct StraightnessRow<'a> {
    line: usize,
    direction: &'a str,
    target: u32,
    nominal_mm: f64,
    deviation_um: f64,
    zone_low_um: f64,
    zone_high_um: f64,
}

/// One row of `angular_<axis>.csv`.
#[derive(Debug, Serialize)]
struct AngularRow {
    line: usize,
    target: u32,
    nominal_mm: f64,
    roll_urad: f64,
    pitch_urad: f64,
    yaw_urad: f64,
}

/// One row of `flatness.csv`.
#[derive(Debug, Serialize)]
struct FlatnessRow<'a> {
    axis: &'a str,
    line: usize,
    target: u32,
    x: f64,
    y: f64,
    z: f64,
    lsq_um: f64,
    min_zone_um: f64,
}

/// Write `report.json`, the CSV tables and `report.html` as the set `dir`
/// through `output` (where the caller declared its inputs and `--force`):
/// an existing report is replaced only with `--force`, a folder that holds
/// an input or files other than a report's never. Returns the paths written.
pub fn write_outputs(report: &Report, dir: &Path, output: &mut OutputPlan) -> Result<Vec<PathBuf>> {
    output.set(dir, REPORT_FILES);
    output.check()?;
    // Render first, so that a plot failure leaves nothing written.
    let page = html::render(report)?;
    let stage = output.stage(dir)?;
    let written = write_set(report, &page, stage.path())?;
    stage.commit()?;
    Ok(written
        .iter()
        .filter_map(|p| p.file_name())
        .map(|name| dir.join(name))
        .collect())
}

/// Every file of the report into the folder `dir`; the paths written.
fn write_set(report: &Report, page: &str, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let json = dir.join("report.json");
    formats::write_json(&json, report)?;
    written.push(json);
    for (axis, a) in report.axes.iter() {
        written.extend(axis_tables(axis.name(), a, dir)?);
    }
    if let Some(f) = &report.flatness {
        let path = dir.join("flatness.csv");
        let rows: Vec<FlatnessRow<'_>> = f
            .points
            .iter()
            .map(|p| FlatnessRow {
                axis: &p.axis,
                line: p.line,
                target: p.target,
                x: p.x,
                y: p.y,
                z: p.z,
                lsq_um: p.lsq_um,
                min_zone_um: p.min_zone_um,
            })
            .collect();
        formats::write_csv(&path, &rows)?;
        written.push(path);
    }
    let path = dir.join("report.html");
    formats::write_atomic(&path, page.as_bytes())?;
    written.push(path);
    Ok(written)
}

/// The CSV tables of one axis, every line in them.
fn axis_tables(name: &str, a: &AxisReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let positioning: Vec<PositioningRow> = a
        .lines
        .iter()
        .flat_map(|l| {
            l.positioning.targets.iter().map(move |t| PositioningRow {
                line: l.line,
                target: t.target,
                nominal_mm: t.nominal,
                mean_up_um: t.mean_up_um,
                s_up_um: t.s_up_um,
                mean_down_um: t.mean_down_um,
                s_down_um: t.s_down_um,
                b_um: t.b_um,
                mean_um: t.mean_um,
                r_up_um: t.r_up_um,
                r_down_um: t.r_down_um,
                r_um: t.r_um,
                runs_up: t.runs_up_um.len(),
                runs_down: t.runs_down_um.len(),
                seed_mean_um: t.seed_mean_um,
                seed_s_um: t.seed_s_um,
            })
        })
        .collect();
    let path = dir.join(format!("positioning_{name}.csv"));
    formats::write_csv(&path, &positioning)?;
    written.push(path);

    let straightness: Vec<StraightnessRow<'_>> = a
        .lines
        .iter()
        .flat_map(|l| {
            l.straightness.iter().flat_map(move |(direction, s)| {
                s.targets.iter().map(move |t| StraightnessRow {
                    line: l.line,
                    direction,
                    target: t.target,
                    nominal_mm: t.nominal,
                    deviation_um: t.deviation_um,
                    zone_low_um: t.zone_low_um,
                    zone_high_um: t.zone_high_um,
                })
            })
        })
        .collect();
    let path = dir.join(format!("straightness_{name}.csv"));
    formats::write_csv(&path, &straightness)?;
    written.push(path);

    let angular: Vec<AngularRow> = a
        .lines
        .iter()
        .flat_map(|l| {
            l.angular.iter().flat_map(move |ang| {
                ang.targets.iter().map(move |t| AngularRow {
                    line: l.line,
                    target: t.target,
                    nominal_mm: t.nominal,
                    roll_urad: t.roll_urad,
                    pitch_urad: t.pitch_urad,
                    yaw_urad: t.yaw_urad,
                })
            })
        })
        .collect();
    if !angular.is_empty() {
        let path = dir.join(format!("angular_{name}.csv"));
        formats::write_csv(&path, &angular)?;
        written.push(path);
    }
    Ok(written)
}
