//! The sensor's readout beyond the ideal model (EMVA 1288 terms,
//! docs/renderer.md): the ADC's resolution and the fixed pattern of each
//! camera — per-pixel gain (PRNU), per-pixel dark offset (DSNU), column and
//! row offsets, hot and dead pixels.
//!
//! A pixel (u, v) receiving μ electrons of light reads
//! `DN = offset + d(u, v) + K·e`, `e ~ N(μ·(1 + g(u, v)) + h(u, v), shot + σ_read²)`:
//! `1 + g` the pixel's relative gain (g ~ N(0, prnu²), clamped at 0; 0 for a
//! dead pixel), `h` a hot pixel's dark electrons, `d = dsnu + column(u) + row(v)`
//! in file DN. The ADC converts `DN/2^s` (s = file bits − ADC bits) to an
//! integer, clamped to the ADC's range, and writes it shifted left by s.
//!
//! The pattern is a function of (campaign seed, camera serial, the pattern
//! parameters, image size) alone: the same in every frame of a campaign.
//! Each map is drawn from its own PCG stream per row (see
//! `sensor::chacha_key`), so enabling one map does not change another; the
//! per-pixel maps are built on first use and cached per camera (4 bytes a
//! pixel and map: 50 MB a map at 4096×3072), on one thread (no nested
//! parallel work inside the cache's lock).

use std::collections::BTreeSet;
use std::sync::{Arc, OnceLock};

use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64Mcg;
use rand_pcg::rand_core::Rng;

use crate::sensor::chacha_key;

/// Purpose tag of the fixed-pattern streams (see `sensor::chacha_key`).
const PATTERN_PURPOSE: u64 = 5;
/// Purpose tag of a camera serial's hash.
const SERIAL_PURPOSE: u64 = 6;

/// The maps of a pattern, each its own stream family.
#[derive(Debug, Clone, Copy)]
enum Map {
    Gain = 1,
    Dsnu = 2,
    Column = 3,
    Row = 4,
    Defects = 5,
}

/// The fixed-pattern parameters of a sensor (the `[sensor]` table's keys).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PatternParams {
    /// Relative σ of the per-pixel gain (PRNU), Gaussian.
    pub prnu: f64,
    /// σ of the per-pixel dark offset (DSNU), file DN.
    pub dsnu_dn: f64,
    /// σ of a per-column offset, file DN.
    pub column_offset_dn: f64,
    /// σ of a per-row offset, file DN.
    pub row_offset_dn: f64,
    /// Hot pixels per camera.
    pub hot_pixels: u32,
    /// `[min, max]` of a hot pixel's extra dark electrons per exposure (uniform).
    pub hot_pixel_e: [f64; 2],
    /// Dead pixels per camera (no response to light).
    pub dead_pixels: u32,
}

impl PatternParams {
    /// Whether the sensor has no fixed pattern at all.
    pub fn is_none(&self) -> bool {
        self.prnu == 0.0
            && self.dsnu_dn == 0.0
            && self.column_offset_dn == 0.0
            && self.row_offset_dn == 0.0
            && self.hot_pixels == 0
            && self.dead_pixels == 0
    }
}

/// Identity of a camera's pattern: campaign seed and a hash of the serial.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PatternKey {
    /// Campaign seed.
    pub seed: u64,
    /// Hash of the camera serial ([`PatternKey::new`]).
    pub serial_hash: u64,
}

impl PatternKey {
    /// The key of camera `serial` in a campaign of seed `seed`: the serial's
    /// UTF-8 bytes, little-endian in 64-bit words after its length, hashed
    /// like every stream key (portable, fixed by its constants).
    pub fn new(seed: u64, serial: &str) -> Self {
        let bytes = serial.as_bytes();
        let mut words = vec![bytes.len() as u64];
        words.extend(bytes.chunks(8).map(|c| {
            let mut w = [0u8; 8];
            w[..c.len()].copy_from_slice(c);
            u64::from_le_bytes(w)
        }));
        let k = chacha_key(SERIAL_PURPOSE, &words);
        let mut b = [0u8; 8];
        b.copy_from_slice(&k[..8]);
        Self {
            seed,
            serial_hash: u64::from_le_bytes(b),
        }
    }

