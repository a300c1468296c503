//! The one error type of `geom`: degenerate input, never I/O.

use thiserror::Error;

/// What went wrong in a geometric computation. Every variant is caused by
/// degenerate or insufficient input; `geom` has no other way to fail.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GeomError {
    /// Fewer points (or observations) than the model needs.
    #[error("{what} needs at least {needed} points, got {got}")]
    TooFewPoints {
        /// The computation that was asked for.
        what: &'static str,
        /// Minimum number of points.
        needed: usize,
        /// Number of points given.
        got: usize,
    },
    /// The input does not determine the result (collinear, coplanar, zero-length, singular).
    #[error("degenerate input: {0}")]
    Degenerate(Degeneracy),
    /// A value was NaN or infinite.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// A point lies on or behind the camera's image plane.
    #[error("point at depth {depth} mm is not in front of the camera")]
    BehindCamera {
        /// Depth of the point in the camera frame (mm).
        depth: f64,
    },
    /// An iteration did not reach its tolerance.
    #[error("{what} did not converge after {iterations} iterations (last step {last_step:e})")]
    NotConverged {
        /// The iteration that failed.
        what: &'static str,
        /// Iterations performed.
        iterations: usize,
        /// Size of the last correction, in the iteration's own unit.
        last_step: f64,
    },
    /// A value so large that the sums of squares a fit needs would overflow.
    #[error(
        "{what}: coordinate {value:e} is beyond ±{limit:e}, where the sums of squares a fit \
         needs overflow"
    )]
    OutOfRange {
        /// The computation that was asked for.
        what: &'static str,
        /// The value.
        value: f64,
        /// The largest magnitude accepted.
        limit: f64,
    },
}

