//! Sphere centres from their images in several calibrated cameras.
//!
//! The observation of a sphere in a camera is the centre of its image ellipse
//! in ideal pixels. The model predicts it exactly: with C = R·X + t the sphere
//! centre in the camera frame and r its radius, the ellipse centre in
//! normalised coordinates is `e = (Cx, Cy)·Cz/(Cz² − r²)` (geom::sphere_image),
//! not the projection `(Cx, Cy)/Cz` — the perspective bias that, ignored,
//! scales displacements by ≈ 480 ppm for the 20 mm sphere (docs/methods.md).
//! Linear triangulation (DLT on the uncorrected centres) starts
//! Levenberg–Marquardt on the reprojection error of this model; with the
//! correction switched off (r = 0) the model is the plain pinhole projection.

use geom::lm::{self, LmOptions, Residuals};
use geom::nalgebra::{DMatrix, DVector, Matrix2x3, Matrix4, Vector4};
use geom::sphere_image::ellipse_centre_jacobian;
use geom::{Camera, Point2, Point3, Vector2, Vector3};

use crate::{FuseError, Result};

/// One camera's view of a sphere.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The calibrated camera.
    pub camera: &'a Camera,
    /// Observed ellipse centre, ideal (undistorted) pixels.
    pub ideal_px: Point2<f64>,
}

/// A triangulated sphere centre.
#[derive(Debug, Clone, PartialEq)]
pub struct Triangulated {
    /// Sphere centre, world frame (mm).
    pub point: Point3<f64>,
    /// RMS reprojection residual over the views (px): `√(Σ|predicted −
    /// observed|²/n)` in ideal pixels at the least-squares centre, how well
    /// the views agree (the `residual_px` of `points.csv`).
    pub residual_px: f64,
}

/// Predicted ellipse centre (ideal pixels) of a sphere of radius `radius` at
/// `x`, and its Jacobian with respect to x (px/mm): the normalised centre and
/// its Jacobian of [`geom::sphere_image::ellipse_centre_jacobian`], mapped by
/// the intrinsics K and the camera rotation R (`∂p/∂x = K₂ₓ₂·∂e/∂C·R`).
pub fn predict(
    camera: &Camera,
    x: &Point3<f64>,
    radius: f64,
) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
    let c = camera.to_camera(x);
    let (e, de_dc) = ellipse_centre_jacobian(&c.coords, radius).ok()?;
    let k = &camera.intrinsics;
    let pixel = k.to_pixel(e).coords;
    let dp_de = geom::nalgebra::Matrix2::new(k.fx, k.skew, 0.0, k.fy);
    let jac = dp_de * de_dc * camera.rotation().matrix();
    Some((pixel, jac))
}

/// Linear triangulation (DLT): homogeneous least squares over the views'
/// normalised coordinates, `x·P₃ − P₁ = 0`, `y·P₃ − P₂ = 0`, P = [R|t].
pub fn linear(views: &[View<'_>]) -> Result<Point3<f64>> {
    if views.len() < 2 {
        return Err(FuseError::TooFewViews { views: views.len() });
    }
    let mut a = Matrix4::<f64>::zeros();
    for v in views {
        let n = v.camera.intrinsics.to_normalized(v.ideal_px);
        let r = v.camera.rotation();
        let t = v.camera.translation();
        let row = |i: usize| Vector4::new(r[(i, 0)], r[(i, 1)], r[(i, 2)], t[i]);
        for eq in [row(0) - row(2) * n.x, row(1) - row(2) * n.y] {
            a += eq * eq.transpose();
        }
    }
    // Smallest eigenvector of AᵀA.
    let (_, h) = geom::fit::smallest_eigenpair(a);
    if h[3].abs() < 1e-12 * h.norm() {
        return Err(FuseError::ParallelViews);
    }
    Ok(Point3::new(h[0] / h[3], h[1] / h[3], h[2] / h[3]))
}

/// Reprojection residuals of one sphere over its views (LM problem in X).
struct Reprojection<'a> {
    views: &'a [View<'a>],
    radius: f64,
}

