//! The one error type of `ingest`: what stops a manifest from being built at
//! all. Frames that cannot be placed are not errors but problems (see
//! [`crate::Problem`]); every message names the file and what is wrong.

use std::path::PathBuf;

use thiserror::Error;

/// Why no manifest could be built.
#[derive(Debug, Error)]
pub enum IngestError {
    /// The motion program cannot be read or breaks its rules.
    #[error("{}: {message}", path.display())]
    Program {
        /// The program file.
        path: PathBuf,
        /// What is wrong (with the key or line at fault).
        message: String,
    },
    /// No camera was given.
    #[error("no camera given (--camera SERIAL=ID)")]
    NoCamera,
    /// A camera with an empty serial.
    #[error("camera {0}: empty serial")]
    EmptySerial(u8),
    /// A camera number outside 1..=3.
    #[error("camera {serial}={id}: camera numbers are 1, 2 or 3")]
    CameraId {
        /// The serial.
        serial: String,
        /// The number given.
        id: u8,
    },
    /// A camera number given to two serials.
    #[error("camera {id} is given twice ({first} and {second})")]
    CameraTwice {
        /// The camera number.
        id: u8,
        /// The first serial given it.
        first: String,
        /// The second.
        second: String,
    },
    /// A serial mapped twice.
    #[error("serial {0} is given twice")]
    SerialTwice(String),
    /// No folder of frames to search.
    #[error("no folder of frames given")]
    NoFolder,
    /// Operating-system error on a file or folder.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// An image's metadata could not be read.
    #[error("{}: {message}", path.display())]
    Metadata {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The program cannot be cut into bursts or dwells as captured
    /// (e.g. dwells closer together than a burst lasts).
    #[error("{0}")]
    Capture(String),
    /// A file of the contract could not be read or written.
    #[error(transparent)]
    Format(#[from] formats::FormatError),
}

impl IngestError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}

/// Result alias for `ingest`.
pub type Result<T> = std::result::Result<T, IngestError>;
