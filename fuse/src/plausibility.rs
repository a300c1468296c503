//! Plausibility of an instant from its reprojection residual.
//!
//! A sphere centre fused from images that do not show the same instant from
//! the cameras it is attributed to — two cameras' images swapped, one image
//! given for two cameras, another instant's image — still triangulates to a
//! point, millimetres off, but its rays miss each other: the RMS reprojection
//! residual (`residual_px` of `points.csv`) is pixels where a good instant's
//! is thousandths to hundredths. Each instant's residual (the largest of its
//! spheres') is compared after the fact with the campaign's own scatter,
//! robustly: with σ = 1.4826·MAD of the residuals of every measured instant
//! (the standard deviation of a normal distribution with that median absolute
//! deviation),
//!
//! - the campaign's limit is `median + K·σ`;
//! - the limit at a commanded position is `m + K·σ`, m the median residual of
//!   the other instants at that position (other runs, directions, captures);
//! - an instant is implausible above both — or above the ceiling — and never
//!   below the floor: `limit = min(CEILING, max(FLOOR, campaign, position))`.
//!
//! The median and the MAD ignore up to half the instants being wrong. The
//! position's limit keeps a part of the field where the camera model fits
//! less well (a larger residual at every instant there) from being taken for
//! wrong images, which come one instant at a time; the floor keeps the limit
//! above what a real camera's centroids and calibration leave when a
//! campaign's own scatter is smaller (noise-free renders); the ceiling
//! refuses residuals no calibrated rig explains, however many instants share
//! them. The limits depend only on the set of residuals, so a resumed run,
//! which sees the same residuals, draws the same line.

/// Multiple of the robust standard deviation above the median residual at
/// which an instant is implausible. The largest residual of the renderer's
/// campaigns, calibrated from their rendered targets, lies 2.9–3.9 σ above
/// the median (seeds 2–5 at 1024 px, 288 instants each; 3.4 σ for 216
/// instants at 4096 px); the wrong images this gate is for lie hundreds to
/// tens of thousands of σ above.
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

/// The residual limits of a campaign.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResidualGate {
    /// Median of the instants' residuals (px).
    pub median_px: f64,
    /// Robust standard deviation, 1.4826 × their median absolute deviation (px).
    pub sigma_px: f64,
    /// The campaign's limit, `min(CEILING, max(FLOOR, median + K·σ))` (px).
    pub limit_px: f64,
    /// Number of instants the statistics come from.
    pub instants: usize,
}

/// The limit one instant is held to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstantLimit {
    /// The limit (px): an instant whose residual exceeds it is implausible.
    pub limit_px: f64,
    /// Median residual of the other instants at its commanded position, and
    /// their number; `None` when it is alone there.
    pub position: Option<(f64, usize)>,
}

/// Median of values (mean of the two middle ones for an even count); NaN when empty.
fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

impl ResidualGate {
    /// The gate of a campaign whose instants have these residuals (px);
    /// `None` without any finite residual.
    pub fn from_residuals(residuals: &[f64]) -> Option<Self> {
        let r: Vec<f64> = residuals
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        if r.is_empty() {
            return None;
        }
        let median_px = median(&r);
        let deviations: Vec<f64> = r.iter().map(|v| (v - median_px).abs()).collect();
        let sigma_px = MAD_TO_SIGMA * median(&deviations);
        Some(Self {
            median_px,
            sigma_px,
            limit_px: Self::clamp(median_px + RESIDUAL_K * sigma_px),
            instants: r.len(),
        })
    }

    /// The limit held within [floor, ceiling]; a NaN limit becomes the
    /// floor (`f64::clamp` would keep the NaN).
    #[allow(clippy::manual_clamp)]
    fn clamp(limit: f64) -> f64 {
        limit.max(RESIDUAL_FLOOR_PX).min(RESIDUAL_CEILING_PX)
    }

    /// The limit of an instant whose commanded position the instants with
    /// residuals `others` share (itself left out).
    pub fn limit_at(&self, others: &[f64]) -> InstantLimit {
        let others: Vec<f64> = others.iter().copied().filter(|v| v.is_finite()).collect();
        if others.is_empty() {
            return InstantLimit {
                limit_px: self.limit_px,
                position: None,
            };
        }
        let m = median(&others);
        InstantLimit {
            limit_px: self
                .limit_px
                .max(Self::clamp(m + RESIDUAL_K * self.sigma_px)),
            position: Some((m, others.len())),
        }
    }

