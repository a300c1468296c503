//! Files of `trinocular probe volumetric` (docs/probe-volumetric.md, docs/formats.md):
//! the error curves `E.csv` (`axis,position,ex,ey,ez,ea,eb,ec`, mm and rad),
//! carriage positions `at.csv` (`x,y,z`), the outputs `fits.csv`,
//! `volumetric.csv`, `circle.csv`, LinuxCNC compensation files, the
//! generator's `setup.json`, and the parts of `trinocular evaluate`'s
//! `report.json` that `--from-report` reads; the error motions, series and
//! models these files and the method's own `report.json` ([`report`]) name.

pub mod report;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::row_error;
use crate::campaign::Axis;
use crate::table::{Invalid, Record, Row, finite, read_csv};
use crate::{FormatError, Result};

/// Largest plausible translation error (mm): a larger value is taken for a
/// file written in µm.
pub const MAX_TRANSLATION_MM: f64 = 1.0;
/// Largest plausible rotation error (rad, ≈ 34′): a larger value is taken for
/// a file written in µrad or arc-seconds.
pub const MAX_ROTATION_RAD: f64 = 0.01;
/// Most lines LinuxCNC reads from one `COMP_FILE` (its `EMCMOT_COMP_SIZE`).
pub const COMP_FILE_MAX_LINES: usize = 256;
/// The `COMP_FILE_TYPE` the compensation files are written for: 0, each line
/// `nominal actual_forward actual_reverse` (the actual positions reached
/// when moving in + and in − direction), in machine units.
pub const COMP_FILE_TYPE: u8 = 0;

/// One row of `E.csv`: the six error motions of one axis at one carriage position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorRow {
    /// The axis: `X`, `Y` or `Z` (checked on reading; see [`ErrorRow::axis`]).
    pub axis: String,
    /// Carriage position q (mm).
    pub position: f64,
    /// Translation along X (mm).
    pub ex: f64,
    /// Translation along Y (mm).
    pub ey: f64,
    /// Translation along Z (mm).
    pub ez: f64,
    /// Rotation about X (rad).
    pub ea: f64,
    /// Rotation about Y (rad).
    pub eb: f64,
    /// Rotation about Z (rad).
    pub ec: f64,
    /// Optional: positioning error approached in the + direction (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positioning_up: Option<f64>,
    /// Optional: positioning error approached in the − direction (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positioning_down: Option<f64>,
}

/// The axis named `name` (`X`, `Y`, `Z`; case ignored).
pub fn axis_named(name: &str) -> Option<Axis> {
    match name.trim().to_ascii_uppercase().as_str() {
        "X" => Some(Axis::X),
        "Y" => Some(Axis::Y),
        "Z" => Some(Axis::Z),
        _ => None,
    }
}

impl ErrorRow {
    /// The axis (rows that [`read_errors`] returned always have one; X otherwise).
    pub fn axis(&self) -> Axis {
        axis_named(&self.axis).unwrap_or(Axis::X)
    }

    /// `[ex, ey, ez, ea, eb, ec]`.
    pub fn motions(&self) -> [f64; 6] {
        [self.ex, self.ey, self.ez, self.ea, self.eb, self.ec]
    }
}

/// Fails unless `value` is finite and a plausible translation error in mm.
fn translation(column: &'static str, value: f64) -> std::result::Result<(), Invalid> {
    finite(column, value)?;
    if value.abs() > MAX_TRANSLATION_MM {
        return Err(Invalid::new(
            column,
            format!(
                "{value} mm is implausible for an error motion (more than {MAX_TRANSLATION_MM} mm): \
                 is the file in µm? Translations are in mm"
            ),
        ));
    }
    Ok(())
}

impl Record for ErrorRow {
    const COLUMNS: &'static [&'static str] =
        &["axis", "position", "ex", "ey", "ez", "ea", "eb", "ec"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        if axis_named(&self.axis).is_none() {
            return Err(Invalid::new(
                "axis",
                format!("'{}' is not an axis: X, Y or Z", self.axis),
            ));
        }
        finite("position", self.position)?;
        translation("ex", self.ex)?;
        translation("ey", self.ey)?;
        translation("ez", self.ez)?;
        for (column, v) in [("ea", self.ea), ("eb", self.eb), ("ec", self.ec)] {
            finite(column, v)?;
            if v.abs() > MAX_ROTATION_RAD {
                return Err(Invalid::new(
                    column,
                    format!(
                        "{v} rad is implausible for an error motion (more than {MAX_ROTATION_RAD} rad): \
                         is the file in µrad or arc-seconds? Rotations are in rad"
                    ),
                ));
            }
        }
        if let Some(v) = self.positioning_up {
            translation("positioning_up", v)?;
        }
        if let Some(v) = self.positioning_down {
            translation("positioning_down", v)?;
        }
        Ok(())
    }
}

