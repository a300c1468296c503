//! A known error model of a machine and the `points.csv` rows it produces
//! (no noise), for tests that compare the evaluation with analytic truth.
//!
//! Per line of an axis with direction `e` (turned by a small yaw against the
//! world frame) and commanded coordinates `c_k`, sphere A at run j, capture m:
//! `A = O + (c_k + p_k ± b_k/2 + σ_k·z_j + q_m)·e + δ1_k·f1 + δ2_k·f2 + s_A`,
//! with `f1, f2` the perpendicular world directions made perpendicular to `e`,
//! `z_j` a run pattern with mean 0 and sample standard deviation 1, `q_m` a
//! capture pattern with mean 0. The straightness deviations `δ1, δ2` are
//! orthogonal (over the targets) to 1, `c_k` and `p_k`, so the least-squares
//! axis through the per-target means is exactly `e` and their least-squares
//! line is exactly zero. The other spheres are turned about A by the rotation
//! vector `ω_k` (`ω_0 = 0`).

#![allow(dead_code, clippy::unwrap_used)]

use formats::{Axis, Direction, InstantKey, PointRow};
use geom::{Point3, Rotation3, Vector3};

/// Sphere names and their offsets from the table reference point (mm): the
/// seed's plan positions with the renderer's heights (B and C 20 and 15 mm
/// above A), a triangle that determines all three rotations.
pub const SPHERES: [(&str, [f64; 3]); 3] = [
    ("A", [0.0, 0.0, 10.0]),
    ("B", [20.0, 20.0, 30.0]),
    ("C", [-15.0, -15.0, 25.0]),
];

/// One sweep of an axis and its errors at each target (mm, rad).
#[derive(Debug, Clone)]
pub struct LineModel {
    /// Axis moved.
    pub axis: Axis,
    /// Commanded coordinates of the other two axes, sorted (X: y, z; Y: x, z).
    pub off: [f64; 2],
    /// Yaw of the axis against the world frame (rad).
    pub yaw: f64,
    /// Commanded axis coordinate per target.
    pub c: Vec<f64>,
    /// Approach directions measured.
    pub directions: Vec<Direction>,
    /// Runs per direction.
    pub runs: usize,
    /// Captures per approach.
    pub captures: usize,
    /// Mean positional error per target.
    pub p: Vec<f64>,
    /// Reversal per target (↑ minus ↓).
    pub b: Vec<f64>,
    /// Standard deviation of the ↑ runs per target.
    pub s_up: Vec<f64>,
    /// Standard deviation of the ↓ runs per target.
    pub s_down: Vec<f64>,
    /// Capture pattern amplitude.
    pub q: f64,
    /// Straightness deviations in the first and second perpendicular directions.
    pub d: [Vec<f64>; 2],
    /// Rotation vector of the table per target (ω_0 = 0).
    pub omega: Vec<Vector3<f64>>,
    /// Table height (world z of the reference point).
    pub z0: f64,
}

/// Remove from `v` its components along each of `basis` (Gram–Schmidt, twice for accuracy).
fn orthogonalise(mut v: Vec<f64>, basis: &[Vec<f64>]) -> Vec<f64> {
    let mut ortho: Vec<Vec<f64>> = Vec::new();
    for b in basis {
        let mut u = b.clone();
        for _ in 0..2 {
            for o in &ortho {
                let k = dot(&u, o) / dot(o, o);
                u.iter_mut().zip(o).for_each(|(x, y)| *x -= k * y);
            }
        }
        ortho.push(u);
    }
    for _ in 0..2 {
        for o in &ortho {
            let k = dot(&v, o) / dot(o, o);
            v.iter_mut().zip(o).for_each(|(x, y)| *x -= k * y);
        }
    }
    v
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Run pattern: mean 0, sample standard deviation 1, n ≥ 2 values; `[0]`
/// for a single run.
pub fn run_pattern(n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![0.0];
    }
    let mid = (n as f64 - 1.0) / 2.0;
    let raw: Vec<f64> = (0..n).map(|j| j as f64 - mid).collect();
    let s = (dot(&raw, &raw) / (n as f64 - 1.0)).sqrt();
    raw.iter().map(|v| v / s).collect()
}

