//! One camera from the markers detected in its calibration image: the
//! detections are assigned to target ids from the nominal camera
//! ([`correspond`]), the camera is calibrated from the plain centroids, then,
//! with that camera, the centroids are recomputed with the camera's model —
//! over undistorted pixel positions and flat-field corrected by the lens's
//! relative illumination, so that each marker's image is a radiance image in
//! the ideal image plane, which the sphere-marker model describes — and the
//! camera is refitted, [`RECENTROID_ROUNDS`] times. The caller supplies the
//! re-centroiding (e.g. `extract::mapped_centroid`), so `calib` reads no images.

use formats::{CorrespondenceRow, TargetRow};
use geom::nalgebra::{Translation3, Vector3};
use geom::{Camera, Point2};

use crate::{
    CalibError, Calibration, CorrespondOptions, Correspondence, Observation, OptionProblem,
    Options, Result, calibrate, correspond, markers, observations,
};

/// Rounds of re-centroiding with the latest camera and refitting.
pub const RECENTROID_ROUNDS: usize = 2;

/// `camera` in the frame of a target moved by `offset` (mm, world frame):
/// a target point x is seen at R (x + offset) + t.
pub fn seeing_moved_target(camera: &Camera, offset: [f64; 3]) -> Camera {
    Camera {
        pose: camera.pose * Translation3::from(Vector3::from(offset)),
        ..camera.clone()
    }
}

/// A camera calibrated from the detections in its image.
#[derive(Debug, Clone)]
pub struct ImageCalibration {
    /// The final calibration.
    pub calibration: Calibration,
    /// The observations it was fitted to (re-centroided detections).
    pub observations: Vec<Observation>,
    /// The assignment of detections to markers.
    pub correspondence: Correspondence,
}

/// Calibrate one camera from `detections` (plain centroids of the blobs in
/// its image, observed pixels) of the markers of `target` (`spheres`: the
/// markers are luminous spheres of their diameters), starting from `nominal`.
/// `recentroid(camera)` returns, for every detection in the same order, its
/// centroid recomputed with `camera`'s model (observed pixels), or `None` to
/// keep the plain one.
pub fn calibrate_detections(
    target: &[TargetRow],
    spheres: bool,
    detections: &[Point2<f64>],
    nominal: &Camera,
    options: &Options,
    correspond_options: &CorrespondOptions,
    recentroid: &dyn Fn(&Camera) -> Vec<Option<Point2<f64>>>,
) -> Result<ImageCalibration> {
    let correspondence = correspond(&markers(target), detections, nominal, correspond_options)?;
    let observe = |pixels: &[Point2<f64>]| {
        let rows: Vec<CorrespondenceRow> = correspondence
            .matches
            .iter()
            .map(|m| CorrespondenceRow {
                id: m.id,
                u: pixels[m.detection].x,
                v: pixels[m.detection].y,
            })
            .collect();
        observations(target, &rows, spheres)
    };
    let (width, height) = (nominal.width, nominal.height);
    let mut obs = observe(detections)?;
    let mut calibration = calibrate(&obs, width, height, options)?;
    for _ in 0..RECENTROID_ROUNDS {
        let again = recentroid(&calibration.camera);
        if again.len() != detections.len() {
            return Err(CalibError::Option(OptionProblem::Recentroided {
                centroids: again.len(),
                detections: detections.len(),
            }));
        }
        let pixels: Vec<Point2<f64>> = again
            .into_iter()
            .zip(detections)
            .map(|(p, d)| p.unwrap_or(*d))
            .collect();
        obs = observe(&pixels)?;
        calibration = calibrate(&obs, width, height, options)?;
    }
    Ok(ImageCalibration {
        calibration,
        observations: obs,
        correspondence,
    })
}
