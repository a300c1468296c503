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
    /// The procedure's start time is not a date-time (a configuration that
    /// did not go through [`crate::Config::validate`]).
    #[error("configuration: {0}")]
    DateTime(#[from] crate::datetime::DateTimeError),
    /// A sphere's radius is not a positive number (mm).
    #[error("scene: sphere radius {0} mm is not positive")]
    SphereRadius(f64),
    /// A camera's projection centre lies inside a sphere (centre, world mm).
    #[error("scene: camera centre lies inside the sphere at {0:?}")]
    CameraInsideSphere([f64; 3]),
    /// A sphere's silhouette cone is not wholly in front of a camera (centre, world mm).
    #[error("scene: sphere at {0:?} is not in front of the camera")]
    BehindCamera([f64; 3]),
    /// A sphere's outline is not an ellipse in a camera.
    #[error("scene: outline is not an ellipse")]
    NotAnEllipse,
    /// Two spheres intersect (centres, world mm).
    #[error("scene: spheres at {0:?} and {1:?} intersect")]
    SpheresIntersect([f64; 3], [f64; 3]),
    /// More spheres overlap one silhouette than the coverage integrator supports.
    #[error("scene: {overlapping} spheres overlap one silhouette; at most {max} are supported")]
    TooManyOverlaps {
        /// Spheres over the silhouette (itself included).
        overlapping: usize,
        /// The most supported.
        max: usize,
    },
    /// A blur σ that is not finite (px).
    #[error("scene: blur σ {0} px is not finite")]
    BlurSigma(f64),
    /// The sensor and the camera model differ in size.
    #[error("scene: sensor is {}×{} px but the camera model is {}×{} px", sensor.0, sensor.1, camera.0, camera.1)]
    SensorSize {
        /// Sensor width and height (px).
        sensor: (u32, u32),
        /// Camera model width and height (px).
        camera: (u32, u32),
    },
    /// The lens distortion's Jacobian is singular at an observed pixel (u, v).
    #[error("scene: lens distortion is singular at pixel ({0}, {1})")]
    DistortionSingular(f64, f64),
    /// The lens distortion folds the image at an observed pixel (u, v).
    #[error("scene: lens distortion folds the image at pixel ({0}, {1})")]
    DistortionFolds(f64, f64),
    /// A geometric computation failed on degenerate input.
    #[error("{what}: {source}")]
    Geometry {
        /// What was being computed.
        what: String,
        /// The underlying error.
        source: geom::GeomError,
    },
    /// An earlier run into the output folder stopped before its last file:
    /// the folder holds part of a rendering.
    #[error(
        "{} holds an incomplete rendering ({} is missing: an earlier run was interrupted or \
         failed); render it again with --force, which replaces what is there",
        folder.display(),
        last.display()
    )]
    Incomplete {
        /// The output folder.
        folder: PathBuf,
        /// The file a complete rendering writes last.
        last: PathBuf,
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
    Evaluate(#[source] evaluate::EvaluateError),
    /// The reference figures could not be turned into JSON.
    #[error("reference figures: {0}")]
    FiguresJson(#[source] serde_json::Error),
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
