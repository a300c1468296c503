//! The tracer method's faults, reasons of [`super::ProbeError`].

use thiserror::Error;

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
