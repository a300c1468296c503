//! Circles: geometric least squares in the plane, and the NIST two-step circle
//! in space (least-squares plane, then a 2-D circle in that plane).

use nalgebra::{DMatrix, DVector, Point2, Point3, Vector2, Vector3};

use super::{centroid, least_squares, orthonormal_basis, plane, solve_least_squares, validate};
use crate::lm::Residuals;
use crate::{Degeneracy, Result};

/// Geometric least-squares circle in the plane.
#[derive(Debug, Clone, PartialEq)]
pub struct Circle2Fit {
    /// Centre.
    pub centre: Point2<f64>,
    /// Radius.
    pub radius: f64,
    /// Diameter `2·radius`.
    pub diameter: f64,
    /// Radial residual `|p − centre| − radius` of each point.
    pub residuals: Vec<f64>,
}

/// Least-squares circle in space (NIST two-step definition).
#[derive(Debug, Clone, PartialEq)]
pub struct Circle3Fit {
    /// Centre (in the least-squares plane).
    pub centre: Point3<f64>,
    /// Unit normal of the least-squares plane.
    pub normal: Vector3<f64>,
    /// Radius.
    pub radius: f64,
    /// Diameter `2·radius`.
    pub diameter: f64,
    /// In-plane radial residual `|p' − centre| − radius` of each point, `p'`
    /// being the point projected onto the plane (the quantity minimised).
    pub residuals: Vec<f64>,
    /// Signed height `(p − centre)·normal` of each point above the plane.
    pub heights: Vec<f64>,
}

/// Radial residuals `|p − c| − r` of a circle `(cx, cy, r)`.
struct CircleDistances<'a> {
    points: &'a [Vector2<f64>],
}

impl Residuals for CircleDistances<'_> {
    fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
        let c = Vector2::new(p[0], p[1]);
        DVector::from_iterator(
            self.points.len(),
            self.points.iter().map(|q| (q - c).norm() - p[2]),
        )
    }

    fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
        let c = Vector2::new(p[0], p[1]);
        let mut jac = DMatrix::zeros(self.points.len(), 3);
        for (i, q) in self.points.iter().enumerate() {
            let d = q - c;
            let dist = d.norm();
            // ∂|q − c|/∂c = −(q − c)/|q − c|; undefined (taken as 0) at the centre.
            if dist > 0.0 {
                jac[(i, 0)] = -d.x / dist;
                jac[(i, 1)] = -d.y / dist;
            }
            jac[(i, 2)] = -1.0;
        }
        jac
    }
}

/// Algebraic (Kåsa) circle: linear least squares on `x² + y² + Dx + Ey + F = 0`,
/// on points centred at their centroid and scaled to unit RMS radius.
/// Returns `(centre, radius)` in the coordinates of `points`.
pub(super) fn kasa(points: &[Vector2<f64>]) -> Result<(Vector2<f64>, f64)> {
    const WHAT: &str = "algebraic circle";
    let n = points.len();
    let mean = points.iter().sum::<Vector2<f64>>() / n as f64;
    let scale = (points
        .iter()
        .map(|q| (q - mean).norm_squared())
        .sum::<f64>()
        / n as f64)
        .sqrt();
    if scale <= 0.0 {
        return Err(Degeneracy::Coincide { what: WHAT }.into());
    }
    let local: Vec<Vector2<f64>> = points.iter().map(|q| (q - mean) / scale).collect();
    let design = DMatrix::from_fn(n, 3, |i, j| match j {
        0 => local[i].x,
        1 => local[i].y,
        _ => 1.0,
    });
    let rhs = DVector::from_iterator(n, local.iter().map(|q| -q.norm_squared()));
    let sol = solve_least_squares(design, &rhs, WHAT)?;
    let centre = Vector2::new(-sol[0] / 2.0, -sol[1] / 2.0);
    let r2 = centre.norm_squared() - sol[2];
    if r2 <= 0.0 {
        return Err(Degeneracy::NoRealElement {
            what: WHAT,
            element: "circle",
        }
        .into());
    }
    Ok((mean + centre * scale, r2.sqrt() * scale))
}

/// Geometric circle fit of points already centred near the origin:
/// Kåsa start, then Levenberg–Marquardt on `|p − c| − r`.
pub(super) fn circle_local(points: &[Vector2<f64>]) -> Result<(Vector2<f64>, f64, Vec<f64>)> {
    let (c0, r0) = kasa(points)?;
    let problem = CircleDistances { points };
    let p = least_squares(&problem, DVector::from_vec(vec![c0.x, c0.y, r0]))?;
    let (centre, radius) = (Vector2::new(p[0], p[1]), p[2].abs());
    let residuals = points
        .iter()
        .map(|q| (q - centre).norm() - radius)
        .collect();
    Ok((centre, radius, residuals))
}

/// Geometric least-squares circle in 2-D: minimises `Σ(|p − c| − r)²`
/// (Kåsa algebraic start, Levenberg–Marquardt).
pub fn circle_2d(points: &[Point2<f64>]) -> Result<Circle2Fit> {
    validate(points, "2-D circle fit", 3)?;
    let origin = centroid(points);
    let local: Vec<Vector2<f64>> = points.iter().map(|p| p - origin).collect();
    let (c, radius, residuals) = circle_local(&local)?;
    Ok(Circle2Fit {
        centre: origin + c,
        radius,
        diameter: 2.0 * radius,
        residuals,
    })
}

