//! Propagation of distributions by Monte Carlo (GUM Supplement 1,
//! JCGM 101:2008; docs/uncertainty.md).
//!
//! A measurement model maps draws of its inputs to the figures it reports
//! (named, e.g. `axes.X.positioning.A_um`). [`propagate`] runs it M times:
//! once with every source of uncertainty drawn, and once per source with only
//! that source drawn (the budget). The expanded uncertainty of a figure is
//! the half-width of the symmetric interval about the reported value that
//! holds [`COVERAGE_PROBABILITY`] of the trial figures
//! ([`expanded`], ≈ 2·σ for a normal output), so that a bias of the figure
//! under noise (a repeatability, a range) lies inside it.
//!
//! Each trial draws from its own streams, one per source, keyed by the seed,
//! the trial's index and the source's index: a trial's numbers do not depend
//! on which thread runs it nor on which other sources are drawn, so the
//! result is the same for a seed whatever the thread count, and a source's
//! budget run sees the same draws as the full run.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

use crate::{Degeneracy, GeomError, Result};

/// Coverage factor k of the expanded uncertainty U = k·u.
pub const COVERAGE_FACTOR: f64 = 2.0;
/// Coverage probability of U (k = 2 for a normal output).
pub const COVERAGE_PROBABILITY: f64 = 0.95;
/// Trials when the user names none (GUM S1 asks for more where the 95 %
/// quantile must be known to two digits; 200 gives U to ≈ ±10 %).
pub const DEFAULT_TRIALS: usize = 200;

/// The numbers one source draws in one trial: standard normal deviates from
/// a ChaCha8 stream of its own.
#[derive(Debug, Clone)]
pub struct Draws(ChaCha8Rng);

impl Draws {
    /// The stream of `source` in trial `trial` of a propagation seeded `seed`.
    fn new(seed: u64, trial: usize, source: usize) -> Self {
        let mut key = [0u8; 32];
        let mut h = splitmix(seed ^ 0x6d6f_6e74_6563_6172);
        h = splitmix(h ^ trial as u64);
        h = splitmix(h ^ source as u64);
        for chunk in key.chunks_exact_mut(8) {
            h = splitmix(h);
            chunk.copy_from_slice(&h.to_le_bytes());
        }
        Self(ChaCha8Rng::from_seed(key))
    }

    /// A stream of its own seeded `seed`, outside a propagation (a test's
    /// or a generator's noise): the same seed, the same deviates.
    pub fn seeded(seed: u64) -> Self {
        Self::new(seed, 0, 0)
    }

    /// A standard normal deviate.
    pub fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.0)
    }

    /// A normal deviate of standard deviation `sd` about 0.
    pub fn gaussian(&mut self, sd: f64) -> f64 {
        sd * self.normal()
    }
}

/// SplitMix64 finaliser: spreads a counter's bits over the word.
fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A square root L of a covariance matrix Σ = L·Lᵀ, for correlated normal
/// draws `x̂ + L·z`. From the symmetric eigendecomposition, so that a
/// semi-definite Σ (a parameter held fixed, a rank-deficient block) is
/// accepted; eigenvalues below `−1e-9·λ_max` are refused as not a covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct CovarianceRoot(DMatrix<f64>);

impl CovarianceRoot {
    /// The root of `covariance` (n × n, symmetric).
    pub fn new(covariance: &DMatrix<f64>) -> Result<Self> {
        if !covariance.is_square() {
            return Err(GeomError::Degenerate(Degeneracy::NotCovariance {
                smallest: f64::NAN,
                largest: f64::NAN,
            }));
        }
        if covariance.iter().any(|v| !v.is_finite()) {
            return Err(GeomError::NonFinite("covariance"));
        }
        let symmetric = (covariance + covariance.transpose()) * 0.5;
        let eigen = symmetric.symmetric_eigen();
        let largest = eigen.eigenvalues.max().max(0.0);
        let smallest = eigen.eigenvalues.min();
        if smallest < -1e-9 * largest - f64::MIN_POSITIVE {
            return Err(GeomError::Degenerate(Degeneracy::NotCovariance {
                smallest,
                largest,
            }));
        }
        let roots = eigen.eigenvalues.map(|l| l.max(0.0).sqrt());
        Ok(Self(eigen.eigenvectors * DMatrix::from_diagonal(&roots)))
    }

    /// Dimension n.
    pub fn dim(&self) -> usize {
        self.0.nrows()
    }

