//! Outlier rejection on reprojection residuals: a point is an outlier when
//! its residual length exceeds k·σ, σ being a robust per-coordinate scale of
//! all residuals (iterated with the fit by [`crate::calibrate`]).

use geom::Vector2;

/// Smallest σ used (px): keeps exact synthetic data from rejecting round-off.
pub const MIN_SIGMA_PX: f64 = 1e-4;

/// Robust per-coordinate σ of 2-D residuals: `√(median |r|² / (2 ln 2))`.
///
/// For isotropic Gaussian residuals of per-coordinate σ, `|r|²/σ²` is χ² with
/// two degrees of freedom, whose median is `2 ln 2`; the median ignores up to
/// half the points being outliers. Floored at [`MIN_SIGMA_PX`]; 0 for no residuals.
pub fn robust_sigma(residuals: &[Vector2<f64>]) -> f64 {
    if residuals.is_empty() {
        return 0.0;
    }
    let mut sq: Vec<f64> = residuals.iter().map(|r| r.norm_squared()).collect();
    sq.sort_by(f64::total_cmp);
    let n = sq.len();
    let median = if n % 2 == 1 {
        sq[n / 2]
    } else {
        0.5 * (sq[n / 2 - 1] + sq[n / 2])
    };
    (median / (2.0 * std::f64::consts::LN_2))
        .sqrt()
        .max(MIN_SIGMA_PX)
}

/// Inlier flags: `|r| ≤ k·σ` (a non-finite residual is an outlier).
pub fn inliers(residuals: &[Vector2<f64>], sigma: f64, k: f64) -> Vec<bool> {
    let limit = k * sigma;
    residuals
        .iter()
        .map(|r| r.norm().is_finite() && r.norm() <= limit)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_of_a_gaussian_sample_and_robustness() {
        // Deterministic isotropic Gaussian sample by Box–Muller on a Halton-like lattice.
        let n = 4000;
        let mut r: Vec<Vector2<f64>> = (0..n)
            .map(|i| {
                let a = (i as f64 + 0.5) / n as f64;
                let b = ((i * 7919) % n) as f64 / n as f64 * std::f64::consts::TAU;
                let rho = (-2.0 * (1.0 - a).ln()).sqrt() * 0.3;
                Vector2::new(rho * b.cos(), rho * b.sin())
            })
            .collect();
        let s = robust_sigma(&r);
        assert!((s - 0.3).abs() < 0.01, "σ = {s}");
        // A quarter of gross outliers barely moves it.
        for v in r.iter_mut().step_by(4) {
            *v *= 100.0;
        }
        let s2 = robust_sigma(&r);
        assert!(s2 < 0.45, "σ with outliers = {s2}");
        let flags = inliers(&r, s2, 4.0);
        let rejected = flags.iter().filter(|f| !**f).count();
        assert!((900..=1010).contains(&rejected), "rejected {rejected}");
        assert_eq!(robust_sigma(&[]), 0.0);
    }
}
