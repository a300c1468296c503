//! `report.json` of `trinocular probe rotary` (docs/formats.md): the errors
//! per angle in µm and µrad (`errors`), the location errors of the axis
//! average line (`location`: `X0C_um`, `Y0C_um`, `A0C_urad`, `B0C_urad`),
//! the layout's condition number (`condition`), and beyond the contract the
//! component errors, the ranges a user signs off, the sphere fits and the
//! interpolated angles. `probe::rotary::report` fills it.

use serde::Serialize;

use super::LocationErrors;
use crate::uncertainty::{FigureKeys, Uncertainty};

/// The figures of the report (docs/probe-rotary.md, "Uncertainty"): every
/// error, location error, component error, range and interpolated error
/// (`_um`, `_urad`); not the standard uncertainties beside them, nor the
/// diagnostics (residuals, largest u) and the sphere fits.
pub const FIGURES: FigureKeys = FigureKeys {
    units: &["_um", "_urad"],
    skip: &[
        "u_EXC_um",
        "u_EYC_um",
        "u_EZC_um",
        "u_EAC_urad",
        "u_EBC_urad",
        "u_ECC_urad",
        "u_X0C_um",
        "u_Y0C_um",
        "u_A0C_urad",
        "u_B0C_urad",
        "residual_rms_um",
        "max_u_translation_um",
        "max_u_rotation_urad",
        "sphere_fits",
        "uncertainty",
    ],
};

/// Where the centres came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum InputKind {
    /// One measured centre per ball and angle.
    Centres,
    /// Probed points, a sphere fitted per ball and angle.
    Points,
}

/// The six errors in report units: translations µm, rotations µrad.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Six {
    /// EXC = δx (µm).
    #[serde(rename = "EXC_um")]
    pub exc_um: f64,
    /// EYC = δy (µm).
    #[serde(rename = "EYC_um")]
    pub eyc_um: f64,
    /// EZC = δz (µm).
    #[serde(rename = "EZC_um")]
    pub ezc_um: f64,
    /// EAC = εx (µrad).
    #[serde(rename = "EAC_urad")]
    pub eac_urad: f64,
    /// EBC = εy (µrad).
    #[serde(rename = "EBC_urad")]
    pub ebc_urad: f64,
    /// ECC = εz (µrad).
    #[serde(rename = "ECC_urad")]
    pub ecc_urad: f64,
}

impl Six {
    /// The six values in the order EXC, EYC, EZC, EAC, EBC, ECC (µm, µrad).
    pub fn values(&self) -> [f64; 6] {
        [
            self.exc_um,
            self.eyc_um,
            self.ezc_um,
            self.eac_urad,
            self.ebc_urad,
            self.ecc_urad,
        ]
    }
}

/// Standard uncertainties of the six errors (µm, µrad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct USix {
    /// u(EXC) (µm).
    #[serde(rename = "u_EXC_um")]
    pub exc_um: f64,
    /// u(EYC) (µm).
    #[serde(rename = "u_EYC_um")]
    pub eyc_um: f64,
    /// u(EZC) (µm).
    #[serde(rename = "u_EZC_um")]
    pub ezc_um: f64,
    /// u(EAC) (µrad).
    #[serde(rename = "u_EAC_urad")]
    pub eac_urad: f64,
    /// u(EBC) (µrad).
    #[serde(rename = "u_EBC_urad")]
    pub ebc_urad: f64,
    /// u(ECC) (µrad).
    #[serde(rename = "u_ECC_urad")]
    pub ecc_urad: f64,
}

/// The six errors at one angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AngleReport {
    /// Table angle (degrees).
    pub angle_deg: f64,
    /// The six errors.
    #[serde(flatten)]
    pub errors: Six,
    /// Their standard uncertainties (absent for component errors).
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<USix>,
    /// RMS residual of the angle's least squares (µm); absent where not computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_rms_um: Option<f64>,
}

/// The location errors of the axis average line (ISO 230-7) and their
/// standard uncertainties.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LocationReport {
    /// X0C, Y0C (µm), A0C, B0C (µrad).
    #[serde(flatten)]
    pub errors: LocationErrors,
    /// u(X0C) (µm).
    #[serde(rename = "u_X0C_um")]
    pub u_x0c_um: f64,
    /// u(Y0C) (µm).
    #[serde(rename = "u_Y0C_um")]
    pub u_y0c_um: f64,
    /// u(A0C) (µrad).
    #[serde(rename = "u_A0C_urad")]
    pub u_a0c_urad: f64,
    /// u(B0C) (µrad).
    #[serde(rename = "u_B0C_urad")]
    pub u_b0c_urad: f64,
    /// Unit direction of the axis average line, ≈ (B0C, −A0C, 1).
    pub direction: [f64; 3],
    /// Condition number of the location fit.
    pub condition: f64,
}

/// Ranges (max − min over the measured angles) — the sign-off figures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RangesReport {
    /// Ranges of the six errors as identified.
    pub errors: Six,
    /// Ranges of the component errors (axis average line taken out).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub components: Option<Six>,
}

/// One ball: its reference centre and where it sits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BallReport {
    /// Name.
    pub ball: String,
    /// Reference centre P0 at 0° (mm).
    pub centre: [f64; 3],
    /// Distance from the nominal axis (mm).
    pub radius_mm: f64,
}

/// One sphere fit (probed points).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SphereFitReport {
    /// Ball.
    pub ball: String,
    /// Angle (degrees).
    pub angle_deg: f64,
    /// Fitted centre (mm).
    pub centre: [f64; 3],
    /// Fitted radius (mm).
    pub radius_mm: f64,
    /// RMS radial residual (µm).
    pub rms_residual_um: f64,
    /// Largest absolute radial residual (µm).
    pub max_residual_um: f64,
    /// Number of probed points.
    pub points: usize,
}

/// Everything `report.json` holds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// `rotary`.
    pub method: &'static str,
    /// Where the input came from (file name).
    pub source: String,
    /// Centres or probed points.
    pub input: InputKind,
    /// The balls.
    pub balls: Vec<BallReport>,
    /// The six errors per measured angle with uncertainties.
    pub errors: Vec<AngleReport>,
    /// Location errors; absent when the angles do not determine them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub location: Option<LocationReport>,
    /// Component errors per angle (errors − fixed axis); absent with `location`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub components: Option<Vec<AngleReport>>,
    /// Ranges of the errors and component errors.
    pub ranges: RangesReport,
    /// Condition number of the ball layout (scaled design, the same at every angle).
    pub condition: f64,
    /// Largest condition number accepted.
    pub condition_limit: f64,
    /// The length (mm) that scales the rotation columns for the condition number.
    pub scale_mm: f64,
    /// RMS of all residuals of the per-angle least squares (µm).
    pub residual_rms_um: f64,
    /// Largest standard uncertainty of a translation error (µm).
    pub max_u_translation_um: f64,
    /// Largest standard uncertainty of a rotation error (µrad).
    pub max_u_rotation_urad: f64,
    /// Sphere fits per ball and angle (probed points only).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sphere_fits: Vec<SphereFitReport>,
    /// The errors at the angles asked for (`--at`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub interpolated: Vec<AngleReport>,
    /// Conventions of the figures.
    pub conventions: Vec<String>,
    /// Things worth knowing that did not stop the method.
    pub warnings: Vec<String>,
    /// How the expanded uncertainties (k = 2) of the figures were found
    /// (written beside each figure as `F_U_um`), or why there are none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<Uncertainty>,
}
