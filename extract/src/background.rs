//! Background estimation, global and local, with κσ-clipped statistics
//! (the scheme of astronomical source extractors such as SExtractor: clip at
//! ±3σ about the median until stable; a mesh of boxes, median-filtered, then
//! interpolated bilinearly for the local background).

use crate::frame::FrameView;

/// Clipping half-width in standard deviations.
const CLIP_SIGMA: f64 = 3.0;
/// Standard deviation of a unit Gaussian truncated at ±3σ (to undo the clip's shrinkage).
const CLIPPED_UNIT_SIGMA: f64 = 0.986_654;
/// Iterations of the clipping loop at most.
const CLIP_ITERATIONS: usize = 10;
/// Sampling step of the global estimate (every n-th pixel of every n-th row).
const GLOBAL_SAMPLE_STEP: usize = 16;
/// Smallest box of the local background mesh (px): fewer pixels give no
/// usable clipped statistics.
pub const MIN_MESH_PX: u32 = 8;

/// Background level and noise (DN).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackgroundStats {
    /// Level: mean of the clipped samples.
    pub level: f64,
    /// Noise: standard deviation of the clipped samples, corrected for the clip.
    pub sigma: f64,
}

/// κσ-clipped mean and standard deviation of `samples` (reordered in place).
pub fn clipped_stats(samples: &mut [u16]) -> BackgroundStats {
    if samples.is_empty() {
        return BackgroundStats {
            level: 0.0,
            sigma: 0.0,
        };
    }
    let mid = samples.len() / 2;
    let (_, median, _) = samples.select_nth_unstable(mid);
    let mut centre = f64::from(*median);
    // Start from the median absolute deviation: robust against bright blobs.
    let mut dev: Vec<u16> = samples
        .iter()
        .map(|&s| (f64::from(s) - centre).abs().min(65535.0) as u16)
        .collect();
    let (_, mad, _) = dev.select_nth_unstable(mid);
    let mut sigma = (f64::from(*mad) * 1.4826).max(0.5);
    let mut stats = BackgroundStats {
        level: centre,
        sigma,
    };
    for _ in 0..CLIP_ITERATIONS {
        let (lo, hi) = (centre - CLIP_SIGMA * sigma, centre + CLIP_SIGMA * sigma);
        let (mut n, mut s, mut ss) = (0u64, 0.0f64, 0.0f64);
        for &v in samples.iter() {
            let v = f64::from(v);
            if v >= lo && v <= hi {
                n += 1;
                s += v;
                ss += v * v;
            }
        }
        if n < 2 {
            break;
        }
        let mean = s / n as f64;
        let var = (ss / n as f64 - mean * mean).max(0.0) * n as f64 / (n - 1) as f64;
        let new_sigma = (var.sqrt() / CLIPPED_UNIT_SIGMA).max(1e-9);
        let converged =
            (mean - centre).abs() < 1e-3 * sigma && (new_sigma - sigma).abs() < 1e-3 * sigma;
        centre = mean;
        sigma = new_sigma;
        stats = BackgroundStats { level: mean, sigma };
        if converged {
            break;
        }
    }
    dev.clear();
    stats
}

/// Global background from a sparse grid of samples over the whole frame.
pub fn global(frame: &FrameView<'_>) -> BackgroundStats {
    let mut samples: Vec<u16> = frame
        .pixels
        .chunks(frame.width as usize)
        .step_by(GLOBAL_SAMPLE_STEP)
        .flat_map(|row| row.iter().step_by(GLOBAL_SAMPLE_STEP).copied())
        .collect();
    clipped_stats(&mut samples)
}

/// Local background: clipped statistics per box of a mesh, median-filtered
/// over 3×3 boxes, bilinearly interpolated between box centres.
#[derive(Debug, Clone)]
pub struct BackgroundMesh {
    box_size: u32,
    cols: usize,
    rows: usize,
    level: Vec<f64>,
    sigma: Vec<f64>,
}

