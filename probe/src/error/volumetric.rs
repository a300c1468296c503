//! The volumetric method's faults, reasons of [`super::ProbeError`].

use formats::Axis;
use formats::probe::volumetric::Series;
use thiserror::Error;

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
