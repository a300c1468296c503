//! Optics: Gaussian point-spread function, thin-lens defocus, and the blur of
//! a coverage layer into the signal it produces on the sensor.
//!
//! The pixel value of a blurred silhouette S is `P(q) = ∫ S(x)·W(q − x) dx`,
//! `W = G_σ ∗ box` (PSF, then pixel-area integration). With S known per pixel
//! p by its covered area A_p and first moment M_p about the pixel centre, a
//! first-order expansion of W gives
//! `P(q) = Σ_p A_p·W(q − p) − M_p·∇W(q − p)`,
//! evaluated as separable convolutions with the pixel-integrated Gaussian
//! `w(j) = Φ((j + ½)/σ) − Φ((j − ½)/σ)` and its derivative
//! `w'(j) = φ_σ(j + ½) − φ_σ(j − ½)`, normalised so that `Σw = 1` and
//! `Σ j·w'(j) = −1`. Then the image's zeroth and first moments equal the exact
//! area and area-moment of the silhouette, for any sub-pixel position: a
//! symmetric blur cannot move the intensity centroid, and pixel sampling
//! cannot bias it. Second order: the expansion treats a pixel's covered area
//! as concentrated at its centre, losing the 1/12 px² spread of a full pixel;
//! the kernel's σ is raised to give it back ([`kernel_sigma`]), so that the
//! image variance is the physical silhouette + σ² + 1/12. Below
//! [`MIN_SIGMA_FOR_MOMENTS`] the expansion is not meaningful (W is a sharp
//! box): the blur uses w with σ only, i.e. plain pixel-area integration.

use geom::nalgebra::Vector2;
use rayon::prelude::*;

use crate::coverage::Coverage;

/// Smallest blur σ (px) for which the first-moment term is applied.
pub(crate) const MIN_SIGMA_FOR_MOMENTS: f64 = 0.3;

/// Kernel half-width in σ.
const KERNEL_SIGMAS: f64 = 5.0;

/// The lens as the renderer needs it, in the units of one camera's images.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Optics {
    /// In-focus Gaussian PSF standard deviation (px).
    pub psf_sigma_px: f64,
    /// Lens focal length (mm).
    pub focal_mm: f64,
    /// Aperture f-number.
    pub f_number: f64,
    /// Distance of the plane in focus (mm, along the optical axis).
    pub focus_distance_mm: f64,
    /// Pixel pitch (mm).
    pub pixel_mm: f64,
}

impl Optics {
    /// Optics without blur (ideal pinhole, pixel-area integration only).
    pub fn sharp(pixel_mm: f64) -> Self {
        Self {
            psf_sigma_px: 0.0,
            focal_mm: 40.0,
            f_number: f64::INFINITY,
            focus_distance_mm: 460.0,
            pixel_mm,
        }
    }

    /// Thin-lens blur-circle diameter on the sensor (px) of a point at depth
    /// `z` (mm): `c = f²/(N·(s − f))·|z − s|/z`.
    pub fn defocus_diameter_px(&self, z: f64) -> f64 {
        let (f, s) = (self.focal_mm, self.focus_distance_mm);
        if !self.f_number.is_finite() || z <= 0.0 || s <= f {
            return 0.0;
        }
        f * f / (self.f_number * (s - f)) * (z - s).abs() / z / self.pixel_mm
    }

    /// Gaussian σ (px) of the total blur at depth `z`: `σ² = σ_psf² + (c/4)²`
    /// (c/4 matches the second moment of the uniform defocus disc, whose
    /// per-axis variance is c²/16).
    pub fn blur_sigma_px(&self, z: f64) -> f64 {
        let c = self.defocus_diameter_px(z);
        (self.psf_sigma_px * self.psf_sigma_px + c * c / 16.0).sqrt()
    }
}

/// A blurred layer: the fraction of one fully covered pixel's flux that each
/// pixel receives (multiply by the radiance for electrons).
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// Column of the first pixel (may lie outside the image).
    pub x0: i64,
    /// Row of the first pixel.
    pub y0: i64,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Values, row-major.
    pub values: Vec<f64>,
}

impl Signal {
    /// Sum of the values (the silhouette's area in px²).
    pub fn total(&self) -> f64 {
        self.values.iter().sum()
    }

    /// Intensity centroid `Σ f·(u, v)/Σ f` in pixel coordinates.
    pub fn centroid(&self) -> Option<Vector2<f64>> {
        let mut s = Vector2::zeros();
        let mut t = 0.0;
        for r in 0..self.height {
            for c in 0..self.width {
                let f = self.values[r * self.width + c];
                s += Vector2::new((self.x0 + c as i64) as f64, (self.y0 + r as i64) as f64) * f;
                t += f;
            }
        }
        (t > 0.0).then(|| s / t)
    }

