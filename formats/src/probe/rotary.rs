//! Files of `trinocular probe rotary` (docs/formats.md, docs/probe-rotary.md).
//!
//! - Input `ball,angle_deg,x,y,z` (mm, table frame): one row per ball and
//!   angle ([`read_centres`]) or several, the probed points of each ball at
//!   each angle ([`read_points`]).
//! - Output `rotary.csv` / `rotary_at.csv` ([`ErrorRow`]), `spheres.csv`
//!   ([`SphereFitRow`]) and the generator's `truth.json` ([`RotaryTruth`]).
//!
//! The readers check what spans rows, each error naming the file, line
//! (the header is line 1) and column: no data rows, a duplicate (ball,
//! angle) centre, a ball with fewer than [`MIN_POINTS`] points at an angle,
//! an angle one ball lacks, angles not shared by all balls, no 0° (the
//! reference), and values in the wrong unit: a coordinate beyond
//! [`MAX_COORDINATE_MM`], or a row whose distance from the axis or height
//! disagrees with the ball's other rows while the value ÷ or × 1000 would
//! fit.

pub mod report;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::row_error;
use crate::Result;
use crate::table::{Invalid, Record, Row, finite, read_csv};

/// One turn (degrees); angles lie in `[0, 360)`.
pub const FULL_TURN_DEG: f64 = 360.0;

/// Largest coordinate (mm) of a ball centre or probed point: 5 m from the
/// table centre is beyond any rotary table a CMM or machine carries; a
/// value past it is a length in µm (or a typing error).
pub const MAX_COORDINATE_MM: f64 = 5000.0;

/// How far (mm) a ball's distance from the axis or its height may differ
/// between angles: a turn keeps both, up to the table's errors (µm) and an
/// axis a little off the frame's Z (as `probe`'s small-error model allows,
/// 2 mm of displacement).
pub const CONSISTENCY_TOLERANCE_MM: f64 = 2.0;

/// Largest ball diameter (mm) a probed point may lie from the others of its
/// ball and angle (standard balls are 10–50 mm).
pub const MAX_BALL_DIAMETER_MM: f64 = 100.0;

/// Fewest probed points that determine a sphere.
pub const MIN_POINTS: usize = 4;

/// The factor between millimetres and the units a stray value may have used (µm, m).
const UNIT_FACTOR: f64 = 1000.0;

/// One row of the input: a ball centre, or one probed point of a ball, at one angle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CentreRow {
    /// Ball name (e.g. `1`).
    pub ball: String,
    /// Table angle (degrees, counter-clockwise seen from +Z), in `[0, 360)`.
    pub angle_deg: f64,
    /// x (mm, table frame).
    pub x: f64,
    /// y (mm).
    pub y: f64,
    /// z (mm).
    pub z: f64,
}

impl CentreRow {
    /// The position (mm).
    pub fn position(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

/// Fails unless `|value| ≤ MAX_COORDINATE_MM`, naming µm as the likely unit.
fn within_reach(column: &'static str, value: f64) -> std::result::Result<(), Invalid> {
    if value.abs() <= MAX_COORDINATE_MM {
        return Ok(());
    }
    Err(Invalid::new(
        column,
        format!(
            "{column} = {value} mm is more than {MAX_COORDINATE_MM} mm from the table centre, beyond any \
             rotary table: µm instead of mm? (the file is in millimetres)"
        ),
    ))
}

impl Record for CentreRow {
    const COLUMNS: &'static [&'static str] = &["ball", "angle_deg", "x", "y", "z"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        if self.ball.trim().is_empty() {
            return Err(Invalid::new("ball", "empty ball name"));
        }
        finite("angle_deg", self.angle_deg)?;
        if !(0.0..FULL_TURN_DEG).contains(&self.angle_deg) {
            return Err(Invalid::new(
                "angle_deg",
                format!(
                    "angle {}° is not in [0°, 360°) (write 360° as 0°, −30° as 330°)",
                    self.angle_deg
                ),
            ));
        }
        for (column, v) in [("x", self.x), ("y", self.y), ("z", self.z)] {
            finite(column, v)?;
            within_reach(column, v)?;
        }
        Ok(())
    }
}

/// A position and the line it came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Located {
    /// 1-based line in the file (the header is line 1).
    pub line: u64,
    /// Position (mm).
    pub position: [f64; 3],
}

