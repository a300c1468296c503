//! The one error type of `synth`: every message names the offending file,
//! configuration key or value.

use std::path::PathBuf;

use thiserror::Error;

/// What went wrong while configuring, rendering or writing synthetic data.
#[derive(Debug, Error)]
pub enum SynthError {
    /// The configuration file could not be parsed or has an invalid value.
    #[error("{}: {message}", source_name(path.as_ref()))]
    Config {
        /// The configuration file, when the configuration came from one.
        path: Option<PathBuf>,
        /// The key at fault and what is wrong with it.
        message: String,
    },
    /// The scene cannot be rendered as asked (spheres intersect, a sphere
    /// leaves the frame, a camera is inside a sphere, ...).
    #[error("scene: {0}")]
    Scene(String),
    /// A geometric computation failed on degenerate input.
    #[error("{what}: {source}")]
    Geometry {
        /// What was being computed.
        what: String,
        /// The underlying error.
        source: geom::GeomError,
    },
    /// A file of the contract could not be written.
    #[error(transparent)]
    Format(#[from] formats::FormatError),
    /// Operating-system error on a file or directory.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// An image could not be encoded.
    #[error("{}: encoding failed: {message}", path.display())]
    Encode {
        /// The image file (or `<memory>`).
        path: PathBuf,
        /// What the encoder reported.
        message: String,
    },
    /// The reference figures could not be computed from the true positions.
    #[error("reference figures: {0}")]
    Evaluate(String),
}

fn source_name(path: Option<&PathBuf>) -> String {
    path.map_or_else(|| "configuration".to_string(), |p| p.display().to_string())
}

impl SynthError {
    /// A configuration error without a file.
    pub fn config(message: impl Into<String>) -> Self {
        Self::Config {
            path: None,
            message: message.into(),
        }
    }

    /// A geometric error, with what was being computed.
    pub fn geometry(what: impl Into<String>, source: geom::GeomError) -> Self {
        Self::Geometry {
            what: what.into(),
            source,
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}

/// Result alias for `synth`.
pub type Result<T> = std::result::Result<T, SynthError>;
