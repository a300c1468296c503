//! Start values from a planar target (Zhang 2000, docs/methods.md §8): a
//! homography per view from the board's (X, Y) to pixels, the intrinsics
//! from the homographies' constraints on `B = K⁻ᵀK⁻¹`, and each view's pose
//! from K and its homography. Distortion starts at 0; the bundle refines
//! everything.

use geom::nalgebra::{DMatrix, Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion};
use geom::{Intrinsics, Point2, Vector3};

use crate::dlt::normalise_2d;
use crate::{CalibError, Result};

/// Points a homography needs.
pub const MIN_HOMOGRAPHY_POINTS: usize = 4;

/// Largest condition number of Zhang's system `V·b = 0` (its largest over
/// its second-smallest singular value, pixels normalised to ≈ 1) before the
/// views are called parallel: beyond it the focal length is undetermined.
pub const MAX_ZHANG_CONDITION: f64 = 1e10;

/// The homography `H` (pixel ∝ H·(X, Y, 1)) of one view: normalised DLT
/// (Hartley & Zisserman Algorithm 4.2) on ≥ 4 points.
pub fn homography(board: &[Point2<f64>], pixels: &[Point2<f64>]) -> Result<Matrix3<f64>> {
    if board.len() < MIN_HOMOGRAPHY_POINTS || board.len() != pixels.len() {
        return Err(CalibError::TooFewPoints {
            what: "a planar view's homography",
            needed: MIN_HOMOGRAPHY_POINTS,
            got: board.len().min(pixels.len()),
        });
    }
    let tb = normalise_2d(board)?;
    let tp = normalise_2d(pixels)?;
    let mut a = DMatrix::zeros(2 * board.len(), 9);
    for (i, (b, p)) in board.iter().zip(pixels).enumerate() {
        let x = tb * b.to_homogeneous();
        let u = tp * p.to_homogeneous();
        let (x, y, w) = (x.x / x.z, x.y / x.z, 1.0);
        let (u, v) = (u.x / u.z, u.y / u.z);
        let row = [
            [0.0, 0.0, 0.0, -x, -y, -w, v * x, v * y, v * w],
            [x, y, w, 0.0, 0.0, 0.0, -u * x, -u * y, -u * w],
        ];
        for (k, r) in row.iter().enumerate() {
            for (j, value) in r.iter().enumerate() {
                a[(2 * i + k, j)] = *value;
            }
        }
    }
    let h = smallest_right_singular_vector(a)?;
    let hn = Matrix3::from_row_slice(h.as_slice());
    let inverse = tp.try_inverse().ok_or_else(degenerate)?;
    let h = inverse * hn * tb;
    let scale = h[(2, 2)];
    Ok(if scale.abs() > f64::EPSILON {
        h / scale
    } else {
        h
    })
}

/// The intrinsics from the homographies of ≥ 1 views of a `width × height`
/// sensor (Zhang 2000 §3.1 and Appendix B): with 3 or more, K with skew
/// held at 0 (the zero-skew row added); with 2, skew 0; with 1, the
/// principal point at the image centre and square pixels, the focal length
/// alone. The pixels are normalised first (the system is poorly scaled in
/// raw pixels). Fails with [`CalibError::ParallelViews`] when the views do
/// not determine K (boards parallel to each other or to the sensor).
pub fn intrinsics(homographies: &[Matrix3<f64>], width: u32, height: u32) -> Result<Intrinsics> {
    let s = 0.5 * f64::from(width + height);
    let (cx, cy) = (0.5 * f64::from(width - 1), 0.5 * f64::from(height - 1));
    // N takes pixels to ≈ unit coordinates about the image centre.
    let n = Matrix3::new(1.0 / s, 0.0, -cx / s, 0.0, 1.0 / s, -cy / s, 0.0, 0.0, 1.0);
    let hs: Vec<Matrix3<f64>> = homographies.iter().map(|h| n * h).collect();
    let k = if hs.len() == 1 {
        focal_only(&hs[0], homographies.len())?
    } else {
        zhang_b(&hs)?
    };
    // Back to pixels: K = N⁻¹·Kₙ.
    let inverse = n.try_inverse().ok_or_else(degenerate)?;
    let k = inverse * k;
    Ok(Intrinsics {
        fx: k[(0, 0)],
        fy: k[(1, 1)],
        cx: k[(0, 2)],
        cy: k[(1, 2)],
        skew: 0.0,
    })
}

