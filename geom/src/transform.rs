//! Rigid transforms, rotation vectors, small-angle error transforms (δ, ε) and
//! the least-squares rigid fit between two point sets.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::{Degeneracy, GeomError, Result};

/// Rotation from a rotation vector (axis × angle, rad) by Rodrigues' formula.
pub fn rotation_from_vector(v: Vector3<f64>) -> Rotation3<f64> {
    Rotation3::new(v)
}

/// Rotation vector (axis × angle, rad, angle in [0, π]) of a rotation.
pub fn rotation_vector(r: &Rotation3<f64>) -> Vector3<f64> {
    quaternion_vector(&UnitQuaternion::from_rotation_matrix(r))
}

/// Rotation vector of a unit quaternion `(w, v)`: `v·2·atan2(|v|, w)/|v|`.
/// Accurate to rounding at the µrad angles of machine errors, where an angle
/// from `acos` of `w` or of the trace (nalgebra's `scaled_axis`) loses half
/// its digits.
pub fn quaternion_vector(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let (w, v) = (q.scalar(), q.vector().into_owned());
    let (w, v) = if w < 0.0 { (-w, -v) } else { (w, v) };
    let s = v.norm();
    if s == 0.0 {
        return Vector3::zeros();
    }
    v * (2.0 * s.atan2(w) / s)
}

/// Rigid transform `x ↦ R(v)·x + t` from a rotation vector and a translation.
pub fn rigid(rotation_vector: Vector3<f64>, translation: Vector3<f64>) -> Isometry3<f64> {
    Isometry3::new(translation, rotation_vector)
}

/// Small-angle error transform of a rigid body: a point p is displaced by
/// `Δp = δ + ε × p` (first order in ε), i.e.
/// `Δx = δx − εz·y + εy·z`, `Δy = δy + εz·x − εx·z`, `Δz = δz − εy·x + εx·y`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SmallError {
    /// Translation errors δx, δy, δz (mm).
    pub delta: Vector3<f64>,
    /// Rotation errors εx, εy, εz (rad) about the frame's axes.
    pub epsilon: Vector3<f64>,
}

impl SmallError {
    /// The identity (no error).
    pub const ZERO: SmallError = SmallError {
        delta: Vector3::new(0.0, 0.0, 0.0),
        epsilon: Vector3::new(0.0, 0.0, 0.0),
    };

    /// The six components `[δx, δy, δz, εx, εy, εz]` (mm, rad), the order of
    /// [`SmallError::design_rows`]' columns.
    pub fn components(&self) -> [f64; 6] {
        [
            self.delta.x,
            self.delta.y,
            self.delta.z,
            self.epsilon.x,
            self.epsilon.y,
            self.epsilon.z,
        ]
    }

    /// Displacement `δ + ε × p` of a point.
    pub fn displacement(&self, p: &Point3<f64>) -> Vector3<f64> {
        self.delta + self.epsilon.cross(&p.coords)
    }

    /// The displaced point `p + δ + ε × p`.
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        p + self.displacement(p)
    }

    /// Rows of the linear map `[δ; ε] ↦ Δp` at p (3×6), for least-squares
    /// identification of the six errors from observed displacements.
    pub fn design_rows(p: &Point3<f64>) -> [[f64; 6]; 3] {
        let (x, y, z) = (p.x, p.y, p.z);
        [
            [1.0, 0.0, 0.0, 0.0, z, -y],
            [0.0, 1.0, 0.0, -z, 0.0, x],
            [0.0, 0.0, 1.0, y, -x, 0.0],
        ]
    }

    /// First-order composition `self ∘ inner` (apply `inner` first): errors add,
    /// `δ = δa + δb`, `ε = εa + εb`; second-order terms (ε·δ, ε·ε) are dropped.
    pub fn compose(&self, inner: &SmallError) -> SmallError {
        SmallError {
            delta: self.delta + inner.delta,
            epsilon: self.epsilon + inner.epsilon,
        }
    }

    /// The exact rigid motion with rotation vector ε and translation δ; agrees
    /// with [`SmallError::apply`] to first order.
    pub fn to_isometry(&self) -> Isometry3<f64> {
        Isometry3::new(self.delta, self.epsilon)
    }

    /// Errors of a near-identity rigid motion: ε = its rotation vector, δ = its translation.
    pub fn from_isometry(iso: &Isometry3<f64>) -> SmallError {
        SmallError {
            delta: iso.translation.vector,
            epsilon: quaternion_vector(&iso.rotation),
        }
    }
}

