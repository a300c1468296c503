//! Temporal noise of a stack from consecutive pairs of frames (EMVA 1288
//! §6.3): `σ²_y = ½·var(A − B)`, in which every fixed pattern cancels; and a
//! model of it against the pixel's level, `σ²_y(μ) = a + b·μ` (read plus
//! quantisation noise, plus shot noise `K·μ`), which sets the outlier
//! threshold of each pixel's robust mean.
//!
//! Sums are exact integers (differences of `u16` values), so the result does
//! not depend on how the rows are split among threads.

use rayon::prelude::*;

use crate::frame::Frame;

/// Differences farther than this many σ from their pair's mean are left out
/// of the variance: cosmic or stray events, never a normal sample (a
/// Gaussian exceeds 6σ with probability 2·10⁻⁹).
const CLIP_SIGMAS: f64 = 6.0;
/// Levels are grouped into this many bins across the container's range.
const BINS: usize = 256;
/// A bin takes part in the fit of the noise model with at least this many
/// differences (its variance then has ≤ 15 % relative error, `√(2/n)`).
const MIN_BIN_SAMPLES: u64 = 100;
/// Clipping passes at most (each one a pass over the stack); they stop
/// earlier when the set of clipped samples no longer changes.
const MAX_PASSES: usize = 4;

/// The temporal variance of a pixel against its level (DN², DN).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct NoiseModel {
    /// `a`: the variance extrapolated to level 0 (DN²).
    intercept: f64,
    /// `b`: the rise of the variance per DN of level (DN), `≥ 0`.
    slope: f64,
    /// The smallest variance ever returned (DN²).
    floor: f64,
    /// The range of levels the fit saw (DN): outside it the variance of its
    /// nearest end is returned, never an extrapolation (a dead pixel of a
    /// flat lies far below the flat's levels, where a line through them may
    /// fall below the read noise).
    levels: (f64, f64),
}

impl NoiseModel {
    /// `b`: the rise of the variance per DN of level (DN); with shot noise,
    /// the system gain K (DN/e⁻).
    pub(crate) fn slope(&self) -> f64 {
        self.slope
    }

    /// The range of levels the fit saw (DN).
    pub(crate) fn levels(&self) -> (f64, f64) {
        self.levels
    }

    /// `max(a + b·clamp(level), floor)`.
    pub(crate) fn variance(&self, level: f64) -> f64 {
        let level = level.clamp(self.levels.0, self.levels.1);
        (self.intercept + self.slope * level).max(self.floor)
    }
}

/// The temporal noise of a stack.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Temporal {
    /// `σ²_y`: mean over consecutive pairs of `½·var(A − B)` over the pixels
    /// not saturated, outliers left out (DN²).
    pub(crate) var_dn2: f64,
    /// The variance against level.
    pub(crate) model: NoiseModel,
    /// Differences that took part (not excluded, not clipped).
    pub(crate) samples: u64,
}

/// Exact sums of the differences of one pair in one level bin.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct BinSums {
    /// Differences.
    n: u64,
    /// The pixels they stand for (each difference its span's weight): the
    /// bin's weight in the fit of the model, as if every pixel had been taken.
    weight: u64,
    /// Σ d.
    s1: i64,
    /// Σ d².
    s2: u64,
    /// Σ 2·level (the level is a median of integers: twice it is an integer).
    level2: u64,
}

impl BinSums {
    fn add(&mut self, d: i64, level2: u64, weight: u64) {
        self.n += 1;
        self.weight += weight;
        self.s1 += d;
        self.s2 += d.unsigned_abs().pow(2);
        self.level2 += level2;
    }

    fn merge(&mut self, other: &BinSums) {
        self.n += other.n;
        self.weight += other.weight;
        self.s1 += other.s1;
        self.s2 += other.s2;
        self.level2 += other.level2;
    }

    /// `Σ (d − d̄)²`.
    fn centred_s2(&self) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let (n, s1) = (self.n as f64, self.s1 as f64);
        (self.s2 as f64 - s1 * s1 / n).max(0.0)
    }
}

/// What one pass uses to leave outliers out: the model and each pair's mean
/// difference.
struct Clip<'a> {
    model: NoiseModel,
    pair_means: &'a [f64],
}

