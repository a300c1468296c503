//! Direct linear transform from 3-D ↔ 2-D correspondences with Hartley's
//! normalisation (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed.,
//! §4.4.4 and Algorithm 7.1), and the non-coplanarity check it needs.
//!
//! `s·[u v 1]ᵀ = P·[X Y Z 1]ᵀ`, 11 unknowns; each point gives two rows of
//! `A·p = 0`, solved by the right singular vector of the smallest singular
//! value after moving both point sets to their centroids and scaling them to
//! a mean distance of √2 (image) and √3 (space).

use geom::camera::normalize_projection;
use geom::nalgebra::{DMatrix, Matrix3, Matrix4, SymmetricEigen};
use geom::{Degeneracy, Matrix3x4, Point2, Point3, Vector2};

use crate::{CalibError, OptionProblem, Result};

/// Fewest points a DLT accepts (11 unknowns, two equations per point).
pub const MIN_POINTS: usize = 6;

/// Smallest accepted ratio of the smallest to the largest principal spread of
/// the 3-D points (RMS distance from the best plane over the RMS extent along
/// the main direction). Below it the DLT is (nearly) singular.
pub const MIN_SPREAD_RATIO: f64 = 0.01;

/// Below this ratio the points are called exactly coplanar (round-off level).
const EXACT_RATIO: f64 = 1e-9;

/// Principal spreads of a 3-D point set: singular values of the centred
/// points, largest first (mm·√n).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Singular values s1 ≥ s2 ≥ s3.
    pub singular_values: [f64; 3],
}

impl Spread {
    /// Of a point set: eigenvalues of the scatter matrix `Σ(X − X̄)(X − X̄)ᵀ`, square-rooted.
    pub fn of(points: &[Point3<f64>]) -> Self {
        let n = points.len().max(1) as f64;
        let c = points
            .iter()
            .fold(Point3::origin().coords, |s, p| s + p.coords)
            / n;
        let scatter = points.iter().fold(Matrix3::zeros(), |s, p| {
            let d = p.coords - c;
            s + d * d.transpose()
        });
        let mut ev: Vec<f64> = SymmetricEigen::new(scatter)
            .eigenvalues
            .iter()
            .map(|v| v.max(0.0).sqrt())
            .collect();
        ev.sort_by(|a, b| b.total_cmp(a));
        Self {
            singular_values: [ev[0], ev[1], ev[2]],
        }
    }

    /// `s3/s1`: 0 for coplanar points.
    pub fn depth_ratio(&self) -> f64 {
        let [s1, _, s3] = self.singular_values;
        if s1 > 0.0 { s3 / s1 } else { 0.0 }
    }

    /// Fails with [`CalibError::Coplanar`] when the points are collinear,
    /// coplanar or nearly coplanar (`s3/s1 <` [`MIN_SPREAD_RATIO`]).
    pub fn check(&self) -> Result<()> {
        let [s1, s2, _] = self.singular_values;
        let line = if s1 > 0.0 { s2 / s1 } else { 0.0 };
        if line < MIN_SPREAD_RATIO {
            return Err(CalibError::Coplanar {
                kind: "collinear",
                ratio: line,
                limit: MIN_SPREAD_RATIO,
            });
        }
        let ratio = self.depth_ratio();
        if ratio < MIN_SPREAD_RATIO {
            return Err(CalibError::Coplanar {
                kind: if ratio < EXACT_RATIO {
                    "coplanar"
                } else {
                    "nearly coplanar"
                },
                ratio,
                limit: MIN_SPREAD_RATIO,
            });
        }
        Ok(())
    }
}

/// Hartley normalisation of image points: the similarity `T` (3×3) taking the
/// centroid to the origin and the mean distance from it to √2.
pub fn normalise_2d(points: &[Point2<f64>]) -> Result<Matrix3<f64>> {
    let n = points.len() as f64;
    let c = points.iter().fold(Vector2::zeros(), |s, p| s + p.coords) / n;
    let mean = points.iter().map(|p| (p.coords - c).norm()).sum::<f64>() / n;
    if !(mean.is_finite() && mean > 0.0) {
        return Err(CalibError::Geom {
            what: "DLT image normalisation",
            source: geom::GeomError::Degenerate(Degeneracy::SetCoincides { set: "image" }),
        });
    }
    let s = std::f64::consts::SQRT_2 / mean;
    Ok(Matrix3::new(
        s,
        0.0,
        -s * c.x,
        0.0,
        s,
        -s * c.y,
        0.0,
        0.0,
        1.0,
    ))
}

