//! Which maps correct a frame (METHODS §6): a map is used only where its
//! own noise is at most `useful_noise_ratio` times the fixed pattern it
//! corrects, said with the numbers.
//!
//! A single flat at 30 000 DN (≈ 10⁴ e⁻) has ≈ 1 % shot noise per pixel, as
//! large as a 1 % PRNU: the smooth model is kept. The column/row pattern of
//! the dark is estimated from whole lines, so its noise is `√H` times
//! smaller than a pixel's, and it is often worth correcting when the
//! per-pixel dark is not.

use crate::calibrate::DarkModel;
use crate::pattern::DarkVariances;

/// The dark's fixed pattern, noise shares removed (DN), and what judges
/// its maps.
pub(crate) struct DarkPattern {
    /// Total DSNU.
    pub(crate) total: f64,
    /// Column DSNU.
    pub(crate) columns: f64,
    /// Row DSNU.
    pub(crate) rows: f64,
    /// The pixel pattern beyond the lines (DSNU without its temporal share
    /// when that is known; with it for a single frame).
    pixel: f64,
    /// σ of the line pattern per pixel, `√(σ²_col + σ²_row)`.
    lines: f64,
    /// Noise of the line pattern's estimate per pixel.
    lines_noise: f64,
    /// Noise of the per-pixel master dark (`None` for one frame).
    pixel_noise: Option<f64>,
}

impl DarkPattern {
    pub(crate) fn new(v: &DarkVariances, noise_dn: Option<f64>, w: usize, h: usize) -> Self {
        let temporal = noise_dn.map_or(0.0, |n| n * n);
        let (wf, hf) = (w.max(1) as f64, h.max(1) as f64);
        // A column mean holds 1/H of the residual's variance (pixel pattern
        // and noise), a row mean 1/W.
        let columns = (v.columns - v.residual / hf).max(0.0);
        let rows = (v.rows - v.residual / wf).max(0.0);
        Self {
            total: (v.total - temporal).max(0.0).sqrt(),
            columns: columns.sqrt(),
            rows: rows.sqrt(),
            pixel: (v.residual - temporal).max(0.0).sqrt(),
            lines: (columns + rows).sqrt(),
            lines_noise: (v.residual / hf + v.residual / wf).sqrt(),
            pixel_noise: noise_dn,
        }
    }

    /// The dark model and why, with the numbers.
    pub(crate) fn decide(&self, ratio: f64, frames: usize, black_dn: f64) -> (DarkModel, String) {
        let pixel_useful = self.pixel_noise.is_some_and(|n| n <= ratio * self.pixel);
        let lines_useful = self.lines > 0.0 && self.lines_noise <= ratio * self.lines;
        let verdict = |used: bool| if used { "used" } else { "not used" };
        let why_not = if lines_useful {
            String::new()
        } else {
            format!(": not ≤ {ratio} × the pattern")
        };
        let lines_text = format!(
            "column/row pattern {} ({:.2} DN, estimated to {:.2} DN from whole lines{why_not})",
            verdict(lines_useful),
            self.lines,
            self.lines_noise,
        );
        let pixel_text = match self.pixel_noise {
            Some(n) => format!(
                "per-pixel master dark {}: its noise {n:.2} DN ({frames} frames) is {} {ratio} × \
                 the pixel DSNU {:.2} DN it corrects beyond the column/row pattern",
                verdict(pixel_useful),
                if pixel_useful { "≤" } else { "not ≤" },
                self.pixel
            ),
            None => format!(
                "per-pixel master dark not used: a single dark frame, whose temporal noise \
                 cannot be measured and is part of its pixel pattern of {:.2} DN",
                self.pixel
            ),
        };
        if pixel_useful {
            (DarkModel::PerPixel, pixel_text)
        } else if lines_useful {
            (DarkModel::Lines, format!("{lines_text}; {pixel_text}"))
        } else {
            (
                DarkModel::Scalar,
                format!("scalar black level {black_dn:.1} DN only: {lines_text}; {pixel_text}"),
            )
        }
    }
}

/// Whether the gain map is used, and why, with the numbers.
pub(crate) fn decide_gain(
    ratio: f64,
    prnu: f64,
    noise: Option<f64>,
    flats: usize,
    darks: usize,
    signal_dn: f64,
) -> (bool, String) {
    match noise {
        Some(n) if n <= ratio * prnu => (
            true,
            format!(
                "per-pixel gain map used: its noise {:.3} % ({flats} flats at {signal_dn:.0} DN \
                 above {darks} darks) is ≤ {ratio} × the PRNU {:.3} % it corrects",
                n * 100.0,
                prnu * 100.0
            ),
        ),
        Some(n) => (
            false,
            format!(
                "smooth model kept, gain map not used: its noise {:.3} % ({flats} flats at \
                 {signal_dn:.0} DN above {darks} darks) is not ≤ {ratio} × the PRNU {:.3} % it \
                 would correct (dividing by it would trade the PRNU for a pattern of its own \
                 noise; more flats lower the noise as 1/√N)",
                n * 100.0,
                prnu * 100.0
            ),
        ),
        None => (
            false,
            format!(
                "smooth model kept, gain map not used: the noise of a gain map from {flats} \
                 flat(s) and {darks} dark(s) cannot be measured (that needs ≥ 2 of each), and a \
                 single flat's shot noise per pixel, 1/√electrons (≈ 1 % at 10 000 e⁻, as in a \
                 flat at 30 000 DN at 3 DN/e⁻), is as large as a typical PRNU; this map's \
                 spread, PRNU and noise together, is {:.3} %",
                prnu * 100.0
            ),
        ),
    }
}
