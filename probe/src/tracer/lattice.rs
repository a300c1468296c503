//! Corrections anywhere inside the grid: trilinear interpolation in the
//! lattice cell that holds the point (the seed's last step), on
//! `geom::interp::Grid3`. The nominal grid must be a lattice: the points are
//! every combination of nx equally spaced x values, ny y values and nz z
//! values (each ≥ 2), within [`LATTICE_TOLERANCE_MM`].

use geom::interp::Grid3;
use geom::nalgebra::{Point3, Vector3};

use crate::{LatticeFault, ProbeError, Result, TracerFault};

/// Nominal coordinates within this distance (mm) of a lattice plane are on
/// it: room for coordinates written to the µm.
pub(crate) const LATTICE_TOLERANCE_MM: f64 = 1e-3;

/// Corrections on a lattice grid, interpolated trilinearly in its cells.
#[derive(Debug, Clone, PartialEq)]
pub struct CorrectionGrid {
    grid: Grid3<Vector3<f64>>,
    lo: [f64; 3],
    hi: [f64; 3],
}

fn not_lattice(fault: LatticeFault) -> ProbeError {
    ProbeError::NotLattice(fault)
}

/// The lattice values of one axis: the points sorted by their coordinate,
/// grouped within the tolerance; each group's first value stands for it.
/// Returns (value, members) per level.
fn levels(nominal: &[Point3<f64>], a: usize) -> Vec<(f64, Vec<usize>)> {
    let mut order: Vec<usize> = (0..nominal.len()).collect();
    order.sort_by(|&i, &j| nominal[i][a].total_cmp(&nominal[j][a]).then(i.cmp(&j)));
    let mut out: Vec<(f64, Vec<usize>)> = Vec::new();
    for i in order {
        let x = nominal[i][a];
        match out.last_mut() {
            Some((l, members)) if x - *l <= LATTICE_TOLERANCE_MM => members.push(i),
            _ => out.push((x, vec![i])),
        }
    }
    for (_, members) in &mut out {
        members.sort_unstable();
    }
    out
}

impl CorrectionGrid {
    /// Check that `nominal` (named by `names`) is a lattice and hold
    /// `corrections` (same order) on it.
    pub fn new(
        nominal: &[Point3<f64>],
        names: &[String],
        corrections: &[Vector3<f64>],
    ) -> Result<CorrectionGrid> {
        if nominal.len() != corrections.len() || nominal.len() != names.len() {
            return Err(not_lattice(LatticeFault::Lengths {
                points: nominal.len(),
                names: names.len(),
                corrections: corrections.len(),
            }));
        }
        let mut origin = [0.0; 3];
        let mut step = [0.0; 3];
        let mut dims = [0usize; 3];
        for a in 0..3 {
            let lv = levels(nominal, a);
            if lv.len() < 2 {
                return Err(not_lattice(LatticeFault::OneLevel { axis: a }));
            }
            // Every level of a lattice holds the same number of points (one
            // fewer where a node is missing); a point off the lattice makes a
            // sparse level of its own.
            let most = lv.iter().map(|(_, m)| m.len()).max().unwrap_or(0);
            if let Some((v, members)) = lv.iter().find(|(_, m)| 2 * m.len() < most) {
                return Err(not_lattice(LatticeFault::SparseLevel {
                    point: members[0],
                    name: names[members[0]].clone(),
                    axis: a,
                    value: *v,
                    count: members.len(),
                    most,
                }));
            }
            let (first, last) = (lv[0].0, lv[lv.len() - 1].0);
            let s = (last - first) / (lv.len() - 1) as f64;
            for (k, (v, members)) in lv.iter().enumerate() {
                let expected = first + k as f64 * s;
                if (v - expected).abs() > LATTICE_TOLERANCE_MM {
                    return Err(not_lattice(LatticeFault::Uneven {
                        point: members[0],
                        name: names[members[0]].clone(),
                        axis: a,
                        value: *v,
                        step: s,
                        expected,
                    }));
                }
            }
            origin[a] = first;
            step[a] = s;
            dims[a] = lv.len();
        }
        // Each node holds exactly one point: a lattice of many more nodes
        // than points (points on a diagonal make n levels per axis, n³ nodes)
        // is refused before its nodes are allocated.
        let cells = dims[0]
            .checked_mul(dims[1])
            .and_then(|c| c.checked_mul(dims[2]))
            .filter(|&c| c <= 2 * nominal.len())
            .ok_or_else(|| {
                not_lattice(LatticeFault::MostlyEmpty {
                    points: nominal.len(),
                    dims,
                })
            })?;
        let mut values: Vec<Option<Vector3<f64>>> = vec![None; cells];
        for (i, p) in nominal.iter().enumerate() {
            let mut index = [0usize; 3];
            for a in 0..3 {
                let g = (p[a] - origin[a]) / step[a];
                let k = g.round();
                if (p[a] - (origin[a] + k * step[a])).abs() > LATTICE_TOLERANCE_MM {
                    return Err(not_lattice(LatticeFault::BetweenValues {
                        point: i,
                        name: names[i].clone(),
                        axis: a,
                        value: p[a],
                    }));
                }
                index[a] = k as usize;
            }
            let slot = index[0] + dims[0] * (index[1] + dims[1] * index[2]);
            if values[slot].replace(corrections[i]).is_some() {
                return Err(not_lattice(LatticeFault::NodeTaken {
                    point: i,
                    name: names[i].clone(),
                }));
            }
        }
        if let Some(slot) = values.iter().position(Option::is_none) {
            let (i, j, k) = (
                slot % dims[0],
                (slot / dims[0]) % dims[1],
                slot / (dims[0] * dims[1]),
            );
            return Err(not_lattice(LatticeFault::MissingNode {
                points: nominal.len(),
                dims,
                cells,
                node: [
                    origin[0] + i as f64 * step[0],
                    origin[1] + j as f64 * step[1],
                    origin[2] + k as f64 * step[2],
                ],
            }));
        }
        let values: Vec<Vector3<f64>> = values.into_iter().flatten().collect();
        let hi = [0, 1, 2].map(|a| origin[a] + (dims[a] - 1) as f64 * step[a]);
        let grid = Grid3::new(Point3::from(origin), Vector3::from(step), dims, values)?;
        Ok(CorrectionGrid {
            grid,
            lo: origin,
            hi,
        })
    }

