//! Sphere centres from their images in several calibrated cameras.
//!
//! The observation of a sphere in a camera is the centre of its image ellipse
//! in ideal pixels. The model predicts it exactly: with C = R·X + t the sphere
//! centre in the camera frame and r its radius, the ellipse centre in
//! normalised coordinates is `e = (Cx, Cy)·Cz/(Cz² − r²)` (crate::sphere_image),
//! not the projection `(Cx, Cy)/Cz` — the perspective bias that, ignored,
//! scales displacements by ≈ 480 ppm for the 20 mm sphere (docs/methods.md).
//! Linear triangulation (DLT on the uncorrected centres) starts
//! Levenberg–Marquardt on the reprojection error of this model; with the
//! correction switched off (r = 0) the model is the plain pinhole projection.

use nalgebra::{
    DMatrix, DVector, Matrix2, Matrix2x3, Matrix3, Matrix4, Point2, Point3, Vector2, Vector4,
};

use crate::lm::{self, LmOptions, Residuals};
use crate::sphere_image::ellipse_centre_jacobian;
use crate::{Camera, Degeneracy, GeomError, Result};

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
/// its Jacobian of [`crate::sphere_image::ellipse_centre_jacobian`], mapped by
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
    let dp_de = Matrix2::new(k.fx, k.skew, 0.0, k.fy);
    let jac = dp_de * de_dc * camera.rotation().matrix();
    Some((pixel, jac))
}

