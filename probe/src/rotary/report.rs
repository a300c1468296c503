//! `report.json` of `trinocular probe rotary` (docs/formats.md): the errors
//! per angle in µm and µrad (`errors`), the location errors of the axis
//! average line (`location`: `X0C_um`, `Y0C_um`, `A0C_urad`, `B0C_urad`),
//! the layout's condition number (`condition`), and beyond the contract the
//! component errors, the ranges a user signs off, the sphere fits and the
//! interpolated angles.

use serde::Serialize;

use super::{CentreFit, Interpolated, SixErrors, Solution};

/// mm → µm.
const UM_PER_MM: f64 = 1e3;
/// rad → µrad.
const URAD_PER_RAD: f64 = 1e6;

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
    /// From mm and rad.
    pub fn from_si(v: &SixErrors) -> Six {
        Six {
            exc_um: v[0] * UM_PER_MM,
            eyc_um: v[1] * UM_PER_MM,
            ezc_um: v[2] * UM_PER_MM,
            eac_urad: v[3] * URAD_PER_RAD,
            ebc_urad: v[4] * URAD_PER_RAD,
            ecc_urad: v[5] * URAD_PER_RAD,
        }
    }

    /// The six values in the order of [`super::NAMES`] (µm, µrad).
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

impl USix {
    /// From mm and rad.
    pub fn from_si(v: &SixErrors) -> USix {
        let s = Six::from_si(v);
        USix {
            exc_um: s.exc_um,
            eyc_um: s.eyc_um,
            ezc_um: s.ezc_um,
            eac_urad: s.eac_urad,
            ebc_urad: s.ebc_urad,
            ecc_urad: s.ecc_urad,
        }
    }
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

/// The location errors of the axis average line (ISO 230-7).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LocationReport {
    /// X0C (µm).
    #[serde(rename = "X0C_um")]
    pub x0c_um: f64,
    /// Y0C (µm).
    #[serde(rename = "Y0C_um")]
    pub y0c_um: f64,
    /// A0C (µrad).
    #[serde(rename = "A0C_urad")]
    pub a0c_urad: f64,
    /// B0C (µrad).
    #[serde(rename = "B0C_urad")]
    pub b0c_urad: f64,
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
}

/// The conventions written into every report.
pub(crate) fn conventions() -> Vec<String> {
    [
        "table frame: Z on the nominal rotation axis, origin on it at the table surface; angles counter-clockwise seen from +Z",
        "errors EXC, EYC, EZC, EAC, EBC, ECC = δx, δy, δz (µm), εx, εy, εz (µrad) of ΔP = δ + ε × Rz(θ)·P0, P0 = each ball's centre at 0° (all six are zero there)",
        "per-angle least squares X = (AᵀA)⁻¹Aᵀb (docs/probe-rotary.md); standard uncertainties √diag(s²(AᵀA)⁻¹), s² = Σr²/(3n − 6)",
        "location errors (ISO 230-7): X0C, Y0C where the axis average line crosses Z = 0; A0C, B0C right-hand rotations about X, Y turning +Z onto its direction ≈ (B0C, −A0C, 1); the mean location over the turn (least squares of a − Rz(θ)·b per pair)",
        "component errors = errors − (I − Rz(θ))·(X0C, Y0C, 0) and (I − Rz(θ))·(A0C, B0C, 0); ranges are max − min over the measured angles",
        "interpolation: linear between the two nearest measured angles, wrapping at 360°",
    ]
    .iter()
    .map(|s| (*s).to_string())
    .collect()
}

fn fit_report(ball: &str, angle_deg: f64, f: &CentreFit) -> SphereFitReport {
    SphereFitReport {
        ball: ball.to_string(),
        angle_deg,
        centre: [f.centre.x, f.centre.y, f.centre.z],
        radius_mm: f.radius,
        rms_residual_um: f.rms_residual * UM_PER_MM,
        max_residual_um: f.max_residual * UM_PER_MM,
        points: f.points,
    }
}

