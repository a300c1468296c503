//! The table's pose at each instant from the three spheres (docs/methods.md,
//! angular errors): the rigid motion of the sphere triplet since the first
//! instant of the line, by least squares (Kabsch), as roll, pitch and yaw of
//! the moving axis.

use std::collections::BTreeMap;

use formats::{Axis, InstantKey, LineKey, PointRow, PoseRow};
use geom::Point3;
use geom::transform::{quaternion_vector, rigid_fit};

/// `[roll, pitch, yaw]` of a rotation vector for motion along `axis`:
/// X → (εx, εy, εz), Y → (εy, εx, εz), Z → (εz, εx, εy).
pub fn roll_pitch_yaw(axis: Axis, r: &geom::Vector3<f64>) -> [f64; 3] {
    match axis {
        Axis::X => [r.x, r.y, r.z],
        Axis::Y => [r.y, r.x, r.z],
        Axis::Z => [r.z, r.x, r.y],
    }
}

/// The table's poses of a measurement, and the instants whose pose could not
/// be fitted although all their spheres were measured.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Poses {
    /// One row per instant with every sphere measured and a rigid fit.
    pub rows: Vec<PoseRow>,
    /// Instants with every sphere measured but no pose, and why.
    pub failed: Vec<(InstantKey, String)>,
}

/// Poses of every instant with all `spheres` measured, relative to the first
/// such instant of its line (rows in the order of `points`). Instants are
/// identified by their key columns; lines by axis and off-axis nominal
/// coordinates. An instant lacking a sphere has no pose and is not listed in
/// [`Poses::failed`] (its missing sphere is its problem). A set of fewer
/// than three spheres has no poses at all, and no failures.
pub fn poses(points: &[PointRow], spheres: &[String]) -> Poses {
    if spheres.len() < 3 {
        return Poses::default();
    }
    let mut order: Vec<InstantKey> = Vec::new();
    let mut centres: BTreeMap<InstantKey, BTreeMap<&str, Point3<f64>>> = BTreeMap::new();
    for p in points {
        let k = p.instant();
        centres
            .entry(k)
            .or_insert_with(|| {
                order.push(k);
                BTreeMap::new()
            })
            .insert(p.sphere.as_str(), Point3::from(p.position()));
    }
    let mut reference: BTreeMap<LineKey, Vec<Point3<f64>>> = BTreeMap::new();
    let mut out = Poses::default();
    for k in order {
        let c = &centres[&k];
        let Some(now): Option<Vec<Point3<f64>>> =
            spheres.iter().map(|s| c.get(s.as_str()).copied()).collect()
        else {
            continue;
        };
        let first = reference.entry(k.line()).or_insert_with(|| now.clone());
        let motion = match rigid_fit(first, &now) {
            Ok(m) => m,
            Err(e) => {
                out.failed
                    .push((k, format!("no pose: rigid fit of the spheres: {e}")));
                continue;
            }
        };
        let r = quaternion_vector(&motion.rotation);
        let [roll, pitch, yaw] = roll_pitch_yaw(k.axis, &r);
        let residual = (first
            .iter()
            .zip(&now)
            .map(|(p, q)| (motion.transform_point(p) - q).norm_squared())
            .sum::<f64>()
            / now.len() as f64)
            .sqrt();
        let [nx, ny, nz] = k.nominal();
        let t = motion.translation.vector;
        out.rows.push(PoseRow {
            axis: k.axis,
            direction: k.direction,
            run: k.run,
            target: k.target,
            capture: k.capture,
            nominal_x: nx,
            nominal_y: ny,
            nominal_z: nz,
            roll,
            pitch,
            yaw,
            rx: r.x,
            ry: r.y,
            rz: r.z,
            tx: t.x,
            ty: t.y,
            tz: t.z,
            residual_mm: residual,
        });
    }
    out
}
