//! The one error type of `evaluate`: every message names the source, and
//! where one row is at fault its line (the header is line 1) and column.

use std::path::PathBuf;

use std::fmt;

use formats::{Axis, Direction, PointRow, Record};
use thiserror::Error;

use crate::points::{MAX_COORDINATE_MM, UNIT_FACTOR, measured_column};

/// Why an evaluation could not be made or its outputs not written.
#[derive(Debug, Error)]
pub enum EvaluateError {
    /// The points file could not be read or breaks the file contract
    /// (parse errors, missing columns, NaN: file, line and column are named).
    #[error(transparent)]
    Format(#[from] formats::FormatError),
    /// A row is well formed but does not fit the campaign (mixed units,
    /// inconsistent nominal positions, duplicates).
    #[error("{source_name}: line {line}, column '{column}': {problem}")]
    Row {
        /// The points file (or `points` for rows given in memory).
        source_name: String,
        /// 1-based line of the row in the file (the header is line 1).
        line: u64,
        /// Column at fault.
        column: &'static str,
        /// What is wrong, with the offending value (boxed: the largest reason
        /// would make every `Result` of the crate large).
        problem: Box<RowProblem>,
    },
    /// The points hold no sphere.
    #[error("evaluate: no spheres in the points")]
    NoSpheres,
    /// The deviations given to ISO 230-2 are unusable.
    #[error("ISO 230-2: {0}")]
    Iso230_2(Iso230_2Problem),
    /// `--sphere` names a sphere the points do not have.
    #[error("option sphere: sphere '{name}' is not in the points (spheres: {})", spheres.join(", "))]
    UnknownSphere {
        /// The sphere asked for.
        name: String,
        /// The spheres the points have.
        spheres: Vec<String>,
    },
    /// A fit failed on degenerate data.
    #[error("{what}: {source}")]
    Geom {
        /// What was being fitted.
        what: Fitted,
        /// The geometric failure.
        source: geom::GeomError,
    },
    /// A plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] ::report::ReportError),
    /// Operating-system error on an output path.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
}

/// A measured line, as messages name it: `axis X at y = 0, z = 0 mm`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineName {
    /// The axis moved.
    pub axis: Axis,
    /// The two off-axis world coordinates of the line (mm), sorted by axis.
    pub off_axis: [(Axis, f64); 2],
}

impl fmt::Display for LineName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [(a, u), (b, v)] = self.off_axis;
        write!(
            f,
            "axis {} at {} = {u}, {} = {v} mm",
            self.axis,
            measured_column(a),
            measured_column(b)
        )
    }
}

/// What a failed fit was fitting.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum Fitted {
    /// The flatness plane of all X and Y lines.
    #[error("flatness")]
    Flatness,
    /// The direction of a line's axis.
    #[error("axis direction of {0}")]
    AxisDirection(LineName),
    /// The straightness of a line in a world direction.
    #[error("straightness in {world} of {line}")]
    Straightness {
        /// The world direction of the deviations.
        world: Axis,
        /// The line.
        line: LineName,
    },
    /// The positioning figures of a line.
    #[error("{0}")]
    Positioning(LineName),
}

