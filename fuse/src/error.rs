//! The one error type of `fuse`.

use std::path::PathBuf;

use formats::InstantKey;
use thiserror::Error;

/// Why a measurement could not be made or started.
#[derive(Debug, Error)]
pub enum FuseError {
    /// A file could not be read or written, or breaks the contract.
    #[error(transparent)]
    Format(#[from] formats::FormatError),
    /// The inputs do not describe a campaign that can be measured; every problem found is listed.
    #[error("{} cannot be measured ({} problem{}): {}", manifest.display(), problems.len(), if problems.len() == 1 { "" } else { "s" }, joined(problems))]
    Campaign {
        /// The manifest.
        manifest: PathBuf,
        /// Every problem found, each naming its row or file.
        problems: Vec<CampaignProblem>,
    },
    /// A partial output belongs to a different run.
    #[error("{}: partial output of a run with other inputs or options; give --force to discard it and start afresh", .0.display())]
    ResumeMismatch(PathBuf),
    /// A map file named in a camera's `sensor` record cannot be read.
    #[error("{}: camera {camera}: the map {} named in it", rig.display(), file.display())]
    MapRead {
        /// `rig.json`.
        rig: PathBuf,
        /// Camera id.
        camera: u8,
        /// The map file.
        file: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A map file of a camera that does not fit its record or the camera.
    #[error("{}: camera {camera}: {}: {fault}", rig.display(), file.display())]
    SensorMap {
        /// `rig.json`.
        rig: PathBuf,
        /// Camera id.
        camera: u8,
        /// The map file.
        file: PathBuf,
        /// What is wrong with it.
        fault: sensor::SensorError,
    },
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
    /// A camera of `rig.json` whose `covariance` matrix is not square in its parameters.
    #[error("camera {camera} of the rig: its covariance matrix does not match its parameter names")]
    Covariance {
        /// Camera id.
        camera: u8,
    },
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

/// One reason a campaign cannot be measured, naming its manifest line or file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CampaignProblem {
    /// The sphere set cannot be told apart by size (formats' check).
    #[error("spheres: {0}")]
    Spheres(formats::SphereSetProblem),
    /// An empty manifest.
    #[error("the manifest has no rows")]
    NoRows,
    /// A row names a camera the rig does not have.
    #[error("line {line}: camera {camera} is not in the rig")]
    UnknownCamera {
        /// Manifest line.
        line: u64,
        /// Camera number.
        camera: u8,
    },
    /// A row's image file does not exist.
    #[error("line {line}: image {} not found", path.display())]
    ImageMissing {
        /// Manifest line.
        line: u64,
        /// The image.
        path: PathBuf,
    },
    /// One file given as the image of two frames.
    #[error(
        "line {line}: image {} is also the image of camera {camera} for {instant} (line {first_line}): one file cannot be two frames",
        path.display()
    )]
    OneFileTwoFrames {
        /// Manifest line.
        line: u64,
        /// The image.
        path: PathBuf,
        /// Camera of the first row that gave it.
        camera: u8,
        /// Instant of the first row that gave it.
        instant: InstantKey,
        /// Line of that row.
        first_line: u64,
    },
    /// A camera with two images of one instant.
    #[error("line {line}: camera {camera} already has an image for {instant} (line {first_line})")]
    CameraTwice {
        /// Manifest line.
        line: u64,
        /// Camera number.
        camera: u8,
        /// The instant.
        instant: InstantKey,
        /// Line of its first image.
        first_line: u64,
    },
    /// The cameras of an instant give different nominal positions.
    #[error(
        "line {line}: cameras disagree on the nominal position of {instant}: camera {camera} (line {other_line}) has {other_nominal:?}"
    )]
    NominalDisagrees {
        /// Manifest line of the instant's first image.
        line: u64,
        /// The instant.
        instant: InstantKey,
        /// The camera that disagrees.
        camera: u8,
        /// Its line.
        other_line: u64,
        /// The nominal position it gives (mm).
        other_nominal: [f64; 3],
    },
    /// An instant lacks the image of a camera its motion needs.
    #[error(
        "line {line}: {instant} has no image of camera {camera} (needed for {} motion)",
        instant.axis
    )]
    MissingCamera {
        /// Manifest line of the instant's first image.
        line: u64,
        /// The instant.
        instant: InstantKey,
        /// The missing camera.
        camera: u8,
    },
    /// Fewer than two cameras of the rig can see the instant's motion.
    #[error("{instant}: fewer than two cameras of the rig can measure {} motion", instant.axis)]
    TooFewCameras {
        /// The instant.
        instant: InstantKey,
    },
}

/// The problems of a campaign, `; `-separated.
fn joined(problems: &[CampaignProblem]) -> String {
    problems
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("; ")
}

/// Result alias for `fuse`.
pub type Result<T> = std::result::Result<T, FuseError>;