/// The rows of one ball, grouped by angle.
#[derive(Debug, Clone, PartialEq)]
pub struct BallRows {
    /// Ball name.
    pub name: String,
    /// Per angle of the file's angle list (same order), the rows at it: one
    /// centre, or the probed points.
    pub at: Vec<Vec<Located>>,
}

/// A checked input file: every ball at the same angles, 0° among them.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryInput {
    /// The file.
    pub path: PathBuf,
    /// The angles (degrees), increasing, the first 0.
    pub angles_deg: Vec<f64>,
    /// The balls in order of first appearance.
    pub balls: Vec<BallRows>,
}

impl RotaryInput {
    /// The lines of ball `ball` at `angle_deg`, if any.
    pub fn lines(&self, ball: &str, angle_deg: f64) -> Vec<u64> {
        let Some(k) = self.angles_deg.iter().position(|a| *a == angle_deg) else {
            return Vec::new();
        };
        self.balls
            .iter()
            .filter(|b| b.name == ball)
            .flat_map(|b| b.at[k].iter().map(|r| r.line))
            .collect()
    }

    /// Each ball's probed points per angle (for a points file).
    pub fn points(&self) -> Vec<(String, Vec<Vec<[f64; 3]>>)> {
        self.balls
            .iter()
            .map(|b| {
                let groups =
                    b.at.iter()
                        .map(|rows| rows.iter().map(|r| r.position).collect())
                        .collect();
                (b.name.clone(), groups)
            })
            .collect()
    }

    /// Each ball's single centre per angle (for a centres file).
    pub fn centres(&self) -> Vec<(String, Vec<[f64; 3]>)> {
        self.balls
            .iter()
            .map(|b| {
                let c =
                    b.at.iter()
                        .filter_map(|rows| rows.first().map(|r| r.position))
                        .collect();
                (b.name.clone(), c)
            })
            .collect()
    }
}

/// Read and check a file of ball centres: one row per ball and angle.
pub fn read_centres(path: &Path) -> Result<RotaryInput> {
    let input = read_grouped(path)?;
    for b in &input.balls {
        for (rows, a) in b.at.iter().zip(&input.angles_deg) {
            if let [first, second, ..] = rows.as_slice() {
                return Err(row_error(
                    path,
                    second.line,
                    "angle_deg",
                    format!(
                        "ball {} at {a}° appears twice (first on line {}): one centre per ball and angle \
                         (several rows are probed points: use --points)",
                        b.name, first.line
                    ),
                ));
            }
        }
    }
    check_common_angles(&input)?;
    for b in &input.balls {
        let centres: Vec<(f64, Located)> = input
            .angles_deg
            .iter()
            .zip(&b.at)
            .flat_map(|(a, rows)| rows.iter().map(move |r| (*a, *r)))
            .collect();
        check_consistency(path, &b.name, &centres, CONSISTENCY_TOLERANCE_MM)?;
    }
    Ok(input)
}