/// Capture pattern: mean 0, values `q·(m − mid)`.
pub fn capture_pattern(n: usize, q: f64) -> Vec<f64> {
    let mid = (n as f64 - 1.0) / 2.0;
    (0..n).map(|m| q * (m as f64 - mid)).collect()
}

impl LineModel {
    /// A line with errors shaped by `seed` (µm-level, smooth, distinct per line).
    pub fn new(
        axis: Axis,
        off: [f64; 2],
        targets: usize,
        step: f64,
        runs: usize,
        seed: f64,
    ) -> Self {
        let n = targets;
        let c: Vec<f64> = (0..n)
            .map(|k| step * (k as f64 - (n as f64 - 1.0) / 2.0))
            .collect();
        let k = |i: usize| i as f64;
        let p: Vec<f64> = (0..n)
            .map(|i| 1e-3 * (4.0 * (0.9 * k(i) + seed).sin() + 0.05 * c[i]))
            .collect();
        let ones = vec![1.0; n];
        let d0: Vec<f64> = (0..n)
            .map(|i| 1e-3 * (3.0 * (0.7 * k(i) + seed).sin() + (1.9 * k(i)).cos()))
            .collect();
        let d1: Vec<f64> = (0..n)
            .map(|i| 1e-3 * (2.0 * (0.5 * k(i) - seed).cos() - (1.3 * k(i)).sin()))
            .collect();
        let basis = [ones, c.clone(), p.clone()];
        Self {
            axis,
            off,
            yaw: 8e-4 * (1.0 + 0.3 * seed),
            directions: vec![Direction::Up, Direction::Down],
            runs,
            captures: 3,
            b: (0..n)
                .map(|i| 1e-3 * (2.0 + 0.5 * (k(i) + seed).cos()))
                .collect(),
            s_up: (0..n)
                .map(|i| 1e-3 * (0.3 + 0.1 * (k(i) * 1.7).sin()))
                .collect(),
            s_down: (0..n)
                .map(|i| 1e-3 * (0.4 + 0.15 * (k(i) * 2.3 + seed).cos()))
                .collect(),
            q: 2e-4,
            d: [orthogonalise(d0, &basis), orthogonalise(d1, &basis)],
            omega: (0..n)
                .map(|i| {
                    Vector3::new(
                        2e-6 * (0.6 * k(i)).sin(),
                        3e-6 * ((0.4 * k(i)).cos() - 1.0),
                        1.5e-6 * k(i) / n as f64,
                    )
                })
                .collect(),
            z0: 0.0,
            c,
            p,
        }
    }

    /// Unit direction of the axis in the world frame.
    pub fn e(&self) -> Vector3<f64> {
        let (s, c) = self.yaw.sin_cos();
        match self.axis {
            Axis::X => Vector3::new(c, s, 0.0),
            Axis::Y => Vector3::new(-s, c, 0.0),
            Axis::Z => Vector3::new(0.0, 0.0, 1.0),
        }
    }

    /// The perpendicular world directions, sorted, made perpendicular to `e`.
    pub fn perpendicular(&self) -> [(Axis, Vector3<f64>); 2] {
        let e = self.e();
        let mut o = self.axis.others();
        o.sort();
        o.map(|a| {
            let w = Vector3::ith(a.index(), 1.0);
            (a, (w - e * w.dot(&e)).normalize())
        })
    }

    /// Commanded position at target k.
    pub fn nominal(&self, k: usize) -> [f64; 3] {
        let mut n = [0.0; 3];
        let o = {
            let mut o = self.axis.others();
            o.sort();
            o
        };
        n[self.axis.index()] = self.c[k];
        n[o[0].index()] = self.off[0];
        n[o[1].index()] = self.off[1];
        n
    }

    /// Table reference point at the datum of the line (c = 0).
    fn origin(&self) -> Vector3<f64> {
        let n = self.nominal(0);
        let mut o = Vector3::new(n[0], n[1], self.z0);
        o[self.axis.index()] = 0.0;
        o
    }

    /// Along-axis error of one capture.
    pub fn along(&self, k: usize, direction: Direction, run: usize, capture: usize) -> f64 {
        let z = run_pattern(self.runs);
        let q = capture_pattern(self.captures, self.q);
        match direction {
            // The ↓ runs use the pattern backwards, so the two directions differ.
            Direction::Up => self.p[k] + self.b[k] / 2.0 + self.s_up[k] * z[run] + q[capture],
            Direction::Down => {
                self.p[k] - self.b[k] / 2.0 + self.s_down[k] * z[self.runs - 1 - run] + q[capture]
            }
        }
    }

