//! The one error type of `formats`: every message names the file, and where
//! it applies the row (1-based line number in the file) and the column.

use std::path::PathBuf;

use geom::GeomError;
use thiserror::Error;

use crate::limits::MAX_IMAGE_SIDE_PX;
use crate::rig::P_TOLERANCE_PX;

/// A file could not be read or written, or its content breaks the contract.
#[derive(Debug, Error)]
pub enum FormatError {
    /// Operating-system error on a file.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A CSV row or field is malformed or invalid.
    #[error("{}: line {line}{}: {message}", path.display(), column.as_ref().map(|c| format!(", column '{c}'")).unwrap_or_default())]
    Row {
        /// The file.
        path: PathBuf,
        /// 1-based line number in the file (the header is line 1).
        line: u64,
        /// Column name, when one column is at fault.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// An output exists and the command was not told to replace it.
    #[error("{}: already exists; give --force to replace it or choose another --out", path.display())]
    Exists {
        /// The output.
        path: PathBuf,
    },
    /// An output would be written over one of the command's inputs (the same
    /// file, also through a link, or a folder holding it).
    #[error("{}: would overwrite an input of this run{}; choose another --out", output.display(), if input == output { String::new() } else { format!(" ({})", input.display()) })]
    OverwritesInput {
        /// The output.
        output: PathBuf,
        /// The input, as given.
        input: PathBuf,
    },
    /// Another run holds the lock of an output folder.
    #[error("{}: another trinocular run ({holder}) is writing into this folder; wait for it to finish or choose another --out", folder.display())]
    Locked {
        /// The output folder.
        folder: PathBuf,
        /// Who holds the lock, as its lock file says (`pid N, COMMAND`).
        holder: String,
    },
    /// A camera description (`nominal.json`, `rig.json`) breaks the contract.
    #[error("{}: {source}", path.display())]
    Rig {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: RigError,
    },
    /// The file as a whole is malformed (empty, missing columns, bad JSON).
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl FormatError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// A whole-file error on `path`.
    pub fn file(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::File {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// A camera description that breaks the contract (docs/formats.md,
/// `nominal.json` and `rig.json`); [`FormatError::Rig`] adds the file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RigError {
    /// A camera id outside 1, 2, 3.
    #[error("camera id {0} is not 1, 2 or 3")]
    CameraId(u8),
    /// A camera id given twice.
    #[error("camera {0} appears twice")]
    Duplicate(u8),
    /// A rig without cameras.
    #[error("no cameras")]
    NoCameras,
    /// A sensor size outside 1..=[`MAX_IMAGE_SIDE_PX`] a side.
    #[error("camera {id}: image size {width}×{height} px is not 1..={MAX_IMAGE_SIDE_PX} px a side")]
    SensorSize {
        /// Camera id.
        id: u8,
        /// Width (px).
        width: u32,
        /// Height (px).
        height: u32,
    },
    /// A nominal focal length or pixel pitch that is not positive.
    #[error("camera {id}: focal_mm and pixel_mm must be positive (got {focal_mm} and {pixel_mm})")]
    Optics {
        /// Camera id.
        id: u8,
        /// Focal length (mm).
        focal_mm: f64,
        /// Pixel pitch (mm).
        pixel_mm: f64,
    },
    /// A nominal lens key (`f_number`, `coc_px`, …) that is not a positive finite number.
    #[error("camera {id}: {key} {value} must be a positive number")]
    OpticsKey {
        /// Camera id.
        id: u8,
        /// The key.
        key: &'static str,
        /// The value read.
        value: f64,
    },
    /// A nominal position, look-at point or up direction with a non-finite value.
    #[error("camera {id}: position, look_at and up must be finite numbers")]
    NonFinitePlacement {
        /// Camera id.
        id: u8,
    },
    /// A nominal placement that defines no orientation (look-at point at the
    /// position, up along the optical axis).
    #[error("camera {id}: {source}")]
    Placement {
        /// Camera id.
        id: u8,
        /// The geometric failure.
        source: GeomError,
    },
    /// A non-finite R or t.
    #[error("camera {id}: non-finite R or t")]
    NonFiniteExtrinsics {
        /// Camera id.
        id: u8,
    },
    /// A malformed intrinsic matrix K.
    #[error("camera {id}: K: {source}")]
    Intrinsics {
        /// Camera id.
        id: u8,
        /// What is wrong with K.
        source: GeomError,
    },
    /// R is not a proper rotation (‖RᵀR − I‖ too large or det R ≤ 0).
    #[error("camera {id}: R is not a rotation matrix")]
    NotRotation {
        /// Camera id.
        id: u8,
    },
    /// A non-finite distortion coefficient.
    #[error("camera {id}: non-finite distortion")]
    NonFiniteDistortion {
        /// Camera id.
        id: u8,
    },
    /// A negative or non-finite RMS reprojection error.
    #[error("camera {id}: rms_px {rms_px} is not a finite number ≥ 0")]
    RmsPx {
        /// Camera id.
        id: u8,
        /// The value read.
        rms_px: f64,
    },
    /// A radial illumination model's scale that is not positive.
    #[error("relative_illumination: scale_px {0} must be positive")]
    IlluminationScale(f64),
    /// A radial illumination model with no coefficient or a non-finite value.
    #[error(
        "relative_illumination: centre_px and coefficients must be finite numbers, at least one coefficient"
    )]
    IlluminationValues,
    /// A radial illumination model that is not positive over the image.
    #[error("relative_illumination: RI = {ri} at pixel ({u}, {v}) is not positive")]
    IlluminationNotPositive {
        /// The relative illumination there.
        ri: f64,
        /// Column (px).
        u: f64,
        /// Row (px).
        v: f64,
    },
    /// `P` holds a non-finite value.
    #[error("P holds a value that is not a finite number")]
    ProjectionNonFinite,
    /// `P`'s left 3×3 block is singular.
    #[error("P is singular (its left 3×3 block has no inverse): not a projection")]
    ProjectionSingular,
    /// `P` puts a point elsewhere than K, R, t do.
    #[error(
        "P contradicts K, R and t: a point K, R, t image at pixel ({u}, {v}) at {depth_mm:.1} mm depth projects through P to ({pu:.3}, {pv:.3}){} (tolerance {P_TOLERANCE_PX} px)",
        if *behind { " behind the camera" } else { "" }
    )]
    ProjectionContradicts {
        /// Column where K, R, t image the point (px).
        u: f64,
        /// Row where K, R, t image the point (px).
        v: f64,
        /// Depth of the point (mm).
        depth_mm: f64,
        /// Column where P images it (px).
        pu: f64,
        /// Row where P images it (px).
        pv: f64,
        /// P puts the point behind the camera.
        behind: bool,
    },
    /// A problem of one camera's illumination model or projection, with the camera.
    #[error("camera {id}: {source}")]
    Camera {
        /// Camera id.
        id: u8,
        /// What is wrong.
        source: Box<RigError>,
    },
}

/// Result alias for `formats`.
pub type Result<T> = std::result::Result<T, FormatError>;
