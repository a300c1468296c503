//! The one error type of `evaluate`: every message names the source, and
//! where one row is at fault its line (the header is line 1) and column.

use std::path::PathBuf;

use thiserror::Error;

/// Why an evaluation could not be made or its outputs not written.
#[derive(Debug, Error)]
pub enum EvaluateError {
    /// The points file could not be read or breaks the file contract
    /// (parse errors, missing columns, NaN: file, line and column are named).
    #[error(transparent)]
    Format(#[from] formats::FormatError),
    /// A row is well formed but does not fit the campaign (one run at a
    /// target, mixed units, inconsistent nominal positions, duplicates).
    #[error("{source_name}: line {line}, column '{column}': {message}")]
    Row {
        /// The points file (or `points` for rows given in memory).
        source_name: String,
        /// 1-based line of the row in the file (the header is line 1).
        line: u64,
        /// Column at fault.
        column: String,
        /// What is wrong, with the offending value.
        message: String,
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
        /// What was being fitted (axis and line).
        what: String,
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
