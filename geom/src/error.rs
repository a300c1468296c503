//! The one error type of `geom`: degenerate input, never I/O.

use thiserror::Error;

/// What went wrong in a geometric computation. Every variant is caused by
/// degenerate or insufficient input; `geom` has no other way to fail.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GeomError {
    /// Fewer points (or observations) than the model needs.
    #[error("{what} needs at least {needed} points, got {got}")]
    TooFewPoints {
        /// The computation that was asked for.
        what: &'static str,
        /// Minimum number of points.
        needed: usize,
        /// Number of points given.
        got: usize,
    },
    /// The input does not determine the result (collinear, coplanar, zero-length, singular).
    #[error("degenerate input: {0}")]
    Degenerate(String),
    /// A value was NaN or infinite.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// A point lies on or behind the camera's image plane.
    #[error("point at depth {depth} mm is not in front of the camera")]
    BehindCamera {
        /// Depth of the point in the camera frame (mm).
        depth: f64,
    },
    /// An iteration did not reach its tolerance.
    #[error("{what} did not converge after {iterations} iterations (last step {last_step:e})")]
    NotConverged {
        /// The iteration that failed.
        what: &'static str,
        /// Iterations performed.
        iterations: usize,
        /// Size of the last correction, in the iteration's own unit.
        last_step: f64,
    },
    /// A value so large that the sums of squares a fit needs would overflow.
    #[error(
        "{what}: coordinate {value:e} is beyond ±{limit:e}, where the sums of squares a fit \
         needs overflow"
    )]
    OutOfRange {
        /// The computation that was asked for.
        what: &'static str,
        /// The value.
        value: f64,
        /// The largest magnitude accepted.
        limit: f64,
    },
}

/// Result alias for `geom`.
pub type Result<T> = std::result::Result<T, GeomError>;
