//! The axis average line (ISO 230-7 location errors X0C, Y0C, A0C, B0C)
//! separated from the component errors.
//!
//! # Derivation
//! Let the table turn about a fixed axis through `c = (X0C, Y0C, 0)` with
//! direction `Rt·z`, `Rt` the rotation by `t = (A0C, B0C, 0)`, and let
//! `(δc(θ), εc(θ))` be the component error motion that the table adds to
//! that turn. A ball at `q` on the table is at `P(θ) = Ec(θ)·A(θ)·q`, and to
//! first order its errors against the ideal `Rz(θ)·P(0)` of §2 are
//!
//! ```text
//! δ(θ) = (I − Rz(θ))·c + δc(θ) − Rz(θ)·δc(0)
//! ε(θ) = (I − Rz(θ))·t + εc(θ) − Rz(θ)·εc(0)
//! ```
//!
//! (a pure offset gives `δ = (I − Rz)·c` exactly; `A(θ)·Rz(θ)ᵀ` is a
//! rotation by `(I − Rz)·t` about an axis through `c`, whose translation
//! adds `−ε × Rz·c` to δz: µrad × µm, below 10⁻⁶ µm, left out). The last
//! terms come from taking the centre at 0° as the reference: the error of
//! the reference pose turns with the table.
//!
//! The axis average line is the mean location of the axis over the turn,
//! so the component errors have zero mean. In the x–y components of δ and
//! ε that leaves the model `a − Rz(θ)·b` with `a = (X0C, Y0C)` or
//! `(A0C, B0C)` and `b = a + (reference-pose error)`, fitted by least
//! squares over the measured angles, the same weight at each. Over a full
//! turn in equal steps the functions 1, cos θ, sin θ are orthogonal and
//! `a` is simply the mean of EXC, EYC (EAC, EBC) over the angles; for other
//! angle sets the fit keeps the constant apart from the once-per-turn
//! terms, as long as [`LOCATION_CONDITION_LIMIT`] holds.
//!
//! The component errors are what remains once the fixed axis is taken
//! out: `E(θ) − ((I − Rz)·(X0C, Y0C, 0), (I − Rz)·(A0C, B0C, 0))`, zero at
//! 0° like the errors themselves. EZC and ECC carry no location term.

use geom::nalgebra::{DMatrix, DVector, Matrix2, Vector2, Vector3};

use super::{AngleErrors, SixErrors, rz};
use crate::{Conditioning, ProbeError, Result, Unsolvable};

/// Largest condition number of the location fit's design accepted. A full
/// turn in equal steps has 1 (orthogonal functions); angles over part of a
/// turn mix the constant with the once-per-turn terms (0°…180° in 30°
/// steps: 1.81; 0°…150°: 2.15; 0°…90°: 3.35). The limit asks for about
/// half a turn: less would make the location errors mostly a guess from
/// the arc's curvature.
pub const LOCATION_CONDITION_LIMIT: f64 = 2.0;

/// A location fit whose condition number exceeds 1 by more than this is
/// not a full turn in equal steps: the location errors then rest on the
/// model (no constant or once-per-turn part in the component errors), and
/// the report says so.
pub(crate) const FULL_TURN_TOLERANCE: f64 = 1e-6;

/// Location errors of the axis average line (ISO 230-7) and their standard
/// uncertainties.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Location {
    /// X0C: x where the axis average line crosses Z = 0 (mm).
    pub x0c_mm: f64,
    /// Y0C: y where the axis average line crosses Z = 0 (mm).
    pub y0c_mm: f64,
    /// A0C: right-hand rotation about X turning +Z onto the line's direction (rad).
    pub a0c_rad: f64,
    /// B0C: right-hand rotation about Y turning +Z onto the line's direction (rad).
    pub b0c_rad: f64,
    /// Standard uncertainties of X0C, Y0C (mm), A0C, B0C (rad), propagated
    /// from the per-angle covariances (angles taken as independent).
    pub uncertainty: [f64; 4],
}

