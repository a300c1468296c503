//! The table's pose at each instant from the three spheres (docs/methods.md,
//! angular errors): the rigid motion of the sphere triplet since the first
//! instant of the line, by least squares (Kabsch), as roll, pitch and yaw of
//! the moving axis.

use std::collections::BTreeMap;

use formats::{InstantKey, LineKey, PointRow, PoseRow};
use geom::Point3;
use geom::transform::rigid_fit_rms;

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
        let fit = match rigid_fit_rms(first, &now) {
            Ok(m) => m,
            Err(e) => {
                out.failed
                    .push((k, format!("no pose: rigid fit of the spheres: {e}")));
                continue;
            }
        };
        let r = fit.rotation;
        let [roll, pitch, yaw] = k.axis.roll_pitch_yaw(&r);
        let residual = fit.rms;
        let [nx, ny, nz] = k.nominal();
        let t = fit.motion.translation.vector;
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
