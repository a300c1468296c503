//! The layout check and the per-angle least squares of the six errors
//! (docs/probe-rotary.md): for each angle θ and ball i, `Pᵢ = Rz(θ)·P0ᵢ` and the
//! three rows of `ΔPᵢ = δ + ε × Pᵢ` (`geom::transform::SmallError`); the
//! stacked system `A·X = b` (3 rows per ball) is solved by least squares,
//! `X = (AᵀA)⁻¹Aᵀb`, through the Householder QR decomposition of `A`
//! (nalgebra's SVD can lose 8 digits on such matrices, dimforge/nalgebra
//! issue 1172; QR keeps them).
//!
//! The rotation columns of `A` are divided by the layout's size `L` (RMS
//! distance of the balls from their centroid) so that all six unknowns are
//! lengths: the condition number of the scaled design is then a property of
//! the layout alone (a turn about Z rotates `A` without changing its
//! singular values), and it is what the layout check compares with
//! [`CONDITION_LIMIT`].

use geom::nalgebra::{DMatrix, DVector, Matrix6, Point3, Vector3};
use geom::transform::SmallError;

use super::{Measurement, SixErrors, rz};
use crate::{CentreFault, ProbeError, Result, Unsolvable};

/// Largest condition number of the scaled design accepted. The seed's
/// layout (three balls about 150 mm from the axis at three heights) has
/// 1.9; three balls on a 300 mm line with the middle one 30 mm off it have
/// 12, 10 mm off 34, 1 mm off 340; three balls within 1 mm of the axis
/// 160. Noise reaches the poorly seen rotation amplified by up to the
/// condition number: beyond 100 a 0.3 µm probing noise would become tens
/// of µm (at the scale length) in that rotation.
pub const CONDITION_LIMIT: f64 = 100.0;

/// Largest displacement `|ΔP|` (mm) of a centre from the ideal position
/// accepted: errors of a rotary table are micrometres to tens of
/// micrometres (an axis a few tenths of a millimetre off the frame's Z
/// still fits); millimetres mean a wrong angle, ball or sense of rotation,
/// for which the small-error model is meaningless.
pub const MAX_DISPLACEMENT_MM: f64 = 2.0;

/// The layout of the balls as the least squares sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    /// Condition number `σmax/σmin` of the scaled design (∞ when singular).
    pub condition: f64,
    /// The scale `L` (mm) that divides the rotation columns: RMS distance of
    /// the reference centres from their centroid.
    pub scale_mm: f64,
}

/// The six errors identified at one angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AngleErrors {
    /// The angle (degrees).
    pub angle_deg: f64,
    /// EXC, EYC, EZC (mm), EAC, EBC, ECC (rad).
    pub errors: SixErrors,
    /// Standard uncertainties of the six, from the residuals:
    /// `√diag(s²·(AᵀA)⁻¹)`, `s² = Σr²/(3n − 6)`. Zero at 0° (the reference).
    pub uncertainty: SixErrors,
    /// The covariance `s²·(AᵀA)⁻¹` of the six (mm², mm·rad, rad²).
    pub covariance: Matrix6<f64>,
    /// RMS of the residuals `b − A·X` (mm).
    pub residual_rms_mm: f64,
    /// Largest absolute residual (mm).
    pub max_residual_mm: f64,
    /// Number of residuals (3 per ball).
    pub residuals: usize,
}

/// Scaled design rows of one ideal position: [`SmallError::design_rows`]
/// with the rotation columns divided by `scale`.
fn scaled_rows(ideal: &Point3<f64>, scale: f64) -> [[f64; 6]; 3] {
    let mut rows = SmallError::design_rows(ideal);
    for row in &mut rows {
        for v in &mut row[3..] {
            *v /= scale;
        }
    }
    rows
}

/// The scaled design of the ideal positions `points`.
fn design(points: &[Point3<f64>], scale: f64) -> DMatrix<f64> {
    let mut a = DMatrix::zeros(3 * points.len(), 6);
    for (i, p) in points.iter().enumerate() {
        for (k, row) in scaled_rows(p, scale).iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                a[(3 * i + k, j)] = *v;
            }
        }
    }
    a
}

/// The layout check's figures for the reference centres: the scale `L` and
/// the condition number of the scaled design (the same at every angle).
pub fn layout(reference: &[Point3<f64>]) -> Result<Layout> {
    if reference.len() < 3 {
        return Err(Unsolvable::TooFewCentres {
            centres: reference.len(),
        }
        .into());
    }
    let n = reference.len() as f64;
    let centroid = reference.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / n;
    let scale_mm = (reference
        .iter()
        .map(|p| (p.coords - centroid).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    if !(scale_mm > 0.0 && scale_mm.is_finite()) {
        return Err(Unsolvable::CoincidentCentres.into());
    }
    let sv = design(reference, scale_mm).singular_values();
    let (lo, hi) = sv.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), s| {
        (lo.min(*s), hi.max(*s))
    });
    let condition = if lo > 0.0 { hi / lo } else { f64::INFINITY };
    Ok(Layout {
        condition,
        scale_mm,
    })
}

