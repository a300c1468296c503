//! Cylinders: a searched start direction, then geometric least squares on the
//! distance to the axis with a minimal (5-parameter) axis parametrisation.

use nalgebra::{DMatrix, DVector, Matrix3, Point3, Vector2, Vector3};

use super::circle::kasa;
use super::{
    RANK_TOLERANCE, canonical_sign, centroid, least_squares, orthonormal_basis, principal_axes,
    validate,
};
use crate::lm::Residuals;
use crate::{Degeneracy, GeomError, Result};

/// Least-squares cylinder.
#[derive(Debug, Clone, PartialEq)]
pub struct CylinderFit {
    /// Point on the axis: the centroid of the points projected onto it.
    pub point: Point3<f64>,
    /// Unit axis direction.
    pub direction: Vector3<f64>,
    /// Radius.
    pub radius: f64,
    /// Diameter `2·radius`.
    pub diameter: f64,
    /// Radial residual `|(p − point) × direction| − radius` of each point.
    pub residuals: Vec<f64>,
}

/// Directions sampled on the half sphere when searching for a start axis.
const SEARCH_DIRECTIONS: usize = 400;
/// Best-scoring start directions refined by Levenberg–Marquardt.
const STARTS_REFINED: usize = 4;
/// Start directions closer than this (radians, sign-insensitive) count as one.
const DISTINCT_START_ANGLE: f64 = 0.2;

/// Residuals `dist(q, axis) − r` in a frame where the axis is near `z`:
/// parameters `(x0, y0, a, b, r)`, axis through `(x0, y0, 0)` along `(a, b, 1)`.
struct AxisDistances<'a> {
    points: &'a [Vector3<f64>],
}

impl AxisDistances<'_> {
    /// Perpendicular vector `e` from the axis to `q`, and `t = w·D/(D·D)`.
    fn offset(q: &Vector3<f64>, p: &DVector<f64>) -> (Vector3<f64>, f64) {
        let w = q - Vector3::new(p[0], p[1], 0.0);
        let d = Vector3::new(p[2], p[3], 1.0);
        let t = w.dot(&d) / d.norm_squared();
        (w - d * t, t)
    }
}

impl Residuals for AxisDistances<'_> {
    fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
        DVector::from_iterator(
            self.points.len(),
            self.points
                .iter()
                .map(|q| Self::offset(q, p).0.norm() - p[4]),
        )
    }

    fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
        let mut jac = DMatrix::zeros(self.points.len(), 5);
        for (i, q) in self.points.iter().enumerate() {
            let (e, t) = Self::offset(q, p);
            let dist = e.norm();
            // ∂dist/∂(x0, y0) = −e_xy/dist, ∂dist/∂(a, b) = −t·e_xy/dist; 0 on the axis.
            if dist > 0.0 {
                jac[(i, 0)] = -e.x / dist;
                jac[(i, 1)] = -e.y / dist;
                jac[(i, 2)] = -t * e.x / dist;
                jac[(i, 3)] = -t * e.y / dist;
            }
            jac[(i, 4)] = -1.0;
        }
        jac
    }
}

/// An axis and radius in coordinates centred at the centroid, with its cost.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    point: Vector3<f64>,
    direction: Vector3<f64>,
    radius: f64,
    cost: f64,
}

/// Frame `(u, v, d)` as the columns of a rotation, `d` its third axis.
fn frame(d: &Vector3<f64>) -> Matrix3<f64> {
    let (u, v) = orthonormal_basis(d);
    Matrix3::from_columns(&[u, v, *d])
}

/// Points expressed in `frame` (`Rᵀ·p`).
fn to_frame(points: &[Vector3<f64>], frame: &Matrix3<f64>) -> Vec<Vector3<f64>> {
    points.iter().map(|p| frame.transpose() * p).collect()
}

/// Algebraic circle of the points projected along `d`: an axis and radius,
/// scored by the sum of squared radial residuals.
fn circle_along(points: &[Vector3<f64>], d: &Vector3<f64>) -> Result<Candidate> {
    let f = frame(d);
    let flat: Vec<Vector2<f64>> = to_frame(points, &f).iter().map(|q| q.xy()).collect();
    let (c, radius) = kasa(&flat)?;
    Ok(Candidate {
        point: f * Vector3::new(c.x, c.y, 0.0),
        direction: *d,
        radius,
        cost: flat.iter().map(|q| ((q - c).norm() - radius).powi(2)).sum(),
    })
}

