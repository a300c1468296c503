//! `report.json` of `trinocular probe tracer`: the keys docs/formats.md
//! lists (`residual_rms_um`, `iterations`, `points`, `stations`, `unknowns`,
//! `equations`, `condition`) and what else a user needs to judge the result,
//! in micrometres. `probe::tracer::report` fills it.

use serde::Serialize;

use crate::uncertainty::FigureKeys;

/// The figures of the report that carry an expanded uncertainty `F_U_um`:
/// the correction field's largest and RMS length. Left out: the fit's
/// statistics (residual RMS, σ of a reading, the last step), the standard
/// uncertainties themselves, the per-station and per-reading tables.
pub const FIGURES: FigureKeys = FigureKeys {
    units: &["_um"],
    skip: &[
        "residual_rms_um",
        "sigma0_um",
        "sigma_um",
        "last_step_um",
        "max_u_um",
        "median_u_um",
        "station_positions",
        "outliers",
        "weak",
    ],
};

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
