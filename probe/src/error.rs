//! The one error type of `probe`.

use thiserror::Error;

/// What went wrong in a probe method. Input rows are named by their position
/// in the input (`row`, 1-based among the data rows, as the caller passed
/// them); the binary maps them to file lines.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ProbeError {
    /// An input value or row is invalid (NaN, out of range, duplicate, wrong unit).
    #[error("{what}: {message}")]
    Input {
        /// The row, column or option at fault, e.g. "row 12, column 'x'".
        what: String,
        /// What is wrong.
        message: String,
    },
    /// The data do not determine the result (too few points, stations, balls; a degenerate layout).
    #[error("{0}")]
    Unsolvable(String),
    /// A layout leaves an unknown unobservable: the condition number of the problem.
    #[error("{what}: condition number {condition:.3e} exceeds {limit:.1e}")]
    IllConditioned {
        /// The layout or matrix at fault.
        what: String,
        /// Its condition number.
        condition: f64,
        /// The largest accepted.
        limit: f64,
    },
    /// The nominal grid is not a lattice, which trilinear interpolation needs.
    #[error("the grid is not a lattice: {message}")]
    NotLattice {
        /// The point at fault (its position among the points), when one is.
        point: Option<usize>,
        /// Its coordinate at fault (0, 1, 2 = x, y, z), when one is.
        axis: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// An iteration did not converge.
    #[error("{what} did not converge after {iterations} iterations")]
    NotConverged {
        /// The iteration.
        what: &'static str,
        /// Iterations performed.
        iterations: usize,
    },
    /// A geometric computation failed on degenerate input.
    #[error(transparent)]
    Geom(#[from] geom::GeomError),
    /// A plot of the report could not be drawn.
    #[error(transparent)]
    Report(#[from] report::ReportError),
}

/// Result alias for `probe`.
pub type Result<T> = std::result::Result<T, ProbeError>;
