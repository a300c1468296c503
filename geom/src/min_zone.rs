//! Minimum-zone (Chebyshev) straightness and flatness, computed exactly.
//!
//! - [`straightness`]: the narrowest pair of parallel lines enclosing the
//!   points, orthogonal width (ISO 12780-1 minimum zone), from the convex
//!   hull by rotating calipers.
//! - [`straightness_vertical`]: Chebyshev fit of `y = kx + b`,
//!   `min over (k, b) of max − min of y − kx − b`; the optimal slope is that of
//!   a hull edge.
//! - [`flatness`]: Chebyshev fit of `z = ax + by + c`, `min over (a, b, c) of
//!   max − min of z − ax − by − c`; a linear programme on centred and scaled
//!   coordinates gives the optimal vertex, which is then recomputed exactly
//!   from its contact points. For the small slopes of a machine table this is
//!   the ISO 12781 minimum zone to within a factor `1/√(1 + a² + b²)`.
//!
//! Each zone is described by its centre line or plane, its width and the
//! residuals of every point about the centre (all within `±width/2`).

use microlp::{ComparisonOp, OptimizationDirection, Problem};
use nalgebra::{Point2, Point3, Vector2, Vector3};

use crate::fit::{self, canonical_sign, centroid, validate};
use crate::{Degeneracy, GeomError, Result};

/// A point touches a zone boundary when it lies within this fraction of the
/// data's extent of it.
const CONTACT_TOLERANCE: f64 = 1e-9;
/// Points whose residual lies within this fraction of the width of an
/// extreme are contact candidates when the LP vertex is recomputed exactly.
const POLISH_BAND: f64 = 1e-2;
/// At most this many candidates per boundary enter the exact recomputation.
const POLISH_CANDIDATES: usize = 10;
/// Rounds of exact recomputation after the LP, at most.
const POLISH_ROUNDS: usize = 4;
/// Scaled LP coefficients smaller than this are set to zero, keeping every
/// row within the solver's recommended range (the exact recomputation
/// removes the effect).
const LP_COEFFICIENT_FLOOR: f64 = 1e-6;

/// Minimum zone of straightness: two parallel lines `width` apart.
#[derive(Debug, Clone, PartialEq)]
pub struct Zone2 {
    /// Orthogonal distance between the two lines.
    pub width: f64,
    /// Point on the centre line (the centroid projected onto it).
    pub point: Point2<f64>,
    /// Unit direction of the lines.
    pub direction: Vector2<f64>,
    /// Unit normal `(−d_y, d_x)`: the direction of positive residuals.
    pub normal: Vector2<f64>,
    /// Signed distance `(p − point)·normal` of each point from the centre line.
    pub residuals: Vec<f64>,
    /// Indices of the points on either line, ascending.
    pub contacts: Vec<usize>,
}

/// Chebyshev line `y = k·x + b ± width/2`.
#[derive(Debug, Clone, PartialEq)]
pub struct SlopeZone {
    /// Vertical distance between the two lines.
    pub width: f64,
    /// Slope of the lines.
    pub k: f64,
    /// Intercept of the centre line.
    pub b: f64,
    /// Vertical residual `y − (k·x + b)` of each point.
    pub residuals: Vec<f64>,
    /// Indices of the points on either line, ascending.
    pub contacts: Vec<usize>,
}

/// Chebyshev plane `z = a·x + b·y + c ± width/2`.
#[derive(Debug, Clone, PartialEq)]
pub struct Zone3 {
    /// Vertical distance between the two planes.
    pub width: f64,
    /// Slope `∂z/∂x` of the planes.
    pub a: f64,
    /// Slope `∂z/∂y` of the planes.
    pub b: f64,
    /// Height of the centre plane at `x = y = 0`.
    pub c: f64,
    /// Vertical residual `z − (a·x + b·y + c)` of each point.
    pub residuals: Vec<f64>,
    /// Indices of the points on either plane, ascending.
    pub contacts: Vec<usize>,
}

