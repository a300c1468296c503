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
//! variance of K·s DN²), `Σ_θ = σ_bg²·(XᵀX)⁻¹` the plane's covariance. As
//! σᵢ² is linear in K, so is `Σ_c = Σ_0 + K·Σ_K` ([`CovarianceForm`]): the
//! sums are gathered without K, which can be given after the pass (e.g. once
//! it has been estimated from the very frames being measured). A
//! pixel crossing the threshold enters with zero weight, so thresholding
//! adds no jump: the linearisation holds across it. The raw weighting
//! (`w = f′·J`) jumps by `T′·J` where a pixel crosses the threshold, which a
//! linear propagation cannot carry: no covariance is given for it.

// Lanes side by side: loops over lane indices into several arrays are what the
// compiler spreads over vector units.
#![allow(clippy::needless_range_loop)]

use geom::{Matrix3, Vector3};

use crate::correction::{MomentSums, Moments, lane_total};

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

    /// `self + t·other`, term by term.
    fn added(&self, t: f64, other: &CentroidCovariance) -> CentroidCovariance {
        CentroidCovariance {
            uu_px2: self.uu_px2 + t * other.uu_px2,
            vv_px2: self.vv_px2 + t * other.vv_px2,
            uv_px2: self.uv_px2 + t * other.uv_px2,
        }
    }
}

/// Which covariance a corrected centroid is wanted with
/// (`crate::correction::mapped_light`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Covariance {
    /// None.
    Off,
    /// At the system gain K (DN/e⁻), with its form.
    AtGain(f64),
    /// Its form only, for K given later ([`CovarianceForm::at`]).
    Form,
}

impl Covariance {
    /// At the gain K when it is known, else none.
    pub fn at_gain(gain_dn_per_e: Option<f64>) -> Self {
        gain_dn_per_e.map_or(Covariance::Off, Covariance::AtGain)
    }
}

/// A centroid's covariance as the form `Σ_c = Σ_0 + K·Σ_K` linear in the
/// system gain K (module docs), for K given after the pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CovarianceForm {
    /// `Σ_0`: the background's noise, in the pixels and in the plane.
    pub fixed: CentroidCovariance,
    /// `Σ_K`: the signal's shot noise per unit of K (px² per DN/e⁻).
    pub per_gain: CentroidCovariance,
}

impl CovarianceForm {
    /// The covariance with the system gain `gain_dn_per_e` (K, DN/e⁻).
    pub fn at(&self, gain_dn_per_e: f64) -> CentroidCovariance {
        self.fixed.added(gain_dn_per_e, &self.per_gain)
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
    pub(crate) fn design(&self, at: [f64; 2]) -> Vector3<f64> {
        Vector3::new(1.0, at[0] - self.centre[0], at[1] - self.centre[1])
    }

    /// `Σ_θ = σ_bg²·(XᵀX)⁻¹`; `None` for a singular ring.
    pub(crate) fn covariance(&self) -> Option<Matrix3<f64>> {
        self.normal
            .try_inverse()
            .map(|inv| inv * self.sigma_dn.powi(2))
    }
}

/// The sums over a blob's weighted pixels that `Σ_c` needs, gathered in the
/// same single pass as the centroid's, before the centroid is known: with
/// `dᵢ = pᵢ − r` about a reference point r near the blob and `e = c − r`,
/// `Σ qᵢ(pᵢ − c)(pᵢ − c)ᵀ` from the [`Moments`] of `qᵢ = σᵢ²·(Jᵢ/RIᵢ)²`
/// about r, as those of `(Jᵢ/RIᵢ)²` (times σ_bg²) and of
/// `max(fᵢ − bᵢ, 0)·(Jᵢ/RIᵢ)²` (times K); and `G_θ`'s rows `(Σ ∂wᵢ/∂θ·dᵢ − e·Σ ∂wᵢ/∂θ)/Σ w`
/// with `∂wᵢ/∂θ = Jᵢ·x_k/RI_k − (Jᵢ/RIᵢ)·xᵢ`, so that the sums of `Jᵢ`
/// and of `(Jᵢ/RIᵢ)·xᵢ` (each also times `dᵢ`) carry it whichever pixel
/// turns out to set `T′`. Gathered in `N` lanes side by side, as
/// [`MomentSums`], and totalled into [`NoiseTotals`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NoiseSums<const N: usize> {
    /// The moments of `(J/RI)²`: `Σ q`, `Σ q·d`, `Σ q·(d_u², d_v², d_u·d_v)`.
    q_background: MomentSums<N>,
    /// The moments of `max(f − b, 0)·(J/RI)²`.
    q_shot: MomentSums<N>,
    /// `Σ J·(1, d_u, d_v)`.
    j: [[f64; N]; 3],
    /// `Σ (J/RI)·x·(1, d_u, d_v)`, x = (1, u − u₀, v − v₀).
    gx: [[[f64; N]; 3]; 3],
}