/// Read `E.csv` with the checks that span rows: per axis the positions
/// increase strictly in file order (a repeated position is a duplicate),
/// and the optional direction columns are given on every row of an axis
/// or on none.
pub fn read_errors(path: &Path) -> Result<Vec<Row<ErrorRow>>> {
    let rows = read_csv::<ErrorRow>(path)?;
    if rows.is_empty() {
        return Err(FormatError::file(path, "no error curves (only a header)"));
    }
    let mut last: BTreeMap<Axis, (f64, u64)> = BTreeMap::new();
    for r in &rows {
        if let Some(&(p, line)) = last.get(&r.record.axis()) {
            if r.record.position == p {
                return Err(row_error(
                    path,
                    r.line,
                    "position",
                    format!(
                        "duplicate: axis {} at {p} mm is already on line {line}",
                        r.record.axis
                    ),
                ));
            }
            if r.record.position < p {
                return Err(row_error(
                    path,
                    r.line,
                    "position",
                    format!(
                        "positions of axis {} must increase: {} mm follows {p} mm (line {line})",
                        r.record.axis, r.record.position
                    ),
                ));
            }
        }
        last.insert(r.record.axis(), (r.record.position, r.line));
    }
    for (column, get) in [
        (
            "positioning_up",
            (|r: &ErrorRow| r.positioning_up) as fn(&ErrorRow) -> Option<f64>,
        ),
        ("positioning_down", |r: &ErrorRow| r.positioning_down),
    ] {
        for axis in last.keys() {
            let of_axis: Vec<&Row<ErrorRow>> =
                rows.iter().filter(|r| r.record.axis() == *axis).collect();
            let given = of_axis.iter().filter(|r| get(&r.record).is_some()).count();
            if given > 0 && given < of_axis.len() {
                let missing = of_axis.iter().find(|r| get(&r.record).is_none());
                return Err(row_error(
                    path,
                    missing.map_or(1, |r| r.line),
                    column,
                    format!(
                        "missing: axis {axis} has this column on {given} of its {} rows; give it on all or none",
                        of_axis.len()
                    ),
                ));
            }
        }
    }
    Ok(rows)
}

/// One row of `at.csv`: carriage positions (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AtRow {
    /// X carriage position (mm).
    pub x: f64,
    /// Y carriage position (mm).
    pub y: f64,
    /// Z carriage position (mm).
    pub z: f64,
}

impl Record for AtRow {
    const COLUMNS: &'static [&'static str] = &["x", "y", "z"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("x", self.x)?;
        finite("y", self.y)?;
        finite("z", self.z)
    }
}

/// Read `at.csv` (at least one row).
pub fn read_at(path: &Path) -> Result<Vec<Row<AtRow>>> {
    let rows = read_csv::<AtRow>(path)?;
    if rows.is_empty() {
        return Err(FormatError::file(path, "no positions (only a header)"));
    }
    Ok(rows)
}

/// One row of `fits.csv`: the figures of one model of one curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitRow {
    /// The axis.
    pub axis: Axis,
    /// The curve: `ex` … `ec`.
    pub error: String,
    /// `fourier` or `polynomial`.
    pub model: String,
    /// R² = 1 − SSE/SST (empty when the curve is constant).
    pub r2: Option<f64>,
    /// Σ r² (mm² or rad²).
    pub sse: f64,
    /// √(SSE/n) (mm or rad).
    pub rmse: f64,
    /// max |r| (mm or rad).
    pub emax: f64,
    /// Order N (the polynomial has degree 2N).
    pub order: usize,
    /// Coefficients 2N + 1.
    pub coefficients: usize,
}

impl Record for FitRow {
    const COLUMNS: &'static [&'static str] = &[
        "axis",
        "error",
        "model",
        "r2",
        "sse",
        "rmse",
        "emax",
        "order",
        "coefficients",
    ];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        if let Some(r2) = self.r2 {
            finite("r2", r2)?;
        }
        finite("sse", self.sse)?;
        finite("rmse", self.rmse)?;
        finite("emax", self.emax)
    }
}

