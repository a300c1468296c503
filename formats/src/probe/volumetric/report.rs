//! `report.json` of `trinocular probe volumetric` (docs/formats.md:
//! `circle.radial_range_um`, `circle.circular_deviation_um`; µm and µrad,
//! mm for positions). `probe::volumetric::analyse` fills it.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::uncertainty::FigureKeys;

/// The figures of the report that carry an expanded uncertainty (`F_U_um`,
/// `F_U_urad`): the removed straightness lines' slopes and intercepts, the
/// largest and RMS volumetric error, the circle's radial range and circular
/// deviation, before and after compensation. Left out: the squareness given
/// as input and the campaign's conversion (echoes of inputs).
pub const FIGURES: FigureKeys = FigureKeys {
    units: &["_um", "_urad"],
    skip: &["squareness_urad", "campaign"],
};

use super::{Model, Motion, Series, Squareness};
use crate::campaign::Axis;

/// `report.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// `volumetric`.
    pub method: &'static str,
    /// Where the curves came from.
    pub source: String,
    /// Chain string.
    pub chain: String,
    /// Axes between the workpiece and the frame, from the workpiece.
    pub workpiece_side: Vec<Axis>,
    /// Axes between the frame and the tool, from the frame.
    pub tool_side: Vec<Axis>,
    /// Tool offset t (mm).
    pub tool_mm: [f64; 3],
    /// Squareness (µrad).
    pub squareness_urad: Squareness,
    /// Model of the predictions: `raw`, `fourier` or `polynomial`.
    pub model: Model,
    /// Order setting: a number or `auto`.
    pub order: String,
    /// Per axis: curves and fits.
    pub axes: Vec<AxisReport>,
    /// The fit table: both series of every curve.
    pub fits: Vec<FitReport>,
    /// Volumetric errors at `--at`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub volumetric: Option<VolumetricReport>,
    /// The circular test, with `--circle`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub circle: Option<CircleReport>,
    /// The conversion of a vision campaign's figures (`--from-report`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub campaign: Option<CampaignReport>,
    /// Conventions of the figures.
    pub conventions: Vec<String>,
    /// Choices made for the data: an axis whose points allow only a lower
    /// series order than asked, which order its fits use and why.
    pub notes: Vec<String>,
    /// Things worth knowing about the figures: fits the predictions use that
    /// explain little of their curve (R² < 0.8) with a residual significant
    /// against the readings' uncertainty, with the order cross-validation chooses.
    pub warnings: Vec<String>,
}

/// One axis: its curves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisReport {
    /// The axis.
    pub axis: Axis,
    /// Measured travel (mm).
    pub travel_mm: [f64; 2],
    /// Number of measured positions.
    pub points: usize,
    /// Measured positions (mm).
    pub positions_mm: Vec<f64>,
    /// The six curves.
    pub curves: Vec<CurveReport>,
    /// Lines removed from the straightness curves.
    pub straightness_lines: Vec<SlopeReport>,
    /// Whether the compensation table has separate forward and reverse values.
    pub compensation_bidirectional: bool,
}

/// One curve and both fits (µm or µrad, see `unit`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CurveReport {
    /// `ex` … `ec`.
    pub error: Motion,
    /// ISO 230-1 symbol (`EXX`, `EYX`, …).
    pub symbol: String,
    /// `um` or `urad`.
    pub unit: &'static str,
    /// Values at the positions (straightness lines removed).
    pub values: Vec<f64>,
    /// Fourier fit.
    pub fourier: SeriesReport,
    /// Polynomial fit.
    pub polynomial: SeriesReport,
}

/// A series fit of a curve (values in the curve's unit).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeriesReport {
    /// Order N.
    pub order: usize,
    /// R².
    pub r2: Option<f64>,
    /// SSE (unit²).
    pub sse: f64,
    /// RMSE.
    pub rmse: f64,
    /// e_max.
    pub emax: f64,
    /// The fit at the measured positions.
    pub fitted: Vec<f64>,
    /// Leave-one-out scores, under `--order auto`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub order_scores: Option<Vec<OrderScore>>,
}

