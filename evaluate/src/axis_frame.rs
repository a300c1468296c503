//! The axis frame of a line: the axis direction from the orthogonal
//! least-squares line through the per-target mean positions (free of cosine
//! error), the datum at the first target, and the two perpendicular
//! directions in which straightness is measured.

use formats::Axis;
use geom::{Point3, Vector3};

/// Direction and datum of one line of an axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisFrame {
    /// Datum: the mean position at the first target (mm).
    pub origin: Point3<f64>,
    /// Unit axis direction, oriented so that commanded displacements and
    /// measured ones have the same sign.
    pub direction: Vector3<f64>,
    /// The two world axes perpendicular to the moving one (X → Y, Z;
    /// Y → X, Z; Z → X, Y) and, for each, its unit direction made
    /// perpendicular to `direction`: `normalize(e − (e·d)d)`.
    pub perpendicular: [(Axis, Vector3<f64>); 2],
}

impl AxisFrame {
    /// Fit the frame of `axis` from the per-target mean positions `means`
    /// (mm), first target first, and the commanded axis coordinates `nominal`
    /// of the same targets (used only to orient the direction).
    pub fn fit(axis: Axis, means: &[Point3<f64>], nominal: &[f64]) -> geom::Result<Self> {
        let line = geom::fit::line_3d(means)?;
        let origin = means[0];
        let mut direction = line.direction;
        // Orient by the target farthest (in commanded terms) from the first.
        let far = (1..means.len().min(nominal.len())).max_by(|&i, &j| {
            (nominal[i] - nominal[0])
                .abs()
                .total_cmp(&(nominal[j] - nominal[0]).abs())
        });
        if let Some(k) = far {
            let measured = (means[k] - origin).dot(&direction);
            if measured * (nominal[k] - nominal[0]) < 0.0 {
                direction = -direction;
            }
        }
        let mut others = axis.others();
        others.sort();
        let perpendicular = others.map(|a| {
            let e = Vector3::ith(a.index(), 1.0);
            (a, (e - direction * e.dot(&direction)).normalize())
        });
        Ok(Self {
            origin,
            direction,
            perpendicular,
        })
    }

    /// Displacement of `p` from the datum along the axis (mm).
    pub fn along(&self, p: &Point3<f64>) -> f64 {
        (p - self.origin).dot(&self.direction)
    }

    /// Displacement of `p` from the datum in perpendicular direction `k` (0 or 1) (mm).
    pub fn across(&self, p: &Point3<f64>, k: usize) -> f64 {
        (p - self.origin).dot(&self.perpendicular[k % 2].1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tilted_axis_measures_true_displacements() {
        // An X axis yawed by 2 mrad and pitched by 1 mrad: measured
        // displacement along the fitted direction equals the commanded one.
        let d = Vector3::new(1.0, 2e-3, -1e-3).normalize();
        let nominal: Vec<f64> = (0..6).map(|k| 30.0 * k as f64).collect();
        let means: Vec<Point3<f64>> = nominal
            .iter()
            .map(|&x| Point3::new(5.0, -3.0, 100.0) + d * x)
            .collect();
        let f = AxisFrame::fit(Axis::X, &means, &nominal).unwrap();
        for (p, x) in means.iter().zip(&nominal) {
            assert!((f.along(p) - x).abs() < 1e-12);
            assert!(f.across(p, 0).abs() < 1e-12 && f.across(p, 1).abs() < 1e-12);
        }
        assert_eq!(
            (f.perpendicular[0].0, f.perpendicular[1].0),
            (Axis::Y, Axis::Z)
        );
        assert!(f.perpendicular[0].1.dot(&d).abs() < 1e-15);
        // Targets numbered from the far end: the direction still follows the commands.
        let rev: Vec<f64> = nominal.iter().map(|x| -x).collect();
        let f = AxisFrame::fit(Axis::X, &means, &rev).unwrap();
        assert!((f.along(&means[5]) + 150.0).abs() < 1e-12);
    }
}