/// `(a − o) × (b − o)`, positive when `o → a → b` turns counter-clockwise.
fn turn(o: &Vector2<f64>, a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    (a - o).perp(&(b - o))
}

/// Convex hull by Andrew's monotone chain: indices of the vertices in
/// counter-clockwise order, collinear points left out. Collinear input gives
/// its two end points.
fn convex_hull(points: &[Vector2<f64>]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&i, &j| {
        points[i]
            .x
            .total_cmp(&points[j].x)
            .then(points[i].y.total_cmp(&points[j].y))
    });
    let mut hull: Vec<usize> = Vec::with_capacity(2 * points.len());
    for pass in [order.clone(), order.into_iter().rev().collect()] {
        let start = hull.len();
        for i in pass {
            while hull.len() >= start + 2
                && turn(
                    &points[hull[hull.len() - 2]],
                    &points[hull[hull.len() - 1]],
                    &points[i],
                ) <= 0.0
            {
                hull.pop();
            }
            hull.push(i);
        }
        // The last point of each chain starts the other.
        hull.pop();
    }
    hull
}

/// Largest distance `|p|` of the points from the origin (the data extent
/// about the centroid); fails when all points coincide.
fn extent<const D: usize>(local: &[nalgebra::SVector<f64, D>], what: &'static str) -> Result<f64> {
    let e = local.iter().map(|q| q.norm()).fold(0.0, f64::max);
    if e > 0.0 {
        Ok(e)
    } else {
        Err(Degeneracy::Coincide { what }.into())
    }
}

/// Smallest and largest of the values (`(+∞, −∞)` when empty).
fn min_max(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    })
}

/// Indices of residuals within `tolerance` of `±width/2`, ascending.
fn contacts(residuals: &[f64], width: f64, tolerance: f64) -> Vec<usize> {
    residuals
        .iter()
        .enumerate()
        .filter(|(_, r)| (r.abs() - width / 2.0).abs() <= tolerance)
        .map(|(i, _)| i)
        .collect()
}

/// Minimum-zone straightness (ISO 12780-1): the narrowest pair of parallel
/// lines enclosing the points, `min over hull edges of max distance from the
/// edge's line`, by rotating calipers over the convex hull.
pub fn straightness(points: &[Point2<f64>]) -> Result<Zone2> {
    const WHAT: &str = "minimum-zone straightness";
    validate(points, WHAT, 2)?;
    let origin = centroid(points);
    let local: Vec<Vector2<f64>> = points.iter().map(|p| p - origin).collect();
    let scale = extent(&local, WHAT)?;
    let hull = convex_hull(&local);
    let h = hull.len();
    let vertex = |k: usize| local[hull[k % h]];

    let mut edge = vertex(1) - vertex(0);
    if h >= 3 {
        // Height of vertex j above the line of edge i (times the edge length).
        let height =
            |i: usize, j: usize| (vertex(i + 1) - vertex(i)).perp(&(vertex(j) - vertex(i)));
        let mut j = (0..h)
            .max_by(|&a, &b| height(0, a).total_cmp(&height(0, b)))
            .unwrap_or(0);
        let mut best = f64::INFINITY;
        for i in 0..h {
            let mut steps = 0;
            while steps < h && height(i, j + 1) > height(i, j) {
                j = (j + 1) % h;
                steps += 1;
            }
            let e = vertex(i + 1) - vertex(i);
            let width = height(i, j) / e.norm();
            if width < best {
                best = width;
                edge = e;
            }
        }
    }
    let direction = canonical_sign(edge.normalize());
    let normal = Vector2::new(-direction.y, direction.x);
    let (lo, hi) = min_max(local.iter().map(|q| q.dot(&normal)));
    let mid = (lo + hi) / 2.0;
    let residuals: Vec<f64> = local.iter().map(|q| q.dot(&normal) - mid).collect();
    let width = hi - lo;
    Ok(Zone2 {
        width,
        point: origin + normal * mid,
        direction,
        normal,
        contacts: contacts(&residuals, width, CONTACT_TOLERANCE * scale),
        residuals,
    })
}

