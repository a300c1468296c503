//! The one error type of `probe`.

use formats::Axis;
use formats::probe::volumetric::Series;
use thiserror::Error;

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

/// What is wrong with a kinematic chain string `W a1 … ak F b1 … bl T`.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ChainFault {
    /// A letter that is none of W, X, Y, Z, F, T.
    #[error("letter {position} '{letter}' is none of W, X, Y, Z, F, T")]
    Letter {
        /// Its position, 1-based.
        position: usize,
        /// The letter (upper case).
        letter: char,
    },
    /// No W, F or T.
    #[error("no {letter} ({name}) in the chain")]
    Missing {
        /// W, F or T.
        letter: char,
        /// `workpiece`, `frame` or `tool`.
        name: &'static str,
    },
    /// W, F or T more than once.
    #[error("{letter} ({name}) appears {count} times")]
    Repeated {
        /// W, F or T.
        letter: char,
        /// `workpiece`, `frame` or `tool`.
        name: &'static str,
        /// How often.
        count: usize,
    },
    /// The first letter is not W.
    #[error("the chain must start with W (the workpiece)")]
    NoStartW,
    /// The last letter is not T.
    #[error("the chain must end with T (the tool)")]
    NoEndT,
    /// An axis more than once.
    #[error("axis {axis} appears {count} times")]
    RepeatedAxis {
        /// The axis.
        axis: Axis,
        /// How often.
        count: usize,
    },
    /// A swept axis of a vision campaign on the tool side (`--from-report`):
    /// the spheres ride on the table.
    #[error(
        "axis {axis} of {report} moved the table that carries the spheres, so it must be \
         between W and F (e.g. WXYFZT)"
    )]
    SweptOnToolSide {
        /// The axis.
        axis: Axis,
        /// The campaign's report (where it was read).
        report: String,
    },
}

/// What is wrong with the measured curves of one axis; each reads as the
/// place within the axis's curves (point 1-based), then the fault.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CurveFault {
    /// Fewer than two positions.
    #[error(": {count} measured position(s): a curve needs at least 2")]
    TooFewPositions {
        /// Positions measured.
        count: usize,
    },
    /// A column with another number of values than positions.
    #[error(", column '{column}': {values} values for {positions} positions")]
    Length {
        /// The column (`ex` … `ec`, `positioning_up`, `positioning_down`).
        column: &'static str,
        /// Its values.
        values: usize,
        /// The positions.
        positions: usize,
    },
    /// A value that is not finite.
    #[error(", point {point}, column '{column}': value {value} is not a finite number")]
    NotFinite {
        /// The point (1-based).
        point: usize,
        /// The column.
        column: &'static str,
        /// The value.
        value: f64,
    },
    /// A position that is not finite.
    #[error(", point {point}, column 'position': position {value} is not a finite number")]
    PositionNotFinite {
        /// The point (1-based).
        point: usize,
        /// The position (mm).
        value: f64,
    },
    /// Positions not strictly increasing.
    #[error(
        ", point {point}, column 'position': positions must increase: {position} mm follows \
         {previous} mm"
    )]
    NotIncreasing {
        /// The point (1-based).
        point: usize,
        /// Its position (mm).
        position: f64,
        /// The position before it (mm).
        previous: f64,
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

/// What an evaluate report lacks for the curves of `--from-report`, each
/// reading as the report's key, then the fault.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CampaignFault {
    /// A key under `axes` that is not X, Y or Z.
    #[error("axes.{name}: not an axis X, Y or Z")]
    NotAnAxis {
        /// The key.
        name: String,
    },
    /// No axis at all.
    #[error("axes: no axis was evaluated")]
    NoAxis,
    /// An axis without roll, pitch and yaw.
    #[error(
        "axes.{axis}.angular: missing: roll, pitch and yaw need three spheres measured at every \
         target"
    )]
    NoAngular {
        /// The axis.
        axis: Axis,
    },
    /// No flatness points.
    #[error(
        "flatness.points: missing: the sphere centres per target are needed for the Abbe offsets"
    )]
    NoFlatness,
    /// An axis without its straightness across another.
    #[error("axes.{axis}.straightness.{across}: missing")]
    NoStraightness {
        /// The axis.
        axis: Axis,
        /// The direction across it.
        across: Axis,
    },
    /// A table of an axis without a value at a target.
    #[error("axes.{axis}.{table}: no value for target {target}")]
    NoValue {
        /// The axis.
        axis: Axis,
        /// The table (`straightness`, `angular.targets`, `flatness points`).
        table: &'static str,
        /// The target.
        target: u32,
    },
    /// A target without a mean positioning deviation.
    #[error("axes.{axis}.positioning.targets: target {target} has no mean deviation")]
    NoMean {
        /// The axis.
        axis: Axis,
        /// The target.
        target: u32,
    },
    /// Two targets at one position.
    #[error(
        "axes.{axis}.positioning.targets: two targets at {position} mm: positions must increase"
    )]
    TwoTargets {
        /// The axis.
        axis: Axis,
        /// The position (mm).
        position: f64,
    },
    /// Fewer than two targets.
    #[error("axes.{axis}.positioning.targets: {count} target(s): a curve needs at least 2")]
    TooFewTargets {
        /// The axis.
        axis: Axis,
        /// The targets.
        count: usize,
    },
    /// A fitted direction that is the zero vector.
    #[error("axes.{axis}.direction: zero vector")]
    ZeroDirection {
        /// The axis.
        axis: Axis,
    },
}

