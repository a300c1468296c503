//! CMM volumetric correction by laser-tracer multilateration (docs/probe-tracer.md,
//! seed 003).
//!
//! A laser tracer at m stations Pⱼ reads, interferometrically, its distance
//! to a target moved by the CMM to n nominal grid points Aᵢ, each reading
//! lᵢⱼ relative to the station's first point: `|Aᵢ − Pⱼ| = dⱼ + lᵢⱼ`, dⱼ the
//! dead path. [`solve`] finds every point, station and dead path:
//!
//! 1. **Layout** ([`solve`] refuses before solving): at least 4 stations; as
//!    many readings as unknowns, `m·n ≥ 4m + 3n − 6` with missing readings
//!    counted; every station reading at least [`MIN_STATION_READINGS`]
//!    points, every point read by at least [`MIN_POINT_STATIONS`] stations;
//!    the grid three-dimensional; and, at the start, no point whose
//!    directions to its stations are (nearly) coplanar — stations in a plane
//!    with the point — and no weak station geometry: condition numbers above
//!    [`CONDITION_LIMIT`] are refused with their value.
//! 2. **Stations** (the seed's step 1): squaring the model with
//!    `k = Xⱼ² + Yⱼ² + Zⱼ² − dⱼ²` makes it linear in (Xⱼ, Yⱼ, Zⱼ, dⱼ, k);
//!    linear least squares per station from the nominal points.
//! 3. **Everything** (the seed's step 2): Gauss–Newton (with Levenberg–
//!    Marquardt damping when a step would raise the cost) on the residuals
//!    `vᵢⱼ = |Aᵢ − Pⱼ| − dⱼ − lᵢⱼ` over all 3n + 4m unknowns. The normal
//!    equations are block-sparse: each point couples only to its stations.
//!    The 3×3 point blocks are eliminated (Schur complement onto the 4m
//!    station unknowns), the reduced system is solved by Cholesky, points
//!    follow by back-substitution — memory and time linear in n. The six
//!    rigid-body freedoms are not observable (the reduced matrix has a
//!    six-dimensional null space, the rigid motions of the stations): each
//!    step is the minimum-norm one in the station unknowns (inner
//!    constraints). Converged when the largest step is below
//!    [`STEP_TOLERANCE_MM`] or the cost falls by less than
//!    [`COST_TOLERANCE`] of itself.
//! 4. **Datum**: the estimated points are rigidly aligned (least
//!    squares, `geom::transform::rigid_fit`) to the nominal grid; corrections
//!    = aligned − nominal carry no rigid motion, and the length scale is the
//!    interferometer's. Stations are reported in the same frame. The
//!    covariance follows the same datum (an S-transformation: the projector
//!    that removes the least-squares rigid motion of the points), giving
//!    each correction's and each station's standard uncertainty.
//! 5. **Residuals**: each reading's residual, normalised by its own standard
//!    deviation `σ·√r` (r its redundancy number), flagged when
//!    `|w| > k` — reported, never dropped; weakly determined points and
//!    stations are named.
//!
//! [`CorrectionGrid`] interpolates corrections trilinearly inside the cells
//! of a lattice grid (`--query`); [`TracerReport`] is `report.json`;
//! [`uncertainty()`] gives U (k = 2) of its figures by Monte Carlo;
//! [`html`] writes `report.html`.
//!
//! # Conventions
//! - Lengths in millimetres in the API and the files, micrometres (`_um`) in
//!   the report; all geometry in `f64`.
//! - Correction = true − nominal, after removing the rigid motion that best
//!   aligns (least squares, equal weights) the estimated points with the
//!   nominal grid; stations and dead paths are in that frame.
//! - Readings have equal weight; their standard deviation is estimated from
//!   the residuals (`σ̂² = Σv² / (N − (3n + 4m − 6))`) unless given.
//! - Stations are numbered in the order the caller gives them (the CLI: first
//!   appearance in `readings.csv`), points in grid order.

mod datum;
mod html;
mod lattice;
mod normal;
mod report;
mod start;
mod uncertainty;
mod view;

use geom::nalgebra::{Point3, Vector3};

use crate::{ProbeError, Result, TracerFault};

