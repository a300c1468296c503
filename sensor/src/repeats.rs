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
//!
//! Not every pixel is needed: the slope rests on the levels away from the
//! bulk of the image (the spheres' interiors against the background), which
//! are few, while the bulk's millions of pixels give its variance far more
//! closely than the fit needs. A census of every [`CENSUS_STEP`]-th pixel of
//! every [`CENSUS_STEP`]-th row finds the bulk level and its spread (median
//! and robust σ of a quarter of it); every [`TILE_PX`]-square tile within one tile of a
//! census pixel off the bulk level by more than [`OFF_BULK_SIGMAS`] is taken
//! whole, and elsewhere the census pixels alone are taken, each standing for
//! the `CENSUS_STEP²` pixels about it in the fit's weights — so that the fit
//! weighs the levels as it would over every pixel, from a few per cent of
//! them (on a full-size seed frame 2–3 %: `measure` pays ≈ 12 ms a pair for
//! K, where ten passes over every pixel took ≈ 400 ms). The pixels taken are
//! gathered once; the flatness test reads their neighbours in the frames.

use rayon::prelude::*;

use crate::adc::depth_of;
use crate::frame::{Frame, StackKind, check_frame, check_same_camera};
use crate::order::median_and_sigma;
use crate::temporal::{BinSums, Levels, NoiseModel, Pair, Pooling, Span, fit_sums, pairs_noise};
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

/// The census (and the sample of the bulk level) takes every this-many-th
/// pixel of every this-many-th row, from the middle of the first block.
const CENSUS_STEP: usize = 16;
/// The side of the tiles taken whole (px): a multiple of [`CENSUS_STEP`],
/// so that a tile holds whole blocks of the census; a tile's neighbours are
/// taken with it, so that every pixel within a tile of a census pixel off
/// the bulk level is taken.
const TILE_PX: usize = 16;
/// The bulk level and its spread are taken from every this-many-th census
/// pixel of every this-many-th census row.
const BULK_SAMPLE: usize = 2;
/// A census pixel whose level lies farther than this many robust σ of the
/// census from its median is off the bulk level (the bulk's own noise and
/// background gradient lie within it; the spheres' interiors far beyond).
const OFF_BULK_SIGMAS: f64 = 8.0;

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
    /// Pixel differences used (of the pixels taken: flat, not saturated, not
    /// clipped), over all pairs.
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