/// What the volumetric model refuses: its set-up, or a position it cannot
/// evaluate. A fit is named as the fits name it (e.g. `axis X, ey, fourier`).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum VolumetricFault {
    /// `--order 0`.
    #[error("--order: the order N must be at least 1")]
    OrderZero,
    /// Fewer points than a series of that order has coefficients.
    #[error(
        "{fit}: {points} points, fewer than the {coefficients} coefficients of a {} of order \
         {order}",
        .series.name()
    )]
    TooFewForOrder {
        /// The fit.
        fit: String,
        /// Points of the curve.
        points: usize,
        /// Coefficients of the series, 2N + 1.
        coefficients: usize,
        /// The series.
        series: Series,
        /// The order N.
        order: usize,
    },
    /// Too few points for `--order auto` to cross-validate any order.
    #[error(
        "{fit}: {points} points leave no {} order to cross-validate (order 1 needs {})",
        .series.name(),
        crate::volumetric::POINTS_PER_COEFFICIENT * 3
    )]
    NothingToCrossValidate {
        /// The fit.
        fit: String,
        /// Points of the curve.
        points: usize,
        /// The series.
        series: Series,
    },
    /// A position outside the measured travel of an axis.
    #[error(
        "axis {axis} at {position} mm: outside the measured travel [{lo}, {hi}] mm: the model \
         does not extrapolate"
    )]
    OutsideTravel {
        /// The axis.
        axis: Axis,
        /// The position (mm).
        position: f64,
        /// Start of the measured travel (mm).
        lo: f64,
        /// Its end (mm).
        hi: f64,
    },
    /// Curves of one axis given twice.
    #[error("axis {axis}: given twice")]
    AxisTwice {
        /// The axis.
        axis: Axis,
    },
    /// An axis of the chain without curves.
    #[error(
        "axis {axis}: in the chain {chain} but without error curves (give its curves, or leave it \
         out of --chain)"
    )]
    ChainAxisWithoutCurves {
        /// The axis.
        axis: Axis,
        /// The chain.
        chain: String,
    },
    /// Curves of an axis that is not in the chain.
    #[error("axis {axis}: has error curves but is not in the chain {chain} (add it to --chain)")]
    CurvesOffChain {
        /// The axis.
        axis: Axis,
        /// The chain.
        chain: String,
    },
    /// A tool offset that is not three finite numbers.
    #[error("--tool: not three finite numbers")]
    ToolNotFinite,
    /// A carriage position that is not finite.
    #[error("position {}: {value} is not a finite number", .axis.name().to_lowercase())]
    PositionNotFinite {
        /// The axis.
        axis: Axis,
        /// The position (mm).
        value: f64,
    },
    /// A non-zero position of an axis outside the chain.
    #[error(
        "position {}: {value} mm, but axis {axis} is not in the chain {chain}: it must be 0",
        .axis.name().to_lowercase()
    )]
    PositionOffChain {
        /// The axis.
        axis: Axis,
        /// The position (mm).
        value: f64,
        /// The chain.
        chain: String,
    },
    /// An axis evaluated without curves.
    #[error("axis {axis}: without error curves")]
    NoCurves {
        /// The axis.
        axis: Axis,
    },
    /// A workpiece point that needs an axis outside the chain.
    #[error(
        "workpiece point ({}, {}, {}): needs axis {axis}, which is not in the chain {chain} (the \
         tool stays at {} = {tool_mm} mm)",
        .point[0],
        .point[1],
        .point[2],
        .axis.name().to_lowercase()
    )]
    PointOffChain {
        /// The point (mm, workpiece frame).
        point: [f64; 3],
        /// The axis.
        axis: Axis,
        /// The chain.
        chain: String,
        /// The tool's coordinate on that axis (mm).
        tool_mm: f64,
    },
    /// A circle of no positive finite radius (or a centre not finite).
    #[error("--circle: radius {radius} must be a positive finite number")]
    CircleRadius {
        /// The radius (mm).
        radius: f64,
    },
    /// A circle in XY with the chain lacking X or Y.
    #[error(
        "--circle: a circle in the plane XY needs axis {axis}, which is not in the chain {chain}"
    )]
    CircleOffChain {
        /// The axis.
        axis: Axis,
        /// The chain.
        chain: String,
    },
    /// A circle whose path leaves an axis's measured travel.
    #[error(
        "--circle: the circle leaves the measured travel: axis {axis} would run from {from} to \
         {to} mm, measured from {lo} to {hi} mm"
    )]
    CircleOutsideTravel {
        /// The axis.
        axis: Axis,
        /// Smallest position of the path (mm).
        from: f64,
        /// Largest (mm).
        to: f64,
        /// Start of the measured travel (mm).
        lo: f64,
        /// Its end (mm).
        hi: f64,
    },
}