impl Location {
    /// The errors a fixed axis so placed makes at `angle_deg`:
    /// `δ = (I − Rz)·(X0C, Y0C, 0)`, `ε = (I − Rz)·(A0C, B0C, 0)`.
    pub fn fixed_axis_errors(&self, angle_deg: f64) -> SixErrors {
        let r = rz(angle_deg);
        let c = Vector3::new(self.x0c_mm, self.y0c_mm, 0.0);
        let t = Vector3::new(self.a0c_rad, self.b0c_rad, 0.0);
        let d = c - r * c;
        let e = t - r * t;
        SixErrors::new(d.x, d.y, d.z, e.x, e.y, e.z)
    }

    /// Direction of the axis average line (unit): `Ry(B0C)·Rx(A0C)·z`,
    /// ≈ (B0C, −A0C, 1).
    pub fn direction(&self) -> Vector3<f64> {
        let (sa, ca) = self.a0c_rad.sin_cos();
        let (sb, cb) = self.b0c_rad.sin_cos();
        Vector3::new(sb * ca, -sa, cb * ca)
    }
}

/// The axis average line and what remains of the errors without it.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisLine {
    /// The location errors.
    pub location: Location,
    /// Condition number of the location fit's design.
    pub condition: f64,
    /// Component errors per measured angle: errors − fixed-axis errors.
    pub components: Vec<SixErrors>,
}

impl AxisLine {
    /// Range (max − min over the measured angles) of each component error.
    pub fn component_ranges(&self) -> SixErrors {
        super::ranges(self.components.iter().copied())
    }
}

/// Rows of the model `a − Rz(θ)·b` for unknowns `(ax, ay, bx, by)`.
fn model_rows(angle_deg: f64) -> [[f64; 4]; 2] {
    let (s, c) = angle_deg.to_radians().sin_cos();
    [[1.0, 0.0, -c, s], [0.0, 1.0, -s, -c]]
}