    /// The generator of one map's line `index` (a row, or the whole line of
    /// column or row offsets, or the defect draws).
    fn stream(&self, map: Map, index: u64) -> Pcg64Mcg {
        let k = chacha_key(
            PATTERN_PURPOSE,
            &[self.seed, self.serial_hash, map as u64, index],
        );
        let mut b = [0u8; 16];
        b.copy_from_slice(&k[..16]);
        Pcg64Mcg::new(u128::from_le_bytes(b))
    }
}

/// A hot pixel: position and extra dark electrons per exposure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HotPixel {
    /// Column (px).
    pub x: u32,
    /// Row (px).
    pub y: u32,
    /// Extra dark electrons per exposure (shot noise on them).
    pub dark_e: f64,
}

/// The injected defective pixels of a camera, each list sorted by row, then column.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Defects {
    /// Hot pixels.
    pub hot: Vec<HotPixel>,
    /// Dead pixels `[x, y]` (no response to light; offset and read noise only).
    pub dead: Vec<[u32; 2]>,
}

/// Uniform integer in `[0, n)` from one 64-bit draw (multiply-shift; bias ≤ n/2⁶⁴).
fn below(rng: &mut Pcg64Mcg, n: u64) -> u64 {
    ((u128::from(rng.next_u64()) * u128::from(n)) >> 64) as u64
}

/// Uniform in `[0, 1)` from the top 53 bits of one draw.
fn unit(rng: &mut Pcg64Mcg) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

impl Defects {
    /// Draw the defect positions of a `width × height` sensor: distinct pixels,
    /// uniform over the image, the first `hot_pixels` hot (each with its dark
    /// electrons drawn right after its position), the next `dead_pixels` dead.
    pub fn draw(params: &PatternParams, width: u32, height: u32, key: PatternKey) -> Self {
        let n = u64::from(width) * u64::from(height);
        let wanted = u64::from(params.hot_pixels) + u64::from(params.dead_pixels);
        let mut defects = Self::default();
        if wanted == 0 || n == 0 {
            return defects;
        }
        let mut rng = key.stream(Map::Defects, 0);
        let mut taken = BTreeSet::new();
        let [lo, hi] = params.hot_pixel_e;
        // The configuration keeps the defects to at most half the pixels.
        while (taken.len() as u64) < wanted.min(n) {
            let i = below(&mut rng, n);
            if !taken.insert(i) {
                continue;
            }
            let (x, y) = ((i % u64::from(width)) as u32, (i / u64::from(width)) as u32);
            if defects.hot.len() < params.hot_pixels as usize {
                let dark_e = lo + (hi - lo) * unit(&mut rng);
                defects.hot.push(HotPixel { x, y, dark_e });
            } else {
                defects.dead.push([x, y]);
            }
        }
        defects.hot.sort_by_key(|h| (h.y, h.x));
        defects.dead.sort_by_key(|d| (d[1], d[0]));
        defects
    }
}

/// The maps of one camera's fixed pattern at one image size.
#[derive(Clone, PartialEq)]
pub struct FixedPattern {
    width: u32,
    height: u32,
    /// Per-pixel relative gain `1 + g` (clamped at 0), row-major; `None`: 1.
    gain: Option<Vec<f32>>,
    /// Per-pixel dark offset (file DN); `None`: 0.
    dsnu: Option<Vec<f32>>,
    /// Per-column offset (file DN).
    column: Option<Vec<f32>>,
    /// Per-row offset (file DN).
    row: Option<Vec<f32>>,
    defects: Defects,
}

impl std::fmt::Debug for FixedPattern {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FixedPattern")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("gain", &self.gain.is_some())
            .field("dsnu", &self.dsnu.is_some())
            .field("column", &self.column.is_some())
            .field("row", &self.row.is_some())
            .field("hot", &self.defects.hot.len())
            .field("dead", &self.defects.dead.len())
            .finish()
    }
}

/// `mean + σ·z` for `count` standard normals z of `rng`, as f32.
fn normals(rng: &mut Pcg64Mcg, count: usize, mean: f64, sigma: f64) -> impl Iterator<Item = f32> {
    (0..count).map(move |_| {
        let z: f64 = StandardNormal.sample(rng);
        (mean + sigma * z) as f32
    })
}

