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
    Ambiguous(Ambiguity),
    /// A chessboard specification or a view of the board is unusable.
    #[error("{0}")]
    Board(BoardProblem),
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
    /// The views of a planar target do not determine the intrinsics.
    #[error(
        "the planar target's {views} view{s} the focal length and the principal point \
         undetermined: the boards are (nearly) parallel to each other or to the sensor \
         (condition number {condition:.2e}); tilt the board between views (±20–45°)",
        s = if *views == 1 { " leaves" } else { "s leave" }
    )]
    ParallelViews {
        /// Views of the camera.
        views: usize,
        /// Condition number of Zhang's system (or of the one-view constraints).
        condition: f64,
    },
    /// A camera that shares no pose with the cameras tied to the world frame.
    #[error(
        "camera {camera} never shares a target pose with the other cameras: the view graph is \
         not connected (cut off from the world frame, pose {world_pose}); add a pose seen by it \
         and by a camera already tied in"
    )]
    CutOff {
        /// The camera cut off.
        camera: u8,
        /// The pose whose frame is the world frame.
        world_pose: u32,
    },
    /// A camera's views hold fewer points than its model needs.
    #[error(
        "camera {camera}: {points} points in {views} view{s}, fewer than the {needed} its model \
         and poses need (each view adds 6 pose unknowns)",
        s = if *views == 1 { "" } else { "s" }
    )]
    TooFewForModel {
        /// The camera.
        camera: u8,
        /// Its points over all its views.
        points: usize,
        /// Its views.
        views: usize,
        /// Points needed.
        needed: usize,
    },
    /// An option or an input is out of range.
    #[error("option {option}: {0}", option = .0.option())]
    Option(OptionProblem),
    /// A flat-field or dark frame cannot give the relative illumination.
    #[error("{0}")]
    FlatField(FlatFieldProblem),
    /// A geometric computation failed on degenerate data.
    #[error("{what}: {source}")]
    Geom {
        /// What was being computed.
        what: &'static str,
        /// The geometric failure.
        source: geom::GeomError,
    },
}

/// How the assignment of detections to markers is ambiguous.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Ambiguity {
    /// Two assignments fit the image equally well and are about equally far
    /// from the nominal prediction.
    #[error(
        "two different assignments fit the image equally well ({best} markers matched with \
         σ = {best_sigma_px:.3} px, {best_offset_px:.0} px from the nominal prediction; and \
         {other} with σ = {other_sigma_px:.3} px, {other_offset_px:.0} px from it; {conflicts} \
         of them matched differently); correct the nominal rig or use a target without \
         repeating structure"
    )]
    TwoAssignments {
        /// Markers matched by the best assignment.
        best: usize,
        /// Its residual σ (px).
        best_sigma_px: f64,
        /// Its displacement from the nominal prediction (px).
        best_offset_px: f64,
        /// Markers matched by the rival assignment.
        other: usize,
        /// Its residual σ (px).
        other_sigma_px: f64,
        /// Its displacement from the nominal prediction (px).
        other_offset_px: f64,
        /// Markers the two match differently.
        conflicts: usize,
    },
    /// A matched marker has a second detection within the gate.
    #[error(
        "marker {marker} has two detections within the {gate_px:.2} px gate: #{detection} at \
         {distance_px:.2} px and #{second} at {second_px:.2} px"
    )]
    TwoDetections {
        /// Marker id.
        marker: u32,
        /// The gate (px).
        gate_px: f64,
        /// The matched detection's index.
        detection: usize,
        /// Its distance from the predicted marker (px).
        distance_px: f64,
        /// The other detection's index.
        second: usize,
        /// Its distance (px).
        second_px: f64,
    },
    /// A matched detection lies within the gate of a second marker.
    #[error(
        "detection #{detection} lies within the {gate_px:.2} px gate of markers {marker} and {second}"
    )]
    TwoMarkers {
        /// The detection's index.
        detection: usize,
        /// The gate (px).
        gate_px: f64,
        /// The matched marker's id.
        marker: u32,
        /// The other marker's id.
        second: u32,
    },
}

/// Why a flat-field and dark frame pair cannot give the relative illumination.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FlatFieldProblem {
    /// The frames differ in size.
    #[error("the dark frame is {}×{} px but the flat field {}×{} px", dark[0], dark[1], flat[0], flat[1])]
    Sizes {
        /// Dark frame width and height (px).
        dark: [u32; 2],
        /// Flat field width and height (px).
        flat: [u32; 2],
    },
    /// A pixel buffer's length is not width × height (or is empty).
    #[error("pixel buffers do not match the image size")]
    Buffers,
    /// Too many pixels of the flat field are saturated.
    #[error(
        "{pixels} pixels of the flat field are saturated ({saturation} DN): take it with a \
         shorter exposure or a dimmer source"
    )]
    Saturated {
        /// Saturated pixels.
        pixels: usize,
        /// The saturation level (DN).
        saturation: u16,
    },
    /// The model's starting centre or scale is unusable.
    #[error("model centre {centre:?} and scale {scale_px} px must be finite, the scale positive")]
    Model {
        /// Starting centre (px).
        centre: [f64; 2],
        /// Radial scale (px).
        scale_px: f64,
    },
    /// The flat field is hardly above the dark frame.
    #[error(
        "the flat field is only {level_dn:.1} DN above the dark frame (noise {noise_dn:.1} DN): \
         is it lit, and is the dark frame the right one?"
    )]
    Unlit {
        /// Brightest block's level above the dark frame (DN).
        level_dn: f64,
        /// The dark frame's noise (DN).
        noise_dn: f64,
    },
    /// The linear start of the fit failed.
    #[error("flat-field fit: {0}")]
    Solve(&'static str),
    /// The fitted level at the model's centre is not positive.
    #[error("flat-field fit: non-positive level {0} at the model's centre")]
    Level(f64),
    /// The fitted model is not positive everywhere in the image.
    #[error("flat-field fit: the model falls to {0} in the image")]
    Falls(f64),
}