/// A view's pose (board → camera) from K and its homography (Zhang 2000
/// §3.1): `r1 = λK⁻¹h1, r2 = λK⁻¹h2, r3 = r1 × r2, t = λK⁻¹h3`,
/// `λ = 1/‖K⁻¹h1‖` with the sign that puts the board in front, R the
/// nearest rotation (SVD).
pub fn pose(k: &Intrinsics, h: &Matrix3<f64>) -> Result<Isometry3<f64>> {
    let kinv = k.matrix().try_inverse().ok_or_else(degenerate)?;
    let a = kinv * h;
    let (c1, c2, c3) = (a.column(0), a.column(1), a.column(2));
    let norm = c1.norm();
    if !(norm.is_finite() && norm > 0.0) {
        return Err(degenerate());
    }
    let mut lambda = 1.0 / norm;
    if c3.z * lambda < 0.0 {
        lambda = -lambda;
    }
    let r1: Vector3<f64> = c1 * lambda;
    let r2: Vector3<f64> = c2 * lambda;
    let r3 = r1.cross(&r2);
    let t: Vector3<f64> = c3 * lambda;
    let m = Matrix3::from_columns(&[r1, r2, r3]);
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(degenerate());
    };
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        r = -r;
    }
    let rotation = Rotation3::from_matrix_unchecked(r);
    Ok(Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&rotation),
    ))
}

/// `v_ij` of Zhang's (8): `h_iᵀ·B·h_j = v_ijᵀ·b`, `b = (B11, B12, B22, B13, B23, B33)`.
fn v(h: &Matrix3<f64>, i: usize, j: usize) -> [f64; 6] {
    let (a, b) = (h.column(i), h.column(j));
    [
        a[0] * b[0],
        a[0] * b[1] + a[1] * b[0],
        a[1] * b[1],
        a[2] * b[0] + a[0] * b[2],
        a[2] * b[1] + a[1] * b[2],
        a[2] * b[2],
    ]
}

