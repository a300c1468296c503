//! What `report.html` says in words (issue 39): the budget's figures named
//! as the summary names them, figures the data cannot give left out with the
//! reason, units in the per-target tables, the correction to 20 °C near the
//! results.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::collections::BTreeMap;

use formats::uncertainty::BudgetEntry;
use formats::{Axis, Direction, InstantKey, PointRow};

/// The page `write_outputs` writes for `report`.
fn page(report: &evaluate::Report) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    evaluate::write_outputs(report, &out, &mut formats::OutputPlan::new(false), None).unwrap();
    std::fs::read_to_string(out.join("report.html")).unwrap()
}

/// The common campaign's report.
fn campaign_report() -> evaluate::Report {
    evaluate::evaluate(&common::rows(&common::campaign()), &Default::default()).unwrap()
}

/// The part of `html` from the element with `id` to the end of its table.
fn table<'a>(html: &'a str, id: &str) -> &'a str {
    let at = html
        .find(&format!("id=\"{id}\""))
        .unwrap_or_else(|| panic!("no #{id}"));
    let end = at + html[at..].find("</table>").unwrap();
    &html[at..end]
}

#[test]
fn the_budget_names_its_figures_as_the_summary_does() {
    let mut report = campaign_report();
    let entry = |figure: &str, value: f64| BudgetEntry {
        figure: figure.into(),
        value,
        expanded: 0.29,
        contributions: BTreeMap::from([("centroids".to_string(), 0.1)]),
    };
    report.uncertainty = Some(common::given(
        vec![
            entry("axes.X.positioning.A_down_um", 7.894),
            entry("axes.X.straightness.Y.min_zone_um", 1.0),
            entry("axes.Y.angular.roll_urad", 3.0),
            entry("flatness.lsq_um", 2.0),
        ],
        BTreeMap::new(),
    ));
    let html = page(&report);
    let budget = table(&html, "budget");
    for label in [
        "X, A↓, µm",
        "X, straightness in Y (min zone), µm",
        "Y, roll range, µrad",
        "flatness (LSQ), µm",
    ] {
        assert!(
            budget.contains(&format!("<td class=\"l\">{label}</td>")),
            "no {label} in {budget}"
        );
    }
    assert!(!budget.contains("axes."), "a JSON path in {budget}");
    assert!(!budget.contains("flatness.lsq_um"), "{budget}");
    // The summary names A↓ the same way.
    assert!(table(&html, "summary").contains("<td class=\"l\">A↓ — unidirectional accuracy</td>"));
}

/// An X line of `targets` targets 50 mm apart, two runs each way, bowed
/// 2 µm in y and z at its middle targets.
fn x_line(targets: u32) -> Vec<formats::PointRow> {
    let mut rows = Vec::new();
    for target in 0..targets {
        let nominal = 50.0 * f64::from(target);
        let bow = if target == 0 || target + 1 == targets {
            0.0
        } else {
            0.002
        };
        for direction in [Direction::Up, Direction::Down] {
            for run in 1..=2 {
                rows.push(PointRow::new(
                    InstantKey::new((Axis::X, direction), [run, target, 1], [nominal, 0.0, 0.0]),
                    "A",
                    [nominal + 1e-4 * f64::from(run), bow, -bow],
                    "2+3",
                    0.0,
                ));
            }
        }
    }
    rows
}

/// A line of two targets has no straightness (the reference line passes
/// through both points: 0 µm by construction): left out with the reason, in
/// report.json, its warnings and on the page; three targets give it.
#[test]
fn two_target_straightness_is_left_out_with_the_reason() {
    let report = evaluate::evaluate(&x_line(2), &Default::default()).unwrap();
    let x = &report.axes.x.as_ref().unwrap().main;
    assert!(x.straightness.is_empty(), "{:?}", x.straightness);
    let reason = x.straightness_left_out.as_deref().unwrap();
    assert!(
        reason.contains("straightness left out") && reason.contains("2 targets"),
        "{reason}"
    );
    assert!(
        report.warnings.iter().any(|w| w.ends_with(reason)),
        "{:?}",
        report.warnings
    );
    let json = serde_json::to_value(&report).unwrap();
    let line_json = &json["axes"]["X"];
    assert_eq!(line_json["straightness"], serde_json::json!({}));
    assert_eq!(line_json["straightness_left_out"], reason);
    let html = page(&report);
    assert!(html.contains(&format!("<p class=\"warn\">{}</p>", report::escape(reason))));
    assert!(
        !html.contains("plot-X-straightness"),
        "a straightness plot of 2 targets"
    );

    let report = evaluate::evaluate(&x_line(3), &Default::default()).unwrap();
    let x = &report.axes.x.as_ref().unwrap().main;
    assert_eq!(x.straightness.keys().collect::<Vec<_>>(), ["Y", "Z"]);
    assert_eq!(x.straightness_left_out, None);
    // 2 µm off the chord at the middle of three: a 2 µm minimum zone.
    assert!(
        (x.straightness["Y"].min_zone_um - 2.0).abs() < 1e-6,
        "{:?}",
        x.straightness["Y"]
    );
    assert!(!report.warnings.iter().any(|w| w.contains("straightness")));
}

/// The per-target tables give their units in the column headers.
#[test]
fn per_target_tables_carry_units() {
    let html = page(&campaign_report());
    for header in [
        "<th>x̄↑ (µm)</th>",
        "<th>s↓ (µm)</th>",
        "<th>R (µm)</th>",
        "<th>A (µm)</th>",
        "<th>straightness Y LSQ / MZ (µm)</th>",
    ] {
        assert!(html.contains(header), "no {header}");
    }
    assert!(!html.contains("<th>x̄↑</th>") && !html.contains("<th>B</th>"));
}

/// A report corrected to 20 °C says so under the summary, not only among
/// the conventions at the page's foot.
#[test]
fn the_correction_to_20_c_is_said_beside_the_results() {
    let mut report = campaign_report();
    assert!(!page(&report).contains("id=\"correction\""));
    report.correction = Some("positioning deviations corrected to 20 °C".into());
    let html = page(&report);
    let said = html
        .find("<p class=\"meta\" id=\"correction\">Conditions applied: positioning deviations corrected to 20 °C</p>")
        .expect("no correction on the page");
    assert!(said < html.find("id=\"summary\"").unwrap());
}

/// Figures with U on the page: the value to U's last digit (GUM 7.2.6),
/// the unit right after the number in the plots' titles.
#[test]
fn figures_are_rounded_to_their_uncertainty() {
    let mut report = campaign_report();
    let figures =
        formats::uncertainty::figures(&report, &evaluate::uncertainty::FIGURE_KEYS).unwrap();
    let expanded: BTreeMap<String, f64> = figures.keys().map(|k| (k.clone(), 2.9)).collect();
    let a = figures["axes.X.positioning.A_um"];
    let lsq = figures["axes.X.straightness.Y.lsq_um"];
    report.uncertainty = Some(common::given(Vec::new(), expanded));
    let html = page(&report);
    let summary = table(&html, "summary");
    assert!(summary.contains(&format!("<td>{a:.1} ± 2.9")), "{summary}");
    assert!(!summary.contains(&format!("{a:.3} ±")), "{summary}");
    let title = format!("LSQ {lsq:.1} ± 2.9 µm");
    assert!(html.contains(&title), "no {title}");
}
