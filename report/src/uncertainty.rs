//! The uncertainty of a report's figures on its page (docs/uncertainty.md):
//! a figure as `value ± U` and the section that states how U was found,
//! with the budget table of the headline figures, or why there is no U.
//! U and the budget's standard uncertainties are written with two
//! significant digits (GUM 7.2.6), each with its figure's unit.

use std::fmt::Write;

use formats::uncertainty::{BudgetEntry, Propagated, Uncertainty};

use crate::page::{Page, escape, num};

/// U (or u) with two significant digits (GUM 7.2.6); a U that is zero or not
/// finite as it is.
pub fn significant(u: f64) -> String {
    let decimals = decimals(u);
    format!("{u:.decimals$}")
}

/// The decimals that give `u` two significant digits once rounded (a `u`
/// that rounds up to the next power of ten, 0.99996 → 1.0, one fewer); 0
/// when `u` is not finite and positive.
fn decimals(u: f64) -> usize {
    if !(u.is_finite() && u > 0.0) {
        return 0;
    }
    let d = (1 - u.log10().floor() as i32).max(0) as usize;
    let rounded: f64 = format!("{u:.d$}").parse().unwrap_or(u);
    if d > 0 && rounded >= 10f64.powi(2 - d as i32) {
        d - 1
    } else {
        d
    }
}

/// What a figure within its own uncertainty of zero is called: the
/// measurement cannot tell it from none.
pub const NOT_SIGNIFICANT: &str = "not significant";

/// The decimals of a value stated with its U: those of U's last digit
/// (GUM 7.2.6: the value rounded to the last digit of its uncertainty); a
/// value without U, or with a U that is zero or not finite, `otherwise`.
pub fn value_decimals(expanded: Option<f64>, otherwise: usize) -> usize {
    match expanded {
        Some(u) if u.is_finite() && u > 0.0 => decimals(u),
        _ => otherwise,
    }
}

/// `value ± U`, U with two significant digits and the value rounded to U's
/// last digit (GUM 7.2.6: `7.9 ± 2.9`) — followed by "(not significant)"
/// when |value| < U — or the value alone with `decimals` decimals without U.
pub fn plus_minus(value: f64, expanded: Option<f64>, decimals: usize) -> String {
    plus_minus_in(value, expanded, decimals, "")
}

/// [`plus_minus`] with `unit` right after the number (`3.000 ± 0.046 µm`,
/// `3 ± 12 µm (not significant)`).
pub fn plus_minus_in(value: f64, expanded: Option<f64>, decimals: usize, unit: &str) -> String {
    let decimals = value_decimals(expanded, decimals);
    let shown = match expanded {
        Some(u) => format!("{value:.decimals$} ± {}", significant(u)),
        None => format!("{value:.decimals$}"),
    };
    let shown = with_unit(shown, unit);
    match expanded {
        Some(u) if value.abs() < u => format!("{shown} ({NOT_SIGNIFICANT})"),
        _ => shown,
    }
}

/// A figure as [`plus_minus`] (3 decimals without U), or an em dash when absent.
pub fn num_u(value: Option<f64>, expanded: Option<f64>) -> String {
    num_u_in(value, expanded, "")
}

/// [`num_u`] with `unit` right after the number (before "(not
/// significant)"); an absent figure is an em dash without a unit.
pub fn num_u_in(value: Option<f64>, expanded: Option<f64>, unit: &str) -> String {
    match value {
        Some(v) => plus_minus_in(v, expanded, 3, unit),
        None => num(value),
    }
}

/// The unit of a figure from its key's suffix (`_um` µm, `_urad` µrad,
/// `_arcsec` ″, `_mm` mm, `_deg` °); empty for another key.
pub fn unit_of(path: &str) -> &'static str {
    const UNITS: [(&str, &str); 5] = [
        ("_um", "µm"),
        ("_urad", "µrad"),
        ("_arcsec", "″"),
        ("_mm", "mm"),
        ("_deg", "°"),
    ];
    UNITS
        .iter()
        .find(|(suffix, _)| path.ends_with(suffix))
        .map_or("", |(_, unit)| unit)
}

/// `text` followed by `unit` (none when empty; no space before ″ and °).
fn with_unit(text: String, unit: &str) -> String {
    match unit {
        "" => text,
        "″" | "°" => format!("{text}{unit}"),
        _ => format!("{text} {unit}"),
    }
}

/// The page's uncertainty section (`#uncertainty`) for a report's
/// `uncertainty` object: how U was found, the budget table (`#budget`) of
/// the headline figures (value, U and each source's standard uncertainty
/// alone), the sources and what is not included; or why the figures carry
/// no U. Nothing when the report has no such object. The budget names each
/// figure by its path; [`section_labelled`] as the page names them.
pub fn section(page: &mut Page, uncertainty: Option<&Uncertainty>) {
    section_labelled(page, uncertainty, &|path| path.to_string());
}

/// [`section`] with each figure of the budget named by `label` (its path
/// in, its name on the page out: `axes.X.positioning.A_down_um` →
/// `X, A↓, µm`).
pub fn section_labelled(
    page: &mut Page,
    uncertainty: Option<&Uncertainty>,
    label: &dyn Fn(&str) -> String,
) {
    let Some(uncertainty) = uncertainty else {
        return;
    };
    page.h2("uncertainty", "Uncertainty (U, k = 2)");
    match uncertainty {
        Uncertainty::NotGiven { reason } => {
            let _ = writeln!(
                page,
                "<p class=\"warn\">The figures carry no expanded uncertainty: {}.</p>",
                escape(reason)
            );
        }
        Uncertainty::Given(p) => given(page, p, label),
    }
}

