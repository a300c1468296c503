//! Least-squares (Gaussian) fits of geometric elements, as ASME B89.4.10 and
//! the NIST Algorithm Testing System define them: minimise the sum of squared
//! orthogonal distances. Also the vertical-residual regressions
//! (`y = kx + b`, `z = ax + by + c`) the straightness and flatness sources use.
//!
//! Every result carries the residual of every input point, in input order.
//! Directions and normals are unit vectors whose largest component is
//! positive (their sign has no meaning otherwise).
//!
//! Linear elements come from the singular value decomposition of the centred
//! points; circles, spheres and cylinders from an algebraic start refined by
//! Levenberg–Marquardt ([`crate::lm`]) on the geometric distances.

mod circle;
mod cylinder;
mod line;
mod plane;
mod sphere;

pub use circle::{Circle2Fit, Circle3Fit, circle_2d, circle_3d};
pub use cylinder::{CylinderFit, cylinder};
pub use line::{Line2Fit, Line3Fit, SlopeLine, line_2d, line_3d, line_y_on_x};
pub use plane::{HeightPlane, PlaneFit, plane, plane_z_on_xy};
pub use sphere::{SphereFit, sphere};

use nalgebra::allocator::Allocator;
use nalgebra::{
    Const, DMatrix, DVector, DefaultAllocator, DimDiff, DimSub, Dyn, Matrix3, OPoint, Point3,
    SMatrix, SVD, SVector, U1, Vector3,
};

use crate::lm::{self, LmOptions, Residuals};
use crate::{Degeneracy, GeomError, Result};

/// Singular values below this fraction of the largest count as zero: the
/// input then does not determine the element (collinear, coplanar, …).
pub(crate) const RANK_TOLERANCE: f64 = 1e-12;

/// Iteration limit of the SVD (nalgebra counts sweeps; 0 would mean unlimited).
pub(crate) const SVD_MAX_ITERATIONS: usize = 1000;

/// Largest coordinate magnitude a fit accepts: products and sums of squares
/// of a billion such values stay far from `f64::MAX` (≈ 1.8e308).
pub const MAX_COORDINATE: f64 = 1e100;

/// Fail unless there are at least `needed` points, all finite and within
/// ±[`MAX_COORDINATE`].
pub(crate) fn validate<const D: usize>(
    points: &[OPoint<f64, nalgebra::Const<D>>],
    what: &'static str,
    needed: usize,
) -> Result<()> {
    if points.len() < needed {
        return Err(GeomError::TooFewPoints {
            what,
            needed,
            got: points.len(),
        });
    }
    if points
        .iter()
        .any(|p| p.coords.iter().any(|v| !v.is_finite()))
    {
        return Err(GeomError::NonFinite(what));
    }
    if let Some(&value) = points
        .iter()
        .flat_map(|p| p.coords.iter())
        .find(|v| v.abs() > MAX_COORDINATE)
    {
        return Err(GeomError::OutOfRange {
            what,
            value,
            limit: MAX_COORDINATE,
        });
    }
    Ok(())
}

/// Centroid `Σp / n` of a non-empty slice.
pub(crate) fn centroid<const D: usize>(
    points: &[OPoint<f64, nalgebra::Const<D>>],
) -> OPoint<f64, nalgebra::Const<D>> {
    let sum = points
        .iter()
        .fold(SVector::<f64, D>::zeros(), |acc, p| acc + p.coords);
    OPoint::from(sum / points.len().max(1) as f64)
}

/// Flip `v` so that its largest-magnitude component is positive.
pub(crate) fn canonical_sign<const D: usize>(v: SVector<f64, D>) -> SVector<f64, D> {
    let largest = v
        .iter()
        .copied()
        .fold(0.0_f64, |m, x| if x.abs() > m.abs() { x } else { m });
    if largest < 0.0 { -v } else { v }
}

/// SVD of `a` with its right singular vectors (and the left ones when
/// `left`), at most [`SVD_MAX_ITERATIONS`] sweeps.
fn svd_of(a: DMatrix<f64>, left: bool) -> Result<SVD<f64, Dyn, Dyn>> {
    SVD::try_new(a, left, true, f64::EPSILON, SVD_MAX_ITERATIONS).ok_or(GeomError::NotConverged {
        what: "singular value decomposition",
        iterations: SVD_MAX_ITERATIONS,
        last_step: f64::NAN,
    })
}

/// Singular values (descending) and right singular vectors (columns, same
/// order) of the `n×3` matrix of points minus `origin`: the principal axes.
pub(crate) fn principal_axes(
    points: &[Point3<f64>],
    origin: &Point3<f64>,
) -> Result<(Vector3<f64>, Matrix3<f64>)> {
    // Zero rows change nothing but keep the decomposition 3×3 for n < 3.
    let rows = points.len().max(3);
    let centred = DMatrix::from_fn(rows, 3, |i, j| {
        points.get(i).map_or(0.0, |p| p[j] - origin[j])
    });
    let svd = svd_of(centred, false)?;
    let v_t = svd
        .v_t
        .ok_or(GeomError::Degenerate(Degeneracy::NoSingularVectors))?;
    let mut sigma = Vector3::zeros();
    let mut axes = Matrix3::zeros();
    for k in 0..3 {
        sigma[k] = svd.singular_values[k];
        axes.set_column(k, &v_t.row(k).transpose());
    }
    Ok((sigma, axes))
}