pub use html::html;
pub use lattice::CorrectionGrid;
pub use report::{
    OutlierReading, Outliers, StationReport, TracerReport, WeakItem, Weakness, report,
};
pub use uncertainty::uncertainty;

/// Fewest stations: with three, each point is only just determined and
/// `m·n ≥ 4m + 3n − 6` fails for every n.
pub const MIN_STATIONS: usize = 4;
/// Fewest readings of one station: the seed's linearised start has five
/// unknowns (Xⱼ, Yⱼ, Zⱼ, dⱼ, k).
pub const MIN_STATION_READINGS: usize = 5;
/// Fewest stations reading one point: its three coordinates.
pub const MIN_POINT_STATIONS: usize = 3;
/// Largest accepted condition number — of a station's linearised start, of
/// a point's direction matrix `Σ uᵢⱼuᵢⱼᵀ`, and of the reduced normal matrix:
/// beyond it an unknown is amplified by more than 10⁵ (√ of it) and is
/// effectively unobservable.
pub const CONDITION_LIMIT: f64 = 1e10;
/// Convergence: largest step of any unknown (mm), 1 pm.
pub const STEP_TOLERANCE_MM: f64 = 1e-9;
/// Convergence: relative decrease of the cost `Σv²` below which a step is
/// no longer worth taking.
pub const COST_TOLERANCE: f64 = 1e-12;
/// Default k of the outlier flag `|w| > k` on normalised residuals.
pub const OUTLIER_K: f64 = 3.0;
/// A point or station whose uncertainty exceeds this multiple of the median
/// is reported as weakly determined.
pub const WEAK_FACTOR: f64 = 3.0;

/// One interferometric reading: station and point (positions in
/// [`Network::station_names`] and [`Network::points`]) and the length `l`
/// relative to the station's first point (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Station index.
    pub station: usize,
    /// Point index.
    pub point: usize,
    /// Reading (mm).
    pub l: f64,
}

/// The measured network: nominal grid, station names and readings.
#[derive(Debug, Clone, PartialEq)]
pub struct Network {
    /// Nominal grid points (CMM coordinates, mm).
    pub points: Vec<Point3<f64>>,
    /// Names of the points (same order), used in messages and the report.
    pub point_names: Vec<String>,
    /// Names of the stations.
    pub station_names: Vec<String>,
    /// The readings, in any order; at most one per (station, point).
    pub readings: Vec<Reading>,
}

impl Network {
    /// The network of a checked `grid.csv` and `readings.csv` (stations in
    /// order of first appearance, points in grid order).
    pub fn from_records(
        grid: &formats::probe::tracer::Grid,
        readings: &formats::probe::tracer::Readings,
    ) -> Network {
        Network {
            points: grid
                .rows
                .iter()
                .map(|r| Point3::from(r.record.position()))
                .collect(),
            point_names: grid.rows.iter().map(|r| r.record.point.clone()).collect(),
            station_names: readings.stations.clone(),
            readings: readings
                .rows
                .iter()
                .enumerate()
                .map(|(k, r)| Reading {
                    station: readings.station_of[k],
                    point: readings.point_of[k],
                    l: r.record.l,
                })
                .collect(),
        }
    }

    /// Unknowns after the datum: `3n + 4m − 6` (docs/probe-tracer.md).
    pub fn unknowns(&self) -> usize {
        (3 * self.points.len() + 4 * self.station_names.len()).saturating_sub(6)
    }
}

/// Settings of [`solve`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// k of the outlier flag `|w| > k` on normalised residuals.
    pub outlier_k: f64,
    /// Standard deviation of a reading (mm), when known a priori; otherwise
    /// estimated from the residuals.
    pub sigma_mm: Option<f64>,
    /// Most Gauss–Newton iterations.
    pub max_iterations: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            outlier_k: OUTLIER_K,
            sigma_mm: None,
            max_iterations: 100,
        }
    }
}

/// A grid point's correction (true − nominal, no rigid motion) and its
/// standard uncertainties (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correction {
    /// Correction vector (mm).
    pub vector: Vector3<f64>,
    /// Standard uncertainties of its components (mm).
    pub u: Vector3<f64>,
}

