//! Plausibility of an instant from its reprojection residual.
//!
//! A sphere centre fused from images that do not show the same instant from
//! the cameras it is attributed to — two cameras' images swapped, one image
//! given for two cameras, another instant's image — still triangulates to a
//! point, millimetres off, but its rays miss each other: the RMS reprojection
//! residual (`residual_px` of `points.csv`) is pixels where a good instant's
//! is hundredths. Each instant's residual (the largest of its spheres') is
//! compared after the fact with the campaign's own scatter, robustly:
//!
//! `limit = min(CEILING, max(FLOOR, median + K·1.4826·MAD))`
//!
//! over the residuals of every measured instant (1.4826·MAD is the standard
//! deviation of a normal distribution with that median absolute deviation).
//! The median and the MAD ignore up to half the instants being wrong; the
//! floor keeps the limit above what a real camera's centroids and
//! calibration leave when a campaign's own scatter is smaller (noise-free
//! renders); the ceiling refuses residuals no calibrated rig explains even
//! when most of a campaign is wrong. The limit depends only on the set of
//! residuals, so a resumed run, which sees the same residuals, draws the same
//! line.

/// Multiple of the robust standard deviation above the median residual at
/// which an instant is implausible. Good instants' residuals of the renderer's
/// campaigns (several seeds, 512–4096 px) stay within 5 of it; the wrong
/// images that this gate is for lie hundreds to tens of thousands above.
pub const RESIDUAL_K: f64 = 10.0;

/// Lowest limit (px): 0.1 px is the reprojection RMS the rig's commissioning
/// tolerates for a calibrated camera (`calib::commission`), so a residual
/// within it is never implausible, however tight the campaign's own scatter.
pub const RESIDUAL_FLOOR_PX: f64 = 0.1;

/// Highest limit (px): 20 times the commissioning tolerance. A sphere centre
/// whose rays miss each other by more than 2 px — 0.12 mm at the seed rig's
/// 58 µm per pixel — is no measurement of a rig that passed commissioning,
/// whatever the rest of the campaign looks like.
pub const RESIDUAL_CEILING_PX: f64 = 2.0;

/// Standard deviation of a normal distribution per unit of its median
/// absolute deviation, 1/Φ⁻¹(3/4).
const MAD_TO_SIGMA: f64 = 1.4826;

/// The residual limit of a campaign.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResidualGate {
    /// Median of the instants' residuals (px).
    pub median_px: f64,
    /// Robust standard deviation, 1.4826 × their median absolute deviation (px).
    pub sigma_px: f64,
    /// The limit (px): an instant whose residual exceeds it is implausible.
    pub limit_px: f64,
    /// Number of instants the statistics come from.
    pub instants: usize,
}

/// Median of values sorted ascending (mean of the two middle ones for an even count).
fn median_sorted(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

impl ResidualGate {
    /// The gate of a campaign whose instants have these residuals (px);
    /// `None` without any finite residual.
    pub fn from_residuals(residuals: &[f64]) -> Option<Self> {
        let mut r: Vec<f64> = residuals
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        if r.is_empty() {
            return None;
        }
        r.sort_by(f64::total_cmp);
        let median_px = median_sorted(&r);
        let mut dev: Vec<f64> = r.iter().map(|v| (v - median_px).abs()).collect();
        dev.sort_by(f64::total_cmp);
        let sigma_px = MAD_TO_SIGMA * median_sorted(&dev);
        let limit_px = (median_px + RESIDUAL_K * sigma_px)
            .max(RESIDUAL_FLOOR_PX)
            .min(RESIDUAL_CEILING_PX);
        Some(Self {
            median_px,
            sigma_px,
            limit_px,
            instants: r.len(),
        })
    }

    /// Whether an instant with this residual (px) is plausible (NaN is not).
    pub fn admits(&self, residual_px: f64) -> bool {
        residual_px <= self.limit_px
    }

    /// How the limit was drawn, for messages:
    /// `limit 0.0512 px (median 0.0121 px + 10 × robust σ 0.0039 px of 48 instants)`.
    pub fn describe(&self) -> String {
        let relative = self.median_px + RESIDUAL_K * self.sigma_px;
        let stats = format!(
            "median {:.4} px, robust σ {:.4} px of {} instants",
            self.median_px, self.sigma_px, self.instants
        );
        if relative > RESIDUAL_CEILING_PX {
            format!("limit {RESIDUAL_CEILING_PX} px (the ceiling; {stats})")
        } else if relative < RESIDUAL_FLOOR_PX {
            format!("limit {RESIDUAL_FLOOR_PX} px (the floor; {stats})")
        } else {
            format!(
                "limit {:.4} px (median {:.4} px + {RESIDUAL_K} × robust σ {:.4} px of {} instants)",
                self.limit_px, self.median_px, self.sigma_px, self.instants
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_limit_follows_the_scatter_between_floor_and_ceiling() {
        // Good instants around 0.05 px, spread 0.01 px, and two wrong ones.
        let mut r: Vec<f64> = (0..40).map(|i| 0.04 + 0.0005 * f64::from(i)).collect();
        r.extend([3.0, 0.9]);
        let g = ResidualGate::from_residuals(&r).unwrap();
        // Median of 42 values: the mean of the 21st and 22nd smallest.
        assert!((g.median_px - 0.05025).abs() < 1e-12, "{g:?}");
        // Deviations 0.0005·|i − 20.5| and the two wrong ones: median 0.0005·10.5.
        assert!((g.sigma_px - 1.4826 * 0.00525).abs() < 1e-12, "{g:?}");
        assert!((g.limit_px - (g.median_px + 10.0 * g.sigma_px)).abs() < 1e-12);
        assert!(r[..40].iter().all(|&v| g.admits(v)));
        assert!(!g.admits(0.9) && !g.admits(3.0) && !g.admits(f64::NAN));
        assert!(g.describe().contains("median 0.050"), "{}", g.describe());
    }

    #[test]
    fn a_tight_campaign_is_held_by_the_floor_and_a_wild_one_by_the_ceiling() {
        let tight = ResidualGate::from_residuals(&[0.001, 0.0012, 0.0011, 0.05]).unwrap();
        assert_eq!(tight.limit_px, RESIDUAL_FLOOR_PX);
        assert!(tight.admits(0.05));
        assert!(tight.describe().contains("floor"), "{}", tight.describe());
        // Most instants wrong: median and MAD are theirs, the ceiling still holds.
        let wild = ResidualGate::from_residuals(&[0.02, 5.0, 40.0, 60.0, 88.0]).unwrap();
        assert_eq!(wild.limit_px, RESIDUAL_CEILING_PX);
        assert!(wild.admits(0.02) && !wild.admits(5.0));
        assert!(wild.describe().contains("ceiling"), "{}", wild.describe());
        assert_eq!(ResidualGate::from_residuals(&[]), None);
        assert_eq!(ResidualGate::from_residuals(&[f64::NAN]), None);
    }
}