/// One row of `volumetric.csv`: the volumetric error (dx, dy, dz) at carriage
/// positions (workpiece frame, mm).
pub use super::PointDisplacementRow as VolumetricRow;

/// One row of `circle.csv`: the predicted circular test at one angle (mm),
/// and the radial deviation left after compensating with each series.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CircleRow {
    /// θ (degrees).
    pub angle_deg: f64,
    /// Error along X (mm).
    pub dx: f64,
    /// Error along Y (mm).
    pub dy: f64,
    /// Error along Z (mm).
    pub dz: f64,
    /// Radial deviation `Δ·(cos θ, sin θ, 0)` (mm).
    pub radial: f64,
    /// Radial deviation after compensation with the Fourier series (mm).
    pub radial_compensated_fourier: f64,
    /// Radial deviation after compensation with the polynomial (mm).
    pub radial_compensated_polynomial: f64,
}

impl Record for CircleRow {
    const COLUMNS: &'static [&'static str] = &[
        "angle_deg",
        "dx",
        "dy",
        "dz",
        "radial",
        "radial_compensated_fourier",
        "radial_compensated_polynomial",
    ];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("angle_deg", self.angle_deg)?;
        finite("radial", self.radial)
    }
}

/// One line of a LinuxCNC compensation file of type [`COMP_FILE_TYPE`] (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompLine {
    /// Nominal (commanded) position.
    pub nominal: f64,
    /// Actual position reached moving in the + direction.
    pub forward: f64,
    /// Actual position reached moving in the − direction.
    pub reverse: f64,
}

/// Why a compensation table cannot be a LinuxCNC `COMP_FILE`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompFileError {
    /// No entries, or more than LinuxCNC reads.
    #[error("{entries} entries; a compensation file takes 1 to {COMP_FILE_MAX_LINES}")]
    Entries {
        /// Entries given.
        entries: usize,
    },
    /// An entry with a value that is not finite.
    #[error("entry {entry} is not finite")]
    NotFinite {
        /// The entry, 1-based.
        entry: usize,
    },
    /// Nominal positions that do not ascend strictly.
    #[error("nominal positions must ascend: {nominal} follows {previous}")]
    NotAscending {
        /// The nominal position out of order.
        nominal: f64,
        /// The one before it.
        previous: f64,
    },
}

/// The text of a LinuxCNC `COMP_FILE` of type 0: one line per entry, the three
/// numbers separated by a space, nominal positions strictly ascending, at most
/// [`COMP_FILE_MAX_LINES`] lines, nothing else (LinuxCNC stops reading at the
/// first line that is not three numbers, so there is no header).
pub fn comp_file_text(lines: &[CompLine]) -> std::result::Result<String, CompFileError> {
    if lines.is_empty() || lines.len() > COMP_FILE_MAX_LINES {
        return Err(CompFileError::Entries {
            entries: lines.len(),
        });
    }
    let mut text = String::new();
    for (k, l) in lines.iter().enumerate() {
        if ![l.nominal, l.forward, l.reverse]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(CompFileError::NotFinite { entry: k + 1 });
        }
        if k > 0 && l.nominal <= lines[k - 1].nominal {
            return Err(CompFileError::NotAscending {
                nominal: l.nominal,
                previous: lines[k - 1].nominal,
            });
        }
        let _ = writeln!(text, "{:.7} {:.7} {:.7}", l.nominal, l.forward, l.reverse);
    }
    Ok(text)
}

/// Write a LinuxCNC `COMP_FILE` (type [`COMP_FILE_TYPE`]), a planned output of `output`.
pub fn write_comp_file(output: &crate::OutputPlan, path: &Path, lines: &[CompLine]) -> Result<()> {
    let text = comp_file_text(lines).map_err(|e| FormatError::file(path, e.to_string()))?;
    output.write_bytes(path, text.as_bytes())
}

/// `setup.json` of the generator and the check data: squareness (rad), chain,
/// tool offset and circle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetupJson {
    /// `EC0Y`, `EB0Z`, `EA0Z` (rad).
    pub squareness_rad: Squareness,
    /// Chain string, e.g. `WXYFZT`.
    pub chain: String,
    /// Tool offset t (mm).
    pub tool_mm: [f64; 3],
    /// The circle of the circular test.
    pub circle: CircleJson,
}

