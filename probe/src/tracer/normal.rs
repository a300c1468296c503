//! The layout of the network, its normal equations and Gauss–Newton.
//!
//! Residual `vᵢⱼ = |Aᵢ − Pⱼ| − dⱼ − lᵢⱼ`; with `a = (Aᵢ − Pⱼ)/|Aᵢ − Pⱼ|` its
//! Jacobian row is `aᵀ` on point i and `−ãᵀ`, `ã = (a, 1)`, on station j's
//! (X, Y, Z, d). The normal matrix `JᵀJ = [U W; Wᵀ V]` has 3×3 blocks
//! `Uᵢ = Σⱼ aaᵀ` on the points, 4×4 blocks `Vⱼ = Σᵢ ããᵀ` on the stations and
//! couplings `Wᵢⱼ = −aãᵀ`. Eliminating the points gives the reduced
//! (Schur complement) system on the 4m station unknowns,
//! `S = V − WᵀU⁻¹W`, `S·δs = g_s − WᵀU⁻¹g_p`, then
//! `δAᵢ = Uᵢ⁻¹(g_pᵢ − Wᵢ·δs)`. S is singular in the six rigid motions of
//! the stations; `(S + λQQᵀ)`, Q an orthonormal basis of them, gives the
//! minimum-norm solution (inner constraints on the stations).
//!
//! Sums run over fixed chunks of points in parallel, and the chunks' partial
//! sums are added in chunk order: results do not depend on the thread count.

use std::collections::HashSet;

use geom::nalgebra::{DMatrix, DVector, Matrix3, SymmetricEigen, Vector3, Vector4};
use rayon::prelude::*;

use super::{
    CONDITION_LIMIT, COST_TOLERANCE, MIN_POINT_STATIONS, MIN_STATION_READINGS, MIN_STATIONS,
    Network, STEP_TOLERANCE_MM,
};
use crate::{Conditioning, ProbeError, Result, TracerFault, Unsolvable};

/// Points per chunk of the parallel sums (fixed, so that the order of the
/// floating-point additions never depends on the thread count).
pub(super) const CHUNK: usize = 256;
/// Damping of the first Levenberg–Marquardt retry, relative to the mean
/// diagonal of the point blocks.
const DAMPING_START: f64 = 1e-6;
/// Damping beyond which no step lowers the cost: the iteration has failed.
const DAMPING_LIMIT: f64 = 1e8;
/// A station closer than this to a point (mm) leaves the direction undefined.
const MIN_DISTANCE_MM: f64 = 1e-6;

/// The readings arranged by point: entries `start[i]..start[i + 1]` are
/// point i's readings, sorted by station.
#[derive(Debug, Clone)]
pub(super) struct Structure {
    /// Number of points.
    pub n: usize,
    /// Number of stations.
    pub m: usize,
    /// Entry range of each point (n + 1 offsets).
    pub start: Vec<usize>,
    /// Station of each entry.
    pub station_of: Vec<usize>,
    /// The caller's reading index of each entry.
    pub reading_of: Vec<usize>,
    /// Reading of each entry (mm).
    pub l: Vec<f64>,
    /// Readings per station.
    pub station_readings: Vec<usize>,
}

fn fault(f: TracerFault) -> ProbeError {
    ProbeError::Tracer(f)
}