    /// The campaign's statistics, for messages:
    /// `median 0.0121 px, robust σ 0.0039 px of 48 instants`.
    pub fn describe(&self) -> String {
        format!(
            "median {:.4} px, robust σ {:.4} px of {} instants",
            self.median_px, self.sigma_px, self.instants
        )
    }

    /// How an instant's limit was drawn, for messages:
    /// `limit 0.1 px (the floor; campaign: median …; its position: median 0.0031 px of 3 other instants)`.
    pub fn explain(&self, limit: &InstantLimit) -> String {
        let rule = if limit.limit_px >= RESIDUAL_CEILING_PX {
            "the ceiling; ".to_string()
        } else if limit.limit_px <= RESIDUAL_FLOOR_PX {
            "the floor; ".to_string()
        } else {
            format!("median + {RESIDUAL_K} σ; ")
        };
        let position = match limit.position {
            Some((m, n)) => format!(
                "; its position: median {m:.4} px of {n} other instant{}",
                if n == 1 { "" } else { "s" }
            ),
            None => "; no other instant at its position".into(),
        };
        format!(
            "limit {:.4} px ({rule}campaign: {}{position})",
            limit.limit_px,
            self.describe()
        )
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
        // Alone at its position, an instant is held to the campaign's limit.
        let alone = g.limit_at(&[]);
        assert_eq!(alone.limit_px, g.limit_px);
        assert!(r[..40].iter().all(|&v| v <= alone.limit_px));
        assert!(0.9 > alone.limit_px);
        assert!(
            g.explain(&alone)
                .contains("median + 10 σ; campaign: median 0.050")
        );
    }

    #[test]
    fn a_position_where_every_instant_has_a_larger_residual_keeps_them() {
        // Most positions at 0.02 px; at one end of the travel the camera model
        // leaves 0.3 px at every instant, with the same noise as elsewhere;
        // one wrong image elsewhere.
        let mut r = vec![0.02; 60];
        for (i, v) in r.iter_mut().enumerate() {
            *v += 0.0002 * (i % 7) as f64;
        }
        let end = [0.3004, 0.2998, 0.3001, 0.3009];
        r.extend(end);
        r.push(0.9);
        let g = ResidualGate::from_residuals(&r).unwrap();
        assert!(g.limit_px < 0.29, "{g:?}");
        // Each instant at the end against the three others there: kept.
        for (i, v) in end.iter().enumerate() {
            let others: Vec<f64> = end
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, o)| *o)
                .collect();
            let limit = g.limit_at(&others);
            assert!(*v <= limit.limit_px, "{v} {limit:?}");
        }
        // The wrong image among good instants at its position: refused.
        let limit = g.limit_at(&[0.0201, 0.0203, 0.0202]);
        assert!(0.9 > limit.limit_px && limit.limit_px == g.limit_px.max(RESIDUAL_FLOOR_PX));
        assert!(
            g.explain(&limit)
                .contains("its position: median 0.0202 px of 3 other instants"),
            "{}",
            g.explain(&limit)
        );
    }

    #[test]
    fn a_tight_campaign_is_held_by_the_floor_and_a_wild_one_by_the_ceiling() {
        let tight = ResidualGate::from_residuals(&[0.001, 0.0012, 0.0011, 0.05]).unwrap();
        assert_eq!(tight.limit_px, RESIDUAL_FLOOR_PX);
        assert!(tight.explain(&tight.limit_at(&[])).contains("the floor"));
        // Most instants wrong: median and MAD are theirs, the ceiling still holds,
        // at a position of wrong instants too.
        let wild = ResidualGate::from_residuals(&[0.02, 5.0, 40.0, 60.0, 88.0]).unwrap();
        assert_eq!(wild.limit_px, RESIDUAL_CEILING_PX);
        let limit = wild.limit_at(&[40.0, 60.0]);
        assert_eq!(limit.limit_px, RESIDUAL_CEILING_PX);
        assert!(wild.explain(&limit).contains("the ceiling"));
        assert_eq!(ResidualGate::from_residuals(&[]), None);
        assert_eq!(ResidualGate::from_residuals(&[f64::NAN]), None);
    }
}
