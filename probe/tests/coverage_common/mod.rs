//! What the coverage tests of the probe methods share: the check of
//! docs/methods.md §7 on a method's generator (over many campaigns with
//! known truth, the true figure lies in value ± U for 90–99 % of all figures
//! and for ≥ 85 % of each figure type, and U is not inflated: per type the
//! median U is at most 3× the RMS of the actual errors, value − truth), a
//! campaign's deterministic numbers, and the check that `report.json` keeps
//! every key and value of the report.

#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use std::collections::BTreeMap;

/// A number in [0, 1) from a campaign and a slot (deterministic).
pub fn unit(campaign: u64, slot: u64) -> f64 {
    let mut z = campaign
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .wrapping_add(slot.wrapping_mul(0xbf58_476d_1ce4_e5b9));
    z = (z ^ (z >> 31)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 29;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// The figure's type: its path without the row indices (`errors.EXC_um`).
pub fn figure_type(path: &str) -> String {
    path.split('.')
        .filter(|p| p.parse::<usize>().is_err())
        .collect::<Vec<_>>()
        .join(".")
}

/// One figure of one campaign: its type, the truth, the measured value and U.
#[derive(Debug, Clone)]
pub struct Case {
    /// Figure type (the report's key without indices).
    pub figure: String,
    /// True value (from the generator's truth).
    pub truth: f64,
    /// Measured value.
    pub value: f64,
    /// Expanded uncertainty (k = 2).
    pub u: f64,
}

impl Case {
    /// The figure at `path` (its type by [`figure_type`]).
    pub fn at(path: &str, truth: f64, value: f64, u: f64) -> Case {
        Case {
            figure: figure_type(path),
            truth,
            value,
            u,
        }
    }

    fn covered(&self) -> bool {
        (self.value - self.truth).abs() <= self.u
    }
}

/// Per figure type: count, coverage, median U, RMS of the actual errors.
#[derive(Debug, Clone, Copy)]
pub struct TypeCoverage {
    /// Figures of the type.
    pub count: usize,
    /// Share with the truth inside value ± U.
    pub coverage: f64,
    /// Median U.
    pub median_u: f64,
    /// RMS of value − truth.
    pub rms_error: f64,
}

/// The coverage of `cases` per type and over all, printed as a table.
pub fn summarise(method: &str, cases: &[Case]) -> (f64, BTreeMap<String, TypeCoverage>) {
    let mut by_type: BTreeMap<String, Vec<&Case>> = BTreeMap::new();
    for c in cases {
        by_type.entry(c.figure.clone()).or_default().push(c);
    }
    let per_type: BTreeMap<String, TypeCoverage> = by_type
        .iter()
        .map(|(name, cs)| {
            let mut us: Vec<f64> = cs.iter().map(|c| c.u).collect();
            us.sort_by(f64::total_cmp);
            let n = cs.len();
            let median_u = if n % 2 == 1 {
                us[n / 2]
            } else {
                0.5 * (us[n / 2 - 1] + us[n / 2])
            };
            let rms_error =
                (cs.iter().map(|c| (c.value - c.truth).powi(2)).sum::<f64>() / n as f64).sqrt();
            let covered = cs.iter().filter(|c| c.covered()).count();
            (
                name.clone(),
                TypeCoverage {
                    count: n,
                    coverage: covered as f64 / n as f64,
                    median_u,
                    rms_error,
                },
            )
        })
        .collect();
    let all = cases.iter().filter(|c| c.covered()).count() as f64 / cases.len() as f64;
    println!(
        "{method}: coverage over {} figures {:.1} %",
        cases.len(),
        100.0 * all
    );
    println!(
        "{:<48} {:>5} {:>9} {:>10} {:>10} {:>8}",
        "figure", "n", "coverage", "median U", "RMS error", "ratio"
    );
    for (name, t) in &per_type {
        println!(
            "{name:<48} {:>5} {:>8.1}% {:>10.4} {:>10.4} {:>8.2}",
            t.count,
            100.0 * t.coverage,
            t.median_u,
            t.rms_error,
            t.median_u / t.rms_error
        );
    }
    (all, per_type)
}

/// Assert the criteria of §7 on `cases`.
pub fn assert_coverage(method: &str, cases: &[Case]) {
    let (all, per_type) = summarise(method, cases);
    assert!(
        (0.90..=0.99).contains(&all),
        "{method}: overall coverage {all}"
    );
    for (name, t) in &per_type {
        assert!(
            t.coverage >= 0.85,
            "{method}: {name} covered {}",
            t.coverage
        );
        assert!(
            t.median_u <= 3.0 * t.rms_error,
            "{method}: {name}: median U {} > 3 × RMS error {}",
            t.median_u,
            t.rms_error
        );
    }
}

/// Every key of `plain` is in `annotated` with the same value.
pub fn assert_unchanged(plain: &serde_json::Value, annotated: &serde_json::Value, path: &str) {
    match (plain, annotated) {
        (serde_json::Value::Object(a), serde_json::Value::Object(b)) => {
            for (k, v) in a {
                let w = b.get(k).unwrap_or_else(|| panic!("{path}.{k} missing"));
                assert_unchanged(v, w, &format!("{path}.{k}"));
            }
        }
        (serde_json::Value::Array(a), serde_json::Value::Array(b)) => {
            assert_eq!(a.len(), b.len(), "{path}");
            for (i, (v, w)) in a.iter().zip(b).enumerate() {
                assert_unchanged(v, w, &format!("{path}.{i}"));
            }
        }
        _ => assert_eq!(plain, annotated, "{path}"),
    }
}
