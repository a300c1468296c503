//! The one error type of `probe`, [`ProbeError`], and the typed reasons it
//! carries: those shared by the methods here, each method's own in its
//! module (`rotary`, `tracer`, `volumetric`), re-exported.

use formats::Axis;
use thiserror::Error;

mod rotary;
mod tracer;
mod volumetric;

pub use rotary::{CentreFault, RotaryFault};
pub use tracer::{LatticeFault, TracerFault};
pub use volumetric::{CampaignFault, ChainFault, CurveFault, VolumetricFault};

/// What went wrong in a probe method. Input rows are named by their position
/// in the input (`row`, 1-based among the data rows, as the caller passed
/// them); the binary maps them to file lines.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ProbeError {
    /// Volumetric: the kinematic chain string (`--chain`) is not a chain, or
    /// does not fit the curves' source.
    #[error("--chain '{text}': {fault}")]
    Chain {
        /// The chain string as given.
        text: String,
        /// What is wrong with it.
        fault: ChainFault,
    },
    /// Volumetric: the measured curves of an axis are not usable curves.
    #[error("axis {axis}{fault}")]
    Curve {
        /// The axis.
        axis: Axis,
        /// Where in its curves and what is wrong.
        fault: CurveFault,
    },
    /// Tracer: a network, option or query the method cannot take.
    #[error("{0}")]
    Tracer(TracerFault),
    /// Rotary table: a measurement, angle or set of probed points the method
    /// cannot take.
    #[error("{0}")]
    Rotary(RotaryFault),
    /// Indexing: positions that do not support the construction, their
    /// rows 1-based among the positions ([`crate::indexing::Fault::located`]).
    #[error("{}", located(.0))]
    Layout(crate::indexing::Fault),
    /// An option that must be a positive number and is not.
    #[error("{option}: {value} must be a positive number")]
    NotPositive {
        /// The option, e.g. `--tolerance`.
        option: &'static str,
        /// The value given.
        value: f64,
    },
    /// Volumetric: a set-up (order, chain, tool, circle) or position the
    /// curves cannot serve.
    #[error("{0}")]
    Volumetric(VolumetricFault),
    /// An error of one named input (a position of `--at`, the circle).
    #[error("{label}: {error}")]
    At {
        /// The input, e.g. `at.csv: line 5` or `--circle`.
        label: String,
        /// What went wrong there.
        error: Box<ProbeError>,
    },
    /// Volumetric: an evaluate report (`--from-report`) that does not give
    /// the curves.
    #[error("{report}: {fault}")]
    Campaign {
        /// The report, as the caller names it.
        report: String,
        /// The key at fault and what is wrong.
        fault: CampaignFault,
    },
    /// Rotary table: one measured centre (a ball at an angle) the method cannot use.
    #[error("{}: {fault}", crate::rotary::centre_label(.ball, *.angle_deg))]
    Centre {
        /// The ball.
        ball: String,
        /// The angle (degrees).
        angle_deg: f64,
        /// What is wrong with its centre.
        fault: CentreFault,
    },
    /// The data do not determine the result (too few points, stations, balls; a degenerate layout).
    #[error(transparent)]
    Unsolvable(#[from] Unsolvable),
    /// A layout leaves an unknown unobservable: the condition number of the problem.
    #[error("{what}: condition number {condition:.3e} exceeds {limit:.1e}")]
    IllConditioned {
        /// The layout or matrix at fault.
        what: Conditioning,
        /// Its condition number.
        condition: f64,
        /// The largest accepted.
        limit: f64,
    },
    /// The nominal grid is not a lattice, which trilinear interpolation needs.
    #[error("the grid is not a lattice: {0}")]
    NotLattice(LatticeFault),
    /// An iteration did not converge.
    #[error("{what} did not converge after {iterations} iterations")]
    NotConverged {
        /// The iteration.
        what: &'static str,
        /// Iterations performed.
        iterations: usize,
    },
    /// A geometric computation failed on degenerate input.
    #[error(transparent)]
    Geom(#[from] geom::GeomError),
    /// A plot of the report could not be drawn.
    #[error(transparent)]
    Report(#[from] report::ReportError),
}

/// `row k, column 'c': what` of a layout fault.
fn located(fault: &crate::indexing::Fault) -> String {
    let (what, message) = fault.located();
    format!("{what}: {message}")
}

/// The matrix a tracer step solves for the station unknowns, as errors name it.
pub(crate) const REDUCED_NORMAL: &str = "the reduced normal matrix of the station unknowns \
     (stations and dead paths weakly determined by the layout, or readings in groups that share \
     too few points)";

/// The layout or matrix whose condition number is too large.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Conditioning {
    /// Rotary table: the balls' reference centres (nearly on one line).
    #[error(
        "ball layout (balls {} at 0°: a rotation is unobservable when they lie nearly on one line)",
        .balls.join(", ")
    )]
    BallLayout {
        /// The balls' names.
        balls: Vec<String>,
    },
    /// Rotary table: the measured angles for the axis average line.
    #[error("axis average line from the measured angles")]
    AxisLine,
    /// Indexing: the sphere through the centres.
    #[error(
        "sphere through the centres (the positions lie too near a plane or a small cap: \
         measure B turns at several A)"
    )]
    CentresSphere,
    /// Tracer: the seed's linearised start of a station.
    #[error(
        "station '{station}': the seed's linearised start from its {count} points \
         (its readings do not tell its distance from the grid)"
    )]
    StationStart {
        /// The station.
        station: String,
        /// Points it reads.
        count: usize,
    },
    /// Tracer: the directions from a point to its stations, before solving.
    #[error(
        "point '{point}': the directions to its {stations} stations are nearly coplanar \
         (stations in a plane with the point)"
    )]
    PointDirections {
        /// The point.
        point: String,
        /// Stations reading it.
        stations: usize,
    },
    /// Tracer: the directions from a point to its stations at the solution.
    #[error("point '{point}' at the solution: the directions to its stations")]
    PointAtSolution {
        /// The point.
        point: String,
    },
    /// Tracer: the reduced normal matrix of the station unknowns.
    #[error("{REDUCED_NORMAL}")]
    ReducedNormal,
    /// Volumetric: a curve fit's design with a basis function that vanishes everywhere.
    #[error("{fit} (a basis function vanishes at every position)")]
    VanishingBasis {
        /// The fit.
        fit: String,
    },
    /// Volumetric: a curve fit's design.
    #[error("{fit}")]
    CurveFit {
        /// The fit.
        fit: String,
    },
}

