//! The distortion model chosen by the data (docs/methods.md, Calibration):
//! a camera is fitted with the default model (k1 k2 p1 p2) and with k3
//! added, and k3 is kept only when the data support it on two counts:
//! - **significance**: the nested-model F statistic
//!   `F = (SSR₀ − SSR₁)/(SSR₁/(m − n₁))` (one parameter added) exceeds
//!   F(1, m − n₁) at 99.9 %;
//! - **prediction**: over a 5-fold cross-validation on the markers (every
//!   fifth marker held out in turn, the camera refitted on the rest), the
//!   held-out residuals are smaller with k3 than without, significantly:
//!   Wilcoxon's signed-rank test on the paired differences of their squares
//!   `dᵢ = |rᵢ,lean|² − |rᵢ,k3|²` above 3.09 (one-sided 99.9 %). A
//!   term that fits the calibration points but does not predict the points
//!   it did not see is overfitted, or too small to matter.
//!
//! A lens that needs k3 leaves residuals far above the markers' noise with
//! the lean model (the seed's 24–70 mm at 40 mm: 8×); one that does not
//! gives an F near 1.

use crate::Result;
use crate::calibration::{Calibration, Observation, Options, calibrate, residuals_of, split};
use crate::refine::Layout;

/// Folds of the cross-validation.
pub const FOLDS: usize = 5;
/// The significance of the F test (one-sided).
pub const F_LEVEL: f64 = 0.999;
/// The held-out gain must exceed this many standard errors (one-sided 99.9 %).
pub const PREDICTION_Z: f64 = 3.09;
/// Fewest residual degrees of freedom for a choice (below it the lean model stays).
const MIN_DOF: usize = 10;

/// One model tried.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Its parameters.
    pub layout: Layout,
    /// RMS reprojection error of the fit over every point used (px).
    pub rms_px: f64,
    /// RMS of the held-out residuals over the folds (px; outliers of the
    /// full fit left out).
    pub held_out_rms_px: f64,
}

/// What the data chose, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelChoice {
    /// The layout kept.
    pub chosen: Layout,
    /// The lean model, then the one with k3.
    pub candidates: Vec<Candidate>,
    /// The F statistic of k3, and its 99.9 % critical value.
    pub f: (f64, f64),
    /// In words: what was kept and why.
    pub reason: String,
}

/// Calibrate one camera with the model the data support: `options`' model
/// without k3, and with k3 ([`crate::refine::Layout::k3`]); the calibration
/// kept and the choice. A model without radial terms is not extended.
pub fn calibrate_choosing(
    observations: &[Observation],
    width: u32,
    height: u32,
    options: &Options,
) -> Result<(Calibration, Option<ModelChoice>)> {
    let lean_options = Options {
        k3: false,
        ..*options
    };
    let lean = calibrate(observations, width, height, &lean_options)?;
    choose_model(observations, width, height, options, lean)
}

/// [`calibrate_choosing`] given the lean model's calibration `lean` of
/// these observations (`options` without k3), where the caller has it.
pub fn choose_model(
    observations: &[Observation],
    width: u32,
    height: u32,
    options: &Options,
    lean: Calibration,
) -> Result<(Calibration, Option<ModelChoice>)> {
    let lean_options = Options {
        k3: false,
        ..*options
    };
    if options.model == crate::Model::Pinhole {
        return Ok((lean, None));
    }
    let rich_options = Options {
        k3: true,
        ..*options
    };
    let Ok(rich) = calibrate(observations, width, height, &rich_options) else {
        return Ok((lean, None));
    };
    let m = 2 * rich.points_used();
    let n = rich_options.layout().len();
    if m < n + MIN_DOF {
        return Ok((lean, None));
    }
    let ssr = |c: &Calibration| {
        let used = c.points_used() as f64;
        c.rms_px * c.rms_px * used
    };
    let keep: Vec<bool> = rich.residuals.iter().map(|r| !r.outlier).collect();
    let lean_held = held_out(observations, width, height, &lean_options, &keep);
    let rich_held = held_out(observations, width, height, &rich_options, &keep);
    let choice = decide(
        options.model.name(),
        [
            (lean_options.layout(), lean.rms_px, ssr(&lean), lean_held),
            (rich_options.layout(), rich.rms_px, ssr(&rich), rich_held),
        ],
        1,
        m - n,
    );
    let chosen = if choice.chosen.k3 { rich } else { lean };
    Ok((chosen, Some(choice)))
}

