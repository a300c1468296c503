//! Pinhole camera with Brown distortion: intrinsics K, pose [R|t], the 3×4
//! projection P = K·[R|t], its RQ decomposition, and back-projected rays.
//!
//! `K = [[fx, skew, cx], [0, fy, cy], [0, 0, 1]]`; a world point X maps to the
//! camera frame by `x_c = R·X + t`, to normalised coordinates `(x_c/z_c, y_c/z_c)`,
//! through the distortion, then to pixels by K. Pixel convention: the centre of
//! the top-left pixel is (0, 0).

use nalgebra::{
    Isometry3, Matrix3, Matrix3x4, Point2, Point3, Rotation3, Translation3, Unit, UnitQuaternion,
    Vector2, Vector3,
};

use crate::{Degeneracy, Distortion, GeomError, Result};

/// Pixel tolerance of [`Camera::undistort_pixel`] (docs/methods.md: converged ≤ 1e-10 px).
pub const UNDISTORT_TOLERANCE_PX: f64 = 1e-10;

/// Linear intrinsic parameters (pixels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length in pixels along u.
    pub fx: f64,
    /// Focal length in pixels along v.
    pub fy: f64,
    /// Principal point, u (px).
    pub cx: f64,
    /// Principal point, v (px).
    pub cy: f64,
    /// Skew: `K[0][1]` (px).
    pub skew: f64,
}

impl Intrinsics {
    /// Square pixels, no skew, principal point at the image centre
    /// `((W − 1)/2, (H − 1)/2)` in the pixel-centre convention.
    pub fn centred(focal_px: f64, width: u32, height: u32) -> Self {
        Self {
            fx: focal_px,
            fy: focal_px,
            cx: (f64::from(width) - 1.0) / 2.0,
            cy: (f64::from(height) - 1.0) / 2.0,
            skew: 0.0,
        }
    }

    /// The 3×3 matrix K.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(
            self.fx, self.skew, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0,
        )
    }

    /// Read K from an upper-triangular matrix, normalising `K[2][2]` to 1.
    pub fn from_matrix(k: &Matrix3<f64>) -> Result<Self> {
        let s = k[(2, 2)];
        if !k.iter().all(|v| v.is_finite()) {
            return Err(GeomError::NonFinite("intrinsic matrix"));
        }
        let lower = k[(1, 0)].abs() + k[(2, 0)].abs() + k[(2, 1)].abs();
        if s == 0.0 || lower > 1e-9 * k.norm() {
            return Err(Degeneracy::NotIntrinsic.into());
        }
        let k = k / s;
        if k[(0, 0)] <= 0.0 || k[(1, 1)] <= 0.0 {
            return Err(Degeneracy::FocalNotPositive.into());
        }
        Ok(Self {
            fx: k[(0, 0)],
            fy: k[(1, 1)],
            cx: k[(0, 2)],
            cy: k[(1, 2)],
            skew: k[(0, 1)],
        })
    }

    /// Normalised image coordinates → pixels: `u = fx·x + skew·y + cx`, `v = fy·y + cy`.
    pub fn to_pixel(&self, n: Vector2<f64>) -> Point2<f64> {
        Point2::new(
            self.fx * n.x + self.skew * n.y + self.cx,
            self.fy * n.y + self.cy,
        )
    }

    /// Pixels → normalised image coordinates (inverse of [`Intrinsics::to_pixel`]).
    pub fn to_normalized(&self, p: Point2<f64>) -> Vector2<f64> {
        let y = (p.y - self.cy) / self.fy;
        Vector2::new((p.x - self.cx - self.skew * y) / self.fx, y)
    }
}

/// A calibrated camera: intrinsics, distortion, pose (world → camera) and sensor size.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Linear intrinsics K.
    pub intrinsics: Intrinsics,
    /// Lens distortion (applied to normalised coordinates).
    pub distortion: Distortion,
    /// World → camera transform: `x_cam = R·x_world + t`.
    pub pose: Isometry3<f64>,
    /// Sensor width (px).
    pub width: u32,
    /// Sensor height (px).
    pub height: u32,
}