/// The axis average line from the errors per angle (see the module's
/// derivation); an [`ProbeError::IllConditioned`] when the angles do not
/// separate it.
pub(crate) fn axis_line(angles_deg: &[f64], errors: &[AngleErrors]) -> Result<AxisLine> {
    let n = angles_deg.len();
    if n < 2 || errors.len() != n {
        return Err(Unsolvable::AxisLineTooFewErrors {
            errors: errors.len(),
            angles: n,
        }
        .into());
    }
    let mut d = DMatrix::zeros(2 * n, 4);
    for (k, &a) in angles_deg.iter().enumerate() {
        for (r, row) in model_rows(a).iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                d[(2 * k + r, j)] = *v;
            }
        }
    }
    let svd = d.clone().svd(true, true);
    let (lo, hi) = svd
        .singular_values
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), s| {
            (lo.min(*s), hi.max(*s))
        });
    let condition = if lo > 0.0 { hi / lo } else { f64::INFINITY };
    if condition > LOCATION_CONDITION_LIMIT {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::AxisLine,
            condition,
            limit: LOCATION_CONDITION_LIMIT,
        });
    }
    // (DᵀD)⁻¹Dᵀ: D is orthogonal over a full turn and never worse than the limit.
    let pinv = (d.transpose() * &d)
        .try_inverse()
        .ok_or(Unsolvable::AxisLineSingular)?
        * d.transpose();
    // (value, variance) of the constant `a` of the pair of errors at `first`, `first + 1`.
    let fit = |first: usize| -> (Vector2<f64>, Matrix2<f64>) {
        let y = DVector::from_iterator(
            2 * n,
            errors
                .iter()
                .flat_map(|e| [e.errors[first], e.errors[first + 1]]),
        );
        let a = (&pinv * y).fixed_rows::<2>(0).into_owned();
        let mut cov = Matrix2::zeros();
        for (k, e) in errors.iter().enumerate() {
            let g = pinv.fixed_view::<2, 2>(0, 2 * k).into_owned();
            let c = e.covariance.fixed_view::<2, 2>(first, first).into_owned();
            cov += g * c * g.transpose();
        }
        (a, cov)
    };
    let (offset, cov_offset) = fit(0);
    let (tilt, cov_tilt) = fit(3);
    let sd = |v: f64| v.max(0.0).sqrt();
    let location = Location {
        x0c_mm: offset.x,
        y0c_mm: offset.y,
        a0c_rad: tilt.x,
        b0c_rad: tilt.y,
        uncertainty: [
            sd(cov_offset[(0, 0)]),
            sd(cov_offset[(1, 1)]),
            sd(cov_tilt[(0, 0)]),
            sd(cov_tilt[(1, 1)]),
        ],
    };
    let components = errors
        .iter()
        .map(|e| e.errors - location.fixed_axis_errors(e.angle_deg))
        .collect();
    Ok(AxisLine {
        location,
        condition,
        components,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::nalgebra::Matrix6;

    fn angle_errors(angle_deg: f64, errors: SixErrors) -> AngleErrors {
        AngleErrors {
            angle_deg,
            errors,
            uncertainty: SixErrors::zeros(),
            covariance: Matrix6::identity() * 1e-8,
            residual_rms_mm: 0.0,
            max_residual_mm: 0.0,
            residuals: 9,
        }
    }

    fn steps(step: f64) -> Vec<f64> {
        (0..)
            .map(|k| f64::from(k) * step)
            .take_while(|a| *a < 360.0)
            .collect()
    }

    #[test]
    fn a_fixed_axis_is_all_location() {
        let truth = Location {
            x0c_mm: 0.012,
            y0c_mm: -0.008,
            a0c_rad: 25e-6,
            b0c_rad: 40e-6,
            uncertainty: [0.0; 4],
        };
        let angles = steps(30.0);
        let errors: Vec<_> = angles
            .iter()
            .map(|a| angle_errors(*a, truth.fixed_axis_errors(*a)))
            .collect();
        let line = axis_line(&angles, &errors).unwrap();
        let l = line.location;
        assert!((l.x0c_mm - 0.012).abs() < 1e-15 && (l.y0c_mm + 0.008).abs() < 1e-15);
        assert!((l.a0c_rad - 25e-6).abs() < 1e-18 && (l.b0c_rad - 40e-6).abs() < 1e-18);
        assert!((line.condition - 1.0).abs() < 1e-12);
        assert!(line.component_ranges().amax() < 1e-15);
        // A full turn: X0C is the mean of 12 angles, each of variance 1e-8 mm².
        assert!((l.uncertainty[0] - (1e-8_f64 / 12.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn reference_pose_error_does_not_move_the_line() {
        // Component errors with zero mean, seen from a reference pose that
        // carries the component error at 0°: δ = (I − Rz)c + δc(θ) − Rz·δc(0).
        let c = Vector3::new(0.005, 0.002, 0.0);
        let dc = |a: f64| {
            let t = a.to_radians();
            Vector3::new(
                0.001 * (2.0 * t).cos(),
                0.0007 * (3.0 * t).sin() + 0.0004 * (2.0 * t).cos(),
                0.0,
            )
        };
        let angles = steps(20.0);
        let errors: Vec<_> = angles
            .iter()
            .map(|&a| {
                let d = c - rz(a) * c + dc(a) - rz(a) * dc(0.0);
                angle_errors(a, SixErrors::new(d.x, d.y, 0.0, 0.0, 0.0, 0.0))
            })
            .collect();
        let l = axis_line(&angles, &errors).unwrap().location;
        assert!((l.x0c_mm - c.x).abs() < 1e-15, "{}", l.x0c_mm);
        assert!((l.y0c_mm - c.y).abs() < 1e-15, "{}", l.y0c_mm);
    }

    #[test]
    fn a_short_arc_is_refused() {
        let angles = [0.0, 30.0, 60.0, 90.0, 120.0];
        let errors: Vec<_> = angles
            .iter()
            .map(|a| angle_errors(*a, SixErrors::zeros()))
            .collect();
        assert!(matches!(
            axis_line(&angles, &errors),
            Err(ProbeError::IllConditioned { .. })
        ));
        let half: Vec<f64> = (0..=6).map(|k| f64::from(k) * 30.0).collect();
        let errors: Vec<_> = half
            .iter()
            .map(|a| angle_errors(*a, SixErrors::zeros()))
            .collect();
        assert!(axis_line(&half, &errors).is_ok());
    }

    #[test]
    fn direction_follows_the_sign_convention() {
        let l = Location {
            x0c_mm: 0.0,
            y0c_mm: 0.0,
            a0c_rad: 1e-4,
            b0c_rad: 2e-4,
            uncertainty: [0.0; 4],
        };
        let d = l.direction();
        assert!((d - Vector3::new(2e-4, -1e-4, 1.0)).norm() < 1e-7);
    }
}
