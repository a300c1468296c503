//! The `[target]` table: the 3-D calibration target.

use serde::{Deserialize, Serialize};

use super::check::{bad, finite, non_negative, positive};
use crate::Result;

/// Largest target grid (markers per side of the Latin square; 49 by default).
const MAX_GRID: u32 = 101;

/// Most further placements of the target (`poses_mm`).
const MAX_POSES: usize = 1000;

/// The 3-D calibration target: markers on a Latin-square lattice, so that no
/// two markers line up along X, Y or Z (each camera sees a full grid).
/// Marker (i, j), i, j = 0..n−1, sits at
/// `centre + spacing·(i − c, j − c) + depth_step·(((2i + 3j) mod n) − c)·ẑ`, c = (n − 1)/2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TargetConfig {
    /// Lattice size n (markers = n²); must be coprime with 6.
    pub grid: u32,
    /// Lattice pitch along X and along Y (mm). The target should span the
    /// volume the spheres travel through: a camera calibrated on a smaller
    /// target is extrapolated at the ends of the travel, which shows first in
    /// the angular errors (a sphere set's lever is only ≈ 8 mm).
    pub spacing_mm: [f64; 2],
    /// Lattice pitch in Z (mm).
    pub depth_step_mm: f64,
    /// Centre of the lattice, world frame (mm).
    pub centre: [f64; 3],
    /// Marker diameter (mm).
    pub marker_diameter_mm: f64,
    /// Largest displacement of a marker from its lattice position along each
    /// axis (mm): a fixed pseudo-random jitter that breaks the lattice's
    /// periodicity, so that no image of the target matches the target
    /// shifted by a lattice step. Below a quarter of either pitch.
    pub jitter_mm: f64,
    /// Marker radiance (electrons per fully covered pixel per exposure).
    pub radiance_e: f64,
    /// Further placements of the target (mm): each the machine's move of the
    /// target from its home placement (pose 0). With any, the target is also
    /// rendered at pose p = 1, 2, … moved by `poses_mm[p − 1]`, and
    /// `calib/views.csv` lists every view (docs/methods.md §8).
    pub poses_mm: Vec<[f64; 3]>,
}

impl Default for TargetConfig {
    fn default() -> Self {
        Self {
            grid: 7,
            spacing_mm: [28.0, 20.0],
            depth_step_mm: 18.0,
            centre: [0.0, 0.0, 30.0],
            marker_diameter_mm: 3.0,
            jitter_mm: 3.0,
            radiance_e: 12_000.0,
            poses_mm: Vec::new(),
        }
    }
}

impl TargetConfig {
    /// Check the lattice, its jitter and the markers; the error names the key.
    pub(crate) fn validate(&self) -> Result<()> {
        let t = self;
        if t.grid < 2 || t.grid.is_multiple_of(2) || t.grid.is_multiple_of(3) || t.grid > MAX_GRID {
            return Err(bad(
                "target.grid",
                format!(
                    "{} must be ≥ 5, at most {MAX_GRID} and coprime with 6 (5, 7, 11, ...)",
                    t.grid
                ),
            ));
        }
        positive("target.spacing_mm[0]", t.spacing_mm[0])?;
        positive("target.spacing_mm[1]", t.spacing_mm[1])?;
        non_negative("target.depth_step_mm", t.depth_step_mm)?;
        finite("target.centre", &t.centre)?;
        positive("target.marker_diameter_mm", t.marker_diameter_mm)?;
        non_negative("target.jitter_mm", t.jitter_mm)?;
        if t.jitter_mm
            >= 0.25
                * t.spacing_mm[0]
                    .min(t.spacing_mm[1])
                    .min(if t.depth_step_mm > 0.0 {
                        t.depth_step_mm
                    } else {
                        f64::INFINITY
                    })
        {
            return Err(bad(
                "target.jitter_mm",
                format!(
                    "{} mm must stay below a quarter of the lattice pitch",
                    t.jitter_mm
                ),
            ));
        }
        if t.poses_mm.len() > MAX_POSES {
            return Err(bad(
                "target.poses_mm",
                format!("{} placements; at most {MAX_POSES}", t.poses_mm.len()),
            ));
        }
        for (i, p) in t.poses_mm.iter().enumerate() {
            finite(&format!("target.poses_mm[{i}]"), p)?;
        }
        non_negative("target.radiance_e", t.radiance_e)
    }
}
