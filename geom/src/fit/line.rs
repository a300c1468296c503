//! Straight lines: orthogonal least squares in 2-D and 3-D, and the vertical
//! regression `y = kx + b`.

use nalgebra::{Matrix2, Point2, Point3, SymmetricEigen, Vector2, Vector3};

use super::{RANK_TOLERANCE, canonical_sign, centroid, principal_axes, validate};
use crate::{Degeneracy, PrincipalSpread, Result};

/// Orthogonal least-squares line in the plane.
#[derive(Debug, Clone, PartialEq)]
pub struct Line2Fit {
    /// Centroid of the points, which lies on the line.
    pub point: Point2<f64>,
    /// Unit direction (principal axis of the points).
    pub direction: Vector2<f64>,
    /// Unit normal `(−d_y, d_x)`: the direction of positive residuals.
    pub normal: Vector2<f64>,
    /// Signed orthogonal distance `(p − point)·normal` of each point.
    pub residuals: Vec<f64>,
}

/// Orthogonal least-squares line in space.
#[derive(Debug, Clone, PartialEq)]
pub struct Line3Fit {
    /// Centroid of the points, which lies on the line.
    pub point: Point3<f64>,
    /// Unit direction (principal axis of the points).
    pub direction: Vector3<f64>,
    /// Orthogonal distance `|(p − point) × direction|` of each point (≥ 0: a
    /// distance from a line in space has no sign).
    pub residuals: Vec<f64>,
}

/// Vertical least-squares line `y = k·x + b`.
#[derive(Debug, Clone, PartialEq)]
pub struct SlopeLine {
    /// Slope `k`.
    pub k: f64,
    /// Intercept `b` (the value of `y` at `x = 0`).
    pub b: f64,
    /// Vertical residual `y − (k·x + b)` of each point.
    pub residuals: Vec<f64>,
}

/// Orthogonal least-squares line in 2-D: centroid plus the eigenvector of the
/// largest eigenvalue of the scatter matrix `Σ(p − p̄)(p − p̄)ᵀ`.
pub fn line_2d(points: &[Point2<f64>]) -> Result<Line2Fit> {
    validate(points, "2-D line fit", 2)?;
    let point = centroid(points);
    let scatter = points.iter().fold(Matrix2::zeros(), |acc, p| {
        let d = p - point;
        acc + d * d.transpose()
    });
    let eigen = SymmetricEigen::new(scatter);
    let (big, small) = if eigen.eigenvalues[0] >= eigen.eigenvalues[1] {
        (0, 1)
    } else {
        (1, 0)
    };
    let (l_big, l_small) = (eigen.eigenvalues[big], eigen.eigenvalues[small]);
    if l_big <= 0.0 {
        return Err(Degeneracy::Coincide {
            what: "2-D line fit",
        }
        .into());
    }
    if l_big - l_small <= RANK_TOLERANCE * l_big {
        return Err(Degeneracy::Isotropic {
            what: "2-D line fit",
        }
        .into());
    }
    let direction = canonical_sign(eigen.eigenvectors.column(big).normalize());
    let normal = Vector2::new(-direction.y, direction.x);
    let residuals = points.iter().map(|p| (p - point).dot(&normal)).collect();
    Ok(Line2Fit {
        point,
        direction,
        normal,
        residuals,
    })
}

/// Orthogonal least-squares line in 3-D: centroid plus the first right
/// singular vector of the centred points.
pub fn line_3d(points: &[Point3<f64>]) -> Result<Line3Fit> {
    validate(points, "3-D line fit", 2)?;
    let point = centroid(points);
    let (sigma, axes) = principal_axes(points, &point)?;
    if sigma[0] <= 0.0 {
        return Err(Degeneracy::Coincide {
            what: "3-D line fit",
        }
        .into());
    }
    if sigma[0] - sigma[1] <= RANK_TOLERANCE * sigma[0] {
        return Err(Degeneracy::NoSingleDirection {
            what: "3-D line fit",
            spread: PrincipalSpread::Largest,
        }
        .into());
    }
    let direction = canonical_sign(axes.column(0).into_owned());
    let residuals = points
        .iter()
        .map(|p| (p - point).cross(&direction).norm())
        .collect();
    Ok(Line3Fit {
        point,
        direction,
        residuals,
    })
}