/// What is wrong with the tracer's network (readings named by their
/// position, 1-based), its options or a query point.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TracerFault {
    /// Point names and points of different counts.
    #[error("point names: {names} names for {points} points")]
    NameCount {
        /// Names.
        names: usize,
        /// Points.
        points: usize,
    },
    /// A nominal point with a coordinate that is not finite.
    #[error("point '{point}': nominal coordinates are not finite")]
    PointNotFinite {
        /// The point's name.
        point: String,
    },
    /// A reading of a station that does not exist.
    #[error("reading {reading}: station index {station} of {stations}")]
    StationIndex {
        /// The reading.
        reading: usize,
        /// Its station index.
        station: usize,
        /// The stations.
        stations: usize,
    },
    /// A reading of a point that does not exist.
    #[error("reading {reading}: point index {point} of {points}")]
    PointIndex {
        /// The reading.
        reading: usize,
        /// Its point index.
        point: usize,
        /// The points.
        points: usize,
    },
    /// A reading that is not finite.
    #[error("reading {reading}: reading {value} is not finite")]
    ReadingNotFinite {
        /// The reading.
        reading: usize,
        /// Its value (mm).
        value: f64,
    },
    /// A second reading of one point from one station.
    #[error("reading {reading}: station '{station}' already has a reading of point '{point}'")]
    DuplicateReading {
        /// The reading.
        reading: usize,
        /// The station.
        station: String,
        /// The point.
        point: String,
    },
    /// An outlier limit k that is not a positive number.
    #[error("outlier k: {k} is not a positive number")]
    OutlierK {
        /// The k given.
        k: f64,
    },
    /// An a-priori σ of a reading that is not a positive number.
    #[error("a-priori σ of a reading: {sigma_mm} mm is not a positive number")]
    Sigma {
        /// The σ given (mm).
        sigma_mm: f64,
    },
    /// No iterations allowed.
    #[error("iterations: at least one iteration is needed")]
    NoIterations,
    /// A query point outside the grid on an axis (0, 1, 2 = x, y, z).
    #[error(
        "query ({}, {}, {}): {} = {} is outside the grid [{lo}, {hi}]",
        .query[0],
        .query[1],
        .query[2],
        axis_name(.axis),
        .query[*.axis]
    )]
    QueryOutside {
        /// The query point (mm).
        query: [f64; 3],
        /// The axis.
        axis: usize,
        /// The grid's smallest value on it (mm).
        lo: f64,
        /// Its largest (mm).
        hi: f64,
    },
}

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

