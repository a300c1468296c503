//! The crate's error.

use thiserror::Error;

/// Result with [`SensorError`].
pub type Result<T> = std::result::Result<T, SensorError>;

/// Why a stack or a map cannot be used. `frame` is the index of the frame
/// in its stack (0-based); the caller names the file.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SensorError {
    /// Placeholder until the implementation lands.
    #[error("{0}")]
    Other(String),
}
