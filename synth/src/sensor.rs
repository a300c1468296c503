//! The image sensor: background (level, linear gradient, stray-light blobs),
//! signal, shot and read noise, gain, offset, quantisation and saturation.
//!
//! Per pixel: mean electrons `μ = RI·background + Σ radiance·signal` (RI the
//! lens's relative illumination when rendering through a lens, 1 otherwise;
//! the signals carry it already);
//! electrons `e = μ + √(μ + σ_read²)·z` with one standard normal z per pixel
//! (the Gaussian approximation of Poisson shot noise plus Gaussian read noise:
//! mean μ, variance μ + σ_read², accurate for the ≥ 100 e⁻ backgrounds used);
//! `DN = round(offset + gain·e)` clamped to `[0, 2^bits − 1]` (saturation).
//! Random numbers: one PCG-64 MCG generator per row, seeded with a hash of
//! (seed, frame, camera, row) — portable and fixed by its constants, so the
//! bytes do not depend on the platform or the thread count.

use image::{ImageBuffer, Luma};
use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;

use crate::illumination::LensIllumination;
use crate::pattern::{FixedPattern, Readout};
use crate::psf::Signal;

/// A 16-bit grayscale image (8-bit images hold values ≤ 255).
pub type Image16 = ImageBuffer<Luma<u16>, Vec<u16>>;

/// A Gaussian blob of stray light (image units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrayLight {
    /// Centre u (px).
    pub u: f64,
    /// Centre v (px).
    pub v: f64,
    /// Standard deviation (px).
    pub sigma_px: f64,
    /// Peak (electrons).
    pub peak_e: f64,
}

/// The sensor model of one camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Output bit depth (8 or 16).
    pub bits: u8,
    /// DN per electron.
    pub gain_dn_per_e: f64,
    /// Black level (DN).
    pub offset_dn: f64,
    /// Read noise (electrons RMS).
    pub read_noise_e: f64,
    /// Shot noise on.
    pub shot_noise: bool,
    /// Uniform background (electrons).
    pub background_e: f64,
    /// Background gradient (electrons per px along u and v), zero at the image centre.
    pub gradient_e_per_px: [f64; 2],
    /// Stray-light blobs.
    pub stray_light: Vec<StrayLight>,
}

impl Sensor {
    /// Largest DN.
    pub fn max_dn(&self) -> f64 {
        f64::from((1u32 << self.bits) - 1)
    }

    /// Whether any noise is drawn.
    pub fn noisy(&self) -> bool {
        self.shot_noise || self.read_noise_e > 0.0
    }

    /// Mean background electrons at pixel (u, v), without stray light.
    pub fn background_at(&self, u: f64, v: f64) -> f64 {
        let (cu, cv) = (
            (f64::from(self.width) - 1.0) / 2.0,
            (f64::from(self.height) - 1.0) / 2.0,
        );
        self.background_e
            + self.gradient_e_per_px[0] * (u - cu)
            + self.gradient_e_per_px[1] * (v - cv)
    }

    /// Expected DN (before rounding and clamping) of a pixel receiving `e` mean electrons.
    pub fn expected_dn(&self, e: f64) -> f64 {
        self.offset_dn + self.gain_dn_per_e * e
    }

    /// Variance (DN²) of a pixel receiving `e` mean electrons, without quantisation.
    pub fn variance_dn2(&self, e: f64) -> f64 {
        let shot = if self.shot_noise { e.max(0.0) } else { 0.0 };
        self.gain_dn_per_e * self.gain_dn_per_e * (shot + self.read_noise_e * self.read_noise_e)
    }
}

/// Identity of one frame's noise: same key → same noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct NoiseKey {
    /// Campaign seed.
    pub seed: u64,
    /// Frame (instant) number within the campaign.
    pub frame: u64,
    /// Camera number.
    pub camera: u8,
}

/// SplitMix64 step: a well-mixed 64-bit value from a counter.
fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// 256-bit ChaCha key from a list of words (domain-separated by `purpose`).
pub(crate) fn chacha_key(purpose: u64, words: &[u64]) -> [u8; 32] {
    let mut h = splitmix(purpose ^ 0x7472_696E_6F63_756C);
    for &w in words {
        h = splitmix(h ^ w);
    }
    let mut key = [0u8; 32];
    for (i, chunk) in key.chunks_exact_mut(8).enumerate() {
        h = splitmix(h.wrapping_add(i as u64));
        chunk.copy_from_slice(&h.to_le_bytes());
    }
    key
}