    /// One draw of the deviation from the estimate, `L·z`, z standard normal.
    pub fn draw(&self, draws: &mut Draws) -> DVector<f64> {
        let z = DVector::from_fn(self.0.ncols(), |_, _| draws.normal());
        &self.0 * z
    }
}

/// The draws of one trial: a stream per source of uncertainty, or `None` for
/// a source held at its estimate in this run (a budget run of another source).
#[derive(Debug)]
pub struct Trial {
    index: usize,
    streams: Vec<Option<Draws>>,
}

impl Trial {
    /// The trial's index (0-based).
    pub fn index(&self) -> usize {
        self.index
    }

    /// The draws of source `source` (its index in [`propagate`]'s list), or
    /// `None` when this run holds it at its estimate.
    pub fn draws(&mut self, source: usize) -> Option<&mut Draws> {
        self.streams.get_mut(source).and_then(Option::as_mut)
    }
}

/// Trials and seed of a propagation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Propagation {
    /// Trials per run (M).
    pub trials: usize,
    /// Seed of every draw.
    pub seed: u64,
}

impl Default for Propagation {
    fn default() -> Self {
        Self {
            trials: DEFAULT_TRIALS,
            seed: 1,
        }
    }
}

/// What a propagation found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Propagated {
    /// Per figure, the expanded uncertainty U (k = 2) with every source drawn.
    pub expanded: BTreeMap<String, f64>,
    /// Per source (by name), per figure, its standard uncertainty alone:
    /// U of the run that draws only that source, divided by k.
    pub contributions: BTreeMap<String, BTreeMap<String, f64>>,
    /// Trials of the full run whose model failed (left out of U).
    pub failed: usize,
}

/// Half-width of the symmetric interval about `reported` that holds
/// [`COVERAGE_PROBABILITY`] of `trials` (JCGM 101 §7.7 with the interval
/// centred on the reported value): the ⌈0.95·M⌉-th smallest |yᵣ − y|.
/// `None` without trials or with a non-finite one.
pub fn expanded(reported: f64, trials: &[f64]) -> Option<f64> {
    if trials.is_empty() || trials.iter().any(|t| !t.is_finite()) || !reported.is_finite() {
        return None;
    }
    let mut d: Vec<f64> = trials.iter().map(|t| (t - reported).abs()).collect();
    d.sort_by(f64::total_cmp);
    let rank = (COVERAGE_PROBABILITY * d.len() as f64).ceil() as usize;
    d.get(rank.clamp(1, d.len()) - 1).copied()
}

/// Expanded uncertainty of every figure of `nominal` over the trials that
/// produced it; a figure no trial produced is left out.
fn expanded_all(
    nominal: &BTreeMap<String, f64>,
    trials: &[BTreeMap<String, f64>],
) -> BTreeMap<String, f64> {
    nominal
        .iter()
        .filter_map(|(name, &value)| {
            let ys: Vec<f64> = trials.iter().filter_map(|t| t.get(name).copied()).collect();
            expanded(value, &ys).map(|u| (name.clone(), u))
        })
        .collect()
}

/// One run: M trials with the sources `active` drawn, in parallel; trials
/// whose model fails are counted and left out.
fn run<F>(options: Propagation, active: &[bool], model: &F) -> (Vec<BTreeMap<String, f64>>, usize)
where
    F: Fn(&mut Trial) -> Option<BTreeMap<String, f64>> + Sync,
{
    let outcomes: Vec<Option<BTreeMap<String, f64>>> = (0..options.trials)
        .into_par_iter()
        .map(|index| {
            let streams = active
                .iter()
                .enumerate()
                .map(|(s, &on)| on.then(|| Draws::new(options.seed, index, s)))
                .collect();
            model(&mut Trial { index, streams })
        })
        .collect();
    let failed = outcomes.iter().filter(|o| o.is_none()).count();
    (outcomes.into_iter().flatten().collect(), failed)
}