/// An estimated station in the frame of the nominal grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Station {
    /// Position (mm).
    pub position: Point3<f64>,
    /// Dead path `dⱼ` (mm).
    pub dead_path: f64,
    /// Standard uncertainties of the position components (mm).
    pub u_position: Vector3<f64>,
    /// Standard uncertainty of the dead path (mm).
    pub u_dead_path: f64,
    /// Number of readings.
    pub readings: usize,
    /// RMS of its residuals (mm).
    pub residual_rms: f64,
}

/// A reading after the solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residual {
    /// Residual `|Aᵢ − Pⱼ| − dⱼ − lᵢⱼ` (mm).
    pub value: f64,
    /// Redundancy number r (0…1): the share of an error in this reading
    /// that shows in its residual.
    pub redundancy: f64,
    /// Normalised residual `v / (σ_w·√r)` (0 where r is 0: not testable).
    pub normalized: f64,
    /// `|normalized| > k`.
    pub outlier: bool,
}

/// A weakly determined point or station: its index and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Weak {
    /// Point or station index.
    pub index: usize,
    /// What makes it weak.
    pub reason: String,
}

/// The solution of the network and what is known about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Per grid point, in grid order.
    pub corrections: Vec<Correction>,
    /// Per station.
    pub stations: Vec<Station>,
    /// Per reading, in the caller's order.
    pub residuals: Vec<Residual>,
    /// Gauss–Newton iterations (linearisations that produced a step).
    pub iterations: usize,
    /// Largest step of the last iteration (mm).
    pub last_step: f64,
    /// RMS of the residuals (mm).
    pub residual_rms: f64,
    /// A-posteriori standard deviation of a reading, `√(Σv² / redundancy)` (mm).
    pub sigma0: f64,
    /// Standard deviation the uncertainties use: a priori if given, else `sigma0` (mm).
    pub sigma: f64,
    /// Whether `sigma` was given a priori.
    pub sigma_a_priori: bool,
    /// Robust scale of the residuals for the outlier flag, `1.4826·median|v/√r|` (mm).
    pub sigma_outliers: f64,
    /// k of the outlier flag.
    pub outlier_k: f64,
    /// Readings expected beyond k by chance alone: testable readings ×
    /// P(|z| > k) for normal errors, `erfc(k/√2)`.
    pub outliers_by_chance: f64,
    /// Readings minus unknowns.
    pub redundancy: usize,
    /// Unknowns after the datum, `3n + 4m − 6`.
    pub unknowns: usize,
    /// Readings.
    pub equations: usize,
    /// Condition number of the reduced normal matrix (station unknowns, the
    /// six rigid freedoms removed) at the solution.
    pub condition: f64,
    /// The point whose direction matrix `Σ uuᵀ` is worst conditioned, and its condition number.
    pub worst_point: (usize, f64),
    /// Weakly determined points.
    pub weak_points: Vec<Weak>,
    /// Weakly determined stations.
    pub weak_stations: Vec<Weak>,
}

/// Solve the network: check the layout, start the stations by the seed's
/// linearised least squares, run Gauss–Newton with the Schur complement,
/// align to the nominal grid and propagate the covariance (docs/probe-tracer.md).
pub fn solve(network: &Network, options: &Options) -> Result<Solution> {
    check_options(options)?;
    let structure = normal::Structure::new(network)?;
    let stations = start::stations(network, &structure)?;
    let mut state = normal::State {
        points: network.points.iter().map(|p| p.coords).collect(),
        stations,
    };
    normal::check_conditioning(network, &structure, &state)?;
    let (iterations, last_step) =
        normal::gauss_newton(network, &structure, &mut state, options.max_iterations)?;
    datum::finish(network, &structure, &state, options, iterations, last_step)
}

fn check_options(options: &Options) -> Result<()> {
    if !(options.outlier_k.is_finite() && options.outlier_k > 0.0) {
        return Err(ProbeError::Tracer(TracerFault::OutlierK {
            k: options.outlier_k,
        }));
    }
    if let Some(s) = options.sigma_mm
        && !(s.is_finite() && s > 0.0)
    {
        return Err(ProbeError::Tracer(TracerFault::Sigma { sigma_mm: s }));
    }
    if options.max_iterations == 0 {
        return Err(ProbeError::Tracer(TracerFault::NoIterations));
    }
    Ok(())
}