/// One pair's photon transfer ([`RepeatGainEstimate::transfer`]): its
/// sums per level bin, what its values show of the ADC depth, its flat
/// pixels' median level, and its frames' size and depth.
#[derive(Debug, Clone)]
pub struct PairTransfer {
    /// Frame A's size and depth, its values left out.
    frame: Frame<'static>,
    /// The OR of the values taken.
    or: u16,
    /// The median level of its flat pixels (DN).
    background: Option<f64>,
    /// Its differences per level bin.
    sums: Vec<Vec<BinSums>>,
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
    /// Every pixel taken instead of the census's choice (the reference the
    /// choice is tested against).
    every_pixel: bool,
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
            every_pixel: false,
        }
    }

    /// Takes in a pair `(a, b)` of repeated captures: [`Self::transfer`],
    /// then [`Self::add`].
    pub fn add_pair(&mut self, a: &Frame<'_>, b: &Frame<'_>) -> Result<()> {
        let transfer = self.transfer(self.sums.len(), a, b)?;
        self.add(transfer)
    }

    /// The photon transfer of pair `index` `(a, b)` (frames `2·index` and
    /// `2·index + 1` of the repeated captures), alone: pairs may be
    /// computed in parallel and taken in with [`Self::add`] in their order.
    /// Refuses frames of another size or depth than each other.
    pub fn transfer(&self, index: usize, a: &Frame<'_>, b: &Frame<'_>) -> Result<PairTransfer> {
        let kind = StackKind::Repeat;
        for (j, f) in [a, b].into_iter().enumerate() {
            check_frame(f, kind, 2 * index + j)?;
            check_same_camera(f, kind, 2 * index + j, a, kind)?;
        }
        let spans = if self.every_pixel {
            Span::rows(a.width, a.values.len())
        } else {
            taken_pixels(a.values, b.values, a.width as usize)
        };
        // The pixels taken, gathered once (in the spans' order): every pass
        // of the fits runs over them contiguously.
        let gather = |values: &[u16]| -> Vec<u16> {
            let mut taken = Vec::with_capacity(Span::total(&spans));
            for span in &spans {
                if span.step == 1 {
                    taken.extend_from_slice(&values[span.start..span.start + span.count]);
                } else {
                    taken.extend(span.pixels().map(|i| values[i]));
                }
            }
            taken
        };
        let (taken_a, taken_b) = (gather(a.values), gather(b.values));
        let or = taken_a.iter().chain(&taken_b).fold(0u16, |all, &v| all | v);
        let floor = depth_of(a.container_bits, or).step_dn().powi(2);
        let fit = |excluded: &[bool]| {
            let pair = Pair {
                a: &taken_a,
                b: &taken_b,
                levels: Levels::Mean,
                spans: &spans,
                excluded,
            };
            pairs_noise(&[pair], a.container_bits, floor, Pooling::DegreesOfFreedom)
                .ok_or(no_gain(0.0, 0.0, 0))
        };
        // Each pixel's level, the pair's mean (A + B)/2, is computed where
        // it is needed, not held; one mask (over the pixels taken) serves
        // both fits.
        let mut excluded: Vec<bool> = taken_a
            .iter()
            .zip(&taken_b)
            .map(|(&x, &y)| x >= self.saturation || y >= self.saturation)
            .collect();
        let rough = fit(&excluded)?;
        exclude_not_flat(
            a.values,
            b.values,
            &spans,
            &mut excluded,
            a.width,
            &rough.temporal.model,
        );
        let fine = fit(&excluded)?;
        Ok(PairTransfer {
            frame: Frame { values: &[], ..*a },
            or,
            background: median_level(&taken_a, &taken_b, &spans, &excluded),
            sums: fine.sums,
        })
    }

    /// Takes in a pair's photon transfer. Refuses a pair of another size or
    /// depth than the first one taken in, and leaves the estimate as it was.
    pub fn add(&mut self, transfer: PairTransfer) -> Result<()> {
        let kind = StackKind::Repeat;
        let first = *self.first.get_or_insert(transfer.frame);
        check_same_camera(&transfer.frame, kind, 2 * self.sums.len(), &first, kind)?;
        self.all |= transfer.or;
        self.background = self.background.or(transfer.background);
        self.sums.extend(transfer.sums);
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

/// The median level (A + B)/2 of the pixels taken (`a`, `b` in the order of
/// `spans`) not `excluded`, each counted as the pixels it stands for; `None`
/// for none. The levels are half-integers, so they are counted by A + B
/// (one counter for each of the 2¹⁷ − 1 sums, not a copy of the pixels):
/// the middle value, or the mean of the two middle values.
fn median_level(a: &[u16], b: &[u16], spans: &[Span], excluded: &[bool]) -> Option<f64> {
    let mut counts = vec![0u64; 2 * usize::from(u16::MAX) + 1];
    for span in spans {
        for i in (span.first..span.first + span.count).filter(|&i| !excluded[i]) {
            counts[usize::from(a[i]) + usize::from(b[i])] += span.weight;
        }
    }
    counted_median(&counts).map(|twice| twice / 2.0)
}

/// The median of values counted by value (`counts[v]` of value v): the
/// middle value, or the mean of the two middle values; `None` for none.
fn counted_median(counts: &[u64]) -> Option<f64> {
    let n: u64 = counts.iter().sum();
    if n == 0 {
        return None;
    }
    // The value of rank r (from 0) in ascending order.
    let at = |rank: u64| {
        let mut seen = 0;
        counts.iter().position(|&c| {
            seen += c;
            seen > rank
        })
    };
    let upper = at(n / 2)? as f64;
    if n % 2 == 1 {
        return Some(upper);
    }
    Some(0.5 * (at(n / 2 - 1)? as f64 + upper))
}

/// The pixels of a pair of `width` px a row that take part (module docs):
/// the tiles about census pixels off the bulk level whole, the census pixels
/// elsewhere; row by row, left to right.
fn taken_pixels(a: &[u16], b: &[u16], width: usize) -> Vec<Span> {
    let w = width.max(1);
    let h = a.len() / w;
    let offset = CENSUS_STEP / 2;
    let census_rows = || (offset..h).step_by(CENSUS_STEP);
    let census_columns = || (offset..w).step_by(CENSUS_STEP);
    let twice = |x: usize, y: usize| f64::from(a[y * w + x]) + f64::from(b[y * w + x]);
    // The bulk level and its spread from every BULK_SAMPLE-th census pixel
    // of every BULK_SAMPLE-th census row (≈ 12 000 of a full frame).
    let mut sample: Vec<f64> = census_rows()
        .step_by(BULK_SAMPLE)
        .flat_map(|y| {
            census_columns()
                .step_by(BULK_SAMPLE)
                .map(move |x| twice(x, y))
        })
        .collect();
    let (bulk, sigma) = median_and_sigma(&mut sample).unwrap_or((0.0, 0.0));
    // In units of A + B: σ of the level (A + B)/2 doubled, at least 1 DN.
    let limit = OFF_BULK_SIGMAS * sigma.max(2.0);
    let (tiles_x, tiles_y) = (w.div_ceil(TILE_PX), h.div_ceil(TILE_PX));
    let mut whole = vec![false; tiles_x * tiles_y];
    for y in census_rows() {
        for x in census_columns() {
            if (twice(x, y) - bulk).abs() <= limit {
                continue;
            }
            let (tx, ty) = (x / TILE_PX, y / TILE_PX);
            for ny in ty.saturating_sub(1)..(ty + 2).min(tiles_y) {
                for nx in tx.saturating_sub(1)..(tx + 2).min(tiles_x) {
                    whole[ny * tiles_x + nx] = true;
                }
            }
        }
    }
    // A span of `count` pixels from `start`, `step` apart, after the others.
    fn push(spans: &mut Vec<Span>, start: usize, count: usize, step: usize) {
        if count > 0 {
            let first = Span::total(spans);
            let weight = (step * step) as u64;
            spans.push(Span {
                start,
                count,
                step,
                weight,
                first,
            });
        }
    }
    let mut spans: Vec<Span> = Vec::new();
    for y in 0..h {
        let row = &whole[(y / TILE_PX) * tiles_x..(y / TILE_PX + 1) * tiles_x];
        let census_row = y % CENSUS_STEP == offset;
        let mut tx = 0;
        while tx < tiles_x {
            let taken = row[tx];
            let end = (tx..tiles_x).find(|&t| row[t] != taken).unwrap_or(tiles_x);
            let (x0, x1) = (tx * TILE_PX, (end * TILE_PX).min(w));
            if taken {
                push(&mut spans, y * w + x0, x1 - x0, 1);
            } else if census_row && x0 + offset < x1 {
                let count = (x1 - x0 - offset).div_ceil(CENSUS_STEP);
                push(&mut spans, y * w + x0 + offset, count, CENSUS_STEP);
            }
            tx = end;
        }
    }
    spans
}

/// `excluded` cut into each span's part.
fn per_span<'e>(spans: &[Span], excluded: &'e mut [bool]) -> Vec<&'e mut [bool]> {
    let mut rest = excluded;
    spans
        .iter()
        .map(|s| {
            let (part, tail) = std::mem::take(&mut rest).split_at_mut(s.count);
            rest = tail;
            part
        })
        .collect()
}