/// Purpose tag of sensor-noise streams.
const NOISE_PURPOSE: u64 = 1;

impl NoiseKey {
    /// The generator of one row: PCG-64 MCG (XSL-RR 128/64 on a
    /// multiplicative congruential state, O'Neill 2014) seeded with a hash of
    /// (seed, frame, camera, row). Fully specified by its constants: the same
    /// bytes on every platform; twice as fast as ChaCha8 for the 12.6 M draws
    /// of a frame.
    pub fn row_rng(&self, row: u32) -> Pcg64Mcg {
        let k = chacha_key(
            NOISE_PURPOSE,
            &[
                self.seed,
                self.frame,
                u64::from(self.camera),
                u64::from(row),
            ],
        );
        let mut b = [0u8; 16];
        b.copy_from_slice(&k[..16]);
        Pcg64Mcg::new(u128::from_le_bytes(b))
    }
}

/// A signal layer and the radiance that scales it (electrons per covered pixel).
#[derive(Debug, Clone, Copy)]
pub struct Exposure<'a> {
    /// Blurred coverage.
    pub signal: &'a Signal,
    /// Electrons of a fully covered pixel.
    pub radiance_e: f64,
}

/// Exact sampler of the quantised DN of a pixel with a given mean: the
/// distribution of `round_half_up(offset + gain·(μ + σ·z))` clamped to
/// `[0, max]`, z standard normal, by Walker's alias method (one 64-bit draw
/// per sample; the normal is truncated at ±9σ, probability 2e-19). Used for
/// the uniform background, which is most of every frame; it is ≈ 3× faster
/// than drawing z and quantising.
#[derive(Debug, Clone)]
struct QuantisedNoise {
    first: u32,
    threshold: Vec<u32>,
    alias: Vec<u16>,
}

impl QuantisedNoise {
    fn new(mean_dn: f64, sd_dn: f64, max: u16) -> Option<Self> {
        if !(sd_dn > 0.0 && mean_dn.is_finite()) {
            return None;
        }
        let lo = (mean_dn - 9.0 * sd_dn).floor().clamp(0.0, f64::from(max)) as u32;
        let hi = (mean_dn + 9.0 * sd_dn).ceil().clamp(0.0, f64::from(max)) as u32;
        let n = (hi - lo + 1) as usize;
        if n > 1 << 16 {
            return None;
        }
        let cdf = |x: f64| 0.5 * libm::erfc(-(x - mean_dn) / (sd_dn * std::f64::consts::SQRT_2));
        // P(DN = k) = P(k − ½ ≤ x < k + ½); the end values take the clamped tails.
        let mut p: Vec<f64> = (lo..=hi)
            .map(|k| {
                let k = f64::from(k);
                let a = if k <= 0.0 { 0.0 } else { cdf(k - 0.5) };
                let b = if k >= f64::from(max) {
                    1.0
                } else {
                    cdf(k + 0.5)
                };
                (b - a).max(0.0)
            })
            .collect();
        let total: f64 = p.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        p.iter_mut().for_each(|x| *x *= n as f64 / total);
        // Vose's alias method.
        let mut threshold = vec![u32::MAX; n];
        let mut alias: Vec<u16> = (0..n).map(|i| i as u16).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| p[i] < 1.0);
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            threshold[s] = (p[s] * 4_294_967_296.0).min(4_294_967_295.0) as u32;
            alias[s] = l as u16;
            p[l] -= 1.0 - p[s];
            if p[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        Some(Self {
            first: lo,
            threshold,
            alias,
        })
    }

    #[inline]
    fn sample(&self, r: u64) -> u16 {
        let i = (((r >> 32) * self.threshold.len() as u64) >> 32) as usize;
        // Branch-free select (the comparison is a coin flip for the CPU's predictor).
        let keep = u32::from((r as u32) < self.threshold[i]);
        let a = u32::from(self.alias[i]);
        let k = a ^ ((i as u32 ^ a) & keep.wrapping_neg());
        (self.first + k) as u16
    }
}

