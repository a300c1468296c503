//! `report.json` of `trinocular probe indexing` (docs/probe-indexing.md):
//! the construction's figures, the maxima and RMS of ΔθA and ΔθB, the
//! radius against a nominal, per-detent means and the positions beyond a
//! tolerance. `probe::indexing::report` fills it.

use serde::Serialize;

use crate::uncertainty::{FigureKeys, Uncertainty};

/// The figures of the report (docs/probe-indexing.md, "Uncertainty"): the
/// radius, its deviation from the nominal, the maxima, RMS and per-detent
/// values of ΔθA and ΔθB; not the standard uncertainties, the nominal and
/// tolerance given, the sphere fit's diagnostics, the signed extremes'
/// positions (`max_dA_at`: a position and a sign, its magnitude is
/// `max_dA_arcsec`) nor the list of positions beyond the tolerance.
pub const FIGURES: FigureKeys = FigureKeys {
    units: &["_mm", "_um", "_arcsec"],
    skip: &[
        "u_radius_um",
        "u_rotation_centre_um",
        "nominal_radius_mm",
        "sphere_fit",
        "max_dA_at",
        "max_dB_at",
        "median_u_dA_arcsec",
        "median_u_dB_arcsec",
        "u_mean_dB_arcsec",
        "tolerance",
        "uncertainty",
    ],
};

/// `report.json` (the positions themselves are in `indexing.csv`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The method.
    pub method: String,
    /// Where the centres came from.
    pub source: String,
    /// Number of positions.
    pub positions: usize,
    /// O, the rotation centre (mm, machine frame).
    pub rotation_centre: [f64; 3],
    /// Standard uncertainties of O (µm).
    pub u_rotation_centre_um: [f64; 3],
    /// Radius of the sphere through the centres (mm).
    pub radius_mm: f64,
    /// Standard uncertainty of the radius (µm).
    pub u_radius_um: f64,
    /// Nominal radius, when given (mm).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nominal_radius_mm: Option<f64>,
    /// Radius − nominal (µm), when a nominal is given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radius_deviation_um: Option<f64>,
    /// The sphere fit.
    pub sphere_fit: SphereReport,
    /// The frame of §3.
    pub axes: AxesReport,
    /// max |ΔθA| over all positions (arc-seconds).
    #[serde(rename = "max_dA_arcsec")]
    pub max_d_a_arcsec: f64,
    /// Where max |ΔθA| is, with its sign.
    #[serde(rename = "max_dA_at")]
    pub max_d_a_at: Extreme,
    /// max |ΔθB| over the positions with A > 0° (arc-seconds).
    #[serde(rename = "max_dB_arcsec")]
    pub max_d_b_arcsec: f64,
    /// Where max |ΔθB| is, with its sign.
    #[serde(rename = "max_dB_at")]
    pub max_d_b_at: Extreme,
    /// RMS of ΔθA over all positions (arc-seconds).
    #[serde(rename = "rms_dA_arcsec")]
    pub rms_d_a_arcsec: f64,
    /// RMS of ΔθB over the positions with A > 0° (arc-seconds).
    #[serde(rename = "rms_dB_arcsec")]
    pub rms_d_b_arcsec: f64,
    /// Median standard uncertainty of ΔθA (arc-seconds).
    #[serde(rename = "median_u_dA_arcsec")]
    pub median_u_d_a_arcsec: f64,
    /// Median standard uncertainty of ΔθB (arc-seconds).
    #[serde(rename = "median_u_dB_arcsec")]
    pub median_u_d_b_arcsec: f64,
    /// max |mean ΔθA| over the A detents with A > 0° (arc-seconds): the
    /// detents' own errors with the noise averaged down (at A = 0° the
    /// mean tilt magnitude is biased by the noise, so it is left out).
    #[serde(rename = "max_detent_dA_arcsec")]
    pub max_detent_d_a_arcsec: f64,
    /// max |weighted mean ΔθB| over the B detents (arc-seconds).
    #[serde(rename = "max_detent_dB_arcsec")]
    pub max_detent_d_b_arcsec: f64,
    /// ΔθA per A detent: mean over its B positions.
    pub a_detents: Vec<ADetent>,
    /// ΔθB per B detent: mean over its A > 0° positions, weighted by 1/u².
    pub b_detents: Vec<BDetent>,
    /// The positions beyond the tolerance, when one is given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<ToleranceReport>,
    /// The measured grid.
    pub grid: GridReport,
    /// Things worth knowing that did not stop the evaluation.
    pub warnings: Vec<String>,
    /// The conventions of the figures.
    pub conventions: Vec<String>,
    /// How the expanded uncertainties (k = 2) of the figures were found
    /// (written beside each figure as `F_U_arcsec`), or why there are none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<Uncertainty>,
}