/// Linear triangulation (DLT): homogeneous least squares over the views'
/// normalised coordinates, `x·P₃ − P₁ = 0`, `y·P₃ − P₂ = 0`, P = [R|t].
pub fn linear(views: &[View<'_>]) -> Result<Point3<f64>> {
    if views.len() < 2 {
        return Err(GeomError::TooFewPoints {
            what: "triangulation (views of the sphere)",
            needed: 2,
            got: views.len(),
        });
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
    let (_, h) = crate::fit::smallest_eigenpair(a);
    if h[3].abs() < 1e-12 * h.norm() {
        return Err(Degeneracy::ParallelViews.into());
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
    )?;
    let point = Point3::new(sol.params[0], sol.params[1], sol.params[2]);
    Ok(Triangulated {
        point,
        residual_px: (sol.residuals.norm_squared() / views.len() as f64).sqrt(),
    })
}

/// Covariance of a triangulated centre `x` from covariances of its views'
/// image centres (one 2×2 block per view, independent between views), to
/// first order: `Σ_X = H·Σ·Hᵀ`, `H = (AᵀA)⁻¹Aᵀ`, A the stacked Jacobians
/// ∂predicted/∂X of [`predict`] (the least squares of [`triangulate`] is
/// unweighted). `None` when a view cannot predict or AᵀA is singular.
pub fn centre_covariance(
    views: &[View<'_>],
    radius: f64,
    x: &Point3<f64>,
    image_covariances: &[Matrix2<f64>],
) -> Option<Matrix3<f64>> {
    if views.len() != image_covariances.len() {
        return None;
    }
    let mut ata = Matrix3::zeros();
    let mut jacobians = Vec::with_capacity(views.len());
    for v in views {
        let (_, a) = predict(v.camera, x, radius)?;
        ata += a.transpose() * a;
        jacobians.push(a);
    }
    let inv = ata.try_inverse()?;
    let mut cov = Matrix3::zeros();
    for (a, c) in jacobians.iter().zip(image_covariances) {
        let h = inv * a.transpose();
        cov += h * c * h.transpose();
    }
    Some(cov)
}

/// The covariance (ideal px²) that the uncertainty of a camera's parameters
/// gives the residual of one view of a sphere at `x`, to first order:
/// `B·Σ_p·Bᵀ`, B = ∂(predicted − observed)/∂p by central differences over
/// [`Camera::perturbed`] — the prediction moves with the camera, and so does
/// the observed centre `ideal` (distorted back through the camera, undistorted
/// through the moved one). `None` when a moved camera cannot predict.
pub fn parameter_image_covariance(
    camera: &Camera,
    names: &[String],
    covariance: &DMatrix<f64>,
    x: &Point3<f64>,
    radius: f64,
    ideal: Point2<f64>,
) -> Option<Matrix2<f64>> {
    let n = names.len();
    if covariance.nrows() != n || covariance.ncols() != n {
        return None;
    }
    let observed = camera.distort_pixel(ideal);
    let residual = |c: &Camera| -> Option<Vector2<f64>> {
        let (p, _) = predict(c, x, radius)?;
        Some(p - c.undistort_pixel(observed).ok()?.coords)
    };
    let mut b = DMatrix::zeros(2, n);
    for j in 0..n {
        // A step of a hundredth of the parameter's own standard deviation
        // (central differences: error O(h²)), or a tiny absolute one.
        let h = (covariance[(j, j)].sqrt() * 1e-2).max(1e-12);
        let mut step = vec![0.0; n];
        step[j] = h;
        let plus = residual(&camera.perturbed(names, &step).ok()?)?;
        step[j] = -h;
        let minus = residual(&camera.perturbed(names, &step).ok()?)?;
        let d = (plus - minus) / (2.0 * h);
        b[(0, j)] = d.x;
        b[(1, j)] = d.y;
    }
    let c = &b * covariance * b.transpose();
    Some(Matrix2::new(c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Intrinsics;
    use nalgebra::Vector3;

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
            let e = crate::sphere_image::ellipse_centre(&c.to_camera(&x), 10.0).unwrap();
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

    /// The first-order covariance of the centre agrees with the scatter of
    /// centres triangulated from noisy image centres.
    #[test]
    fn centre_covariance_matches_the_scatter_of_noisy_triangulations() {
        let cams = rig();
        let x = Point3::new(20.0, -10.0, 40.0);
        let exact = views(&cams, &x, 10.0);
        let sigma = [0.05, 0.08, 0.03];
        let covs: Vec<Matrix2<f64>> = sigma
            .iter()
            .map(|&s: &f64| Matrix2::identity() * (s * s))
            .collect();
        let predicted = centre_covariance(&exact, 10.0, &x, &covs).unwrap();
        // Seeded standard normal deviates (σ = 1).
        let mut draws = crate::montecarlo::Draws::seeded(12345);
        let mut normal = || draws.normal();
        let n = 4000;
        let mut scatter = Matrix3::zeros();
        for _ in 0..n {
            let noisy: Vec<View<'_>> = exact
                .iter()
                .zip(sigma)
                .map(|(v, s)| View {
                    camera: v.camera,
                    ideal_px: v.ideal_px + Vector2::new(normal() * s, normal() * s),
                })
                .collect();
            let d = triangulate(&noisy, 10.0).unwrap().point - x;
            scatter += d * d.transpose();
        }
        scatter /= n as f64;
        for i in 0..3 {
            let ratio = scatter[(i, i)] / predicted[(i, i)];
            assert!((ratio - 1.0).abs() < 0.1, "axis {i}: {ratio}");
        }
    }

    /// A camera's parameter covariance moves a view's residual as moving the
    /// camera does: a covariance on cx alone gives var(u) = σ², nothing on v.
    #[test]
    fn a_principal_point_uncertainty_moves_the_image_by_itself() {
        let cams = rig();
        let x = Point3::new(20.0, -10.0, 40.0);
        let v = views(&cams, &x, 10.0);
        let names: Vec<String> = ["cx", "cy"].map(String::from).to_vec();
        let cov = DMatrix::from_row_slice(2, 2, &[0.25, 0.0, 0.0, 0.0]);
        let c =
            parameter_image_covariance(v[2].camera, &names, &cov, &x, 10.0, v[2].ideal_px).unwrap();
        // The prediction moves by δcx; the observed centre, undistorted through
        // the moved camera, moves by less than δcx·|∂distortion| — net ≈ σ².
        assert!((c[(0, 0)] / 0.25 - 1.0).abs() < 0.05, "{c}");
        assert!(c[(1, 1)].abs() < 0.25 * 0.05, "{c}");
    }
}