/// Kₙ from ≥ 2 normalised homographies, skew held at 0 (B12 = 0).
fn zhang_b(hs: &[Matrix3<f64>]) -> Result<Matrix3<f64>> {
    let mut rows: Vec<[f64; 6]> = Vec::with_capacity(2 * hs.len() + 1);
    for h in hs {
        rows.push(v(h, 0, 1));
        let (a, b) = (v(h, 0, 0), v(h, 1, 1));
        rows.push(std::array::from_fn(|k| a[k] - b[k]));
    }
    rows.push([0.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
    let m = DMatrix::from_fn(rows.len(), 6, |i, j| rows[i][j]);
    let singular = m.clone().svd(false, false).singular_values;
    let condition = singular[0] / singular[4].max(f64::MIN_POSITIVE);
    if !(condition.is_finite() && condition < MAX_ZHANG_CONDITION) {
        return Err(CalibError::ParallelViews {
            views: hs.len(),
            condition,
        });
    }
    let b = smallest_right_singular_vector(m)?;
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let d = b11 * b22 - b12 * b12;
    let v0 = (b12 * b13 - b11 * b23) / d;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    let alpha2 = lambda / b11;
    let beta2 = lambda * b11 / d;
    if !(alpha2 > 0.0 && beta2 > 0.0 && alpha2.is_finite() && beta2.is_finite()) {
        return Err(CalibError::ParallelViews {
            views: hs.len(),
            condition,
        });
    }
    let (alpha, beta) = (alpha2.sqrt(), beta2.sqrt());
    let gamma = -b12 * alpha2 * beta / lambda;
    let u0 = gamma * v0 / beta - b13 * alpha2 / lambda;
    Ok(Matrix3::new(alpha, 0.0, u0, 0.0, beta, v0, 0.0, 0.0, 1.0))
}

/// Kₙ from one normalised homography: the principal point at the origin
/// (the image centre), square pixels, no skew; `1/f²` from Zhang's two
/// constraints in the least-squares sense.
fn focal_only(h: &Matrix3<f64>, views: usize) -> Result<Matrix3<f64>> {
    // With B = diag(w, w, 1), w = 1/f²: h_iᵀBh_j = w(h0i h0j + h1i h1j) + h2i h2j.
    let (p, q) = (h.column(0), h.column(1));
    let a1 = p[0] * q[0] + p[1] * q[1];
    let c1 = p[2] * q[2];
    let a2 = (p[0] * p[0] + p[1] * p[1]) - (q[0] * q[0] + q[1] * q[1]);
    let c2 = p[2] * p[2] - q[2] * q[2];
    // w·a + c = 0 for both rows.
    let w = -(a1 * c1 + a2 * c2) / (a1 * a1 + a2 * a2);
    let condition = (a1 * a1 + a2 * a2).sqrt() / (c1 * c1 + c2 * c2).sqrt().max(f64::MIN_POSITIVE);
    if !(w.is_finite() && w > 0.0) {
        return Err(CalibError::ParallelViews { views, condition });
    }
    let f = 1.0 / w.sqrt();
    Ok(Matrix3::new(f, 0.0, 0.0, 0.0, f, 0.0, 0.0, 0.0, 1.0))
}

/// The unit vector minimising ‖A·x‖ (the last right singular vector).
fn smallest_right_singular_vector(a: DMatrix<f64>) -> Result<geom::nalgebra::DVector<f64>> {
    // AᵀA's eigenvector of the smallest eigenvalue: A has more rows than
    // columns here, and nalgebra's thin SVD of a tall A gives Vᵀ whole.
    let svd = a.svd(false, true);
    let v_t = svd.v_t.ok_or_else(degenerate)?;
    let (i, _) = svd
        .singular_values
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .ok_or_else(degenerate)?;
    Ok(v_t.row(i).transpose())
}

fn degenerate() -> CalibError {
    CalibError::Geom {
        what: "planar start (homography)",
        source: geom::GeomError::Degenerate(geom::Degeneracy::SetCoincides { set: "board" }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::{Camera, Point3};

    fn board() -> Vec<Point2<f64>> {
        (0..7)
            .flat_map(|i| {
                (0..5).map(move |j| Point2::new(20.0 * f64::from(i), 20.0 * f64::from(j)))
            })
            .collect()
    }

    fn views() -> Vec<Camera> {
        let k = Intrinsics {
            fx: 1210.0,
            fy: 1195.0,
            cx: 655.0,
            cy: 470.0,
            skew: 0.0,
        };
        [
            (
                Vector3::new(0.3, -0.2, 0.1),
                Vector3::new(-60.0, -40.0, 520.0),
            ),
            (
                Vector3::new(-0.35, 0.1, -0.2),
                Vector3::new(-50.0, -30.0, 480.0),
            ),
            (
                Vector3::new(0.1, 0.4, 0.3),
                Vector3::new(-70.0, -50.0, 560.0),
            ),
        ]
        .into_iter()
        .map(|(r, t)| Camera {
            intrinsics: k,
            distortion: geom::Distortion::NONE,
            pose: Isometry3::new(t, r),
            width: 1280,
            height: 960,
        })
        .collect()
    }

    /// Each camera's homography of the board, from its exact projections.
    fn homographies(b: &[Point2<f64>], cams: &[Camera]) -> Vec<Matrix3<f64>> {
        cams.iter()
            .map(|c| {
                let px: Vec<Point2<f64>> = b
                    .iter()
                    .map(|p| c.project(&Point3::new(p.x, p.y, 0.0)).unwrap())
                    .collect();
                homography(b, &px).unwrap()
            })
            .collect()
    }

    #[test]
    fn exact_views_give_the_camera_back() {
        let b = board();
        let cams = views();
        let hs = homographies(&b, &cams);
        let k = intrinsics(&hs, 1280, 960).unwrap();
        let truth = cams[0].intrinsics;
        for (got, want) in [
            (k.fx, truth.fx),
            (k.fy, truth.fy),
            (k.cx, truth.cx),
            (k.cy, truth.cy),
        ] {
            assert!((got - want).abs() < 1e-6, "{got} vs {want}");
        }
        for (c, h) in cams.iter().zip(&hs) {
            let p = pose(&k, h).unwrap();
            assert!((p.translation.vector - c.pose.translation.vector).norm() < 1e-6);
            assert!(p.rotation.angle_to(&c.pose.rotation) < 1e-9);
        }
        // One view alone: the focal length with the centre assumed (here
        // 15 px off the true one) — a start for the bundle, within 20 %.
        let one = intrinsics(&hs[..1], 1280, 960).unwrap();
        assert!(
            (one.fx / truth.fx - 1.0).abs() < 0.2,
            "fx from one view {}",
            one.fx
        );
    }

    #[test]
    fn parallel_views_are_refused_with_their_condition() {
        let b = board();
        let mut cams = views();
        for c in &mut cams {
            // Every board parallel to the sensor: only translated.
            c.pose.rotation = UnitQuaternion::identity();
        }
        let hs = homographies(&b, &cams);
        let err = intrinsics(&hs, 1280, 960).unwrap_err();
        assert!(matches!(err, CalibError::ParallelViews { .. }), "{err}");
        assert!(err.to_string().contains("condition"), "{err}");
    }
}
