//! `report.json` of `probe tracer`: the keys docs/formats.md lists
//! (`residual_rms_um`, `iterations`, `points`, `stations`, `unknowns`,
//! `equations`, `condition`) and what else a user needs to judge the result,
//! in micrometres. The types live in `formats::probe::tracer::report`;
//! [`report()`] fills them.

pub use formats::probe::tracer::report::{
    OutlierReading, Outliers, StationReport, TracerReport, WeakItem, Weakness,
};

use std::collections::BTreeMap;

use geom::nalgebra::Vector3;

use super::{Network, Solution};

const UM: f64 = 1e3;

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

/// The headline figures of a set of corrections: the largest length (and
/// where), the RMS length (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CorrectionFigures {
    /// Index of the largest correction.
    pub at: usize,
    /// Its length (mm).
    pub max: f64,
    /// RMS of the lengths (mm).
    pub rms: f64,
}

impl CorrectionFigures {
    /// The figures of `vectors` (mm).
    pub fn of<'a>(vectors: impl Iterator<Item = &'a Vector3<f64>>) -> CorrectionFigures {
        let lengths: Vec<f64> = vectors.map(|v| v.norm()).collect();
        let (at, max) =
            lengths
                .iter()
                .copied()
                .enumerate()
                .fold((0, f64::NEG_INFINITY), |best, (i, v)| {
                    if v > best.1 { (i, v) } else { best }
                });
        let n = lengths.len().max(1) as f64;
        CorrectionFigures {
            at,
            max: max.max(0.0),
            rms: (lengths.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
        }
    }

    /// As the report's figures by their keys (µm).
    pub fn named(&self) -> BTreeMap<String, f64> {
        BTreeMap::from([
            (MAX_CORRECTION.to_string(), self.max * UM),
            (RMS_CORRECTION.to_string(), self.rms * UM),
        ])
    }
}

/// Key of the largest correction in `report.json`.
pub(crate) const MAX_CORRECTION: &str = "max_correction_um";
/// Key of the RMS correction in `report.json`.
pub(crate) const RMS_CORRECTION: &str = "rms_correction_um";

/// Build `report.json` from a solution of `network`.
pub fn report(network: &Network, s: &Solution) -> TracerReport {
    let figures = CorrectionFigures::of(s.corrections.iter().map(|c| &c.vector));
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
        max_correction_um: figures.max * UM,
        max_correction_point: network.point_names[figures.at].clone(),
        rms_correction_um: figures.rms * UM,
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