/// A per-pixel map `mean + σ·z`, each row from its own stream. Drawn on one
/// thread (≈ 0.1 s for 12.6 M pixels): it is built inside a `OnceLock` that
/// rendering threads wait on, where nested parallel work could steal one of
/// their own frames and re-enter the lock.
fn pixel_map(
    key: PatternKey,
    map: Map,
    width: u32,
    height: u32,
    mean: f64,
    sigma: f64,
) -> Vec<f32> {
    let w = width as usize;
    let mut values = vec![0f32; w * height as usize];
    for (v, row) in values.chunks_mut(w).enumerate() {
        let mut rng = key.stream(map, v as u64);
        for (x, z) in row.iter_mut().zip(normals(&mut rng, w, mean, sigma)) {
            *x = z;
        }
    }
    values
}

impl FixedPattern {
    /// Draw the pattern of a `width × height` sensor.
    pub fn new(params: &PatternParams, width: u32, height: u32, key: PatternKey) -> Self {
        let line = |map: Map, count: u32, sigma: f64| {
            (sigma > 0.0)
                .then(|| normals(&mut key.stream(map, 0), count as usize, 0.0, sigma).collect())
        };
        let gain = (params.prnu > 0.0).then(|| {
            let mut g = pixel_map(key, Map::Gain, width, height, 1.0, params.prnu);
            g.iter_mut().for_each(|x| *x = x.max(0.0));
            g
        });
        Self {
            width,
            height,
            gain,
            dsnu: (params.dsnu_dn > 0.0)
                .then(|| pixel_map(key, Map::Dsnu, width, height, 0.0, params.dsnu_dn)),
            column: line(Map::Column, width, params.column_offset_dn),
            row: line(Map::Row, height, params.row_offset_dn),
            defects: Defects::draw(params, width, height, key),
        }
    }

    /// The defective pixels.
    pub fn defects(&self) -> &Defects {
        &self.defects
    }

    /// Fill row `v`'s relative gain (`1 + g`, 0 for a dead pixel), extra dark
    /// electrons (hot pixels) and dark offset (file DN) into the slices, each
    /// of the image's width.
    pub fn row(&self, v: u32, gain: &mut [f64], dark_e: &mut [f64], offset: &mut [f64]) {
        let w = self.width as usize;
        let at = v as usize * w;
        match &self.gain {
            Some(g) => {
                for (o, &x) in gain.iter_mut().zip(&g[at..at + w]) {
                    *o = f64::from(x);
                }
            }
            None => gain.fill(1.0),
        }
        let row_offset = self.row.as_ref().map_or(0.0, |r| f64::from(r[v as usize]));
        match &self.dsnu {
            Some(d) => {
                for (o, &x) in offset.iter_mut().zip(&d[at..at + w]) {
                    *o = row_offset + f64::from(x);
                }
            }
            None => offset.fill(row_offset),
        }
        if let Some(c) = &self.column {
            for (o, &x) in offset.iter_mut().zip(c) {
                *o += f64::from(x);
            }
        }
        dark_e.fill(0.0);
        let hot = &self.defects.hot;
        let first = hot.partition_point(|h| h.y < v);
        for h in hot[first..].iter().take_while(|h| h.y == v) {
            dark_e[h.x as usize] = h.dark_e;
        }
        let dead = &self.defects.dead;
        let first = dead.partition_point(|d| d[1] < v);
        for d in dead[first..].iter().take_while(|d| d[1] == v) {
            gain[d[0] as usize] = 0.0;
        }
    }
}

/// A camera's fixed pattern, drawn on first use at the image size asked for
/// and cached for that size.
#[derive(Debug)]
struct PatternCell {
    params: PatternParams,
    key: PatternKey,
    cached: OnceLock<Arc<FixedPattern>>,
}

impl PatternCell {
    fn get(&self, width: u32, height: u32) -> Arc<FixedPattern> {
        let make = || Arc::new(FixedPattern::new(&self.params, width, height, self.key));
        let cached = self.cached.get_or_init(make);
        if cached.width == width && cached.height == height {
            Arc::clone(cached)
        } else {
            make()
        }
    }
}

/// How a camera's sensor turns electrons into the file's DN beyond the ideal
/// [`crate::Sensor`]: the ADC's resolution and the fixed pattern. Clones share
/// the cached pattern.
#[derive(Debug, Clone)]
pub struct Readout {
    adc_bits: u8,
    pattern: Option<Arc<PatternCell>>,
}