/// Least-squares circle in 3-D, NIST two-step: least-squares plane
/// ([`plane`]), then [`circle_2d`] of the points projected onto it.
pub fn circle_3d(points: &[Point3<f64>]) -> Result<Circle3Fit> {
    validate(points, "3-D circle fit", 3)?;
    let pl = plane(points)?;
    let (u, v) = orthonormal_basis(&pl.normal);
    let local: Vec<Vector2<f64>> = points
        .iter()
        .map(|p| {
            let d = p - pl.point;
            Vector2::new(d.dot(&u), d.dot(&v))
        })
        .collect();
    let (c, radius, residuals) = circle_local(&local)?;
    Ok(Circle3Fit {
        centre: pl.point + u * c.x + v * c.y,
        normal: pl.normal,
        radius,
        diameter: 2.0 * radius,
        residuals,
        heights: pl.residuals,
    })
}

#[cfg(test)]
mod tests {
    use std::f64::consts::TAU;

    use super::*;
    use crate::GeomError;

    #[test]
    fn circle_jacobian_is_analytic() {
        let points: Vec<_> = (0..6)
            .map(|k| Vector2::new((k as f64).cos() * 3.0, (k as f64 * 1.3).sin() * 2.0))
            .collect();
        let problem = CircleDistances { points: &points };
        let at = DVector::from_vec(vec![0.3, -0.2, 2.5]);
        assert!(crate::lm::jacobian_error(&problem, &at) < 1e-7);
    }

    #[test]
    fn circle_2d_is_the_least_squares_optimum() {
        // 60° arc with ±1 µm alternating radial noise.
        let (c, r) = (Point2::new(120.0, -35.0), 12.5);
        let pts: Vec<_> = (0..13)
            .map(|k| {
                let t = 0.3 + k as f64 * TAU / 6.0 / 12.0;
                let rr = r + if k % 2 == 0 { 1e-3 } else { -1e-3 };
                c + Vector2::new(t.cos(), t.sin()) * rr
            })
            .collect();
        let fit = circle_2d(&pts).unwrap();
        // Normal equations Jᵀr = 0: Σe = 0 and Σe·(p − c)/|p − c| = 0.
        let sum: f64 = fit.residuals.iter().sum();
        let moment: Vector2<f64> = pts
            .iter()
            .zip(&fit.residuals)
            .map(|(p, e)| (p - fit.centre).normalize() * *e)
            .sum();
        assert!(
            sum.abs() < 1e-13 && moment.norm() < 1e-13,
            "{sum} {moment:?}"
        );
        let cost = |centre: Point2<f64>, radius: f64| -> f64 {
            pts.iter()
                .map(|p| ((p - centre).norm() - radius).powi(2))
                .sum()
        };
        assert!(cost(fit.centre, fit.radius) <= cost(c, r));
        assert!((fit.centre - c).norm() < 1e-2);
        let exact: Vec<_> = (0..5)
            .map(|k| c + Vector2::new((k as f64).cos(), (k as f64).sin()) * r)
            .collect();
        let fit = circle_2d(&exact).unwrap();
        assert!((fit.centre - c).norm() < 1e-12);
        assert!((fit.diameter - 2.0 * r).abs() < 1e-12);
        assert!(fit.residuals.iter().all(|e| e.abs() < 1e-12));
    }

    #[test]
    fn circle_3d_recovers_a_tilted_circle() {
        let n = Vector3::new(0.3, -0.4, 0.866).normalize();
        let (u, v) = orthonormal_basis(&n);
        let c = Point3::new(10.0, 20.0, -30.0);
        let pts: Vec<_> = (0..8)
            .map(|k| {
                let t = k as f64 * 0.7;
                c + (u * t.cos() + v * t.sin()) * 40.0
            })
            .collect();
        let fit = circle_3d(&pts).unwrap();
        assert!((fit.centre - c).norm() < 1e-11);
        assert!(fit.normal.cross(&n).norm() < 1e-13);
        assert!((fit.radius - 40.0).abs() < 1e-11);
        assert!(fit.heights.iter().all(|h| h.abs() < 1e-11));
    }

    #[test]
    fn degenerate_circles_are_errors() {
        let line: Vec<_> = (0..5)
            .map(|k| Point2::new(k as f64, 2.0 * k as f64))
            .collect();
        assert!(matches!(circle_2d(&line), Err(GeomError::Degenerate(_))));
        assert!(matches!(
            circle_2d(&line[..2]),
            Err(GeomError::TooFewPoints { .. })
        ));
        let line3: Vec<_> = line.iter().map(|p| Point3::new(p.x, p.y, 1.0)).collect();
        assert!(matches!(circle_3d(&line3), Err(GeomError::Degenerate(_))));
        let p = Point2::new(1.0, 1.0);
        assert!(circle_2d(&[p, p, p, p]).is_err());
        assert!(matches!(
            circle_2d(&[p, Point2::new(0.0, 1.0), Point2::new(f64::NAN, 0.0)]),
            Err(GeomError::NonFinite(_))
        ));
    }
}