/// Read and check a file of probed points: ≥ [`MIN_POINTS`] rows per ball
/// and angle.
pub fn read_points(path: &Path) -> Result<RotaryInput> {
    let input = read_grouped(path)?;
    for b in &input.balls {
        for (rows, a) in b.at.iter().zip(&input.angles_deg) {
            if let Some(last) = rows.last()
                && rows.len() < MIN_POINTS
            {
                return Err(row_error(
                    path,
                    last.line,
                    "ball",
                    format!(
                        "ball {} at {a}° has {} probed point(s) ({}): a sphere needs at least \
                         {MIN_POINTS} (the north pole and four on the equator)",
                        b.name,
                        rows.len(),
                        line_list(rows)
                    ),
                ));
            }
        }
    }
    check_common_angles(&input)?;
    for b in &input.balls {
        let mut medians = Vec::new();
        for (rows, a) in b.at.iter().zip(&input.angles_deg) {
            let Some(first) = rows.first() else { continue };
            let median = median_point(rows);
            check_spread(path, &b.name, rows, &median)?;
            medians.push((
                *a,
                Located {
                    line: first.line,
                    position: median,
                },
            ));
        }
        check_consistency(
            path,
            &b.name,
            &medians,
            CONSISTENCY_TOLERANCE_MM + MAX_BALL_DIAMETER_MM / 2.0,
        )?;
    }
    Ok(input)
}

/// `lines 12, 13, 14` (or `line 12`) for the lines of some rows.
fn line_list(rows: &[Located]) -> String {
    let lines: Vec<String> = rows.iter().map(|r| r.line.to_string()).collect();
    let word = if lines.len() == 1 { "line" } else { "lines" };
    format!("{word} {}", lines.join(", "))
}

/// Read the rows, check each, and group them by ball (first appearance)
/// and angle (increasing); a file without data rows is an error.
fn read_grouped(path: &Path) -> Result<RotaryInput> {
    let rows: Vec<Row<CentreRow>> = read_csv(path)?;
    if rows.is_empty() {
        return Err(row_error(
            path,
            2,
            "ball",
            format!(
                "no data rows: the file has a header only (expected {})",
                CentreRow::COLUMNS.join(",")
            ),
        ));
    }
    let mut angles: Vec<f64> = rows.iter().map(|r| r.record.angle_deg).collect();
    angles.sort_by(f64::total_cmp);
    angles.dedup();
    let mut balls: Vec<BallRows> = Vec::new();
    for r in &rows {
        let k = angles
            .iter()
            .position(|a| *a == r.record.angle_deg)
            .unwrap_or_default();
        let located = Located {
            line: r.line,
            position: r.record.position(),
        };
        match balls.iter_mut().find(|b| b.name == r.record.ball) {
            Some(b) => b.at[k].push(located),
            None => {
                let mut at = vec![Vec::new(); angles.len()];
                at[k].push(located);
                balls.push(BallRows {
                    name: r.record.ball.clone(),
                    at,
                });
            }
        }
    }
    Ok(RotaryInput {
        path: path.to_path_buf(),
        angles_deg: angles,
        balls,
    })
}