/// The ADC: converts `DN/2^shift` of the file's DN to an integer in
/// `[0, max]` (round half up) and writes it shifted left by `shift`
/// (`shift` = file bits − ADC bits; 0: the file's own depth).
#[derive(Debug, Clone, Copy)]
struct Adc {
    shift: u32,
    /// `2^−shift`.
    scale: f64,
    /// Largest ADC code.
    max: u16,
}

impl Adc {
    fn new(sensor: &Sensor, adc_bits: u8) -> Self {
        let bits = adc_bits.clamp(1, sensor.bits);
        let shift = u32::from(sensor.bits - bits);
        Self {
            shift,
            scale: 1.0 / f64::from(1u32 << shift),
            max: ((1u32 << bits) - 1) as u16,
        }
    }

    /// The file value of `x` + ½ ADC DN: truncation rounds half up, `as u16`
    /// saturates at 0 and 65535 (NaN → 0), `.min(max)` clamps the ADC's range.
    #[inline]
    fn code(&self, x_plus_half: f64) -> u16 {
        (x_plus_half as u16).min(self.max) << self.shift
    }
}

/// Electrons to ADC DN for one sensor: `DN/2^shift = offset + gain·e`, the
/// noise of a pixel of mean `m` electrons `√(m + σ_read²)` (shot noise on) or
/// `σ_read`.
#[derive(Debug, Clone, Copy)]
struct Conversion {
    adc: Adc,
    /// Offset in ADC DN plus ½ (rounding half up by truncation).
    offset: f64,
    /// ADC DN per electron.
    gain: f64,
    /// σ_read² (electrons²).
    rn2: f64,
    shot: bool,
    noisy: bool,
}

impl Conversion {
    fn new(sensor: &Sensor, adc: Adc) -> Self {
        Self {
            adc,
            offset: sensor.offset_dn * adc.scale + 0.5,
            gain: sensor.gain_dn_per_e * adc.scale,
            rn2: sensor.read_noise_e * sensor.read_noise_e,
            shot: sensor.shot_noise,
            noisy: sensor.noisy(),
        }
    }

    /// Temporal noise (electrons) of a pixel of mean `m` electrons.
    #[inline]
    fn sd(&self, m: f64) -> f64 {
        (if self.shot { m.max(0.0) } else { 0.0 } + self.rn2).sqrt()
    }

    /// The file value of a pixel of `e` electrons.
    #[inline]
    fn code(&self, e: f64) -> u16 {
        self.adc.code(self.offset + self.gain * e)
    }

    /// The file value of a pixel of `e` electrons and an extra dark offset
    /// `d` (file DN).
    #[inline]
    fn code_with_offset(&self, e: f64, d: f64) -> u16 {
        self.adc
            .code(self.offset + self.adc.scale * d + self.gain * e)
    }
}