impl Structure {
    /// Check the network (names, finite values, indices, duplicates) and the
    /// counts of docs/probe-tracer.md, then arrange the readings by point.
    pub(crate) fn new(net: &Network) -> Result<Structure> {
        let (n, m) = (net.points.len(), net.station_names.len());
        if net.point_names.len() != n {
            return Err(fault(TracerFault::NameCount {
                names: net.point_names.len(),
                points: n,
            }));
        }
        for (i, p) in net.points.iter().enumerate() {
            if !p.iter().all(|v| v.is_finite()) {
                return Err(fault(TracerFault::PointNotFinite {
                    point: net.point_names[i].clone(),
                }));
            }
        }
        if m < MIN_STATIONS {
            return Err(Unsolvable::TooFewStations {
                stations: m,
                needed: MIN_STATIONS,
            }
            .into());
        }
        let mut seen = HashSet::with_capacity(net.readings.len());
        let mut per_point = vec![0usize; n];
        let mut station_readings = vec![0usize; m];
        for (k, r) in net.readings.iter().enumerate() {
            let reading = k + 1;
            if r.station >= m {
                return Err(fault(TracerFault::StationIndex {
                    reading,
                    station: r.station,
                    stations: m,
                }));
            }
            if r.point >= n {
                return Err(fault(TracerFault::PointIndex {
                    reading,
                    point: r.point,
                    points: n,
                }));
            }
            if !r.l.is_finite() {
                return Err(fault(TracerFault::ReadingNotFinite {
                    reading,
                    value: r.l,
                }));
            }
            if !seen.insert((r.station, r.point)) {
                return Err(fault(TracerFault::DuplicateReading {
                    reading,
                    station: net.station_names[r.station].clone(),
                    point: net.point_names[r.point].clone(),
                }));
            }
            per_point[r.point] += 1;
            station_readings[r.station] += 1;
        }
        let unknowns = net.unknowns();
        if net.readings.len() < unknowns {
            return Err(Unsolvable::TooFewReadings {
                readings: net.readings.len(),
                unknowns,
                points: n,
                stations: m,
            }
            .into());
        }
        for (j, &c) in station_readings.iter().enumerate() {
            if c < MIN_STATION_READINGS {
                return Err(Unsolvable::StationReadsTooFew {
                    station: net.station_names[j].clone(),
                    count: c,
                    needed: MIN_STATION_READINGS,
                }
                .into());
            }
        }
        for (i, &c) in per_point.iter().enumerate() {
            if c < MIN_POINT_STATIONS {
                return Err(Unsolvable::PointReadTooFew {
                    point: net.point_names[i].clone(),
                    count: c,
                    needed: MIN_POINT_STATIONS,
                }
                .into());
            }
        }
        let mut order: Vec<usize> = (0..net.readings.len()).collect();
        order.sort_by_key(|&k| (net.readings[k].point, net.readings[k].station));
        let mut start = Vec::with_capacity(n + 1);
        start.push(0);
        let mut acc = 0;
        for c in &per_point {
            acc += c;
            start.push(acc);
        }
        Ok(Structure {
            n,
            m,
            start,
            station_of: order.iter().map(|&k| net.readings[k].station).collect(),
            reading_of: order.clone(),
            l: order.iter().map(|&k| net.readings[k].l).collect(),
            station_readings,
        })
    }

    /// Entry range of point `i`.
    pub(crate) fn entries(&self, i: usize) -> std::ops::Range<usize> {
        self.start[i]..self.start[i + 1]
    }

    /// Point ranges of the chunks, in order.
    pub(crate) fn chunks(&self) -> Vec<std::ops::Range<usize>> {
        (0..self.n.div_ceil(CHUNK))
            .map(|c| c * CHUNK..((c + 1) * CHUNK).min(self.n))
            .collect()
    }
}

/// The unknowns: point positions and, per station, (X, Y, Z, d) (mm).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct State {
    /// Point positions.
    pub points: Vec<Vector3<f64>>,
    /// Station position and dead path.
    pub stations: Vec<Vector4<f64>>,
}

/// The normal equations at a state, reduced onto the station unknowns.
#[derive(Debug, Clone)]
pub(super) struct Linearisation {
    /// Unit vector `a` from station to point, per entry.
    pub unit: Vec<Vector3<f64>>,
    /// Residual per entry (mm).
    pub residual: Vec<f64>,
    /// `(Uᵢ + μI)⁻¹` per point.
    pub u_inv: Vec<Matrix3<f64>>,
    /// `g_pᵢ = −Σ a·v` per point.
    pub g_points: Vec<Vector3<f64>>,
    /// Reduced matrix `S` (4m × 4m), damping included.
    pub schur: DMatrix<f64>,
    /// Reduced right-hand side.
    pub rhs: DVector<f64>,
    /// `Σ v²` (mm²).
    pub cost: f64,
    /// The point with the worst-conditioned `Uᵢ` and its condition number
    /// (computed only when asked for; otherwise (0, 1)).
    pub worst_point: (usize, f64),
}

