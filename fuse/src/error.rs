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
    /// A rig camera's model is unusable.
    #[error("rig camera {camera}: {source}")]
    RigCamera {
        /// Camera id.
        camera: u8,
        /// What is wrong, as the rig file's reader says it.
        source: formats::RigError,
    },
    /// A camera number appears twice in the rig.
    #[error("rig camera {camera}: appears twice in the rig")]
    DuplicateCamera {
        /// Camera id.
        camera: u8,
    },
    /// The rig has fewer than two cameras.
    #[error("rig camera {camera}: a measurement needs at least two cameras")]
    TooFewCameras {
        /// The one camera's id (0 when there is none).
        camera: u8,
    },
    /// The cameras' optical axes are all parallel: no working point.
    #[error("rig camera 0: the optical axes are all parallel: no working point")]
    ParallelOpticalAxes,
    /// A geometric computation failed (degenerate input).
    #[error("{what}: {source}")]
    Geometry {
        /// What was being computed.
        what: &'static str,
        /// The cause.
        source: geom::GeomError,
    },
    /// Extraction failed.
    #[error(transparent)]
    Extract(#[from] extract::ExtractError),
    /// A sphere was seen by fewer than two cameras.
    #[error("a sphere needs two views, has {views}")]
    TooFewViews {
        /// Views given.
        views: usize,
    },
    /// The views' rays are parallel: linear triangulation puts the sphere at infinity.
    #[error("views are parallel: the sphere is at infinity")]
    ParallelViews,
    /// The pixel-scale fusion was given different camera sets at its two
    /// instants, or fewer than two cameras.
    #[error(
        "pixel-scale fusion needs the same two or more cameras at both instants \
         (reference {reference}, current {current}, depths {depths})"
    )]
    SeedCameras {
        /// Views at the reference instant.
        reference: usize,
        /// Views at the current instant.
        current: usize,
        /// Reference depths given.
        depths: usize,
    },
    /// The pixel-scale fusion's least-squares solve failed.
    #[error("pixel-scale fusion: {0}")]
    SeedSolve(&'static str),
}

impl FuseError {
    /// A geometry error with its context.
    pub fn geometry(what: &'static str, source: geom::GeomError) -> Self {
        Self::Geometry { what, source }
    }
}

/// Result alias for `fuse`.
pub type Result<T> = std::result::Result<T, FuseError>;
