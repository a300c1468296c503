//! Conformance with a tolerance (ISO 14253-1:2017): the tolerance file
//! (`--tolerances tol.toml`, docs/formats.md), the decision for each figure
//! against its upper limit with its expanded uncertainty, and the verdict.
//!
//! Every figure judged here is a one-sided, upper-limited figure (an
//! accuracy, a range, a zone): ISO 14253-1 §5.2 proves conformity when the
//! value plus U is within the limit, §5.3 non-conformity when the value
//! minus U is beyond it, and between the two no decision can be proven
//! (inconclusive). The simple, shared-risk rule (ISO 14253-1 §6, ILAC-G8
//! "simple acceptance") compares the value alone. A signed figure (a
//! location error, a deviation from a nominal) is judged by its magnitude:
//! its limit L is the symmetric specification −L … +L, for which the same
//! rule reads |value| + U ≤ L.
//!
//! [`SignOff`] is what a signed report adds to its figures: the test
//! conditions, the rule, the decisions and the verdict; every report that
//! takes `--conditions`/`--tolerances` (evaluate and each probe method)
//! carries it flattened into its `report.json`.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::conditions::Conditions;
use crate::{FormatError, Result};

/// The decision rule (`--decision-rule`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rule {
    /// ISO 14253-1 with the expanded uncertainty as guard band.
    Iso14253,
    /// Shared risk: the value against the limit.
    Simple,
}

impl Rule {
    /// The rule as the report states it.
    pub fn describe(self) -> &'static str {
        match self {
            Rule::Iso14253 => {
                "ISO 14253-1: conforms when value + U ≤ limit, does not conform when value − U > limit, \
                 otherwise inconclusive (U expanded, k = 2)"
            }
            Rule::Simple => "simple acceptance (shared risk): conforms when value ≤ limit",
        }
    }
}

/// The decision on one figure, or the verdict on all.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
pub enum Decision {
    /// Proven within the limit.
    #[serde(rename = "conforms")]
    Conforms,
    /// Neither proven within nor beyond.
    #[serde(rename = "inconclusive")]
    Inconclusive,
    /// Proven beyond the limit.
    #[serde(rename = "does not conform")]
    DoesNotConform,
}

impl Decision {
    /// The words on the report.
    pub fn words(self) -> &'static str {
        match self {
            Decision::Conforms => "conforms",
            Decision::Inconclusive => "inconclusive",
            Decision::DoesNotConform => "does not conform",
        }
    }
}

/// The decision on `value` with expanded uncertainty `u` against the upper
/// `limit` under `rule`. Under ISO 14253-1 a figure without U is decided
/// as by the simple rule (the report says that U was not available).
pub fn decide(value: f64, u: Option<f64>, limit: f64, rule: Rule) -> Decision {
    match (rule, u) {
        (Rule::Iso14253, Some(u)) if value + u <= limit => Decision::Conforms,
        (Rule::Iso14253, Some(u)) if value - u > limit => Decision::DoesNotConform,
        (Rule::Iso14253, Some(_)) => Decision::Inconclusive,
        _ if value <= limit => Decision::Conforms,
        _ => Decision::DoesNotConform,
    }
}

/// One limit of the tolerance file: its table (an axis, or none for the
/// top level), key, the report figure it limits and the limit.
#[derive(Debug, Clone, PartialEq)]
pub struct Limit {
    /// `X`, `Y`, `Z`, or `None` at the top level.
    pub axis: Option<String>,
    /// The key (`A_um`).
    pub key: String,
    /// The figure's path in the report (`axes.X.positioning.A_um`).
    pub path: String,
    /// The upper limit, in the figure's unit.
    pub limit: f64,
}

/// A figure judged: the `conformance` entries of `report.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Judged {
    /// The axis (absent at the top level).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axis: Option<String>,
    /// The tolerance file's key.
    pub figure: String,
    /// The figure's value.
    pub value: f64,
    /// Its expanded uncertainty (k = 2), when given.
    #[serde(rename = "U")]
    pub expanded: Option<f64>,
    /// The limit.
    pub limit: f64,
    /// The decision.
    pub decision: Decision,
}