/// `ã = (a, 1)`.
fn tilde(a: &Vector3<f64>) -> Vector4<f64> {
    Vector4::new(a.x, a.y, a.z, 1.0)
}

/// Condition number of a symmetric positive semi-definite 3×3 matrix
/// (infinite when singular).
fn condition3(u: &Matrix3<f64>) -> f64 {
    let e = SymmetricEigen::new(*u).eigenvalues;
    let (lo, hi) = (e.min(), e.max());
    if lo > 0.0 { hi / lo } else { f64::INFINITY }
}

struct ChunkSums {
    unit: Vec<Vector3<f64>>,
    residual: Vec<f64>,
    u_inv: Vec<Matrix3<f64>>,
    g_points: Vec<Vector3<f64>>,
    schur: Vec<f64>,
    rhs: Vec<f64>,
    cost: f64,
    worst_point: (usize, f64),
}

/// Linearise at `state` with damping `mu` and reduce onto the stations;
/// with `conditions`, also find the worst-conditioned point (a singular
/// point is then reported with its condition number rather than failing).
pub(super) fn linearise(
    net: &Network,
    st: &Structure,
    state: &State,
    mu: f64,
    conditions: bool,
) -> Result<Linearisation> {
    let size = 4 * st.m;
    let chunks: Vec<Result<ChunkSums>> = st
        .chunks()
        .into_par_iter()
        .map(|points| {
            let entries = st.start[points.start]..st.start[points.end];
            let mut out = ChunkSums {
                unit: Vec::with_capacity(entries.len()),
                residual: Vec::with_capacity(entries.len()),
                u_inv: Vec::with_capacity(points.len()),
                g_points: Vec::with_capacity(points.len()),
                schur: vec![0.0; size * size],
                rhs: vec![0.0; size],
                cost: 0.0,
                worst_point: (0, 1.0),
            };
            for i in points {
                let mut u = Matrix3::identity() * mu;
                let mut g = Vector3::zeros();
                let first = out.unit.len();
                for e in st.entries(i) {
                    let s = state.stations[st.station_of[e]];
                    let diff = state.points[i] - s.xyz();
                    let dist = diff.norm();
                    if dist < MIN_DISTANCE_MM {
                        return Err(Unsolvable::PointAtStation {
                            point: net.point_names[i].clone(),
                            station: net.station_names[st.station_of[e]].clone(),
                        }
                        .into());
                    }
                    let a = diff / dist;
                    let r = dist - s.w - st.l[e];
                    u += a * a.transpose();
                    g -= a * r;
                    out.cost += r * r;
                    out.unit.push(a);
                    out.residual.push(r);
                }
                if conditions {
                    let c = condition3(&u);
                    if c.is_nan() || c > out.worst_point.1 {
                        out.worst_point = (i, c);
                    }
                    if !c.is_finite() {
                        // Reported by the caller with its condition number.
                        out.u_inv.push(Matrix3::zeros());
                        out.g_points.push(g);
                        continue;
                    }
                }
                let u_inv = u.cholesky().map(|c| c.inverse()).ok_or_else(|| {
                    ProbeError::from(Unsolvable::PointDirectionsFlat {
                        point: net.point_names[i].clone(),
                    })
                })?;
                let units = &out.unit[first..];
                let stations = &st.station_of[st.entries(i)];
                for (k, (a, &j)) in units.iter().zip(stations).enumerate() {
                    let at = tilde(a);
                    let r = out.residual[first + k];
                    let e_j = u_inv * a;
                    // V_j and g_s,j = Σ ã·v; rhs −= Wᵀ U⁻¹ g_p.
                    let gain = r + e_j.dot(&g);
                    for p in 0..4 {
                        out.rhs[4 * j + p] += at[p] * gain;
                    }
                    for (b, &q) in units.iter().zip(stations) {
                        let bt = tilde(b);
                        let c = if q == j { 1.0 } else { 0.0 } - e_j.dot(b);
                        for p in 0..4 {
                            let row = (4 * j + p) * size + 4 * q;
                            for t in 0..4 {
                                out.schur[row + t] += c * at[p] * bt[t];
                            }
                        }
                    }
                }
                out.u_inv.push(u_inv);
                out.g_points.push(g);
            }
            Ok(out)
        })
        .collect();
    let mut lin = Linearisation {
        unit: Vec::with_capacity(st.l.len()),
        residual: Vec::with_capacity(st.l.len()),
        u_inv: Vec::with_capacity(st.n),
        g_points: Vec::with_capacity(st.n),
        schur: DMatrix::zeros(size, size),
        rhs: DVector::zeros(size),
        cost: 0.0,
        worst_point: (0, 1.0),
    };
    for chunk in chunks {
        let c = chunk?;
        lin.unit.extend(c.unit);
        lin.residual.extend(c.residual);
        lin.u_inv.extend(c.u_inv);
        lin.g_points.extend(c.g_points);
        // The flat sums are row-major; S is symmetric, so the layout does not matter.
        for (s, v) in lin.schur.iter_mut().zip(&c.schur) {
            *s += v;
        }
        for (s, v) in lin.rhs.iter_mut().zip(&c.rhs) {
            *s += v;
        }
        lin.cost += c.cost;
        if c.worst_point.1.is_nan() || c.worst_point.1 > lin.worst_point.1 {
            lin.worst_point = c.worst_point;
        }
    }
    for k in 0..size {
        lin.schur[(k, k)] += mu;
    }
    Ok(lin)
}