/// The sphere through the centres.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SphereReport {
    /// RMS of the radial residuals (µm).
    pub residual_rms_um: f64,
    /// Largest |radial residual| (µm).
    pub residual_max_um: f64,
    /// Noise of a centre, `√(Σr²/(n − 4))` (µm).
    pub noise_um: f64,
    /// Condition number of JᵀJ.
    pub condition: f64,
}

/// The frame's axes and Q.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxesReport {
    /// x = y × z.
    pub x: [f64; 3],
    /// y, the A axis.
    pub y_a_axis: [f64; 3],
    /// z, the B axis.
    pub z_b_axis: [f64; 3],
    /// Q, the centre of the A = 0° circle (mm).
    pub b_circle_centre: [f64; 3],
    /// Positions in the B turn at A = 0°.
    pub b_turn_positions: usize,
    /// Step of that turn (degrees).
    pub b_turn_step_deg: f64,
    /// Positions in the B = 0° sweep (A > 0°).
    pub a_sweep_positions: usize,
}

/// A signed extreme value and its position.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Extreme {
    /// Commanded A (degrees).
    pub a_deg: f64,
    /// Commanded B (degrees).
    pub b_deg: f64,
    /// The value (arc-seconds).
    pub value_arcsec: f64,
}

/// ΔθA of one A detent.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ADetent {
    /// Commanded A (degrees).
    pub a_deg: f64,
    /// Positions at this A.
    pub positions: usize,
    /// Mean ΔθA (arc-seconds).
    #[serde(rename = "mean_dA_arcsec")]
    pub mean_d_a_arcsec: f64,
    /// Smallest ΔθA (arc-seconds).
    #[serde(rename = "min_dA_arcsec")]
    pub min_d_a_arcsec: f64,
    /// Largest ΔθA (arc-seconds).
    #[serde(rename = "max_dA_arcsec")]
    pub max_d_a_arcsec: f64,
}

/// ΔθB of one B detent.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BDetent {
    /// Commanded B (degrees, wrapped to (−180°, 180°]).
    pub b_deg: f64,
    /// Positions at this B with A > 0°.
    pub positions: usize,
    /// Mean ΔθB weighted by 1/u² (arc-seconds).
    #[serde(rename = "mean_dB_arcsec")]
    pub mean_d_b_arcsec: f64,
    /// Its standard uncertainty if the positions were independent (arc-seconds).
    #[serde(rename = "u_mean_dB_arcsec")]
    pub u_mean_d_b_arcsec: f64,
}

/// The positions beyond a tolerance by more than their expanded
/// uncertainty U = 2u (ISO 14253-1: beyond, proven), and how many more
/// cannot be decided (within U of the tolerance, either side).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ToleranceReport {
    /// The tolerance on |ΔθA| and |ΔθB| (arc-seconds).
    pub tolerance_arcsec: f64,
    /// How many positions exceed it in ΔθA by more than U.
    #[serde(rename = "count_dA")]
    pub count_d_a: usize,
    /// How many positions exceed it in ΔθB by more than U.
    #[serde(rename = "count_dB")]
    pub count_d_b: usize,
    /// How many positions have |ΔθA| within U of it (inconclusive).
    #[serde(rename = "inconclusive_dA")]
    pub inconclusive_d_a: usize,
    /// How many positions have |ΔθB| within U of it (inconclusive).
    #[serde(rename = "inconclusive_dB")]
    pub inconclusive_d_b: usize,
    /// The positions beyond by more than U, worst first.
    pub exceeding: Vec<Exceedance>,
}

/// A position beyond the tolerance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Exceedance {
    /// Commanded A (degrees).
    pub a_deg: f64,
    /// Commanded B (degrees).
    pub b_deg: f64,
    /// ΔθA (arc-seconds).
    #[serde(rename = "dA_arcsec")]
    pub d_a_arcsec: f64,
    /// ΔθB (arc-seconds), absent at A = 0°.
    #[serde(rename = "dB_arcsec")]
    pub d_b_arcsec: Option<f64>,
    /// U (k = 2) of ΔθA (arc-seconds).
    #[serde(rename = "U_dA_arcsec")]
    pub expanded_d_a_arcsec: f64,
    /// U (k = 2) of ΔθB (arc-seconds), absent at A = 0°.
    #[serde(rename = "U_dB_arcsec")]
    pub expanded_d_b_arcsec: Option<f64>,
    /// Which errors exceed by more than U: `A`, `B` or `A+B`.
    pub exceeds: String,
}

/// The measured grid.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GridReport {
    /// Commanded A values (degrees, ascending).
    pub a_deg: Vec<f64>,
    /// Commanded B values (degrees, wrapped, ascending).
    pub b_deg: Vec<f64>,
    /// (A, B) of the grid that were not measured.
    pub missing: Vec<[f64; 2]>,
}
