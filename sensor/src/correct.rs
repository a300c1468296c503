//! The per-pixel correction of a frame before its blobs are extracted
//! (METHODS §6): `f′ = black + (f − dark_px)/gain_px`, defective pixels
//! replaced by the mean of their valid 8-neighbours.

use rayon::prelude::*;

use crate::defect_map::{DefectMap, ring};
use crate::{Result, SensorError};

/// What the correction of a frame uses.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorMaps {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// The median of the master dark (DN): added back after the dark is
    /// subtracted, so that the corrected frame keeps the sensor's offset.
    pub black_level_dn: f32,
    /// Per-pixel dark (DN); `None`: the scalar black level only.
    pub dark: Option<Vec<f32>>,
    /// Per-pixel relative gain `1 + g` (median 1); `None`: the smooth model
    /// only.
    pub gain: Option<Vec<f32>>,
    /// Defective pixels, replaced by their neighbours.
    pub defects: DefectMap,
    /// The saturation value (DN): such a pixel stays saturated.
    pub saturation: u16,
}

impl SensorMaps {
    /// `f′ = black + (f − dark_px)/gain_px`, rounded, clamped to
    /// `[0, saturation]`; a pixel at saturation stays at saturation; each
    /// defective pixel is replaced by the mean of its valid (non-defective,
    /// in-frame) 8-neighbours' corrected values, or of those at distance 2
    /// (the 5×5 ring) if it has none, or kept if neither has any. Refuses a
    /// frame or map of another size, and a dark that is not finite or a gain
    /// that is not positive and finite at a pixel. Parallel over rows; the
    /// output does not depend on the number of threads.
    pub fn correct(
        &self,
        frame: &[u16],
        width: u32,
        height: u32,
        out: &mut Vec<u16>,
    ) -> Result<()> {
        self.check_sizes(frame.len(), width, height)?;
        out.clear();
        out.resize(frame.len(), 0);
        let row = self.width as usize;
        let rows: Vec<Result<()>> = out
            .par_chunks_mut(row)
            .zip(frame.par_chunks(row))
            .enumerate()
            .map(|(y, (out, input))| self.correct_row(y, input, out))
            .collect();
        rows.into_iter().collect::<Result<()>>()?;
        self.replace_defects(out);
        Ok(())
    }

    /// Whether every map is absent and there are no defects (correction
    /// would change nothing).
    pub fn is_identity(&self) -> bool {
        self.dark.is_none() && self.gain.is_none() && self.defects.is_empty()
    }

    /// The frame and every map of this size.
    fn check_sizes(&self, len: usize, width: u32, height: u32) -> Result<()> {
        let n = self.width as usize * self.height as usize;
        let size_error = |what: &str, message: String| {
            Err(SensorError::MapSize {
                what: what.into(),
                message,
            })
        };
        if (width, height) != (self.width, self.height) || len != n {
            return size_error(
                "frame",
                format!(
                    "{width}×{height} px ({len} values) where the sensor maps are {}×{} px",
                    self.width, self.height
                ),
            );
        }
        for (what, map) in [("dark map", &self.dark), ("gain map", &self.gain)] {
            if let Some(m) = map.as_ref().filter(|m| m.len() != n) {
                return size_error(
                    what,
                    format!("{} values for {}×{} px", m.len(), self.width, self.height),
                );
            }
        }
        if (self.defects.width, self.defects.height) != (self.width, self.height) {
            return size_error(
                "defect map",
                format!(
                    "{}×{} px where the sensor maps are {}×{} px",
                    self.defects.width, self.defects.height, self.width, self.height
                ),
            );
        }
        Ok(())
    }

    /// Correct one row (before defect replacement).
    fn correct_row(&self, y: usize, input: &[u16], out: &mut [u16]) -> Result<()> {
        let row = self.width as usize;
        let black = f64::from(self.black_level_dn);
        let top = f64::from(self.saturation);
        for (x, (o, &f)) in out.iter_mut().zip(input).enumerate() {
            if f >= self.saturation {
                *o = self.saturation;
                continue;
            }
            let i = y * row + x;
            let dark = self.dark.as_ref().map_or(black, |d| f64::from(d[i]));
            let gain = self.gain.as_ref().map_or(1.0, |g| f64::from(g[i]));
            if !dark.is_finite() {
                return Err(self.value_error("dark map", x, y, dark, "a finite level"));
            }
            if !(gain.is_finite() && gain > 0.0) {
                return Err(self.value_error("gain map", x, y, gain, "a positive gain"));
            }
            let value = black + (f64::from(f) - dark) / gain;
            *o = value.round().clamp(0.0, top) as u16;
        }
        Ok(())
    }

    fn value_error(
        &self,
        what: &str,
        x: usize,
        y: usize,
        value: f64,
        expected: &str,
    ) -> SensorError {
        SensorError::MapValue {
            what: what.into(),
            x: x as u32,
            y: y as u32,
            value,
            expected: format!("{expected} is needed"),
        }
    }

    /// Replace each defective pixel by its valid neighbours' mean; every
    /// replacement reads only corrected values of good pixels.
    fn replace_defects(&self, out: &mut [u16]) {
        let (w, h) = (self.width, self.height);
        let values: &[u16] = out;
        let replaced: Vec<Option<u16>> = self
            .defects
            .defects
            .par_iter()
            .map(|d| {
                (1..=2).find_map(|r| {
                    let (n, sum) = ring(d.x, d.y, r, w, h)
                        .filter(|&(x, y)| !self.defects.is_defect(x, y))
                        .fold((0u32, 0u64), |(n, s), (x, y)| {
                            (
                                n + 1,
                                s + u64::from(values[y as usize * w as usize + x as usize]),
                            )
                        });
                    (n > 0).then(|| ((sum as f64 / f64::from(n)).round()) as u16)
                })
            })
            .collect();
        for (d, v) in self.defects.defects.iter().zip(replaced) {
            if let Some(v) = v {
                out[d.y as usize * w as usize + d.x as usize] = v;
            }
        }
    }
}