/// The three squareness errors of docs/probe-volumetric.md (rad in files and in the
/// model; µrad where a report says so): Y against X in the XY plane, Z
/// against X, Z against Y.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Squareness {
    /// Y against X: `a_Y = (−sin EC0Y, cos EC0Y, 0)`.
    #[serde(rename = "EC0Y")]
    pub ec0y: f64,
    /// Z against X: rotation of `a_Z` about Y.
    #[serde(rename = "EB0Z")]
    pub eb0z: f64,
    /// Z against Y: rotation of `a_Z` about X.
    #[serde(rename = "EA0Z")]
    pub ea0z: f64,
}

/// A circle in the workpiece frame, plane XY (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CircleJson {
    /// Centre.
    pub centre_mm: [f64; 3],
    /// Radius.
    pub radius_mm: f64,
}

/// The parts of `trinocular evaluate`'s `report.json` that `--from-report`
/// reads (docs/formats.md; other keys are ignored).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluateReport {
    /// Per axis (`X`, `Y`, `Z`): the main line's figures.
    pub axes: BTreeMap<String, EvaluateLine>,
    /// Flatness, with the per-target mean sphere centres of every line.
    #[serde(default)]
    pub flatness: Option<EvaluateFlatness>,
    /// The sphere that carries positioning and straightness.
    pub sphere: String,
}

/// One line of an axis in `report.json`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluateLine {
    /// Index of the line among the axis's lines.
    pub line: usize,
    /// Off-axis commanded coordinates (mm), keyed `x`/`y`/`z`.
    pub off_axis: BTreeMap<String, f64>,
    /// Fitted axis direction (unit vector, world frame).
    pub direction: [f64; 3],
    /// Positioning, per target.
    pub positioning: EvaluatePositioning,
    /// Straightness per perpendicular world axis (`X`, `Y`, `Z`).
    pub straightness: BTreeMap<String, EvaluateStraightness>,
    /// Roll, pitch, yaw per target (absent without three spheres).
    #[serde(default)]
    pub angular: Option<EvaluateAngular>,
}

/// Positioning of a line.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluatePositioning {
    /// Per target.
    pub targets: Vec<EvaluatePositioningTarget>,
    /// Expanded uncertainty (k = 2) of M, the range of the mean
    /// bidirectional deviations (µm; absent when evaluated without trials).
    #[serde(rename = "M_U_um", default)]
    pub m_u_um: Option<f64>,
}

/// Positioning at one target (µm; nominal in mm).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluatePositioningTarget {
    /// Target index.
    pub target: u32,
    /// Commanded coordinate of the moving axis (mm).
    pub nominal: f64,
    /// Mean deviation of the ↑ approaches.
    #[serde(default)]
    pub mean_up_um: Option<f64>,
    /// Mean deviation of the ↓ approaches.
    #[serde(default)]
    pub mean_down_um: Option<f64>,
    /// Mean bidirectional deviation.
    #[serde(default)]
    pub mean_um: Option<f64>,
}

/// Straightness of a line in one direction.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluateStraightness {
    /// Per target.
    pub targets: Vec<EvaluateStraightnessTarget>,
    /// Expanded uncertainty (k = 2) of the least-squares straightness, the
    /// range of the deviations (µm; absent when evaluated without trials).
    #[serde(rename = "lsq_U_um", default)]
    pub lsq_u_um: Option<f64>,
}

/// Straightness at one target.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluateStraightnessTarget {
    /// Target index.
    pub target: u32,
    /// Deviation from the least-squares reference line (µm).
    pub deviation_um: f64,
}

/// Angular errors of a line.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluateAngular {
    /// Per target, relative to the first target.
    pub targets: Vec<EvaluateAngularTarget>,
    /// Expanded uncertainty (k = 2) of the roll range (µrad; absent when
    /// evaluated without trials).
    #[serde(rename = "roll_U_urad", default)]
    pub roll_u_urad: Option<f64>,
    /// Of the pitch range.
    #[serde(rename = "pitch_U_urad", default)]
    pub pitch_u_urad: Option<f64>,
    /// Of the yaw range.
    #[serde(rename = "yaw_U_urad", default)]
    pub yaw_u_urad: Option<f64>,
}

/// Roll, pitch, yaw at one target (µrad).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluateAngularTarget {
    /// Target index.
    pub target: u32,
    /// Rotation about the moving axis.
    pub roll_urad: f64,
    /// Pitch (X: about Y; Y, Z: about X).
    pub pitch_urad: f64,
    /// Yaw (X, Y: about Z; Z: about Y).
    pub yaw_urad: f64,
}

/// Flatness of the combined lines.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluateFlatness {
    /// The per-target mean sphere centres.
    pub points: Vec<EvaluateFlatnessPoint>,
}