/// A centre too far from its ideal position for the small-error model: an
/// error naming the centre, and the sense of rotation when a clockwise turn
/// would fit.
fn check_displacement(ball: &str, angle_deg: f64, p0: &Point3<f64>, p: &Point3<f64>) -> Result<()> {
    let d = (p - rz(angle_deg) * p0).norm();
    if d <= MAX_DISPLACEMENT_MM {
        return Ok(());
    }
    let clockwise = (p - rz(-angle_deg) * p0).norm() <= MAX_DISPLACEMENT_MM;
    Err(ProbeError::Centre {
        ball: ball.to_string(),
        angle_deg,
        fault: CentreFault::Displaced {
            distance_mm: d,
            angle_deg,
            clockwise,
        },
    })
}

/// The six errors at every measured angle (docs/probe-rotary.md), after the
/// displacement check of every centre.
pub(crate) fn errors_per_angle(m: &Measurement, layout: &Layout) -> Result<Vec<AngleErrors>> {
    let reference = m.reference();
    let scale = layout.scale_mm;
    let mut out = Vec::with_capacity(m.angles_deg.len());
    for (k, &angle) in m.angles_deg.iter().enumerate() {
        let ideal: Vec<Point3<f64>> = reference.iter().map(|p0| rz(angle) * p0).collect();
        let mut b = DVector::zeros(3 * m.balls.len());
        for (i, ball) in m.balls.iter().enumerate() {
            let p = ball.centres[k];
            check_displacement(&ball.name, angle, &reference[i], &p)?;
            let d = p - ideal[i];
            for c in 0..3 {
                b[3 * i + c] = d[c];
            }
        }
        out.push(solve_angle(angle, &design(&ideal, scale), &b, scale)?);
    }
    Ok(out)
}

/// Least squares of one angle on the scaled design `a`; the solution and
/// covariance are scaled back to mm and rad.
fn solve_angle(
    angle_deg: f64,
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    scale: f64,
) -> Result<AngleErrors> {
    let qr = a.clone().qr();
    let scaled = qr
        .r()
        .solve_upper_triangular(&(qr.q().transpose() * b))
        .ok_or(Unsolvable::SingularDesign { angle_deg })?;
    let residual = b - a * &scaled;
    let m = residual.len();
    let ssr = residual.norm_squared();
    let cov_scaled =
        geom::lm::covariance(a, ssr, m, 6).ok_or(Unsolvable::NoCovariance { angle_deg })?;
    // Unscale: X = S·X_s with S = diag(1, 1, 1, 1/L, 1/L, 1/L).
    let s = SixErrors::new(1.0, 1.0, 1.0, 1.0 / scale, 1.0 / scale, 1.0 / scale);
    let errors = scaled.fixed_rows::<6>(0).component_mul(&s);
    let cov_scaled = Matrix6::from_fn(|i, j| cov_scaled[(i, j)]);
    let covariance = Matrix6::from_diagonal(&s) * cov_scaled * Matrix6::from_diagonal(&s);
    let uncertainty = covariance.diagonal().map(|v| v.max(0.0).sqrt());
    Ok(AngleErrors {
        angle_deg,
        errors,
        uncertainty,
        covariance,
        residual_rms_mm: (ssr / m as f64).sqrt(),
        max_residual_mm: residual.amax(),
        residuals: m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seed_layout() -> Vec<Point3<f64>> {
        vec![
            Point3::new(150.0, 10.0, 60.0),
            Point3::new(-70.0, 120.0, 95.0),
            Point3::new(-55.0, -135.0, 30.0),
        ]
    }

    #[test]
    fn condition_does_not_depend_on_the_angle() {
        let l = layout(&seed_layout()).unwrap();
        let turned: Vec<_> = seed_layout().iter().map(|p| rz(73.0) * p).collect();
        let t = layout(&turned).unwrap();
        assert!((l.condition - t.condition).abs() < 1e-9 * l.condition);
        assert!(l.condition < 10.0, "{}", l.condition);
    }

    #[test]
    fn collinear_balls_are_singular() {
        // On one line through the axis: the rotation about that line is unseen.
        let line = [
            Point3::new(-100.0, 0.0, 50.0),
            Point3::new(50.0, 0.0, 50.0),
            Point3::new(150.0, 0.0, 50.0),
        ];
        assert!(layout(&line).unwrap().condition > 1e12);
        // All on the axis.
        let axis = [
            Point3::new(0.0, 0.0, 20.0),
            Point3::new(0.0, 0.0, 60.0),
            Point3::new(0.0, 0.0, 90.0),
        ];
        assert!(layout(&axis).unwrap().condition > 1e12);
        assert!(layout(&axis[..2]).is_err());
    }

    #[test]
    fn nearly_collinear_is_ill_conditioned() {
        let l = layout(&[
            Point3::new(-150.0, 0.0, 50.0),
            Point3::new(150.0, 0.0, 50.0),
            Point3::new(0.0, 1.0, 50.0),
        ])
        .unwrap();
        assert!(l.condition > CONDITION_LIMIT, "{}", l.condition);
    }

    #[test]
    fn clockwise_angles_are_named() {
        let p0 = Point3::new(150.0, 10.0, 60.0);
        let e = check_displacement("1", 30.0, &p0, &(rz(-30.0) * p0)).unwrap_err();
        assert!(e.to_string().contains("clockwise"), "{e}");
        assert!(e.to_string().contains("ball 1 at 30°"), "{e}");
        assert!(check_displacement("1", 30.0, &p0, &(rz(30.0) * p0)).is_ok());
    }
}
