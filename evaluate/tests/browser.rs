//! `report.html` in a real browser (`report::browser`: headless Chromium over
//! the DevTools protocol): a report written from a realistic campaign logs no
//! console errors, exceptions or failed loads, and every plot it should have
//! is laid out at its full size and drawn — enough drawn pixels, enough
//! distinct colours, and the series colours of that kind of plot. (The
//! harness's own test shows it catches errors and blank plots.)
//!
//! Without `chromium` on the PATH (or `TRINOCULAR_CHROMIUM`) the test prints
//! a notice that it is SKIPPED and passes, unless
//! `TRINOCULAR_REQUIRE_BROWSER=1`, when it fails.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use report::browser::{self, PAGE_WIDTH, check_region, rgb};
use report::plot::{DOWN, HEIGHT, MAP_HEIGHT, MEAN, RPY, UP, WIDTH, ZONE, diverging};

/// The series colours a plot of this id must show.
fn colours_of(id: &str) -> Vec<[u8; 3]> {
    if id.ends_with("positioning") {
        vec![rgb(UP), rgb(DOWN)]
    } else if id.contains("straightness") {
        vec![rgb(MEAN), rgb(ZONE), rgb(UP)]
    } else if id.ends_with("angular") {
        RPY.iter().map(|c| rgb(*c)).collect()
    } else {
        // The flatness map: both ends of the diverging scale.
        vec![rgb(diverging(-1.0)), rgb(diverging(1.0))]
    }
}

/// Write `report`'s files into `dir` and show report.html in `chromium`:
/// the page's markup and what the browser drew.
fn shown(
    chromium: &std::path::Path,
    report: &evaluate::Report,
    dir: &std::path::Path,
) -> (String, browser::Rendered) {
    let out = dir.join("report");
    evaluate::write_outputs(report, &out, &mut formats::OutputPlan::new(false), None).unwrap();
    let page = out.join("report.html");
    let shown = browser::render(chromium, &page).unwrap();
    (std::fs::read_to_string(page).unwrap(), shown)
}

/// No console errors, the plots `expected` in order, the page within the
/// window, every plot laid out at its full size and drawn in its colours.
fn check_page(shown: &browser::Rendered, expected: &[String]) {
    assert!(
        shown.errors.is_empty(),
        "console errors: {:#?}",
        shown.errors
    );
    let ids: Vec<&str> = shown.plots.iter().map(|p| p.id.as_str()).collect();
    assert_eq!(ids, expected, "plots on the page");
    assert!(
        shown.width <= PAGE_WIDTH,
        "page {} px wider than the window",
        shown.width
    );
    for p in &shown.plots {
        let full = if p.id == "plot-flatness" {
            MAP_HEIGHT
        } else {
            HEIGHT
        };
        assert_eq!(
            (p.w, p.h),
            (WIDTH, full),
            "{} laid out at {}×{}",
            p.id,
            p.w,
            p.h
        );
        check_region(&shown.screenshot, p, &colours_of(&p.id)).unwrap();
    }
}

/// The plots of an axis: positioning (when it has figures), straightness in
/// each perpendicular direction, angular errors.
fn axis_plots(axis: &str, perp: [&str; 2], positioning: bool) -> Vec<String> {
    let mut ids = Vec::new();
    if positioning {
        ids.push(format!("plot-{axis}-positioning"));
    }
    ids.extend(perp.map(|d| format!("plot-{axis}-straightness-{d}")));
    ids.push(format!("plot-{axis}-angular"));
    ids
}

#[test]
fn report_html_renders_in_chromium() {
    let Some(chromium) = browser::browser_or_skip("evaluate report.html in Chromium").unwrap()
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let rows = common::rows(&common::campaign());
    let report = evaluate::evaluate(
        &rows,
        &evaluate::Options {
            vdi3441: true,
            ..Default::default()
        },
    )
    .unwrap();
    let (_, shown) = shown(&chromium, &report, dir.path());
    let mut expected = Vec::new();
    for (axis, perp) in [("X", ["Y", "Z"]), ("Y", ["X", "Z"])] {
        expected.extend(axis_plots(axis, perp, true));
    }
    expected.push("plot-flatness".into());
    check_page(&shown, &expected);
    if let Ok(keep) = std::env::var("TRINOCULAR_KEEP_SCREENSHOT") {
        shown.screenshot.save(&keep).unwrap();
        eprintln!("screenshot saved to {keep}");
    }
}