/// The choice between the lean model and the one with k3 added (`q` more
/// parameters, `dof` residual degrees of freedom of the richer fit): per
/// model its layout, fit RMS (px), sum of squared residuals and held-out
/// squared residuals (`None`: a fold could not be fitted).
pub(crate) fn decide(
    name: &str,
    models: [(Layout, f64, f64, Option<Vec<f64>>); 2],
    q: usize,
    dof: usize,
) -> ModelChoice {
    let [
        (lean_layout, lean_rms, ssr0, lean_held),
        (rich_layout, rich_rms, ssr1, rich_held),
    ] = models;
    let f = if ssr1 > 0.0 {
        (((ssr0 - ssr1) / q as f64) / (ssr1 / dof as f64)).max(0.0)
    } else {
        f64::INFINITY
    };
    let critical = f_critical(q, dof);
    let rms_of = |h: &Option<Vec<f64>>| {
        h.as_ref().map_or(f64::INFINITY, |v| {
            (v.iter().sum::<f64>() / v.len().max(1) as f64).sqrt()
        })
    };
    let (held_lean, held_rich) = (rms_of(&lean_held), rms_of(&rich_held));
    let gain_z = match (&lean_held, &rich_held) {
        (Some(a), Some(b)) => paired_z(a, b),
        _ => f64::NEG_INFINITY,
    };
    let candidates = vec![
        Candidate {
            layout: lean_layout,
            rms_px: lean_rms,
            held_out_rms_px: held_lean,
        },
        Candidate {
            layout: rich_layout,
            rms_px: rich_rms,
            held_out_rms_px: held_rich,
        },
    ];
    let significant = f > critical;
    let predicts = gain_z > PREDICTION_Z;
    let reason = match (significant, predicts) {
        (true, true) => format!(
            "{name}+k3: k3 is significant (F {f:.1} > {critical:.1}, 99.9 %) and predicts held-out \
             markers better ({held_rich:.4} against {held_lean:.4} px RMS, z {gain_z:.1})"
        ),
        (true, false) => format!(
            "{name}: k3 is significant (F {f:.1}) but does not predict held-out markers \
             significantly better ({held_rich:.4} against {held_lean:.4} px RMS, z {gain_z:.1} ≤ \
             {PREDICTION_Z})"
        ),
        (false, _) => format!("{name}: k3 is not significant (F {f:.1} ≤ {critical:.1}, 99.9 %)"),
    };
    ModelChoice {
        chosen: if significant && predicts {
            rich_layout
        } else {
            lean_layout
        },
        candidates,
        f: (f, critical),
        reason,
    }
}

/// Each marker's squared residual when the camera is fitted without it
/// ([`FOLDS`]-fold: marker i in fold i mod FOLDS), over the markers `keep`,
/// in a fixed order; `None` where a fold cannot be fitted.
fn held_out(
    observations: &[Observation],
    width: u32,
    height: u32,
    options: &Options,
    keep: &[bool],
) -> Option<Vec<f64>> {
    let mut held: Vec<f64> = Vec::new();
    for fold in 0..FOLDS {
        let train: Vec<Observation> = observations
            .iter()
            .enumerate()
            .filter(|(i, _)| i % FOLDS != fold)
            .map(|(_, o)| *o)
            .collect();
        let fit = calibrate(&train, width, height, options).ok()?;
        let (world, image, radius) = split(
            observations
                .iter()
                .enumerate()
                .filter(|(i, _)| i % FOLDS == fold && keep[*i])
                .map(|(_, o)| o),
        );
        let residuals = residuals_of(&fit.camera, options.layout(), &world, &image, &radius);
        held.extend(residuals.iter().map(|r| r.norm_squared()));
    }
    held.iter().all(|r| r.is_finite()).then_some(held)
}

