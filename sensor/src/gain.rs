//! The per-pixel gain map (METHODS §6): the master flat less the master
//! dark, divided by its smooth relative-illumination model and normalised
//! to median 1; what remains is `1 + g_px` (PRNU) plus the noise of the
//! stacks, whose share EMVA 1288 removes in quadrature.

use rayon::prelude::*;

use crate::order::median;
use crate::pattern::order_sample;
use crate::sums::{sum_rows, variance_of};
use crate::{Result, SensorError};

/// The noise a gain map inherits from its stacks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StackNoise {
    /// `σ²_y.dark`, temporal, per frame (DN²).
    pub(crate) dark_var_dn2: f64,
    /// K (DN/e⁻): the flat's temporal variance is `σ²_y.dark + K·s` at a
    /// signal of `s` DN above the dark.
    pub(crate) gain_dn_per_e: f64,
    /// Frames of the flat stack.
    pub(crate) flats: usize,
    /// Frames of the dark stack.
    pub(crate) darks: usize,
}

impl StackNoise {
    /// Relative variance of `(flat − dark)` at a signal of `s` DN:
    /// `(σ²_y.dark/N_f + K·s/N_f + σ²_y.dark/N_d)/s²`.
    fn relative_var(&self, s: f64) -> f64 {
        let (nf, nd) = (self.flats.max(1) as f64, self.darks.max(1) as f64);
        (self.dark_var_dn2 / nf + self.gain_dn_per_e * s / nf + self.dark_var_dn2 / nd) / (s * s)
    }
}

/// `(flat − dark)/smooth(x, y)` normalised to median 1. The smooth model
/// is evaluated pixel by pixel on this thread (it need not be `Sync`); it
/// must be positive and finite everywhere.
pub(crate) fn gain_map(
    flat: &[f32],
    dark: &[f32],
    width: usize,
    smooth: &dyn Fn(f64, f64) -> f64,
) -> Result<Vec<f32>> {
    let width = width.max(1);
    let mut raw = Vec::with_capacity(flat.len());
    for (i, (&f, &d)) in flat.iter().zip(dark).enumerate() {
        let (x, y) = (i % width, i / width);
        let model = smooth(x as f64, y as f64);
        if !(model.is_finite() && model > 0.0) {
            return Err(SensorError::SmoothModel {
                x: x as u32,
                y: y as u32,
                value: model,
            });
        }
        raw.push(((f64::from(f) - f64::from(d)) / model) as f32);
    }
    let centre = median(&mut order_sample(&raw)).unwrap_or(1.0);
    if !(centre.is_finite() && centre > 0.0) {
        return Err(SensorError::FlatDarkerThanDark {
            flat_dn: mean(flat),
            dark_dn: mean(dark),
        });
    }
    raw.par_iter_mut()
        .for_each(|g| *g = (f64::from(*g) / centre) as f32);
    Ok(raw)
}

/// Mean of a frame (summed in order).
fn mean(values: &[f32]) -> f64 {
    values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len().max(1) as f64
}

/// The spatial variance of the gain map over the good pixels, and the mean
/// relative noise variance it inherits from the stacks there (0 without a
/// noise model).
pub(crate) fn gain_variances(
    gain: &[f32],
    flat: &[f32],
    dark: &[f32],
    width: usize,
    noise: Option<&StackNoise>,
    good: &(dyn Fn(usize) -> bool + Sync),
) -> (f64, f64) {
    let width = width.max(1);
    let [n, d1, d2, noise_var] = sum_rows(gain.len() / width, |y| {
        let mut s = [0.0; 4];
        for (x, &g) in gain[y * width..(y + 1) * width].iter().enumerate() {
            let i = y * width + x;
            if !good(i) {
                continue;
            }
            let d = f64::from(g) - 1.0;
            let signal = f64::from(flat[i]) - f64::from(dark[i]);
            s[0] += 1.0;
            s[1] += d;
            s[2] += d * d;
            s[3] += noise.map_or(0.0, |m| m.relative_var(signal));
        }
        s
    });
    (variance_of(n, d1, d2), noise_var / n.max(1.0))
}