/// Orthonormal basis (4m × 6) of the rigid motions of the stations at
/// `state`: translations and rotations about their centroid, dead paths fixed.
pub(super) fn station_rigid_basis(state: &State) -> DMatrix<f64> {
    let m = state.stations.len();
    let centroid = state
        .stations
        .iter()
        .fold(Vector3::zeros(), |s, p| s + p.xyz())
        / m as f64;
    let mut g = DMatrix::zeros(4 * m, 6);
    for (j, s) in state.stations.iter().enumerate() {
        let p = s.xyz() - centroid;
        for k in 0..3 {
            g[(4 * j + k, k)] = 1.0;
            let axis = Vector3::ith(k, 1.0);
            let w = axis.cross(&p);
            for r in 0..3 {
                g[(4 * j + r, 3 + k)] = w[r];
            }
        }
    }
    g.qr().q()
}

/// `S + λQQᵀ` with λ the mean diagonal of S: the reduced matrix with its
/// rigid null space lifted to a typical eigenvalue.
pub(super) fn regularised(lin: &Linearisation, basis: &DMatrix<f64>) -> DMatrix<f64> {
    let size = lin.schur.nrows();
    let lambda = lin.schur.trace() / size as f64;
    &lin.schur + basis * basis.transpose() * lambda
}

/// Condition number of a symmetric positive definite matrix.
pub(super) fn condition(matrix: &DMatrix<f64>) -> f64 {
    let e = SymmetricEigen::new(matrix.clone()).eigenvalues;
    let (lo, hi) = (e.min(), e.max());
    if lo > 0.0 { hi / lo } else { f64::INFINITY }
}