/// Why a row of the points does not fit the file or the campaign.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RowProblem {
    /// The file holds nothing, not even a header.
    #[error("the file is empty: expected the header {}", PointRow::COLUMNS.join(","))]
    EmptyFile,
    /// The file holds a header only.
    #[error("no data rows: the file has a header only")]
    HeaderOnly,
    /// A value breaks the file contract (`formats::Invalid`'s complaint, kept
    /// as the file contract words it).
    #[error("{0}")]
    Contract(String),
    /// A coordinate beyond any machine's travel, yet a length in µm.
    #[error(
        "{column} = {value} mm lies more than {MAX_COORDINATE_MM} mm from the origin, beyond the \
         travel of any machine the rig measures: is the file in µm? (points.csv is in millimetres)"
    )]
    BeyondTravel {
        /// The coordinate's column.
        column: &'static str,
        /// Its value (mm).
        value: f64,
    },
    /// A coordinate that is no length in any unit.
    #[error(
        "{column} = {value:e} is not a length in millimetres (more than {:e} mm from the origin)",
        MAX_COORDINATE_MM * UNIT_FACTOR
    )]
    NotALength {
        /// The coordinate's column.
        column: &'static str,
        /// Its value.
        value: f64,
    },
    /// The same sphere at the same instant twice.
    #[error(
        "sphere {sphere} at axis {axis} {direction} run {run} target {target} capture {capture} \
         appears twice (first on line {first_line})"
    )]
    Duplicate {
        /// The sphere.
        sphere: String,
        /// Axis moved.
        axis: Axis,
        /// Approach direction.
        direction: Direction,
        /// Run.
        run: u32,
        /// Target.
        target: u32,
        /// Capture.
        capture: u32,
        /// Line of the first row of that instant and sphere.
        first_line: u64,
    },
    /// A measured coordinate about 1000 times (or 1/1000 of) what its row leads to expect.
    #[error(
        "{column} = {value} is about {ratio} times the {expected:.3} mm its commanded position \
         leads to expect: mixed units? (points.csv is in millimetres; rows of this sphere and \
         axis agree to within {tolerance:.3} mm)"
    )]
    MeasuredScaled {
        /// The measured column.
        column: &'static str,
        /// Its value.
        value: f64,
        /// `1000` or `1/1000`.
        ratio: &'static str,
        /// The value expected from the commanded position and the other rows (mm).
        expected: f64,
        /// How closely the other rows agree (mm).
        tolerance: f64,
    },
    /// A commanded coordinate about 1000 times (or 1/1000 of) what the measured one leads to expect.
    #[error(
        "{column} = {value} is about {ratio} times the {expected:.3} mm the measured position \
         leads to expect: mixed units? (points.csv is in millimetres)"
    )]
    NominalScaled {
        /// The nominal column.
        column: &'static str,
        /// Its value.
        value: f64,
        /// `1000` or `1/1000`.
        ratio: &'static str,
        /// The value expected from the measured position (mm).
        expected: f64,
    },
    /// A measured coordinate far from what the other rows lead to expect.
    #[error(
        "{column} = {value} lies {off:.3} mm from the {expected:.3} mm expected from its commanded \
         position and the other rows of sphere {sphere} on axis {axis} (tolerance {tolerance:.3} \
         mm): mixed units or a wrong row?"
    )]
    FarFromExpected {
        /// The measured column.
        column: &'static str,
        /// Its value.
        value: f64,
        /// Distance from the expected value (mm).
        off: f64,
        /// The expected value (mm).
        expected: f64,
        /// The sphere.
        sphere: String,
        /// The axis moved.
        axis: Axis,
        /// How closely the other rows agree (mm).
        tolerance: f64,
    },
    /// A line without rows of the sphere that carries positioning and straightness.
    #[error("{line} has no rows of sphere {sphere}, which carries positioning and straightness")]
    NoMainSphere {
        /// The line.
        line: LineName,
        /// The sphere.
        sphere: String,
    },
    /// A line of one target.
    #[error("{0} has a single target: an axis needs at least two")]
    SingleTarget(LineName),
    /// A target commanded at two positions.
    #[error(
        "target {target} of {line} is commanded at {here} mm here but at {first} mm on line {first_line}"
    )]
    TargetMoved {
        /// The target.
        target: u32,
        /// The line.
        line: LineName,
        /// Its commanded coordinate on this row (mm).
        here: f64,
        /// Its commanded coordinate on its first row (mm).
        first: f64,
        /// Line of its first row.
        first_line: u64,
    },
}

/// Why deviations cannot be evaluated by ISO 230-2.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Iso230_2Problem {
    /// No targets at all.
    #[error("no targets")]
    NoTargets,
    /// The first target has no approach in either direction.
    #[error("target 0 has no approaches")]
    NoApproaches,
    /// A target's directions differ from the first target's.
    #[error("target {target} has approaches in {has} but target 0 in {first}")]
    MixedDirections {
        /// Target index.
        target: usize,
        /// Its directions ("↑ and ↓", "↑ only", …).
        has: &'static str,
        /// The first target's directions.
        first: &'static str,
    },
    /// Too few approaches in one direction at a target.
    #[error(
        "target {target}: {runs} {direction} approach(es); at least {needed} runs per direction \
         are needed"
    )]
    TooFewRuns {
        /// Target index.
        target: usize,
        /// "↑" or "↓".
        direction: &'static str,
        /// Approaches given.
        runs: usize,
        /// Approaches needed.
        needed: usize,
    },
    /// A deviation is NaN or infinite.
    #[error("target {target}: deviation {value} is not a finite number")]
    NonFinite {
        /// Target index.
        target: usize,
        /// The value.
        value: f64,
    },
}

/// Result alias for `evaluate`.
pub type Result<T> = std::result::Result<T, EvaluateError>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_and_a_failed_fit_are_named_as_messages_always_named_them() {
        let line = LineName {
            axis: Axis::X,
            off_axis: [(Axis::Y, 0.0), (Axis::Z, 12.5)],
        };
        assert_eq!(line.to_string(), "axis X at y = 0, z = 12.5 mm");
        let fitted = Fitted::Straightness {
            world: Axis::Z,
            line,
        };
        assert_eq!(
            fitted.to_string(),
            "straightness in Z of axis X at y = 0, z = 12.5 mm"
        );
        assert_eq!(
            Fitted::AxisDirection(line).to_string(),
            "axis direction of axis X at y = 0, z = 12.5 mm"
        );
    }
}