impl<const N: usize> Default for NoiseSums<N> {
    fn default() -> Self {
        Self {
            q_background: MomentSums::default(),
            q_shot: MomentSums::default(),
            j: [[0.0; N]; 3],
            gx: [[[0.0; N]; 3]; 3],
        }
    }
}

impl<const N: usize> NoiseSums<N> {
    /// Add pixels that carry weight, lane by lane: observed at `(u, v)`, at
    /// `d` from the reference point, with area Jacobian `jacobian`,
    /// `g = J/RI` and `signal_dn` = f − b; the plane's origin from `noise`.
    /// A lane whose `jacobian` and `g` are 0 adds nothing.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add(
        &mut self,
        noise: &PixelNoise,
        u: &[f64; N],
        v: f64,
        d: &[[f64; N]; 2],
        jacobian: &[f64; N],
        g: &[f64; N],
        signal_dn: &[f64; N],
    ) {
        let (mut background, mut shot) = ([0.0; N], [0.0; N]);
        for l in 0..N {
            background[l] = g[l] * g[l];
            shot[l] = signal_dn[l].max(0.0) * background[l];
        }
        self.q_background.add(d, &background);
        self.q_shot.add(d, &shot);
        for l in 0..N {
            let j = jacobian[l];
            self.j[0][l] += j;
            self.j[1][l] += j * d[0][l];
            self.j[2][l] += j * d[1][l];
            let x = [
                g[l],
                g[l] * (u[l] - noise.centre[0]),
                g[l] * (v - noise.centre[1]),
            ];
            for (row, xa) in self.gx.iter_mut().zip(x) {
                row[0][l] += xa;
                row[1][l] += xa * d[0][l];
                row[2][l] += xa * d[1][l];
            }
        }
    }

    /// The sums over every lane.
    pub(crate) fn total(&self) -> NoiseTotals {
        NoiseTotals {
            q_background: self.q_background.total(),
            q_shot: self.q_shot.total(),
            j: self.j.each_ref().map(lane_total),
            gx: self.gx.each_ref().map(|row| row.each_ref().map(lane_total)),
        }
    }
}

/// [`NoiseSums`] totalled over their lanes.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NoiseTotals {
    q_background: Moments,
    q_shot: Moments,
    j: [f64; 3],
    gx: [[f64; 3]; 3],
}

impl NoiseTotals {
    /// The sums of both.
    pub(crate) fn added(&self, other: &NoiseTotals) -> NoiseTotals {
        NoiseTotals {
            q_background: self.q_background.added(1.0, &other.q_background),
            q_shot: self.q_shot.added(1.0, &other.q_shot),
            j: std::array::from_fn(|c| self.j[c] + other.j[c]),
            gx: std::array::from_fn(|r| std::array::from_fn(|c| self.gx[r][c] + other.gx[r][c])),
        }
    }

    /// `Σ_c` of the module docs for the centroid at `e` from the reference
    /// point, of the added pixels with weight sum `weight_sum`, over
    /// `background`; `threshold` is the observed pixel and RI of the pixel
    /// that sets `T′`; as the form linear in K. `None` when the plane's
    /// covariance is undefined.
    pub(crate) fn covariance(
        &self,
        e: [f64; 2],
        weight_sum: f64,
        background: &Background,
        threshold: ([f64; 2], f64),
    ) -> Option<CovarianceForm> {
        let plane = self.plane_part(e, weight_sum, background, threshold)?;
        let pixels = pixel_part(&self.q_background, e, weight_sum);
        Some(CovarianceForm {
            fixed: plane.added(background.sigma_dn.powi(2), &pixels),
            per_gain: pixel_part(&self.q_shot, e, weight_sum),
        })
    }

