//! Spheres: algebraic start, then geometric least squares.

use nalgebra::{DMatrix, DVector, Point3, Vector3};

use super::{centroid, least_squares, solve_least_squares, validate};
use crate::lm::Residuals;
use crate::{Degeneracy, Result};

/// Geometric least-squares sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereFit {
    /// Centre.
    pub centre: Point3<f64>,
    /// Radius.
    pub radius: f64,
    /// Diameter `2·radius`.
    pub diameter: f64,
    /// Radial residual `|p − centre| − radius` of each point.
    pub residuals: Vec<f64>,
}

/// Radial residuals `|p − c| − r` of a sphere `(cx, cy, cz, r)`.
struct SphereDistances<'a> {
    points: &'a [Vector3<f64>],
}

impl Residuals for SphereDistances<'_> {
    fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
        let c = Vector3::new(p[0], p[1], p[2]);
        DVector::from_iterator(
            self.points.len(),
            self.points.iter().map(|q| (q - c).norm() - p[3]),
        )
    }

    fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
        let c = Vector3::new(p[0], p[1], p[2]);
        let mut jac = DMatrix::zeros(self.points.len(), 4);
        for (i, q) in self.points.iter().enumerate() {
            let d = q - c;
            let dist = d.norm();
            // ∂|q − c|/∂c = −(q − c)/|q − c|; undefined (taken as 0) at the centre.
            if dist > 0.0 {
                for k in 0..3 {
                    jac[(i, k)] = -d[k] / dist;
                }
            }
            jac[(i, 3)] = -1.0;
        }
        jac
    }
}

/// Algebraic sphere: linear least squares on `|p|² + D·p + G = 0`, on points
/// centred at their centroid and scaled to unit RMS radius.
/// Returns `(centre, radius)` in the coordinates of `points`.
fn algebraic(points: &[Vector3<f64>]) -> Result<(Vector3<f64>, f64)> {
    const WHAT: &str = "algebraic sphere";
    let n = points.len();
    let scale = (points.iter().map(|q| q.norm_squared()).sum::<f64>() / n as f64).sqrt();
    if scale <= 0.0 {
        return Err(Degeneracy::Coincide { what: WHAT }.into());
    }
    let local: Vec<Vector3<f64>> = points.iter().map(|q| q / scale).collect();
    let design = DMatrix::from_fn(n, 4, |i, j| if j < 3 { local[i][j] } else { 1.0 });
    let rhs = DVector::from_iterator(n, local.iter().map(|q| -q.norm_squared()));
    let sol = solve_least_squares(design, &rhs, WHAT)?;
    let centre = Vector3::new(-sol[0] / 2.0, -sol[1] / 2.0, -sol[2] / 2.0);
    let r2 = centre.norm_squared() - sol[3];
    if r2 <= 0.0 {
        return Err(Degeneracy::NoRealElement {
            what: WHAT,
            element: "sphere",
        }
        .into());
    }
    Ok((centre * scale, r2.sqrt() * scale))
}

/// Geometric least-squares sphere: minimises `Σ(|p − c| − r)²` (algebraic
/// start, Levenberg–Marquardt, in coordinates centred at the centroid).
pub fn sphere(points: &[Point3<f64>]) -> Result<SphereFit> {
    validate(points, "sphere fit", 4)?;
    let origin = centroid(points);
    let local: Vec<Vector3<f64>> = points.iter().map(|p| p - origin).collect();
    let (c0, r0) = algebraic(&local)?;
    let problem = SphereDistances { points: &local };
    let p = least_squares(&problem, DVector::from_vec(vec![c0.x, c0.y, c0.z, r0]))?;
    let c = Vector3::new(p[0], p[1], p[2]);
    let radius = p[3].abs();
    let residuals = local.iter().map(|q| (q - c).norm() - radius).collect();
    Ok(SphereFit {
        centre: origin + c,
        radius,
        diameter: 2.0 * radius,
        residuals,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GeomError;

    #[test]
    fn sphere_jacobian_is_analytic() {
        let points: Vec<_> = (0..7)
            .map(|k| {
                let t = k as f64;
                Vector3::new(t.cos() * 3.0, (1.3 * t).sin() * 2.0, t * 0.4)
            })
            .collect();
        let problem = SphereDistances { points: &points };
        let at = DVector::from_vec(vec![0.3, -0.2, 0.1, 2.5]);
        assert!(crate::lm::jacobian_error(&problem, &at) < 1e-7);
    }

    #[test]
    fn sphere_recovers_a_cap() {
        // Five probed points as in docs/probe-rotary.md: north pole plus four on a
        // small circle, on a 12.5 mm ball far from the origin.
        let c = Point3::new(250.0, -100.0, 75.0);
        let r = 12.5;
        let mut pts = vec![c + Vector3::z() * r];
        for k in 0..4 {
            let t = k as f64 * std::f64::consts::FRAC_PI_2 + 0.1;
            let polar = 1.2_f64;
            pts.push(
                c + Vector3::new(t.cos() * polar.sin(), t.sin() * polar.sin(), polar.cos()) * r,
            );
        }
        let fit = sphere(&pts).unwrap();
        assert!((fit.centre - c).norm() < 1e-11);
        assert!((fit.diameter - 2.0 * r).abs() < 1e-11);
        assert!(fit.residuals.iter().all(|e| e.abs() < 1e-11));
    }

    #[test]
    fn degenerate_spheres_are_errors() {
        // Coplanar points on a circle determine no sphere.
        let ring: Vec<_> = (0..8)
            .map(|k| {
                let t = k as f64 * 0.8;
                Point3::new(t.cos(), t.sin(), 3.0)
            })
            .collect();
        assert!(matches!(sphere(&ring), Err(GeomError::Degenerate(_))));
        assert!(matches!(
            sphere(&ring[..3]),
            Err(GeomError::TooFewPoints { .. })
        ));
        let mut bad = ring.clone();
        bad[0].x = f64::INFINITY;
        assert!(matches!(sphere(&bad), Err(GeomError::NonFinite(_))));
    }
}
