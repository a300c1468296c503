//! What one camera sees of the spheres in one frame: blobs → candidate sphere
//! images with their centres in ideal (undistorted) pixels.
//!
//! Lens distortion and the lens's relative illumination are handled inside the
//! centroid, not after it: each pixel is flat-field corrected (its background
//! removed, divided by RI) and weighted by `F′·J` at its undistorted position,
//! J the area Jacobian of the undistortion (`extract::correction`), so that the
//! centroid is that of the radiance in the ideal image, where a uniformly
//! luminous sphere is a uniform ellipse — whatever the lens.

use extract::{Blob, CameraMap, Extraction, FrameView, Weighting, mapped_centroid};
use geom::{Camera, Illumination, Point2};

/// Circularity (minor/major moment axis) below which a blob is not a sphere image.
pub const MIN_CIRCULARITY: f64 = 0.7;

/// A blob that may be the image of a sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Centroid in ideal (undistorted) pixels.
    pub ideal_px: Point2<f64>,
    /// Apparent diameter (px): the minor axis of the moment ellipse, which
    /// the oblique stretch of an off-axis sphere's image leaves unchanged.
    pub diameter_px: f64,
    /// Why the blob cannot be a whole sphere image, if it cannot.
    pub rejected: Option<&'static str>,
}

fn rejection(blob: &Blob) -> Option<&'static str> {
    if blob.touches_border {
        Some("touches the image border")
    } else if blob.circularity() < MIN_CIRCULARITY {
        Some("not round")
    } else {
        None
    }
}

/// Candidates of one frame: every blob with its corrected centroid in ideal
/// pixels (camera `camera`, its lens's relative illumination `illumination`).
/// `frame` must be the frame the extraction came from.
pub fn candidates(
    camera: &Camera,
    illumination: &Illumination,
    frame: &FrameView<'_>,
    extraction: &Extraction,
    weighting: Weighting,
) -> Vec<Candidate> {
    let map = CameraMap::new(camera, illumination);
    extraction
        .blobs
        .iter()
        .map(|b| {
            let ideal = mapped_centroid(frame, b, &extraction.level, weighting, &map);
            let rejected = rejection(b).or(if ideal.is_none() {
                Some("cannot be corrected (no background around it, or outside the lens model)")
            } else {
                None
            });
            let [u, v] = ideal.unwrap_or([b.u, b.v]);
            Candidate {
                ideal_px: Point2::new(u, v),
                diameter_px: b.ellipse().minor_px,
                rejected,
            }
        })
        .collect()
}