/// Every ball at every angle of the file, and 0° among them.
fn check_common_angles(input: &RotaryInput) -> Result<()> {
    let path = &input.path;
    for (k, a) in input.angles_deg.iter().enumerate() {
        let (with, without): (Vec<&BallRows>, Vec<&BallRows>) =
            input.balls.iter().partition(|b| !b.at[k].is_empty());
        let Some(missing) = without.first() else {
            continue;
        };
        let Some(line) = with.first().and_then(|b| b.at[k].first()).map(|r| r.line) else {
            continue;
        };
        let names = |bs: &[&BallRows]| {
            bs.iter()
                .map(|b| b.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let message = if without.len() == 1 {
            format!(
                "ball {} has no row at {a}°, which every other ball has (here ball {}): every ball \
                 must be measured at every angle",
                missing.name, with[0].name
            )
        } else {
            format!(
                "angle {a}° is measured for ball(s) {} only, not for {}: every ball must be measured \
                 at the same angles",
                names(&with),
                names(&without)
            )
        };
        return Err(row_error(path, line, "angle_deg", message));
    }
    if input.angles_deg.first() != Some(&0.0) {
        let line = input
            .balls
            .iter()
            .flat_map(|b| b.at.iter().flatten())
            .map(|r| r.line)
            .min()
            .unwrap_or(2);
        return Err(row_error(
            path,
            line,
            "angle_deg",
            format!(
                "no row at 0° (the angles start at {}°): each ball's centre at 0° is its reference",
                input.angles_deg.first().copied().unwrap_or(f64::NAN)
            ),
        ));
    }
    Ok(())
}

/// Median of the values (upper median for an even count); `values` non-empty.
fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Component-wise median of the rows' positions.
fn median_point(rows: &[Located]) -> [f64; 3] {
    [0, 1, 2].map(|c| median(rows.iter().map(|r| r.position[c]).collect()))
}

/// `µm` when `value ÷ 1000` lies within `tol` of `expected`, `m` when
/// `value × 1000` does.
fn wrong_unit(value: f64, expected: f64, tol: f64) -> Option<&'static str> {
    if (value / UNIT_FACTOR - expected).abs() <= tol {
        Some("µm")
    } else if (value * UNIT_FACTOR - expected).abs() <= tol {
        Some("m")
    } else {
        None
    }
}

const COLUMNS_XYZ: [&str; 3] = ["x", "y", "z"];

/// The probed points of one ball and angle lie within a ball's diameter of
/// their median; a point that does not but would with one value ÷ or × 1000
/// names that column and unit.
fn check_spread(path: &Path, ball: &str, rows: &[Located], median: &[f64; 3]) -> Result<()> {
    for r in rows {
        let off: Vec<f64> = (0..3).map(|c| (r.position[c] - median[c]).abs()).collect();
        let Some(c) = (0..3)
            .filter(|c| off[*c] > MAX_BALL_DIAMETER_MM)
            .max_by(|a, b| off[*a].total_cmp(&off[*b]))
        else {
            continue;
        };
        let column = COLUMNS_XYZ[c];
        let unit = wrong_unit(r.position[c], median[c], MAX_BALL_DIAMETER_MM);
        return Err(row_error(
            path,
            r.line,
            column,
            format!(
                "{column} = {} lies {:.3} mm from the other probed points of ball {ball} at this angle \
                 (median {:.3}), more than a ball's diameter{}",
                r.position[c],
                off[c],
                median[c],
                unit.map_or_else(String::new, |u| format!(": {u} instead of mm?"))
            ),
        ));
    }
    Ok(())
}

/// `p` turned by `angle_deg` counter-clockwise about Z.
fn turn(p: &[f64; 3], angle_deg: f64) -> [f64; 3] {
    let (s, c) = angle_deg.to_radians().sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]]
}

/// A turn keeps each ball's distance from the axis and its height: a row
/// (centre, or median of probed points; with its angle) farther than `tol`
/// from the ball's median in either is an error. The column named is the
/// one whose value ÷ or × 1000 lands where a turn of the ball's median 0°
/// position (the median of every row turned back) puts it.
fn check_consistency(path: &Path, ball: &str, rows: &[(f64, Located)], tol: f64) -> Result<()> {
    let rho = |p: &[f64; 3]| p[0].hypot(p[1]);
    let rho_med = median(rows.iter().map(|(_, r)| rho(&r.position)).collect());
    let z_med = median(rows.iter().map(|(_, r)| r.position[2]).collect());
    let worst = rows
        .iter()
        .map(|(a, r)| {
            let dz = (r.position[2] - z_med).abs();
            let dr = (rho(&r.position) - rho_med).abs();
            (*a, r, dz.max(dr))
        })
        .filter(|(_, _, d)| *d > tol)
        .max_by(|a, b| a.2.total_cmp(&b.2));
    let Some((angle, r, _)) = worst else {
        return Ok(());
    };
    let p = r.position;
    let back: Vec<[f64; 3]> = rows.iter().map(|(a, r)| turn(&r.position, -a)).collect();
    let p0 = [0, 1, 2].map(|c| median(back.iter().map(|q| q[c]).collect()));
    let expected = turn(&p0, angle);
    let fix = (0..3).find_map(|c| wrong_unit(p[c], expected[c], tol).map(|unit| (c, unit)));
    let (column, message) = match fix {
        Some((c, unit)) => (
            COLUMNS_XYZ[c],
            format!(
                "{} = {} does not fit ball {ball}'s other rows (at {angle}° they put it near {:.3} mm) \
                 unless it is in {unit}: the file is in millimetres",
                COLUMNS_XYZ[c], p[c], expected[c]
            ),
        ),
        None => (
            if (p[2] - z_med).abs() > tol {
                "z"
            } else {
                "ball"
            },
            format!(
                "the row lies {:.3} mm from the axis at z = {:.3} mm, but ball {ball}'s other rows lie \
                 {rho_med:.3} mm from it at z = {z_med:.3} mm (a turn keeps both to within {tol} mm): \
                 a wrong ball name, a different frame or unit?",
                rho(&p),
                p[2]
            ),
        ),
    };
    Err(row_error(path, r.line, column, message))
}