/// Levenberg–Marquardt on `dist − r` in the frame of the candidate's axis.
fn refine(points: &[Vector3<f64>], start: &Candidate) -> Result<Candidate> {
    let f = frame(&start.direction);
    let local = to_frame(points, &f);
    let p0 = f.transpose() * start.point;
    let problem = AxisDistances { points: &local };
    let p = least_squares(
        &problem,
        DVector::from_vec(vec![p0.x, p0.y, 0.0, 0.0, start.radius]),
    )?;
    Ok(Candidate {
        point: f * Vector3::new(p[0], p[1], 0.0),
        direction: f * Vector3::new(p[2], p[3], 1.0).normalize(),
        radius: p[4].abs(),
        cost: problem.residuals(&p).norm_squared(),
    })
}

/// Unit vectors spread evenly over the half sphere `z ≥ 0` (Fibonacci lattice).
fn half_sphere_directions(count: usize) -> impl Iterator<Item = Vector3<f64>> {
    let golden = std::f64::consts::PI * (3.0 - 5.0_f64.sqrt());
    (0..count).map(move |k| {
        let z = (k as f64 + 0.5) / count as f64;
        let rho = (1.0 - z * z).sqrt();
        let phi = golden * k as f64;
        Vector3::new(rho * phi.cos(), rho * phi.sin(), z)
    })
}

/// Least-squares cylinder: minimises `Σ(dist(p, axis) − r)²`.
///
/// Start: the point cloud's principal axes and a lattice of directions over
/// the half sphere, each scored by a circle fit of the points projected along
/// it; the best few are refined by Levenberg–Marquardt (axis through
/// `(x0, y0, 0)` along `(a, b, 1)` in the start's frame), then once more in
/// the frame of the solution; the lowest sum of squares wins.
pub fn cylinder(points: &[Point3<f64>]) -> Result<CylinderFit> {
    validate(points, "cylinder fit", 5)?;
    let origin = centroid(points);
    let (sigma, axes) = principal_axes(points, &origin)?;
    if sigma[1] <= RANK_TOLERANCE * sigma[0] {
        return Err(Degeneracy::CollinearOrCoincide {
            what: "cylinder fit",
        }
        .into());
    }
    let local: Vec<Vector3<f64>> = points.iter().map(|p| p - origin).collect();

    let mut starts: Vec<Candidate> = axes
        .column_iter()
        .map(|c| c.into_owned())
        .chain(half_sphere_directions(SEARCH_DIRECTIONS))
        .filter_map(|d| circle_along(&local, &d).ok())
        .collect();
    starts.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let mut distinct: Vec<Candidate> = Vec::with_capacity(STARTS_REFINED);
    for s in starts {
        let separate = distinct.iter().all(|d| {
            let cross = d.direction.cross(&s.direction).norm();
            cross.atan2(d.direction.dot(&s.direction).abs()) > DISTINCT_START_ANGLE
        });
        if separate {
            distinct.push(s);
            if distinct.len() == STARTS_REFINED {
                break;
            }
        }
    }

    let mut best: Option<Candidate> = None;
    let mut last_error = GeomError::Degenerate(Degeneracy::NoStartAxis);
    for start in &distinct {
        match refine(&local, start).and_then(|c| refine(&local, &c)) {
            Ok(c) if best.is_none_or(|b| c.cost < b.cost) => best = Some(c),
            Ok(_) => {}
            Err(e) => last_error = e,
        }
    }
    let best = best.ok_or(last_error)?;

    let direction = canonical_sign(best.direction);
    // Foot of the perpendicular from the centroid (the local origin) on the axis.
    let foot = best.point - direction * best.point.dot(&direction);
    let residuals = local
        .iter()
        .map(|q| (q - foot).cross(&direction).norm() - best.radius)
        .collect();
    Ok(CylinderFit {
        point: origin + foot,
        direction,
        radius: best.radius,
        diameter: 2.0 * best.radius,
        residuals,
    })
}

#[cfg(test)]
mod tests {
    use std::f64::consts::TAU;

    use proptest::prelude::*;

    use super::*;

    /// Points on a cylinder: `turns` of a helix-like pattern over `length`,
    /// covering the angle span `arc` (radians).
    fn cylinder_points(
        point: Point3<f64>,
        axis: Vector3<f64>,
        radius: f64,
        length: f64,
        arc: f64,
        n: usize,
    ) -> Vec<Point3<f64>> {
        let d = axis.normalize();
        let (u, v) = orthonormal_basis(&d);
        (0..n)
            .map(|k| {
                let t = arc * (k as f64 * 0.618_034).fract();
                let s = length * ((k as f64 * 0.414_214).fract() - 0.5);
                point + d * s + (u * t.cos() + v * t.sin()) * radius
            })
            .collect()
    }

    #[test]
    fn axis_jacobian_is_analytic() {
        let points: Vec<_> = (0..9)
            .map(|k| {
                let t = k as f64;
                Vector3::new(t.cos() * 3.0, (1.3 * t).sin() * 2.0, t * 0.4 - 1.0)
            })
            .collect();
        let problem = AxisDistances { points: &points };
        let at = DVector::from_vec(vec![0.3, -0.2, 0.1, -0.05, 2.5]);
        assert!(crate::lm::jacobian_error(&problem, &at) < 1e-7);
    }