fn no_gain(low: f64, high: f64, pixels: u64) -> SensorError {
    SensorError::NoGainFromRepeats {
        low_dn: low,
        high_dn: high,
        pixels,
    }
}

/// Leaves out of the fine fit, beside the pixels taken that are `excluded`
/// already (saturated ones), the frame's border and the pixels whose 3×3
/// range of levels `(A + B)/2` exceeds [`FLAT_RANGE_SIGMAS`]·σ of the level
/// (`σ² = model(level)/2`).
fn exclude_not_flat(
    a: &[u16],
    b: &[u16],
    spans: &[Span],
    excluded: &mut [bool],
    width: u32,
    model: &NoiseModel,
) {
    let w = width as usize;
    let h = a.len() / w.max(1);
    // Twice the level, A + B, exactly; the test `range/2 > k·σ` squared:
    // `range² > 4k²·σ² = 2k²·model(level)`.
    let twice = |i: usize| u32::from(a[i]) + u32::from(b[i]);
    let k2 = 2.0 * FLAT_RANGE_SIGMAS * FLAT_RANGE_SIGMAS;
    spans
        .par_iter()
        .zip(per_span(spans, excluded))
        .for_each(|(span, part)| {
            let (x0, y) = (span.start % w, span.start / w);
            if y == 0 || y + 1 >= h {
                part.fill(true);
                return;
            }
            let rows = [(y - 1) * w, y * w, (y + 1) * w];
            // Each column's lowest and highest A + B over the three rows.
            let column = |x: usize| {
                rows.iter().fold((u32::MAX, 0), |(lo, hi), &row| {
                    let l = twice(row + x);
                    (lo.min(l), hi.max(l))
                })
            };
            // A run of adjacent pixels shares its columns: each column once.
            let columns: Vec<(u32, u32)> = if span.step == 1 {
                let first = x0.saturating_sub(1);
                (first..(x0 + span.count + 1).min(w)).map(column).collect()
            } else {
                Vec::new()
            };
            for (k, out) in part.iter_mut().enumerate() {
                let x = x0 + k * span.step;
                if *out || x == 0 || x + 1 >= w {
                    *out = true;
                    continue;
                }
                let (lo, hi) = if span.step == 1 {
                    // Columns x − 1, x, x + 1 (the first stored is x0 − 1).
                    let c = &columns[x - x0.saturating_sub(1) - 1..][..3];
                    (
                        c[0].0.min(c[1].0).min(c[2].0),
                        c[0].1.max(c[1].1).max(c[2].1),
                    )
                } else {
                    [x - 1, x, x + 1]
                        .map(column)
                        .iter()
                        .fold((u32::MAX, 0), |(lo, hi), c| (lo.min(c.0), hi.max(c.1)))
                };
                let range = f64::from(hi - lo);
                let level = 0.5 * f64::from(twice(y * w + x));
                *out = range * range > k2 * model.variance(level);
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::temporal::mean_level;

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
        let spans = Span::rows(1001, 1001);
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
                median_level(&a, &b, &spans, &excluded),
                crate::order::median(&mut kept),
                "{n} pixels"
            );
        }
        assert_eq!(median_level(&a, &b, &spans, &vec![true; a.len()]), None);
    }

    /// A frame of `w × h` px at `bulk` DN with a disc of radius `r` px at
    /// `level` DN about (`cx`, `cy`), noise-free.
    fn disc_frame(w: usize, h: usize, bulk: u16, level: u16, c: (f64, f64), r: f64) -> Vec<u16> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                if (x - c.0).hypot(y - c.1) <= r {
                    level
                } else {
                    bulk
                }
            })
            .collect()
    }

    /// The census takes every pixel of a disc off the bulk level — above it
    /// or below it — and of the tiles about it, and of the bulk only its own
    /// pixels, each standing for the `CENSUS_STEP²` about it.
    #[test]
    fn the_census_takes_the_levels_off_the_bulk_whole() {
        let (w, h) = (400, 300);
        for (bulk, level) in [(1000, 30_000), (30_000, 1000)] {
            let f = disc_frame(w, h, bulk, level, (201.3, 147.8), 37.0);
            let spans = taken_pixels(&f, &f, w);
            let taken: std::collections::HashSet<usize> =
                spans.iter().flat_map(Span::pixels).collect();
            assert_eq!(taken.len(), Span::total(&spans), "no pixel twice");
            for (i, &v) in f.iter().enumerate() {
                if v == level {
                    assert!(taken.contains(&i), "disc pixel {i} left out");
                }
            }
            let census = w.div_ceil(CENSUS_STEP) * h.div_ceil(CENSUS_STEP);
            let disc_tiles = taken.len().saturating_sub(census);
            assert!(taken.len() < census + 12 * 12 * TILE_PX * TILE_PX);
            // The weights stand for the whole frame, to within the tiles'
            // own census pixels counted twice over.
            let weight: u64 = spans.iter().map(|s| s.weight * s.count as u64).sum();
            let frame = (w * h) as u64;
            assert!(
                weight.abs_diff(frame) < frame / 20,
                "{weight} of {frame}; {disc_tiles} px in tiles"
            );
        }
        let flat = vec![500u16; w * h];
        let spans = taken_pixels(&flat, &flat, w);
        assert!(
            spans
                .iter()
                .all(|s| s.step == CENSUS_STEP && s.weight == (CENSUS_STEP * CENSUS_STEP) as u64)
        );
    }

    /// Pairs of a measurement-like scene (1024 × 768 px: a background of
    /// 200 e⁻ and three discs of 30–60 px radius at 3000–9000 e⁻; K = 4
    /// DN/e⁻, read noise 5 e⁻, offset 1000 DN, 16-bit): K from the census's
    /// pixels within 0.5 % of K from every pixel, from ≤ 10 % of them.
    #[test]
    fn the_census_gives_the_gain_of_every_pixel() {
        use rand_distr::{Distribution, StandardNormal};
        use rand_pcg::Pcg64Mcg;
        let (w, h, gain) = (1024, 768, 4.0);
        let discs = [
            ((300.0, 250.0), 60.0, 9000.0),
            ((700.0, 500.0), 45.0, 6000.0),
        ];
        let discs = [discs[0], discs[1], ((520.0, 180.0), 30.0, 3000.0)];
        let mut rng = Pcg64Mcg::new(0x5eed);
        let mut frame = || -> Vec<u16> {
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f64, (i / w) as f64);
                    let mu = discs
                        .iter()
                        .filter(|(c, r, _)| (x - c.0).hypot(y - c.1) <= *r)
                        .fold(200.0, |m, d| m + d.2);
                    let z: f64 = StandardNormal.sample(&mut rng);
                    let e = mu + (mu + 25.0_f64).sqrt() * z;
                    (1000.0 + gain * e).round().clamp(0.0, 65535.0) as u16
                })
                .collect()
        };
        let frames: Vec<Vec<u16>> = (0..4).map(|_| frame()).collect();
        fn view(values: &[u16], w: usize, h: usize) -> Frame<'_> {
            Frame {
                values,
                width: w as u32,
                height: h as u32,
                container_bits: 16,
                exposure_s: None,
            }
        }
        let estimate = |every_pixel: bool| {
            let mut e = RepeatGainEstimate {
                every_pixel,
                ..RepeatGainEstimate::new(u16::MAX)
            };
            for pair in frames.chunks(2) {
                e.add_pair(&view(&pair[0], w, h), &view(&pair[1], w, h))
                    .unwrap();
            }
            e.finish().unwrap()
        };
        let (census, every) = (estimate(false), estimate(true));
        let change = census.gain_dn_per_e / every.gain_dn_per_e - 1.0;
        println!(
            "K {:.4} from {} differences, {:.4} from every pixel ({}): {:+.3} %; truth {gain}",
            census.gain_dn_per_e,
            census.pixels,
            every.gain_dn_per_e,
            every.pixels,
            100.0 * change
        );
        assert!(change.abs() < 0.005, "{census:?} {every:?}");
        assert!(10 * census.pixels < every.pixels, "{census:?} {every:?}");
        assert!((every.gain_dn_per_e / gain - 1.0).abs() < 0.02, "{every:?}");
    }
}
