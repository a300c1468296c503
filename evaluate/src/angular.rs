//! Angular errors of a line (docs/methods.md, "beyond the source"): the rigid
//! motion of the sphere set from the first target to each target (Kabsch fit,
//! `geom::transform::rigid_fit`) gives the table's rotation vector
//! `ω = (εx, εy, εz)`; roll is the rotation about the moving axis, pitch and
//! yaw the other two (X: roll εx, pitch εy, yaw εz; Y: roll εy, pitch εx,
//! yaw εz; Z: roll εz, pitch εx, yaw εy; `formats::Axis::roll_pitch_yaw`).
//! The fit itself is `geom::transform::rigid_fit_rms`; this module says how
//! well a sphere set determines it.

use geom::{Point3, Vector3};

/// Smallest lever below which angular errors are flagged as poorly
/// determined (mm): 1 µm of position noise then gives more than 200 µrad.
pub const MIN_LEVER_MM: f64 = 5.0;

/// How well a sphere set determines a rotation: the smallest principal lever
/// `√(λ_min/n)` of its inertia tensor `Σ(|r|²·I − r·rᵀ)` (r from the centroid)
/// and the axis it belongs to. A rigid fit's rotation error about that axis is
/// ≈ (position error)/lever: three spheres nearly in a line have a tiny lever
/// about the line.
pub fn lever(points: &[Point3<f64>]) -> (f64, Vector3<f64>) {
    if points.is_empty() {
        return (0.0, Vector3::zeros());
    }
    let n = points.len() as f64;
    let c = points.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / n;
    let inertia = points.iter().fold(geom::Matrix3::zeros(), |m, p| {
        let r = p.coords - c;
        m + geom::Matrix3::identity() * r.norm_squared() - r * r.transpose()
    });
    let (min, axis) = geom::fit::smallest_eigenpair(inertia);
    ((min.max(0.0) / n).sqrt(), axis)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lever_flags_spheres_in_a_line() {
        // The seed's plan positions with heights in proportion: nearly collinear.
        let line = [
            Point3::new(0.0, 0.0, 30.0),
            Point3::new(20.0, 20.0, 45.0),
            Point3::new(-15.0, -15.0, 18.0),
        ];
        let (l, axis) = lever(&line);
        assert!(l < 0.5, "{l}");
        assert!(axis.dot(&Vector3::new(1.0, 1.0, 0.75).normalize()).abs() > 0.99);
        let triangle = [
            Point3::new(0.0, 0.0, 30.0),
            Point3::new(20.0, 20.0, 50.0),
            Point3::new(-15.0, -15.0, 45.0),
        ];
        assert!(lever(&triangle).0 > MIN_LEVER_MM);
    }

    #[test]
    fn quaternion_vector_keeps_the_digits_of_microradian_angles() {
        // µrad angles to rounding, where acos-based conversions lose digits.
        let tiny = Vector3::new(1.1e-6, -2.3e-7, 1.4e-7);
        let q = geom::nalgebra::UnitQuaternion::from_scaled_axis(tiny);
        assert!((geom::transform::quaternion_vector(&q) - tiny).norm() < 1e-20);
        let big = Vector3::new(0.3, -1.1, 0.7);
        let q = geom::nalgebra::UnitQuaternion::from_scaled_axis(big);
        assert!((geom::transform::quaternion_vector(&q) - big).norm() < 1e-14);
    }
}