/// Two frames of one scene (`A − B` holds their temporal noise alone): the
/// pixels taken of each, what each pixel's difference is binned by, and the
/// spans they were taken in. Values, levels and exclusions are held in the
/// spans' order (pixel `k` of a span at `first + k`): for every pixel of a
/// frame ([`Span::rows`]) that is the frame itself.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pair<'a> {
    /// Frame A's pixels taken.
    pub(crate) a: &'a [u16],
    /// Frame B's pixels taken.
    pub(crate) b: &'a [u16],
    /// Each pixel's level (DN).
    pub(crate) levels: Levels<'a>,
    /// The spans the pixels were taken in (their weights).
    pub(crate) spans: &'a [Span],
    /// Whether each pixel is left out (saturated, or not usable for another
    /// reason).
    pub(crate) excluded: &'a [bool],
}

/// Pixels of one row taken at a fixed step, each standing for `weight`
/// pixels of the frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Span {
    /// Index of the first pixel in the frame.
    pub(crate) start: usize,
    /// Pixels taken.
    pub(crate) count: usize,
    /// Step between them (px).
    pub(crate) step: usize,
    /// Pixels of the frame each stands for.
    pub(crate) weight: u64,
    /// Index of the first in the order of all spans' pixels.
    pub(crate) first: usize,
}

impl Span {
    /// Every pixel of a frame, a span a row.
    pub(crate) fn rows(width: u32, pixels: usize) -> Vec<Span> {
        let w = (width as usize).max(1);
        (0..pixels / w)
            .map(|y| Span {
                start: y * w,
                count: w,
                step: 1,
                weight: 1,
                first: y * w,
            })
            .collect()
    }

    /// The frame indices of its pixels.
    pub(crate) fn pixels(&self) -> impl Iterator<Item = usize> + use<> {
        let (start, step) = (self.start, self.step);
        (0..self.count).map(move |k| start + k * step)
    }

    /// Pixels taken by `spans` in all.
    pub(crate) fn total(spans: &[Span]) -> usize {
        spans.last().map_or(0, |s| s.first + s.count)
    }
}

/// What a pair's pixels are binned by.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Levels<'a> {
    /// Each pixel's level, given (a stack's medians).
    Given(&'a [f32]),
    /// The pair's own mean level of each pixel ([`mean_level`]), computed
    /// where it is needed rather than held.
    Mean,
}

/// The level `(a + b)/2` of a pixel of a pair (exact: a half-integer).
#[inline]
pub(crate) fn mean_level(a: u16, b: u16) -> f32 {
    (f32::from(a) + f32::from(b)) / 2.0
}

/// The temporal noise of a stack of ≥ 2 frames (`None` for fewer).
/// `levels` holds each pixel's median over the stack, `saturated` whether
/// it reaches saturation in any frame (those pixels are left out);
/// `floor_dn2` bounds the model's variance from below.
pub(crate) fn temporal_noise(
    frames: &[Frame<'_>],
    levels: &[f32],
    saturated: &[bool],
    floor_dn2: f64,
) -> Option<Temporal> {
    if frames.len() < 2 {
        return None;
    }
    let first = frames.first()?;
    let spans = Span::rows(first.width, first.values.len());
    let pairs: Vec<Pair<'_>> = frames
        .windows(2)
        .map(|ab| Pair {
            a: ab[0].values,
            b: ab[1].values,
            levels: Levels::Given(levels),
            spans: &spans,
            excluded: saturated,
        })
        .collect();
    pairs_noise(&pairs, first.container_bits, floor_dn2, Pooling::Samples)
        .map(|fitted| fitted.temporal)
}

/// How a bin's variance is pooled over pairs, each pair's own bin mean
/// removed: over the samples (`Σ centred / n`, biased low by one sample per
/// pair and bin: negligible for the full-frame bins of a stack, and what
/// its figures have always used), or over the degrees of freedom
/// (`Σ centred / (n − pairs)`, unbiased: needed where a bin holds few
/// samples of each pair, as the sphere interiors of repeated captures).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Pooling {
    /// Divide by the number of samples.
    Samples,
    /// Divide by the degrees of freedom.
    DegreesOfFreedom,
}

/// The temporal noise of pairs as fitted, and the sums it was fitted to:
/// one vector of level bins per pair, which pool with other pairs' sums
/// ([`fit_sums`]).
pub(crate) struct PairsNoise {
    /// The fit.
    pub(crate) temporal: Temporal,
    /// Each pair's sums per level bin, outliers left out.
    pub(crate) sums: Vec<Vec<BinSums>>,
}