/// A per-target mean centre of the evaluated sphere (mm, world frame).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EvaluateFlatnessPoint {
    /// Axis of the line.
    pub axis: String,
    /// Line index within the axis.
    pub line: usize,
    /// Target index.
    pub target: u32,
    /// Measured x (mm).
    pub x: f64,
    /// Measured y (mm).
    pub y: f64,
    /// Measured z (mm).
    pub z: f64,
}

/// Read `DIR/report.json` written by `trinocular evaluate`.
pub fn read_evaluate_report(dir: &Path) -> Result<EvaluateReport> {
    let path = dir.join("report.json");
    let report: EvaluateReport = crate::read_json(&path)?;
    for (name, line) in &report.axes {
        if !matches!(name.as_str(), "X" | "Y" | "Z") {
            return Err(FormatError::file(
                &path,
                format!("axes.{name}: unknown axis"),
            ));
        }
        let finite = line.positioning.targets.iter().all(|t| {
            t.nominal.is_finite()
                && [t.mean_um, t.mean_up_um, t.mean_down_um]
                    .iter()
                    .flatten()
                    .all(|v| v.is_finite())
        });
        if !finite {
            return Err(FormatError::file(
                &path,
                format!("axes.{name}.positioning: a value is not a finite number"),
            ));
        }
    }
    Ok(report)
}

/// One of the six error motions of a linear axis (ISO 230-1 names for axis
/// X in brackets): translations `ex` (EXX), `ey` (EYX), `ez` (EZX) along, and
/// rotations `ea` (EAX), `eb` (EBX), `ec` (ECX) about, the machine X, Y, Z.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Motion {
    /// Translation along X (mm).
    Ex,
    /// Translation along Y (mm).
    Ey,
    /// Translation along Z (mm).
    Ez,
    /// Rotation about X (rad).
    Ea,
    /// Rotation about Y (rad).
    Eb,
    /// Rotation about Z (rad).
    Ec,
}

impl Motion {
    /// The six motions in file-column order `ex, ey, ez, ea, eb, ec`.
    pub const ALL: [Motion; 6] = [
        Motion::Ex,
        Motion::Ey,
        Motion::Ez,
        Motion::Ea,
        Motion::Eb,
        Motion::Ec,
    ];

    /// Index 0–5 in [`Motion::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The column name `ex` … `ec`.
    pub fn name(self) -> &'static str {
        ["ex", "ey", "ez", "ea", "eb", "ec"][self.index()]
    }

    /// The motion of column `name` (`ex` … `ec`).
    pub fn from_name(name: &str) -> Option<Motion> {
        Motion::ALL.into_iter().find(|m| m.name() == name)
    }

    /// A rotation (`ea`, `eb`, `ec`, rad) rather than a translation (mm).
    pub fn is_rotation(self) -> bool {
        self.index() >= 3
    }

    /// The machine axis (X, Y, Z) the translation runs along or the rotation turns about.
    pub fn direction(self) -> Axis {
        match self {
            Motion::Ex | Motion::Ea => Axis::X,
            Motion::Ey | Motion::Eb => Axis::Y,
            Motion::Ez | Motion::Ec => Axis::Z,
        }
    }

    /// A straightness of `axis`: a translation across it.
    pub fn is_straightness(self, axis: Axis) -> bool {
        !self.is_rotation() && self.direction() != axis
    }

    /// The positioning error of `axis`: the translation along it.
    pub fn is_positioning(self, axis: Axis) -> bool {
        !self.is_rotation() && self.direction() == axis
    }

    /// The ISO 230-1 symbol of this motion of `axis`, e.g. `EYX` (straightness
    /// of X in Y) or `EBX` (pitch of X).
    pub fn symbol(self, axis: Axis) -> String {
        let letter = match self {
            Motion::Ex => "X",
            Motion::Ey => "Y",
            Motion::Ez => "Z",
            Motion::Ea => "A",
            Motion::Eb => "B",
            Motion::Ec => "C",
        };
        format!("E{letter}{}", axis.name())
    }

    /// The translation along `axis` (its positioning error).
    pub fn along(axis: Axis) -> Motion {
        Motion::ALL[axis.index()]
    }
}

/// The kind of a fitted series.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Series {
    /// Fourier series of order N (2N + 1 coefficients).
    Fourier,
    /// Polynomial of degree 2N (2N + 1 coefficients), in Chebyshev form.
    Polynomial,
}

impl Series {
    /// Both kinds, Fourier first.
    pub const BOTH: [Series; 2] = [Series::Fourier, Series::Polynomial];