/// Propagate the sources named `sources` through `model` (module docs):
/// U of every figure of `nominal` with all sources drawn, and each source's
/// own contribution. `model` returns the trial's figures, or `None` when the
/// measurement cannot be computed from the trial's draws.
pub fn propagate<F>(
    nominal: &BTreeMap<String, f64>,
    sources: &[&str],
    options: Propagation,
    model: F,
) -> Propagated
where
    F: Fn(&mut Trial) -> Option<BTreeMap<String, f64>> + Sync,
{
    let all = vec![true; sources.len()];
    let (trials, failed) = run(options, &all, &model);
    let contributions = sources
        .iter()
        .enumerate()
        .map(|(s, name)| {
            // A single source's own run draws the same streams as the full
            // run: its trials are those.
            let own = (sources.len() > 1).then(|| {
                let only: Vec<bool> = (0..sources.len()).map(|i| i == s).collect();
                run(options, &only, &model).0
            });
            let u = expanded_all(nominal, own.as_deref().unwrap_or(&trials))
                .into_iter()
                .map(|(k, v)| (k, v / COVERAGE_FACTOR))
                .collect();
            ((*name).to_string(), u)
        })
        .collect();
    Propagated {
        expanded: expanded_all(nominal, &trials),
        contributions,
        failed,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figure(v: f64) -> BTreeMap<String, f64> {
        BTreeMap::from([("y_um".to_string(), v)])
    }

    /// y = a + b with a ~ N(0, 3²), b ~ N(0, 4²): U ≈ 2·5 = 10, the budget 3 and 4.
    #[test]
    fn a_sum_of_normals_has_the_expanded_uncertainty_of_its_variance() {
        let nominal = figure(0.0);
        let p = propagate(
            &nominal,
            &["a", "b"],
            Propagation {
                trials: 20_000,
                seed: 7,
            },
            |t| {
                let a = t.draws(0).map_or(0.0, |d| d.gaussian(3.0));
                let b = t.draws(1).map_or(0.0, |d| d.gaussian(4.0));
                Some(figure(a + b))
            },
        );
        let u = p.expanded["y_um"];
        // The 95 % quantile of |N(0, 5²)| is 1.96·5 = 9.8; ±3 % for 20 000 trials.
        assert!((u - 9.8).abs() < 0.3, "{u}");
        assert!((p.contributions["a"]["y_um"] - 2.94).abs() < 0.1);
        assert!((p.contributions["b"]["y_um"] - 3.92).abs() < 0.12);
        assert_eq!(p.failed, 0);
    }

    /// The same seed gives the same U whatever the thread count.
    #[test]
    fn the_result_does_not_depend_on_the_threads() {
        let nominal = figure(1.0);
        let model = |t: &mut Trial| {
            let d = t.draws(0)?;
            Some(figure(1.0 + d.normal() * d.normal()))
        };
        let options = Propagation {
            trials: 500,
            seed: 3,
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| propagate(&nominal, &["x"], options, model));
        let many = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap()
            .install(|| propagate(&nominal, &["x"], options, model));
        assert_eq!(one, many);
    }

    /// A figure biased by the noise (the spread of noisy values exceeds the
    /// true spread): U about the reported value holds the bias.
    #[test]
    fn a_biased_figure_keeps_its_bias_inside_u() {
        let u = expanded(
            1.0,
            &[1.5, 1.6, 1.55, 1.7, 1.52, 1.58, 1.61, 1.49, 1.53, 1.6],
        )
        .unwrap();
        assert!((u - 0.7).abs() < 1e-12);
        assert_eq!(expanded(0.0, &[]), None);
        assert_eq!(expanded(0.0, &[f64::NAN]), None);
    }

    /// Correlated draws have the covariance they were drawn from; a
    /// semi-definite one is accepted, an indefinite one refused.
    #[test]
    fn correlated_draws_have_their_covariance() {
        let cov = DMatrix::from_row_slice(3, 3, &[4.0, 2.0, 0.0, 2.0, 3.0, 0.0, 0.0, 0.0, 0.0]);
        let root = CovarianceRoot::new(&cov).unwrap();
        let mut d = Draws::new(1, 0, 0);
        let n = 40_000;
        let mut s = DMatrix::zeros(3, 3);
        for _ in 0..n {
            let x = root.draw(&mut d);
            s += &x * x.transpose();
        }
        s /= n as f64;
        assert!((&s - &cov).abs().max() < 0.12, "{s}");
        let bad = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(CovarianceRoot::new(&bad).is_err());
    }

    /// A failing model's trials are counted and left out.
    #[test]
    fn failed_trials_are_counted() {
        let nominal = figure(0.0);
        let p = propagate(&nominal, &["x"], Propagation::default(), |t| {
            (t.index() % 10 != 0).then(|| figure(t.draws(0).map_or(0.0, Draws::normal)))
        });
        assert_eq!(p.failed, DEFAULT_TRIALS / 10);
        assert!(p.expanded["y_um"] > 1.5);
    }
}