impl BackgroundMesh {
    /// Estimate the mesh with boxes of `box_size` px (at least
    /// [`MIN_MESH_PX`]; a box larger than the frame is the whole frame).
    pub fn estimate(frame: &FrameView<'_>, box_size: u32) -> Self {
        let box_size = box_size
            .max(MIN_MESH_PX)
            .min(frame.width.max(frame.height).max(MIN_MESH_PX));
        let cols = frame.width.div_ceil(box_size) as usize;
        let rows = frame.height.div_ceil(box_size) as usize;
        let mut level = Vec::with_capacity(cols * rows);
        let mut sigma = Vec::with_capacity(cols * rows);
        let (bw, bh) = (
            box_size.min(frame.width) as usize,
            box_size.min(frame.height) as usize,
        );
        let mut samples = Vec::with_capacity(bw * bh);
        let step = box_size as usize;
        for by in 0..rows {
            for bx in 0..cols {
                samples.clear();
                let (x0, y0) = (bx * step, by * step);
                let (x1, y1) = (
                    (x0 + step).min(frame.width as usize),
                    (y0 + step).min(frame.height as usize),
                );
                for y in y0..y1 {
                    samples.extend_from_slice(&frame.row(y as u32)[x0..x1]);
                }
                let s = clipped_stats(&mut samples);
                level.push(s.level);
                sigma.push(s.sigma);
            }
        }
        let level = median3x3(&level, cols, rows);
        let sigma = median3x3(&sigma, cols, rows);
        Self {
            box_size,
            cols,
            rows,
            level,
            sigma,
        }
    }

    /// Interpolated (level, σ) at pixel (x, y).
    pub fn at(&self, x: u32, y: u32) -> (f64, f64) {
        let half = f64::from(self.box_size) / 2.0;
        let gx = ((f64::from(x) + 0.5 - half) / f64::from(self.box_size))
            .clamp(0.0, (self.cols - 1) as f64);
        let gy = ((f64::from(y) + 0.5 - half) / f64::from(self.box_size))
            .clamp(0.0, (self.rows - 1) as f64);
        let (i0, j0) = (gx.floor() as usize, gy.floor() as usize);
        let (i1, j1) = ((i0 + 1).min(self.cols - 1), (j0 + 1).min(self.rows - 1));
        let (wx, wy) = (gx - i0 as f64, gy - j0 as f64);
        let lerp = |v: &[f64]| {
            let a = v[j0 * self.cols + i0] * (1.0 - wx) + v[j0 * self.cols + i1] * wx;
            let b = v[j1 * self.cols + i0] * (1.0 - wx) + v[j1 * self.cols + i1] * wx;
            a * (1.0 - wy) + b * wy
        };
        (lerp(&self.level), lerp(&self.sigma))
    }
}

/// 3×3 median filter of a small grid (edges use the available neighbours).
fn median3x3(v: &[f64], cols: usize, rows: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(v.len());
    let mut window = Vec::with_capacity(9);
    for j in 0..rows {
        for i in 0..cols {
            window.clear();
            for jj in j.saturating_sub(1)..=(j + 1).min(rows - 1) {
                for ii in i.saturating_sub(1)..=(i + 1).min(cols - 1) {
                    window.push(v[jj * cols + ii]);
                }
            }
            window.sort_by(f64::total_cmp);
            out.push(window[window.len() / 2]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-normal samples (sum of 12 uniforms − 6).
    fn gaussian_samples(n: usize, mean: f64, sigma: f64) -> Vec<u16> {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let z: f64 = (0..12).map(|_| uniform()).sum::<f64>() - 6.0;
                (mean + sigma * z).round() as u16
            })
            .collect()
    }

    #[test]
    fn clipped_stats_ignore_bright_outliers() {
        let mut s = gaussian_samples(100_000, 1000.0, 20.0);
        // 2 % bright pixels (a blob) must not move the estimate.
        for v in s.iter_mut().step_by(50) {
            *v = 40_000;
        }
        let b = clipped_stats(&mut s);
        assert!((b.level - 1000.0).abs() < 0.5, "level {}", b.level);
        assert!((b.sigma - 20.0).abs() < 0.6, "sigma {}", b.sigma);
    }

    #[test]
    fn mesh_follows_a_gradient() {
        let (w, h) = (256u32, 128u32);
        let px: Vec<u16> = (0..h)
            .flat_map(|_| (0..w).map(|x| 1000 + x as u16 * 4))
            .collect();
        let f = FrameView::new(w, h, 16, &px).unwrap();
        let mesh = BackgroundMesh::estimate(&f, 32);
        let (lvl, _) = mesh.at(128, 64);
        assert!((lvl - 1512.0).abs() < 10.0, "{lvl}");
    }
}
