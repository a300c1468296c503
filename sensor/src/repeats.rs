//! The system gain K from the measurement images themselves, when no flat
//! and dark stacks were taken: photon transfer (EMVA 1288 §6,
//! `σ²_y = ½·var(A − B)` against `μ_y = (A + B)/2`) on pairs of repeated
//! captures of one instant — the background and the spheres' flat interiors
//! give levels far apart, and the slope of `σ²_y` over them is K.
//!
//! Only locally flat pixels take part: where the image has a gradient, a
//! small motion between the two captures (the machine's repeatability, the
//! renderer's capture jitter) adds `(∇f·δ)²` to the difference. A pixel is
//! flat when the range of the pair's mean over its 3×3 neighbourhood is
//! within [`FLAT_RANGE_SIGMAS`] of the mean's noise at its level (from a
//! first fit over every pixel of the pair); the mean `(A + B)/2` is
//! independent of `A − B` for Gaussian noise of equal variance, so this
//! choice does not bias the variance of the differences it keeps.
//!
//! The pairs are taken one at a time ([`RepeatGainEstimate`]): each pair's
//! flat pixels and outliers are judged against the pair's own fit, and only
//! its sums per level bin are kept, so memory holds one pair's frames.

use rayon::prelude::*;

use crate::adc::{depth_of, values_or};
use crate::frame::{Frame, StackKind, check_frame, check_same_camera};
use crate::temporal::{
    BinSums, Levels, NoiseModel, Pair, Pooling, fit_sums, mean_level, pairs_noise,
};
use crate::{Result, SensorError};

/// The 3×3 range of a flat pixel's pair mean is at most this many σ of the
/// mean (σ/√2): the range of 9 normal samples exceeds 6σ with probability
/// ≈ 5·10⁻⁴, while a 0.05 px motion on a gradient this steep adds at most
/// (6·σ/√2 /2 · 0.05)² ≈ 0.6 % of σ² to a difference.
const FLAT_RANGE_SIGMAS: f64 = 6.0;

/// The fitted levels must span at least this many σ of the background's
/// temporal noise: two bins of the background's own noise spread (a span of
/// a few σ) show a slope from noise alone, never K.
const MIN_SPAN_SIGMAS: f64 = 20.0;

/// K and the background's temporal noise from repeated captures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepeatGain {
    /// K: the slope of `σ²_y` against `μ_y` (DN/e⁻).
    pub gain_dn_per_e: f64,
    /// The background: the median level of the flat pixels of the first
    /// pair (most of a measurement image is background) (DN).
    pub background_level_dn: f64,
    /// `σ_y` at that level from the fitted line, temporal, per frame (DN).
    pub background_temporal_dn: f64,
    /// The highest level the fit saw (DN).
    pub top_level_dn: f64,
    /// Pixel differences used (flat, not saturated, not clipped), over all pairs.
    pub pixels: u64,
    /// Pairs used.
    pub pairs: usize,
}

/// K from pairs `(A, B)` of repeated captures of one instant each (the
/// same camera and setting; pairs of different instants may be pooled):
/// [`RepeatGainEstimate`] over the pairs in turn.
pub fn gain_from_repeats(pairs: &[(Frame<'_>, Frame<'_>)], saturation: u16) -> Result<RepeatGain> {
    let mut estimate = RepeatGainEstimate::new(saturation);
    for (a, b) in pairs {
        estimate.add_pair(a, b)?;
    }
    estimate.finish()
}

/// K from pairs of repeated captures given one at a time, so that only one
/// pair's frames are held (two pairs of full frames are 100 MB): each
/// pair's photon transfer over its locally flat pixels not saturated (at
/// `saturation` DN in either frame) — the flat pixels chosen, and outliers
/// clipped, against the pair's own fit — its sums per level bin kept, and
/// the line fitted to the sums of all pairs at the end.
#[derive(Debug, Clone)]
pub struct RepeatGainEstimate {
    saturation: u16,
    /// The first frame's size and depth, its values left out.
    first: Option<Frame<'static>>,
    /// The OR of every value (the ADC depth).
    all: u16,
    /// Each pair's differences per level bin.
    sums: Vec<Vec<BinSums>>,
    /// The median level of the first pair's flat pixels.
    background: Option<f64>,
}

impl RepeatGainEstimate {
    /// No pairs yet; pixels at `saturation` DN are left out.
    pub fn new(saturation: u16) -> Self {
        Self {
            saturation,
            first: None,
            all: 0,
            sums: Vec::new(),
            background: None,
        }
    }

    /// Takes in a pair `(a, b)` of repeated captures. Refuses frames of
    /// another size or depth than the first pair's.
    pub fn add_pair(&mut self, a: &Frame<'_>, b: &Frame<'_>) -> Result<()> {
        let kind = StackKind::Repeat;
        let index = 2 * self.sums.len();
        let first = *self.first.get_or_insert(Frame { values: &[], ..*a });
        for (j, f) in [a, b].into_iter().enumerate() {
            check_frame(f, kind, index + j)?;
            check_same_camera(f, kind, index + j, &first, kind)?;
        }
        let pair_or = values_or(&[*a, *b]);
        self.all |= pair_or;
        let floor = depth_of(first.container_bits, pair_or).step_dn().powi(2);
        let fit = |excluded: &[bool]| {
            let pair = Pair {
                a: a.values,
                b: b.values,
                levels: Levels::Mean,
                excluded,
            };
            pairs_noise(
                &[pair],
                first.width,
                first.container_bits,
                floor,
                Pooling::DegreesOfFreedom,
            )
            .ok_or(no_gain(0.0, 0.0, 0))
        };
        // Each pixel's level, the pair's mean (A + B)/2, is computed where
        // it is needed, not held; one mask serves both fits.
        let mut excluded = saturated_pixels(a.values, b.values, self.saturation);
        let rough = fit(&excluded)?;
        exclude_not_flat(
            a.values,
            b.values,
            &mut excluded,
            first.width,
            &rough.temporal.model,
        );
        let fine = fit(&excluded)?;
        if self.background.is_none() {
            self.background = median_level(a.values, b.values, &excluded);
        }
        self.sums.extend(fine.sums);
        Ok(())
    }