impl Camera {
    /// A camera at `position` looking at `target`, with the world direction `up`
    /// appearing upward in the image (camera y points down: y_c ∝ −up⊥).
    pub fn look_at(
        position: Point3<f64>,
        target: Point3<f64>,
        up: Vector3<f64>,
        intrinsics: Intrinsics,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        let z = target - position;
        if z.norm() == 0.0 || !z.iter().all(|v| v.is_finite()) {
            return Err(Degeneracy::LooksAtItself.into());
        }
        let z = z.normalize();
        let up_perp = up - z * up.dot(&z);
        if up_perp.norm() < 1e-9 * up.norm().max(1.0) {
            return Err(Degeneracy::UpAlongAxis.into());
        }
        let y = -up_perp.normalize();
        let x = y.cross(&z);
        let r = Rotation3::from_matrix_unchecked(Matrix3::from_rows(&[
            x.transpose(),
            y.transpose(),
            z.transpose(),
        ]));
        let t = -(r * position.coords);
        Ok(Self::pinhole(intrinsics, &r, t, width, height))
    }

    /// A camera without distortion from K, R and t (`x_cam = R·x_world + t`).
    pub fn pinhole(
        intrinsics: Intrinsics,
        r: &Rotation3<f64>,
        t: Vector3<f64>,
        width: u32,
        height: u32,
    ) -> Self {
        Self {
            intrinsics,
            distortion: Distortion::NONE,
            pose: Isometry3::from_parts(
                Translation3::from(t),
                UnitQuaternion::from_rotation_matrix(r),
            ),
            width,
            height,
        }
    }

    /// Names of the parameters [`Camera::perturbed`] accepts, in the order a
    /// calibration estimates them.
    pub const PARAMETERS: [&'static str; 16] = [
        "fx", "fy", "cx", "cy", "skew", "rx", "ry", "rz", "tx", "ty", "tz", "k1", "k2", "p1", "p2",
        "k3",
    ];

    /// The camera with its named parameters moved by `delta` (the draw of a
    /// calibration's covariance): `rx, ry, rz` a small rotation ω about the
    /// camera's own axes, `R = exp([ω]×)·R` (rad); `tx, ty, tz` added to t
    /// (mm); `fx, fy, cx, cy, skew` (px) and `k1, k2, p1, p2, k3` added to
    /// their values. Fails on a name not in [`Camera::PARAMETERS`] or
    /// lengths that differ.
    pub fn perturbed<S: AsRef<str>>(&self, names: &[S], delta: &[f64]) -> Result<Camera> {
        if names.len() != delta.len() {
            return Err(Degeneracy::LengthsDiffer {
                what: Some("camera parameters"),
                first: names.len(),
                first_items: "names",
                second: delta.len(),
                second_items: "values",
            }
            .into());
        }
        let mut c = self.clone();
        let (mut omega, mut dt) = (Vector3::zeros(), Vector3::zeros());
        for (name, &d) in names.iter().zip(delta) {
            if !d.is_finite() {
                return Err(GeomError::NonFinite("camera parameter deviation"));
            }
            let k = &mut c.intrinsics;
            let dist = &mut c.distortion;
            match name.as_ref() {
                "fx" => k.fx += d,
                "fy" => k.fy += d,
                "cx" => k.cx += d,
                "cy" => k.cy += d,
                "skew" => k.skew += d,
                "rx" => omega.x += d,
                "ry" => omega.y += d,
                "rz" => omega.z += d,
                "tx" => dt.x += d,
                "ty" => dt.y += d,
                "tz" => dt.z += d,
                "k1" => dist.k1 += d,
                "k2" => dist.k2 += d,
                "p1" => dist.p1 += d,
                "p2" => dist.p2 += d,
                "k3" => dist.k3 += d,
                _ => return Err(Degeneracy::UnknownParameter.into()),
            }
        }
        let rotation = Rotation3::new(omega) * self.rotation();
        c.pose = Isometry3::from_parts(
            Translation3::from(self.translation() + dt),
            UnitQuaternion::from_rotation_matrix(&rotation),
        );
        Ok(c)
    }

    /// World → camera rotation R.
    pub fn rotation(&self) -> Rotation3<f64> {
        self.pose.rotation.to_rotation_matrix()
    }

    /// World → camera translation t.
    pub fn translation(&self) -> Vector3<f64> {
        self.pose.translation.vector
    }

    /// Camera centre in the world frame: `C = −Rᵀ·t`.
    pub fn centre(&self) -> Point3<f64> {
        self.pose.inverse_transform_point(&Point3::origin())
    }

