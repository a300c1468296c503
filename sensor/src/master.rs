//! The master frame of a stack: an outlier-robust per-pixel mean (the
//! master dark / flat of EMVA 1288 and astronomy), its temporal noise and
//! level.
//!
//! Memory: the caller holds the stack, `N·W·H·2` bytes; the master adds
//! `W·H·4` bytes (its f32 mean, which first holds the per-pixel medians) and
//! `W·H` bytes (the saturation mask) while it is made.

use rayon::prelude::*;

use crate::adc::adc_depth;
use crate::frame::Frame;
use crate::order::{MAD_TO_SIGMA, median};
use crate::sums::sum_rows;
use crate::temporal::{NoiseModel, temporal_noise};
use crate::{Result, SensorError};

/// A sample farther than this many σ from its pixel's median is an outlier
/// (a cosmic or stray event): a Gaussian sample exceeds 5σ with probability
/// 6·10⁻⁷, so a 16-frame stack of 12 Mpx loses about 100 good samples of
/// 2·10⁸, while a spike of a few hundred DN above a read noise of 20 DN is
/// always caught.
const OUTLIER_SIGMAS: f64 = 5.0;
/// From this many frames the pixel's own spread (MAD) also sets its σ, so
/// that a pixel noisier than its level predicts (a hot pixel's dark-current
/// shot noise) keeps its samples; with fewer the MAD is too uncertain.
const OWN_SPREAD_FRAMES: usize = 5;

/// Outlier-robust per-pixel mean of a stack and its statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct Master {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Per-pixel robust mean (DN), row-major.
    pub mean: Vec<f32>,
    /// Frames in the stack.
    pub frames: usize,
    /// Samples rejected as outliers (cosmic or stray events).
    pub rejected: usize,
    /// `μ_y`: mean over the pixels of the master, those saturated in any
    /// frame left out (all pixels when every one is saturated) (DN).
    pub level_dn: f64,
    /// `σ²_y`: mean over consecutive pairs of `½·var(A − B)` (DN²); `None`
    /// for a single frame.
    pub temporal_var_dn2: Option<f64>,
    /// Fraction of pixels at the saturation value in any frame.
    pub saturated_fraction: f64,
}

impl Master {
    /// Per-pixel noise of the master, `√(σ²_y / N)` (DN); `None` for one
    /// frame.
    pub fn noise_dn(&self) -> Option<f64> {
        self.temporal_var_dn2
            .map(|v| (v / self.frames.max(1) as f64).sqrt())
    }

    /// Per-frame temporal noise `σ_y` (DN); `None` for one frame.
    pub fn temporal_dn(&self) -> Option<f64> {
        self.temporal_var_dn2.map(f64::sqrt)
    }
}

/// The robust mean of each pixel over the stack: for ≥ 3 frames, samples
/// farther than 5σ from the pixel's median are left out, σ from the stack's
/// temporal noise at the pixel's level (and from ≥ 5 frames at least the
/// pixel's own MAD spread); for 2 frames the plain mean. `saturation` is the
/// value (DN) at which a pixel counts as saturated.
///
/// The frames must be of one size (see [`crate::check_stack`]); the error
/// names the first that is not.
pub fn master(frames: &[Frame<'_>], saturation: u16) -> Result<Master> {
    let first = check_shape(frames)?;
    let (width, height) = (first.width, first.height);
    let row = width as usize;
    let (mut mean, saturated) = medians(frames, saturation, row);
    // A difference of two quantised values is at least one ADC step: the
    // model's variance never goes below step².
    let floor = adc_depth(frames).step_dn().powi(2);
    let temporal = temporal_noise(frames, &mean, &saturated, floor);
    let rejected = match temporal {
        Some(t) if frames.len() >= 3 => robust_means(frames, &t.model, &mut mean, row),
        _ => {
            plain_means(frames, &mut mean, row);
            0
        }
    };
    let pixels = mean.len().max(1);
    let saturated_count = saturated.iter().filter(|&&s| s).count();
    Ok(Master {
        width,
        height,
        level_dn: level(&mean, &saturated, row),
        mean,
        frames: frames.len(),
        rejected,
        temporal_var_dn2: temporal.map(|t| t.var_dn2),
        saturated_fraction: saturated_count as f64 / pixels as f64,
    })
}

/// Frame 0 when every frame has its size and the values for it.
fn check_shape<'f, 'a>(frames: &'f [Frame<'a>]) -> Result<&'f Frame<'a>> {
    let first = frames
        .first()
        .ok_or_else(|| SensorError::InconsistentStack {
            frame: 0,
            message: "the stack has no frames".into(),
        })?;
    for (index, f) in frames.iter().enumerate() {
        if (f.width, f.height) != (first.width, first.height)
            || f.values.len() != first.pixels()
            || first.pixels() == 0
        {
            return Err(SensorError::InconsistentStack {
                frame: index,
                message: format!(
                    "{}×{} px with {} values where frame 0 is {}×{} px",
                    f.width,
                    f.height,
                    f.values.len(),
                    first.width,
                    first.height
                ),
            });
        }
    }
    Ok(first)
}

