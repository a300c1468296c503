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
//! first fit over every pixel); the mean `(A + B)/2` is independent of
//! `A − B` for Gaussian noise of equal variance, so this choice does not
//! bias the variance of the differences it keeps.

use rayon::prelude::*;

use crate::adc::adc_depth;
use crate::frame::{Frame, StackKind, check_frame, check_same_camera};
use crate::temporal::{Levels, NoiseModel, Pair, Pooling, mean_level, pairs_noise};
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
/// the photon transfer of the module docs over the locally flat pixels, not
/// saturated (at `saturation` DN in either frame). Refuses frames of
/// different sizes or depths, and images without two levels far enough
/// apart to show a rise of the noise (no flat bright region).
pub fn gain_from_repeats(pairs: &[(Frame<'_>, Frame<'_>)], saturation: u16) -> Result<RepeatGain> {
    let (first, _) = pairs.first().ok_or(SensorError::EmptyStack {
        kind: StackKind::Repeat,
    })?;
    let kind = StackKind::Repeat;
    for (index, (a, b)) in pairs.iter().enumerate() {
        for (j, f) in [a, b].into_iter().enumerate() {
            check_frame(f, kind, 2 * index + j)?;
            check_same_camera(f, kind, 2 * index + j, first, kind)?;
        }
    }
    let all: Vec<Frame<'_>> = pairs.iter().flat_map(|(a, b)| [*a, *b]).collect();
    let floor = adc_depth(&all).step_dn().powi(2);
    let (width, bits) = (first.width, first.container_bits);
    // Each pixel's level, the pair's mean (A + B)/2, is computed where it
    // is needed, not held: two pairs of full frames are 100 MB already.
    let saturated: Vec<Vec<bool>> = pairs
        .iter()
        .map(|(a, b)| saturated_pixels(a.values, b.values, saturation))
        .collect();
    // The photon transfer over the pixels not masked out.
    let fit = |masks: &[Vec<bool>]| {
        pairs_noise(
            &with_masks(pairs, masks),
            width,
            bits,
            floor,
            Pooling::DegreesOfFreedom,
        )
        .ok_or(no_gain(0.0, 0.0, 0))
    };
    let rough = fit(&saturated)?;
    let flat: Vec<Vec<bool>> = pairs
        .iter()
        .zip(&saturated)
        .map(|((a, b), saturated)| not_flat(a.values, b.values, saturated, width, &rough.model))
        .collect();
    drop(saturated);
    let fine = fit(&flat)?;
    let (low, high) = fine.model.levels();
    let gain = fine.model.slope();
    let background = pairs
        .first()
        .zip(flat.first())
        .and_then(|((a, b), out)| median_level(a.values, b.values, out))
        .unwrap_or(low);
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
        pairs: pairs.len(),
    })
}

/// The pairs, binned by their mean levels, each with its mask of pixels
/// left out.
fn with_masks<'a>(pairs: &'a [(Frame<'a>, Frame<'a>)], masks: &'a [Vec<bool>]) -> Vec<Pair<'a>> {
    pairs
        .iter()
        .zip(masks)
        .map(|((a, b), excluded)| Pair {
            a: a.values,
            b: b.values,
            levels: Levels::Mean,
            excluded,
        })
        .collect()
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

/// The pixels to leave out of the fine fit: saturated ones, the frame's
/// border, and those whose 3×3 range of levels `(A + B)/2` exceeds
/// [`FLAT_RANGE_SIGMAS`]·σ of the level (`σ² = model(level)/2`).
fn not_flat(a: &[u16], b: &[u16], saturated: &[bool], width: u32, model: &NoiseModel) -> Vec<bool> {
    let w = width as usize;
    let h = a.len() / w.max(1);
    let level = |i: usize| mean_level(a[i], b[i]);
    (0..a.len())
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if saturated[i] || x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
                return true;
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
            f64::from(hi - lo) > FLAT_RANGE_SIGMAS * sigma
        })
        .collect()
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
