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
    /// The program's dwells follow each other closer than a burst lasts:
    /// triggered bursts cannot be told apart by time.
    #[error(
        "the program's dwells follow each other {between_s:.4} s after the last capture \
         while a burst of {captures} frames at {fps} fps spans {span_s:.4} s: bursts cannot be \
         told apart by time"
    )]
    BurstsOverlap {
        /// Shortest programmed stop from one dwell's last capture to the next one's first (s).
        between_s: f64,
        /// Frames a burst.
        captures: u32,
        /// Frame rate (1/s).
        fps: f64,
        /// Time from a burst's first frame to its last (s).
        span_s: f64,
    },
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

/// Why a camera's time stamp is not a time.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum TimeError {
    /// Not an ISO 8601 civil date-time (or not a day of the calendar).
    #[error("time '{text}' is not a date-time: {reason}")]
    Syntax {
        /// The stamp as written.
        text: String,
        /// The parser's complaint.
        reason: String,
    },
    /// A date-time with no UTC time stamp (the converter's complaint).
    #[error("time '{text}': {reason}")]
    Timestamp {
        /// The stamp as written.
        text: String,
        /// The converter's complaint.
        reason: String,
    },
    /// A date-time outside the range of a UTC time stamp in nanoseconds.
    #[error("time '{0}' is out of range")]
    Range(String),
}

/// Result alias for `ingest`.
pub type Result<T> = std::result::Result<T, IngestError>;