/// Two unit vectors `u`, `v` with `(u, v, n)` a right-handed orthonormal frame.
pub(crate) fn orthonormal_basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    // Cross with the coordinate axis least aligned with n.
    let axis = if n.x.abs() <= n.y.abs() && n.x.abs() <= n.z.abs() {
        Vector3::x()
    } else if n.y.abs() <= n.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let u = n.cross(&axis).normalize();
    let v = n.cross(&u);
    (u, v)
}

/// Least-squares solution of `A·x = b` by SVD; fails when `A` has numerical
/// rank below its column count (relative tolerance [`RANK_TOLERANCE`]).
pub(crate) fn solve_least_squares(
    a: DMatrix<f64>,
    b: &DVector<f64>,
    what: &'static str,
) -> Result<DVector<f64>> {
    let cols = a.ncols();
    let svd = svd_of(a, true)?;
    let largest = svd.singular_values.max();
    let smallest = svd.singular_values.min();
    if svd.singular_values.len() < cols || smallest <= RANK_TOLERANCE * largest {
        return Err(Degeneracy::Underdetermined { what }.into());
    }
    svd.solve(b, 0.0)
        .map_err(|reason| Degeneracy::SolveFailed { what, reason }.into())
}

/// Smallest eigenvalue of a symmetric matrix and its unit eigenvector
/// (the first of equal ones, in nalgebra's `symmetric_eigen` order): the
/// homogeneous least-squares solution `min ‖A·h‖, ‖h‖ = 1` of `M = AᵀA`, or
/// the axis of least inertia.
pub fn smallest_eigenpair<const D: usize>(m: SMatrix<f64, D, D>) -> (f64, SVector<f64, D>)
where
    Const<D>: DimSub<U1>,
    DefaultAllocator: Allocator<DimDiff<Const<D>, U1>>,
{
    let eig = m.symmetric_eigen();
    let (i, min) =
        eig.eigenvalues
            .iter()
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |(bi, bv), (i, &v)| if v < bv { (i, v) } else { (bi, bv) },
            );
    (min, eig.eigenvectors.column(i).into_owned())
}

/// Gauss–Newton steps at most, after Levenberg–Marquardt.
const POLISH_STEPS: usize = 5;
/// Relative rise of `Σr²` a Gauss–Newton step may cause (rounding of the
/// residuals makes the cost flat near the minimum; the gradient is not).
const POLISH_COST_SLACK: f64 = 1e-12;

/// Levenberg–Marquardt from `initial`, then up to [`POLISH_STEPS`] full
/// Gauss–Newton steps `δ = −J⁺r`, each kept while it shrinks the gradient
/// `‖Jᵀr‖` without raising `Σr²`: on an ill-conditioned fit (a short arc)
/// this takes the parameters from the solver's stopping point to the
/// stationary point, to machine precision.
pub(crate) fn least_squares<P: Residuals>(
    problem: &P,
    initial: DVector<f64>,
) -> Result<DVector<f64>> {
    let mut params = lm::minimize(problem, initial, &LmOptions::default())?.params;
    let state = |p: &DVector<f64>| {
        let r = problem.residuals(p);
        let j = problem.jacobian(p);
        let gradient = (j.transpose() * &r).norm();
        (r, j, gradient)
    };
    let (mut r, mut j, mut gradient) = state(&params);
    for _ in 0..POLISH_STEPS {
        let cost = r.norm_squared();
        let Ok(step) = solve_least_squares(j.clone(), &(-&r), "Gauss–Newton step") else {
            break;
        };
        let trial = &params + step;
        let (tr, tj, tg) = state(&trial);
        if !(tg < gradient && tr.norm_squared() <= cost * (1.0 + POLISH_COST_SLACK)) {
            break;
        }
        (params, r, j, gradient) = (trial, tr, tj, tg);
    }
    Ok(params)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smallest_eigenpair_of_a_rotated_diagonal() {
        let r = nalgebra::Rotation3::new(Vector3::new(0.3, -0.2, 0.5));
        let m = r.matrix()
            * Matrix3::from_diagonal(&Vector3::new(3.0, 0.5, 2.0))
            * r.matrix().transpose();
        let (min, v) = smallest_eigenpair(m);
        assert!((min - 0.5).abs() < 1e-12);
        assert!((v.dot(&(r * Vector3::y())).abs() - 1.0).abs() < 1e-12);
    }
}