/// Why the data do not determine a result: the counts, names and positions
/// at fault.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Unsolvable {
    /// Rotary table: fewer than two measured angles.
    #[error("{angles} measured angle(s): the method needs the reference 0° and at least one more")]
    TooFewAngles {
        /// Angles measured.
        angles: usize,
    },
    /// Rotary table: fewer than three balls (named as given).
    #[error(
        "{} ball(s) ({}): the six errors need at least 3 balls not on one line",
        .names.len(),
        .names.join(", ")
    )]
    TooFewBalls {
        /// The balls' names.
        names: Vec<String>,
    },
    /// Rotary table: fewer than three reference centres.
    #[error("{centres} ball(s): the six errors need at least 3 balls not on one line")]
    TooFewCentres {
        /// Reference centres given.
        centres: usize,
    },
    /// Rotary table: every reference centre at one place.
    #[error("the balls' reference centres coincide: no rotation can be seen")]
    CoincidentCentres,
    /// Rotary table: the six-error design at an angle is singular.
    #[error("least squares of the six errors at {angle_deg}°: the design is singular")]
    SingularDesign {
        /// The angle (degrees).
        angle_deg: f64,
    },
    /// Rotary table: no covariance of the six errors at an angle.
    #[error(
        "least squares of the six errors at {angle_deg}°: AᵀA is singular or there are no \
         redundant observations"
    )]
    NoCovariance {
        /// The angle (degrees).
        angle_deg: f64,
    },
    /// Rotary table: the axis average line without errors at two angles.
    #[error("the axis average line needs errors at ≥ 2 angles, got {errors} (for {angles} angles)")]
    AxisLineTooFewErrors {
        /// Angles with errors.
        errors: usize,
        /// Angles measured.
        angles: usize,
    },
    /// Rotary table: the axis average line's design is singular.
    #[error("axis average line: singular design")]
    AxisLineSingular,
    /// Indexing: the sphere through the centres has a singular normal matrix.
    #[error("sphere through the centres: singular normal matrix")]
    SingularSphere,
    /// Indexing: the A = 0° centres do not define the B axis.
    #[error("the mean of the A = 0° centres coincides with the rotation centre: no B axis")]
    NoBAxis,
    /// Indexing: the B = 0° sweep does not define the A axis.
    #[error("the B = 0° sweep lies along the B axis: no A axis")]
    NoAAxis,
    /// Indexing: no position to summarise.
    #[error("no positions")]
    NoPositions,
    /// Indexing: no position tilted by A.
    #[error("no position with A > 0°")]
    NoTiltedPosition,
    /// Tracer: fewer stations than multilateration needs.
    #[error(
        "{stations} stations: multilateration needs at least {needed} \
         (m·n ≥ 4m + 3n − 6 cannot hold with fewer)"
    )]
    TooFewStations {
        /// Stations given.
        stations: usize,
        /// The fewest accepted.
        needed: usize,
    },
    /// Tracer: fewer readings than unknowns.
    #[error(
        "{readings} readings for {unknowns} unknowns (3·{points} point coordinates + 4·{stations} \
         station unknowns − 6 rigid freedoms): at least as many readings as unknowns are needed"
    )]
    TooFewReadings {
        /// Readings given.
        readings: usize,
        /// Unknowns of the network.
        unknowns: usize,
        /// Grid points.
        points: usize,
        /// Stations.
        stations: usize,
    },
    /// Tracer: a station reads too few points.
    #[error("station '{station}' reads {count} points: at least {needed} are needed")]
    StationReadsTooFew {
        /// The station.
        station: String,
        /// Points it reads.
        count: usize,
        /// The fewest accepted.
        needed: usize,
    },
    /// Tracer: a point is read by too few stations.
    #[error("point '{point}' is read by {count} stations: at least {needed} are needed")]
    PointReadTooFew {
        /// The point.
        point: String,
        /// Stations reading it.
        count: usize,
        /// The fewest accepted.
        needed: usize,
    },
    /// Tracer: a station's points lie in one plane (mirror ambiguity).
    #[error(
        "station '{station}' reads {count} points that lie in one plane (principal spreads \
         {largest:.3e} and {smallest:.3e} mm): the grid must be three-dimensional, or the station \
         and its mirror image in that plane fit the readings equally"
    )]
    StationPlanar {
        /// The station.
        station: String,
        /// Points it reads.
        count: usize,
        /// Largest principal spread (mm).
        largest: f64,
        /// Smallest principal spread (mm).
        smallest: f64,
    },
    /// Tracer: every reading of a station is zero.
    #[error("station '{station}': all its readings are zero")]
    StationZero {
        /// The station.
        station: String,
    },
    /// Tracer: the seed's linear start of a station has no solution.
    #[error("station '{station}': {reason}")]
    StationStart {
        /// The station.
        station: String,
        /// The solver's reason.
        reason: &'static str,
    },
    /// Tracer: a point at a station's position.
    #[error("point '{point}' coincides with station '{station}'")]
    PointAtStation {
        /// The point.
        point: String,
        /// The station.
        station: String,
    },
    /// Tracer: the directions from a point to its stations lie in a plane.
    #[error("point '{point}': the directions to its stations do not span three dimensions")]
    PointDirectionsFlat {
        /// The point.
        point: String,
    },
    /// Tracer: the regularised reduced normal matrix of a step is not positive definite.
    #[error("{REDUCED_NORMAL} is not positive definite")]
    ReducedNotPositive,
    /// Tracer: the reduced normal matrix is singular at the solution.
    #[error("the reduced normal matrix is singular at the solution")]
    ReducedSingular,
    /// Tracer: collinear grid points allow no rigid alignment.
    #[error("the grid points are collinear: no rigid alignment")]
    CollinearGrid,
    /// Tracer: no redundancy to estimate σ of a reading.
    #[error(
        "{readings} readings for {unknowns} unknowns: no redundancy to estimate the \
         uncertainty of a reading (give it a priori, or add readings)"
    )]
    NoRedundancy {
        /// Readings.
        readings: usize,
        /// Unknowns.
        unknowns: usize,
    },
    /// Volumetric: a curve fit's triangular factor is singular.
    #[error("{fit}: singular triangular factor")]
    SingularFactor {
        /// The fit.
        fit: String,
    },
    /// Volumetric: a position outside the travel a series was fitted on.
    #[error("{position_mm} mm outside a fitted travel")]
    OutsideFit {
        /// The position (mm).
        position_mm: f64,
    },
}