    /// Optical axis (camera +z) as a world direction.
    pub fn optical_axis(&self) -> Unit<Vector3<f64>> {
        Unit::new_normalize(self.pose.inverse_transform_vector(&Vector3::z()))
    }

    /// World point in the camera frame.
    pub fn to_camera(&self, p: &Point3<f64>) -> Point3<f64> {
        self.pose.transform_point(p)
    }

    /// Ideal (undistorted) normalised coordinates of a world point; fails behind the camera.
    pub fn normalized(&self, p: &Point3<f64>) -> Result<Vector2<f64>> {
        let c = self.to_camera(p);
        if c.z <= 0.0 || !c.z.is_finite() {
            return Err(GeomError::BehindCamera { depth: c.z });
        }
        Ok(Vector2::new(c.x / c.z, c.y / c.z))
    }

    /// Full model: world point → observed (distorted) pixel.
    pub fn project(&self, p: &Point3<f64>) -> Result<Point2<f64>> {
        let n = self.normalized(p)?;
        Ok(self.intrinsics.to_pixel(self.distortion.distort(n)))
    }

    /// Pinhole only: world point → ideal (undistorted) pixel, i.e. `P·X`.
    pub fn project_pinhole(&self, p: &Point3<f64>) -> Result<Point2<f64>> {
        Ok(self.intrinsics.to_pixel(self.normalized(p)?))
    }

    /// Ideal pixel → observed pixel (applies the lens distortion).
    pub fn distort_pixel(&self, ideal: Point2<f64>) -> Point2<f64> {
        let n = self.intrinsics.to_normalized(ideal);
        self.intrinsics.to_pixel(self.distortion.distort(n))
    }

    /// Observed pixel → ideal normalised coordinates, converged to
    /// [`UNDISTORT_TOLERANCE_PX`] in the image.
    pub fn undistort_normalized(&self, observed: Point2<f64>) -> Result<Vector2<f64>> {
        let tol = UNDISTORT_TOLERANCE_PX / self.intrinsics.fx.max(self.intrinsics.fy);
        self.distortion
            .undistort(self.intrinsics.to_normalized(observed), tol)
    }

    /// Observed pixel → ideal pixel (the pinhole image of the same ray).
    pub fn undistort_pixel(&self, observed: Point2<f64>) -> Result<Point2<f64>> {
        Ok(self
            .intrinsics
            .to_pixel(self.undistort_normalized(observed)?))
    }

    /// Observed pixel → (ideal pixel, area Jacobian `|∂ideal/∂observed|`), the
    /// factor by which a unit observed pixel's area scales in the ideal image
    /// (K cancels in the determinant: `1/det J_distort`).
    pub fn undistort_pixel_area(&self, observed: Point2<f64>) -> Result<(Point2<f64>, f64)> {
        let n = self.undistort_normalized(observed)?;
        self.area_at(observed, n)
    }

    /// [`Camera::undistort_pixel_area`] with the iteration started at the ideal
    /// normalised coordinates `near` of a neighbouring pixel (the first-order
    /// shift of the observed position added); same convergence. Also returns
    /// the ideal normalised coordinates, to start the next neighbour from.
    pub fn undistort_pixel_area_near(
        &self,
        observed: Point2<f64>,
        near: (Point2<f64>, Vector2<f64>),
    ) -> Result<(Point2<f64>, f64, Vector2<f64>)> {
        let k = &self.intrinsics;
        let d = k.to_normalized(observed);
        let start = near.1 + (d - k.to_normalized(near.0));
        let tol = UNDISTORT_TOLERANCE_PX / k.fx.max(k.fy);
        let n = self.distortion.undistort_from(d, start, tol)?;
        let (p, j) = self.area_at(observed, n)?;
        Ok((p, j, n))
    }

    /// Ideal pixel and area Jacobian at ideal normalised coordinates `n`.
    fn area_at(&self, observed: Point2<f64>, n: Vector2<f64>) -> Result<(Point2<f64>, f64)> {
        let det = self.distortion.jacobian(n).determinant();
        if det <= 0.0 {
            return Err(Degeneracy::DistortionFolds {
                u: observed.x,
                v: observed.y,
            }
            .into());
        }
        Ok((self.intrinsics.to_pixel(n), 1.0 / det))
    }