    /// Range `(lo, hi)` of the grid along axis `a` (0, 1, 2 = x, y, z; mm).
    pub fn range(&self, a: usize) -> (f64, f64) {
        (self.lo[a], self.hi[a])
    }

    /// The first axis (0, 1, 2) along which `p` lies outside the grid, if any.
    pub fn outside(&self, p: &Point3<f64>) -> Option<usize> {
        (0..3).find(|&a| !(p[a] >= self.lo[a] && p[a] <= self.hi[a]))
    }

    /// Correction at `p` by trilinear interpolation in its cell (mm); a point
    /// outside the grid is an error naming the axis.
    pub fn at(&self, p: &Point3<f64>) -> Result<Vector3<f64>> {
        if let Some(a) = self.outside(p) {
            return Err(ProbeError::Tracer(TracerFault::QueryOutside {
                query: [p.x, p.y, p.z],
                axis: a,
                lo: self.lo[a],
                hi: self.hi[a],
            }));
        }
        Ok(self.grid.trilinear(p)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(dims: [usize; 3], step: [f64; 3]) -> Vec<Point3<f64>> {
        let mut out = Vec::new();
        // Scrambled order: z fastest, to show the order of the points does not matter.
        for i in 0..dims[0] {
            for j in 0..dims[1] {
                for k in 0..dims[2] {
                    out.push(Point3::new(
                        -50.0 + i as f64 * step[0],
                        j as f64 * step[1],
                        10.0 + k as f64 * step[2],
                    ));
                }
            }
        }
        out
    }

    fn names(n: usize) -> Vec<String> {
        (1..=n).map(|i| i.to_string()).collect()
    }

    #[test]
    fn reproduces_an_affine_field_and_refuses_outside() {
        let pts = lattice([3, 4, 2], [100.0, 50.0, 200.0]);
        let f = |p: &Point3<f64>| {
            Vector3::new(1e-3 * p.x, -2e-3 * p.y + 1e-4 * p.z, 3e-6 * p.x + 0.002)
        };
        let c: Vec<Vector3<f64>> = pts.iter().map(f).collect();
        let g = CorrectionGrid::new(&pts, &names(pts.len()), &c).unwrap();
        for q in [
            Point3::new(-50.0, 0.0, 10.0),
            Point3::new(12.5, 131.0, 77.0),
            Point3::new(150.0, 150.0, 210.0),
        ] {
            assert!((g.at(&q).unwrap() - f(&q)).norm() < 1e-15, "{q}");
        }
        assert_eq!(g.range(2), (10.0, 210.0));
        assert_eq!(g.outside(&Point3::new(0.0, 151.0, 20.0)), Some(1));
        let e = g.at(&Point3::new(0.0, 0.0, 210.5)).unwrap_err().to_string();
        assert!(e.contains("z = 210.5") && e.contains("outside"), "{e}");
    }

    #[test]
    fn refuses_what_is_not_a_lattice() {
        let pts = lattice([3, 3, 2], [10.0, 10.0, 10.0]);
        let c = vec![Vector3::zeros(); pts.len()];
        let mut moved = pts.clone();
        moved[4].y += 3.0;
        let e = CorrectionGrid::new(&moved, &names(pts.len()), &c)
            .unwrap_err()
            .to_string();
        assert!(e.contains("lattice"), "{e}");
        let e = CorrectionGrid::new(&pts[1..], &names(pts.len() - 1), &c[1..])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("17 points") && e.contains("no point at (-50, 0, 10)"),
            "{e}"
        );
        let mut uneven = pts.clone();
        for p in &mut uneven {
            if p.x > -45.0 {
                p.x += 5.0;
            }
        }
        let e = CorrectionGrid::new(&uneven, &names(pts.len()), &c)
            .unwrap_err()
            .to_string();
        assert!(e.contains("equally spaced"), "{e}");
        // 2000 points on a diagonal: 2000 levels per axis, 8e9 nodes never allocated.
        let diagonal: Vec<Point3<f64>> = (0..2000)
            .map(|k| Point3::new(k as f64, k as f64, k as f64))
            .collect();
        let c = vec![Vector3::zeros(); diagonal.len()];
        let e = CorrectionGrid::new(&diagonal, &names(diagonal.len()), &c)
            .unwrap_err()
            .to_string();
        assert!(e.contains("2000 points span 2000×2000×2000"), "{e}");
    }
}
