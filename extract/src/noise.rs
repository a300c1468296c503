//! The covariance of a corrected centroid from the pixels' temporal noise
//! (METHODS §7), by linear propagation through the weights of
//! `crate::correction`.
//!
//! The centroid `c = Σ wᵢ·pᵢ / Σ wᵢ` with `wᵢ = ((fᵢ − bᵢ)/RIᵢ − T′)·Jᵢ`
//! (thresholded weighting; pixels with `f′ᵢ > T′` only) moves with each
//! pixel's value by `gᵢ = ∂c/∂fᵢ = (pᵢ − c)·(Jᵢ/RIᵢ) / Σ w`, and with the
//! background plane θ = (c, a, b) fitted to the ring by
//! `G_θ = Σᵢ (pᵢ − c)·∂wᵢ/∂θ / Σ w`, `∂wᵢ/∂θ = Jᵢ·(x_k/RI_k − xᵢ/RIᵢ)`,
//! `x = (1, u − u₀, v − v₀)` and k the pixel that sets `T′` (a constant
//! error of the plane cancels in `f′ − T′`; only its tilt remains):
//!
//! `Σ_c = Σᵢ σᵢ²·gᵢgᵢᵀ + G_θ·Σ_θ·G_θᵀ`, `σᵢ² = σ_bg² + K·max(fᵢ − bᵢ, 0)` (DN²),
//!
//! σ_bg the ring's residual σ about its plane (read, quantisation and the
//! background's shot noise, and whatever fixed pattern the frame still
//! carries), K the system gain (DN/e⁻: a signal of s DN has a shot-noise
//! variance of K·s DN²), `Σ_θ = σ_bg²·(XᵀX)⁻¹` the plane's covariance. A
//! pixel crossing the threshold enters with zero weight, so thresholding
//! adds no jump: the linearisation holds across it. The raw weighting
//! (`w = f′·J`) jumps by `T′·J` where a pixel crosses the threshold, which a
//! linear propagation cannot carry: no covariance is given for it.

use geom::{Matrix3, Vector3};

use crate::correction::Mapped;

/// The covariance of a centroid (px²), in the image its positions are in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentroidCovariance {
    /// `var u` (px²).
    pub uu_px2: f64,
    /// `var v` (px²).
    pub vv_px2: f64,
    /// `cov(u, v)` (px²).
    pub uv_px2: f64,
}

impl CentroidCovariance {
    /// `σ_u` (px).
    pub fn sigma_u_px(&self) -> f64 {
        self.uu_px2.sqrt()
    }

    /// `σ_v` (px).
    pub fn sigma_v_px(&self) -> f64 {
        self.vv_px2.sqrt()
    }

    /// `ρ = cov(u, v)/(σ_u·σ_v)`; 0 when either σ is 0.
    pub fn correlation(&self) -> f64 {
        let s = self.sigma_u_px() * self.sigma_v_px();
        if s > 0.0 {
            (self.uv_px2 / s).clamp(-1.0, 1.0)
        } else {
            0.0
        }
    }

    /// `[[var u, cov], [cov, var v]]` (px²).
    pub fn matrix(&self) -> [[f64; 2]; 2] {
        [[self.uu_px2, self.uv_px2], [self.uv_px2, self.vv_px2]]
    }
}

/// The background plane under a blob, as fitted to its ring, with what its
/// noise needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Background {
    /// `b(u, v) = c + a·u + b·v` (DN), absolute pixel coordinates.
    pub(crate) plane: [f64; 3],
    /// Residual σ of the ring about the plane (DN).
    pub(crate) sigma_dn: f64,
    /// `(u₀, v₀)`: the origin of the fit's design rows (px).
    pub(crate) centre: [f64; 2],
    /// `XᵀX` of the fit, rows `x = (1, u − u₀, v − v₀)`.
    pub(crate) normal: Matrix3<f64>,
}

impl Background {
    /// The design row `x = (1, u − u₀, v − v₀)` of pixel (u, v).
    fn design(&self, at: [f64; 2]) -> Vector3<f64> {
        Vector3::new(1.0, at[0] - self.centre[0], at[1] - self.centre[1])
    }

    /// `Σ_θ = σ_bg²·(XᵀX)⁻¹`; `None` for a singular ring.
    fn covariance(&self) -> Option<Matrix3<f64>> {
        self.normal
            .try_inverse()
            .map(|inv| inv * self.sigma_dn.powi(2))
    }
}

/// A pixel that carries weight in a corrected centroid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct WeightedPixel {
    /// Observed pixel (u, v).
    pub(crate) observed: [f64; 2],
    /// Its mapping (position in the corrected image, J, RI).
    pub(crate) mapped: Mapped,
    /// `f − b` (DN).
    pub(crate) signal_dn: f64,
}

/// `Σ_c` of the module docs for the centroid `centroid` of `pixels` with
/// weight sum `weight_sum` over `background`; `threshold` is the observed
/// pixel and RI of the pixel that sets `T′`; `gain_dn_per_e` is K.
/// `None` when the plane's covariance is undefined.
pub(crate) fn centroid_covariance(
    pixels: &[WeightedPixel],
    centroid: [f64; 2],
    weight_sum: f64,
    background: &Background,
    threshold: ([f64; 2], f64),
    gain_dn_per_e: f64,
) -> Option<CentroidCovariance> {
    let p = pixel_part(pixels, centroid, weight_sum, background, gain_dn_per_e);
    let b = plane_part(pixels, centroid, weight_sum, background, threshold)?;
    Some(CentroidCovariance {
        uu_px2: p.uu_px2 + b.uu_px2,
        vv_px2: p.vv_px2 + b.vv_px2,
        uv_px2: p.uv_px2 + b.uv_px2,
    })
}

