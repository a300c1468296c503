//! What one camera sees of the spheres in one frame: blobs → candidate sphere
//! images with their centres in ideal (undistorted) pixels.
//!
//! Lens distortion and the lens's relative illumination are handled inside the
//! centroid, not after it: each pixel is flat-field corrected (its background
//! removed, divided by RI) and weighted by `F′·J` at its undistorted position,
//! J the area Jacobian of the undistortion (`extract::correction`), so that the
//! centroid is that of the radiance in the ideal image, where a uniformly
//! luminous sphere is a uniform ellipse — whatever the lens.
//!
//! The geometry checks are made on that same corrected light, in the ideal
//! image: its moment ellipse gives the apparent diameter and the roundness.
//! A sphere's ideal image seen at an angle θ off the optical axis is an
//! ellipse stretched radially, minor/major = √(cos²θ − sin²α)/cos α ≈ cos θ
//! (α the sphere's angular radius, `geom::sphere_image`): a blob is a sphere
//! image when its circularity is at least [`MIN_CIRCULARITY`] of that,
//! however strongly the lens distorts the observed one.

use extract::{
    Blob, CameraMap, CentroidCovariance, Extraction, FrameView, MappedLight, Weighting,
    mapped_light,
};
use geom::{Camera, Illumination, Point2};

/// Roundness (the corrected light's circularity over the cos θ a sphere's
/// ideal image has at its place) below which a blob is not a sphere image:
/// a sphere image is ≈ 1, rounder where blur and pixels matter; merged blobs
/// and streaks are far below.
pub const MIN_CIRCULARITY: f64 = 0.7;

/// A blob that may be the image of a sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Centroid in ideal (undistorted) pixels.
    pub ideal_px: Point2<f64>,
    /// Apparent diameter (ideal px): the minor axis of the corrected light's
    /// moment ellipse, `a ≈ 2f·tan α/cos θ`, so that `f·D/a ≈ d·cos θ` is
    /// the sphere's depth Z whatever its place in the field.
    pub diameter_px: f64,
    /// Why the blob cannot be a whole sphere image, if it cannot.
    pub rejected: Option<&'static str>,
    /// Covariance of `ideal_px` from the image noise (ideal px²,
    /// `extract::CentroidCovariance`); `None` without a noise model (the
    /// camera's system gain K), for a blob that could not be corrected, or
    /// with the raw weighting.
    pub covariance: Option<CentroidCovariance>,
}

/// Roundness of a blob's corrected light at ideal position `at`: its
/// circularity over cos θ = 1/√(1 + |n|²), n the normalised coordinates.
fn roundness(camera: &Camera, light: &MappedLight, at: Point2<f64>) -> f64 {
    let n = camera.intrinsics.to_normalized(at);
    light.ellipse().circularity() * (1.0 + n.norm_squared()).sqrt()
}

fn rejection(camera: &Camera, blob: &Blob, light: Option<&MappedLight>) -> Option<&'static str> {
    match light {
        _ if blob.touches_border => Some("touches the image border"),
        None => Some("cannot be corrected (no background around it, or outside the lens model)"),
        Some(l) => {
            let [u, v] = l.centroid;
            (roundness(camera, l, Point2::new(u, v)) < MIN_CIRCULARITY).then_some("not round")
        }
    }
}

/// Candidates of one frame: every blob with its corrected centroid and
/// diameter in ideal pixels (camera `camera`, its lens's relative
/// illumination `illumination`); with the camera's system gain
/// `gain_dn_per_e` (K, DN/e⁻), each centroid's covariance from the image
/// noise. `frame` must be the frame the extraction came from (not denoised
/// when K is given: the covariance assumes independent pixels).
pub fn candidates(
    camera: &Camera,
    illumination: &Illumination,
    frame: &FrameView<'_>,
    extraction: &Extraction,
    weighting: Weighting,
    gain_dn_per_e: Option<f64>,
) -> Vec<Candidate> {
    let map = CameraMap::new(camera, illumination);
    extraction
        .blobs
        .iter()
        .map(|b| {
            let light = mapped_light(frame, b, &extraction.level, weighting, &map, gain_dn_per_e);
            let rejected = rejection(camera, b, light.as_ref());
            let ([u, v], diameter_px) = match &light {
                Some(l) => (l.centroid, l.ellipse().minor_px),
                None => ([b.u, b.v], b.ellipse().minor_px),
            };
            Candidate {
                ideal_px: Point2::new(u, v),
                diameter_px,
                rejected,
                covariance: light.and_then(|l| l.covariance),
            }
        })
        .collect()
}