    /// Value at pixel (u, v), 0 outside the layer.
    pub fn at(&self, u: i64, v: i64) -> f64 {
        let (c, r) = (u - self.x0, v - self.y0);
        if c < 0 || r < 0 || c as usize >= self.width || r as usize >= self.height {
            return 0.0;
        }
        self.values[r as usize * self.width + c as usize]
    }
}

/// Half-width (px) of the blur kernel for σ.
pub(crate) fn kernel_radius(sigma: f64) -> usize {
    if sigma <= 0.0 {
        0
    } else {
        (KERNEL_SIGMAS * sigma + 1.0).ceil() as usize
    }
}

fn phi(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

fn gauss(x: f64, sigma: f64) -> f64 {
    (-(x * x) / (2.0 * sigma * sigma)).exp() / (sigma * (std::f64::consts::TAU).sqrt())
}

/// Pixel-integrated Gaussian `w` and its derivative `w'` on `−r..=r`,
/// normalised (Σw = 1, Σ j·w'(j) = −1).
pub(crate) fn kernels(sigma: f64) -> (Vec<f64>, Vec<f64>) {
    let r = kernel_radius(sigma) as i64;
    if r == 0 {
        return (vec![1.0], vec![0.0]);
    }
    let mut w: Vec<f64> = (-r..=r)
        .map(|j| {
            let j = j as f64;
            phi((j + 0.5) / sigma) - phi((j - 0.5) / sigma)
        })
        .collect();
    let sum: f64 = w.iter().sum();
    w.iter_mut().for_each(|x| *x /= sum);
    // Exact symmetry: the centroid-preservation argument needs it bit for bit.
    let n = w.len();
    for j in 0..n / 2 {
        let m = 0.5 * (w[j] + w[n - 1 - j]);
        w[j] = m;
        w[n - 1 - j] = m;
    }
    let mut d: Vec<f64> = (-r..=r)
        .map(|j| {
            let j = j as f64;
            gauss(j + 0.5, sigma) - gauss(j - 0.5, sigma)
        })
        .collect();
    for j in 0..n / 2 {
        let m = 0.5 * (d[j] - d[n - 1 - j]);
        d[j] = m;
        d[n - 1 - j] = -m;
    }
    d[n / 2] = 0.0;
    let first: f64 = (-r..=r).zip(&d).map(|(j, v)| j as f64 * v).sum();
    if first.abs() > 0.0 {
        d.iter_mut().for_each(|x| *x /= -first);
    }
    (w, d)
}

/// Discrete variance `Σ j²·w(j)` of the kernel [`kernels`] builds for `s`.
fn kernel_variance(s: f64) -> f64 {
    let (w, _) = kernels(s);
    let r = (w.len() / 2) as f64;
    w.iter()
        .enumerate()
        .map(|(i, v)| (i as f64 - r).powi(2) * v)
        .sum()
}

/// The σ of the pixel-integrated Gaussian used with the first-moment terms:
/// the one whose discrete variance is `σ² + 1/6`. The moment expansion treats
/// each pixel's covered area as a point mass (plus dipole) at its centre, which
/// drops the 1/12 px² within-pixel spread of every full pixel; the kernel adds
/// it back, so the image variance is the physical `var(S) + σ² + 1/12`
/// (silhouette, PSF, pixel integration). Bisection on the monotonic variance.
pub(crate) fn kernel_sigma(sigma: f64) -> f64 {
    let target = sigma * sigma + 1.0 / 6.0;
    let (mut lo, mut hi) = (sigma, sigma + 1.0);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if kernel_variance(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Blur a coverage layer with a Gaussian of `sigma` px (PSF + defocus), keeping
/// its area and first moments exact (see the module docs). The result extends
/// the layer by the kernel radius on every side.
pub fn blur(cov: &Coverage, sigma: f64) -> Signal {
    let moments = sigma >= MIN_SIGMA_FOR_MOMENTS;
    let ks = if moments { kernel_sigma(sigma) } else { sigma };
    let r = kernel_radius(ks);
    let (w, d) = kernels(ks);
    let (cw, ch) = (cov.width, cov.height);
    let (ow, oh) = (cw + 2 * r, ch + 2 * r);
    if cw == 0 || ch == 0 {
        return Signal {
            x0: cov.x0,
            y0: cov.y0,
            width: 0,
            height: 0,
            values: Vec::new(),
        };
    }
    // Horizontal pass over the coverage rows: h1 = A∗w − Mu∗w', h2 = Mv∗w.
    let mut h1 = vec![0.0; ch * ow];
    let mut h2 = vec![0.0; ch * ow];
    h1.par_chunks_mut(ow)
        .zip(h2.par_chunks_mut(ow))
        .enumerate()
        .for_each(|(row, (o1, o2))| {
            let a = &cov.area[row * cw..(row + 1) * cw];
            let mu = &cov.moment_u[row * cw..(row + 1) * cw];
            let mv = &cov.moment_v[row * cw..(row + 1) * cw];
            for p in 0..cw {
                if a[p] == 0.0 && mu[p] == 0.0 && mv[p] == 0.0 {
                    continue;
                }
                // Output column q = p + r + j − r = p + k for kernel index k (offset k − r).
                let (ap, mup, mvp) = (a[p], mu[p], mv[p]);
                let o1 = &mut o1[p..p + 2 * r + 1];
                let o2 = &mut o2[p..p + 2 * r + 1];
                if moments {
                    for k in 0..=2 * r {
                        o1[k] += ap * w[k] - mup * d[k];
                        o2[k] += mvp * w[k];
                    }
                } else {
                    for k in 0..=2 * r {
                        o1[k] += ap * w[k];
                    }
                }
            }
        });
    // Vertical pass: P = h1∗w − h2∗w'.
    let mut values = vec![0.0; oh * ow];
    values.par_chunks_mut(ow).enumerate().for_each(|(q, out)| {
        // Output row q receives coverage rows p with q = p + k, k in 0..=2r.
        let lo = q.saturating_sub(2 * r);
        let hi = q.min(ch - 1);
        if lo > hi {
            return;
        }
        for p in lo..=hi {
            let k = q - p;
            let (wk, dk) = (w[k], d[k]);
            let a = &h1[p * ow..(p + 1) * ow];
            let b = &h2[p * ow..(p + 1) * ow];
            if moments {
                for x in 0..ow {
                    out[x] += a[x] * wk - b[x] * dk;
                }
            } else {
                for x in 0..ow {
                    out[x] += a[x] * wk;
                }
            }
        }
    });
    Signal {
        x0: cov.x0 - r as i64,
        y0: cov.y0 - r as i64,
        width: ow,
        height: oh,
        values,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernels_are_normalised() {
        for sigma in [0.3, 0.55, 1.0, 3.7] {
            let (w, d) = kernels(sigma);
            let r = kernel_radius(sigma) as i64;
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            let m1: f64 = (-r..=r).zip(&w).map(|(j, v)| j as f64 * v).sum();
            assert!(m1.abs() < 1e-15);
            let dm: f64 = (-r..=r).zip(&d).map(|(j, v)| j as f64 * v).sum();
            assert!((dm + 1.0).abs() < 1e-14);
            // Sampled at integer offsets, the pixel-integrated Gaussian has the
            // variance σ² + 1/12 of its continuous form once σ is not small
            // against a pixel (aliasing ∝ exp(−2π²σ²)).
            if sigma >= 1.0 {
                let m2: f64 = (-r..=r).zip(&w).map(|(j, v)| (j * j) as f64 * v).sum();
                assert!(
                    (m2 / (sigma * sigma + 1.0 / 12.0) - 1.0).abs() < 1e-5,
                    "{sigma}: {m2}"
                );
            }
        }
    }

    #[test]
    fn defocus_follows_the_thin_lens() {
        let o = Optics {
            psf_sigma_px: 0.5,
            focal_mm: 40.0,
            f_number: 8.0,
            focus_distance_mm: 460.0,
            pixel_mm: 0.0055,
        };
        assert_eq!(o.defocus_diameter_px(460.0), 0.0);
        // 75 mm behind focus: f²/(N(s−f))·75/535 = 0.0667 mm = 12.1 px.
        let c = o.defocus_diameter_px(535.0);
        assert!((c - 1600.0 / (8.0 * 420.0) * 75.0 / 535.0 / 0.0055).abs() < 1e-9);
        assert!((c - 12.14).abs() < 0.01);
        assert!(o.blur_sigma_px(535.0) > o.blur_sigma_px(500.0));
    }

    /// A point-like coverage at a sub-pixel position: the blurred image keeps
    /// its total and its exact position as the centroid.
    #[test]
    fn blur_preserves_area_and_first_moment() {
        let cov = Coverage {
            x0: 10,
            y0: 20,
            width: 3,
            height: 2,
            area: vec![0.0, 0.3, 1.0, 0.0, 0.2, 0.7],
            moment_u: vec![0.0, 0.06, 0.0, 0.0, -0.03, 0.1],
            moment_v: vec![0.0, -0.05, 0.0, 0.0, 0.02, -0.04],
        };
        let exact = cov.centroid().unwrap();
        for sigma in [0.35, 0.8, 2.5] {
            let s = blur(&cov, sigma);
            assert!((s.total() - cov.total_area()).abs() < 1e-12);
            let c = s.centroid().unwrap();
            assert!(
                (c - exact).norm() < 1e-12,
                "σ = {sigma}: {c:?} vs {exact:?}"
            );
        }
    }
}
