//! The `[board]` table: a printed chessboard for `synth board`.

use serde::{Deserialize, Serialize};

use super::check::{bad, positive};
use crate::Result;

/// A printed chessboard under even light, placed by hand in front of the
/// cameras (`synth board`). Inner corners `inner = [COLS, ROWS]`; the board's
/// frame: origin at the first inner corner, x along COLS, y along ROWS,
/// z = 0 (into the board: a camera sees the printed face from z < 0); the
/// square diagonally outside the first corner (x, y ∈ [−s, 0]) is black.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardConfig {
    /// Inner corners along the board's x and y: [COLS, ROWS] (≥ 3 each).
    pub inner: [u32; 2],
    /// Side of a square (mm).
    pub square_mm: f64,
    /// White paper around the squares (in squares).
    pub margin_squares: f64,
    /// Radiance of the white paper (electrons per fully covered pixel).
    pub white_e: f64,
    /// Radiance of a black square.
    pub black_e: f64,
    /// Views of the board per camera.
    pub views_per_camera: u32,
    /// Largest random tilt of the board away from facing its cameras (deg).
    pub tilt_deg: f64,
    /// Largest random offset of the board's centre from the working point
    /// along each axis (mm).
    pub spread_mm: f64,
}

impl Default for BoardConfig {
    fn default() -> Self {
        Self {
            inner: [9, 6],
            square_mm: 12.0,
            margin_squares: 1.0,
            white_e: 9000.0,
            black_e: 600.0,
            views_per_camera: 15,
            tilt_deg: 15.0,
            spread_mm: 20.0,
        }
    }
}

/// Most inner corners along a side.
const MAX_INNER: u32 = 100;

impl BoardConfig {
    /// Check the board; the error names the key.
    pub(crate) fn validate(&self) -> Result<()> {
        let b = self;
        if b.inner.iter().any(|&n| !(3..=MAX_INNER).contains(&n)) {
            return Err(bad(
                "board.inner",
                format!("{:?}: each between 3 and {MAX_INNER}", b.inner),
            ));
        }
        positive("board.square_mm", b.square_mm)?;
        positive("board.white_e", b.white_e)?;
        if !(b.margin_squares.is_finite() && b.margin_squares >= 0.0) {
            return Err(bad("board.margin_squares", "must be finite and ≥ 0"));
        }
        if !(b.black_e.is_finite() && b.black_e >= 0.0 && b.black_e < b.white_e) {
            return Err(bad("board.black_e", "must be ≥ 0 and below white_e"));
        }
        if b.views_per_camera == 0 || b.views_per_camera > 1000 {
            return Err(bad("board.views_per_camera", "between 1 and 1000"));
        }
        if !(b.tilt_deg.is_finite() && (0.0..60.0).contains(&b.tilt_deg)) {
            return Err(bad("board.tilt_deg", "between 0 and 60"));
        }
        if !(b.spread_mm.is_finite() && b.spread_mm >= 0.0) {
            return Err(bad("board.spread_mm", "must be finite and ≥ 0"));
        }
        Ok(())
    }
}