    /// K from the pairs taken in: refuses none, and images without two
    /// levels far enough apart to show a rise of the noise (no flat bright
    /// region).
    pub fn finish(self) -> Result<RepeatGain> {
        let Some(first) = self.first else {
            return Err(SensorError::EmptyStack {
                kind: StackKind::Repeat,
            });
        };
        let floor = depth_of(first.container_bits, self.all).step_dn().powi(2);
        let (fine, _) = fit_sums(&self.sums, floor, Pooling::DegreesOfFreedom);
        let (low, high) = fine.model.levels();
        let gain = fine.model.slope();
        let background = self.background.unwrap_or(low);
        let sigma = fine.model.variance(background).sqrt();
        if !(gain > 0.0 && high - low > MIN_SPAN_SIGMAS * sigma) {
            return Err(no_gain(low, high, fine.samples));
        }
        Ok(RepeatGain {
            gain_dn_per_e: gain,
            background_level_dn: background,
            background_temporal_dn: sigma,
            top_level_dn: high,
            pixels: fine.samples,
            pairs: self.sums.len(),
        })
    }
}

/// The median level (A + B)/2 of the pixels not `excluded`, `None` for
/// none. The levels are half-integers, so they are counted by A + B (one
/// counter for each of the 2¹⁷ − 1 sums, not a copy of the pixels): the
/// middle value, or the mean of the two middle values.
fn median_level(a: &[u16], b: &[u16], excluded: &[bool]) -> Option<f64> {
    let mut counts = vec![0u64; 2 * usize::from(u16::MAX) + 1];
    for ((&x, &y), &out) in a.iter().zip(b).zip(excluded) {
        if !out {
            counts[usize::from(x) + usize::from(y)] += 1;
        }
    }
    let n: u64 = counts.iter().sum();
    if n == 0 {
        return None;
    }
    // The level of rank r (from 0) in ascending order.
    let at = |rank: u64| {
        let mut seen = 0;
        counts.iter().position(|&c| {
            seen += c;
            seen > rank
        })
    };
    let level = |sum: usize| sum as f64 / 2.0;
    let upper = level(at(n / 2)?);
    if n % 2 == 1 {
        return Some(upper);
    }
    Some(0.5 * (level(at(n / 2 - 1)?) + upper))
}

fn no_gain(low: f64, high: f64, pixels: u64) -> SensorError {
    SensorError::NoGainFromRepeats {
        low_dn: low,
        high_dn: high,
        pixels,
    }
}

/// Whether each pixel is saturated in either frame.
fn saturated_pixels(a: &[u16], b: &[u16], saturation: u16) -> Vec<bool> {
    a.par_iter()
        .zip(b)
        .map(|(&x, &y)| x >= saturation || y >= saturation)
        .collect()
}

/// Leaves out of the fine fit, beside the pixels `excluded` already
/// (saturated ones), the frame's border and the pixels whose 3×3 range of
/// levels `(A + B)/2` exceeds [`FLAT_RANGE_SIGMAS`]·σ of the level
/// (`σ² = model(level)/2`).
fn exclude_not_flat(a: &[u16], b: &[u16], excluded: &mut [bool], width: u32, model: &NoiseModel) {
    let w = width as usize;
    let h = a.len() / w.max(1);
    let level = |i: usize| mean_level(a[i], b[i]);
    excluded.par_iter_mut().enumerate().for_each(|(i, out)| {
        let (x, y) = (i % w, i / w);
        if *out || x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
            *out = true;
            return;
        }
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for row in y - 1..=y + 1 {
            for j in row * w + x - 1..=row * w + x + 1 {
                let l = level(j);
                lo = lo.min(l);
                hi = hi.max(l);
            }
        }
        let sigma = (model.variance(f64::from(level(i))) / 2.0).sqrt();
        *out = f64::from(hi - lo) > FLAT_RANGE_SIGMAS * sigma;
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counted median of the levels (A + B)/2 is the sorted one, for an
    /// odd and an even number of pixels kept, and none for none.
    #[test]
    fn the_counted_median_level_is_the_sorted_one() {
        let mut state = 7u64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 33) as u16
        };
        let a: Vec<u16> = (0..1001).map(|_| next()).collect();
        let b: Vec<u16> = (0..1001).map(|_| next() / 7).collect();
        for keep_every in [2, 3] {
            let excluded: Vec<bool> = (0..a.len()).map(|i| i % keep_every != 0).collect();
            let mut kept: Vec<f64> = a
                .iter()
                .zip(&b)
                .zip(&excluded)
                .filter(|(_, out)| !**out)
                .map(|((&x, &y), _)| f64::from(mean_level(x, y)))
                .collect();
            let n = kept.len();
            assert_eq!(
                median_level(&a, &b, &excluded),
                crate::order::median(&mut kept),
                "{n} pixels"
            );
        }
        assert_eq!(median_level(&a, &b, &vec![true; a.len()]), None);
    }
}