/// Hartley normalisation of space points: the similarity `U` (4×4) taking the
/// centroid to the origin and the mean distance from it to √3.
pub fn normalise_3d(points: &[Point3<f64>]) -> Result<Matrix4<f64>> {
    let n = points.len() as f64;
    let c = points
        .iter()
        .fold(Point3::origin().coords, |s, p| s + p.coords)
        / n;
    let mean = points.iter().map(|p| (p.coords - c).norm()).sum::<f64>() / n;
    if !(mean.is_finite() && mean > 0.0) {
        return Err(CalibError::Geom {
            what: "DLT space normalisation",
            source: geom::GeomError::Degenerate(Degeneracy::SetCoincides { set: "target" }),
        });
    }
    let s = 3f64.sqrt() / mean;
    let mut u = Matrix4::identity() * s;
    u[(3, 3)] = 1.0;
    u[(0, 3)] = -s * c.x;
    u[(1, 3)] = -s * c.y;
    u[(2, 3)] = -s * c.z;
    Ok(u)
}

/// Normalised DLT (Hartley & Zisserman Algorithm 7.1 with §4.4.4
/// normalisation): the projection matrix minimising the algebraic error of
/// the normalised points, scaled by [`normalize_projection`] so that its
/// third row's first three entries have unit norm and points in front of the
/// camera have positive depth.
///
/// Fails on fewer than [`MIN_POINTS`] points, on (nearly) coplanar points,
/// and when the linear system has no unique solution.
pub fn dlt(world: &[Point3<f64>], image: &[Point2<f64>]) -> Result<Matrix3x4<f64>> {
    if world.len() != image.len() {
        return Err(CalibError::Option(OptionProblem::DltPoints {
            world: world.len(),
            image: image.len(),
        }));
    }
    if world.len() < MIN_POINTS {
        return Err(CalibError::TooFewPoints {
            what: "DLT",
            needed: MIN_POINTS,
            got: world.len(),
        });
    }
    Spread::of(world).check()?;
    let t = normalise_2d(image)?;
    let u = normalise_3d(world)?;
    let mut a = DMatrix::zeros(2 * world.len(), 12);
    for (i, (x, p)) in world.iter().zip(image).enumerate() {
        let xn = u * x.to_homogeneous();
        let pn = t * p.to_homogeneous();
        for k in 0..4 {
            // Row 2i:   [ 0ᵀ, −Xᵀ, v·Xᵀ ];  row 2i+1: [ Xᵀ, 0ᵀ, −u·Xᵀ ].
            a[(2 * i, 4 + k)] = -xn[k];
            a[(2 * i, 8 + k)] = pn.y * xn[k];
            a[(2 * i + 1, k)] = xn[k];
            a[(2 * i + 1, 8 + k)] = -pn.x * xn[k];
        }
    }
    let svd = a.svd(false, true);
    let v_t = svd.v_t.ok_or(CalibError::Geom {
        what: "DLT",
        source: geom::GeomError::Degenerate(Degeneracy::SvdNotConverged),
    })?;
    let s = &svd.singular_values;
    let mut order: Vec<usize> = (0..s.len()).collect();
    order.sort_by(|&i, &j| s[j].total_cmp(&s[i]));
    let (smallest, second) = (order[s.len() - 1], order[s.len() - 2]);
    if s[second].is_nan() || s[second] <= 1e-10 * s[order[0]] {
        return Err(CalibError::Geom {
            what: "DLT",
            source: geom::GeomError::Degenerate(Degeneracy::MultipleSolutions),
        });
    }
    let h = v_t.row(smallest);
    let pn = Matrix3x4::from_fn(|r, c| h[4 * r + c]);
    let t_inv = t.try_inverse().ok_or(CalibError::Geom {
        what: "DLT",
        source: geom::GeomError::Degenerate(Degeneracy::Singular {
            matrix: "image normalisation",
        }),
    })?;
    let p = t_inv * pn * u;
    normalize_projection(&p).map_err(CalibError::geom("DLT"))
}

