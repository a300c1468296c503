//! The rotary `report.html` in a real browser (`report::browser`: headless
//! Chromium over the DevTools protocol): a report of the check data's
//! probed points, with interpolated angles, logs no console errors,
//! exceptions or failed loads, and every plot it should have is laid out at
//! its full size and drawn — enough drawn pixels, enough distinct colours,
//! and the series colours of that plot.
//!
//! Without `chromium` on the PATH (or `TRINOCULAR_CHROMIUM`) the test prints
//! a notice that it is SKIPPED and passes, unless
//! `TRINOCULAR_REQUIRE_BROWSER=1`, when it fails.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod browser_common;
mod pages;
mod tracer_common;

use report::browser::{self, rgb};
use report::plot::{DOWN, HEIGHT, MAP_HEIGHT, MEAN, SIX, ZONE};

/// The series colours a plot of this id must show.
fn colours_of(id: &str) -> Vec<[u8; 3]> {
    if id.ends_with("translations") {
        SIX[..3].iter().map(|c| rgb(*c)).collect()
    } else if id.ends_with("rotations") {
        SIX[3..].iter().map(|c| rgb(*c)).collect()
    } else {
        // Paths of a pair of errors: measured path, fixed-axis circle, location.
        vec![rgb(MEAN), rgb(ZONE), rgb(DOWN)]
    }
}

#[test]
fn rotary_report_html_renders_in_chromium() {
    let Some(chromium) = browser::browser_or_skip("rotary report.html in Chromium").unwrap() else {
        return;
    };
    let page = pages::rotary();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("report.html");
    std::fs::write(&file, &page).unwrap();
    // Self-contained: no scripts, no external resources (the SVG namespace is a name, not a load).
    for bad in ["<script", "<link", "src=\"", "href=\"http", "url("] {
        assert!(!page.contains(bad), "page has {bad}");
    }

    browser_common::check_page(
        &chromium,
        &file,
        &[
            "plot-errors-translations",
            "plot-errors-rotations",
            "plot-location-offset",
            "plot-location-tilt",
            "plot-components-translations",
            "plot-components-rotations",
        ],
        |id| {
            let full = if id.starts_with("plot-location") {
                MAP_HEIGHT
            } else {
                HEIGHT
            };
            (full, colours_of(id))
        },
    );
    for table in [
        "location",
        "ranges",
        "errors",
        "components",
        "interpolated",
        "layout",
        "sphere-fits",
    ] {
        assert!(
            page.contains(&format!("<table id=\"{table}\">")),
            "table {table} missing"
        );
    }
}
