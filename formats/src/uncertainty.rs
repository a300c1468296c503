//! The uncertainty of a report's figures (docs/uncertainty.md): which
//! numbers of a `report.json` are figures, their expanded uncertainties
//! `F_U_um` written beside them, and the report's `uncertainty` object.
//!
//! A figure is a number whose key ends in one of a report's figure units
//! (`A_um`, `roll_urad`), named by its path in the report's JSON
//! (`axes.X.positioning.A_um`, `axes.X.lines.0.positioning.A_um`). Its
//! expanded uncertainty (k = 2) is written as a sibling key with `_U` before
//! the unit: `A_um` → `A_U_um`, `roll_urad` → `roll_U_urad`.

use std::collections::BTreeMap;

use geom::montecarlo::{self, COVERAGE_FACTOR, Propagation};
use serde::Serialize;
use serde_json::Value;

/// Which numbers of a report are figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FigureKeys {
    /// Key suffixes of figures (`_um`, `_urad`, …).
    pub units: &'static [&'static str],
    /// Keys whose values are not figures: objects and arrays under them
    /// (per-target tables) and numbers so named (diagnostics).
    pub skip: &'static [&'static str],
}

impl FigureKeys {
    /// The unit suffix of `key` when it names a figure.
    fn unit(&self, key: &str) -> Option<&'static str> {
        if self.skip.contains(&key) {
            return None;
        }
        self.units
            .iter()
            .copied()
            .find(|u| key.len() > u.len() && key.ends_with(u) && !key.ends_with(&format!("_U{u}")))
    }
}

/// The key of the expanded uncertainty of figure `key`: `_U` before its
/// unit (`A_um` → `A_U_um`); `None` when `key` is not a figure.
pub fn expanded_key(key: &str, keys: &FigureKeys) -> Option<String> {
    let unit = keys.unit(key)?;
    Some(format!("{}_U{unit}", &key[..key.len() - unit.len()]))
}

/// Every figure of `report` by its path.
pub fn figures<T: Serialize>(
    report: &T,
    keys: &FigureKeys,
) -> serde_json::Result<BTreeMap<String, f64>> {
    let value = serde_json::to_value(report)?;
    let mut out = BTreeMap::new();
    collect(&value, "", keys, &mut out);
    Ok(out)
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn collect(value: &Value, path: &str, keys: &FigureKeys, out: &mut BTreeMap<String, f64>) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                if keys.skip.contains(&k.as_str()) {
                    continue;
                }
                match v {
                    Value::Number(n) if keys.unit(k).is_some() => {
                        if let Some(x) = n.as_f64() {
                            out.insert(join(path, k), x);
                        }
                    }
                    _ => collect(v, &join(path, k), keys, out),
                }
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                collect(v, &join(path, &i.to_string()), keys, out);
            }
        }
        _ => {}
    }
}

/// `report` as JSON with the expanded uncertainty of every figure in
/// `expanded` (by path) written beside it.
pub fn with_expanded<T: Serialize>(
    report: &T,
    expanded: &BTreeMap<String, f64>,
    keys: &FigureKeys,
) -> serde_json::Result<Value> {
    let mut value = serde_json::to_value(report)?;
    annotate(&mut value, "", expanded, keys);
    Ok(value)
}

/// Write `report` as JSON to `path` (atomically) with the expanded
/// uncertainties beside their figures ([`with_expanded`]); errors name `path`.
pub fn write_with_expanded<T: Serialize>(
    path: &std::path::Path,
    report: &T,
    expanded: &BTreeMap<String, f64>,
    keys: &FigureKeys,
) -> crate::Result<()> {
    let value = with_expanded(report, expanded, keys)
        .map_err(|e| crate::FormatError::file(path, e.to_string()))?;
    crate::write_json(path, &value)
}

fn annotate(value: &mut Value, path: &str, expanded: &BTreeMap<String, f64>, keys: &FigureKeys) {
    match value {
        Value::Object(map) => {
            let mut siblings = Vec::new();
            for (k, v) in map.iter_mut() {
                if keys.skip.contains(&k.as_str()) {
                    continue;
                }
                let here = join(path, k);
                match (expanded.get(&here), expanded_key(k, keys)) {
                    (Some(&u), Some(name)) if v.is_number() => siblings.push((name, u)),
                    _ => annotate(v, &here, expanded, keys),
                }
            }
            for (name, u) in siblings {
                if let Some(n) = serde_json::Number::from_f64(u) {
                    map.insert(name, Value::Number(n));
                }
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter_mut().enumerate() {
                annotate(v, &join(path, &i.to_string()), expanded, keys);
            }
        }
        _ => {}
    }
}

/// The `uncertainty` object of a report: how the figures' U were found, or
/// why there are none.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Uncertainty {
    /// Propagated by Monte Carlo.
    Given(Propagated),
    /// Not given, and why (no observations to propagate, `--trials 0`).
    NotGiven {
        /// Why the figures carry no U.
        reason: String,
    },
}