/// Pixel of a world point under a projection matrix: `(P·X)₁,₂ / (P·X)₃`;
/// `None` when the depth `(P·X)₃` is not positive.
pub fn project(p: &Matrix3x4<f64>, x: &Point3<f64>) -> Option<Point2<f64>> {
    let h = p * x.to_homogeneous();
    (h.z > 0.0).then(|| Point2::new(h.x / h.z, h.y / h.z))
}

/// Reprojection residuals `project(P, X) − x` (px); `None` for a point behind the camera.
pub fn residuals(
    p: &Matrix3x4<f64>,
    world: &[Point3<f64>],
    image: &[Point2<f64>],
) -> Vec<Option<Vector2<f64>>> {
    world
        .iter()
        .zip(image)
        .map(|(x, q)| project(p, x).map(|r| r - q))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::{Camera, Distortion, Intrinsics, Isometry3, Vector3};

    fn camera() -> Camera {
        Camera {
            intrinsics: Intrinsics {
                fx: 1200.0,
                fy: 1180.0,
                cx: 400.0,
                cy: 310.0,
                skew: 0.7,
            },
            distortion: Distortion::NONE,
            pose: Isometry3::new(
                Vector3::new(-20.0, 15.0, 600.0),
                Vector3::new(0.2, -0.3, 0.1),
            ),
            width: 800,
            height: 600,
        }
    }

    fn cube() -> Vec<Point3<f64>> {
        let mut v = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..3 {
                    v.push(Point3::new(
                        30.0 * f64::from(i),
                        30.0 * f64::from(j),
                        40.0 * f64::from(k),
                    ));
                }
            }
        }
        v
    }

    #[test]
    fn exact_data_give_the_exact_projection() {
        let cam = camera();
        let world = cube();
        let image: Vec<_> = world
            .iter()
            .map(|x| cam.project_pinhole(x).unwrap())
            .collect();
        let p = dlt(&world, &image).unwrap();
        let truth = cam.projection_matrix();
        assert!((p - truth).norm() < 1e-9 * truth.norm(), "{p} vs {truth}");
        let back = Camera::from_projection_matrix(&p, 800, 600).unwrap();
        assert!((back.intrinsics.skew - 0.7).abs() < 1e-8);
        for r in residuals(&p, &world, &image) {
            assert!(r.unwrap().norm() < 1e-9);
        }
    }

    #[test]
    fn normalisation_has_the_stated_moments() {
        let pts = [
            Point2::new(10.0, 20.0),
            Point2::new(400.0, 30.0),
            Point2::new(200.0, 500.0),
        ];
        let t = normalise_2d(&pts).unwrap();
        let q: Vec<_> = pts.iter().map(|p| (t * p.to_homogeneous()).xy()).collect();
        let c = q.iter().fold(Vector2::zeros(), |s, p| s + p) / 3.0;
        let mean = q.iter().map(|p| p.norm()).sum::<f64>() / 3.0;
        assert!(c.norm() < 1e-12 && (mean - 2f64.sqrt()).abs() < 1e-12);
        let world = cube();
        let u = normalise_3d(&world).unwrap();
        let mean = world
            .iter()
            .map(|p| (u * p.to_homogeneous()).xyz().norm())
            .sum::<f64>()
            / world.len() as f64;
        assert!((mean - 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn coplanar_and_collinear_points_are_named() {
        let flat: Vec<_> = cube()
            .into_iter()
            .map(|p| Point3::new(p.x, p.y, 5.0))
            .collect();
        let image = vec![Point2::new(0.0, 0.0); flat.len()];
        let e = dlt(&flat, &image).unwrap_err();
        assert!(
            matches!(
                e,
                CalibError::Coplanar {
                    kind: "coplanar",
                    ..
                }
            ),
            "{e}"
        );
        let thin: Vec<_> = cube()
            .into_iter()
            .map(|p| Point3::new(p.x, p.y, p.z * 1e-3))
            .collect();
        let e = dlt(&thin, &image).unwrap_err();
        assert!(
            matches!(
                e,
                CalibError::Coplanar {
                    kind: "nearly coplanar",
                    ..
                }
            ),
            "{e}"
        );
        let line: Vec<_> = (0..10)
            .map(|i| Point3::new(f64::from(i), 2.0 * f64::from(i), 0.0))
            .collect();
        let e = dlt(&line, &image[..10]).unwrap_err();
        assert!(e.to_string().contains("collinear"), "{e}");
    }
}