/// The temporal noise of pairs of frames of `container_bits` bits (`None`
/// without pairs): each pair's `½·var(A − B)` over the pixels taken and not
/// excluded, binned by level and fitted against it,
/// outliers beyond [`CLIP_SIGMAS`] of the model left out in up to
/// [`MAX_PASSES`] passes; bins pooled as `pooling` says.
pub(crate) fn pairs_noise(
    pairs: &[Pair<'_>],
    container_bits: u8,
    floor_dn2: f64,
    pooling: Pooling,
) -> Option<PairsNoise> {
    if pairs.is_empty() {
        return None;
    }
    let bin_shift = u32::from(container_bits.saturating_sub(8));
    let mut clip: Option<(NoiseModel, Vec<f64>)> = None;
    let mut kept_before = None;
    let mut result = None;
    for _ in 0..MAX_PASSES {
        let sums = pair_sums(
            pairs,
            bin_shift,
            clip.as_ref().map(|(model, pair_means)| Clip {
                model: *model,
                pair_means,
            }),
        );
        let (temporal, pair_means) = fit_sums(&sums, floor_dn2, pooling);
        let converged = kept_before == Some(temporal.samples);
        kept_before = Some(temporal.samples);
        clip = Some((temporal.model, pair_means));
        result = Some(PairsNoise { temporal, sums });
        if converged {
            break;
        }
    }
    result
}

/// The temporal noise of sums of pairs' differences per level bin (one
/// vector of bins per pair): `σ²_y` over the pairs, and the model of the
/// bins' variance against their levels, bins pooled as `pooling` says; with
/// each pair's mean difference.
pub(crate) fn fit_sums(
    sums: &[Vec<BinSums>],
    floor_dn2: f64,
    pooling: Pooling,
) -> (Temporal, Vec<f64>) {
    let (var_dn2, pair_means) = pair_variance(sums);
    let temporal = Temporal {
        var_dn2,
        model: fit_model(sums, floor_dn2, pooling),
        samples: sums.iter().flatten().map(|b| b.n).sum(),
    };
    (temporal, pair_means)
}

/// Per pair, per level bin: the exact sums of `A − B` over the pixels taken
/// and not excluded (and within the clip, when one is given). Integer sums:
/// the same whatever the spans' split among threads.
fn pair_sums(pairs: &[Pair<'_>], bin_shift: u32, clip: Option<Clip<'_>>) -> Vec<Vec<BinSums>> {
    pairs
        .iter()
        .enumerate()
        .map(|(index, pair)| {
            // The pair's mean difference and the model of the clip.
            let clip = clip.as_ref().map(|c| (c.pair_means[index], c.model));
            pair.spans
                .par_iter()
                .fold(
                    || vec![BinSums::default(); BINS],
                    |mut bins, span| {
                        let taken = span.first..span.first + span.count;
                        let levels = match pair.levels {
                            Levels::Given(levels) => Some(&levels[taken.clone()]),
                            Levels::Mean => None,
                        };
                        let pixels = pair.a[taken.clone()]
                            .iter()
                            .zip(&pair.b[taken.clone()])
                            .zip(&pair.excluded[taken]);
                        for (k, ((&va, &vb), &out)) in pixels.enumerate() {
                            if out {
                                continue;
                            }
                            let d = i64::from(va) - i64::from(vb);
                            let level = levels.map_or_else(
                                || f64::from(mean_level(va, vb)),
                                |levels| f64::from(levels[k]),
                            );
                            if let Some((mean, model)) = &clip {
                                // The kept interval's squared half-width.
                                let half_width2 =
                                    CLIP_SIGMAS * CLIP_SIGMAS * (2.0 * model.variance(level));
                                if (d as f64 - mean).powi(2) > half_width2 {
                                    continue;
                                }
                            }
                            let bin = ((level as u32) >> bin_shift).min(BINS as u32 - 1) as usize;
                            bins[bin].add(d, (2.0 * level) as u64, span.weight);
                        }
                        bins
                    },
                )
                .reduce(
                    || vec![BinSums::default(); BINS],
                    |mut x, y| {
                        for (bx, by) in x.iter_mut().zip(&y) {
                            bx.merge(by);
                        }
                        x
                    },
                )
        })
        .collect()
}

/// `σ²_y` as the mean over pairs of `½·var(A − B)` (EMVA 1288 eq. for the
/// temporal variance, population variance), and each pair's mean difference.
fn pair_variance(sums: &[Vec<BinSums>]) -> (f64, Vec<f64>) {
    let mut means = Vec::with_capacity(sums.len());
    let mut total = 0.0;
    for bins in sums {
        let mut all = BinSums::default();
        for b in bins {
            all.merge(b);
        }
        let n = all.n.max(1) as f64;
        means.push(all.s1 as f64 / n);
        total += 0.5 * all.centred_s2() / n;
    }
    (total / sums.len().max(1) as f64, means)
}

/// Weighted least squares of each bin's `½·var(A − B)` (pooled over pairs,
/// each pair's own bin mean removed) against the bin's mean level, weights
/// the numbers of pixels the differences stand for: `σ²_y(μ) = a + b·μ`. A single populated bin
/// (a dark frame) or a negative slope gives the constant model; with no
/// bin populated enough, the variance pooled over all bins.
fn fit_model(sums: &[Vec<BinSums>], floor_dn2: f64, pooling: Pooling) -> NoiseModel {
    let mut points = Vec::new();
    for bin in 0..BINS {
        let mut n = 0u64;
        let mut weight = 0u64;
        let mut centred = 0.0;
        let mut level2 = 0u64;
        let mut means = 0u64;
        for bins in sums {
            let b = &bins[bin];
            n += b.n;
            weight += b.weight;
            centred += b.centred_s2();
            level2 += b.level2;
            means += u64::from(b.n > 0);
        }
        if n >= MIN_BIN_SAMPLES {
            let dof = match pooling {
                Pooling::Samples => n as f64,
                Pooling::DegreesOfFreedom => (n - means).max(1) as f64,
            };
            points.push((
                level2 as f64 / (2.0 * n as f64),
                0.5 * centred / dof,
                weight as f64,
            ));
        }
    }
    if points.is_empty() {
        // Too few pixels for any bin on its own: one constant for all.
        let (n, centred) = sums
            .iter()
            .flatten()
            .fold((0u64, 0.0), |(n, c), b| (n + b.n, c + b.centred_s2()));
        return NoiseModel {
            intercept: 0.5 * centred / n.max(1) as f64,
            slope: 0.0,
            floor: floor_dn2,
            levels: (0.0, 0.0),
        };
    }
    let weight: f64 = points.iter().map(|p| p.2).sum();
    let mean_level = points.iter().map(|p| p.0 * p.2).sum::<f64>() / weight;
    let mean_var = points.iter().map(|p| p.1 * p.2).sum::<f64>() / weight;
    let sxx: f64 = points
        .iter()
        .map(|p| p.2 * (p.0 - mean_level).powi(2))
        .sum();
    let sxy: f64 = points
        .iter()
        .map(|p| p.2 * (p.0 - mean_level) * (p.1 - mean_var))
        .sum();
    let slope = if sxx > 0.0 && points.len() > 1 {
        (sxy / sxx).max(0.0)
    } else {
        0.0
    };
    let low = points.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let high = points.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    NoiseModel {
        intercept: mean_var - slope * mean_level,
        slope,
        floor: floor_dn2,
        levels: (low, high),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_model_is_linear_in_the_level_and_floored() {
        let m = NoiseModel {
            intercept: 10.0,
            slope: 0.5,
            floor: 1.0,
            levels: (0.0, 1000.0),
        };
        assert_eq!(m.variance(100.0), 60.0);
        assert_eq!(m.variance(2000.0), 510.0, "no extrapolation");
        let m = NoiseModel {
            intercept: -10.0,
            slope: 0.5,
            floor: 1.0,
            levels: (0.0, 1000.0),
        };
        assert_eq!(m.variance(0.0), 1.0);
    }

    #[test]
    fn pair_variance_is_half_the_variance_of_the_difference() {
        // Differences +2, −2 about a mean of 0: var(A − B) = 4, σ²_y = 2.
        let a = [10u16, 6, 10, 6];
        let b = [8u16, 8, 8, 8];
        let frames = [
            Frame {
                values: &a,
                width: 4,
                height: 1,
                container_bits: 16,
                exposure_s: None,
            },
            Frame {
                values: &b,
                width: 4,
                height: 1,
                container_bits: 16,
                exposure_s: None,
            },
        ];
        let levels = [9.0f32, 7.0, 9.0, 7.0];
        let t = temporal_noise(&frames, &levels, &[false; 4], 0.0).unwrap();
        assert!((t.var_dn2 - 2.0).abs() < 1e-12);
    }
}
