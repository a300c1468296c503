//! The uncertainty statement of a probe method (docs/methods.md §7, GUM
//! Supplement 1): the Monte Carlo run through [`geom::montecarlo`] and the
//! report's `uncertainty` object with the budget of its headline figures
//! ([`Uncertainty::from_trials`]), `report.json` with each figure's `F_U_um`
//! beside it, and the terminal's lines. Each method supplies a
//! [`Statement`] (its sources of uncertainty, what is not included, its
//! headline figures) and a model that re-runs its own computation on one
//! trial's draws; the page shows it through `report::uncertainty`.
//!
//! - [`TypeA`]: a noise estimated from residuals with ν degrees of freedom;
//!   each trial draws its standard deviation as `s·√(ν/χ²_ν)`, so that the
//!   drawn inputs follow the scaled-and-shifted t distribution of JCGM 101
//!   §6.4.9 (a noise known from few residuals widens U).
//! - [`propagate`]: run it; [`not_given`]: the object when there is none.
//! - [`Bound`]: the figures whose U is the quantile of a bound on their
//!   error rather than of their own spread (extremes over positions that
//!   share one true value); [`reflected_rms`]: a root mean square, whose
//!   noise bias is additive in its square.

use std::collections::BTreeMap;

pub use formats::uncertainty::{Bound, BoundKind, Source, Statement, TRIALS_OFF};
use formats::uncertainty::{FigureKeys, Uncertainty, figures, with_expanded};
use geom::montecarlo::{self, Draws, Trial};
/// The trials and seed of a propagation, and the trials when none are
/// named (the command line's `--trials`, `--seed`).
pub use geom::montecarlo::{DEFAULT_TRIALS, Propagation};
use serde::Serialize;
use serde_json::Value;

/// How U is defined, as a method that re-runs its computation states it.
pub const METHOD: &str = "GUM Supplement 1 Monte Carlo: the method's computation re-run on \
     every trial's draws of the inputs; U = half-width of the symmetric interval about the \
     reported value that holds 95 % of the trial figures (k = 2 for a normal output), so that a \
     bias of the figure under noise lies inside it";

/// A standard deviation estimated from residuals (Type A), with its degrees
/// of freedom ν.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TypeA {
    /// The estimate s (the unit of the residuals).
    pub sd: f64,
    /// Degrees of freedom ν of the estimate.
    pub dof: usize,
}

impl TypeA {
    /// `s = √(Σr² / (scale·ν))` from a sum of squared residuals and its
    /// degrees of freedom (`scale` the variance of a residual in units of
    /// the noise's, e.g. 2 for a difference of two measured values);
    /// `None` without degrees of freedom or with a sum that is not finite.
    pub fn from_sum_of_squares(sum_sq: f64, dof: usize, scale: f64) -> Option<TypeA> {
        (dof > 0 && sum_sq.is_finite() && sum_sq >= 0.0 && scale > 0.0).then(|| TypeA {
            sd: (sum_sq / (scale * dof as f64)).sqrt(),
            dof,
        })
    }

    /// One trial's standard deviation `s·√(ν/χ²_ν)` (χ²_ν the sum of ν
    /// squared standard normal deviates): normal draws of it are t-distributed
    /// with ν degrees of freedom about the estimate (JCGM 101 §6.4.9.7).
    pub fn trial_sd(&self, draws: &mut Draws) -> f64 {
        let chi2: f64 = (0..self.dof).map(|_| draws.normal().powi(2)).sum();
        if chi2 > 0.0 {
            self.sd * (self.dof as f64 / chi2).sqrt()
        } else {
            self.sd
        }
    }

    /// The standard deviation of a trial whose sources `0..sources` share
    /// this noise: drawn from the stream of the first source the trial
    /// draws, `None` when it draws none.
    pub fn shared_sd(&self, trial: &mut Trial, sources: usize) -> Option<f64> {
        (0..sources).find_map(|s| trial.draws(s).map(|d| self.trial_sd(d)))
    }
}

