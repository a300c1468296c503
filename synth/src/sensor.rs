//! The image sensor: background (level, linear gradient, stray-light blobs),
//! signal, shot and read noise, gain, offset, quantisation and saturation.
//!
//! Per pixel: mean electrons `μ = background + Σ radiance·signal`;
//! electrons `e = μ + √(μ + σ_read²)·z` with one standard normal z per pixel
//! (the Gaussian approximation of Poisson shot noise plus Gaussian read noise:
//! mean μ, variance μ + σ_read², accurate for the ≥ 100 e⁻ backgrounds used);
//! `DN = round(offset + gain·e)` clamped to `[0, 2^bits − 1]` (saturation).
//! Random numbers: one ChaCha8 stream per (seed, frame, camera) key, one
//! stream id per row, so the bytes do not depend on the thread count.

use image::{ImageBuffer, Luma};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

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
        let (cu, cv) = ((f64::from(self.width) - 1.0) / 2.0, (f64::from(self.height) - 1.0) / 2.0);
        self.background_e + self.gradient_e_per_px[0] * (u - cu) + self.gradient_e_per_px[1] * (v - cv)
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
pub fn chacha_key(purpose: u64, words: &[u64]) -> [u8; 32] {
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
    /// The generator of one row.
    pub fn row_rng(&self, row: u32) -> ChaCha8Rng {
        let mut rng = ChaCha8Rng::from_seed(chacha_key(NOISE_PURPOSE, &[self.seed, self.frame, u64::from(self.camera)]));
        rng.set_stream(u64::from(row));
        rng
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

/// Expose the sensor: background + signals + noise → quantised image.
/// Rows are computed in parallel; the result does not depend on the thread count.
pub fn expose(sensor: &Sensor, layers: &[Exposure<'_>], key: NoiseKey) -> Image16 {
    let (w, h) = (sensor.width as usize, sensor.height as usize);
    let mut data = vec![0u16; w * h];
    let max = sensor.max_dn();
    let rn2 = sensor.read_noise_e * sensor.read_noise_e;
    data.par_chunks_mut(w).enumerate().for_each_init(
        || vec![0.0f64; w],
        |mean, (v, out)| {
            mean_row(sensor, layers, v, mean);
            let mut rng = key.row_rng(v as u32);
            let mut last = f64::NAN;
            let mut sd = 0.0;
            for (o, &m) in out.iter_mut().zip(mean.iter()) {
                let e = if sensor.noisy() {
                    if m != last {
                        let shot = if sensor.shot_noise { m.max(0.0) } else { 0.0 };
                        sd = (shot + rn2).sqrt();
                        last = m;
                    }
                    let z: f64 = StandardNormal.sample(&mut rng);
                    m + sd * z
                } else {
                    m
                };
                let dn = (sensor.offset_dn + sensor.gain_dn_per_e * e).round();
                *o = dn.clamp(0.0, max) as u16;
            }
        },
    );
    // The buffer has exactly width·height samples by construction.
    ImageBuffer::from_raw(sensor.width, sensor.height, data).unwrap_or_else(|| ImageBuffer::new(sensor.width, sensor.height))
}

/// Mean electrons of row `v` into `mean`.
pub fn mean_row(sensor: &Sensor, layers: &[Exposure<'_>], v: usize, mean: &mut [f64]) {
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
        let reach = 6.0 * s.sigma_px;
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

    /// Background mean and variance against the configured noise. 196,608
    /// pixels: the sample mean's standard error is 60/√N = 0.14 DN (0.01 %),
    /// the variance's relative standard error √(2/N) = 0.32 %, so a 2 %
    /// tolerance is > 6 standard errors yet catches any wrong term (read noise
    /// alone would be 11 % of the variance; rounding adds 1/12 DN² = 0.002 %).
    #[test]
    fn background_statistics_match_the_configuration() {
        for s in [
            sensor(),
            Sensor {
                bits: 8,
                gain_dn_per_e: 0.05,
                offset_dn: 10.0,
                background_e: 600.0,
                read_noise_e: 8.0,
                ..sensor()
            },
        ] {
            let img = expose(
                &s,
                &[],
                NoiseKey {
                    seed: 7,
                    frame: 3,
                    camera: 2,
                },
            );
            let n = img.len() as f64;
            let mean = img.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
            let var = img.iter().map(|&x| (f64::from(x) - mean).powi(2)).sum::<f64>() / (n - 1.0);
            let want_mean = s.expected_dn(s.background_e);
            let want_var = s.variance_dn2(s.background_e) + 1.0 / 12.0;
            assert!((mean / want_mean - 1.0).abs() < 0.02, "mean {mean} vs {want_mean}");
            assert!((var / want_var - 1.0).abs() < 0.02, "variance {var} vs {want_var}");
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
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let four = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
        let a = one.install(|| expose(&s, &[], key));
        let b = four.install(|| expose(&s, &[], key));
        assert_eq!(a.as_raw(), b.as_raw());
        let c = expose(&s, &[], NoiseKey { frame: 6, ..key });
        assert_ne!(a.as_raw(), c.as_raw());
    }
}
