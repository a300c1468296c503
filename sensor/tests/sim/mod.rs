//! An in-test simulator of the METHODS §6 pixel model, independent of the
//! crate: `y = offset + d_px + col_x + row_y + K·e`, electrons
//! `e ~ N(μ, μ + σ_d²)` (Gaussian shot and read noise),
//! `μ = s(x, y)·(1 + g_px) + hot_px`, quantised by an `adc_bits` ADC and
//! written left-shifted into a 16-bit file. Fixed patterns and noise from
//! seeded PCG generators.

#![allow(dead_code)]

use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64Mcg;
use rand_pcg::rand_core::Rng;

/// Frame size of the tests: small enough for a fast test, large enough
/// (49 152 px) for statistics to 1 %.
pub const WIDTH: usize = 256;
pub const HEIGHT: usize = 192;

/// The sensor of one test.
#[derive(Debug, Clone)]
pub struct Sensor {
    pub width: usize,
    pub height: usize,
    pub adc_bits: u32,
    /// K, file DN per electron.
    pub gain: f64,
    pub read_noise_e: f64,
    pub offset_dn: f64,
    /// 1 + g_px (PRNU; dead, weak, strong pixels included).
    pub response: Vec<f64>,
    /// d_px + col_x + row_y (DN).
    pub dark_dn: Vec<f64>,
    /// Dark electrons per frame (hot pixels).
    pub hot_e: Vec<f64>,
    /// The injected defects (x, y, kind code 1..4).
    pub defects: Vec<(usize, usize, u8)>,
    /// Realised sample σ of the PRNU over the good pixels.
    pub prnu: f64,
    /// Realised σ of the pixel DSNU and of the column offsets (DN).
    pub pixel_dsnu_dn: f64,
    pub column_dsnu_dn: f64,
}

/// What the fixed pattern holds.
#[derive(Debug, Clone)]
pub struct Pattern {
    pub prnu: f64,
    pub pixel_dsnu_dn: f64,
    pub column_dsnu_dn: f64,
    pub row_dsnu_dn: f64,
    /// One column this much brighter (DN) in the dark.
    pub bright_column: Option<(usize, f64)>,
    /// Hot pixel amplitudes (DN of dark signal), placed at random.
    pub hot_dn: Vec<f64>,
    /// Dead (response 0), weak (0.5), strong (1.5) pixels, at random; plus a
    /// 2×2 cluster of dead pixels when `dead_cluster`.
    pub dead: usize,
    pub weak: usize,
    pub strong: usize,
    pub dead_cluster: bool,
}

impl Pattern {
    /// The case: PRNU 1 %, DSNU, column offsets with one bright
    /// column, hot pixels from 200 DN up, a few dead/weak/strong pixels.
    pub fn realistic() -> Self {
        Self {
            prnu: 0.01,
            pixel_dsnu_dn: 6.0,
            column_dsnu_dn: 8.0,
            row_dsnu_dn: 2.0,
            bright_column: Some((77, 400.0)),
            hot_dn: [200.0, 300.0, 500.0, 1000.0, 2000.0, 5000.0, 8000.0]
                .iter()
                .cycle()
                .take(42)
                .copied()
                .collect(),
            dead: 6,
            weak: 6,
            strong: 6,
            dead_cluster: true,
        }
    }

    /// No fixed pattern at all.
    pub fn ideal() -> Self {
        Self {
            prnu: 0.0,
            pixel_dsnu_dn: 0.0,
            column_dsnu_dn: 0.0,
            row_dsnu_dn: 0.0,
            bright_column: None,
            hot_dn: Vec::new(),
            dead: 0,
            weak: 0,
            strong: 0,
            dead_cluster: false,
        }
    }
}

fn rng(seed: u64, stream: u64) -> Pcg64Mcg {
    Pcg64Mcg::new((u128::from(seed) << 64 | u128::from(stream)) | 1)
}

fn normal(r: &mut Pcg64Mcg) -> f64 {
    StandardNormal.sample(r)
}

