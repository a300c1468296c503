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
    let out = dir.path().join("report");
    evaluate::write_outputs(&report, &out, &mut formats::OutputPlan::new(false)).unwrap();
    let shown = browser::render(&chromium, &out.join("report.html")).unwrap();
    assert!(
        shown.errors.is_empty(),
        "console errors: {:#?}",
        shown.errors
    );
    let ids: Vec<&str> = shown.plots.iter().map(|p| p.id.as_str()).collect();
    let mut expected = Vec::new();
    for (axis, perp) in [("X", ["Y", "Z"]), ("Y", ["X", "Z"])] {
        expected.push(format!("plot-{axis}-positioning"));
        expected.extend(perp.map(|d| format!("plot-{axis}-straightness-{d}")));
        expected.push(format!("plot-{axis}-angular"));
    }
    expected.push("plot-flatness".into());
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
    if let Ok(keep) = std::env::var("TRINOCULAR_KEEP_SCREENSHOT") {
        shown.screenshot.save(&keep).unwrap();
        eprintln!("screenshot saved to {keep}");
    }
}