/// The Gauss–Newton step from a linearisation: station part by Cholesky of
/// the regularised reduced matrix, point part by back-substitution.
fn step(st: &Structure, lin: &Linearisation, basis: &DMatrix<f64>) -> Result<State> {
    let reduced = regularised(lin, basis);
    let chol = reduced
        .cholesky()
        .ok_or(ProbeError::Unsolvable(Unsolvable::ReducedNotPositive))?;
    let stations = station_steps(st, &chol.solve(&lin.rhs));
    let points = (0..st.n)
        .into_par_iter()
        .with_min_len(CHUNK)
        .map(|i| point_step(st, lin, &lin.g_points[i], &stations, i))
        .collect();
    Ok(State { points, stations })
}

/// The station part of a step, `δs` as (X, Y, Z, d) per station.
fn station_steps(st: &Structure, ds: &DVector<f64>) -> Vec<Vector4<f64>> {
    (0..st.m)
        .map(|j| Vector4::new(ds[4 * j], ds[4 * j + 1], ds[4 * j + 2], ds[4 * j + 3]))
        .collect()
}

/// Point i's step by back-substitution, `δAᵢ = Uᵢ⁻¹(g_pᵢ − Wᵢ·δs)`.
fn point_step(
    st: &Structure,
    lin: &Linearisation,
    g: &Vector3<f64>,
    stations: &[Vector4<f64>],
    i: usize,
) -> Vector3<f64> {
    let mut rhs = *g;
    for e in st.entries(i) {
        let a = lin.unit[e];
        rhs += a * tilde(&a).dot(&stations[st.station_of[e]]);
    }
    lin.u_inv[i] * rhs
}

/// The solution's linear response to a change of the readings: the
/// Gauss–Newton step from a state whose residuals are the change's
/// negative, with the normal equations linearised and the reduced matrix
/// factorised once. Exact to first order in the change: the step from a
/// network's exact readings plus noise n is `(JᵀJ)⁻¹Jᵀn` with J taken at
/// the state, and J moves with the state by O(|n|/L) relative (L the
/// station distances), far below the noise for readings of micrometres
/// over metres.
pub(super) struct Response<'a> {
    st: &'a Structure,
    lin: Linearisation,
    chol: geom::nalgebra::Cholesky<f64, geom::nalgebra::Dyn>,
}