impl Uncertainty {
    /// The expanded uncertainties by figure path (empty when not given).
    pub fn expanded(&self) -> Option<&BTreeMap<String, f64>> {
        match self {
            Uncertainty::Given(p) => Some(&p.expanded),
            Uncertainty::NotGiven { .. } => None,
        }
    }

    /// U of the figure at `path`, when given.
    pub fn of(&self, path: &str) -> Option<f64> {
        self.expanded().and_then(|e| e.get(path).copied())
    }
}

/// A Monte Carlo propagation's record (GUM Supplement 1).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Propagated {
    /// How U is defined.
    pub method: String,
    /// Coverage factor k.
    pub k: f64,
    /// Trials per run.
    pub trials: usize,
    /// Seed of the draws.
    pub seed: u64,
    /// Trials whose model failed (left out of U).
    pub failed_trials: usize,
    /// The sources of uncertainty drawn, by name, with what each is.
    pub sources: BTreeMap<String, String>,
    /// What is not included, in words.
    pub not_included: Vec<String>,
    /// The budget of each headline figure.
    pub budget: Vec<BudgetEntry>,
    /// U per figure path (written beside each figure, not in this object).
    #[serde(skip)]
    pub expanded: BTreeMap<String, f64>,
}

/// The budget of one figure: its value, U and each source's standard
/// uncertainty alone (their quadratic sum ≈ (U/k)² for a linear model).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BudgetEntry {
    /// The figure's path in the report.
    pub figure: String,
    /// Its value.
    pub value: f64,
    /// Its expanded uncertainty (k = 2), all sources drawn.
    #[serde(rename = "U")]
    pub expanded: f64,
    /// Standard uncertainty from each source alone (by source name).
    pub contributions: BTreeMap<String, f64>,
}

/// Why a report carries no U when no trials were asked for.
pub const TRIALS_OFF: &str =
    "the Monte Carlo propagation was turned off (trials = 0, --trials 0 on the command line)";

/// A source of uncertainty: its name in the budget (the name of its draws
/// in [`geom::montecarlo::propagate`]) and what is drawn, in words.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// Name in the budget (`readings`, `centroids`).
    pub name: &'static str,
    /// What is drawn, from which distribution, in words.
    pub description: String,
}

/// What a method states about its propagation besides the trials: how U is
/// defined, the sources (in the order of the trials' streams), what is not
/// included, and the headline figures (paths) that get a budget entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Statement {
    /// How U is defined and what the trials re-run.
    pub method: String,
    /// The sources of uncertainty, in the order of the trials' streams.
    pub sources: Vec<Source>,
    /// What is not included, in words.
    pub not_included: Vec<String>,
    /// The headline figures (paths in the report), in the budget's order.
    pub headline: Vec<String>,
}

impl Statement {
    /// The sources' names, in the order of the trials' streams.
    pub fn names(&self) -> Vec<&'static str> {
        self.sources.iter().map(|s| s.name).collect()
    }
}

impl Uncertainty {
    /// The record of a Monte Carlo run (`found`, from
    /// [`geom::montecarlo::propagate`] of `statement`'s sources with
    /// `options`) about the reported figures `nominal`: U of every figure,
    /// the budget of each headline figure present (value, U, each source's
    /// standard uncertainty alone). No U, and why, when every trial failed.
    pub fn from_trials(
        found: montecarlo::Propagated,
        nominal: &BTreeMap<String, f64>,
        statement: Statement,
        options: Propagation,
    ) -> Uncertainty {
        if options.trials > 0 && found.failed >= options.trials {
            return Uncertainty::NotGiven {
                reason: format!(
                    "every one of the {} Monte Carlo trials failed: the method cannot be re-run \
                     on inputs drawn about the measured ones",
                    options.trials
                ),
            };
        }
        let budget = statement
            .headline
            .iter()
            .filter_map(|figure| budget_entry(figure, nominal, &found))
            .collect();
        Uncertainty::Given(Propagated {
            method: statement.method,
            k: COVERAGE_FACTOR,
            trials: options.trials,
            seed: options.seed,
            failed_trials: found.failed,
            sources: statement
                .sources
                .into_iter()
                .map(|s| (s.name.to_string(), s.description))
                .collect(),
            not_included: statement.not_included,
            budget,
            expanded: found.expanded,
        })
    }
}

