//! Interpolation: piecewise linear (optionally periodic, for angles) and
//! trilinear on a regular 3-D grid.

use std::ops::{Add, Mul};

use nalgebra::{Point3, Vector3};

use crate::{Degeneracy, GeomError, Result};

fn check_knots(knots: &[f64], values: usize) -> Result<()> {
    if knots.len() != values {
        return Err(Degeneracy::LengthsDiffer {
            what: None,
            first: knots.len(),
            first_items: "knots",
            second: values,
            second_items: "values",
        }
        .into());
    }
    if knots.is_empty() {
        return Err(GeomError::TooFewPoints {
            what: "interpolation",
            needed: 1,
            got: 0,
        });
    }
    if knots.iter().any(|k| !k.is_finite()) {
        return Err(GeomError::NonFinite("interpolation knots"));
    }
    if knots.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Degeneracy::KnotsNotIncreasing.into());
    }
    Ok(())
}

/// Piecewise-linear interpolation at `x` inside `[knots[0], knots[last]]`
/// (knots strictly increasing); outside the range is an error.
pub fn linear<T>(knots: &[f64], values: &[T], x: f64) -> Result<T>
where
    T: Copy + Add<Output = T> + Mul<f64, Output = T>,
{
    check_knots(knots, values.len())?;
    let last = knots.len() - 1;
    if !(x >= knots[0] && x <= knots[last]) {
        return Err(Degeneracy::OutsideRange {
            x,
            first: knots[0],
            last: knots[last],
        }
        .into());
    }
    let i = knots.partition_point(|k| *k <= x).clamp(1, last.max(1));
    if last == 0 {
        return Ok(values[0]);
    }
    let w = (x - knots[i - 1]) / (knots[i] - knots[i - 1]);
    Ok(values[i - 1] * (1.0 - w) + values[i] * w)
}

/// Linear interpolation on a periodic abscissa (e.g. rotary-table angles):
/// `x` is reduced to `[0, period)` and the segment from the last knot wraps
/// round to the first knot + period. Knots must lie in `[0, period)`.
pub fn linear_periodic<T>(knots: &[f64], values: &[T], x: f64, period: f64) -> Result<T>
where
    T: Copy + Add<Output = T> + Mul<f64, Output = T>,
{
    check_knots(knots, values.len())?;
    if !(period > 0.0 && period.is_finite() && x.is_finite()) {
        return Err(GeomError::NonFinite("periodic interpolation"));
    }
    let last = knots.len() - 1;
    if knots[0] < 0.0 || knots[last] >= period {
        return Err(Degeneracy::KnotsOutsidePeriod.into());
    }
    let x = x.rem_euclid(period);
    let (x0, v0, x1, v1) = if x < knots[0] {
        (knots[last] - period, values[last], knots[0], values[0])
    } else if x >= knots[last] {
        (knots[last], values[last], knots[0] + period, values[0])
    } else {
        let i = knots.partition_point(|k| *k <= x);
        (knots[i - 1], values[i - 1], knots[i], values[i])
    };
    if x1 == x0 {
        return Ok(v0);
    }
    let w = (x - x0) / (x1 - x0);
    Ok(v0 * (1.0 - w) + v1 * w)
}

/// Values on a regular 3-D grid: node (i, j, k) sits at `origin + (i·sx, j·sy, k·sz)`;
/// values are stored with i fastest.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid3<T> {
    origin: Point3<f64>,
    step: Vector3<f64>,
    dims: [usize; 3],
    values: Vec<T>,
}

