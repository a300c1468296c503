//! The two-halves cross-validation of a calibration over views
//! (docs/methods.md §8 item 9): the poses split into two halves (alternate
//! pose ids), each calibrated on its own; over the volume grid of the whole
//! calibration, the same observations (each grid point's image in every
//! camera that sees it, through the whole rig) are triangulated with either
//! half's cameras, each in its half's world (its first pose), one set
//! moved onto the other by the best rigid motion, and the differences
//! compared with what the halves' covariances predict, √(tr Σ_A + tr Σ_B)
//! (each half's triangulation covariance from its own calibration,
//! [`crate::volume_uncertainty`]'s; the halves are independent data). The
//! alignment takes out the part of the halves' errors common to the whole
//! grid, which the prediction keeps: on the safe side.

use std::collections::BTreeMap;

use geom::nalgebra::Point3;
use geom::triangulate::{View as Sight, triangulate};

use crate::bundle::volume_point;
use crate::{CalibError, OptionProblem, Options, Result, Rig, View, VolumePoint, calibrate_views};

/// The two halves compared.
#[derive(Debug, Clone, PartialEq)]
pub struct HalvesCheck {
    /// The pose ids of each half.
    pub halves: [Vec<u32>; 2],
    /// Grid points compared (seen by two or more cameras common to both halves).
    pub points: usize,
    /// RMS of the positions' differences (µm, 3-D).
    pub rms_difference_um: f64,
    /// RMS of the predicted differences √(tr Σ_A + tr Σ_B) (µm).
    pub rms_predicted_um: f64,
    /// Points whose difference is within twice its prediction.
    pub within_2sigma: usize,
}

/// Cross-validate `rig` (calibrated from `views`) by two halves of its poses,
/// over its volume grid `volume` ([`crate::volume_uncertainty`]'s; module docs).
/// Fails where the poses are too few to split (fewer than 4) or a half
/// cannot be calibrated alone (a camera cut off, too few points): the error
/// says which.
pub fn two_halves(
    rig: &Rig,
    views: &[View],
    volume: &[VolumePoint],
    sizes: &BTreeMap<u8, (u32, u32)>,
    options: &Options,
) -> Result<HalvesCheck> {
    let poses: Vec<u32> = rig.poses.keys().copied().collect();
    if poses.len() < 4 {
        return Err(CalibError::Option(OptionProblem::TooFewPosesToSplit {
            poses: poses.len(),
        }));
    }
    let halves: [Vec<u32>; 2] = [0, 1].map(|h| poses.iter().skip(h).step_by(2).copied().collect());
    let half_rigs = halves
        .iter()
        .map(|half| {
            let own: Vec<View> = views
                .iter()
                .filter(|v| half.contains(&v.pose))
                .cloned()
                .collect();
            calibrate_views(&own, sizes, options)
        })
        .collect::<Result<Vec<Rig>>>()?;
    let common: Vec<u8> = rig
        .cameras
        .iter()
        .map(|c| c.id)
        .filter(|id| {
            half_rigs
                .iter()
                .all(|r| r.cameras.iter().any(|c| c.id == *id))
        })
        .collect();
    let names: Vec<Vec<String>> = half_rigs
        .iter()
        .map(|r| r.layout.names().iter().map(|s| s.to_string()).collect())
        .collect();
    // Each grid point triangulated by either half, in that half's world.
    let mut sets: [Vec<Point3<f64>>; 2] = [Vec::new(), Vec::new()];
    let mut variances = Vec::new();
    for grid in volume {
        let seen: Vec<u8> = grid
            .cameras
            .iter()
            .copied()
            .filter(|id| common.contains(id))
            .collect();
        if seen.len() < 2 {
            continue;
        }
        let found: Vec<(Point3<f64>, f64)> = half_rigs
            .iter()
            .zip(&names)
            .filter_map(|(half, names)| position(rig, half, names, &seen, &grid.point))
            .collect();
        if let [a, b] = found[..] {
            sets[0].push(a.0);
            sets[1].push(b.0);
            variances.push(a.1 + b.1);
        }
    }
    // The halves' worlds differ (each is its own first pose): B onto A by
    // the best rigid motion (Kabsch), which also takes out the part of
    // each half's error common to the whole volume — the prediction keeps
    // it: on the safe side.
    let points = variances.len();
    let (mut ss_diff, mut ss_pred, mut within) = (0.0, 0.0, 0);
    if points >= 3 {
        let onto = geom::transform::rigid_fit(&sets[1], &sets[0])
            .map_err(CalibError::geom("aligning the two halves' volume grids"))?;
        for ((a, b), variance) in sets[0].iter().zip(&sets[1]).zip(&variances) {
            let d = 1e3 * (a - onto * b).norm();
            ss_diff += d * d;
            ss_pred += variance;
            if d <= 2.0 * variance.sqrt() {
                within += 1;
            }
        }
    }
    let rms = |ss: f64| {
        if points > 0 {
            (ss / points as f64).sqrt()
        } else {
            0.0
        }
    };
    Ok(HalvesCheck {
        halves,
        points,
        rms_difference_um: rms(ss_diff),
        rms_predicted_um: rms(ss_pred),
        within_2sigma: within,
    })
}

/// The grid point `x` (the whole rig's world) seen through the whole rig by
/// the cameras `seen`, triangulated with `half`'s cameras: its position in
/// `half`'s world (mm), and the trace of its covariance from `half`'s
/// calibration (µm²).
fn position(
    rig: &Rig,
    half: &Rig,
    names: &[String],
    seen: &[u8],
    x: &Point3<f64>,
) -> Option<(Point3<f64>, f64)> {
    fn camera(r: &Rig, id: u8) -> Option<&geom::Camera> {
        r.cameras.iter().find(|c| c.id == id).map(|c| &c.camera)
    }
    let mut sights = Vec::with_capacity(seen.len());
    for &id in seen {
        let observed = camera(rig, id)?.project(x).ok()?;
        let own = camera(half, id)?;
        sights.push(Sight {
            camera: own,
            ideal_px: own.undistort_pixel(observed).ok()?,
        });
    }
    let found = triangulate(&sights, 0.0).ok()?;
    let sigma = volume_point(half, names, found.point).sigma_um?;
    Some((found.point, sigma.norm_squared()))
}