/// Why the input does not determine the result: one variant per reason, with
/// the values that show it; its text follows `degenerate input: ` in
/// [`GeomError::Degenerate`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Degeneracy {
    /// Two sequences that pair up element by element have different lengths.
    #[error("{}{first} {first_items} but {second} {second_items}", prefix(.what))]
    LengthsDiffer {
        /// The computation, when the text names it.
        what: Option<&'static str>,
        /// Length of the first sequence.
        first: usize,
        /// What the first sequence holds (plural).
        first_items: &'static str,
        /// Length of the second sequence.
        second: usize,
        /// What the second sequence holds (plural).
        second_items: &'static str,
    },
    /// A grid's values are not one per node.
    #[error(
        "grid of {}×{}×{} nodes needs {} values, got {got}",
        .dims[0], .dims[1], .dims[2], .dims[0] * .dims[1] * .dims[2]
    )]
    GridValues {
        /// Nodes per axis.
        dims: [usize; 3],
        /// Number of values given.
        got: usize,
    },
    /// An abscissa outside the knots of a piecewise-linear interpolation.
    #[error("{x} outside the interpolation range [{first}, {last}]")]
    OutsideRange {
        /// The abscissa asked for.
        x: f64,
        /// First knot.
        first: f64,
        /// Last knot.
        last: f64,
    },
    /// A point outside the box of a trilinear grid.
    #[error("point {point:?} outside the interpolation grid")]
    OutsideGrid {
        /// The point asked for.
        point: [f64; 3],
    },
    /// Interpolation knots that do not increase strictly.
    #[error("interpolation knots must increase strictly")]
    KnotsNotIncreasing,
    /// Periodic knots outside `[0, period)`.
    #[error("periodic knots must lie in [0, period)")]
    KnotsOutsidePeriod,
    /// A trilinear grid with fewer than two nodes on some axis.
    #[error("a trilinear grid needs ≥ 2 nodes per axis")]
    GridTooSmall,
    /// A grid step that is not positive and finite.
    #[error("grid steps must be positive")]
    GridStepNotPositive,
    /// All points of a fit are one point.
    #[error("{what}: all points coincide")]
    Coincide {
        /// The fit.
        what: &'static str,
    },
    /// All points of a named set are one point (the Hartley normalisation of a DLT).
    #[error("all {set} points coincide")]
    SetCoincides {
        /// The set of points (`image`, `target`).
        set: &'static str,
    },
    /// The points lie on one line.
    #[error("{what}: points are collinear")]
    Collinear {
        /// The fit.
        what: &'static str,
    },
    /// The points lie on one line or are one point.
    #[error("{what}: the points are collinear or coincide")]
    CollinearOrCoincide {
        /// The fit.
        what: &'static str,
    },
    /// All points share one abscissa: a regression on x has no slope.
    #[error("{what}: all points have the same x")]
    SameX {
        /// The fit.
        what: &'static str,
    },
    /// Two principal spreads are equal where the fit needs one direction.
    #[error("{what}: no single direction of {spread} spread")]
    NoSingleDirection {
        /// The fit.
        what: &'static str,
        /// The spread whose direction is the result.
        spread: PrincipalSpread,
    },
    /// 2-D points spread equally in every direction (no line direction).
    #[error("{what}: the points spread equally in every direction")]
    Isotropic {
        /// The fit.
        what: &'static str,
    },
    /// A linear least-squares system of numerical rank below its unknowns.
    #[error("{what}: the points do not determine the element")]
    Underdetermined {
        /// The computation.
        what: &'static str,
    },
    /// An algebraic fit whose squared radius is not positive.
    #[error("{what}: no real {element}")]
    NoRealElement {
        /// The fit.
        what: &'static str,
        /// The element (`circle`, `sphere`).
        element: &'static str,
    },
    /// No start axis of a cylinder fit converged.
    #[error("cylinder fit: no start axis found")]
    NoStartAxis,
    /// A singular value decomposition gave no singular vectors.
    #[error("{what}: SVD failed")]
    SvdFailed {
        /// The computation.
        what: &'static str,
    },
    /// The SVD of a fit's centred points gave no right singular vectors.
    #[error("singular value decomposition returned no vectors")]
    NoSingularVectors,
    /// The SVD of the DLT's linear system gave no right singular vectors.
    #[error("SVD did not converge")]
    SvdNotConverged,
    /// nalgebra's SVD solve refused the system. nalgebra reports why only as
    /// a `&'static str`, so that text is the typed form kept.
    #[error("{what}: {reason}")]
    SolveFailed {
        /// The computation.
        what: &'static str,
        /// nalgebra's reason.
        reason: &'static str,
    },
    /// The DLT's linear system has a null space of dimension above one.
    #[error("the linear system has more than one solution (critical configuration)")]
    MultipleSolutions,
    /// The flatness linear programme has no solution.
    #[error("flatness linear programme failed: {0}")]
    LpFailed(microlp::Error),
    /// The flatness linear programme stopped at a limit before a solution.
    #[error("flatness linear programme was interrupted")]
    LpInterrupted,
    /// A matrix that must be inverted is singular.
    #[error("singular {matrix}")]
    Singular {
        /// The matrix (`intrinsic matrix`, `distortion Jacobian`, …).
        matrix: &'static str,
    },
    /// RQ decomposition of a singular matrix.
    #[error("RQ of a singular matrix")]
    SingularRq,
    /// A projection matrix whose left 3×3 block is singular.
    #[error("projection matrix has a singular left 3×3 block")]
    SingularProjection,
    /// A matrix that is not an intrinsic matrix K.
    #[error("intrinsic matrix is not upper triangular with K[2][2] ≠ 0")]
    NotIntrinsic,
    /// An intrinsic matrix with a focal length ≤ 0.
    #[error("focal lengths must be positive")]
    FocalNotPositive,
    /// A camera whose target is its own position.
    #[error("camera looks at its own position")]
    LooksAtItself,
    /// A camera whose up vector is parallel to its optical axis.
    #[error("camera up vector is parallel to its optical axis")]
    UpAlongAxis,
    /// Lens distortion whose Jacobian determinant is ≤ 0 at an observed pixel.
    #[error("distortion folds the image at ({u:.1}, {v:.1}) px")]
    DistortionFolds {
        /// Observed pixel column.
        u: f64,
        /// Observed pixel row.
        v: f64,
    },
    /// A sphere radius ≤ 0.
    #[error("sphere radius {radius} mm is not positive")]
    RadiusNotPositive {
        /// The radius (mm).
        radius: f64,
    },
    /// A sphere not wholly in front of the camera.
    #[error("sphere is not wholly in front of the camera (its image is not an ellipse)")]
    SphereNotInFront,
    /// A camera centre inside a sphere.
    #[error("camera is inside the sphere")]
    CameraInsideSphere,
    /// The views of a triangulation are parallel: the point is at infinity.
    #[error("views are parallel: the sphere is at infinity")]
    ParallelViews,
    /// A camera parameter name that is not one of `Camera::PARAMETERS`.
    #[error(
        "unknown camera parameter (not one of fx fy cx cy skew rx ry rz tx ty tz k1 k2 p1 p2 k3)"
    )]
    UnknownParameter,
    /// A matrix given as a covariance that is not square, or not positive semi-definite.
    #[error(
        "not a covariance matrix (not square, or an eigenvalue {smallest:e} below zero against the largest {largest:e})"
    )]
    NotCovariance {
        /// Its smallest eigenvalue (NaN when not square).
        smallest: f64,
        /// Its largest eigenvalue (NaN when not square).
        largest: f64,
    },
}

/// `"{what}: "`, or nothing when no computation is named.
fn prefix(what: &Option<&'static str>) -> String {
    what.map(|w| format!("{w}: ")).unwrap_or_default()
}

/// Which principal spread of the points gives a fit's direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrincipalSpread {
    /// The least spread: a plane's normal.
    Least,
    /// The largest spread: a line's direction.
    Largest,
}

impl std::fmt::Display for PrincipalSpread {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PrincipalSpread::Least => "least",
            PrincipalSpread::Largest => "largest",
        })
    }
}

impl From<Degeneracy> for GeomError {
    fn from(reason: Degeneracy) -> Self {
        GeomError::Degenerate(reason)
    }
}

/// Result alias for `geom`.
pub type Result<T> = std::result::Result<T, GeomError>;