/// Expose the sensor: background (times the lens's relative illumination
/// `lens` when given) + signals + noise → quantised image, through the ideal
/// readout (an ADC of the file's depth, no fixed pattern). Rows are computed
/// in parallel; the result does not depend on the thread count.
pub fn expose(
    sensor: &Sensor,
    layers: &[Exposure<'_>],
    key: NoiseKey,
    lens: Option<&LensIllumination>,
) -> Image16 {
    expose_through(sensor, &Readout::ideal(sensor.bits), layers, key, lens)
}

/// [`expose`] through a camera's `readout`: its ADC resolution and fixed
/// pattern (`crate::pattern`; the pattern at the sensor's size).
pub fn expose_through(
    sensor: &Sensor,
    readout: &Readout,
    layers: &[Exposure<'_>],
    key: NoiseKey,
    lens: Option<&LensIllumination>,
) -> Image16 {
    let conversion = Conversion::new(sensor, Adc::new(sensor, readout.adc_bits()));
    let w = sensor.width as usize;
    let mut data = vec![0u16; w * sensor.height as usize];
    match readout.pattern(sensor.width, sensor.height) {
        None => expose_plain(&mut data, sensor, conversion, layers, key, lens),
        Some(p) => {
            let rows = PatternedRows {
                sensor,
                conversion,
                pattern: &p,
                layers,
                key,
                lens,
            };
            data.par_chunks_mut(w).enumerate().for_each_init(
                || PatternRows::new(w),
                |scratch, (v, out)| rows.row(v, out, scratch),
            );
        }
    }
    // The buffer has exactly width·height samples by construction.
    ImageBuffer::from_raw(sensor.width, sensor.height, data)
        .unwrap_or_else(|| ImageBuffer::new(sensor.width, sensor.height))
}

/// The rows (`data`, row-major) of a sensor without a fixed pattern: the
/// uniform background by the exact alias sampler, every other pixel by a
/// normal draw.
fn expose_plain(
    data: &mut [u16],
    sensor: &Sensor,
    conversion: Conversion,
    layers: &[Exposure<'_>],
    key: NoiseKey,
    lens: Option<&LensIllumination>,
) {
    use rand_pcg::rand_core::Rng;
    let w = sensor.width as usize;
    let (adc, noisy) = (conversion.adc, conversion.noisy);
    let sd_of = |m: f64| conversion.sd(m);
    // The uniform background (no gradient, no fall-off): sampled exactly in DN.
    let flat = sensor.gradient_e_per_px == [0.0, 0.0] && lens.is_none();
    let bg = sensor.background_e;
    let sampler = if noisy && flat {
        QuantisedNoise::new(
            (sensor.offset_dn + sensor.gain_dn_per_e * bg) * adc.scale,
            conversion.gain * sd_of(bg),
            adc.max,
        )
    } else {
        None
    };
    let row_is_plain = |v: usize| {
        let vf = v as f64;
        flat && !sensor
            .stray_light
            .iter()
            .any(|s| s.peak_e != 0.0 && (vf - s.v).abs() <= STRAY_REACH_SIGMAS * s.sigma_px)
            && !layers.iter().any(|l| {
                let r = v as i64 - l.signal.y0;
                r >= 0 && (r as usize) < l.signal.height
            })
    };
    data.par_chunks_mut(w).enumerate().for_each_init(
        || vec![0.0f64; w],
        |mean, (v, out)| {
            if !noisy {
                mean_row(sensor, layers, v, mean, lens);
                for (o, &m) in out.iter_mut().zip(mean.iter()) {
                    *o = conversion.code(m);
                }
                return;
            }
            let mut rng = key.row_rng(v as u32);
            if let (Some(q), true) = (&sampler, row_is_plain(v)) {
                for o in out.iter_mut() {
                    *o = q.sample(rng.next_u64()) << adc.shift;
                }
                return;
            }
            mean_row(sensor, layers, v, mean, lens);
            let mut last = f64::NAN;
            let mut sd = 0.0;
            for (o, &m) in out.iter_mut().zip(mean.iter()) {
                if let (Some(q), true) = (&sampler, m == bg) {
                    *o = q.sample(rng.next_u64()) << adc.shift;
                    continue;
                }
                if m != last {
                    sd = sd_of(m);
                    last = m;
                }
                let z: f64 = StandardNormal.sample(&mut rng);
                *o = conversion.code(m + sd * z);
            }
        },
    );
}

/// Scratch rows of [`PatternedRows`]: mean electrons, the pattern's
/// relative gain, dark electrons and dark offset.
#[derive(Debug, Clone)]
struct PatternRows {
    mean: Vec<f64>,
    gain: Vec<f64>,
    dark_e: Vec<f64>,
    offset: Vec<f64>,
}

impl PatternRows {
    fn new(width: usize) -> Self {
        Self {
            mean: vec![0.0; width],
            gain: vec![0.0; width],
            dark_e: vec![0.0; width],
            offset: vec![0.0; width],
        }
    }
}

/// The exposure of a sensor with a fixed pattern: every pixel by a normal
/// draw of `e ~ N(μ·(1 + g) + h, shot + σ_read²)`, then `offset + d + K·e`
/// (module `pattern`).
struct PatternedRows<'a> {
    sensor: &'a Sensor,
    conversion: Conversion,
    pattern: &'a FixedPattern,
    layers: &'a [Exposure<'a>],
    key: NoiseKey,
    lens: Option<&'a LensIllumination>,
}

impl PatternedRows<'_> {
    /// Row `v` into `out`.
    fn row(&self, v: usize, out: &mut [u16], s: &mut PatternRows) {
        mean_row(self.sensor, self.layers, v, &mut s.mean, self.lens);
        self.pattern
            .row(v as u32, &mut s.gain, &mut s.dark_e, &mut s.offset);
        let mut rng = self.key.row_rng(v as u32);
        let c = &self.conversion;
        for (u, o) in out.iter_mut().enumerate() {
            let mut e = s.mean[u] * s.gain[u] + s.dark_e[u];
            if c.noisy {
                let z: f64 = StandardNormal.sample(&mut rng);
                e += c.sd(e) * z;
            }
            *o = c.code_with_offset(e, s.offset[u]);
        }
    }
}