    /// `fourier` or `polynomial`.
    pub fn name(self) -> &'static str {
        match self {
            Series::Fourier => "fourier",
            Series::Polynomial => "polynomial",
        }
    }
}

/// How a curve is evaluated between measured positions (`--model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Model {
    /// Linear between the measured positions.
    Raw,
    /// The fitted Fourier series.
    Fourier,
    /// The fitted polynomial.
    Polynomial,
}

impl Model {
    /// `raw`, `fourier` or `polynomial`.
    pub fn name(self) -> &'static str {
        match self {
            Model::Raw => "raw",
            Model::Fourier => "fourier",
            Model::Polynomial => "polynomial",
        }
    }

    /// The series of a fitted model.
    pub fn series(self) -> Option<Series> {
        match self {
            Model::Raw => None,
            Model::Fourier => Some(Series::Fourier),
            Model::Polynomial => Some(Series::Polynomial),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::probe::assert_mentions;

    fn read(text: &str) -> Result<Vec<Row<ErrorRow>>> {
        let dir = tempfile::tempdir().map_err(|e| FormatError::io("tmp", e))?;
        let p = dir.path().join("E.csv");
        std::fs::write(&p, text).map_err(|e| FormatError::io(&p, e))?;
        read_errors(&p)
    }

    const HEADER: &str = "axis,position,ex,ey,ez,ea,eb,ec\n";

    #[test]
    fn good_curves_read() {
        let rows = read(&format!(
            "{HEADER}X,0,0.001,0,0,1e-6,0,0\nX,10,0.002,0,0,0,0,0\nY,0,0,0,0,0,0,0\n"
        ))
        .unwrap_or_default();
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[1].line, 3);
        assert_eq!(rows[0].record.positioning_up, None);
    }

    #[test]
    fn bad_curves_name_line_and_column() {
        let cases = [
            (
                "X,0,0,0,0,0,0,0\nX,0,0,0,0,0,0,0\n",
                "line 3, column 'position'",
                "duplicate",
            ),
            (
                "X,10,0,0,0,0,0,0\nX,5,0,0,0,0,0,0\n",
                "line 3, column 'position'",
                "increase",
            ),
            ("X,0,3.05,0,0,0,0,0\n", "line 2, column 'ex'", "µm"),
            ("X,0,0,0,0,0,0,6.2\n", "line 2, column 'ec'", "µrad"),
            ("X,0,0,NaN,0,0,0,0\n", "line 2, column 'ey'", "finite"),
            ("W,0,0,0,0,0,0,0\n", "line 2, column 'axis'", "not an axis"),
        ];
        for (body, place, says) in cases {
            let e = read(&format!("{HEADER}{body}"))
                .map(|_| ())
                .unwrap_err()
                .to_string();
            assert!(e.contains(place) && e.contains(says), "{body}: {e}");
        }
        let e = read("axis,position,ex,ey,ez,ea,eb,ec,positioning_up\nX,0,0,0,0,0,0,0,0.001\nX,1,0,0,0,0,0,0,\n")
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3, column 'positioning_up'"), "{e}");
        let e = read("axis,position,ex,ey,ez,ea,eb\nX,0,0,0,0,0,0\n")
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert_mentions(&e, &["column 'ec'", "missing"]);
    }

    #[test]
    fn comp_file_follows_the_linuxcnc_rules() {
        let l = |n: f64| CompLine {
            nominal: n,
            forward: n + 0.001,
            reverse: n - 0.001,
        };
        let text = comp_file_text(&[l(0.0), l(10.0)]).unwrap_or_default();
        assert_eq!(
            text,
            "0.0000000 0.0010000 -0.0010000\n10.0000000 10.0010000 9.9990000\n"
        );
        assert_eq!(
            comp_file_text(&[l(1.0), l(1.0)]).map_err(|e| e.to_string()),
            Err("nominal positions must ascend: 1 follows 1".to_string())
        );
        assert_eq!(
            comp_file_text(&[]),
            Err(CompFileError::Entries { entries: 0 })
        );
        let many: Vec<CompLine> = (0..257).map(|k| l(k as f64)).collect();
        assert_eq!(
            comp_file_text(&many).map_err(|e| e.to_string()),
            Err("257 entries; a compensation file takes 1 to 256".to_string())
        );
        assert_eq!(
            comp_file_text(&[l(f64::NAN)]),
            Err(CompFileError::NotFinite { entry: 1 })
        );
    }
}