/// Wilcoxon's signed-rank statistic of the paired differences `a − b`, as
/// a normal deviate (`W⁺ − n(n+1)/4` over `√(n(n+1)(2n+1)/24)`, zero
/// differences dropped, ties given their mean rank): robust to the few
/// markers at the field's edge whose residuals dominate a mean of squares.
/// `−∞` for fewer than two differences.
fn paired_z(a: &[f64], b: &[f64]) -> f64 {
    let mut d: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(x, y)| x - y)
        .filter(|d| *d != 0.0)
        .collect();
    if d.len() < 2 {
        return f64::NEG_INFINITY;
    }
    d.sort_by(|x, y| x.abs().total_cmp(&y.abs()));
    let mut w_plus = 0.0;
    let mut i = 0;
    while i < d.len() {
        let mut j = i;
        while j + 1 < d.len() && d[j + 1].abs() == d[i].abs() {
            j += 1;
        }
        // Ranks i + 1 … j + 1 share their mean.
        let rank = 0.5 * ((i + 1) + (j + 1)) as f64;
        w_plus += rank * d[i..=j].iter().filter(|x| **x > 0.0).count() as f64;
        i = j + 1;
    }
    let n = d.len() as f64;
    (w_plus - n * (n + 1.0) / 4.0) / (n * (n + 1.0) * (2.0 * n + 1.0) / 24.0).sqrt()
}

/// F(q, ν) at [`F_LEVEL`]. For q = 1 the square of Student's t(ν) at
/// 0.9995 by the Cornish–Fisher expansion about the normal quantile
/// z = 3.2905 (`t ≈ z + (z³ + z)/(4ν) + (5z⁵ + 16z³ + 3z)/(96ν²)`; within
/// 0.5 % for ν ≥ 10); for q > 1, χ²_q(0.999)/q by Wilson–Hilferty,
/// `q(1 − 2/(9q) + z₀.₉₉₉·√(2/(9q)))³`, z₀.₉₉₉ = 3.0902 (the ν → ∞
/// limit), times `1 + (q + 2)/ν` for finite ν (within 2 % of the tables
/// for ν ≥ 100, the bundles' range).
pub(crate) fn f_critical(q: usize, dof: usize) -> f64 {
    let nu = dof as f64;
    if q <= 1 {
        let z: f64 = 3.290_526_731;
        let t = z
            + (z.powi(3) + z) / (4.0 * nu)
            + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * nu * nu);
        return t * t;
    }
    let q = q as f64;
    let z = 3.090_232_306;
    let a = 2.0 / (9.0 * q);
    let chi2 = q * (1.0 - a + z * a.sqrt()).powi(3);
    chi2 / q * (1.0 + (q + 2.0) / nu)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_signed_rank_statistic() {
        // Every difference positive, n = 4: W⁺ = 10, z = (10 − 5)/√7.5.
        let z = paired_z(&[2.0, 3.0, 4.0, 5.0], &[1.0, 1.0, 1.0, 1.0]);
        assert!((z - 5.0 / 7.5f64.sqrt()).abs() < 1e-12);
        // Symmetric differences: 0.
        assert!(paired_z(&[2.0, 0.0, 3.0, 0.0], &[0.0, 2.0, 0.0, 3.0]).abs() < 1e-12);
        assert_eq!(paired_z(&[1.0], &[0.0]), f64::NEG_INFINITY);
    }

    #[test]
    fn the_f_quantile_matches_tables() {
        // F(1, ν) at 0.999: 10.83 (ν → ∞), 11.97 (ν = 60), 13.29 (ν = 30), 21.04 (ν = 10).
        assert!((f_critical(1, 1_000_000) - 10.83).abs() < 0.01);
        // F(2, 120) 7.32, F(3, 120) 5.78, F(3, ∞) 5.42 at 0.999.
        for (q, nu, table) in [(2, 120, 7.32), (3, 120, 5.78), (3, 1_000_000, 5.42)] {
            let f = f_critical(q, nu);
            assert!(
                (f / table - 1.0).abs() < 0.02,
                "F({q}, {nu}) {f} vs {table}"
            );
        }
        assert!(
            (f_critical(1, 60) / 11.97 - 1.0).abs() < 0.005,
            "{}",
            f_critical(1, 60)
        );
        assert!(
            (f_critical(1, 30) / 13.29 - 1.0).abs() < 0.005,
            "{}",
            f_critical(1, 30)
        );
        assert!(
            (f_critical(1, 10) / 21.04 - 1.0).abs() < 0.05,
            "{}",
            f_critical(1, 10)
        );
    }
}
