//! `report.json` of `probe tracer`: the keys docs/formats.md lists
//! (`residual_rms_um`, `iterations`, `points`, `stations`, `unknowns`,
//! `equations`, `condition`) and what else a user needs to judge the result,
//! in micrometres.

use serde::Serialize;

use super::{Network, Solution};

const UM: f64 = 1e3;

/// A station's estimate in the report (mm for the position and dead path,
/// µm for uncertainties and residuals).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StationReport {
    /// Station name.
    pub station: String,
    /// Position in the frame of the nominal grid (mm).
    pub position: [f64; 3],
    /// Dead path (mm).
    pub dead_path: f64,
    /// Standard uncertainties of the position (µm).
    pub u_position_um: [f64; 3],
    /// Standard uncertainty of the dead path (µm).
    pub u_dead_path_um: f64,
    /// Readings of the station.
    pub readings: usize,
    /// RMS of its residuals (µm).
    pub residual_rms_um: f64,
}

/// A flagged reading.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OutlierReading {
    /// Station name.
    pub station: String,
    /// Point name.
    pub point: String,
    /// Residual (µm).
    pub residual_um: f64,
    /// Normalised residual.
    pub normalized: f64,
}

/// The outlier test: `|w| > k` on normalised residuals.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outliers {
    /// k.
    pub k: f64,
    /// Robust scale of the residuals the test uses (µm).
    pub sigma_um: f64,
    /// Number of flagged readings.
    pub count: usize,
    /// Readings expected beyond k by chance alone (normal errors).
    pub expected_by_chance: f64,
    /// The flagged readings, largest |w| first.
    pub readings: Vec<OutlierReading>,
}

/// A weakly determined point or station.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakItem {
    /// Its name.
    pub name: String,
    /// Why it is weak.
    pub reason: String,
}

/// Weakly determined points and stations.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Weakness {
    /// Points.
    pub points: Vec<WeakItem>,
    /// Stations.
    pub stations: Vec<WeakItem>,
}

/// `report.json` of `probe tracer`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TracerReport {
    /// RMS of the residuals (µm).
    pub residual_rms_um: f64,
    /// Gauss–Newton iterations.
    pub iterations: usize,
    /// Grid points n.
    pub points: usize,
    /// Stations m.
    pub stations: usize,
    /// Unknowns after the datum, `3n + 4m − 6`.
    pub unknowns: usize,
    /// Readings.
    pub equations: usize,
    /// Condition number of the reduced normal matrix (station unknowns,
    /// rigid freedoms removed).
    pub condition: f64,
    /// Readings minus unknowns.
    pub redundancy: usize,
    /// A-posteriori standard deviation of a reading (µm).
    pub sigma0_um: f64,
    /// Standard deviation of a reading the uncertainties use (µm).
    pub sigma_um: f64,
    /// Whether `sigma_um` was given a priori.
    pub sigma_a_priori: bool,
    /// Largest step of the last iteration (µm).
    pub last_step_um: f64,
    /// The datum, in words.
    pub datum: String,
    /// The point with the worst-conditioned direction matrix `Σ uuᵀ`.
    pub worst_point: String,
    /// Its condition number.
    pub worst_point_condition: f64,
    /// Largest correction length (µm).
    pub max_correction_um: f64,
    /// The point where it is.
    pub max_correction_point: String,
    /// RMS of the correction lengths (µm).
    pub rms_correction_um: f64,
    /// Largest standard uncertainty of a correction component (µm).
    pub max_u_um: f64,
    /// Median of the points' largest standard uncertainty (µm).
    pub median_u_um: f64,
    /// Stations, their dead paths and uncertainties.
    pub station_positions: Vec<StationReport>,
    /// The outlier test.
    pub outliers: Outliers,
    /// Weakly determined points and stations.
    pub weak: Weakness,
}

/// The datum, as the report states it.
pub(crate) const DATUM: &str = "corrections = estimated − nominal after the least-squares rigid \
                         alignment of the estimated points to the nominal grid (no rigid motion); \
                         length scale from the interferometer";

fn items(weak: &[super::Weak], names: &[String]) -> Vec<WeakItem> {
    weak.iter()
        .map(|w| WeakItem {
            name: names[w.index].clone(),
            reason: w.reason.clone(),
        })
        .collect()
}

/// Build `report.json` from a solution of `network`.
pub fn report(network: &Network, s: &Solution) -> TracerReport {
    let lengths: Vec<f64> = s.corrections.iter().map(|c| c.vector.norm()).collect();
    let (max_i, max_len) =
        lengths
            .iter()
            .copied()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |best, (i, v)| {
                if v > best.1 { (i, v) } else { best }
            });
    let n = lengths.len().max(1) as f64;
    let mut u_max: Vec<f64> = s.corrections.iter().map(|c| c.u.max()).collect();
    u_max.sort_by(f64::total_cmp);
    let median_u = u_max.get(u_max.len() / 2).copied().unwrap_or(0.0);
    let mut flagged: Vec<OutlierReading> = network
        .readings
        .iter()
        .zip(&s.residuals)
        .filter(|(_, r)| r.outlier)
        .map(|(rd, r)| OutlierReading {
            station: network.station_names[rd.station].clone(),
            point: network.point_names[rd.point].clone(),
            residual_um: r.value * UM,
            normalized: r.normalized,
        })
        .collect();
    flagged.sort_by(|a, b| b.normalized.abs().total_cmp(&a.normalized.abs()));
    TracerReport {
        residual_rms_um: s.residual_rms * UM,
        iterations: s.iterations,
        points: network.points.len(),
        stations: network.station_names.len(),
        unknowns: s.unknowns,
        equations: s.equations,
        condition: s.condition,
        redundancy: s.redundancy,
        sigma0_um: s.sigma0 * UM,
        sigma_um: s.sigma * UM,
        sigma_a_priori: s.sigma_a_priori,
        last_step_um: s.last_step * UM,
        datum: DATUM.into(),
        worst_point: network.point_names[s.worst_point.0].clone(),
        worst_point_condition: s.worst_point.1,
        max_correction_um: max_len.max(0.0) * UM,
        max_correction_point: network.point_names[max_i].clone(),
        rms_correction_um: (lengths.iter().map(|v| v * v).sum::<f64>() / n).sqrt() * UM,
        max_u_um: u_max.last().copied().unwrap_or(0.0) * UM,
        median_u_um: median_u * UM,
        station_positions: s
            .stations
            .iter()
            .zip(&network.station_names)
            .map(|(st, name)| StationReport {
                station: name.clone(),
                position: [st.position.x, st.position.y, st.position.z],
                dead_path: st.dead_path,
                u_position_um: [st.u_position.x, st.u_position.y, st.u_position.z].map(|v| v * UM),
                u_dead_path_um: st.u_dead_path * UM,
                readings: st.readings,
                residual_rms_um: st.residual_rms * UM,
            })
            .collect(),
        outliers: Outliers {
            k: s.outlier_k,
            sigma_um: s.sigma_outliers * UM,
            count: flagged.len(),
            expected_by_chance: s.outliers_by_chance,
            readings: flagged,
        },
        weak: Weakness {
            points: items(&s.weak_points, &network.point_names),
            stations: items(&s.weak_stations, &network.station_names),
        },
    }
}
