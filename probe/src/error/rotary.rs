//! The rotary method's faults, reasons of [`super::ProbeError`].

use thiserror::Error;

use super::ProbeError;

/// What is wrong with one measured centre of the rotary method.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CentreFault {
    /// A coordinate that is not finite.
    #[error("centre {centre:?} is not finite")]
    NotFinite {
        /// The centre (mm).
        centre: geom::nalgebra::Point3<f64>,
    },
    /// No sphere fits the probed points.
    #[error("sphere fit: {0}")]
    SphereFit(Box<ProbeError>),
    /// Too far from the 0° centre turned by the angle for the small-error model.
    #[error(
        "the centre lies {distance_mm:.3} mm from its 0° centre turned by {angle_deg}° about Z \
         (more than {} mm: the small-error model does not apply): {}",
        crate::rotary::MAX_DISPLACEMENT_MM,
        if *.clockwise {
            "it matches a clockwise turn: angles count counter-clockwise seen from +Z"
        } else {
            "a wrong angle or ball, or a table frame whose Z is not on the axis?"
        }
    )]
    Displaced {
        /// Distance from the ideal position (mm).
        distance_mm: f64,
        /// The angle (degrees).
        angle_deg: f64,
        /// Whether a clockwise turn by the angle would fit.
        clockwise: bool,
    },
}

/// What is wrong with a rotary-table measurement (its angles, balls and
/// counts), an angle asked for, or the probed points of a sphere.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RotaryFault {
    /// A measured angle outside [0°, 360°).
    #[error("angle_deg: angle {angle}° is not in [0°, 360°)")]
    AngleRange {
        /// The angle (degrees).
        angle: f64,
    },
    /// No measurement at 0°, the reference.
    #[error(
        "angle_deg: no measurement at 0° (the first angle is {first}°): the centre at 0° is each \
         ball's reference"
    )]
    NoZero {
        /// The first angle (degrees).
        first: f64,
    },
    /// Angles not strictly increasing.
    #[error("angle_deg: angles must increase strictly: {angle}° follows {previous}°")]
    NotIncreasing {
        /// The angle (degrees).
        angle: f64,
        /// The angle before it (degrees).
        previous: f64,
    },
    /// A ball without a name.
    #[error("ball: ball number {number} has no name")]
    Unnamed {
        /// Its number (1-based).
        number: usize,
    },
    /// Two balls of one name.
    #[error("ball: ball {ball} is given twice")]
    DuplicateBall {
        /// The name.
        ball: String,
    },
    /// A ball without one centre per angle.
    #[error(
        "ball {ball}: {centres} centres for {angles} angles: every ball needs one centre per angle"
    )]
    CentreCount {
        /// The ball.
        ball: String,
        /// Its centres.
        centres: usize,
        /// The angles.
        angles: usize,
    },
    /// A ball without one sphere fit per angle while others have fits.
    #[error(
        "ball {ball}: {fits} sphere fits for {angles} angles: with probed points every ball needs \
         one fit per angle"
    )]
    FitCount {
        /// The ball.
        ball: String,
        /// Its fits.
        fits: usize,
        /// The angles.
        angles: usize,
    },
    /// A ball without probed points at every angle.
    #[error(
        "ball {ball}: probed points at {groups} angles of {angles}: every ball needs points at \
         every angle"
    )]
    PointGroups {
        /// The ball.
        ball: String,
        /// The angles it has points at.
        groups: usize,
        /// The angles.
        angles: usize,
    },
    /// An angle asked for that is not finite.
    #[error("angle: {angle} is not a finite angle")]
    AngleNotFinite {
        /// The angle (degrees).
        angle: f64,
    },
    /// Too few probed points for a sphere.
    #[error(
        "probed points: {count} point(s): a sphere needs at least {} (the seed probes the north \
         pole and four on the equator)",
        crate::rotary::MIN_POINTS
    )]
    TooFewPoints {
        /// The points given.
        count: usize,
    },
}