/// Vertical least-squares line `y = k·x + b`:
/// `k = Σ(x − x̄)(y − ȳ) / Σ(x − x̄)²`, `b = ȳ − k·x̄`.
pub fn line_y_on_x(points: &[Point2<f64>]) -> Result<SlopeLine> {
    validate(points, "line y = kx + b", 2)?;
    let mean = centroid(points);
    let (sxx, sxy) = points.iter().fold((0.0, 0.0), |(sxx, sxy), p| {
        let d = p - mean;
        (sxx + d.x * d.x, sxy + d.x * d.y)
    });
    let x_extent = points
        .iter()
        .map(|p| (p.x - mean.x).abs())
        .fold(0.0, f64::max);
    if x_extent <= RANK_TOLERANCE * mean.x.abs() || sxx <= 0.0 {
        return Err(Degeneracy::SameX {
            what: "line y = kx + b",
        }
        .into());
    }
    let k = sxy / sxx;
    let b = mean.y - k * mean.x;
    // Residuals about the centroid: y − ȳ − k(x − x̄) loses no digits to b.
    let residuals = points
        .iter()
        .map(|p| (p.y - mean.y) - k * (p.x - mean.x))
        .collect();
    Ok(SlopeLine { k, b, residuals })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GeomError;

    #[test]
    fn line_2d_recovers_an_exact_line() {
        let pts: Vec<_> = (0..10)
            .map(|i| Point2::new(1.0 + 3.0 * i as f64, -2.0 - 4.0 * i as f64))
            .collect();
        let fit = line_2d(&pts).unwrap();
        let d = Vector2::new(3.0, -4.0) / 5.0;
        assert!((fit.direction.dot(&d).abs() - 1.0).abs() < 1e-15);
        assert!(fit.residuals.iter().all(|r| r.abs() < 1e-12));
        assert_eq!(fit.direction, canonical_sign(fit.direction));
    }

    #[test]
    fn line_2d_residual_signs_follow_the_normal() {
        let pts = [
            Point2::new(0.0, 0.1),
            Point2::new(1.0, -0.1),
            Point2::new(2.0, 0.1),
            Point2::new(3.0, -0.1),
        ];
        let fit = line_2d(&pts).unwrap();
        for (p, r) in pts.iter().zip(&fit.residuals) {
            assert!((r - (p - fit.point).dot(&fit.normal)).abs() < 1e-15);
        }
        assert!(fit.residuals[0] * fit.residuals[1] < 0.0);
    }

    #[test]
    fn line_3d_recovers_an_exact_line() {
        let d = Vector3::new(1.0, 2.0, -2.0) / 3.0;
        let pts: Vec<_> = (0..7)
            .map(|i| Point3::new(5.0, -1.0, 2.0) + d * (i as f64 * 1.7))
            .collect();
        let fit = line_3d(&pts).unwrap();
        assert!(fit.direction.cross(&d).norm() < 1e-15);
        assert!(fit.residuals.iter().all(|r| *r < 1e-13));
        // Two points are enough.
        assert!(line_3d(&pts[..2]).is_ok());
    }

    #[test]
    fn slope_line_matches_closed_form() {
        let pts = [
            Point2::new(0.0, 1.0),
            Point2::new(1.0, 3.0),
            Point2::new(2.0, 4.0),
            Point2::new(3.0, 8.0),
        ];
        // x̄ = 1.5, ȳ = 4; Σdx·dy = 11, Σdx² = 5.
        let fit = line_y_on_x(&pts).unwrap();
        assert!((fit.k - 2.2).abs() < 1e-14);
        assert!((fit.b - (4.0 - 2.2 * 1.5)).abs() < 1e-14);
        assert!(fit.residuals.iter().sum::<f64>().abs() < 1e-14);
    }

    #[test]
    fn degenerate_lines_are_errors() {
        let p = Point2::new(1.0, 2.0);
        assert!(matches!(line_2d(&[p]), Err(GeomError::TooFewPoints { .. })));
        assert!(matches!(line_2d(&[p, p, p]), Err(GeomError::Degenerate(_))));
        let square = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(1.0, 1.0),
            Point2::new(0.0, 1.0),
        ];
        assert!(matches!(line_2d(&square), Err(GeomError::Degenerate(_))));
        assert!(matches!(
            line_2d(&[p, Point2::new(f64::NAN, 0.0)]),
            Err(GeomError::NonFinite(_))
        ));
        let q = Point3::new(1.0, 2.0, 3.0);
        assert!(matches!(line_3d(&[q, q]), Err(GeomError::Degenerate(_))));
        let vertical = [Point2::new(1.0, 0.0), Point2::new(1.0, 5.0)];
        assert!(matches!(
            line_y_on_x(&vertical),
            Err(GeomError::Degenerate(_))
        ));
        assert!(line_y_on_x(&[Point2::new(0.0, f64::INFINITY), p]).is_err());
    }
}