impl Sensor {
    /// 12-bit ADC left-shifted by 4, K = 4 file DN/e⁻, σ_d = 5 e⁻,
    /// offset 1600 DN, with `pattern` drawn from `seed`.
    pub fn twelve_bit(pattern: &Pattern, seed: u64) -> Self {
        Self::new(WIDTH, HEIGHT, 12, 4.0, 5.0, 1600.0, pattern, seed)
    }

    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: usize,
        height: usize,
        adc_bits: u32,
        gain: f64,
        read_noise_e: f64,
        offset_dn: f64,
        pattern: &Pattern,
        seed: u64,
    ) -> Self {
        let n = width * height;
        let mut r = rng(seed, 0xfeed);
        let mut response: Vec<f64> = (0..n)
            .map(|_| 1.0 + pattern.prnu * normal(&mut r))
            .collect();
        let columns: Vec<f64> = (0..width)
            .map(|_| pattern.column_dsnu_dn * normal(&mut r))
            .collect();
        let rows: Vec<f64> = (0..height)
            .map(|_| pattern.row_dsnu_dn * normal(&mut r))
            .collect();
        let pixel: Vec<f64> = (0..n)
            .map(|_| pattern.pixel_dsnu_dn * normal(&mut r))
            .collect();
        let mut dark_dn: Vec<f64> = (0..n)
            .map(|i| pixel[i] + columns[i % width] + rows[i / width])
            .collect();
        if let Some((x, dn)) = pattern.bright_column {
            for y in 0..height {
                dark_dn[y * width + x] += dn;
            }
        }
        // Defects at distinct random pixels away from the border and from
        // each other (so each stands alone unless meant as a cluster).
        let mut taken = vec![false; n];
        let mut place = |r: &mut Pcg64Mcg| loop {
            let x = 3 + (r.next_u64() % (width as u64 - 6)) as usize;
            let y = 3 + (r.next_u64() % (height as u64 - 6)) as usize;
            let free = (y - 2..=y + 2).all(|yy| (x - 2..=x + 2).all(|xx| !taken[yy * width + xx]));
            if free {
                taken[y * width + x] = true;
                return (x, y);
            }
        };
        let mut hot_e = vec![0.0; n];
        let mut defects = Vec::new();
        for &dn in &pattern.hot_dn {
            let (x, y) = place(&mut r);
            hot_e[y * width + x] = dn / gain;
            defects.push((x, y, 1));
        }
        for (count, value, code) in [
            (pattern.dead, 0.0, 2),
            (pattern.weak, 0.5, 3),
            (pattern.strong, 1.5, 4),
        ] {
            for _ in 0..count {
                let (x, y) = place(&mut r);
                response[y * width + x] = value;
                defects.push((x, y, code));
            }
        }
        if pattern.dead_cluster {
            let (x, y) = place(&mut r);
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                response[(y + dy) * width + x + dx] = 0.0;
                defects.push((x + dx, y + dy, 2));
            }
        }
        let is_defect = |i: usize| defects.iter().any(|&(x, y, _)| y * width + x == i);
        let good: Vec<usize> = (0..n).filter(|&i| !is_defect(i)).collect();
        let prnu = sample_sigma(good.iter().map(|&i| response[i]));
        let pixel_dsnu_dn = sample_sigma(good.iter().map(|&i| pixel[i]));
        let column_dsnu_dn = sample_sigma(columns.iter().copied());
        Self {
            width,
            height,
            adc_bits,
            gain,
            read_noise_e,
            offset_dn,
            response,
            dark_dn,
            hot_e,
            defects,
            prnu,
            pixel_dsnu_dn,
            column_dsnu_dn,
        }
    }

    /// The left shift of the ADC into 16 bits.
    pub fn step(&self) -> f64 {
        f64::from(1u32 << (16 - self.adc_bits))
    }

    /// The largest file value.
    pub fn saturation(&self) -> u16 {
        (((1u32 << self.adc_bits) - 1) << (16 - self.adc_bits)) as u16
    }

    /// One frame of scene `signal_e(x, y)` (electrons before PRNU), noise
    /// drawn from `(seed, frame)`; `noise: false` gives the expected frame.
    pub fn frame(
        &self,
        signal_e: &dyn Fn(usize, usize) -> f64,
        seed: u64,
        noise: bool,
    ) -> Vec<u16> {
        let mut r = rng(seed, 0x1000);
        let top = f64::from((1u32 << self.adc_bits) - 1);
        let step = self.step();
        (0..self.width * self.height)
            .map(|i| {
                let (x, y) = (i % self.width, i / self.width);
                let mu = signal_e(x, y) * self.response[i] + self.hot_e[i];
                let e = if noise {
                    mu + (mu + self.read_noise_e.powi(2)).sqrt() * normal(&mut r)
                } else {
                    mu
                };
                let v = self.offset_dn + self.dark_dn[i] + self.gain * e;
                let adc = (v / step).round().clamp(0.0, top);
                (adc * step) as u16
            })
            .collect()
    }

    /// A stack of `n` frames of a scene, frame k drawn with seed `seed + k`.
    pub fn stack(
        &self,
        signal_e: &dyn Fn(usize, usize) -> f64,
        n: usize,
        seed: u64,
    ) -> Vec<Vec<u16>> {
        (0..n)
            .map(|k| self.frame(signal_e, seed + k as u64, true))
            .collect()
    }

    /// The relative fall-off of the flat-field source through the lens:
    /// `1 − 0.35·ρ²`, ρ the distance from the centre over the half-diagonal.
    pub fn falloff(&self, u: f64, v: f64) -> f64 {
        let (cu, cv) = (
            (self.width as f64 - 1.0) / 2.0,
            (self.height as f64 - 1.0) / 2.0,
        );
        let rho2 = ((u - cu).powi(2) + (v - cv).powi(2)) / (cu * cu + cv * cv);
        1.0 - 0.35 * rho2
    }

    /// A flat at `fraction` of the full scale at the centre (electrons).
    pub fn flat_signal(&self, fraction: f64) -> impl Fn(usize, usize) -> f64 + '_ {
        let centre_e = (fraction * f64::from(self.saturation()) - self.offset_dn) / self.gain;
        move |x, y| centre_e * self.falloff(x as f64, y as f64)
    }
}

/// Frames of a stack as `sensor::Frame`s.
pub fn frames<'a>(
    stack: &'a [Vec<u16>],
    sensor: &Sensor,
    exposure_s: Option<f64>,
) -> Vec<sensor::Frame<'a>> {
    stack
        .iter()
        .map(|values| sensor::Frame {
            values,
            width: sensor.width as u32,
            height: sensor.height as u32,
            container_bits: 16,
            exposure_s,
        })
        .collect()
}

/// Sample standard deviation.
pub fn sample_sigma(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = values.clone().count() as f64;
    let mean = values.clone().sum::<f64>() / n;
    (values.map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}