/// One row of `rotary.csv` / `rotary_at.csv`: the six errors (mm, rad) and
/// their standard uncertainties at one angle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[allow(non_snake_case)]
pub struct ErrorRow {
    /// Table angle (degrees).
    pub angle_deg: f64,
    /// δx (mm).
    pub EXC: f64,
    /// δy (mm).
    pub EYC: f64,
    /// δz (mm).
    pub EZC: f64,
    /// εx (rad).
    pub EAC: f64,
    /// εy (rad).
    pub EBC: f64,
    /// εz (rad).
    pub ECC: f64,
    /// u(EXC) (mm).
    pub u_EXC: f64,
    /// u(EYC) (mm).
    pub u_EYC: f64,
    /// u(EZC) (mm).
    pub u_EZC: f64,
    /// u(EAC) (rad).
    pub u_EAC: f64,
    /// u(EBC) (rad).
    pub u_EBC: f64,
    /// u(ECC) (rad).
    pub u_ECC: f64,
}

impl ErrorRow {
    /// A row from the angle, the six errors and their uncertainties.
    pub fn new(angle_deg: f64, errors: [f64; 6], u: [f64; 6]) -> ErrorRow {
        ErrorRow {
            angle_deg,
            EXC: errors[0],
            EYC: errors[1],
            EZC: errors[2],
            EAC: errors[3],
            EBC: errors[4],
            ECC: errors[5],
            u_EXC: u[0],
            u_EYC: u[1],
            u_EZC: u[2],
            u_EAC: u[3],
            u_EBC: u[4],
            u_ECC: u[5],
        }
    }

    /// The six errors (mm, rad).
    pub fn errors(&self) -> [f64; 6] {
        [self.EXC, self.EYC, self.EZC, self.EAC, self.EBC, self.ECC]
    }

    /// Their standard uncertainties.
    pub fn uncertainties(&self) -> [f64; 6] {
        [
            self.u_EXC, self.u_EYC, self.u_EZC, self.u_EAC, self.u_EBC, self.u_ECC,
        ]
    }
}

impl Record for ErrorRow {
    const COLUMNS: &'static [&'static str] = &[
        "angle_deg",
        "EXC",
        "EYC",
        "EZC",
        "EAC",
        "EBC",
        "ECC",
        "u_EXC",
        "u_EYC",
        "u_EZC",
        "u_EAC",
        "u_EBC",
        "u_ECC",
    ];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("angle_deg", self.angle_deg)?;
        for (k, v) in self.errors().into_iter().enumerate() {
            finite(Self::COLUMNS[1 + k], v)?;
        }
        for (k, v) in self.uncertainties().into_iter().enumerate() {
            finite(Self::COLUMNS[7 + k], v)?;
        }
        Ok(())
    }
}

/// One row of `spheres.csv`: the sphere fitted to the probed points of one
/// ball at one angle (its `ball,angle_deg,x,y,z` make it a centres file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SphereFitRow {
    /// Ball name.
    pub ball: String,
    /// Table angle (degrees).
    pub angle_deg: f64,
    /// Centre x (mm).
    pub x: f64,
    /// Centre y (mm).
    pub y: f64,
    /// Centre z (mm).
    pub z: f64,
    /// Radius (mm).
    pub radius: f64,
    /// RMS radial residual (mm).
    pub rms_residual: f64,
    /// Largest absolute radial residual (mm).
    pub max_residual: f64,
    /// Number of probed points.
    pub points: usize,
}