/// The `uncertainty` object when the figures carry no U.
pub fn not_given(reason: impl Into<String>) -> Uncertainty {
    Uncertainty::NotGiven {
        reason: reason.into(),
    }
}

/// Figures of a report (by path); a report that does not serialise has none.
pub fn report_figures<R: Serialize>(report: &R, keys: &FigureKeys) -> BTreeMap<String, f64> {
    figures(report, keys).unwrap_or_default()
}

/// Propagate by Monte Carlo: `nominal` are the reported figures; `model`
/// re-draws the inputs (source `i` of `statement` is [`Trial::draws`]`(i)`)
/// and returns the figures of the re-run method (`None` when it fails on
/// that draw). `options.trials == 0` gives no U, and says why.
pub fn propagate<F>(
    nominal: &BTreeMap<String, f64>,
    statement: Statement,
    options: Propagation,
    model: F,
) -> Uncertainty
where
    F: Fn(&mut Trial) -> Option<BTreeMap<String, f64>> + Sync,
{
    if options.trials == 0 {
        return not_given(TRIALS_OFF);
    }
    let found = montecarlo::propagate(nominal, &statement.names(), options, model);
    Uncertainty::from_trials(found, nominal, statement, options)
}

/// `report.json`: `report` with `F_U_um` beside each figure that has a U
/// and the `uncertainty` object (when given) under `uncertainty`; every
/// other key and value as it is.
pub fn report_json<T: Serialize>(
    report: &T,
    uncertainty: Option<&Uncertainty>,
    keys: &FigureKeys,
) -> serde_json::Result<Value> {
    let none = BTreeMap::new();
    let expanded = uncertainty.and_then(Uncertainty::expanded).unwrap_or(&none);
    let mut value = with_expanded(report, expanded, keys)?;
    if let (Value::Object(map), Some(u)) = (&mut value, uncertainty) {
        map.insert("uncertainty".into(), serde_json::to_value(u)?);
    }
    Ok(value)
}

/// Lines that state the uncertainty for a terminal: how it was found and
/// each headline figure as `value ± U`, or why there is none.
pub fn summary(uncertainty: &Uncertainty) -> Vec<String> {
    match uncertainty {
        Uncertainty::NotGiven { reason } => {
            vec![format!("no expanded uncertainties: {reason}")]
        }
        Uncertainty::Given(p) => {
            let failed = if p.failed_trials > 0 {
                format!(", {} failed", p.failed_trials)
            } else {
                String::new()
            };
            std::iter::once(format!(
                "expanded uncertainties U (k = {}) by Monte Carlo, {} trials, seed {}{failed}:",
                p.k, p.trials, p.seed
            ))
            .chain(p.budget.iter().map(|b| {
                format!(
                    "  {} = {}",
                    b.figure,
                    report::plus_minus(b.value, Some(b.expanded), 4)
                )
            }))
            .collect()
        }
    }
}

