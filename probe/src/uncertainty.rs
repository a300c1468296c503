//! The uncertainty statement of a probe method (docs/methods.md §7, GUM
//! Supplement 1): the Monte Carlo run through [`geom::montecarlo`], the
//! report's `uncertainty` object with the budget of its headline figures
//! ([`formats::uncertainty::Propagated`]), `report.json` with each figure's
//! `F_U_um` beside it, and the page's value ± U and budget table. Each
//! method supplies its sources of uncertainty and a model that re-runs its
//! own computation on one trial's draws.

use std::collections::BTreeMap;

use formats::uncertainty::{BudgetEntry, FigureKeys, Propagated, Uncertainty, with_expanded};
use geom::montecarlo::{self, COVERAGE_FACTOR, Trial};
pub use geom::montecarlo::{DEFAULT_TRIALS, Propagation};
use report::Page;
use serde::Serialize;
use serde_json::Value;

/// How U is defined, as the report states it.
pub const METHOD: &str = "GUM Supplement 1 Monte Carlo: the method's computation re-run on \
     every trial's draws of the inputs; U = half-width of the symmetric interval about the \
     reported value that holds 95 % of the trial figures (k = 2 for a normal output), so that a \
     bias of the figure under noise lies inside it";

/// Why a report carries no U under `--trials 0`.
pub const TRIALS_OFF: &str = "the Monte Carlo propagation was turned off (--trials 0)";

/// A source of uncertainty: its name in the budget and what it is.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// Name in the budget (`readings`, `squareness`).
    pub name: &'static str,
    /// What is drawn, from which distribution, in words.
    pub description: String,
}

/// Propagate `sources` through `model` (their index in `sources` is their
/// index in [`Trial::draws`]) and state the result: U of every figure of
/// `nominal` (the reported figures), the budget of the `headline` figures
/// present, and `not_included` in words. `options.trials == 0` gives no U,
/// and says why.
pub fn propagate<F>(
    nominal: &BTreeMap<String, f64>,
    sources: &[Source],
    not_included: Vec<String>,
    headline: &[&str],
    options: Propagation,
    model: F,
) -> Uncertainty
where
    F: Fn(&mut Trial) -> Option<BTreeMap<String, f64>> + Sync,
{
    if options.trials == 0 {
        return Uncertainty::NotGiven {
            reason: TRIALS_OFF.into(),
        };
    }
    let names: Vec<&str> = sources.iter().map(|s| s.name).collect();
    let found = montecarlo::propagate(nominal, &names, options, model);
    let budget = headline
        .iter()
        .filter_map(|&figure| {
            Some(BudgetEntry {
                figure: figure.to_string(),
                value: *nominal.get(figure)?,
                expanded: *found.expanded.get(figure)?,
                contributions: found
                    .contributions
                    .iter()
                    .filter_map(|(s, u)| u.get(figure).map(|v| (s.clone(), *v)))
                    .collect(),
            })
        })
        .collect();
    Uncertainty::Given(Propagated {
        method: METHOD.into(),
        k: COVERAGE_FACTOR,
        trials: options.trials,
        seed: options.seed,
        failed_trials: found.failed,
        sources: sources
            .iter()
            .map(|s| (s.name.to_string(), s.description.clone()))
            .collect(),
        not_included,
        budget,
        expanded: found.expanded,
    })
}

/// `report.json`: `report` with `F_U_um` beside each figure that has a U
/// and the `uncertainty` object added; every other key and value as it is.
pub fn report_json<T: Serialize>(
    report: &T,
    uncertainty: &Uncertainty,
    keys: &FigureKeys,
) -> serde_json::Result<Value> {
    let none = BTreeMap::new();
    let mut value = with_expanded(report, uncertainty.expanded().unwrap_or(&none), keys)?;
    if let Value::Object(map) = &mut value {
        map.insert("uncertainty".into(), serde_json::to_value(uncertainty)?);
    }
    Ok(value)
}

/// `value` (already formatted, without unit) followed by ` ± U unit` when
/// the figure at `path` has a U, else by its unit alone.
pub fn plus_minus(value: &str, uncertainty: &Uncertainty, path: &str, unit: &str) -> String {
    let text = match uncertainty.of(path) {
        Some(u) => format!("{value} ± {} {unit}", significant(u)),
        None => format!("{value} {unit}"),
    };
    text.trim_end().to_string()
}

/// U written with two significant digits (GUM 7.2.6).
fn significant(u: f64) -> String {
    if !(u.is_finite() && u > 0.0) {
        return format!("{u}");
    }
    let decimals = (1 - u.log10().floor() as i32).max(0) as usize;
    format!("{u:.decimals$}")
}

/// The page's uncertainty section: how U was found, the budget of the
/// headline figures (U and each source's standard uncertainty), the
/// sources and what is not included; or why there is no U.
pub fn section(page: &mut Page, uncertainty: &Uncertainty, unit_of: impl Fn(&str) -> &'static str) {
    page.h2("uncertainty", "Uncertainty (k = 2)");
    let p = match uncertainty {
        Uncertainty::NotGiven { reason } => {
            page.paragraph(&format!("The figures are given without U: {reason}."));
            return;
        }
        Uncertainty::Given(p) => p,
    };
    page.paragraph(&format!(
        "{} trials (seed {}{}). {}.",
        p.trials,
        p.seed,
        if p.failed_trials > 0 {
            format!(", {} failed and left out", p.failed_trials)
        } else {
            String::new()
        },
        METHOD
    ));
    let names: Vec<&String> = p.sources.keys().collect();
    let mut header = vec!["figure", "value", "U (k = 2)"];
    let titles: Vec<String> = names.iter().map(|n| format!("u: {n}")).collect();
    header.extend(titles.iter().map(String::as_str));
    let rows: Vec<Vec<String>> = p
        .budget
        .iter()
        .map(|b| {
            let unit = unit_of(&b.figure);
            let mut row = vec![
                b.figure.clone(),
                format!("{:.4} {unit}", b.value),
                format!("{} {unit}", significant(b.expanded)),
            ];
            row.extend(names.iter().map(|n| {
                b.contributions
                    .get(*n)
                    .map_or_else(|| "—".into(), |u| format!("{} {unit}", significant(*u)))
            }));
            row
        })
        .collect();
    page.table(Some("budget"), &header, &rows);
    let sources: Vec<String> = p.sources.iter().map(|(n, d)| format!("{n}: {d}")).collect();
    page.notes("Sources of uncertainty", &sources, false);
    if !p.not_included.is_empty() {
        page.notes("Not included", &p.not_included, false);
    }
}

/// The unit of a figure path from its key's suffix (`_urad` → µrad, else µm).
pub fn unit_of(path: &str) -> &'static str {
    if path.ends_with("_urad") {
        "µrad"
    } else {
        "µm"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn u_has_two_significant_digits() {
        assert_eq!(significant(0.01234), "0.012");
        assert_eq!(significant(1.234), "1.2");
        assert_eq!(significant(12.34), "12");
        let off = Uncertainty::NotGiven {
            reason: TRIALS_OFF.into(),
        };
        assert_eq!(plus_minus("3.000", &off, "a_um", "µm"), "3.000 µm");
    }
}