/// The budget of `figure`: its value in `nominal`, its U and each source's
/// standard uncertainty in `found`; `None` when it has no value or no U.
fn budget_entry(
    figure: &str,
    nominal: &BTreeMap<String, f64>,
    found: &montecarlo::Propagated,
) -> Option<BudgetEntry> {
    Some(BudgetEntry {
        figure: figure.to_string(),
        value: *nominal.get(figure)?,
        expanded: *found.expanded.get(figure)?,
        contributions: found
            .contributions
            .iter()
            .filter_map(|(source, u)| u.get(figure).map(|v| (source.clone(), *v)))
            .collect(),
    })
}

/// A figure whose error is bounded by the deviations of the values it is
/// taken over (`m` measured, `t` true, `d = m − t`): an extreme of
/// magnitudes, `|max|m| − max|t|| ≤ max|d|`; a mean of magnitudes,
/// `|mean|m| − mean|t|| ≤ mean|d|`; a range, `|range(m) − range(t)| ≤
/// range(d)`. Where the values' noise is comparable with their spread,
/// noise biases such a figure upward by about as much as the figure itself,
/// which re-drawing about the measured values reproduces only in part; the
/// trial value `reported + bound(d)` (`d` = the trial's values − the
/// reported ones) makes U the 95 % quantile of the bound's draws.
#[derive(Debug, Clone, PartialEq)]
pub struct Bound {
    /// The figure's path.
    pub figure: String,
    /// The values it is taken over (indices into the trial's deviations).
    pub over: Vec<usize>,
    /// How the figure combines its values.
    pub kind: BoundKind,
}

/// How a [`Bound`]'s figure combines its values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundKind {
    /// An extreme of magnitudes: the largest |d|.
    Largest,
    /// A mean of magnitudes: the mean |d|.
    Mean,
    /// A range (max − min) of signed values: the range of d.
    Range,
}

impl BoundKind {
    /// The bound from the signed deviations `d` (0 without any).
    pub fn of(self, d: impl IntoIterator<Item = f64>) -> f64 {
        let mut d = d.into_iter().peekable();
        if d.peek().is_none() {
            return 0.0;
        }
        match self {
            BoundKind::Largest => d.fold(0.0, |m, x| m.max(x.abs())),
            BoundKind::Mean => {
                let (sum, n) = d.fold((0.0, 0usize), |(s, n), x| (s + x.abs(), n + 1));
                sum / n as f64
            }
            BoundKind::Range => {
                let (lo, hi) = d.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                    (lo.min(x), hi.max(x))
                });
                hi - lo
            }
        }
    }
}

impl Bound {
    /// Replace the figure's trial value in `trial` by `reported + bound`,
    /// the bound from the trial's signed `deviations` (trial value −
    /// reported value of each value).
    pub fn apply(
        &self,
        nominal: &BTreeMap<String, f64>,
        deviations: &[f64],
        trial: &mut BTreeMap<String, f64>,
    ) {
        let d = self.over.iter().filter_map(|&i| deviations.get(i).copied());
        bounded(nominal, &self.figure, self.kind.of(d), trial);
    }
}

