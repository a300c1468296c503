//! Extraction of luminous blobs from grayscale frames: decode (8/16-bit TIFF
//! and PNG, with EXIF metadata), optional denoising, background and threshold
//! (fixed or automatic, global or local), run-length connected components,
//! and the thresholded gray centroid with exact integer moments.
//!
//! # Conventions
//! - Pixel coordinates: the centre of the top-left pixel is (0, 0), u to the
//!   right, v down. A blob covering pixels 0..=9 in u has its centre at 4.5.
//! - Values in native DN: 8-bit frames keep 0..=255 (stored as `u16`);
//!   thresholds are in the frame's own DN. A pixel is above the threshold when f ≥ T.
//! - Centroid (docs/methods.md): `u0 = Σu·F/ΣF`, `v0 = Σv·F/ΣF` with `F = f − T`
//!   (default) or `F = f` over each 8-connected blob of pixels with f ≥ T.
//! - Results are exact integer sums: the same on any number of threads.
//! - Corrected centroids ([`mapped_centroid`], [`observed_centroids`]) re-weight a blob's pixels with the
//!   camera's model: undistortion and the flat-field correction by the
//!   lens's relative illumination, over the local background; [`mapped_light`]
//!   adds the second moments of that light (its ellipse in the ideal image).

mod error;

mod backend;
mod background;
mod batch;
mod blob;
mod correction;
mod decode;
mod denoise;
mod frame;
pub mod gpu;
mod label;
mod metadata;
mod noise;
mod ring;
mod strips;
mod threshold;
mod tiff_tags;

pub use backend::{Backend, CpuBackend, DEFAULT_MIN_AREA, ExtractParams, Extraction};
pub use background::MIN_MESH_PX;
pub use batch::{FrameBlobs, Radiometry, extract_file, extract_files, extract_files_flat};
pub use blob::{Blob, BoundingBox, MomentEllipse, Moments};
pub use correction::{
    CameraMap, FlatFieldMap, LANES, LATTICE_TOLERANCE_PX, Lattice, Mapped, MappedLanes,
    MappedLight, NODE_SPACINGS_PX, PixelMap, mapped_centroid, mapped_light, observed_centroids,
};
pub use decode::FrameReader;
pub use denoise::{Denoise, apply as denoise};
pub use error::{ExtractError, ParameterProblem, Result};
pub use frame::{Frame, FrameView};
#[cfg(feature = "gpu")]
pub use gpu::GpuBackend;
pub use label::Weighting;
pub use metadata::FrameMetadata;
pub use noise::{CentroidCovariance, Covariance, CovarianceForm};
pub use threshold::{DEFAULT_K, Level, Threshold};
pub use tiff_tags::tiff_fields;
