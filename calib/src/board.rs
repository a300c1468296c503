//! Printed chessboards in calibration views (`calibrate --views --board
//! chessboard:COLSxROWS:SQUARE_MM`, docs/methods.md §8): the board's inner
//! corners as a planar target, and the corners found in a view.
//!
//! Corners are found by the `calib-targets` crate (ChESS corners, then the
//! labelled grid of one board); this module maps its grid labels to corner
//! ids. The board's frame: origin at the first inner corner, x along COLS,
//! y along ROWS, z = 0 into the board (the printed face is seen from
//! z < 0); corner (i, j) has id `1 + j·COLS + i`; the square diagonally
//! outside the first corner is black. Of the labellings that fit the board's
//! extent, the one kept shows the board's x → y turn clockwise in the image
//! (the printed face seen from the front) and has the square outside corner
//! (0, 0) darker than its neighbour outside corner (1, 0)'s edge — which,
//! with COLS + ROWS odd, tells the board from itself turned by 180°. Such a
//! board is symmetric under a reflection (about its middle line along the
//! even count), so a mirrored image is an image of the board too: a view
//! seen through the paper cannot be told from the pattern (a ChArUco board's
//! markers can), only by its disagreement with the other views.

use calib_targets::chessboard::ChessboardParams;
use calib_targets::detect;
use calib_targets::image::GrayImage;
use formats::{CorrespondenceRow, TargetRow};
use geom::Point2;

use crate::{BoardProblem, CalibError, Result};

/// A printed chessboard: inner corners and square size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    /// Inner corners along the board's x.
    pub cols: u32,
    /// Inner corners along the board's y.
    pub rows: u32,
    /// Side of a square (mm).
    pub square_mm: f64,
}

impl Board {
    /// Parse `chessboard:COLSxROWS:SQUARE_MM`.
    pub fn parse(spec: &str) -> Result<Self> {
        let bad = || CalibError::Board(BoardProblem::Spec(spec.to_string()));
        let mut parts = spec.split(':');
        let (Some("chessboard"), Some(grid), Some(square), None) =
            (parts.next(), parts.next(), parts.next(), parts.next())
        else {
            return Err(bad());
        };
        let (cols, rows) = grid.split_once(['x', 'X', '×']).ok_or_else(bad)?;
        let cols: u32 = cols.trim().parse().map_err(|_| bad())?;
        let rows: u32 = rows.trim().parse().map_err(|_| bad())?;
        let square_mm: f64 = square.trim().parse().map_err(|_| bad())?;
        if cols < 3
            || rows < 3
            || cols > 200
            || rows > 200
            || !(square_mm.is_finite() && square_mm > 0.0)
        {
            return Err(bad());
        }
        if (cols + rows).is_multiple_of(2) {
            return Err(CalibError::Board(BoardProblem::Symmetric { cols, rows }));
        }
        Ok(Self {
            cols,
            rows,
            square_mm,
        })
    }

    /// The inner corners as a planar target (`id,x,y,z`, z = 0).
    pub fn target(&self) -> Vec<TargetRow> {
        (0..self.rows)
            .flat_map(|j| {
                (0..self.cols).map(move |i| TargetRow {
                    id: 1 + j * self.cols + i,
                    x: f64::from(i) * self.square_mm,
                    y: f64::from(j) * self.square_mm,
                    z: 0.0,
                    diameter: None,
                    u_mm: None,
                })
            })
            .collect()
    }
}

/// A gray image as the detector takes it: 8-bit, the frame's levels from
/// its 0.5th to its 99.5th percentile spread over 0–255.
fn gray(width: u32, height: u32, pixels: &[u16]) -> GrayImage {
    let mut sorted: Vec<u16> = pixels.iter().step_by(7).copied().collect();
    sorted.sort_unstable();
    let at = |q: f64| f64::from(sorted[((sorted.len() - 1) as f64 * q) as usize]);
    let (lo, hi) = if sorted.is_empty() {
        (0.0, 1.0)
    } else {
        (at(0.005), at(0.995).max(at(0.005) + 1.0))
    };
    let data = pixels
        .iter()
        .map(|&p| {
            (255.0 * (f64::from(p) - lo) / (hi - lo))
                .clamp(0.0, 255.0)
                .round() as u8
        })
        .collect();
    GrayImage::from_raw(width, height, data).unwrap_or_else(|| GrayImage::new(width, height))
}

/// Bilinear sample of `img` at `p` (gray levels), `None` outside.
fn sample(img: &GrayImage, p: Point2<f64>) -> Option<f64> {
    let (w, h) = (f64::from(img.width()), f64::from(img.height()));
    if !(p.x >= 0.0 && p.y >= 0.0 && p.x < w - 1.0 && p.y < h - 1.0) {
        return None;
    }
    let (x0, y0) = (p.x.floor(), p.y.floor());
    let (fx, fy) = (p.x - x0, p.y - y0);
    let g = |x: f64, y: f64| f64::from(img.get_pixel(x as u32, y as u32).0[0]);
    Some(
        (1.0 - fx) * (1.0 - fy) * g(x0, y0)
            + fx * (1.0 - fy) * g(x0 + 1.0, y0)
            + (1.0 - fx) * fy * g(x0, y0 + 1.0)
            + fx * fy * g(x0 + 1.0, y0 + 1.0),
    )
}