/// A removed straightness line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlopeReport {
    /// `ey`, `ez` of X, ….
    pub error: Motion,
    /// Slope (µrad = µm/m).
    pub slope_urad: f64,
    /// Intercept at q = 0 (µm).
    pub intercept_um: f64,
}

/// One row of the fit table (the units of `fits.csv`: mm or rad).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    /// The axis.
    pub axis: Axis,
    /// The curve.
    pub error: Motion,
    /// `fourier` or `polynomial`.
    pub model: Series,
    /// Order N.
    pub order: usize,
    /// R².
    pub r2: Option<f64>,
    /// SSE (mm² or rad²).
    pub sse: f64,
    /// RMSE (mm or rad).
    pub rmse: f64,
    /// e_max (mm or rad).
    pub emax: f64,
}

/// Volumetric errors at the given positions (µm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VolumetricReport {
    /// Number of positions.
    pub points: usize,
    /// Largest |Δ|.
    pub max_um: f64,
    /// RMS of |Δ|.
    pub rms_um: f64,
    /// Per position: carriage positions (mm) and Δ (µm).
    pub rows: Vec<VolumetricPoint>,
}

/// Δ at one position.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VolumetricPoint {
    /// Carriage positions x, y, z (mm).
    pub q_mm: [f64; 3],
    /// Volumetric error (µm, workpiece frame).
    pub d_um: [f64; 3],
}

/// The circular test (µm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CircleReport {
    /// Centre (mm, workpiece frame).
    pub centre_mm: [f64; 3],
    /// Radius (mm).
    pub radius_mm: f64,
    /// Range of the radial deviations.
    pub radial_range_um: f64,
    /// ISO 230-4 circular deviation about the least-squares centre.
    pub circular_deviation_um: f64,
    /// Least-squares centre of the predicted path (mm).
    pub lsq_centre_mm: [f64; 2],
    /// Radial deviation per degree, θ = 0 … 359°.
    pub radial_um: Vec<f64>,
    /// After compensating with each series.
    pub compensated: CompensatedReport,
}

/// The circular test after compensation (µm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompensatedReport {
    /// With the Fourier series.
    pub fourier: CircleFigures,
    /// With the polynomial.
    pub polynomial: CircleFigures,
}

/// Figures of a circular test (µm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CircleFigures {
    /// Range of the radial deviations.
    pub radial_range_um: f64,
    /// Circular deviation.
    pub circular_deviation_um: f64,
    /// Radial deviation per degree.
    pub radial_um: Vec<f64>,
}

/// How a vision campaign's figures were converted.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CampaignReport {
    /// Per swept axis.
    pub sweeps: Vec<SweepInfo>,
    /// Squareness measured by the campaign (µrad).
    pub measured_squareness_urad: BTreeMap<String, f64>,
    /// Notes of the conversion.
    pub notes: Vec<String>,
}

/// One candidate of an order choice: its leave-one-out RMSE.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OrderScore {
    /// Order N.
    pub order: usize,
    /// `√(PRESS/n)`, PRESS = Σ (rᵢ/(1 − hᵢᵢ))²: the RMS error of predicting
    /// each point from a fit to the others (value unit).
    pub loo_rmse: f64,
}

/// What the conversion found for one swept axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepInfo {
    /// The axis.
    pub axis: Axis,
    /// Index of the main line in the report.
    pub line: usize,
    /// Commanded off-axis coordinates of the line (mm), x, y, z.
    pub off_axis_mm: [f64; 3],
    /// Position where the curves are zero (mm).
    pub reference_mm: f64,
    /// Lever from the carriage's reference point to the sphere (mm).
    pub lever_mm: [f64; 3],
    /// The direction evaluate fitted (unit, world frame).
    pub fitted_direction: [f64; 3],
    /// The carriage direction after removing the Abbe terms (unit, world frame).
    pub direction: [f64; 3],
}