/// `Σᵢ σᵢ²·gᵢgᵢᵀ`: the pixels' own noise.
fn pixel_part(
    pixels: &[WeightedPixel],
    centroid: [f64; 2],
    weight_sum: f64,
    background: &Background,
    gain_dn_per_e: f64,
) -> CentroidCovariance {
    let var_bg = background.sigma_dn.powi(2);
    let (mut uu, mut vv, mut uv) = (0.0, 0.0, 0.0);
    for p in pixels {
        let m = &p.mapped;
        let scale = m.jacobian / m.illumination / weight_sum;
        let g = [
            (m.position[0] - centroid[0]) * scale,
            (m.position[1] - centroid[1]) * scale,
        ];
        let var = var_bg + gain_dn_per_e * p.signal_dn.max(0.0);
        uu += var * g[0] * g[0];
        vv += var * g[1] * g[1];
        uv += var * g[0] * g[1];
    }
    CentroidCovariance {
        uu_px2: uu,
        vv_px2: vv,
        uv_px2: uv,
    }
}

/// `G_θ·Σ_θ·G_θᵀ`: the background plane's error, shared by every pixel.
fn plane_part(
    pixels: &[WeightedPixel],
    centroid: [f64; 2],
    weight_sum: f64,
    background: &Background,
    threshold: ([f64; 2], f64),
) -> Option<CentroidCovariance> {
    let x_k = background.design(threshold.0) / threshold.1;
    // G_θ as two rows (u, v) of three.
    let (mut gu, mut gv) = (Vector3::zeros(), Vector3::zeros());
    for p in pixels {
        let m = &p.mapped;
        let dw = (x_k - background.design(p.observed) / m.illumination) * m.jacobian;
        gu += dw * ((m.position[0] - centroid[0]) / weight_sum);
        gv += dw * ((m.position[1] - centroid[1]) / weight_sum);
    }
    let cov = background.covariance()?;
    let form = |a: &Vector3<f64>, b: &Vector3<f64>| a.dot(&(cov * b));
    Some(CentroidCovariance {
        uu_px2: form(&gu, &gu),
        vv_px2: form(&gv, &gv),
        uv_px2: form(&gu, &gv),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform disc of `radius` px and signal `s` DN above a flat
    /// background, thresholded at `t` DN above it, with its ring of
    /// `RING_*` pixels around the bounding box: the pixel part is the closed
    /// form `σ²·Σ dᵢ²/W²` and the background plane's share is small.
    #[test]
    fn a_disc_has_the_closed_form_and_a_small_background_share() {
        let (radius, s, t, k, sigma_bg) = (12.0f64, 20_000.0, 1_000.0, 4.0, 40.0);
        let r = radius.ceil() as i32;
        let mut pixels = Vec::new();
        for y in -r..=r {
            for x in -r..=r {
                let (u, v) = (f64::from(x), f64::from(y));
                if u.hypot(v) <= radius {
                    pixels.push(WeightedPixel {
                        observed: [u, v],
                        mapped: Mapped {
                            position: [u, v],
                            jacobian: 1.0,
                            illumination: 1.0,
                        },
                        signal_dn: s,
                    });
                }
            }
        }
        let w = (s - t) * pixels.len() as f64;
        // The ring of crate::correction: 8 px from the box, 8 px wide.
        let (inner, outer) = (r + 8, r + 16);
        let mut normal = Matrix3::zeros();
        for y in -outer..=outer {
            for x in -outer..=outer {
                if x.abs() > inner || y.abs() > inner {
                    let d = Vector3::new(1.0, f64::from(x), f64::from(y));
                    normal += d * d.transpose();
                }
            }
        }
        let background = Background {
            plane: [0.0; 3],
            sigma_dn: sigma_bg,
            centre: [0.0, 0.0],
            normal,
        };
        let p = pixel_part(&pixels, [0.0, 0.0], w, &background, k);
        let sum_d2: f64 = pixels.iter().map(|p| p.observed[0].powi(2)).sum();
        let closed = (sigma_bg.powi(2) + k * s) * sum_d2 / (w * w);
        assert!((p.uu_px2 / closed - 1.0).abs() < 1e-12, "{p:?} {closed}");
        assert!((p.uu_px2 - p.vv_px2).abs() < 1e-12 * p.uu_px2 && p.uv_px2.abs() < 1e-12);
        // T′ set at the disc's edge pixel (12, 0).
        let b = plane_part(&pixels, [0.0, 0.0], w, &background, ([12.0, 0.0], 1.0)).unwrap();
        let share = b.uu_px2 / p.uu_px2;
        eprintln!(
            "disc r = {radius} px, s = {s} DN, K = {k}: σ_u = {:.5} px from the pixels, \
             background plane adds {:.3} % of the variance",
            p.uu_px2.sqrt(),
            100.0 * share
        );
        assert!(share < 0.01, "{share}");
    }
}