    #[test]
    fn cylinder_recovers_shapes_of_every_proportion() {
        let cases = [
            // long bar, full turn
            (Vector3::new(0.2, 0.1, 1.0), 5.0, 200.0, TAU),
            // short wide bore, full turn
            (Vector3::new(1.0, -0.3, 0.2), 80.0, 10.0, TAU),
            // quarter-turn patch
            (Vector3::new(-0.4, 1.0, 0.5), 30.0, 40.0, TAU / 4.0),
            // equal length and diameter, half turn
            (Vector3::new(0.0, 0.0, 1.0), 25.0, 50.0, TAU / 2.0),
        ];
        for (axis, radius, length, arc) in cases {
            let c = Point3::new(150.0, -80.0, 320.0);
            let pts = cylinder_points(c, axis, radius, length, arc, 40);
            let fit = cylinder(&pts).unwrap();
            let d = axis.normalize();
            assert!(
                fit.direction.cross(&d).norm() < 1e-10,
                "{axis:?}: {:?}",
                fit.direction
            );
            assert!(
                (fit.radius - radius).abs() < 1e-9,
                "{axis:?}: r = {}",
                fit.radius
            );
            assert!((fit.point - c).cross(&d).norm() < 1e-9);
            assert!(fit.residuals.iter().all(|r| r.abs() < 1e-9));
        }
    }

    #[test]
    fn cylinder_point_is_the_projected_centroid() {
        let pts = cylinder_points(
            Point3::origin(),
            Vector3::new(1.0, 1.0, 1.0),
            10.0,
            30.0,
            TAU,
            25,
        );
        let fit = cylinder(&pts).unwrap();
        let c = centroid(&pts);
        assert!((c - fit.point).dot(&fit.direction).abs() < 1e-10);
    }

    #[test]
    fn degenerate_cylinders_are_errors() {
        let line: Vec<_> = (0..8).map(|k| Point3::new(k as f64, 1.0, 2.0)).collect();
        assert!(matches!(cylinder(&line), Err(GeomError::Degenerate(_))));
        assert!(matches!(
            cylinder(&line[..4]),
            Err(GeomError::TooFewPoints { .. })
        ));
        let mut bad = cylinder_points(Point3::origin(), Vector3::z(), 1.0, 2.0, TAU, 10);
        bad[2].z = f64::NAN;
        assert!(matches!(cylinder(&bad), Err(GeomError::NonFinite(_))));
    }

    /// `Σ(dist − r)²` of the points about a cylinder.
    fn cost(pts: &[Point3<f64>], point: &Point3<f64>, axis: &Vector3<f64>, radius: f64) -> f64 {
        let d = axis.normalize();
        pts.iter()
            .map(|p| ((p - point).cross(&d).norm() - radius).powi(2))
            .sum()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Any orientation and proportion, down to a 30° patch: exact data are
        /// recovered, and with 10 µm of noise the fit is no worse than the truth.
        #[test]
        fn cylinder_needs_no_tuning(
            axis in (-1.0..1.0_f64, -1.0..1.0_f64, -1.0..1.0_f64)
                .prop_filter("a direction", |(x, y, z)| x * x + y * y + z * z > 0.01),
            centre in (-500.0..500.0_f64, -500.0..500.0_f64, -500.0..500.0_f64),
            radius in 2.0..100.0_f64,
            length in 5.0..300.0_f64,
            arc in 0.5..TAU,
            n in 12..60_usize,
            noise_seed in 0..1000_u32,
        ) {
            let axis = Vector3::new(axis.0, axis.1, axis.2).normalize();
            let c = Point3::new(centre.0, centre.1, centre.2);
            let pts = cylinder_points(c, axis, radius, length, arc, n);
            let fit = cylinder(&pts).unwrap();
            prop_assert!(fit.direction.cross(&axis).norm() < 1e-7, "{:?}", fit.direction);
            prop_assert!((fit.radius - radius).abs() < 1e-7 * radius, "r = {}", fit.radius);
            prop_assert!((fit.point - c).cross(&axis).norm() < 1e-7 * radius);

            let noisy: Vec<_> = pts
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    let e = ((k as f64 + 1.0) * (noise_seed as f64 + 0.5) * 12.9898).sin() * 1e-2;
                    p + (p - c).cross(&axis).cross(&axis).normalize() * e
                })
                .collect();
            let fit = cylinder(&noisy).unwrap();
            let truth = cost(&noisy, &c, &axis, radius);
            let found = cost(&noisy, &fit.point, &fit.direction, fit.radius);
            prop_assert!(found <= truth * (1.0 + 1e-9), "{found} > {truth}");
        }
    }
}