/// Why a board specification or a view of the board cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BoardProblem {
    /// The `--board` text is not `chessboard:COLSxROWS:SQUARE_MM`.
    #[error(
        "board '{0}': expected chessboard:COLSxROWS:SQUARE_MM (inner corners, e.g. \
         chessboard:9x6:12.0)"
    )]
    Spec(String),
    /// A board whose orientation cannot be told from its pattern.
    #[error(
        "board {cols}×{rows}: a chessboard with an even number of inner corners in all \
         (COLS + ROWS even) looks the same turned by 180°; use one odd and one even count \
         (e.g. 9×6)"
    )]
    Symmetric {
        /// Inner corners along x.
        cols: u32,
        /// Inner corners along y.
        rows: u32,
    },
    /// No board in the image.
    #[error("no chessboard found ({0})")]
    NotFound(String),
    /// Only part of the board was found.
    #[error(
        "the chessboard found partially: {found} of {expected} inner corners ({extent}); the whole board must be in view"
    )]
    Partial {
        /// Corners found.
        found: usize,
        /// Corners of the board.
        expected: usize,
        /// The labelled grid's extent.
        extent: String,
    },
    /// The pattern does not tell the orientation (too little contrast).
    #[error(
        "the chessboard's orientation is not determined: the corner squares' contrast is {contrast:.1} gray levels"
    )]
    Orientation {
        /// Contrast between the two sampled squares (8-bit gray levels).
        contrast: f64,
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

/// Which option or input of a calibration is out of range, with its value.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum OptionProblem {
    /// Too few poses to calibrate two halves of them.
    #[error("{poses} poses: the two-halves check needs at least 4 (two per half)")]
    TooFewPosesToSplit {
        /// Poses of the calibration.
        poses: usize,
    },
    /// More than half of the detections coincide with another one.
    #[error("more than half of the detections coincide with another one")]
    CoincidentDetections,
    /// A detection is NaN or infinite.
    #[error("detection {index} at ({x}, {y}) is not finite")]
    DetectionNotFinite {
        /// Index of the detection.
        index: usize,
        /// Its u (px).
        x: f64,
        /// Its v (px).
        y: f64,
    },
    /// The correspondence search's bounds are out of range.
    #[error("max_scale {max_scale} must be ≥ 1 and gate_fraction {gate_fraction} in (0, 0.5)")]
    Search {
        /// Largest scale of the nominal target tried.
        max_scale: f64,
        /// Gate as a fraction of the detections' spacing.
        gate_fraction: f64,
    },
    /// Re-centroiding gave another number of centroids than detections.
    #[error("{centroids} centroids for {detections} detections")]
    Recentroided {
        /// Centroids returned.
        centroids: usize,
        /// Detections given.
        detections: usize,
    },
    /// The DLT was given different numbers of space and image points.
    #[error("{world} space points but {image} image points")]
    DltPoints {
        /// Space points.
        world: usize,
        /// Image points.
        image: usize,
    },
    /// An unknown distortion model name.
    #[error("'{0}' is not one of pinhole, k1k2, k1k2p1p2")]
    Model(String),
    /// k3 asked for with the pinhole model.
    #[error("k3 needs a radial model (k1k2 or k1k2p1p2), not pinhole")]
    K3WithoutRadial,
    /// The outlier factor is not a number ≥ 1.
    #[error("{0} must be a number ≥ 1")]
    OutlierK(f64),
    /// No round of outlier rejection allowed.
    #[error("at least one round is needed")]
    NoRound,
    /// An image of zero width or height.
    #[error("{width}×{height} px is empty")]
    ImageSize {
        /// Width (px).
        width: u32,
        /// Height (px).
        height: u32,
    },
    /// A target uncertainty that is not a finite number ≥ 0.
    #[error("{0} µm is not a finite number ≥ 0")]
    TargetUncertainty(f64),
    /// The observations given with a calibration are not the ones it was fitted to.
    #[error(
        "{observations} observations for a calibration of {residuals} points (or in another order)"
    )]
    ObservationsDiffer {
        /// Observations given.
        observations: usize,
        /// Points of the calibration.
        residuals: usize,
    },
}

impl OptionProblem {
    /// The option or input concerned, as the message names it.
    pub fn option(&self) -> &'static str {
        match self {
            Self::CoincidentDetections | Self::DetectionNotFinite { .. } => "detections",
            Self::Search { .. } => "correspondence search",
            Self::Recentroided { .. } => "re-centroiding",
            Self::DltPoints { .. } => "dlt",
            Self::Model(_) => "model",
            Self::K3WithoutRadial => "k3",
            Self::OutlierK(_) => "outlier k",
            Self::NoRound => "max rounds",
            Self::ImageSize { .. } => "image size",
            Self::TargetUncertainty(_) => "target uncertainty",
            Self::ObservationsDiffer { .. } => "observations",
            Self::TooFewPosesToSplit { .. } => "poses",
        }
    }
}