/// Every X line measured once each way: the X section says why its
/// positioning is left out where the plot would be, and draws the rest.
#[test]
fn report_html_without_positioning_renders_in_chromium() {
    let Some(chromium) =
        browser::browser_or_skip("evaluate report.html without positioning in Chromium").unwrap()
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut lines = common::campaign();
    for l in &mut lines[..3] {
        l.runs = 1;
    }
    let report = evaluate::evaluate(&common::rows(&lines), &Default::default()).unwrap();
    let reason = report
        .axes
        .x
        .as_ref()
        .unwrap()
        .main
        .positioning
        .left_out
        .clone()
        .unwrap();
    let (html, shown) = shown(&chromium, &report, dir.path());
    let mut expected = axis_plots("X", ["Y", "Z"], false);
    expected.extend(axis_plots("Y", ["X", "Z"], true));
    expected.push("plot-flatness".into());
    check_page(&shown, &expected);
    // In the X section, the summary and the table of the X lines (colspan).
    let escaped = report::escape(&reason);
    let section = &html[html.find("id=\"axis-X\"").unwrap()..html.find("id=\"axis-Y\"").unwrap()];
    assert!(
        section.contains(&format!("<p class=\"warn\">{escaped}</p>")),
        "{section}"
    );
    assert_eq!(section.matches("colspan=\"5\"").count(), 3, "{section}");
    assert!(html.contains(&format!("<td class=\"l warn\">{escaped}</td>")));
}

/// With limits, the page opens with the verdict: drawn in Chromium, the
/// verdict line in the colour of its decision above the summary, and each
/// limited figure with value ± U, its limit and its decision in words.
#[test]
fn the_verdict_table_is_shown_first_in_chromium() {
    use formats::conformance::{Decision, Limit, Rule};
    let Some(chromium) = browser::browser_or_skip("the verdict in Chromium").unwrap() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut report =
        evaluate::evaluate(&common::rows(&common::campaign()), &Default::default()).unwrap();
    let figures =
        formats::uncertainty::figures(&report, &evaluate::uncertainty::FIGURE_KEYS).unwrap();
    // Every figure with U = 10 % of its value (at least 0.1).
    let expanded: std::collections::BTreeMap<String, f64> = figures
        .iter()
        .map(|(k, v)| (k.clone(), (0.1 * v.abs()).max(0.1)))
        .collect();
    report.uncertainty = Some(common::given(Vec::new(), expanded.clone()));
    let limit = |key: &str, factor: f64| {
        let path = format!("axes.X.positioning.{key}");
        Limit {
            axis: Some("X".into()),
            key: key.into(),
            limit: figures[&path] * factor,
            path,
        }
    };
    // E well within, A at its value (inconclusive), R far beyond.
    let limits = [limit("E_um", 2.0), limit("A_um", 1.0), limit("R_um", 0.5)];
    report
        .signoff
        .judge(
            std::path::Path::new("tol.toml"),
            &limits,
            &figures,
            Some(&expanded),
            Rule::Iso14253,
        )
        .unwrap();
    assert_eq!(report.signoff.verdict, Some(Decision::DoesNotConform));
    let (html, shown) = shown(&chromium, &report, dir.path());
    assert!(
        shown.errors.is_empty(),
        "console errors: {:#?}",
        shown.errors
    );
    let verdict_at = html.find("id=\"verdict\"").unwrap();
    assert!(verdict_at < html.find("id=\"summary\"").unwrap());
    for (key, decision) in [
        ("E_um", "conforms"),
        ("A_um", "inconclusive"),
        ("R_um", "does not conform"),
    ] {
        let path = format!("axes.X.positioning.{key}");
        let value = report::plus_minus_in(figures[&path], expanded.get(&path).copied(), 3, "µm");
        let row = format!("<td class=\"l\">{key}</td><td>{value}</td>");
        let at = html.find(&row).unwrap_or_else(|| panic!("no row {row}"));
        assert!(html[at..].split("</tr>").next().unwrap().contains(decision));
    }
    // The verdict's red band is drawn near the top of the page.
    let red = [0xf8, 0xd4, 0xd4];
    let img = &shown.screenshot;
    let band = (0..img.height().min(400))
        .flat_map(|y| (0..img.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| img.get_pixel(x, y).0[..3] == red)
        .count();
    assert!(band > 2000, "verdict band {band} px");
}