/// A least-squares rigid motion and how well it fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidFit {
    /// The motion `to ≈ R·from + t`.
    pub motion: Isometry3<f64>,
    /// Rotation vector of R (rad), [`quaternion_vector`].
    pub rotation: Vector3<f64>,
    /// RMS distance between the moved `from` points and `to`,
    /// `√(Σ‖R·aᵢ + t − bᵢ‖²/n)` (mm): zero for a rigid set.
    pub rms: f64,
}

/// [`rigid_fit`] with its rotation vector and RMS residual: the pose of a
/// rigid set of points (the table's spheres) relative to a reference pose.
pub fn rigid_fit_rms(from: &[Point3<f64>], to: &[Point3<f64>]) -> Result<RigidFit> {
    let motion = rigid_fit(from, to)?;
    let ss: f64 = from
        .iter()
        .zip(to)
        .map(|(a, b)| (motion.transform_point(a) - b).norm_squared())
        .sum();
    Ok(RigidFit {
        motion,
        rotation: quaternion_vector(&motion.rotation),
        rms: (ss / from.len() as f64).sqrt(),
    })
}

/// Least-squares rigid motion `to ≈ R·from + t` (Kabsch/Horn: SVD of the
/// cross-covariance, with the reflection guard). Needs ≥ 3 non-collinear pairs.
pub fn rigid_fit(from: &[Point3<f64>], to: &[Point3<f64>]) -> Result<Isometry3<f64>> {
    if from.len() != to.len() {
        return Err(Degeneracy::LengthsDiffer {
            what: Some("rigid fit"),
            first: from.len(),
            first_items: "source points",
            second: to.len(),
            second_items: "target points",
        }
        .into());
    }
    if from.len() < 3 {
        return Err(GeomError::TooFewPoints {
            what: "rigid fit",
            needed: 3,
            got: from.len(),
        });
    }
    if from
        .iter()
        .chain(to)
        .any(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(GeomError::NonFinite("rigid fit"));
    }
    let n = from.len() as f64;
    let ca = from.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / n;
    let cb = to.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / n;
    let h = from.iter().zip(to).fold(Matrix3::zeros(), |h, (a, b)| {
        h + (a.coords - ca) * (b.coords - cb).transpose()
    });
    let svd = h.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(Degeneracy::SvdFailed { what: "rigid fit" }.into());
    };
    let mut s = svd.singular_values;
    // Sort-independent rank test: the two largest singular values must be non-zero.
    s.as_mut_slice().sort_by(|a, b| b.total_cmp(a));
    if s[1] <= 1e-12 * s[0].max(f64::MIN_POSITIVE) {
        return Err(Degeneracy::Collinear { what: "rigid fit" }.into());
    }
    let v = v_t.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = cb - rotation * ca;
    Ok(Isometry3::from_parts(Translation3::from(t), rotation))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rigid_fit_rms_recovers_a_known_motion_and_its_residual() {
        let first = [
            Point3::new(0.0, 0.0, 10.0),
            Point3::new(20.0, 20.0, 8.0),
            Point3::new(-15.0, -15.0, 5.0),
        ];
        let w = Vector3::new(3e-5, -2e-5, 5e-5);
        let iso = rigid(w, Vector3::new(50.0, 0.01, -0.02));
        let mut at: Vec<_> = first.iter().map(|p| iso * p).collect();
        let fit = rigid_fit_rms(&first, &at).unwrap();
        assert!((fit.rotation - w).norm() < 1e-10 && fit.rms < 1e-10);
        // Moving one point by 3 µm along z, normal to the plane of the set
        // (nearly), leaves an RMS of a few µm at most and above zero.
        at[0].z += 0.003;
        let fit = rigid_fit_rms(&first, &at).unwrap();
        assert!(fit.rms > 1e-4 && fit.rms < 0.003, "{}", fit.rms);
    }

    #[test]
    fn rotation_vector_round_trip() {
        let v = Vector3::new(0.3, -1.1, 0.7);
        assert!((rotation_vector(&rotation_from_vector(v)) - v).norm() < 1e-14);
    }

    #[test]
    fn rotation_vector_keeps_every_digit_at_microradians() {
        // acos-based conversions lose ≈ 8 digits here (relative error ≈ 1e-4 at 1 µrad).
        let tiny = Vector3::new(3e-6, -2e-6, 5e-7);
        let q = UnitQuaternion::from_scaled_axis(tiny);
        assert!((quaternion_vector(&q) - tiny).norm() < 1e-20);
        let r = rotation_from_vector(tiny);
        assert!((rotation_vector(&r) - tiny).norm() < 1e-19);
        assert!(
            (SmallError::from_isometry(&Isometry3::new(Vector3::zeros(), tiny)).epsilon - tiny)
                .norm()
                < 1e-20
        );
    }

    #[test]
    fn small_error_matches_exact_motion_to_first_order() {
        let e = SmallError {
            delta: Vector3::new(2e-3, -1e-3, 5e-4),
            epsilon: Vector3::new(1e-5, -2e-5, 3e-5),
        };
        let p = Point3::new(100.0, -50.0, 30.0);
        let exact = e.to_isometry().transform_point(&p);
        // Second-order term ≈ |ε|²·|p| ≈ 1.4e-9·120 mm.
        assert!((exact - e.apply(&p)).norm() < 1e-6);
        let rows = SmallError::design_rows(&p);
        let x = e.components();
        let d = e.displacement(&p);
        for i in 0..3 {
            let lin: f64 = rows[i].iter().zip(&x).map(|(a, b)| a * b).sum();
            assert!((lin - d[i]).abs() < 1e-15);
        }
        let back = SmallError::from_isometry(&e.to_isometry());
        assert!((back.epsilon - e.epsilon).norm() < 1e-18);
        assert!((back.delta - e.delta).norm() < 1e-18);
    }

    #[test]
    fn first_order_composition_adds_errors() {
        let a = SmallError {
            delta: Vector3::new(1e-3, 0.0, 0.0),
            epsilon: Vector3::new(0.0, 1e-5, 0.0),
        };
        let b = SmallError {
            delta: Vector3::new(0.0, 2e-3, 0.0),
            epsilon: Vector3::new(0.0, 0.0, -1e-5),
        };
        let p = Point3::new(50.0, 20.0, -10.0);
        let seq = a.apply(&b.apply(&p));
        assert!((a.compose(&b).apply(&p) - seq).norm() < 1e-7);
    }

    #[test]
    fn rigid_fit_recovers_motion() {
        let motion = rigid(
            Vector3::new(0.01, -0.02, 0.5),
            Vector3::new(10.0, -3.0, 7.0),
        );
        let from = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(20.0, 20.0, 5.0),
            Point3::new(-15.0, -15.0, 10.0),
            Point3::new(3.0, -7.0, 1.0),
        ];
        let to: Vec<_> = from.iter().map(|p| motion.transform_point(p)).collect();
        let fit = rigid_fit(&from, &to).unwrap();
        assert!((fit.to_homogeneous() - motion.to_homogeneous()).norm() < 1e-12);
    }

    #[test]
    fn rigid_fit_rejects_collinear_points() {
        let from = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 1.0, 1.0),
            Point3::new(2.0, 2.0, 2.0),
        ];
        assert!(rigid_fit(&from, &from).is_err());
        assert!(rigid_fit(&from[..2], &from[..2]).is_err());
    }
}
