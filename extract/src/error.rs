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
    Parameters(#[from] ParameterProblem),
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
            ExtractError::Parameters(problem) => ExtractError::Unsupported {
                path: path.to_path_buf(),
                message: problem.to_string(),
            },
            runs @ ExtractError::TooManyRuns { .. } => ExtractError::Unsupported {
                path: path.to_path_buf(),
                message: runs.to_string(),
            },
            other => other,
        }
    }
}

/// What is wrong with extraction parameters or with a frame's buffer.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ParameterProblem {
    /// A fixed threshold of 0 DN.
    #[error("threshold 0 DN would keep every pixel: it must be at least 1")]
    ZeroThreshold,
    /// A fixed threshold above the frame's largest value.
    #[error("threshold {threshold} is outside 1..={max} for a {bit_depth}-bit frame")]
    ThresholdRange {
        /// The threshold (DN).
        threshold: u16,
        /// The frame's largest value (DN).
        max: u16,
        /// The frame's bit depth.
        bit_depth: u8,
    },
    /// The factor k of an automatic threshold is not finite and positive.
    #[error("threshold factor k = {0} must be positive")]
    ThresholdFactor(f64),
    /// The background mesh of a local threshold is out of range.
    #[error("background mesh {mesh} px is not {min}..={max} px")]
    Mesh {
        /// The mesh (px).
        mesh: u32,
        /// Smallest mesh (px).
        min: u32,
        /// Largest mesh (px).
        max: u32,
    },
    /// `max_pixels` is 0.
    #[error("max_pixels must be at least 1")]
    ZeroMaxPixels,
    /// The blob area range is empty.
    #[error("min_area {min_area} exceeds max_area {max_area}")]
    AreaRange {
        /// Smallest blob area (px).
        min_area: u64,
        /// Largest blob area (px).
        max_area: u64,
    },
    /// The Gaussian denoising sigma is not finite and positive.
    #[error("denoising: the Gaussian σ {0} px must be finite and positive")]
    GaussianSigma(f32),
    /// The frame is larger than the limits allow.
    #[error("{0}")]
    Size(formats::limits::SizeError),
    /// A frame of zero width or height.
    #[error("frame has zero size")]
    ZeroSize,
    /// The pixel buffer does not hold width × height pixels.
    #[error("{width}×{height} frame needs {} pixels, got {got}", *width as usize * *height as usize)]
    PixelCount {
        /// Frame width (px).
        width: u32,
        /// Frame height (px).
        height: u32,
        /// Pixels in the buffer.
        got: usize,
    },
    /// A bit depth other than 8 or 16.
    #[error("bit depth {0} is not 8 or 16")]
    BitDepth(u8),
    /// The sensor's per-pixel maps do not fit the frame.
    #[error("per-pixel sensor correction: {0}")]
    Sensor(sensor::SensorError),
}

/// Result alias for `extract`.
pub type Result<T> = std::result::Result<T, ExtractError>;