/// Stray-light blobs are evaluated out to this many σ.
const STRAY_REACH_SIGMAS: f64 = 6.0;

/// Mean electrons of row `v` into `mean`: background light (times `lens`'s
/// relative illumination when given), then the signal layers.
pub fn mean_row(
    sensor: &Sensor,
    layers: &[Exposure<'_>],
    v: usize,
    mean: &mut [f64],
    lens: Option<&LensIllumination>,
) {
    let vf = v as f64;
    let b0 = sensor.background_at(0.0, vf);
    let gu = sensor.gradient_e_per_px[0];
    if gu == 0.0 {
        mean.fill(b0);
    } else {
        for (u, m) in mean.iter_mut().enumerate() {
            *m = b0 + gu * u as f64;
        }
    }
    for s in &sensor.stray_light {
        let reach = STRAY_REACH_SIGMAS * s.sigma_px;
        let dv = vf - s.v;
        if dv.abs() > reach || s.peak_e == 0.0 {
            continue;
        }
        let row_peak = s.peak_e * (-(dv * dv) / (2.0 * s.sigma_px * s.sigma_px)).exp();
        let lo = (s.u - reach).floor().max(0.0) as usize;
        let hi = ((s.u + reach).ceil().max(0.0) as usize).min(mean.len());
        for (u, m) in mean.iter_mut().enumerate().take(hi).skip(lo) {
            let du = u as f64 - s.u;
            *m += row_peak * (-(du * du) / (2.0 * s.sigma_px * s.sigma_px)).exp();
        }
    }
    if let Some(lens) = lens {
        lens.scale_row(vf, mean);
    }
    for layer in layers {
        let sig = layer.signal;
        let r = v as i64 - sig.y0;
        if r < 0 || r as usize >= sig.height {
            continue;
        }
        let row = &sig.values[r as usize * sig.width..(r as usize + 1) * sig.width];
        // Columns of the layer inside the image.
        let c0 = (-sig.x0).max(0) as usize;
        let c1 = ((mean.len() as i64 - sig.x0).max(0) as usize).min(sig.width);
        for c in c0..c1 {
            mean[(sig.x0 + c as i64) as usize] += layer.radiance_e * row[c];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sensor() -> Sensor {
        Sensor {
            width: 512,
            height: 384,
            bits: 16,
            gain_dn_per_e: 4.0,
            offset_dn: 400.0,
            read_noise_e: 5.0,
            shot_noise: true,
            background_e: 200.0,
            gradient_e_per_px: [0.0, 0.0],
            stray_light: Vec::new(),
        }
    }

    /// Background mean and variance against the configured noise, through
    /// both noise paths: the exact DN sampler of the uniform background, and
    /// normal draws (a uniform signal layer over the whole frame moves every
    /// pixel off the background). 196,608 pixels: the sample mean's standard
    /// error is σ/√N ≈ 0.14 DN (1e-4 relative), the variance's relative
    /// standard error √(2/N) = 0.32 %. The 2 % is > 6 standard errors
    /// yet catches any wrong term (read noise alone is 11 % of the variance;
    /// rounding adds 1/12 DN²); the mean is also held to 5 standard errors.
    #[test]
    fn background_statistics_match_the_configuration() {
        let flat = Signal {
            x0: 0,
            y0: 0,
            width: 512,
            height: 384,
            values: vec![1.0; 512 * 384],
        };
        for (s, extra_e) in [
            (sensor(), 0.0),
            (sensor(), 300.0),
            (
                Sensor {
                    bits: 8,
                    gain_dn_per_e: 0.05,
                    offset_dn: 10.0,
                    background_e: 600.0,
                    read_noise_e: 8.0,
                    ..sensor()
                },
                0.0,
            ),
        ] {
            let layers = [Exposure {
                signal: &flat,
                radiance_e: extra_e,
            }];
            let img = expose(
                &s,
                if extra_e > 0.0 { &layers } else { &[] },
                NoiseKey {
                    seed: 7,
                    frame: 3,
                    camera: 2,
                },
                None,
            );
            let n = img.len() as f64;
            let mean = img.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
            let var = img
                .iter()
                .map(|&x| (f64::from(x) - mean).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            let e = s.background_e + extra_e;
            let want_mean = s.expected_dn(e);
            let want_var = s.variance_dn2(e) + 1.0 / 12.0;
            assert!(
                (mean / want_mean - 1.0).abs() < 0.02,
                "mean {mean} vs {want_mean}"
            );
            assert!(
                (mean - want_mean).abs() < 5.0 * (want_var / n).sqrt(),
                "mean {mean} vs {want_mean}"
            );
            assert!(
                (var / want_var - 1.0).abs() < 0.02,
                "variance {var} vs {want_var}"
            );
        }
    }

    /// The alias sampler reproduces the exact DN probabilities.
    #[test]
    fn dn_sampler_is_exact() {
        let (mu, sd) = (3.3, 1.7);
        let q = QuantisedNoise::new(mu, sd, 255).unwrap();
        let mut rng = rand_pcg::Pcg64::new(1, 2);
        let n = 1_000_000;
        let mut counts = vec![0u32; 256];
        for _ in 0..n {
            use rand_pcg::rand_core::Rng;
            counts[usize::from(q.sample(rng.next_u64()))] += 1;
        }
        let cdf = |x: f64| 0.5 * libm::erfc(-(x - mu) / (sd * std::f64::consts::SQRT_2));
        for (k, &count) in counts.iter().enumerate().take(12) {
            let p = if k == 0 {
                cdf(0.5)
            } else {
                cdf(k as f64 + 0.5) - cdf(k as f64 - 0.5)
            };
            let f = f64::from(count) / f64::from(n);
            // Binomial standard error √(p(1−p)/n) ≤ 5e-4; allow 5 of them.
            assert!(
                (f - p).abs() < 5.0 * (p * (1.0 - p) / f64::from(n)).sqrt() + 1e-6,
                "DN {k}: {f} vs {p}"
            );
        }
    }

    #[test]
    fn saturation_and_gradient() {
        let mut s = sensor();
        s.read_noise_e = 0.0;
        s.shot_noise = false;
        s.gradient_e_per_px = [1.0, 0.0];
        s.stray_light = vec![StrayLight {
            u: 100.0,
            v: 100.0,
            sigma_px: 5.0,
            peak_e: 1e6,
        }];
        let img = expose(
            &s,
            &[],
            NoiseKey {
                seed: 0,
                frame: 0,
                camera: 1,
            },
            None,
        );
        assert_eq!(img.get_pixel(100, 100).0[0], u16::MAX);
        // Noise-free: DN = 400 + 4·(200 + (u − 255.5)).
        assert_eq!(img.get_pixel(300, 300).0[0], 400 + 4 * (200 + 44) + 2);
        assert_eq!(img.get_pixel(0, 300).0[0], 400 + 4 * 200 - 4 * 255 - 2);
    }

    #[test]
    fn same_key_same_bytes_any_thread_count() {
        let s = sensor();
        let key = NoiseKey {
            seed: 11,
            frame: 5,
            camera: 3,
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let four = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let a = one.install(|| expose(&s, &[], key, None));
        let b = four.install(|| expose(&s, &[], key, None));
        assert_eq!(a.as_raw(), b.as_raw());
        let c = expose(&s, &[], NoiseKey { frame: 6, ..key }, None);
        assert_ne!(a.as_raw(), c.as_raw());
    }
}