/// A report row of interpolated errors.
pub(crate) fn interpolated_report(i: &Interpolated) -> AngleReport {
    AngleReport {
        angle_deg: i.angle_deg,
        errors: Six::from_si(&i.errors),
        uncertainty: Some(USix::from_si(&i.uncertainty)),
        residual_rms_um: None,
    }
}

impl Report {
    /// The report of a solution; `source` names the input, `at` holds the
    /// interpolated angles asked for.
    pub fn new(solution: &Solution, source: &str, at: &[Interpolated]) -> Report {
        let input = if solution.fits.is_empty() {
            InputKind::Centres
        } else {
            InputKind::Points
        };
        let balls = solution
            .balls
            .iter()
            .zip(&solution.reference)
            .map(|(b, p)| BallReport {
                ball: b.clone(),
                centre: [p.x, p.y, p.z],
                radius_mm: p.x.hypot(p.y),
            })
            .collect();
        let errors = solution
            .errors
            .iter()
            .map(|e| AngleReport {
                angle_deg: e.angle_deg,
                errors: Six::from_si(&e.errors),
                uncertainty: Some(USix::from_si(&e.uncertainty)),
                residual_rms_um: Some(e.residual_rms_mm * UM_PER_MM),
            })
            .collect();
        let location = solution.axis.as_ref().map(|a| {
            let l = &a.location;
            let d = l.direction();
            LocationReport {
                x0c_um: l.x0c_mm * UM_PER_MM,
                y0c_um: l.y0c_mm * UM_PER_MM,
                a0c_urad: l.a0c_rad * URAD_PER_RAD,
                b0c_urad: l.b0c_rad * URAD_PER_RAD,
                u_x0c_um: l.uncertainty[0] * UM_PER_MM,
                u_y0c_um: l.uncertainty[1] * UM_PER_MM,
                u_a0c_urad: l.uncertainty[2] * URAD_PER_RAD,
                u_b0c_urad: l.uncertainty[3] * URAD_PER_RAD,
                direction: [d.x, d.y, d.z],
                condition: a.condition,
            }
        });
        let components = solution.axis.as_ref().map(|a| {
            solution
                .angles_deg
                .iter()
                .zip(&a.components)
                .map(|(angle, c)| AngleReport {
                    angle_deg: *angle,
                    errors: Six::from_si(c),
                    uncertainty: None,
                    residual_rms_um: None,
                })
                .collect()
        });
        let max_u = |range: std::ops::Range<usize>| {
            solution
                .errors
                .iter()
                .flat_map(|e| range.clone().map(move |k| e.uncertainty[k]))
                .fold(0.0, f64::max)
        };
        let sphere_fits = solution
            .balls
            .iter()
            .zip(&solution.fits)
            .flat_map(|(b, fits)| {
                solution
                    .angles_deg
                    .iter()
                    .zip(fits)
                    .map(move |(a, f)| fit_report(b, *a, f))
            })
            .collect();
        Report {
            method: "rotary",
            source: source.to_string(),
            input,
            balls,
            errors,
            location,
            components,
            ranges: RangesReport {
                errors: Six::from_si(&solution.ranges()),
                components: solution
                    .axis
                    .as_ref()
                    .map(|a| Six::from_si(&a.component_ranges())),
            },
            condition: solution.layout.condition,
            condition_limit: super::CONDITION_LIMIT,
            scale_mm: solution.layout.scale_mm,
            residual_rms_um: solution.residual_rms_mm() * UM_PER_MM,
            max_u_translation_um: max_u(0..3) * UM_PER_MM,
            max_u_rotation_urad: max_u(3..6) * URAD_PER_RAD,
            sphere_fits,
            interpolated: at.iter().map(interpolated_report).collect(),
            conventions: conventions(),
            warnings: solution.warnings.clone(),
        }
    }
}