    /// Sphere A's centre at one capture.
    pub fn sphere_a(
        &self,
        k: usize,
        direction: Direction,
        run: usize,
        capture: usize,
    ) -> Point3<f64> {
        let [(_, f0), (_, f1)] = self.perpendicular();
        Point3::from(
            self.origin()
                + self.e() * (self.c[k] + self.along(k, direction, run, capture))
                + f0 * self.d[0][k]
                + f1 * self.d[1][k]
                + Vector3::from(SPHERES[0].1),
        )
    }

    /// Per-target mean of sphere A (the model's value at the target).
    pub fn mean_a(&self, k: usize) -> Point3<f64> {
        let [(_, f0), (_, f1)] = self.perpendicular();
        Point3::from(
            self.origin()
                + self.e() * (self.c[k] + self.p[k])
                + f0 * self.d[0][k]
                + f1 * self.d[1][k]
                + Vector3::from(SPHERES[0].1),
        )
    }

    /// The rows of this line, all spheres, ↑ runs with targets ascending and
    /// ↓ runs descending, as a campaign takes them.
    pub fn rows(&self) -> Vec<PointRow> {
        let mut rows = Vec::new();
        let n = self.c.len();
        let a_offset = Vector3::from(SPHERES[0].1);
        for run in 0..self.runs {
            for &direction in &self.directions {
                let order: Vec<usize> = match direction {
                    Direction::Up => (0..n).collect(),
                    Direction::Down => (0..n).rev().collect(),
                };
                for k in order {
                    let rot = Rotation3::new(self.omega[k]);
                    for capture in 0..self.captures {
                        let a = self.sphere_a(k, direction, run, capture);
                        for (name, offset) in SPHERES {
                            let p = a + rot * (Vector3::from(offset) - a_offset);
                            let nominal = self.nominal(k);
                            rows.push(PointRow::new(
                                InstantKey::new(
                                    (self.axis, direction),
                                    [run as u32 + 1, k as u32, capture as u32 + 1],
                                    [nominal[0], nominal[1], nominal[2]],
                                ),
                                name,
                                [p.x, p.y, p.z],
                                "2+3",
                                0.0,
                            ));
                        }
                    }
                }
            }
        }
        rows
    }
}

/// A realistic campaign: X swept along y = −20, 0, +20 (5 runs on the middle
/// line, 3 on the others), Y along x = 0 (4 runs), three spheres.
pub fn campaign() -> Vec<LineModel> {
    let mut lines = vec![
        LineModel::new(Axis::X, [-20.0, 0.0], 11, 15.0, 3, 0.4),
        LineModel::new(Axis::X, [0.0, 0.0], 11, 15.0, 5, 0.0),
        LineModel::new(Axis::X, [20.0, 0.0], 11, 15.0, 3, 0.8),
        LineModel::new(Axis::Y, [0.0, 0.0], 9, 15.0, 4, 1.3),
    ];
    // Line heights differ (a table tilted by 20 µm/m across the X lines).
    for l in &mut lines {
        l.z0 = if l.axis == Axis::X {
            2e-5 * l.off[0]
        } else {
            1e-5 * l.off[0]
        };
    }
    lines
}

/// All rows of a campaign.
pub fn rows(lines: &[LineModel]) -> Vec<PointRow> {
    lines.iter().flat_map(LineModel::rows).collect()
}

/// Write rows as a points.csv.
pub fn write_points(path: &std::path::Path, rows: &[PointRow]) {
    formats::write_csv(path, rows).unwrap();
}

/// A report's uncertainty as a test states it: its budget and expanded
/// uncertainties, with a nominal method, sources and one trial.
pub fn given(
    budget: Vec<formats::uncertainty::BudgetEntry>,
    expanded: std::collections::BTreeMap<String, f64>,
) -> formats::uncertainty::Uncertainty {
    formats::uncertainty::Uncertainty::Given(formats::uncertainty::Propagated {
        method: "test".into(),
        k: 2.0,
        trials: 1,
        seed: 1,
        failed_trials: 0,
        sources: std::collections::BTreeMap::from([("centroids".to_string(), "noise".to_string())]),
        not_included: Vec::new(),
        budget,
        expanded,
    })
}
