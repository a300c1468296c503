//! What the coverage tests of the probe methods share: a campaign's
//! deterministic numbers, the tally of figures within ± U per figure type
//! with the acceptance (90–99 % of all, ≥ 85 % per type, median U
//! ≤ 3 × RMS of the actual errors), and the check that `report.json` keeps
//! every key and value of the report.

#![allow(dead_code)]

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

/// Per figure type: the figures within ± U, the errors and the U.
#[derive(Debug, Default)]
pub struct Tally(BTreeMap<String, (usize, Vec<f64>, Vec<f64>)>);

impl Tally {
    /// One figure at `path`: measured `value`, `truth`, `expanded` U.
    pub fn add(&mut self, path: &str, value: f64, truth: f64, expanded: f64) {
        let e = self.0.entry(figure_type(path)).or_default();
        e.0 += usize::from((value - truth).abs() <= expanded);
        e.1.push(value - truth);
        e.2.push(expanded);
    }

    /// Print the coverage per type and of all figures, and hold the
    /// issue's acceptance.
    pub fn check(mut self, campaigns: u64) {
        let (mut inside, mut all) = (0, 0);
        let mut failures = Vec::new();
        println!("figure type: coverage (inside/figures), median U / RMS error");
        for (kind, (ok, errors, us)) in &mut self.0 {
            let n = errors.len();
            inside += *ok;
            all += n;
            let rms = (errors.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt();
            us.sort_by(f64::total_cmp);
            let median = us[us.len() / 2];
            let coverage = *ok as f64 / n as f64;
            println!(
                "{kind:28} {:5.1} % ({ok}/{n}), median U {median:.4} / RMS {rms:.4} = {:.2}",
                100.0 * coverage,
                median / rms
            );
            if coverage < 0.85 {
                failures.push(format!("{kind}: coverage {:.1} %", 100.0 * coverage));
            }
            if median > 3.0 * rms {
                failures.push(format!("{kind}: median U {median} > 3 × RMS {rms}"));
            }
        }
        let total = inside as f64 / all as f64;
        println!(
            "all figures: {:.1} % ({inside}/{all}) over {campaigns} campaigns",
            100.0 * total
        );
        assert!((0.90..=0.99).contains(&total), "coverage {total}");
        assert!(failures.is_empty(), "{failures:#?}");
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
