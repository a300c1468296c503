//! The perspective image of a sphere: the silhouette cone cuts the image plane
//! in an ellipse whose centre is not the projection of the sphere centre.
//!
//! A sphere of radius R with centre C (camera frame) is seen inside the cone
//! `(X·C)² ≥ ‖X‖²·(‖C‖² − R²)`. On the normalised image plane z = 1 that cone
//! is the conic `xᵀ·Q·x = 0`, `Q = C·Cᵀ − (‖C‖² − R²)·I` (homogeneous x), an
//! ellipse with centre `e = (Cx, Cy)·Cz/(Cz² − R²)` — pushed radially outward
//! from the projected centre `c = (Cx, Cy)/Cz` by the factor `Cz²/(Cz² − R²)`
//! (docs/methods.md, perspective bias: `Δ = r_c·R²/(Z² − R²)`).

use nalgebra::{Matrix2x3, Matrix3, Point3, Vector2, Vector3};

use crate::{Degeneracy, GeomError, Result};

fn check(centre: &Point3<f64>, radius: f64) -> Result<()> {
    if !(centre.iter().all(|v| v.is_finite()) && radius.is_finite()) {
        return Err(GeomError::NonFinite("sphere image"));
    }
    if radius <= 0.0 {
        return Err(Degeneracy::RadiusNotPositive { radius }.into());
    }
    if centre.z * centre.z <= radius * radius || centre.z <= 0.0 {
        return Err(Degeneracy::SphereNotInFront.into());
    }
    Ok(())
}

/// Conic matrix `Q = C·Cᵀ − (‖C‖² − R²)·I` of the sphere's outline on the
/// normalised image plane (points inside have `xᵀQx > 0` with x = (x, y, 1)).
pub fn outline_conic(centre: &Point3<f64>, radius: f64) -> Result<Matrix3<f64>> {
    check(centre, radius)?;
    let c = centre.coords;
    Ok(c * c.transpose() - Matrix3::identity() * (c.norm_squared() - radius * radius))
}

/// Centre of the outline ellipse in normalised coordinates:
/// `e = (Cx, Cy)·Cz/(Cz² − R²)`.
pub fn ellipse_centre(centre: &Point3<f64>, radius: f64) -> Result<Vector2<f64>> {
    check(centre, radius)?;
    Ok(ellipse_centre_jacobian(&centre.coords, radius)?.0)
}

/// Centre of the outline ellipse (normalised coordinates) of a sphere of
/// radius `radius` ≥ 0 (mm) centred at `centre` (camera frame, mm), and its
/// Jacobian `∂e/∂C` (1/mm), the model of every fit that observes sphere
/// images (calibration, triangulation). With `s = Cz/(Cz² − R²)`:
///
/// `e = (Cx·s, Cy·s)`, `∂e/∂C = [[s, 0, Cx·s′], [0, s, Cy·s′]]`,
/// `s′ = ∂s/∂Cz = −(Cz² + R²)/(Cz² − R²)²`.
///
/// R = 0 is the pinhole projection `(Cx, Cy)/Cz`. Unlike [`ellipse_centre`]
/// it does not allocate, for use inside solvers.
///
/// # Errors
/// [`GeomError::BehindCamera`] when the sphere is not wholly in front of the
/// camera (`Cz ≤ R`), or a coordinate is NaN.
pub fn ellipse_centre_jacobian(
    centre: &Vector3<f64>,
    radius: f64,
) -> Result<(Vector2<f64>, Matrix2x3<f64>)> {
    let q = centre.z * centre.z - radius * radius;
    if !(centre.z > radius && q > 0.0) {
        return Err(GeomError::BehindCamera { depth: centre.z });
    }
    let s = centre.z / q;
    let ds = -(centre.z * centre.z + radius * radius) / (q * q);
    Ok((
        Vector2::new(centre.x * s, centre.y * s),
        Matrix2x3::new(s, 0.0, centre.x * ds, 0.0, s, centre.y * ds),
    ))
}