/// The section of a propagated uncertainty.
fn given(page: &mut Page, p: &Propagated, label: &dyn Fn(&str) -> String) {
    let failed = if p.failed_trials > 0 {
        format!("; {} failed and were left out", p.failed_trials)
    } else {
        String::new()
    };
    page.meta(&escape(&format!(
        "Figures are shown as value ± U (expanded uncertainty, k = {}). {}. {} trials, seed {}{failed}.",
        p.k, p.method, p.trials, p.seed
    )));
    let names: Vec<&String> = p.sources.keys().collect();
    let titles: Vec<String> = names.iter().map(|n| format!("u {n} alone")).collect();
    let mut header = vec!["figure", "value", "U (k = 2)"];
    header.extend(titles.iter().map(String::as_str));
    let rows: Vec<Vec<String>> = p
        .budget
        .iter()
        .map(|b| budget_row(b, &names, label))
        .collect();
    page.table(Some("budget"), &header, &rows);
    let sources: Vec<String> = p.sources.iter().map(|(n, d)| format!("{n}: {d}")).collect();
    page.notes("Sources of uncertainty", &sources, false);
    page.notes("Not included in U", &p.not_included, false);
}

/// One row of the budget: the figure, its value to the last digit of its U
/// (GUM 7.2.6), U and each source's u to one digit more (a negligible
/// source reads 0), each with the figure's unit; the figure named by `label`.
fn budget_row(b: &BudgetEntry, sources: &[&String], label: &dyn Fn(&str) -> String) -> Vec<String> {
    let unit = unit_of(&b.figure);
    let value_decimals = value_decimals(Some(b.expanded), 3);
    let mut row = vec![
        label(&b.figure),
        with_unit(format!("{:.value_decimals$}", b.value), unit),
        with_unit(significant(b.expanded), unit),
    ];
    let u_decimals = value_decimals + 1;
    row.extend(sources.iter().map(|s| {
        b.contributions.get(*s).map_or_else(
            || "—".into(),
            |u| with_unit(format!("{u:.u_decimals$}"), unit),
        )
    }));
    row
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    #[test]
    fn u_has_two_significant_digits() {
        assert_eq!(significant(0.01234), "0.012");
        assert_eq!(significant(1.234), "1.2");
        assert_eq!(significant(12.34), "12");
        assert_eq!(significant(0.0), "0");
        assert_eq!(significant(0.99996), "1.0");
        assert_eq!(significant(9.97), "10");
        assert_eq!(significant(0.0999), "0.10");
        assert_eq!(plus_minus(3.0, None, 3), "3.000");
        assert_eq!(plus_minus(3.0, Some(0.04567), 3), "3.000 ± 0.046");
        assert_eq!(num_u(None, Some(1.0)), "—");
        assert_eq!(
            plus_minus_in(3.0, Some(12.34), 1, "µm"),
            "3 ± 12 µm (not significant)"
        );
        // The value to U's last digit (GUM 7.2.6), whatever the decimals asked.
        assert_eq!(plus_minus(7.894, Some(2.9), 3), "7.9 ± 2.9");
        assert_eq!(plus_minus(7.894, Some(0.0), 3), "7.894 ± 0");
        assert_eq!(
            num_u_in(Some(0.5), Some(2.9), "µm"),
            "0.5 ± 2.9 µm (not significant)"
        );
        assert_eq!(num_u_in(None, Some(2.9), "µm"), "—");
        assert_eq!(plus_minus(-3.0, Some(2.5), 1), "-3.0 ± 2.5");
        assert_eq!(plus_minus_in(3.0, None, 1, "″"), "3.0″");
        assert_eq!(unit_of("a.max_dA_arcsec"), "″");
        assert_eq!(unit_of("axes.X.angular.roll_urad"), "µrad");
        assert_eq!(unit_of("count"), "");
    }

    fn page_of(u: Option<&Uncertainty>) -> String {
        let mut page = Page::new("t", "h");
        section(&mut page, u);
        page.finish()
    }

    #[test]
    fn the_section_states_the_budget_or_why_there_is_none() {
        assert!(!page_of(None).contains("id=\"uncertainty\""));
        let off = page_of(Some(&Uncertainty::NotGiven {
            reason: "no <trials>".into(),
        }));
        assert!(off.contains("<h2 id=\"uncertainty\">"));
        assert!(off.contains("no expanded uncertainty: no &lt;trials&gt;."));
        let p = Propagated {
            method: "Monte Carlo".into(),
            k: 2.0,
            trials: 200,
            seed: 7,
            failed_trials: 0,
            sources: BTreeMap::from([
                ("a".to_string(), "first".to_string()),
                ("b".to_string(), "second".to_string()),
            ]),
            not_included: vec!["heat".into()],
            budget: vec![BudgetEntry {
                figure: "x.max_dA_arcsec".into(),
                value: 1.23456,
                expanded: 0.0789,
                contributions: BTreeMap::from([("a".to_string(), 0.0312)]),
            }],
            expanded: BTreeMap::new(),
        };
        let html = page_of(Some(&Uncertainty::Given(p)));
        assert!(html.contains("<table id=\"budget\">"));
        assert!(html.contains("<th>u a alone</th><th>u b alone</th>"));
        assert!(
            html.contains(
                "<td class=\"l\">x.max_dA_arcsec</td><td>1.235″</td><td>0.079″</td>\
                 <td>0.0312″</td><td>—</td>"
            ),
            "{html}"
        );
        assert!(html.contains("200 trials, seed 7."));
        assert!(html.contains("<li>a: first</li>") && html.contains("<li>heat</li>"));
    }
}