impl<'a> Response<'a> {
    /// Linearise at `state` and factorise its regularised reduced matrix.
    pub(super) fn new(net: &Network, st: &'a Structure, state: &State) -> Result<Response<'a>> {
        let lin = linearise(net, st, state, 0.0, false)?;
        let chol = regularised(&lin, &station_rigid_basis(state))
            .cholesky()
            .ok_or(ProbeError::Unsolvable(Unsolvable::ReducedNotPositive))?;
        Ok(Response { st, lin, chol })
    }

    /// The step of the unknowns when every reading (entry e, in the
    /// structure's order) changes by `dl[e]` (mm): residuals `v = −dl`, so
    /// `g_pᵢ = Σ a·dl` and the reduced right-hand side `Σ ã(v + (Uᵢ⁻¹a)·g_pᵢ)`.
    /// Serial: it runs inside the parallel Monte Carlo trials.
    pub(super) fn step(&self, dl: &[f64]) -> State {
        let (st, lin) = (self.st, &self.lin);
        let mut rhs = DVector::zeros(4 * st.m);
        let g_points: Vec<Vector3<f64>> = (0..st.n)
            .map(|i| {
                let g = st
                    .entries(i)
                    .fold(Vector3::zeros(), |g, e| g + lin.unit[e] * dl[e]);
                for e in st.entries(i) {
                    let a = lin.unit[e];
                    let gain = (lin.u_inv[i] * a).dot(&g) - dl[e];
                    let j = 4 * st.station_of[e];
                    for (p, t) in tilde(&a).iter().enumerate() {
                        rhs[j + p] += t * gain;
                    }
                }
                g
            })
            .collect();
        let stations = station_steps(st, &self.chol.solve(&rhs));
        let points = (0..st.n)
            .map(|i| point_step(st, lin, &g_points[i], &stations, i))
            .collect();
        State { points, stations }
    }
}

/// `state + delta`, unknown by unknown.
pub(super) fn add(state: &State, delta: &State) -> State {
    State {
        points: state
            .points
            .iter()
            .zip(&delta.points)
            .map(|(p, d)| p + d)
            .collect(),
        stations: state
            .stations
            .iter()
            .zip(&delta.stations)
            .map(|(s, d)| s + d)
            .collect(),
    }
}

fn largest(delta: &State) -> f64 {
    delta
        .points
        .iter()
        .map(|d| d.amax())
        .chain(delta.stations.iter().map(|d| d.amax()))
        .fold(0.0, f64::max)
}

/// `Σ v²` at `state`, summed chunk by chunk in order.
pub(super) fn cost(st: &Structure, state: &State) -> f64 {
    let parts: Vec<f64> = st
        .chunks()
        .into_par_iter()
        .map(|points| {
            let mut sum = 0.0;
            for i in points {
                for e in st.entries(i) {
                    let s = state.stations[st.station_of[e]];
                    let r = (state.points[i] - s.xyz()).norm() - s.w - st.l[e];
                    sum += r * r;
                }
            }
            sum
        })
        .collect();
    parts.iter().sum()
}

/// Refuse, before solving, a layout whose unknowns are not all observable:
/// a point whose directions to its stations are (nearly) coplanar, or a
/// reduced matrix (stations, dead paths) beyond [`CONDITION_LIMIT`].
pub(super) fn check_conditioning(net: &Network, st: &Structure, state: &State) -> Result<()> {
    let lin = linearise(net, st, state, 0.0, true)?;
    let (i, c) = lin.worst_point;
    if c.is_nan() || c > CONDITION_LIMIT {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::PointDirections {
                point: net.point_names[i].clone(),
                stations: st.entries(i).len(),
            },
            condition: c,
            limit: CONDITION_LIMIT,
        });
    }
    let c = condition(&regularised(&lin, &station_rigid_basis(state)));
    if c.is_nan() || c > CONDITION_LIMIT {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::ReducedNormal,
            condition: c,
            limit: CONDITION_LIMIT,
        });
    }
    Ok(())
}

/// Gauss–Newton from `state` to convergence (on the step and the cost),
/// damped (Levenberg–Marquardt) only when a full step would raise the cost.
/// Returns the iterations taken and the largest step of the last one (mm).
pub(super) fn gauss_newton(
    net: &Network,
    st: &Structure,
    state: &mut State,
    max_iterations: usize,
) -> Result<(usize, f64)> {
    let mut mu = 0.0;
    let mut lin = linearise(net, st, state, mu, false)?;
    let mut current = lin.cost;
    for iteration in 1..=max_iterations {
        loop {
            let delta = step(st, &lin, &station_rigid_basis(state))?;
            let size = largest(&delta);
            let trial = add(state, &delta);
            let trial_cost = cost(st, &trial);
            if trial_cost <= current || size <= STEP_TOLERANCE_MM {
                let decrease = current - trial_cost;
                *state = trial;
                if size <= STEP_TOLERANCE_MM || decrease <= COST_TOLERANCE * trial_cost {
                    return Ok((iteration, size));
                }
                current = trial_cost;
                mu /= 10.0;
                if mu < DAMPING_START * mean_point_diagonal(st) {
                    mu = 0.0;
                }
                lin = linearise(net, st, state, mu, false)?;
                break;
            }
            let scale = mean_point_diagonal(st);
            mu = if mu == 0.0 {
                DAMPING_START * scale
            } else {
                mu * 10.0
            };
            if mu > DAMPING_LIMIT * scale {
                return Err(ProbeError::NotConverged {
                    what: "tracer Gauss–Newton (no step lowers the cost)",
                    iterations: iteration,
                });
            }
            lin = linearise(net, st, state, mu, false)?;
        }
    }
    Err(ProbeError::NotConverged {
        what: "tracer Gauss–Newton",
        iterations: max_iterations,
    })
}

