//! `report.json` of `trinocular probe rotary` (docs/formats.md): the errors
//! per angle in µm and µrad (`errors`), the location errors of the axis
//! average line (`location`: `X0C_um`, `Y0C_um`, `A0C_urad`, `B0C_urad`),
//! the layout's condition number (`condition`), and beyond the contract the
//! component errors, the ranges a user signs off, the sphere fits and the
//! interpolated angles. The types live in `formats::probe::rotary::report`;
//! [`report()`] fills them.

use formats::probe::rotary::LocationErrors;
pub use formats::probe::rotary::report::{
    AngleReport, BallReport, InputKind, LocationReport, RangesReport, Report, Six, SphereFitReport,
    USix,
};

use super::{CentreFit, Interpolated, SixErrors, Solution};

/// mm → µm.
const UM_PER_MM: f64 = 1e3;
/// rad → µrad.
const URAD_PER_RAD: f64 = 1e6;

/// The six errors in report units (µm, µrad) from mm and rad.
fn six(v: &SixErrors) -> Six {
    Six {
        exc_um: v[0] * UM_PER_MM,
        eyc_um: v[1] * UM_PER_MM,
        ezc_um: v[2] * UM_PER_MM,
        eac_urad: v[3] * URAD_PER_RAD,
        ebc_urad: v[4] * URAD_PER_RAD,
        ecc_urad: v[5] * URAD_PER_RAD,
    }
}

/// Standard uncertainties in report units (µm, µrad) from mm and rad.
fn u_six(v: &SixErrors) -> USix {
    let s = six(v);
    USix {
        exc_um: s.exc_um,
        eyc_um: s.eyc_um,
        ezc_um: s.ezc_um,
        eac_urad: s.eac_urad,
        ebc_urad: s.ebc_urad,
        ecc_urad: s.ecc_urad,
    }
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
        errors: six(&i.errors),
        uncertainty: Some(u_six(&i.uncertainty)),
        residual_rms_um: None,
    }
}

/// The report of a solution; `source` names the input, `at` holds the
/// interpolated angles asked for.
pub fn report(solution: &Solution, source: &str, at: &[Interpolated]) -> Report {
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
            errors: six(&e.errors),
            uncertainty: Some(u_six(&e.uncertainty)),
            residual_rms_um: Some(e.residual_rms_mm * UM_PER_MM),
        })
        .collect();
    let location = solution.axis.as_ref().map(|a| {
        let l = &a.location;
        let d = l.direction();
        LocationReport {
            errors: LocationErrors {
                x0c_um: l.x0c_mm * UM_PER_MM,
                y0c_um: l.y0c_mm * UM_PER_MM,
                a0c_urad: l.a0c_rad * URAD_PER_RAD,
                b0c_urad: l.b0c_rad * URAD_PER_RAD,
            },
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
                errors: six(c),
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
            errors: six(&solution.ranges()),
            components: solution.axis.as_ref().map(|a| six(&a.component_ranges())),
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
        uncertainty: None,
    }
}
