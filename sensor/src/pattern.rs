//! The fixed pattern of a master dark (EMVA 1288 §8, DSNU): its black level,
//! its column and row offsets, and the pixel pattern that remains.
//!
//! `dark(x, y) = black + column[x] + row[y] + residual(x, y)`.

use rayon::prelude::*;

use crate::order::{median, median_and_sigma, quantile};
use crate::sums::{sum_rows, variance_of};

/// Order statistics of a whole frame are taken over at most this many
/// pixels (an even stride through the frame): 4 Mi pixels, the whole of
/// anything up to 2048 × 2048, and 32 MiB of scratch for the largest frame.
const MAX_ORDER_SAMPLES: usize = 1 << 22;

/// The line pattern of a dark frame.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Lines {
    /// The median of the frame (DN).
    pub(crate) black: f64,
    /// Offset of each column from `black` (DN).
    pub(crate) columns: Vec<f64>,
    /// Offset of each row from `black + column` (DN).
    pub(crate) rows: Vec<f64>,
}

impl Lines {
    /// `black + column[x] + row[y]`.
    pub(crate) fn at(&self, x: usize, y: usize) -> f64 {
        self.black + self.columns[x] + self.rows[y]
    }
}

/// Spatial variances of a master dark (DN²), good pixels only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct DarkVariances {
    /// Of all good pixels.
    pub(crate) total: f64,
    /// Of the column offsets (means over each column).
    pub(crate) columns: f64,
    /// Of the row offsets.
    pub(crate) rows: f64,
    /// Of the residual once both line patterns are removed.
    pub(crate) residual: f64,
}

/// Every `stride`-th value so that at most `MAX_ORDER_SAMPLES` remain.
pub(crate) fn order_sample(values: &[f32]) -> Vec<f64> {
    order_sample_of(values.len(), |i| f64::from(values[i]))
}

/// `value(i)` for every `stride`-th index of `0..n` so that at most
/// `MAX_ORDER_SAMPLES` remain.
fn order_sample_of(n: usize, value: impl Fn(usize) -> f64) -> Vec<f64> {
    let stride = n.div_ceil(MAX_ORDER_SAMPLES).max(1);
    (0..n).step_by(stride).map(value).collect()
}

/// The 1st percentile of a frame (on the order sample).
pub(crate) fn percentile1(values: &[f32]) -> f64 {
    quantile(&mut order_sample(values), 0.01).unwrap_or(0.0)
}

/// The line pattern by medians: robust to hot pixels and bright columns
/// alike (a column of hot pixels moves its median by nothing).
pub(crate) fn robust_lines(dark: &[f32], width: usize, height: usize) -> Lines {
    let black = median(&mut order_sample(dark)).unwrap_or(0.0);
    let columns: Vec<f64> = (0..width)
        .into_par_iter()
        .map(|x| {
            let mut col: Vec<f64> = (0..height)
                .map(|y| f64::from(dark[y * width + x]))
                .collect();
            median(&mut col).unwrap_or(black) - black
        })
        .collect();
    let rows: Vec<f64> = dark
        .par_chunks(width)
        .map(|row| {
            let mut r: Vec<f64> = row
                .iter()
                .zip(&columns)
                .map(|(&v, c)| f64::from(v) - c)
                .collect();
            median(&mut r).unwrap_or(black) - black
        })
        .collect();
    Lines {
        black,
        columns,
        rows,
    }
}

/// The line pattern by means over the good pixels (`good(i)`), about the
/// same black level: columns first, then rows of what the columns leave.
pub(crate) fn mean_lines(
    dark: &[f32],
    width: usize,
    height: usize,
    black: f64,
    good: &(dyn Fn(usize) -> bool + Sync),
) -> Lines {
    let columns: Vec<f64> = (0..width)
        .into_par_iter()
        .map(|x| {
            let (n, s) = (0..height)
                .map(|y| y * width + x)
                .filter(|&i| good(i))
                .fold((0usize, 0.0), |(n, s), i| (n + 1, s + f64::from(dark[i])));
            if n == 0 { 0.0 } else { s / n as f64 - black }
        })
        .collect();
    let rows: Vec<f64> = dark
        .par_chunks(width)
        .enumerate()
        .map(|(y, row)| {
            let (n, s) = row
                .iter()
                .enumerate()
                .filter(|&(x, _)| good(y * width + x))
                .fold((0usize, 0.0), |(n, s), (x, &v)| {
                    (n + 1, s + f64::from(v) - columns[x])
                });
            if n == 0 { 0.0 } else { s / n as f64 - black }
        })
        .collect();
    Lines {
        black,
        columns,
        rows,
    }
}

/// The robust σ (MAD) of the residual `dark − lines` (on the order sample).
pub(crate) fn residual_sigma(dark: &[f32], width: usize, lines: &Lines) -> f64 {
    let width = width.max(1);
    let mut residual = order_sample_of(dark.len(), |i| {
        f64::from(dark[i]) - lines.at(i % width, i / width)
    });
    median_and_sigma(&mut residual).map_or(0.0, |(_, s)| s)
}

/// The spatial variances of the dark over its good pixels, with `lines`
/// the mean line pattern of those pixels.
pub(crate) fn dark_variances(
    dark: &[f32],
    width: usize,
    lines: &Lines,
    good: &(dyn Fn(usize) -> bool + Sync),
) -> DarkVariances {
    let (total, residual) = good_pixel_variances(dark, width, lines, good);
    DarkVariances {
        total,
        columns: variance(&lines.columns),
        rows: variance(&lines.rows),
        residual,
    }
}

/// Variances of the good pixels' values and residuals (sums about the
/// black level).
fn good_pixel_variances(
    dark: &[f32],
    width: usize,
    lines: &Lines,
    good: &(dyn Fn(usize) -> bool + Sync),
) -> (f64, f64) {
    let width = width.max(1);
    let [n, d1, d2, r1, r2] = sum_rows(dark.len() / width, |y| {
        let mut s = [0.0; 5];
        for (x, &v) in dark[y * width..(y + 1) * width].iter().enumerate() {
            if !good(y * width + x) {
                continue;
            }
            let (d, r) = (f64::from(v) - lines.black, f64::from(v) - lines.at(x, y));
            s[0] += 1.0;
            s[1] += d;
            s[2] += d * d;
            s[3] += r;
            s[4] += r * r;
        }
        s
    });
    (variance_of(n, d1, d2), variance_of(n, r1, r2))
}

/// Population variance of a set of offsets.
fn variance(values: &[f64]) -> f64 {
    crate::order::mean_var(values.iter().copied()).map_or(0.0, |(_, v)| v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_recovered_and_a_hot_pixel_does_not_move_them() {
        let (w, h) = (6usize, 5usize);
        let cols = [0.0, 3.0, -2.0, 50.0, 0.0, 1.0];
        let rows = [0.0, 1.0, -1.0, 0.0, 2.0];
        let mut dark: Vec<f32> = (0..w * h)
            .map(|i| (100.0 + cols[i % w] + rows[i / w]) as f32)
            .collect();
        // In the row whose offset is above the column median: a hot pixel
        // moves a median by at most one rank, here by nothing.
        dark[4 * w + 4] += 1000.0;
        let lines = robust_lines(&dark, w, h);
        for (x, c) in cols.iter().enumerate() {
            assert!((lines.at(x, 0) - lines.at(0, 0) - c).abs() < 1e-9);
        }
        for (y, r) in rows.iter().enumerate() {
            assert!((lines.at(0, y) - lines.at(0, 0) - r).abs() < 1e-9);
        }
        assert!(residual_sigma(&dark, w, &lines) < 1e-9);
    }
}