/// A labelling of the detected grid: (u, v, a, b) → (i, j), (u, v) ∈ [0, a] × [0, b].
type Labelling = fn(i32, i32, i32, i32) -> (i32, i32);

/// Least contrast (8-bit gray levels) between the two squares sampled to
/// tell the board's orientation.
const MIN_CONTRAST: f64 = 20.0;

/// The board's inner corners in one view (`width` × `height` pixels,
/// row-major, any bit depth), as `id,u,v` rows by id; an error says why the
/// view cannot be used (not found, found partially, mirrored).
pub fn find_board(
    board: &Board,
    width: u32,
    height: u32,
    pixels: &[u16],
) -> Result<Vec<CorrespondenceRow>> {
    let img = gray(width, height, pixels);
    let params = ChessboardParams::default();
    // ChESS corners refined by a saddle-point fit to the image patch.
    let mut chess = detect::default_chess_config();
    chess.refiner = Some(detect::ImageRefiner::saddle_point());
    let found = detect::detect_chessboard(&img, &chess, &params)
        .map_err(|e| CalibError::Board(BoardProblem::NotFound(e.to_string())))?;
    let corners: Vec<(i32, i32, Point2<f64>)> = found
        .corners
        .iter()
        .map(|c| {
            (
                c.grid.u,
                c.grid.v,
                Point2::new(f64::from(c.position.x), f64::from(c.position.y)),
            )
        })
        .collect();
    let (cols, rows) = (board.cols as i32, board.rows as i32);
    let (umin, umax) = extent(corners.iter().map(|c| c.0));
    let (vmin, vmax) = extent(corners.iter().map(|c| c.1));
    let expected = (board.cols * board.rows) as usize;
    let fits = |a: i32, b: i32| a == cols - 1 && b == rows - 1;
    let (du, dv) = (umax - umin, vmax - vmin);
    if corners.len() != expected || !(fits(du, dv) || fits(dv, du)) {
        return Err(CalibError::Board(BoardProblem::Partial {
            found: corners.len(),
            expected,
            extent: format!("{} × {} corners", du + 1, dv + 1),
        }));
    }
    // The eight labellings (i, j) of (u, v) ∈ [0, a] × [0, b]: the turns and
    // mirrors; those that do not fit the board leave a corner unlabelled.
    let labellings: [Labelling; 8] = [
        |u, v, _, _| (u, v),
        |u, v, a, b| (a - u, b - v),
        |u, v, a, _| (v, a - u),
        |u, v, _, b| (b - v, u),
        |u, v, a, _| (a - u, v),
        |u, v, _, b| (u, b - v),
        |u, v, _, _| (v, u),
        |u, v, a, b| (b - v, a - u),
    ];
    let mut weakest = f64::INFINITY;
    for label in labellings {
        let mut at = vec![None; expected];
        for &(u, v, p) in &corners {
            let (i, j) = label(u - umin, v - vmin, du, dv);
            if (0..cols).contains(&i) && (0..rows).contains(&j) {
                at[(j * cols + i) as usize] = Some(p);
            }
        }
        let Some(at) = at.into_iter().collect::<Option<Vec<_>>>() else {
            continue;
        };
        let c = |i: i32, j: i32| at[(j * cols + i) as usize];
        let (o, x, y) = (c(0, 0), c(1, 0) - c(0, 0), c(0, 1) - c(0, 0));
        let clockwise = x.x * y.y - x.y * y.x > 0.0;
        // The square outside corner (0, 0) (black) against the one beside it
        // along the board's y (x ∈ [0, s], y ∈ [−s, 0]: white).
        let dark = sample(&img, o - 0.5 * x - 0.5 * y);
        let light = sample(&img, o + 0.5 * x - 0.5 * y);
        let (Some(dark), Some(light)) = (dark, light) else {
            continue;
        };
        let contrast = light - dark;
        if contrast.abs() < MIN_CONTRAST {
            weakest = weakest.min(contrast.abs());
            continue;
        }
        if contrast < 0.0 || !clockwise {
            continue;
        }
        return Ok(at
            .iter()
            .enumerate()
            .map(|(k, p)| CorrespondenceRow {
                id: 1 + k as u32,
                u: p.x,
                v: p.y,
            })
            .collect());
    }
    Err(CalibError::Board(BoardProblem::Orientation {
        contrast: if weakest.is_finite() { weakest } else { 0.0 },
    }))
}

/// Smallest and largest of non-empty values.
fn extent(values: impl Iterator<Item = i32>) -> (i32, i32) {
    values.fold((i32::MAX, i32::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)))
}