/// Inverse of [`ellipse_centre`] given the sphere's depth Cz: the projection
/// of the sphere centre `c = e·(Cz² − R²)/Cz²` (normalised coordinates).
pub fn projected_centre(
    ellipse_centre: Vector2<f64>,
    depth: f64,
    radius: f64,
) -> Result<Vector2<f64>> {
    check(&Point3::new(0.0, 0.0, depth), radius)?;
    Ok(ellipse_centre * (1.0 - (radius * radius) / (depth * depth)))
}

/// Half-angle of the silhouette cone, `asin(R/‖C‖)` (rad).
pub fn cone_half_angle(centre: &Point3<f64>, radius: f64) -> Result<f64> {
    let d = centre.coords.norm();
    if d.is_nan() || d <= radius {
        return Err(Degeneracy::CameraInsideSphere.into());
    }
    Ok((radius / d).asin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_lies_on_the_conic_axis_and_matches_the_bias_formula() {
        let c = Point3::new(75.0, -20.0, 460.0);
        let r = 10.0;
        let e = ellipse_centre(&c, r).unwrap();
        // Gradient of the conic vanishes at the centre: Q·(e, 1) ∝ (0, 0, *).
        let q = outline_conic(&c, r).unwrap();
        let g = q * nalgebra::Vector3::new(e.x, e.y, 1.0);
        assert!(g.x.abs() < 1e-9 && g.y.abs() < 1e-9);
        // Δ = r_c·R²/(Z² − R²) with r_c the distance of the projected centre.
        let proj = Vector2::new(c.x / c.z, c.y / c.z);
        let delta = (e - proj).norm();
        let expected = proj.norm() * r * r / (c.z * c.z - r * r);
        assert!((delta - expected).abs() < 1e-15);
        let back = projected_centre(e, c.z, r).unwrap();
        assert!((back - proj).norm() < 1e-15);
    }

    #[test]
    fn outline_points_are_tangent_rays() {
        // A ray at exactly the cone half-angle from C satisfies xᵀQx = 0.
        let c = Point3::new(30.0, 40.0, 400.0);
        let r = 7.5;
        let q = outline_conic(&c, r).unwrap();
        let a = cone_half_angle(&c, r).unwrap();
        let axis = c.coords.normalize();
        let perp = axis.cross(&nalgebra::Vector3::x()).normalize();
        let dir = nalgebra::Rotation3::new(perp * a) * axis;
        let x = dir / dir.z;
        assert!((x.transpose() * q * x)[0].abs() < 1e-9 * c.coords.norm_squared());
    }

    #[test]
    fn jacobian_matches_central_differences() {
        for r in [0.0, 10.0] {
            let c = Vector3::new(75.0, -20.0, 460.0);
            let (e, j) = ellipse_centre_jacobian(&c, r).unwrap();
            if r == 0.0 {
                assert!((e - Vector2::new(c.x / c.z, c.y / c.z)).norm() < 1e-16);
            }
            for k in 0..3 {
                let h = 1e-3;
                let mut a = c;
                let mut b = c;
                a[k] += h;
                b[k] -= h;
                let num = (ellipse_centre_jacobian(&a, r).unwrap().0
                    - ellipse_centre_jacobian(&b, r).unwrap().0)
                    / (2.0 * h);
                assert!((num - j.column(k)).norm() < 1e-12, "r {r} column {k}");
            }
        }
        assert!(ellipse_centre_jacobian(&Vector3::new(0.0, 0.0, 5.0), 5.0).is_err());
        assert!(ellipse_centre_jacobian(&Vector3::new(0.0, 0.0, f64::NAN), 0.0).is_err());
    }

    #[test]
    fn sphere_touching_the_image_plane_is_degenerate() {
        assert!(ellipse_centre(&Point3::new(0.0, 0.0, 5.0), 5.0).is_err());
        assert!(ellipse_centre(&Point3::new(0.0, 0.0, 50.0), -1.0).is_err());
    }
}