impl PartialEq for Readout {
    fn eq(&self, other: &Self) -> bool {
        self.adc_bits == other.adc_bits
            && self.params() == other.params()
            && self.pattern.as_ref().map(|p| p.key) == other.pattern.as_ref().map(|p| p.key)
    }
}

impl Readout {
    /// The ideal readout of a `bits`-bit file: an ADC of the file's depth, no pattern.
    pub fn ideal(bits: u8) -> Self {
        Self {
            adc_bits: bits,
            pattern: None,
        }
    }

    /// A readout with an ADC of `adc_bits` (0: the file's depth `bits`) and
    /// the fixed pattern `params` of the camera `key` (none when all off).
    pub fn new(bits: u8, adc_bits: u8, params: PatternParams, key: PatternKey) -> Self {
        Self {
            adc_bits: if adc_bits == 0 { bits } else { adc_bits },
            pattern: (!params.is_none()).then(|| {
                Arc::new(PatternCell {
                    params,
                    key,
                    cached: OnceLock::new(),
                })
            }),
        }
    }

    /// The ADC's resolution (bits).
    pub fn adc_bits(&self) -> u8 {
        self.adc_bits
    }

    /// The fixed-pattern parameters (all zero when there is none).
    pub fn params(&self) -> PatternParams {
        self.pattern.as_ref().map(|p| p.params).unwrap_or_default()
    }

    /// The fixed pattern at a `width × height` image; `None` without one.
    pub fn pattern(&self, width: u32, height: u32) -> Option<Arc<FixedPattern>> {
        self.pattern.as_ref().map(|p| p.get(width, height))
    }

    /// The defective pixels at a `width × height` image (drawn without the maps).
    pub fn defects(&self, width: u32, height: u32) -> Defects {
        self.pattern
            .as_ref()
            .map(|p| Defects::draw(&p.params, width, height, p.key))
            .unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> PatternParams {
        PatternParams {
            prnu: 0.01,
            dsnu_dn: 2.0,
            column_offset_dn: 1.5,
            row_offset_dn: 0.5,
            hot_pixels: 40,
            hot_pixel_e: [500.0, 5000.0],
            dead_pixels: 20,
        }
    }

    /// Defects are distinct pixels inside the image, hot ones within their
    /// electron range; the same key draws the same pattern, another serial another.
    #[test]
    fn defects_are_distinct_and_keyed() {
        let key = PatternKey::new(7, "TRN-SYN-0001");
        let d = Defects::draw(&params(), 64, 48, key);
        assert_eq!((d.hot.len(), d.dead.len()), (40, 20));
        let mut all: BTreeSet<(u32, u32)> = d.hot.iter().map(|h| (h.x, h.y)).collect();
        all.extend(d.dead.iter().map(|p| (p[0], p[1])));
        assert_eq!(all.len(), 60);
        assert!(all.iter().all(|&(x, y)| x < 64 && y < 48));
        assert!(d.hot.iter().all(|h| (500.0..5000.0).contains(&h.dark_e)));
        assert_eq!(d, Defects::draw(&params(), 64, 48, key));
        assert_ne!(
            d,
            Defects::draw(&params(), 64, 48, PatternKey::new(7, "TRN-SYN-0002"))
        );
        assert_ne!(
            d,
            Defects::draw(&params(), 64, 48, PatternKey::new(8, "TRN-SYN-0001"))
        );
        // The pattern's own copy is the same draw.
        assert_eq!(FixedPattern::new(&params(), 64, 48, key).defects(), &d);
    }

    /// One map does not depend on whether another is drawn.
    #[test]
    fn maps_are_independent_streams() {
        let key = PatternKey::new(3, "A");
        let all = FixedPattern::new(&params(), 32, 16, key);
        let only_dsnu = FixedPattern::new(
            &PatternParams {
                dsnu_dn: 2.0,
                ..PatternParams::default()
            },
            32,
            16,
            key,
        );
        assert_eq!(all.dsnu, only_dsnu.dsnu);
        assert!(only_dsnu.gain.is_none() && only_dsnu.defects.hot.is_empty());
    }
}
