//! The one error type of `extract`. Messages name the file and what is wrong.

use std::path::PathBuf;

use thiserror::Error;

/// Why a frame could not be read or extracted.
#[derive(Debug, Error)]
pub enum ExtractError {
    /// The file could not be opened or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The image file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file is not a decodable image (corrupt, truncated, unknown format).
    #[error("{}: cannot decode image: {message}", path.display())]
    Decode {
        /// The image file.
        path: PathBuf,
        /// The decoder's complaint.
        message: String,
    },
    /// The image decodes but is not something the extractor accepts
    /// (colour, an unsupported or unexpected bit depth, zero size).
    #[error("{}: {message}", path.display())]
    Unsupported {
        /// The image file.
        path: PathBuf,
        /// What is not supported.
        message: String,
    },
    /// The extraction parameters do not fit the frame.
    #[error("invalid extraction parameters: {0}")]
    Parameters(String),
    /// Too many above-threshold runs: the threshold is far too low for this frame.
    #[error(
        "{runs} above-threshold runs (limit {limit}): threshold {threshold} is too low for this frame"
    )]
    TooManyRuns {
        /// Runs found before giving up.
        runs: usize,
        /// The configured limit.
        limit: usize,
        /// The threshold in use (DN).
        threshold: String,
    },
    /// A compute backend failed or is not available.
    #[error("backend {backend}: {message}")]
    Backend {
        /// Backend name.
        backend: String,
        /// What went wrong.
        message: String,
    },
}

impl ExtractError {
    /// Attach a file name to an error that has none (parameters, runs).
    pub fn in_file(self, path: &std::path::Path) -> ExtractError {
        match self {
            ExtractError::Parameters(m) => ExtractError::Unsupported {
                path: path.to_path_buf(),
                message: m,
            },
            ExtractError::TooManyRuns {
                runs,
                limit,
                threshold,
            } => ExtractError::Unsupported {
                path: path.to_path_buf(),
                message: format!(
                    "{runs} above-threshold runs (limit {limit}): threshold {threshold} is too low for this frame"
                ),
            },
            other => other,
        }
    }
}

/// Result alias for `extract`.
pub type Result<T> = std::result::Result<T, ExtractError>;