/// Set figure `figure`'s trial value in `trial` to `reported + bound`
/// ([`Bound`]); nothing when the figure is not reported.
pub fn bounded(
    nominal: &BTreeMap<String, f64>,
    figure: &str,
    bound: f64,
    trial: &mut BTreeMap<String, f64>,
) {
    if let Some(reported) = nominal.get(figure) {
        trial.insert(figure.to_string(), reported + bound);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEYS: FigureKeys = FigureKeys {
        units: &["_um", "_urad"],
        skip: &["targets", "fit_rms_um"],
    };

    #[derive(Serialize)]
    struct Line {
        #[serde(rename = "A_um")]
        a: f64,
        roll_urad: f64,
        fit_rms_um: f64,
        nominal: f64,
        targets: Vec<Target>,
    }

    #[derive(Serialize)]
    struct Target {
        mean_um: f64,
    }

    #[derive(Serialize)]
    struct Report {
        lines: Vec<Line>,
    }

    fn report() -> Report {
        Report {
            lines: vec![Line {
                a: 3.0,
                roll_urad: 12.0,
                fit_rms_um: 0.1,
                nominal: 5.0,
                targets: vec![Target { mean_um: 1.0 }],
            }],
        }
    }

    #[test]
    fn figures_are_the_unit_keys_outside_the_skipped_ones() {
        let f = figures(&report(), &KEYS).unwrap();
        let names: Vec<&str> = f.keys().map(String::as_str).collect();
        assert_eq!(names, ["lines.0.A_um", "lines.0.roll_urad"]);
        assert_eq!(expanded_key("A_um", &KEYS).as_deref(), Some("A_U_um"));
        assert_eq!(
            expanded_key("roll_urad", &KEYS).as_deref(),
            Some("roll_U_urad")
        );
        assert_eq!(expanded_key("A_U_um", &KEYS), None);
        assert_eq!(expanded_key("nominal", &KEYS), None);
    }

    #[test]
    fn expanded_uncertainties_are_written_beside_their_figures() {
        let u = BTreeMap::from([("lines.0.A_um".to_string(), 0.4)]);
        let v = with_expanded(&report(), &u, &KEYS).unwrap();
        assert_eq!(v["lines"][0]["A_U_um"], 0.4);
        assert!(v["lines"][0].get("roll_U_urad").is_none());
        assert_eq!(v["lines"][0]["A_um"], 3.0);
    }

    fn statement(headline: &[&str]) -> Statement {
        Statement {
            method: "m".into(),
            sources: vec![Source {
                name: "noise",
                description: "N(0, 1)".into(),
            }],
            not_included: vec!["heat".into()],
            headline: headline.iter().map(|h| (*h).to_string()).collect(),
        }
    }

    /// The budget holds the headline figures that have a value and a U, in
    /// the statement's order; U of every figure is kept.
    #[test]
    fn the_budget_is_assembled_from_the_trials() {
        let nominal = BTreeMap::from([("a_um".to_string(), 2.0), ("b_um".to_string(), 3.0)]);
        let options = Propagation {
            trials: 50,
            seed: 1,
        };
        let found = montecarlo::propagate(&nominal, &["noise"], options, |t| {
            let z = t.draws(0).map_or(0.0, |d| d.normal());
            Some(BTreeMap::from([
                ("a_um".to_string(), 2.0 + z),
                ("b_um".to_string(), 3.0 + 0.1 * z),
            ]))
        });
        let u = Uncertainty::from_trials(
            found.clone(),
            &nominal,
            statement(&["b_um", "missing_um", "a_um"]),
            options,
        );
        let Uncertainty::Given(p) = &u else {
            panic!("{u:?}")
        };
        let figures: Vec<&str> = p.budget.iter().map(|b| b.figure.as_str()).collect();
        assert_eq!(figures, ["b_um", "a_um"]);
        assert_eq!(p.budget[1].value, 2.0);
        assert_eq!(p.budget[1].expanded, found.expanded["a_um"]);
        assert_eq!(
            p.budget[1].contributions["noise"],
            found.contributions["noise"]["a_um"]
        );
        assert_eq!(p.expanded, found.expanded);
        assert_eq!(p.sources["noise"], "N(0, 1)");
        assert_eq!((p.trials, p.seed, p.k), (50, 1, 2.0));
    }

    #[test]
    fn no_u_when_every_trial_fails() {
        let nominal = BTreeMap::from([("a_um".to_string(), 2.0)]);
        let options = Propagation {
            trials: 10,
            seed: 1,
        };
        let found = montecarlo::propagate(&nominal, &["noise"], options, |_| None);
        let u = Uncertainty::from_trials(found, &nominal, statement(&["a_um"]), options);
        assert!(
            matches!(&u, Uncertainty::NotGiven { reason } if reason.contains("every one of the 10")),
            "{u:?}"
        );
    }

    /// Each bound holds against a true set: `|F(m) − F(t)| ≤ bound(m − t)`.
    #[test]
    fn the_bounds_hold_for_their_figures() {
        let t = [0.0, 2.0, -1.0, 0.5];
        let m = [0.3, 1.6, -0.2, 0.9];
        let d: Vec<f64> = m.iter().zip(&t).map(|(m, t)| m - t).collect();
        let range = |v: &[f64]| {
            v.iter().copied().fold(f64::MIN, f64::max) - v.iter().copied().fold(f64::MAX, f64::min)
        };
        let largest = |v: &[f64]| v.iter().fold(0.0, |a: f64, x| a.max(x.abs()));
        let mean = |v: &[f64]| v.iter().map(|x| x.abs()).sum::<f64>() / v.len() as f64;
        assert!((BoundKind::Range.of(d.clone()) - 1.2).abs() < 1e-12);
        assert!((range(&m) - range(&t)).abs() <= BoundKind::Range.of(d.clone()));
        assert!((largest(&m) - largest(&t)).abs() <= BoundKind::Largest.of(d.clone()));
        assert!((mean(&m) - mean(&t)).abs() <= BoundKind::Mean.of(d.clone()));
        assert_eq!(BoundKind::Range.of([]), 0.0);
        let nominal = BTreeMap::from([("r_um".to_string(), 3.0)]);
        let mut trial = BTreeMap::from([("r_um".to_string(), 2.5)]);
        Bound {
            figure: "r_um".into(),
            over: vec![0, 1, 2, 3],
            kind: BoundKind::Range,
        }
        .apply(&nominal, &d, &mut trial);
        assert!((trial["r_um"] - 4.2).abs() < 1e-12);
    }
}
