//! The one error type of `report`.

use thiserror::Error;

/// A plot could not be drawn, or (feature `browser`) a page could not be checked.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReportError {
    /// A drawing error, with the plot's title.
    #[error("plot '{plot}': {message}")]
    Plot {
        /// Plot title.
        plot: String,
        /// The drawing error.
        message: String,
    },
    /// The browser could not be started or did not answer.
    #[error("browser: {0}")]
    Browser(String),
}

/// Result alias for `report`.
pub type Result<T> = std::result::Result<T, ReportError>;