/// The trial value of a root mean square `R` whose re-run gave `T`: noise
/// adds its variance to the mean square (`E[rms(t + n)²] = rms(t)² + σ̄²`),
/// a bias re-drawing adds once more, so the trial's draw of the truth is
/// the reflection `√max(0, 2R² − T²)` (the basic bootstrap on the mean
/// square, whose bias is additive); `|draw − R|` then holds the bias that
/// `|T − R|` would hold only in part where the noise is comparable with R.
pub fn reflected_rms(reported: f64, trial: f64) -> f64 {
    (2.0 * reported * reported - trial * trial).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` standard normal deviates of the streams of `seed`.
    fn normals(seed: u64, n: usize) -> Vec<f64> {
        let out = std::sync::Mutex::new(vec![0.0; n]);
        let options = Propagation { trials: n, seed };
        montecarlo::propagate(&BTreeMap::new(), &["z"], options, |t| {
            let z = t.draws(0)?.normal();
            if let Ok(mut o) = out.lock() {
                o[t.index()] = z;
            }
            None
        });
        out.into_inner().unwrap_or_default()
    }

    fn statement(headline: &[&str]) -> Statement {
        Statement {
            method: "test".into(),
            sources: vec![Source {
                name: "noise",
                description: "the values' noise".into(),
            }],
            not_included: Vec::new(),
            headline: headline.iter().map(|h| (*h).to_string()).collect(),
        }
    }

    /// 48 values sharing one true value 1.0 with noise σ = 0.1: the
    /// maximum is biased by ≈ 2.3σ; re-drawing about the measured values
    /// alone covers the truth rarely, the bound in ≥ 90 % of campaigns.
    #[test]
    fn the_bound_covers_a_maximum_over_tied_values() {
        let sigma = 0.1;
        let noise = TypeA {
            sd: sigma,
            dof: 1000,
        };
        let options = Propagation {
            trials: 200,
            seed: 5,
        };
        let max = |v: &[f64]| v.iter().fold(f64::MIN, |m, x| m.max(*x));
        let bound = Bound {
            figure: "max".into(),
            over: (0..48).collect(),
            kind: BoundKind::Largest,
        };
        let (mut naive, mut bounded) = (0, 0);
        let campaigns = 40;
        for c in 0..campaigns {
            let measured: Vec<f64> = normals(100 + c, 48)
                .iter()
                .map(|z| 1.0 + sigma * z)
                .collect();
            let nominal = BTreeMap::from([("max".to_string(), max(&measured))]);
            for (with_bound, count) in [(false, &mut naive), (true, &mut bounded)] {
                let u = propagate(&nominal, statement(&["max"]), options, |t| {
                    let sd = noise.shared_sd(t, 1)?;
                    let d = t.draws(0)?;
                    let trial: Vec<f64> = measured.iter().map(|m| m + d.gaussian(sd)).collect();
                    let mut f = BTreeMap::from([("max".to_string(), max(&trial))]);
                    if with_bound {
                        let dev: Vec<f64> = trial
                            .iter()
                            .zip(&measured)
                            .map(|(a, b)| (a - b).abs())
                            .collect();
                        bound.apply(&nominal, &dev, &mut f);
                    }
                    Some(f)
                });
                if (nominal["max"] - 1.0).abs() <= u.of("max").unwrap_or(0.0) {
                    *count += 1;
                }
            }
        }
        assert!(naive < campaigns / 2, "naive {naive}/{campaigns}");
        assert!(bounded >= campaigns * 9 / 10, "bound {bounded}/{campaigns}");
    }

    /// 95 % quantiles of |t₃| = 3.18 and of |N(0, 1)| = 1.96.
    #[test]
    fn t_scaling_widens_a_noise_known_from_few_residuals() {
        let quantile = |dof: usize| {
            let noise = TypeA { sd: 1.0, dof };
            let nominal = BTreeMap::from([("y".to_string(), 0.0)]);
            let options = Propagation {
                trials: 20_000,
                seed: 3,
            };
            let u = propagate(&nominal, statement(&[]), options, |t| {
                let sd = noise.shared_sd(t, 1)?;
                Some(BTreeMap::from([(
                    "y".to_string(),
                    t.draws(0)?.gaussian(sd),
                )]))
            });
            u.of("y").unwrap_or(f64::NAN)
        };
        assert!((quantile(3) - 3.18).abs() < 0.25, "{}", quantile(3));
        assert!((quantile(3000) - 1.96).abs() < 0.08, "{}", quantile(3000));
        let s = TypeA::from_sum_of_squares(8.0, 2, 2.0).unwrap();
        assert!((s.sd - 2.0_f64.sqrt()).abs() < 1e-15);
        assert!(TypeA::from_sum_of_squares(1.0, 0, 1.0).is_none());
    }
}