/// Chebyshev line `y = kx + b`: `min over k of max − min of y − kx`, exact at
/// the slope of a hull edge, found by bisection on the convex width over the
/// sorted edge slopes.
pub fn straightness_vertical(points: &[Point2<f64>]) -> Result<SlopeZone> {
    const WHAT: &str = "Chebyshev line y = kx + b";
    validate(points, WHAT, 2)?;
    let origin = centroid(points);
    let local: Vec<Vector2<f64>> = points.iter().map(|p| p - origin).collect();
    let scale = extent(&local, WHAT)?;
    let hull = convex_hull(&local);
    let h = hull.len();
    let mut slopes: Vec<f64> = (0..h)
        .filter_map(|i| {
            let e = local[hull[(i + 1) % h]] - local[hull[i]];
            (e.x != 0.0).then(|| e.y / e.x)
        })
        .collect();
    if slopes.is_empty() {
        return Err(Degeneracy::SameX { what: WHAT }.into());
    }
    slopes.sort_by(f64::total_cmp);
    slopes.dedup();
    let width = |k: f64| {
        let (lo, hi) = min_max(hull.iter().map(|&i| local[i].y - k * local[i].x));
        hi - lo
    };
    // The width is convex in k and linear between consecutive edge slopes.
    let (mut lo, mut hi) = (0, slopes.len() - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if width(slopes[mid]) <= width(slopes[mid + 1]) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    let k = slopes[lo];
    let (rmin, rmax) = min_max(local.iter().map(|q| q.y - k * q.x));
    let mid = (rmin + rmax) / 2.0;
    let residuals: Vec<f64> = local.iter().map(|q| q.y - k * q.x - mid).collect();
    let width = rmax - rmin;
    Ok(SlopeZone {
        width,
        k,
        b: origin.y + mid - k * origin.x,
        contacts: contacts(&residuals, width, CONTACT_TOLERANCE * scale),
        residuals,
    })
}

/// Vertical range `(min, max)` of `z − a·x − b·y` over the points.
fn height_range(local: &[Vector3<f64>], a: f64, b: f64) -> (f64, f64) {
    min_max(local.iter().map(|q| q.z - a * q.x - b * q.y))
}

/// Slopes `(a, b)` of the plane containing the directions `d1` and `d2`
/// (`a·dx + b·dy = dz` for both); `None` when they span a vertical plane.
fn slopes_through(d1: &Vector3<f64>, d2: &Vector3<f64>) -> Option<(f64, f64)> {
    let det = d1.x * d2.y - d1.y * d2.x;
    let size = d1.xy().norm() * d2.xy().norm();
    if det.abs() <= fit::RANK_TOLERANCE * size {
        return None;
    }
    Some((
        (d1.z * d2.y - d2.z * d1.y) / det,
        (d1.x * d2.z - d2.x * d1.z) / det,
    ))
}

/// Indices of the points whose residual lies within `band` of the extreme
/// `bound` (`upper`: the maximum, else the minimum), closest first, at most
/// [`POLISH_CANDIDATES`].
fn near_extreme(residuals: &[f64], bound: f64, band: f64, upper: bool) -> Vec<usize> {
    let gap = |r: f64| if upper { bound - r } else { r - bound };
    let mut near: Vec<usize> = (0..residuals.len())
        .filter(|&i| gap(residuals[i]) <= band)
        .collect();
    near.sort_by(|&i, &j| gap(residuals[i]).total_cmp(&gap(residuals[j])));
    near.truncate(POLISH_CANDIDATES);
    near
}

/// The exact Chebyshev vertex near `(a, b)`: every plane through three
/// near-extreme points of one side (with one of the other), and every plane
/// parallel to a pair on each side, evaluated on all points; the narrowest
/// (including `(a, b)` itself) wins.
fn polish(local: &[Vector3<f64>], a: f64, b: f64) -> (f64, f64) {
    let (lo, hi) = height_range(local, a, b);
    let mut best = (hi - lo, a, b);
    let residuals: Vec<f64> = local.iter().map(|q| q.z - a * q.x - b * q.y).collect();
    let band = POLISH_BAND * (hi - lo);
    let upper = near_extreme(&residuals, hi, band, true);
    let lower = near_extreme(&residuals, lo, band, false);
    let mut consider = |d1: Vector3<f64>, d2: Vector3<f64>| {
        if let Some((a, b)) = slopes_through(&d1, &d2) {
            let (lo, hi) = height_range(local, a, b);
            if hi - lo < best.0 {
                best = (hi - lo, a, b);
            }
        }
    };
    // Three on one side: the plane through them.
    for side in [&upper, &lower] {
        for (n, &i) in side.iter().enumerate() {
            for (m, &j) in side.iter().enumerate().skip(n + 1) {
                for &k in side.iter().skip(m + 1) {
                    consider(local[j] - local[i], local[k] - local[i]);
                }
            }
        }
    }
    // Two on each side: the plane parallel to both pairs.
    for (n, &i) in upper.iter().enumerate() {
        for &j in upper.iter().skip(n + 1) {
            for (m, &k) in lower.iter().enumerate() {
                for &l in lower.iter().skip(m + 1) {
                    consider(local[j] - local[i], local[l] - local[k]);
                }
            }
        }
    }
    (best.1, best.2)
}

/// [`polish`] repeated until it stops moving, at most [`POLISH_ROUNDS`] times.
fn exact_vertex(local: &[Vector3<f64>], mut a: f64, mut b: f64) -> (f64, f64) {
    for _ in 0..POLISH_ROUNDS {
        let next = polish(local, a, b);
        if next == (a, b) {
            break;
        }
        (a, b) = next;
    }
    (a, b)
}

/// Chebyshev slopes by linear programming, on residuals `r` from the
/// least-squares plane with `x, y` scaled by `s_xy` and `r` by its range
/// `s_r`: minimise `h` subject to `|r_i − δa·x_i − δb·y_i − δc| ≤ h`.
/// Returns the corrections `(δa, δb)` in the original units.
fn chebyshev_lp(
    local: &[Vector3<f64>],
    residuals: &[f64],
    s_xy: f64,
    s_r: f64,
) -> Result<(f64, f64)> {
    let mut lp = Problem::new(OptimizationDirection::Minimize);
    let free = (f64::NEG_INFINITY, f64::INFINITY);
    let da = lp.add_var(0.0, free);
    let db = lp.add_var(0.0, free);
    let dc = lp.add_var(0.0, free);
    let h = lp.add_var(1.0, (0.0, f64::INFINITY));
    let coefficient = |v: f64| {
        let scaled = v / s_xy;
        if scaled.abs() < LP_COEFFICIENT_FLOOR {
            0.0
        } else {
            scaled
        }
    };
    for (q, r) in local.iter().zip(residuals) {
        let row: Vec<_> = [(da, coefficient(q.x)), (db, coefficient(q.y)), (dc, 1.0)]
            .into_iter()
            .filter(|(_, c)| *c != 0.0)
            .collect();
        let rhs = r / s_r;
        let mut above = row.clone();
        above.push((h, 1.0));
        lp.add_constraint(above, ComparisonOp::Ge, rhs);
        let mut below = row;
        below.push((h, -1.0));
        lp.add_constraint(below, ComparisonOp::Le, rhs);
    }
    let solution = lp
        .solve()
        .map_err(|e| GeomError::Degenerate(Degeneracy::LpFailed(e)))?;
    let solution = solution
        .into_solution()
        .map_err(|_| GeomError::Degenerate(Degeneracy::LpInterrupted))?;
    let to_slope = s_r / s_xy;
    Ok((
        solution.var_value(da) * to_slope,
        solution.var_value(db) * to_slope,
    ))
}

/// Chebyshev (minimum-zone, vertical) flatness: `min over (a, b, c) of
/// max − min of z − ax − by − c`, by linear programming from the
/// least-squares plane, the optimal vertex then recomputed exactly.
pub fn flatness(points: &[Point3<f64>]) -> Result<Zone3> {
    const WHAT: &str = "minimum-zone flatness";
    validate(points, WHAT, 3)?;
    let ls = fit::plane_z_on_xy(points)?;
    let origin = centroid(points);
    let local: Vec<Vector3<f64>> = points.iter().map(|p| p - origin).collect();
    let scale = extent(&local, WHAT)?;
    let (rmin, rmax) = min_max(ls.residuals.iter().copied());
    let (mut a, mut b) = (ls.a, ls.b);
    if rmax > rmin {
        let s_xy = local
            .iter()
            .map(|q| q.x.abs().max(q.y.abs()))
            .fold(0.0, f64::max);
        let (da, db) = chebyshev_lp(&local, &ls.residuals, s_xy, rmax - rmin)?;
        let (pa, pb) = exact_vertex(&local, a + da, b + db);
        let width = |(a, b): (f64, f64)| {
            let (lo, hi) = height_range(&local, a, b);
            hi - lo
        };
        // Never wider than the least-squares plane, whatever the LP did.
        if width((pa, pb)) <= width((a, b)) {
            (a, b) = (pa, pb);
        }
    }
    let (lo, hi) = height_range(&local, a, b);
    let mid = (lo + hi) / 2.0;
    let residuals: Vec<f64> = local
        .iter()
        .map(|q| q.z - a * q.x - b * q.y - mid)
        .collect();
    let width = hi - lo;
    Ok(Zone3 {
        width,
        a,
        b,
        c: origin.z + mid - a * origin.x - b * origin.y,
        contacts: contacts(&residuals, width, CONTACT_TOLERANCE * scale),
        residuals,
    })
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// Agreement required between the exact zone and an exhaustive search (mm).
    const EXHAUSTIVE_TOLERANCE: f64 = 1e-9;

    /// `max − min` of the values.
    fn spread(values: impl Iterator<Item = f64>) -> f64 {
        let (lo, hi) = min_max(values);
        hi - lo
    }

    /// Exhaustive orthogonal zone: every line through two points.
    fn straightness_exhaustive(points: &[Point2<f64>]) -> f64 {
        let mut best = f64::INFINITY;
        for (i, p) in points.iter().enumerate() {
            for q in &points[i + 1..] {
                let d = q - p;
                if d.norm() > 0.0 {
                    let n = Vector2::new(-d.y, d.x).normalize();
                    best = best.min(spread(points.iter().map(|r| (r - p).dot(&n))));
                }
            }
        }
        best
    }

    /// Exhaustive vertical zone: every slope through two points.
    fn vertical_exhaustive(points: &[Point2<f64>]) -> f64 {
        let mut best = f64::INFINITY;
        for (i, p) in points.iter().enumerate() {
            for q in &points[i + 1..] {
                if q.x != p.x {
                    let k = (q.y - p.y) / (q.x - p.x);
                    best = best.min(spread(points.iter().map(|r| (r.y - p.y) - k * (r.x - p.x))));
                }
            }
        }
        best
    }

    /// Exhaustive vertical flatness: every plane through three points and every
    /// plane parallel to the lines through two disjoint pairs.
    fn flatness_exhaustive(points: &[Point3<f64>]) -> f64 {
        let n = points.len();
        let width = |d1: Vector3<f64>, d2: Vector3<f64>| {
            let det = d1.x * d2.y - d1.y * d2.x;
            if det == 0.0 {
                return f64::INFINITY;
            }
            let a = (d1.z * d2.y - d2.z * d1.y) / det;
            let b = (d1.x * d2.z - d2.x * d1.z) / det;
            let o = points[0];
            spread(
                points
                    .iter()
                    .map(|p| (p.z - o.z) - a * (p.x - o.x) - b * (p.y - o.y)),
            )
        };
        let mut best = f64::INFINITY;
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    for l in 0..n {
                        let distinct = i < j && k < l && [i, j].iter().all(|x| ![k, l].contains(x));
                        if distinct {
                            best = best.min(width(points[j] - points[i], points[l] - points[k]));
                        }
                        if i < j && j < k && l == 0 {
                            best = best.min(width(points[j] - points[i], points[k] - points[i]));
                        }
                    }
                }
            }
        }
        best
    }

    fn assert_residuals_in_zone(residuals: &[f64], width: f64, contacts: &[usize]) {
        let slack = 1e-12 * (1.0 + width);
        assert!(residuals.iter().all(|r| r.abs() <= width / 2.0 + slack));
        assert!(
            contacts.len() >= 2.min(residuals.len()),
            "contacts {contacts:?}"
        );
    }

    /// A zone of the exhaustive optimum's width, every residual within it.
    fn is_optimum(
        width: f64,
        exhaustive: f64,
        residuals: &[f64],
        contacts: &[usize],
    ) -> std::result::Result<(), TestCaseError> {
        prop_assert!(
            (width - exhaustive).abs() <= EXHAUSTIVE_TOLERANCE,
            "{width} vs {exhaustive}"
        );
        assert_residuals_in_zone(residuals, width, contacts);
        Ok(())
    }

    #[test]
    fn straightness_of_a_triangle_is_its_least_altitude() {
        let pts = [
            Point2::new(0.0, 0.0),
            Point2::new(2.0, 0.0),
            Point2::new(1.0, 1.0),
        ];
        let zone = straightness(&pts).unwrap();
        assert!((zone.width - 1.0).abs() < 1e-15);
        assert!((zone.direction - Vector2::x()).norm() < 1e-15);
        assert_eq!(zone.contacts, vec![0, 1, 2]);
        assert!((zone.point.y - 0.5).abs() < 1e-15);
    }

    #[test]
    fn straightness_of_collinear_points_is_zero() {
        let pts: Vec<_> = (0..6)
            .map(|k| Point2::new(k as f64, 0.5 * k as f64 + 1.0))
            .collect();
        let zone = straightness(&pts).unwrap();
        assert!(zone.width.abs() < 1e-14);
        assert!((zone.direction - Vector2::new(2.0, 1.0).normalize()).norm() < 1e-15);
        let vertical = straightness_vertical(&pts).unwrap();
        assert!(vertical.width.abs() < 1e-14 && (vertical.k - 0.5).abs() < 1e-15);
        assert!((vertical.b - 1.0).abs() < 1e-14);
    }

    #[test]
    fn vertical_straightness_of_a_tent() {
        let pts = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 1.0),
            Point2::new(2.0, 0.0),
        ];
        let zone = straightness_vertical(&pts).unwrap();
        assert_eq!((zone.width, zone.k, zone.b), (1.0, 0.0, 0.5));
        assert_eq!(zone.residuals, vec![-0.5, 0.5, -0.5]);
    }

    #[test]
    fn flatness_of_a_twisted_square() {
        // z = xy on the unit square: the Chebyshev plane is z = x/2 + y/2 − 1/4.
        let pts = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(1.0, 1.0, 1.0),
        ];
        let zone = flatness(&pts).unwrap();
        assert!((zone.width - 0.5).abs() < 1e-15);
        assert!((zone.a - 0.5).abs() < 1e-15 && (zone.b - 0.5).abs() < 1e-15);
        assert!((zone.c + 0.25).abs() < 1e-15);
        assert_eq!(zone.contacts, vec![0, 1, 2, 3]);
        // Three points always lie in one plane.
        assert!(flatness(&pts[1..]).unwrap().width.abs() < 1e-15);
    }

    /// A machine table: 15 × 15 grid over ±100 mm, 512 mm high, tilted by
    /// 2 mm/m and 0.7 mm/m, with a few micrometres of waviness.
    fn table() -> Vec<Point3<f64>> {
        let mut pts = Vec::new();
        for i in 0..15 {
            for j in 0..15 {
                let (x, y) = (
                    i as f64 * 200.0 / 14.0 - 100.0,
                    j as f64 * 200.0 / 14.0 - 100.0,
                );
                let wave =
                    2e-3 * (x / 37.0).sin() * (y / 53.0).cos() + 1e-3 * ((x * y) / 900.0).sin();
                pts.push(Point3::new(x, y, 512.0 + 2e-3 * x - 7e-4 * y + wave));
            }
        }
        pts
    }

    #[test]
    fn flatness_of_a_table_is_a_global_minimum() {
        let pts = table();
        let zone = flatness(&pts).unwrap();
        let ls = fit::plane_z_on_xy(&pts).unwrap();
        let ls_width = spread(ls.residuals.iter().copied());
        assert!(zone.width <= ls_width, "{} > {ls_width}", zone.width);
        assert_residuals_in_zone(&zone.residuals, zone.width, &zone.contacts);
        assert!(zone.contacts.len() >= 4, "{:?}", zone.contacts);
        // A convex function with no descent direction is at its global minimum.
        let width = |a: f64, b: f64| spread(pts.iter().map(|p| p.z - a * p.x - b * p.y));
        assert!((width(zone.a, zone.b) - zone.width).abs() < 1e-12);
        for step in [1e-6, 1e-8, 1e-10] {
            for k in 0..64 {
                let t = k as f64 * std::f64::consts::TAU / 64.0;
                let w = width(zone.a + step * t.cos(), zone.b + step * t.sin());
                assert!(
                    w >= zone.width - 1e-13,
                    "descent {t} at step {step}: {w} < {}",
                    zone.width
                );
            }
        }
    }

    #[test]
    fn degenerate_zones_are_errors() {
        let p = Point2::new(1.0, 1.0);
        assert!(matches!(
            straightness(&[p]),
            Err(GeomError::TooFewPoints { .. })
        ));
        assert!(matches!(
            straightness(&[p, p, p]),
            Err(GeomError::Degenerate(_))
        ));
        assert!(matches!(
            straightness(&[p, Point2::new(f64::NAN, 0.0)]),
            Err(GeomError::NonFinite(_))
        ));
        let column = [p, Point2::new(1.0, 3.0), Point2::new(1.0, -2.0)];
        assert!(straightness(&column).is_ok());
        assert!(matches!(
            straightness_vertical(&column),
            Err(GeomError::Degenerate(_))
        ));
        let line: Vec<_> = (0..5)
            .map(|k| Point3::new(k as f64, 2.0 * k as f64, 1.0))
            .collect();
        assert!(matches!(flatness(&line), Err(GeomError::Degenerate(_))));
        assert!(matches!(
            flatness(&line[..2]),
            Err(GeomError::TooFewPoints { .. })
        ));
        let mut bad = table();
        bad[7].z = f64::INFINITY;
        assert!(matches!(flatness(&bad), Err(GeomError::NonFinite(_))));
        // Values whose squares overflow give an error, not a zone of width 0.
        let absurd = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 1e300),
            Point2::new(2.0, 0.0),
        ];
        assert!(matches!(
            straightness(&absurd),
            Err(GeomError::OutOfRange { value, .. }) if value == 1e300
        ));
        bad[7].z = -1e200;
        assert!(matches!(flatness(&bad), Err(GeomError::OutOfRange { .. })));
    }

    /// Points along a 150 mm axis with micrometre deviations and a small tilt.
    fn axis_points(n: std::ops::Range<usize>) -> impl Strategy<Value = Vec<Point2<f64>>> {
        (
            -1e-3..1e-3_f64,
            prop::collection::vec((0.0..150.0_f64, -5e-3..5e-3_f64), n),
        )
            .prop_map(|(tilt, v)| {
                v.into_iter()
                    .map(|(x, e)| Point2::new(x, 20.0 + tilt * x + e))
                    .collect()
            })
    }

    /// Points scattered over a 200 mm square, any shape.
    fn scattered(n: std::ops::Range<usize>) -> impl Strategy<Value = Vec<Point2<f64>>> {
        prop::collection::vec((-100.0..100.0_f64, -100.0..100.0_f64), n)
            .prop_map(|v| v.into_iter().map(|(x, y)| Point2::new(x, y)).collect())
    }

    /// Table points: ±100 mm, an arbitrary height and tilt, µm deviations.
    fn surface(n: std::ops::Range<usize>) -> impl Strategy<Value = Vec<Point3<f64>>> {
        (
            -500.0..500.0_f64,
            -2e-3..2e-3_f64,
            -2e-3..2e-3_f64,
            prop::collection::vec((-100.0..100.0_f64, -100.0..100.0_f64, -5e-3..5e-3_f64), n),
        )
            .prop_map(|(z0, a, b, v)| {
                v.into_iter()
                    .map(|(x, y, e)| Point3::new(x, y, z0 + a * x + b * y + e))
                    .collect()
            })
    }

    proptest! {
        #[test]
        fn straightness_is_exhaustive_optimum(pts in axis_points(2..9), other in scattered(3..9)) {
            for set in [&pts, &other] {
                let zone = straightness(set).unwrap();
                is_optimum(zone.width, straightness_exhaustive(set), &zone.residuals, &zone.contacts)?;
            }
        }

        #[test]
        fn vertical_straightness_is_exhaustive_optimum(pts in axis_points(2..9), other in scattered(3..9)) {
            for set in [&pts, &other] {
                let zone = straightness_vertical(set).unwrap();
                is_optimum(zone.width, vertical_exhaustive(set), &zone.residuals, &zone.contacts)?;
            }
        }

        #[test]
        fn flatness_is_exhaustive_optimum(pts in surface(4..9), off in (-1.0..1.0_f64, -1.0..1.0_f64)) {
            let zone = flatness(&pts).unwrap();
            let exhaustive = flatness_exhaustive(&pts);
            is_optimum(zone.width, exhaustive, &zone.residuals, &zone.contacts)?;
            // The exact recomputation alone finds the vertex from a start off
            // by 1e-4 of the width across the data (far more than the LP's error).
            let local: Vec<Vector3<f64>> = pts.iter().map(|p| p.coords).collect();
            let slope_error = 1e-4 * exhaustive / 100.0;
            let (a, b) = exact_vertex(&local, zone.a + off.0 * slope_error, zone.b + off.1 * slope_error);
            let (lo, hi) = height_range(&local, a, b);
            prop_assert!((hi - lo - exhaustive).abs() <= EXHAUSTIVE_TOLERANCE,
                "polished {} vs {}", hi - lo, exhaustive);
        }

        #[test]
        fn min_zone_is_no_wider_than_least_squares(line in axis_points(3..300), table in surface(4..300)) {
            let zone = straightness(&line).unwrap();
            let ls = spread(fit::line_2d(&line).unwrap().residuals.into_iter());
            prop_assert!(zone.width <= ls, "straightness {} > {}", zone.width, ls);
            let zone = straightness_vertical(&line).unwrap();
            let ls = spread(fit::line_y_on_x(&line).unwrap().residuals.into_iter());
            prop_assert!(zone.width <= ls, "vertical straightness {} > {}", zone.width, ls);
            let zone = flatness(&table).unwrap();
            let ls = spread(fit::plane_z_on_xy(&table).unwrap().residuals.into_iter());
            prop_assert!(zone.width <= ls, "flatness {} > {}", zone.width, ls);
            assert_residuals_in_zone(&zone.residuals, zone.width, &zone.contacts);
        }
    }
}
