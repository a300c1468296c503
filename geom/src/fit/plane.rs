//! Planes: orthogonal least squares and the vertical regression `z = ax + by + c`.

use nalgebra::{DMatrix, DVector, Point3, Vector3};

use super::{
    RANK_TOLERANCE, canonical_sign, centroid, principal_axes, solve_least_squares, validate,
};
use crate::{Degeneracy, PrincipalSpread, Result};

/// Orthogonal least-squares plane.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneFit {
    /// Centroid of the points, which lies on the plane.
    pub point: Point3<f64>,
    /// Unit normal (direction of least spread of the points).
    pub normal: Vector3<f64>,
    /// Signed orthogonal distance `(p − point)·normal` of each point.
    pub residuals: Vec<f64>,
}

/// Vertical least-squares plane `z = a·x + b·y + c`.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightPlane {
    /// Slope `∂z/∂x`.
    pub a: f64,
    /// Slope `∂z/∂y`.
    pub b: f64,
    /// Height at `x = y = 0`.
    pub c: f64,
    /// Vertical residual `z − (a·x + b·y + c)` of each point.
    pub residuals: Vec<f64>,
}

/// Orthogonal least-squares plane: centroid plus the right singular vector of
/// the smallest singular value of the centred points.
pub fn plane(points: &[Point3<f64>]) -> Result<PlaneFit> {
    validate(points, "plane fit", 3)?;
    let point = centroid(points);
    let (sigma, axes) = principal_axes(points, &point)?;
    if sigma[1] <= RANK_TOLERANCE * sigma[0] {
        return Err(Degeneracy::CollinearOrCoincide { what: "plane fit" }.into());
    }
    if sigma[1] - sigma[2] <= RANK_TOLERANCE * sigma[0] {
        return Err(Degeneracy::NoSingleDirection {
            what: "plane fit",
            spread: PrincipalSpread::Least,
        }
        .into());
    }
    let normal = canonical_sign(axes.column(2).into_owned());
    let residuals = points.iter().map(|p| (p - point).dot(&normal)).collect();
    Ok(PlaneFit {
        point,
        normal,
        residuals,
    })
}

/// Vertical least-squares plane `z = a·x + b·y + c` (minimises `Σ(z − ax − by − c)²`),
/// solved by SVD on coordinates centred at the centroid.
pub fn plane_z_on_xy(points: &[Point3<f64>]) -> Result<HeightPlane> {
    const WHAT: &str = "plane z = ax + by + c";
    validate(points, WHAT, 3)?;
    let mean = centroid(points);
    let design = DMatrix::from_fn(points.len(), 2, |i, j| points[i][j] - mean[j]);
    let rhs = DVector::from_iterator(points.len(), points.iter().map(|p| p.z - mean.z));
    let slopes = solve_least_squares(design, &rhs, WHAT)?;
    let (a, b) = (slopes[0], slopes[1]);
    let c = mean.z - a * mean.x - b * mean.y;
    let residuals = points
        .iter()
        .map(|p| (p.z - mean.z) - a * (p.x - mean.x) - b * (p.y - mean.y))
        .collect();
    Ok(HeightPlane { a, b, c, residuals })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GeomError;

    fn tilted_grid() -> Vec<Point3<f64>> {
        let mut pts = Vec::new();
        for i in 0..5 {
            for j in 0..4 {
                let (x, y) = (i as f64 * 10.0 - 20.0, j as f64 * 7.0 - 10.0);
                pts.push(Point3::new(x, y, 0.002 * x - 0.001 * y + 40.0));
            }
        }
        pts
    }

    #[test]
    fn plane_recovers_an_exact_plane() {
        let pts = tilted_grid();
        let fit = plane(&pts).unwrap();
        let n = Vector3::new(-0.002, 0.001, 1.0).normalize();
        assert!(fit.normal.cross(&n).norm() < 1e-15);
        assert!(fit.normal.z > 0.0);
        assert!(fit.residuals.iter().all(|r| r.abs() < 1e-12));
    }

    #[test]
    fn height_plane_recovers_an_exact_plane() {
        let fit = plane_z_on_xy(&tilted_grid()).unwrap();
        assert!((fit.a - 0.002).abs() < 1e-15);
        assert!((fit.b + 0.001).abs() < 1e-15);
        assert!((fit.c - 40.0).abs() < 1e-13);
        assert!(fit.residuals.iter().all(|r| r.abs() < 1e-13));
    }

    #[test]
    fn height_plane_residuals_sum_to_zero() {
        let mut pts = tilted_grid();
        for (k, p) in pts.iter_mut().enumerate() {
            p.z += 1e-3 * ((k * 7 % 5) as f64 - 2.0);
        }
        let fit = plane_z_on_xy(&pts).unwrap();
        assert!(fit.residuals.iter().sum::<f64>().abs() < 1e-13);
        for (p, r) in pts.iter().zip(&fit.residuals) {
            assert!((p.z - fit.a * p.x - fit.b * p.y - fit.c - r).abs() < 1e-12);
        }
    }

    #[test]
    fn degenerate_planes_are_errors() {
        let line: Vec<_> = (0..5)
            .map(|i| Point3::new(i as f64, 2.0 * i as f64, -(i as f64)))
            .collect();
        assert!(matches!(plane(&line), Err(GeomError::Degenerate(_))));
        assert!(matches!(
            plane_z_on_xy(&line),
            Err(GeomError::Degenerate(_))
        ));
        assert!(matches!(
            plane(&line[..2]),
            Err(GeomError::TooFewPoints { .. })
        ));
        let mut bad = tilted_grid();
        bad[3].y = f64::NAN;
        assert!(matches!(plane(&bad), Err(GeomError::NonFinite(_))));
        assert!(matches!(plane_z_on_xy(&bad), Err(GeomError::NonFinite(_))));
    }
}