/// Why a nominal grid is not a lattice. Points are named by their position
/// among the points (`point`) and their name; axes by 0, 1, 2 = x, y, z.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LatticeFault {
    /// Points, names and corrections of different lengths.
    #[error("{points} points, {names} names, {corrections} corrections")]
    Lengths {
        /// Points.
        points: usize,
        /// Names.
        names: usize,
        /// Corrections.
        corrections: usize,
    },
    /// One value on an axis.
    #[error(
        "all points share one {} value: a lattice needs at least two per axis",
        axis_name(.axis)
    )]
    OneLevel {
        /// The axis.
        axis: usize,
    },
    /// A value shared by too few points: a point off the lattice.
    #[error(
        "point '{name}' has {} = {value}, a value {count} point(s) share where the grid's \
         other {} levels hold up to {most}",
        axis_name(.axis),
        axis_name(.axis)
    )]
    SparseLevel {
        /// The first point with the value.
        point: usize,
        /// Its name.
        name: String,
        /// The axis.
        axis: usize,
        /// The value (mm).
        value: f64,
        /// Points with the value.
        count: usize,
        /// Most points with one value of the axis.
        most: usize,
    },
    /// The values of an axis not equally spaced.
    #[error(
        "the {} values are not equally spaced: point '{name}' has {value} where a step of \
         {step} puts {expected}",
        axis_name(.axis)
    )]
    Uneven {
        /// The first point with the value.
        point: usize,
        /// Its name.
        name: String,
        /// The axis.
        axis: usize,
        /// The value (mm).
        value: f64,
        /// The step (mm).
        step: f64,
        /// The value the step puts there (mm).
        expected: f64,
    },
    /// Far more lattice nodes than points.
    #[error(
        "{points} points span {}×{}×{} lattice values: most nodes of such a lattice would \
         have no point",
        .dims[0],
        .dims[1],
        .dims[2]
    )]
    MostlyEmpty {
        /// Points.
        points: usize,
        /// Lattice values per axis.
        dims: [usize; 3],
    },
    /// A coordinate between two lattice values.
    #[error(
        "point '{name}' has {} = {value} between the lattice values",
        axis_name(.axis)
    )]
    BetweenValues {
        /// The point.
        point: usize,
        /// Its name.
        name: String,
        /// The axis.
        axis: usize,
        /// The coordinate (mm).
        value: f64,
    },
    /// Two points on one node.
    #[error("point '{name}' falls on a lattice node already taken")]
    NodeTaken {
        /// The point.
        point: usize,
        /// Its name.
        name: String,
    },
    /// A node without a point.
    #[error(
        "{points} points where the {}×{}×{} lattice has {cells}: no point at ({}, {}, {})",
        .dims[0],
        .dims[1],
        .dims[2],
        .node[0],
        .node[1],
        .node[2]
    )]
    MissingNode {
        /// Points.
        points: usize,
        /// Lattice values per axis.
        dims: [usize; 3],
        /// Nodes.
        cells: usize,
        /// The node without a point (mm).
        node: [f64; 3],
    },
}

impl LatticeFault {
    /// The point at fault (its position among the points), when one is.
    pub fn point(&self) -> Option<usize> {
        match self {
            Self::SparseLevel { point, .. }
            | Self::Uneven { point, .. }
            | Self::BetweenValues { point, .. }
            | Self::NodeTaken { point, .. } => Some(*point),
            Self::Lengths { .. }
            | Self::OneLevel { .. }
            | Self::MostlyEmpty { .. }
            | Self::MissingNode { .. } => None,
        }
    }

    /// Its coordinate at fault (0, 1, 2 = x, y, z), when one is.
    pub fn axis(&self) -> Option<usize> {
        match self {
            Self::OneLevel { axis }
            | Self::SparseLevel { axis, .. }
            | Self::Uneven { axis, .. }
            | Self::BetweenValues { axis, .. } => Some(*axis),
            Self::Lengths { .. }
            | Self::MostlyEmpty { .. }
            | Self::NodeTaken { .. }
            | Self::MissingNode { .. } => None,
        }
    }
}

/// The name of axis 0, 1, 2 in messages.
fn axis_name(axis: &usize) -> &'static str {
    ["x", "y", "z"].get(*axis).copied().unwrap_or("?")
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