impl<T> Grid3<T>
where
    T: Copy + Add<Output = T> + Mul<f64, Output = T>,
{
    /// A grid with `dims` nodes per axis (each ≥ 2) and positive steps.
    pub fn new(
        origin: Point3<f64>,
        step: Vector3<f64>,
        dims: [usize; 3],
        values: Vec<T>,
    ) -> Result<Self> {
        if dims.iter().any(|d| *d < 2) {
            return Err(Degeneracy::GridTooSmall.into());
        }
        if step.iter().any(|s| !(*s > 0.0 && s.is_finite())) {
            return Err(Degeneracy::GridStepNotPositive.into());
        }
        if values.len() != dims[0] * dims[1] * dims[2] {
            return Err(Degeneracy::GridValues {
                dims,
                got: values.len(),
            }
            .into());
        }
        Ok(Self {
            origin,
            step,
            dims,
            values,
        })
    }

    /// Node value at (i, j, k).
    pub fn node(&self, i: usize, j: usize, k: usize) -> T {
        self.values[i + self.dims[0] * (j + self.dims[1] * k)]
    }

    /// Trilinear interpolation inside the grid's box; outside is an error.
    pub fn trilinear(&self, p: &Point3<f64>) -> Result<T> {
        let mut cell = [0usize; 3];
        let mut w = [0.0f64; 3];
        for a in 0..3 {
            let g = (p[a] - self.origin[a]) / self.step[a];
            let max = (self.dims[a] - 1) as f64;
            if !(g >= -1e-12 && g <= max + 1e-12) {
                return Err(Degeneracy::OutsideGrid {
                    point: [p.x, p.y, p.z],
                }
                .into());
            }
            let g = g.clamp(0.0, max);
            let i = (g.floor() as usize).min(self.dims[a] - 2);
            cell[a] = i;
            w[a] = g - i as f64;
        }
        let [i, j, k] = cell;
        let lerp = |a: T, b: T, t: f64| a * (1.0 - t) + b * t;
        let c00 = lerp(self.node(i, j, k), self.node(i + 1, j, k), w[0]);
        let c10 = lerp(self.node(i, j + 1, k), self.node(i + 1, j + 1, k), w[0]);
        let c01 = lerp(self.node(i, j, k + 1), self.node(i + 1, j, k + 1), w[0]);
        let c11 = lerp(
            self.node(i, j + 1, k + 1),
            self.node(i + 1, j + 1, k + 1),
            w[0],
        );
        Ok(lerp(lerp(c00, c10, w[1]), lerp(c01, c11, w[1]), w[2]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_between_knots() {
        let k = [0.0, 1.0, 3.0];
        let v = [0.0, 2.0, 6.0];
        assert_eq!(linear(&k, &v, 2.0).unwrap(), 4.0);
        assert_eq!(linear(&k, &v, 3.0).unwrap(), 6.0);
        assert!(linear(&k, &v, 3.5).is_err());
    }

    #[test]
    fn periodic_wraps_at_360() {
        // Every 30°, value = angle, except that 330° → 360° wraps back to 0.
        let k: Vec<f64> = (0..12).map(|i| f64::from(i) * 30.0).collect();
        let v: Vec<f64> = k.iter().map(|a| (a / 30.0).sin()).collect();
        let mid = linear_periodic(&k, &v, 345.0, 360.0).unwrap();
        assert!((mid - 0.5 * (v[11] + v[0])).abs() < 1e-15);
        let neg = linear_periodic(&k, &v, -15.0, 360.0).unwrap();
        assert!((neg - mid).abs() < 1e-15);
        let turn = linear_periodic(&k, &v, 720.0 + 45.0, 360.0).unwrap();
        assert!((turn - 0.5 * (v[1] + v[2])).abs() < 1e-15);
    }

    #[test]
    fn trilinear_reproduces_affine_fields() {
        let f = |p: Point3<f64>| 1.0 + 2.0 * p.x - 0.5 * p.y + 0.25 * p.z;
        let origin = Point3::new(-10.0, 0.0, 5.0);
        let step = Vector3::new(10.0, 20.0, 5.0);
        let dims = [3, 4, 2];
        let mut values = Vec::new();
        for k in 0..2 {
            for j in 0..4 {
                for i in 0..3 {
                    values.push(f(
                        origin + Vector3::new(i as f64 * 10.0, j as f64 * 20.0, k as f64 * 5.0)
                    ));
                }
            }
        }
        let g = Grid3::new(origin, step, dims, values).unwrap();
        for p in [
            Point3::new(-3.0, 17.0, 6.0),
            Point3::new(10.0, 60.0, 10.0),
            origin,
        ] {
            assert!((g.trilinear(&p).unwrap() - f(p)).abs() < 1e-12);
        }
        assert!(g.trilinear(&Point3::new(11.0, 0.0, 5.0)).is_err());
    }
}