impl Residuals for Reprojection<'_> {
    fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
        let x = Point3::new(p[0], p[1], p[2]);
        let mut r = DVector::zeros(2 * self.views.len());
        for (i, v) in self.views.iter().enumerate() {
            let pred =
                predict(v.camera, &x, self.radius).map_or(Vector2::repeat(f64::NAN), |(q, _)| q);
            r[2 * i] = pred.x - v.ideal_px.x;
            r[2 * i + 1] = pred.y - v.ideal_px.y;
        }
        r
    }

    fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
        let x = Point3::new(p[0], p[1], p[2]);
        let mut j = DMatrix::zeros(2 * self.views.len(), 3);
        for (i, v) in self.views.iter().enumerate() {
            let jac =
                predict(v.camera, &x, self.radius).map_or(Matrix2x3::repeat(f64::NAN), |(_, j)| j);
            j.view_mut((2 * i, 0), (2, 3)).copy_from(&jac);
        }
        j
    }
}

/// Triangulate a sphere of radius `radius` (0: ignore the perspective bias)
/// from two or more views: linear start, then least squares on the exact
/// ellipse-centre model.
pub fn triangulate(views: &[View<'_>], radius: f64) -> Result<Triangulated> {
    let start = linear(views)?;
    let problem = Reprojection { views, radius };
    let sol = lm::minimize(
        &problem,
        DVector::from_column_slice(start.coords.as_slice()),
        &LmOptions::default(),
    )
    .map_err(|e| FuseError::geometry("triangulation", e))?;
    let point = Point3::new(sol.params[0], sol.params[1], sol.params[2]);
    Ok(Triangulated {
        point,
        residual_px: (sol.residuals.norm_squared() / views.len() as f64).sqrt(),
    })
}

/// The seed's pixel-scale fusion (docs/methods.md): the displacement of a sphere
/// since a reference instant from each camera's image displacement, scaled by
/// the camera's mm per pixel at the sphere's depth. Each camera sees the
/// displacement's components along its image axes, `[x̂_c; ŷ_c]·Δ = Z_c·Δn`
/// (x̂_c, ŷ_c the camera's x and y axes in the world, Z_c the reference depth,
/// Δn the change of normalised coordinates); the cameras' equations are solved
/// together by least squares — for cameras 2 and 3 on an X sweep, x is the
/// mean of the two cameras' Δx, y comes from camera 3 and z from camera 2.
/// Returns Δ (mm) and the RMS residual of the equations in pixels.
pub fn seed_displacement(
    reference: &[View<'_>],
    current: &[View<'_>],
    depths: &[f64],
) -> Result<(Vector3<f64>, f64)> {
    if reference.len() != current.len() || reference.len() != depths.len() || reference.len() < 2 {
        return Err(FuseError::SeedCameras {
            reference: reference.len(),
            current: current.len(),
            depths: depths.len(),
        });
    }
    let n = reference.len();
    let mut a = DMatrix::zeros(2 * n, 3);
    let mut b = DVector::zeros(2 * n);
    let mut scale = Vec::with_capacity(2 * n);
    for (i, ((r, c), &z)) in reference.iter().zip(current).zip(depths).enumerate() {
        let k = &r.camera.intrinsics;
        let dn = k.to_normalized(c.ideal_px) - k.to_normalized(r.ideal_px);
        let rot = r.camera.rotation();
        for (row, axis) in [(2 * i, 0), (2 * i + 1, 1)] {
            for col in 0..3 {
                a[(row, col)] = rot[(axis, col)];
            }
            b[row] = z * dn[axis];
        }
        // mm → px at this camera's depth, for the residual.
        scale.push(k.fx / z);
        scale.push(k.fy / z);
    }
    let svd = a.clone().svd(true, true);
    let d = svd.solve(&b, 1e-12).map_err(FuseError::SeedSolve)?;
    let res = &a * &d - &b;
    let rms = (res
        .iter()
        .zip(&scale)
        .map(|(r, s)| (r * s).powi(2))
        .sum::<f64>()
        / n as f64)
        .sqrt();
    Ok((Vector3::new(d[0], d[1], d[2]), rms))
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::Intrinsics;

    fn rig() -> Vec<Camera> {
        let k = Intrinsics::centred(7966.0, 4096, 3072);
        let look = |pos: Point3<f64>, up: Vector3<f64>| {
            let mut c =
                Camera::look_at(pos, Point3::new(0.0, 0.0, 30.0), up, k, 4096, 3072).unwrap();
            c.distortion.k1 = -0.04;
            c
        };
        vec![
            look(Point3::new(-460.0, 0.0, 30.0), Vector3::z()),
            look(Point3::new(0.0, -460.0, 30.0), Vector3::z()),
            look(Point3::new(0.0, 0.0, 490.0), Vector3::y()),
        ]
    }

    fn views<'a>(cams: &'a [Camera], x: &Point3<f64>, radius: f64) -> Vec<View<'a>> {
        cams.iter()
            .map(|c| View {
                camera: c,
                ideal_px: {
                    let (p, _) = predict(c, x, radius).unwrap();
                    Point2::new(p.x, p.y)
                },
            })
            .collect()
    }

    #[test]
    fn prediction_is_the_ellipse_centre_and_its_jacobian_is_right() {
        let cams = rig();
        let x = Point3::new(60.0, -40.0, 45.0);
        for c in &cams {
            let (p, _) = predict(c, &x, 10.0).unwrap();
            let e = geom::sphere_image::ellipse_centre(&c.to_camera(&x), 10.0).unwrap();
            assert!((p - c.intrinsics.to_pixel(e).coords).norm() < 1e-9);
        }
        let v = views(&cams, &x, 10.0);
        let problem = Reprojection {
            views: &v,
            radius: 10.0,
        };
        let at = DVector::from_vec(vec![61.0, -39.0, 44.0]);
        assert!(lm::jacobian_error(&problem, &at) < 1e-6);
    }

    #[test]
    fn exact_views_triangulate_exactly() {
        let cams = rig();
        let x = Point3::new(60.0, -40.0, 45.0);
        for pair in [[1usize, 2], [0, 2], [0, 1]] {
            let v: Vec<View<'_>> = pair.iter().map(|&i| views(&cams, &x, 10.0)[i]).collect();
            let t = triangulate(&v, 10.0).unwrap();
            assert!((t.point - x).norm() < 1e-9, "{pair:?}: {:?}", t.point);
            assert!(t.residual_px < 1e-9);
        }
    }

    #[test]
    fn ignoring_the_bias_scales_off_axis_positions() {
        // Uncorrected, a 20 mm sphere 75 mm off-axis triangulates ≈ 480 ppm further out.
        let cams = rig();
        let (a, b) = (Point3::new(-75.0, 0.0, 30.0), Point3::new(75.0, 0.0, 30.0));
        let pair = |x: &Point3<f64>| -> Vec<View<'_>> { views(&cams, x, 10.0)[1..].to_vec() };
        let d_true = (b - a).norm();
        let d_biased = (triangulate(&pair(&b), 0.0).unwrap().point
            - triangulate(&pair(&a), 0.0).unwrap().point)
            .norm();
        let ppm = (d_biased / d_true - 1.0) * 1e6;
        assert!(ppm > 400.0 && ppm < 560.0, "{ppm} ppm");
        let d_corrected = (triangulate(&pair(&b), 10.0).unwrap().point
            - triangulate(&pair(&a), 10.0).unwrap().point)
            .norm();
        assert!((d_corrected - d_true).abs() < 1e-9);
    }

    #[test]
    fn seed_fusion_recovers_an_x_displacement() {
        let cams = rig();
        let x0 = Point3::new(0.0, 0.0, 30.0);
        let x1 = Point3::new(30.0, 0.002, -0.001);
        let ideal = |x: &Point3<f64>| -> Vec<View<'_>> { views(&cams, x, 0.0)[1..].to_vec() };
        let depths: Vec<f64> = cams[1..].iter().map(|c| c.to_camera(&x0).z).collect();
        let (d, _) = seed_displacement(&ideal(&x0), &ideal(&(x0 + x1.coords)), &depths).unwrap();
        // Pixel scale at the reference depth: the motion across the field is
        // recovered to the (small) perspective error of the seed's model.
        assert!((d.x - 30.0).abs() < 1e-3, "{d:?}");
    }

    #[test]
    fn the_residual_is_the_rms_distance_of_the_reprojections() {
        let cams = rig();
        let x = Point3::new(10.0, 5.0, 40.0);
        let mut v = views(&cams, &x, 10.0);
        // Shift one view by (3, 4) px: the views disagree, and the residual is
        // the RMS distance of the reprojected least-squares centre.
        v[0].ideal_px += Vector2::new(3.0, 4.0);
        let t = triangulate(&v, 10.0).unwrap();
        let ss: f64 = v
            .iter()
            .map(|w| {
                let (p, _) = predict(w.camera, &t.point, 10.0).unwrap();
                (p - w.ideal_px.coords).norm_squared()
            })
            .sum();
        assert!((t.residual_px - (ss / 3.0).sqrt()).abs() < 1e-12);
        // Below the RMS at the true centre (√(25/3) px), and well above zero.
        assert!(t.residual_px > 1.0 && t.residual_px < (25.0f64 / 3.0).sqrt());
    }
}
