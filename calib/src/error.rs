//! The one error type of `calib`: every message names the marker id, the
//! value or the count at fault. The caller adds the camera and the file.

use thiserror::Error;

/// Why a camera could not be calibrated or its correspondences not found.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CalibError {
    /// Fewer points than the estimation needs.
    #[error("{what} needs at least {needed} points, got {got}")]
    TooFewPoints {
        /// The estimation that was asked for.
        what: &'static str,
        /// Minimum number of points.
        needed: usize,
        /// Number of points given.
        got: usize,
    },
    /// The image has too few detections to calibrate from.
    #[error(
        "only {detections} markers were detected in the image; calibration needs at least {needed} \
         (is the target in view and the threshold right?)"
    )]
    TooFewDetections {
        /// Detections offered.
        detections: usize,
        /// Minimum needed.
        needed: usize,
    },
    /// The automatic assignment matched too few markers.
    #[error(
        "only {matched} target markers could be matched to the {detections} detections \
         ({markers} markers on the target); calibration needs at least {needed}"
    )]
    TooFewMatches {
        /// Markers matched.
        matched: usize,
        /// Minimum needed.
        needed: usize,
        /// Detections offered.
        detections: usize,
        /// Markers on the target.
        markers: usize,
    },
    /// The 3-D points do not span space: the DLT has no unique solution.
    #[error(
        "the target points are {kind}: their smallest principal spread is {ratio:.2e} of the \
         largest (a DLT needs a non-coplanar 3-D target, ratio ≥ {limit})"
    )]
    Coplanar {
        /// `collinear`, `coplanar` or `nearly coplanar`.
        kind: &'static str,
        /// Smallest over largest singular value of the centred points (second over first when collinear).
        ratio: f64,
        /// The limit below which the points are rejected.
        limit: f64,
    },
    /// No assignment of detections to markers fits a camera (residuals too
    /// large for the marker spacing, or fewer than three quarters of the
    /// detections matched): wrong image or wrong nominal rig.
    #[error(
        "no assignment of the {detections} detections to target markers is consistent with a \
         camera: the best matches {matched} markers with DLT residuals of σ = {sigma_px:.2} px \
         (a believable one matches at least three quarters of the detections with σ ≤ {limit_px:.2} px); \
         is this the right image for this camera, and is the nominal rig right?"
    )]
    Inconsistent {
        /// Markers matched by the best candidate.
        matched: usize,
        /// Detections offered.
        detections: usize,
        /// Robust σ of its DLT residuals (px).
        sigma_px: f64,
        /// Largest acceptable σ (px).
        limit_px: f64,
    },
    /// The assignments that fit the image need a camera turned far from its nominal orientation.
    #[error(
        "the only assignments of detections to markers that fit the image put the camera \
         {angle_deg:.1}° from its nominal orientation (at most {limit_deg:.0}° accepted); is this \
         the right image for this camera, and is the nominal rig right?"
    )]
    FarFromNominal {
        /// Smallest rotation from the nominal camera among the candidates (deg).
        angle_deg: f64,
        /// The limit (deg).
        limit_deg: f64,
    },
    /// Two different assignments of detections to markers explain the image equally well.
    #[error("the marker assignment is ambiguous: {0}")]
    Ambiguous(String),
    /// A coordinate is NaN or infinite.
    #[error("point {id}: {field} = {value} is not a finite number")]
    NonFinite {
        /// Marker id.
        id: u32,
        /// Which coordinate.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// A marker id occurs twice among the points of one camera.
    #[error("marker id {id} occurs more than once")]
    DuplicateId {
        /// Marker id.
        id: u32,
    },
    /// A correspondence names an id that is not on the target.
    #[error("marker id {id} is not on the target")]
    UnknownId {
        /// Marker id.
        id: u32,
    },
    /// A marker lies on or behind the camera's image plane.
    #[error("marker {id} lies at depth {depth_mm:.3} mm, not in front of the camera")]
    BehindCamera {
        /// Marker id.
        id: u32,
        /// Depth in the camera frame (mm).
        depth_mm: f64,
    },
    /// An option is out of range.
    #[error("option {option}: {message}")]
    Option {
        /// The option.
        option: &'static str,
        /// What is wrong, with the value.
        message: String,
    },
    /// A flat-field or dark frame cannot give the relative illumination.
    #[error("{0}")]
    FlatField(String),
    /// A geometric computation failed on degenerate data.
    #[error("{what}: {source}")]
    Geom {
        /// What was being computed.
        what: &'static str,
        /// The geometric failure.
        source: geom::GeomError,
    },
}

impl CalibError {
    /// Wrap a geometric failure with what was being computed.
    pub fn geom(what: &'static str) -> impl FnOnce(geom::GeomError) -> CalibError {
        move |source| CalibError::Geom { what, source }
    }
}

/// Result alias for `calib`.
pub type Result<T> = std::result::Result<T, CalibError>;
