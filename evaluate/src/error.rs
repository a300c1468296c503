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
    /// Input to one of the pure evaluation functions is unusable.
    #[error("{what}: {message}")]
    Data {
        /// The evaluation that was asked for.
        what: &'static str,
        /// What is wrong.
        message: String,
    },
    /// An option names something the data does not have.
    #[error("option {option}: {message}")]
    Option {
        /// The option.
        option: &'static str,
        /// What is wrong.
        message: String,
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

/// Result alias for `evaluate`.
pub type Result<T> = std::result::Result<T, EvaluateError>;