impl Record for SphereFitRow {
    const COLUMNS: &'static [&'static str] = &[
        "ball",
        "angle_deg",
        "x",
        "y",
        "z",
        "radius",
        "rms_residual",
        "max_residual",
        "points",
    ];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        super::finite_fields!(self, angle_deg, x, y, z, radius, rms_residual, max_residual)
    }
}

/// Location errors of the axis average line (ISO 230-7 names), as
/// `truth.json` and `report.json` ([`report::LocationReport`]) give them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LocationErrors {
    /// X0C (µm).
    #[serde(rename = "X0C_um")]
    pub x0c_um: f64,
    /// Y0C (µm).
    #[serde(rename = "Y0C_um")]
    pub y0c_um: f64,
    /// A0C (µrad).
    #[serde(rename = "A0C_urad")]
    pub a0c_urad: f64,
    /// B0C (µrad).
    #[serde(rename = "B0C_urad")]
    pub b0c_urad: f64,
}

/// A ball of the truth: its true centre at 0° (before errors).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BallTruth {
    /// Ball name.
    pub ball: String,
    /// Position on the table (mm).
    pub position: [f64; 3],
}

/// `truth.json` of the rotary check data: the true six errors per angle
/// (`truth_mm_rad`, columns EXC…ECC, mm and rad, referred to 0° as the
/// method refers them), and where the generator wrote them, the location
/// errors, the component errors and what the data were made with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RotaryTruth {
    /// The angles (degrees).
    pub angles_deg: Vec<f64>,
    /// `EXC … ECC`.
    pub columns: Vec<String>,
    /// The six true errors per angle (mm, rad).
    pub truth_mm_rad: Vec<[f64; 6]>,
    /// True location errors of the axis average line.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub location: Option<LocationErrors>,
    /// True component errors per angle (errors − fixed-axis part; mm, rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub components_mm_rad: Option<Vec<[f64; 6]>>,
    /// The balls and their positions.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub balls: Vec<BallTruth>,
    /// Standard deviation of the centre noise per coordinate (µm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_um: Option<f64>,
    /// Standard deviation of the probed-point noise per coordinate (µm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probe_noise_um: Option<f64>,
    /// Ball radius (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ball_radius_mm: Option<f64>,
    /// Random seed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::probe::assert_mentions;

    fn write(text: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.csv");
        std::fs::write(&path, text).unwrap();
        (dir, path)
    }

    /// Three balls every 90°, exact turns of their 0° centres, each row
    /// passed through `edit(ball, angle, position)`.
    fn table(edit: impl Fn(u32, f64, [f64; 3]) -> [f64; 3]) -> String {
        let mut s = String::from("ball,angle_deg,x,y,z\n");
        for a in [0.0_f64, 90.0, 180.0, 270.0] {
            for (b, p) in [
                (1, [150.0, 10.0, 60.0]),
                (2, [-70.0, 120.0, 95.0]),
                (3, [-55.0, -135.0, 3.0]),
            ] {
                let (sn, c) = a.to_radians().sin_cos();
                let q = edit(b, a, [c * p[0] - sn * p[1], sn * p[0] + c * p[1], p[2]]);
                s.push_str(&format!("{b},{a},{},{},{}\n", q[0], q[1], q[2]));
            }
        }
        s
    }

    fn good() -> String {
        table(|_, _, p| p)
    }

    fn error_of(text: &str) -> String {
        let (_d, p) = write(text);
        read_centres(&p).unwrap_err().to_string()
    }

    #[test]
    fn a_good_file_groups_by_ball_and_angle() {
        let (_d, p) = write(&good());
        let input = read_centres(&p).unwrap();
        assert_eq!(input.angles_deg, vec![0.0, 90.0, 180.0, 270.0]);
        assert_eq!(input.balls.len(), 3);
        assert_eq!(input.balls[1].name, "2");
        assert_eq!(input.lines("2", 90.0), vec![6]);
        assert_eq!(input.centres()[0].1.len(), 4);
    }

    #[test]
    fn duplicate_missing_and_unshared_angles_name_the_line() {
        let mut dup = good();
        dup.push_str("2,90,1,2,95\n");
        let e = error_of(&dup);
        assert_mentions(&e, &["line 14, column 'angle_deg'", "twice", "line 6"]);

        let missing: String = good()
            .lines()
            .filter(|l| !l.starts_with("3,180"))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = error_of(&missing);
        assert_mentions(&e, &["ball 3 has no row at 180°", "column 'angle_deg'"]);

        let mut other = good();
        other.push_str("1,45,10,150,60\n");
        let e = error_of(&other);
        assert!(
            e.contains("45° is measured for ball(s) 1 only, not for 2, 3"),
            "{e}"
        );
        assert!(e.contains("line 14"), "{e}");

        let no_zero: String = good()
            .lines()
            .filter(|l| !l.contains(",0,"))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = error_of(&no_zero);
        assert_mentions(&e, &["no row at 0°", "line 2"]);
    }

    #[test]
    fn wrong_units_name_the_column() {
        let e = error_of("ball,angle_deg,x,y,z\n1,0,150000,10,60\n");
        assert_mentions(&e, &["line 2, column 'x'", "µm"]);
        // One value in µm or m within reach of the absolute limit: the ball's other rows tell.
        let e = error_of(&table(|b, a, p| {
            if b == 3 && a == 180.0 {
                [p[0], p[1], p[2] * 1e3]
            } else {
                p
            }
        }));
        assert_mentions(&e, &["line 10, column 'z'", "in µm"]);
        let e = error_of(&table(|b, a, p| {
            if b == 2 && a == 90.0 {
                [p[0], p[1] / 1e3, p[2]]
            } else {
                p
            }
        }));
        assert_mentions(&e, &["line 6, column 'y'", "in m:"]);
        let e = error_of(&table(|b, a, p| {
            if b == 1 && a == 270.0 {
                [p[0] + 40.0, p[1], p[2]]
            } else {
                p
            }
        }));
        assert_mentions(&e, &["line 11", "wrong ball name"]);
        let e = error_of("ball,angle_deg,x,y,z\n1,0,NaN,10,60\n");
        assert_mentions(&e, &["line 2, column 'x'", "not a finite"]);
        let e = error_of("ball,angle_deg,x,y,z\n1,360,150,10,60\n");
        assert_mentions(&e, &["column 'angle_deg'", "[0°, 360°)"]);
        let e = error_of("ball,angle_deg,x,y,z\n");
        assert_mentions(&e, &["line 2", "no data rows"]);
    }

    #[test]
    fn points_need_four_per_ball_and_angle() {
        let mut s = String::from("ball,angle_deg,x,y,z\n");
        for a in [0, 90] {
            for b in 1..=3 {
                let n = if a == 90 && b == 2 { 3 } else { 5 };
                for k in 0..n {
                    s.push_str(&format!(
                        "{b},{a},{},{},{}\n",
                        100.0 * f64::from(b) + f64::from(k),
                        0.0,
                        50.0
                    ));
                }
            }
        }
        let (_d, p) = write(&s);
        let e = read_points(&p).unwrap_err().to_string();
        assert_mentions(
            &e,
            &["ball 2 at 90° has 3 probed point(s)", "column 'ball'"],
        );
        assert!(e.contains("line 24"), "{e}");
        let (_d, p) = write(&s.replace("201,0,50", "201000,0,50"));
        let e = read_points(&p).unwrap_err().to_string();
        assert_mentions(&e, &["column 'x'", "µm"]);
    }
}
