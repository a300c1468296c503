//! What one camera sees of the spheres in one frame: blobs → candidate sphere
//! images with their centres in ideal (undistorted) pixels.
//!
//! Lens distortion is handled inside the centroid, not after it (METHODS.md
//! §1): the centroid is taken over undistorted pixel positions, each pixel
//! weighted by `F·J` with J the area Jacobian of the undistortion, so that it
//! is the centroid of the light in the ideal image, where a sphere's outline
//! is an exact ellipse.

use std::cell::Cell;

use extract::{Blob, Extraction, FrameView, PixelMap, Weighting, mapped_centroid};
use geom::{Camera, Point2, Vector2};

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

/// The camera's undistortion as a pixel map (observed → ideal pixel, area
/// Jacobian). Pixels come run by run, so each is solved starting from the
/// previous pixel's solution: one or two Newton steps instead of several,
/// converged to the same tolerance.
struct Undistortion<'a> {
    camera: &'a Camera,
    last: Cell<Option<(Point2<f64>, Vector2<f64>)>>,
}

impl PixelMap for Undistortion<'_> {
    fn map(&self, u: f64, v: f64) -> Option<([f64; 2], f64)> {
        let observed = Point2::new(u, v);
        let (p, j, n) = match self.last.get() {
            Some(near) => self.camera.undistort_pixel_area_near(observed, near).ok()?,
            None => {
                let (p, j) = self.camera.undistort_pixel_area(observed).ok()?;
                (p, j, self.camera.intrinsics.to_normalized(p))
            }
        };
        self.last.set(Some((observed, n)));
        Some(([p.x, p.y], j))
    }
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

/// Candidates of one frame: every blob with its undistorted centroid.
/// `frame` must be the frame the extraction came from.
pub fn candidates(
    camera: &Camera,
    frame: &FrameView<'_>,
    extraction: &Extraction,
    weighting: Weighting,
) -> Vec<Candidate> {
    let map = Undistortion {
        camera,
        last: Cell::new(None),
    };
    extraction
        .blobs
        .iter()
        .map(|b| {
            let ideal = if camera.distortion.is_none() {
                Some([b.u, b.v])
            } else {
                mapped_centroid(frame, b, &extraction.level, weighting, &map)
            };
            let rejected = rejection(b).or(if ideal.is_none() {
                Some("cannot be undistorted")
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