    /// Back-projected ray of an observed pixel: (camera centre, unit direction), world frame.
    pub fn ray(&self, observed: Point2<f64>) -> Result<(Point3<f64>, Unit<Vector3<f64>>)> {
        let n = self.undistort_normalized(observed)?;
        let d = self
            .pose
            .inverse_transform_vector(&Vector3::new(n.x, n.y, 1.0));
        Ok((self.centre(), Unit::new_normalize(d)))
    }

    /// 3×4 projection `P = K·[R|t]` of the undistorted pinhole model; its third
    /// row's first three entries have unit norm (they are R's third row).
    pub fn projection_matrix(&self) -> Matrix3x4<f64> {
        let mut rt = Matrix3x4::zeros();
        rt.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(self.rotation().matrix());
        rt.set_column(3, &self.translation());
        self.intrinsics.matrix() * rt
    }

    /// Camera (without distortion) from a projection matrix of any scale and sign.
    pub fn from_projection_matrix(p: &Matrix3x4<f64>, width: u32, height: u32) -> Result<Self> {
        let (intrinsics, r, t) = decompose_projection(p)?;
        Ok(Self::pinhole(intrinsics, &r, t, width, height))
    }
}

/// Scale a projection matrix so that `‖P[2][0..3]‖ = 1` and `det P[:, 0..3] > 0`
/// (points in front of the camera then have positive depth `P[2]·X`).
pub fn normalize_projection(p: &Matrix3x4<f64>) -> Result<Matrix3x4<f64>> {
    let m = p.fixed_view::<3, 3>(0, 0);
    let det = m.determinant();
    let n = m.row(2).norm();
    if !det.is_finite() || det == 0.0 || n == 0.0 {
        return Err(Degeneracy::SingularProjection.into());
    }
    Ok(p * (det.signum() / n))
}

/// RQ decomposition of a 3×3 matrix: `M = U·Q` with U upper triangular with a
/// positive diagonal and Q orthogonal (Hartley & Zisserman A4.1.1, via QR of the
/// row-reversed transpose).
pub fn rq3(m: &Matrix3<f64>) -> Result<(Matrix3<f64>, Matrix3<f64>)> {
    if !m.iter().all(|v| v.is_finite()) {
        return Err(GeomError::NonFinite("RQ decomposition"));
    }
    // J = anti-identity. (J·M)ᵀ = Q̃·R̃ ⇒ M = (J·R̃ᵀ·J)·(J·Q̃ᵀ).
    let j = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0);
    let qr = (j * m).transpose().qr();
    let mut u = j * qr.r().transpose() * j;
    let mut q = j * qr.q().transpose();
    // Make U's diagonal positive: U·D, D·Q with D = diag(sign(U_ii)), D² = I.
    for i in 0..3 {
        if u[(i, i)] == 0.0 {
            return Err(Degeneracy::SingularRq.into());
        }
        if u[(i, i)] < 0.0 {
            u.column_mut(i).neg_mut();
            q.row_mut(i).neg_mut();
        }
    }
    Ok((u, q))
}

