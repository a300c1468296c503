//! The CSV tables of a report (docs/formats.md): per axis
//! `positioning_<axis>.csv`, `straightness_<axis>.csv`, `angular_<axis>.csv`
//! (where the axis has angular figures), and `flatness.csv` — one row per
//! target of each line, the figures of [`Report`] in table form.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{AxisReport, Report};
use crate::{Result, write_csv};

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
    seed_mean_um: Option<f64>,
    seed_s_um: Option<f64>,
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

/// Write every CSV table of `report` into the folder `dir`; the paths
/// written, axis by axis, then `flatness.csv`.
pub fn write_tables(report: &Report, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for (axis, a) in report.axes.iter() {
        written.extend(axis_tables(axis.name(), a, dir)?);
    }
    if let Some(f) = &report.flatness {
        // A flatness point's fields are the table's columns, in order.
        let path = dir.join("flatness.csv");
        write_csv(&path, &f.points)?;
        written.push(path);
    }
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
    write_csv(&path, &positioning)?;
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
    write_csv(&path, &straightness)?;
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
        write_csv(&path, &angular)?;
        written.push(path);
    }
    Ok(written)
}