/// Mean diagonal of the point blocks: `Σ aaᵀ` has trace = readings of the
/// point, so the mean diagonal is readings / (3n).
fn mean_point_diagonal(st: &Structure) -> f64 {
    st.l.len() as f64 / (3 * st.n) as f64
}

#[cfg(test)]
mod tests {
    use geom::nalgebra::Point3;

    use super::*;
    use crate::tracer::Reading;

    /// A 3×3×3 grid, five stations, exact readings.
    fn network() -> (Network, Vec<Vector4<f64>>) {
        let points: Vec<Point3<f64>> = (0..27)
            .map(|k| {
                Point3::new(
                    200.0 * (k / 9) as f64,
                    200.0 * ((k / 3) % 3) as f64,
                    150.0 * (k % 3) as f64,
                )
            })
            .collect();
        let stations: Vec<Vector3<f64>> = (0..5)
            .map(|j| {
                let a = std::f64::consts::TAU * j as f64 / 5.0;
                let z = if j % 2 == 0 { -100.0 } else { 450.0 };
                Vector3::new(200.0 + 800.0 * a.cos(), 200.0 + 700.0 * a.sin(), z)
            })
            .collect();
        let mut readings = Vec::new();
        let mut truth = Vec::new();
        for (j, s) in stations.iter().enumerate() {
            let zero = (points[0].coords - s).norm();
            truth.push(Vector4::new(s.x, s.y, s.z, zero));
            for (i, p) in points.iter().enumerate() {
                readings.push(Reading {
                    station: j,
                    point: i,
                    l: (p.coords - s).norm() - zero,
                });
            }
        }
        let net = Network {
            points,
            point_names: (1..=27).map(|i| i.to_string()).collect(),
            station_names: (1..=5).map(|j| j.to_string()).collect(),
            readings,
        };
        (net, truth)
    }

    #[test]
    fn a_far_start_converges_through_damping() {
        let (net, truth) = network();
        let st = Structure::new(&net).unwrap();
        // Stations 150 mm and dead paths 40 mm off, points 5 mm off: far
        // beyond what the seed's start leaves; the damped iteration still
        // reaches the exact solution.
        let mut state = State {
            points: net
                .points
                .iter()
                .enumerate()
                .map(|(i, p)| p.coords + Vector3::new(5.0, -3.0, 4.0) * ((i % 3) as f64 - 1.0))
                .collect(),
            stations: truth
                .iter()
                .map(|s| s + Vector4::new(150.0, -120.0, 90.0, 40.0))
                .collect(),
        };
        let (iterations, _) = gauss_newton(&net, &st, &mut state, 100).unwrap();
        assert!(iterations > 3, "{iterations}");
        assert!(cost(&st, &state) < 1e-20, "{}", cost(&st, &state));
        // The shape is the truth's: distances between points are exact.
        let d = |s: &State, a: usize, b: usize| (s.points[a] - s.points[b]).norm();
        for (a, b) in [(0, 26), (4, 13), (8, 18)] {
            let nominal = (net.points[a] - net.points[b]).norm();
            assert!((d(&state, a, b) - nominal).abs() < 1e-9);
        }
    }

    #[test]
    fn the_reduced_matrix_has_the_six_rigid_motions_as_null_space() {
        let (net, truth) = network();
        let st = Structure::new(&net).unwrap();
        let state = State {
            points: net.points.iter().map(|p| p.coords).collect(),
            stations: truth,
        };
        let lin = linearise(&net, &st, &state, 0.0, false).unwrap();
        let basis = station_rigid_basis(&state);
        let scale = lin.schur.amax();
        assert!((&lin.schur * &basis).amax() < 1e-10 * scale);
        let e = SymmetricEigen::new(lin.schur.clone()).eigenvalues;
        let mut e: Vec<f64> = e.iter().copied().collect();
        e.sort_by(f64::total_cmp);
        // Six zeros to rounding, then a gap of ten orders of magnitude.
        assert!(e[5].abs() < 1e-12 * scale && e[6] > 1e-6 * scale, "{e:?}");
    }
}