/// Result alias for `probe`.
pub type Result<T> = std::result::Result<T, ProbeError>;

#[cfg(test)]
mod tests {
    use super::*;

    /// The typed reasons read as the messages they replace.
    #[test]
    fn messages_keep_their_wording() {
        let curve = |fault| {
            ProbeError::Curve {
                axis: Axis::Y,
                fault,
            }
            .to_string()
        };
        assert_eq!(
            curve(CurveFault::TooFewPositions { count: 1 }),
            "axis Y: 1 measured position(s): a curve needs at least 2"
        );
        assert_eq!(
            curve(CurveFault::NotIncreasing {
                point: 3,
                position: 10.0,
                previous: 20.5
            }),
            "axis Y, point 3, column 'position': positions must increase: 10 mm follows 20.5 mm"
        );
        let chain = |fault| ProbeError::Chain {
            text: "WXFT".into(),
            fault,
        };
        assert_eq!(
            chain(ChainFault::Letter {
                position: 2,
                letter: 'Q'
            })
            .to_string(),
            "--chain 'WXFT': letter 2 'Q' is none of W, X, Y, Z, F, T"
        );
        assert_eq!(
            chain(ChainFault::Repeated {
                letter: 'F',
                name: "frame",
                count: 2
            })
            .to_string(),
            "--chain 'WXFT': F (frame) appears 2 times"
        );
        assert_eq!(
            chain(ChainFault::SweptOnToolSide {
                axis: Axis::Z,
                report: "r/report.json".into()
            })
            .to_string(),
            "--chain 'WXFT': axis Z of r/report.json moved the table that carries the spheres, so \
             it must be between W and F (e.g. WXYFZT)"
        );
        let e = ProbeError::from(Unsolvable::TooFewBalls {
            names: vec!["A".into(), "B".into()],
        });
        assert_eq!(
            e.to_string(),
            "2 ball(s) (A, B): the six errors need at least 3 balls not on one line"
        );
        assert_eq!(
            Unsolvable::ReducedNotPositive.to_string(),
            "the reduced normal matrix of the station unknowns (stations and dead paths weakly \
             determined by the layout, or readings in groups that share too few points) is not \
             positive definite"
        );
        let planar = Unsolvable::StationPlanar {
            station: "S1".into(),
            count: 8,
            largest: 100.0,
            smallest: 0.0,
        };
        assert_eq!(
            planar.to_string(),
            "station 'S1' reads 8 points that lie in one plane (principal spreads 1.000e2 and \
             0.000e0 mm): the grid must be three-dimensional, or the station and its mirror image \
             in that plane fit the readings equally"
        );
        let few = Unsolvable::TooFewReadings {
            readings: 10,
            unknowns: 30,
            points: 8,
            stations: 4,
        };
        let sparse = ProbeError::NotLattice(LatticeFault::SparseLevel {
            point: 3,
            name: "P4".into(),
            axis: 1,
            value: 12.5,
            count: 1,
            most: 9,
        });
        assert_eq!(
            sparse.to_string(),
            "the grid is not a lattice: point 'P4' has y = 12.5, a value 1 point(s) share where \
             the grid's other y levels hold up to 9"
        );
        let missing = LatticeFault::MissingNode {
            points: 26,
            dims: [3, 3, 3],
            cells: 27,
            node: [0.0, 50.0, 100.0],
        };
        assert_eq!(
            missing.to_string(),
            "26 points where the 3×3×3 lattice has 27: no point at (0, 50, 100)"
        );
        assert_eq!((missing.point(), missing.axis()), (None, None));
        let ill = ProbeError::IllConditioned {
            what: Conditioning::StationStart {
                station: "S2".into(),
                count: 12,
            },
            condition: 2.5e11,
            limit: 1e10,
        };
        assert_eq!(
            ill.to_string(),
            "station 'S2': the seed's linearised start from its 12 points (its readings do not \
             tell its distance from the grid): condition number 2.500e11 exceeds 1.0e10"
        );
        let displaced = ProbeError::Centre {
            ball: "1".into(),
            angle_deg: 30.0,
            fault: CentreFault::Displaced {
                distance_mm: 5.17638,
                angle_deg: 30.0,
                clockwise: true,
            },
        };
        assert_eq!(
            displaced.to_string(),
            "ball 1 at 30°: the centre lies 5.176 mm from its 0° centre turned by 30° about Z \
             (more than 2 mm: the small-error model does not apply): it matches a clockwise \
             turn: angles count counter-clockwise seen from +Z"
        );
        let fit = ProbeError::Centre {
            ball: "B".into(),
            angle_deg: 90.0,
            fault: CentreFault::SphereFit(Box::new(Unsolvable::NoPositions.into())),
        };
        assert_eq!(fit.to_string(), "ball B at 90°: sphere fit: no positions");
        assert_eq!(
            Conditioning::CentresSphere.to_string(),
            "sphere through the centres (the positions lie too near a plane or a small cap: \
             measure B turns at several A)"
        );
        assert_eq!(
            few.to_string(),
            "10 readings for 30 unknowns (3·8 point coordinates + 4·4 station unknowns − 6 rigid \
             freedoms): at least as many readings as unknowns are needed"
        );
    }
}