/// The overall verdict: the worst decision (none conforms when one does
/// not; inconclusive when one is and none fails); `None` without figures.
pub fn verdict(judged: &[Judged]) -> Option<Decision> {
    judged.iter().map(|j| j.decision).max()
}

/// What a report's tolerance file may hold: its tables (`[X]`, or a
/// report object's dotted path `[location]`, `[compensated.circle]`), the
/// report path each key limits (`figure(table, key)`, `None` for an unknown
/// key) and, for errors, the keys in words.
#[derive(Clone, Copy)]
pub struct Keys<'a> {
    /// The tables a file may have (dotted for nested tables).
    pub tables: &'a [&'a str],
    /// The figure a key limits.
    pub figure: &'a dyn Fn(Option<&str>, &str) -> Option<String>,
    /// Every key, in words.
    pub names: &'a str,
}

/// Read the tolerance file `path`: top-level keys and tables of numbers
/// (nested tables by their dotted name), each key one of `keys`.
pub fn read_tolerances(path: &Path, keys: Keys<'_>) -> Result<Vec<Limit>> {
    let Keys {
        tables,
        figure: known,
        names,
    } = keys;
    let bad = |message: String| FormatError::File {
        path: path.to_path_buf(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?;
    let table: toml::Table = toml::from_str(&text)
        .map_err(|e| bad(format!("not a tolerance file: {}", e.to_string().trim())))?;
    let mut limits = Vec::new();
    let mut add = |axis: Option<&str>, key: &str, value: &toml::Value| -> Result<()> {
        let name = match axis {
            Some(a) => format!("[{a}] {key}"),
            None => key.to_string(),
        };
        let figure = known(axis, key)
            .ok_or_else(|| bad(format!("{name}: not a figure with a limit; known: {names}")))?;
        let limit = match value {
            toml::Value::Float(f) => *f,
            toml::Value::Integer(i) => *i as f64,
            other => return Err(bad(format!("{name}: {other} is not a number"))),
        };
        if !(limit.is_finite() && limit >= 0.0) {
            return Err(bad(format!(
                "{name}: the limit {limit} is not a finite value ≥ 0"
            )));
        }
        limits.push(Limit {
            axis: axis.map(str::to_string),
            key: key.to_string(),
            path: figure,
            limit,
        });
        Ok(())
    };
    // Depth first through the tables, in the file's key order.
    let mut pending: Vec<(Option<String>, &toml::Table)> = vec![(None, &table)];
    while let Some((prefix, table)) = pending.pop() {
        let mut nested = Vec::new();
        for (key, value) in table {
            match value {
                toml::Value::Table(t) => {
                    let name = match &prefix {
                        Some(p) => format!("{p}.{key}"),
                        None => key.clone(),
                    };
                    if !tables.contains(&name.as_str()) {
                        return Err(bad(format!(
                            "[{name}]: not a table of figures with limits; known: {names}"
                        )));
                    }
                    nested.push((Some(name), t));
                }
                v => add(prefix.as_deref(), key, v)?,
            }
        }
        pending.extend(nested.into_iter().rev());
    }
    Ok(limits)
}

/// Read the tolerance file `path` of a report whose limits name its
/// figures by their paths (the probe methods): a figure `a.b.F_um` is the
/// key `F_um` of table `[a.b]`, a top-level figure a top-level key. Figures
/// inside arrays (per-position tables) take no limit.
pub fn read_tolerances_by_path(path: &Path, figures: &BTreeMap<String, f64>) -> Result<Vec<Limit>> {
    let signed_off: Vec<&str> = figures
        .keys()
        .map(String::as_str)
        .filter(|p| !p.split('.').any(|s| s.parse::<usize>().is_ok()))
        .collect();
    let mut by_table: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for p in &signed_off {
        let (table, key) = p.rsplit_once('.').unwrap_or(("", p));
        by_table.entry(table).or_default().push(key);
    }
    // Every table and the tables above it ([a] holds [a.b]).
    let tables: Vec<&str> = by_table
        .keys()
        .filter(|t| !t.is_empty())
        .flat_map(|t| t.match_indices('.').map(|(i, _)| &t[..i]).chain([*t]))
        .collect();
    let names = by_table
        .iter()
        .map(|(table, keys)| match *table {
            "" => format!("top level {}", keys.join(", ")),
            t => format!("[{t}] {}", keys.join(", ")),
        })
        .collect::<Vec<_>>()
        .join("; ");
    let names = if names.is_empty() {
        "none (this report has no figure that takes a limit)".to_string()
    } else {
        names
    };
    let figure = |table: Option<&str>, key: &str| {
        let path = match table {
            Some(t) => format!("{t}.{key}"),
            None => key.to_string(),
        };
        signed_off.contains(&path.as_str()).then_some(path)
    };
    read_tolerances(
        path,
        Keys {
            tables: &tables,
            figure: &figure,
            names: &names,
        },
    )
}

/// Judge each limit's figure in `figures` (value by path) with its U from
/// `expanded` (by path) under `rule`, a signed value by its magnitude; a
/// limit whose figure the report does not have is an error naming the file
/// and key.
pub fn judge(
    path: &Path,
    limits: &[Limit],
    figures: &BTreeMap<String, f64>,
    expanded: Option<&BTreeMap<String, f64>>,
    rule: Rule,
) -> Result<Vec<Judged>> {
    limits
        .iter()
        .map(|l| {
            let value = *figures.get(&l.path).ok_or_else(|| FormatError::File {
                path: path.to_path_buf(),
                message: format!(
                    "{}{}: the report has no such figure ({}): was it measured?",
                    l.axis
                        .as_ref()
                        .map(|a| format!("[{a}] "))
                        .unwrap_or_default(),
                    l.key,
                    l.path
                ),
            })?;
            let u = expanded.and_then(|e| e.get(&l.path).copied());
            Ok(Judged {
                axis: l.axis.clone(),
                figure: l.key.clone(),
                value,
                expanded: u,
                limit: l.limit,
                decision: decide(value.abs(), u, l.limit, rule),
            })
        })
        .collect()
}

/// What a signed report adds to its figures (`report.json`, flattened):
/// the test conditions given and, with a tolerance file, the decision rule
/// in words, each limited figure's decision and the verdict.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SignOff {
    /// The test conditions given (`--conditions`), as read.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conditions: Option<Conditions>,
    /// The decision rule of `conformance` (`--tolerances`), in words.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decision_rule: Option<String>,
    /// Each limited figure's decision (`--tolerances`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conformance: Option<Vec<Judged>>,
    /// The overall verdict: the worst decision.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verdict: Option<Decision>,
}

impl SignOff {
    /// Judge the `limits` of tolerance file `path` on the report's
    /// `figures` with their U (`expanded`) under `rule`: fills the rule,
    /// the decisions and the verdict.
    pub fn judge(
        &mut self,
        path: &Path,
        limits: &[Limit],
        figures: &BTreeMap<String, f64>,
        expanded: Option<&BTreeMap<String, f64>>,
        rule: Rule,
    ) -> Result<()> {
        let judged = judge(path, limits, figures, expanded, rule)?;
        let without_u = rule == Rule::Iso14253 && judged.iter().any(|j| j.expanded.is_none());
        self.decision_rule = Some(if without_u {
            format!(
                "{}; figures without U (no uncertainty given) decided by their value alone",
                rule.describe()
            )
        } else {
            rule.describe().to_string()
        });
        self.verdict = verdict(&judged);
        self.conformance = Some(judged);
        Ok(())
    }

    /// Whether a figure was proven beyond its limit.
    pub fn fails(&self) -> bool {
        self.verdict == Some(Decision::DoesNotConform)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each boundary of ISO 14253-1 from both sides, and the simple rule.
    #[test]
    fn decisions_follow_the_rule_on_each_side_of_each_boundary() {
        use Decision::*;
        let (limit, u, e) = (10.0, 1.0, 1e-9);
        let iso = |v: f64, u: Option<f64>| decide(v, u, limit, Rule::Iso14253);
        // value + U against the limit: conformance proven up to it.
        assert_eq!(iso(9.0 - e, Some(u)), Conforms);
        assert_eq!(iso(9.0, Some(u)), Conforms);
        assert_eq!(iso(9.0 + e, Some(u)), Inconclusive);
        // value itself at the limit: inconclusive either side.
        assert_eq!(iso(10.0 - e, Some(u)), Inconclusive);
        assert_eq!(iso(10.0 + e, Some(u)), Inconclusive);
        // value − U against the limit: non-conformance proven beyond it.
        assert_eq!(iso(11.0 - e, Some(u)), Inconclusive);
        assert_eq!(iso(11.0, Some(u)), Inconclusive);
        assert_eq!(iso(11.0 + e, Some(u)), DoesNotConform);
        // U = 0: the two boundaries meet at the limit.
        assert_eq!(iso(10.0, Some(0.0)), Conforms);
        assert_eq!(iso(10.0 + e, Some(0.0)), DoesNotConform);
        // No U: decided by the value (said so on the report).
        assert_eq!(iso(10.0, None), Conforms);
        assert_eq!(iso(10.0 + e, None), DoesNotConform);
        // Simple rule: U does not enter.
        let simple = |v: f64| decide(v, Some(u), limit, Rule::Simple);
        assert_eq!(simple(10.0 - e), Conforms);
        assert_eq!(simple(10.0), Conforms);
        assert_eq!(simple(10.0 + e), DoesNotConform);
    }

    /// A tolerance file in `dir` with `text`.
    fn file(dir: &tempfile::TempDir, text: &str) -> std::path::PathBuf {
        let p = dir.path().join("tol.toml");
        std::fs::write(&p, text).unwrap();
        p
    }

    /// Probe reports' keys are their figures' paths: nested tables by
    /// their dotted names, array entries not limited, unknown keys and
    /// tables refused with the known ones listed.
    #[test]
    fn tolerances_by_path_name_figures_in_nested_tables() {
        let figures: BTreeMap<String, f64> = [
            ("max_dA_arcsec", 3.0),
            ("location.X0C_um", -4.0),
            ("ranges.errors.EXC_um", 2.0),
            ("errors.0.EXC_um", 1.0),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
        let dir = tempfile::tempdir().unwrap();
        let text = "max_dA_arcsec = 5\n[location]\nX0C_um = 3.5\n[ranges.errors]\nEXC_um = 2.5\n";
        let limits = read_tolerances_by_path(&file(&dir, text), &figures).unwrap();
        let paths: Vec<(&str, f64)> = limits.iter().map(|l| (l.path.as_str(), l.limit)).collect();
        assert_eq!(
            paths,
            [
                ("max_dA_arcsec", 5.0),
                ("location.X0C_um", 3.5),
                ("ranges.errors.EXC_um", 2.5)
            ]
        );
        // A signed figure is judged by its magnitude: |−4| > 3.5.
        let judged = judge(Path::new("t"), &limits, &figures, None, Rule::Simple).unwrap();
        assert_eq!(judged[1].value, -4.0);
        assert_eq!(judged[1].decision, Decision::DoesNotConform);
        for bad in [
            "[errors.0]\nEXC_um = 1\n",
            "[location]\nEXC_um = 1\n",
            "[nowhere]\nEXC_um = 1\n",
            "X0C_um = 1\n",
        ] {
            let e = read_tolerances_by_path(&file(&dir, bad), &figures)
                .unwrap_err()
                .to_string();
            assert!(e.contains("tol.toml"), "{e}");
            assert!(
                e.contains(
                    "known: top level max_dA_arcsec; [location] X0C_um; [ranges.errors] EXC_um"
                ),
                "{e}"
            );
        }
    }

    #[test]
    fn the_verdict_is_the_worst_decision() {
        let j = |d| Judged {
            axis: None,
            figure: "f".into(),
            value: 1.0,
            expanded: None,
            limit: 1.0,
            decision: d,
        };
        use Decision::*;
        assert_eq!(verdict(&[]), None);
        assert_eq!(verdict(&[j(Conforms), j(Conforms)]), Some(Conforms));
        assert_eq!(verdict(&[j(Conforms), j(Inconclusive)]), Some(Inconclusive));
        assert_eq!(
            verdict(&[j(DoesNotConform), j(Inconclusive), j(Conforms)]),
            Some(DoesNotConform)
        );
    }
}