/// Each pixel's median over the stack and whether it reaches `saturation`
/// in any frame.
fn medians(frames: &[Frame<'_>], saturation: u16, row: usize) -> (Vec<f32>, Vec<bool>) {
    let pixels = frames.first().map_or(0, Frame::pixels);
    let mut levels = vec![0f32; pixels];
    let mut saturated = vec![false; pixels];
    levels
        .par_chunks_mut(row)
        .zip(saturated.par_chunks_mut(row))
        .enumerate()
        .for_each(|(y, (levels, saturated))| {
            let mut samples = Vec::with_capacity(frames.len());
            for (x, (level, sat)) in levels.iter_mut().zip(saturated.iter_mut()).enumerate() {
                let i = y * row + x;
                samples.clear();
                samples.extend(frames.iter().map(|f| f.values[i]));
                samples.sort_unstable();
                *sat = samples.last().is_some_and(|&v| v >= saturation);
                *level = sorted_median(&samples);
            }
        });
    (levels, saturated)
}

/// The median of sorted integers (exact in f32: at most 2¹⁶ in halves).
fn sorted_median(sorted: &[u16]) -> f32 {
    let n = sorted.len();
    match n {
        0 => 0.0,
        _ if n % 2 == 1 => f32::from(sorted[n / 2]),
        _ => 0.5 * (f32::from(sorted[n / 2 - 1]) + f32::from(sorted[n / 2])),
    }
}

/// Replace each pixel's median (in `mean`) by the mean of its samples
/// within `OUTLIER_SIGMAS`·σ of it; returns the number left out.
fn robust_means(frames: &[Frame<'_>], model: &NoiseModel, mean: &mut [f32], row: usize) -> usize {
    mean.par_chunks_mut(row)
        .enumerate()
        .map(|(y, levels)| {
            let mut samples = Vec::with_capacity(frames.len());
            let mut spread = Vec::with_capacity(frames.len());
            let mut rejected = 0;
            for (x, level) in levels.iter_mut().enumerate() {
                let i = y * row + x;
                samples.clear();
                samples.extend(frames.iter().map(|f| f64::from(f.values[i])));
                let centre = f64::from(*level);
                let model_sigma = model.variance(centre).sqrt();
                let sigma = if samples
                    .iter()
                    .all(|v| (v - centre).abs() <= OUTLIER_SIGMAS * model_sigma)
                {
                    model_sigma
                } else {
                    pixel_sigma(model_sigma, centre, &samples, &mut spread)
                };
                let (n, sum) = samples
                    .iter()
                    .filter(|&&v| (v - centre).abs() <= OUTLIER_SIGMAS * sigma)
                    .fold((0usize, 0.0), |(n, s), &v| (n + 1, s + v));
                rejected += samples.len() - n;
                if n > 0 {
                    *level = (sum / n as f64) as f32;
                }
            }
            rejected
        })
        .sum()
}

/// σ of one pixel's samples: the model's at its level, or the samples' own
/// MAD spread about `centre` when larger and there are enough of them.
fn pixel_sigma(sigma: f64, centre: f64, samples: &[f64], spread: &mut Vec<f64>) -> f64 {
    if samples.len() < OWN_SPREAD_FRAMES {
        return sigma;
    }
    spread.clear();
    spread.extend(samples.iter().map(|v| (v - centre).abs()));
    let own = median(spread).map_or(0.0, |mad| MAD_TO_SIGMA * mad);
    sigma.max(own)
}

/// The plain mean of each pixel's samples.
fn plain_means(frames: &[Frame<'_>], mean: &mut [f32], row: usize) {
    let n = frames.len().max(1) as f64;
    mean.par_chunks_mut(row).enumerate().for_each(|(y, out)| {
        for (x, m) in out.iter_mut().enumerate() {
            let i = y * row + x;
            let sum: f64 = frames.iter().map(|f| f64::from(f.values[i])).sum();
            *m = (sum / n) as f32;
        }
    });
}

/// `μ_y`: the mean of the master over the pixels not saturated (over all
/// when none is left).
fn level(mean: &[f32], saturated: &[bool], row: usize) -> f64 {
    let [n, sum, all] = sum_rows(mean.len() / row.max(1), |y| {
        let range = y * row..(y + 1) * row;
        let mut s = [0.0; 3];
        for (&v, &sat) in mean[range.clone()].iter().zip(&saturated[range]) {
            s[2] += f64::from(v);
            if !sat {
                s[0] += 1.0;
                s[1] += f64::from(v);
            }
        }
        s
    });
    if n > 0.0 {
        sum / n
    } else {
        all / mean.len().max(1) as f64
    }
}
