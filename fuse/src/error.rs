//! The one error type of `fuse`.

use std::path::PathBuf;

use thiserror::Error;

/// Why a measurement could not be made or started.
#[derive(Debug, Error)]
pub enum FuseError {
    /// A file could not be read or written, or breaks the contract.
    #[error(transparent)]
    Format(#[from] formats::FormatError),
    /// The inputs do not describe a campaign that can be measured; every problem found is listed.
    #[error("{} cannot be measured ({} problem{}): {}", manifest.display(), problems.len(), if problems.len() == 1 { "" } else { "s" }, problems.join("; "))]
    Campaign {
        /// The manifest.
        manifest: PathBuf,
        /// Every problem found, each naming its row or file.
        problems: Vec<String>,
    },
    /// A partial output belongs to a different run.
    #[error("{}: partial output of a run with other inputs or options; give --force to discard it and start afresh", .0.display())]
    ResumeMismatch(PathBuf),
    /// A rig camera is unusable.
    #[error("rig camera {camera}: {message}")]
    Rig {
        /// Camera id.
        camera: u8,
        /// What is wrong.
        message: String,
    },
    /// A geometric computation failed (degenerate input).
    #[error("{what}: {source}")]
    Geometry {
        /// What was being computed.
        what: String,
        /// The cause.
        source: geom::GeomError,
    },
    /// Extraction failed.
    #[error(transparent)]
    Extract(#[from] extract::ExtractError),
    /// An instant could not be measured (goes to problems.csv in a batch).
    #[error("{0}")]
    Instant(String),
}

impl FuseError {
    /// A geometry error with its context.
    pub fn geometry(what: impl Into<String>, source: geom::GeomError) -> Self {
        Self::Geometry {
            what: what.into(),
            source,
        }
    }
}

/// Result alias for `fuse`.
pub type Result<T> = std::result::Result<T, FuseError>;