    /// `G_θ·Σ_θ·G_θᵀ`: the background plane's error, shared by every pixel.
    fn plane_part(
        &self,
        e: [f64; 2],
        weight_sum: f64,
        background: &Background,
        threshold: ([f64; 2], f64),
    ) -> Option<CentroidCovariance> {
        let x_k = background.design(threshold.0) / threshold.1;
        // Σ ∂w/∂θ·(1, d_u, d_v) = x_k·Σ J·(1, d_u, d_v) − Σ (J/RI)·x·(1, d_u, d_v).
        let sum =
            |c: usize| x_k * self.j[c] - Vector3::new(self.gx[0][c], self.gx[1][c], self.gx[2][c]);
        let (dw, dw_du, dw_dv) = (sum(0), sum(1), sum(2));
        // G_θ as two rows (u, v) of three.
        let gu = (dw_du - dw * e[0]) / weight_sum;
        let gv = (dw_dv - dw * e[1]) / weight_sum;
        let cov = background.covariance()?;
        let form = |a: &Vector3<f64>, b: &Vector3<f64>| a.dot(&(cov * b));
        Some(CentroidCovariance {
            uu_px2: form(&gu, &gu),
            vv_px2: form(&gv, &gv),
            uv_px2: form(&gu, &gv),
        })
    }
}

/// `Σᵢ qᵢ·gᵢgᵢᵀ` (`gᵢ` of the module docs) from the moments of q about the
/// reference point: the pixels' own noise, per unit of what q leaves out.
fn pixel_part(q: &Moments, e: [f64; 2], weight_sum: f64) -> CentroidCovariance {
    let [uu, vv, uv] = q.about(e).map(|m| m / (weight_sum * weight_sum));
    CentroidCovariance {
        uu_px2: uu,
        vv_px2: vv,
        uv_px2: uv,
    }
}

/// What the pixels' design rows need: the plane's origin (u₀, v₀).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PixelNoise {
    centre: [f64; 2],
}

impl PixelNoise {
    /// The noise of pixels over `background`.
    pub(crate) fn new(background: &Background) -> Self {
        Self {
            centre: background.centre,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform disc of `radius` px and signal `s` DN above a flat
    /// background, thresholded at `t` DN above it, with its ring of
    /// `RING_*` pixels around the bounding box: the pixel part is the closed
    /// form `σ²·Σ dᵢ²/W²` and the background plane's share is small. The
    /// sums are taken about a point off the disc's centre, as a blob's are.
    #[test]
    fn a_disc_has_the_closed_form_and_a_small_background_share() {
        let (radius, s, t, k, sigma_bg) = (12.0f64, 20_000.0, 1_000.0, 4.0, 40.0);
        let r = radius.ceil() as i32;
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
        let (reference, noise) = ([-7.5, 3.25], PixelNoise::new(&background));
        let mut sums = NoiseSums::<1>::default();
        let (mut count, mut sum_d2) = (0.0, 0.0);
        for y in -r..=r {
            for x in -r..=r {
                let (u, v) = (f64::from(x), f64::from(y));
                if u.hypot(v) <= radius {
                    let d = [[u - reference[0]], [v - reference[1]]];
                    sums.add(&noise, &[u], v, &d, &[1.0], &[1.0], &[s]);
                    count += 1.0;
                    sum_d2 += u * u;
                }
            }
        }
        let w = (s - t) * count;
        // The centroid (0, 0) from the reference point.
        let e = [-reference[0], -reference[1]];
        let sums = sums.total();
        let form = sums
            .covariance(e, w, &background, ([12.0, 0.0], 1.0))
            .unwrap();
        let plane = sums
            .plane_part(e, w, &background, ([12.0, 0.0], 1.0))
            .unwrap();
        // The pixels' part: the form at K less the plane's.
        let p = form.at(k).added(-1.0, &plane);
        let closed = (sigma_bg.powi(2) + k * s) * sum_d2 / (w * w);
        assert!((p.uu_px2 / closed - 1.0).abs() < 1e-12, "{p:?} {closed}");
        assert!(
            (p.uu_px2 - p.vv_px2).abs() < 1e-12 * p.uu_px2 && p.uv_px2.abs() < 1e-12 * p.uu_px2
        );
        // T′ set at the disc's edge pixel (12, 0).
        let b = plane;
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