/// Split `P ∝ K·[R|t]` into intrinsics, rotation (det +1) and translation.
pub fn decompose_projection(
    p: &Matrix3x4<f64>,
) -> Result<(Intrinsics, Rotation3<f64>, Vector3<f64>)> {
    let p = normalize_projection(p)?;
    let m: Matrix3<f64> = p.fixed_view::<3, 3>(0, 0).into();
    let (k, r) = rq3(&m)?;
    // det M > 0 and diag K > 0 ⇒ det R = +1.
    let t = k
        .try_inverse()
        .ok_or(GeomError::Degenerate(Degeneracy::Singular {
            matrix: "intrinsic matrix",
        }))?
        * p.column(3);
    let intrinsics = Intrinsics::from_matrix(&k)?;
    // Re-orthonormalise against round-off.
    let rotation = Rotation3::from_matrix_eps(&r, 1e-15, 100, Rotation3::identity());
    Ok((intrinsics, rotation, t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn seed_camera(distortion: Distortion) -> Camera {
        // Camera 1 of the seed rig: 460 mm from the table centre on −X, looking along +X.
        let k = Intrinsics::centred(40.0 / 0.0055, 4096, 3072);
        let mut cam = Camera::look_at(
            Point3::new(-460.0, 0.0, 50.0),
            Point3::new(0.0, 0.0, 50.0),
            Vector3::z(),
            k,
            4096,
            3072,
        )
        .unwrap();
        cam.distortion = distortion;
        cam
    }

    #[test]
    fn look_at_frames_the_target() {
        let cam = seed_camera(Distortion::NONE);
        let c = cam.project(&Point3::new(0.0, 0.0, 50.0)).unwrap();
        assert!((c.x - 2047.5).abs() < 1e-9 && (c.y - 1535.5).abs() < 1e-9);
        // World +Z appears upward (smaller v), world +Y appears... to the left when looking along +X.
        let up = cam.project(&Point3::new(0.0, 0.0, 60.0)).unwrap();
        assert!(up.y < c.y);
        let left = cam.project(&Point3::new(0.0, 10.0, 50.0)).unwrap();
        assert!(left.x < c.x);
        assert!((cam.centre() - Point3::new(-460.0, 0.0, 50.0)).norm() < 1e-12);
        assert!((cam.optical_axis().into_inner() - Vector3::x()).norm() < 1e-15);
    }

    #[test]
    fn behind_camera_is_an_error() {
        let cam = seed_camera(Distortion::NONE);
        assert!(matches!(
            cam.project(&Point3::new(-500.0, 0.0, 50.0)),
            Err(GeomError::BehindCamera { .. })
        ));
    }

    #[test]
    fn ray_passes_through_the_point() {
        let cam = seed_camera(Distortion {
            k1: -0.06,
            k2: 0.02,
            k3: 0.0,
            p1: 1e-4,
            p2: -2e-4,
        });
        let x = Point3::new(12.0, -37.0, 81.0);
        let (o, d) = cam.ray(cam.project(&x).unwrap()).unwrap();
        let v = x - o;
        let miss = (v - d.into_inner() * v.dot(&d)).norm();
        assert!(miss < 1e-9, "ray misses by {miss} mm");
    }

    #[test]
    fn warm_started_undistortion_agrees_with_the_cold_one() {
        let mut cam = seed_camera(Distortion {
            k1: -0.06,
            k2: 0.03,
            k3: 0.0,
            p1: 2e-4,
            p2: -1e-4,
        });
        cam.intrinsics = Intrinsics::centred(7966.0, 4096, 3072);
        let mut near: Option<(Point2<f64>, Vector2<f64>)> = None;
        for (u, v) in [
            (3900.0, 2900.0),
            (3901.0, 2900.0),
            (3902.0, 2900.0),
            (3700.0, 2901.0),
            (100.0, 50.0),
        ] {
            let observed = Point2::new(u, v);
            let (p0, j0) = cam.undistort_pixel_area(observed).unwrap();
            if let Some(n) = near {
                let (p1, j1, _) = cam.undistort_pixel_area_near(observed, n).unwrap();
                assert!((p1 - p0).norm() < 1e-9, "{observed:?}");
                assert!((j1 - j0).abs() < 1e-12);
            }
            near = Some((observed, cam.intrinsics.to_normalized(p0)));
        }
    }

    #[test]
    fn projection_matrix_agrees_with_pinhole_projection() {
        let cam = seed_camera(Distortion::NONE);
        let p = cam.projection_matrix();
        assert!((p.fixed_view::<1, 3>(2, 0).norm() - 1.0).abs() < 1e-15);
        let x = Point3::new(12.0, -37.0, 81.0);
        let h = p * x.to_homogeneous();
        let q = cam.project_pinhole(&x).unwrap();
        assert!((h.x / h.z - q.x).abs() < 1e-9 && (h.y / h.z - q.y).abs() < 1e-9);
    }

    #[test]
    fn singular_projection_is_an_error() {
        assert!(decompose_projection(&Matrix3x4::zeros()).is_err());
    }

    fn arb_distortion() -> impl Strategy<Value = Distortion> {
        (
            -0.3..0.3f64,
            -0.3..0.3f64,
            -0.1..0.1f64,
            -2e-3..2e-3f64,
            -2e-3..2e-3f64,
        )
            .prop_map(|(k1, k2, k3, p1, p2)| Distortion { k1, k2, k3, p1, p2 })
    }

    proptest! {
        /// distort ∘ undistort is the identity to 1e-10 px over the whole sensor,
        /// for every lens whose radial profile r·(1 + k1·r² + k2·r⁴ + k3·r⁶) keeps
        /// rising out to 1.2× the corner radius and gets past the corner radius
        /// there (beyond its maximum a distorted radius has no preimage, and
        /// undistortion rightly fails).
        #[test]
        fn undistort_round_trip(d in arb_distortion(), u in 0.0..4095.0f64, v in 0.0..3071.0f64) {
            let mut cam = seed_camera(d);
            cam.intrinsics = Intrinsics::centred(4096.0, 4096, 3072);
            let corner = cam.intrinsics.to_normalized(Point2::new(0.0, 0.0)).norm();
            let monotone = (0..=120).all(|i| {
                let r2 = (1.2 * corner * f64::from(i) / 120.0).powi(2);
                1.0 + 3.0 * d.k1 * r2 + 5.0 * d.k2 * r2 * r2 + 7.0 * d.k3 * r2 * r2 * r2 > 0.1
            });
            // And the rising part reaches past the corner: an observed corner
            // pixel has its preimage within it (a strong barrel lens maps
            // 1.2× the corner radius inside the corner, and then nothing
            // lands on the corner at all).
            let r = 1.2 * corner;
            let r2 = r * r;
            let reaches = r * (1.0 + d.k1 * r2 + d.k2 * r2 * r2 + d.k3 * r2 * r2 * r2) >= corner;
            prop_assume!(monotone && reaches);
            let observed = Point2::new(u, v);
            let ideal = cam.undistort_pixel(observed);
            prop_assert!(ideal.is_ok(), "{:?}: {:?}", observed, ideal);
            if let Ok(ideal) = ideal {
                let back = cam.distort_pixel(ideal);
                prop_assert!((back - observed).norm() <= 1e-10, "{:?} -> {:?}", observed, back);
            }
        }

        /// RQ reproduces the matrix with an upper-triangular, positive-diagonal factor.
        #[test]
        fn rq_round_trip(a in proptest::array::uniform9(-10.0..10.0f64)) {
            let m = Matrix3::from_row_slice(&a);
            prop_assume!(m.determinant().abs() > 1e-3);
            let (u, q) = rq3(&m).unwrap();
            prop_assert!((u * q - m).norm() <= 1e-12 * m.norm());
            prop_assert!((q * q.transpose() - Matrix3::identity()).norm() < 1e-12);
            prop_assert!(u[(1, 0)] == 0.0 || u[(1, 0)].abs() < 1e-12);
            prop_assert!(u[(2, 0)].abs() < 1e-12 && u[(2, 1)].abs() < 1e-12);
            prop_assert!(u[(0, 0)] > 0.0 && u[(1, 1)] > 0.0 && u[(2, 2)] > 0.0);
        }

        /// P ↔ (K, R, t) at any scale and sign of P.
        #[test]
        fn projection_round_trip(
            f in 500.0..10000.0f64, aspect in 0.9..1.1f64, skew in -5.0..5.0f64,
            cx in 0.0..4000.0f64, cy in 0.0..3000.0f64,
            rv in proptest::array::uniform3(-3.0..3.0f64),
            t in proptest::array::uniform3(-500.0..500.0f64),
            scale in prop_oneof![-1e3..-1e-3f64, 1e-3..1e3f64],
        ) {
            let k = Intrinsics { fx: f, fy: f * aspect, cx, cy, skew };
            let pose = Isometry3::new(Vector3::from(t), Vector3::from(rv));
            let cam = Camera { intrinsics: k, distortion: Distortion::NONE, pose, width: 4096, height: 3072 };
            let p = cam.projection_matrix();
            let back = Camera::from_projection_matrix(&(p * scale), 4096, 3072).unwrap();
            let ki = back.intrinsics;
            prop_assert!((ki.fx - k.fx).abs() < 1e-9 * f);
            prop_assert!((ki.fy - k.fy).abs() < 1e-9 * f);
            prop_assert!((ki.cx - k.cx).abs() < 1e-8 && (ki.cy - k.cy).abs() < 1e-8);
            prop_assert!((ki.skew - k.skew).abs() < 1e-8);
            prop_assert!((back.rotation().matrix() - cam.rotation().matrix()).norm() < 1e-12);
            prop_assert!((back.translation() - cam.translation()).norm() < 1e-9);
            prop_assert!((back.projection_matrix() - p).norm() < 1e-9 * p.norm());
        }
    }
}
