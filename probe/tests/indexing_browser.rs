//! The indexing `report.html` in a real browser (`report::browser`, headless
//! Chromium): a report of the generator's PH10 with a tolerance logs no
//! console errors, exceptions or failed loads, and its four plots — the
//! ΔθA and ΔθB maps and curves — are laid out at full size and drawn, with
//! the colours of their series (both ends of the diverging scale on a map;
//! the positions, the detent means and the tolerance on a curve).
//!
//! Without `chromium` on the PATH (or `TRINOCULAR_CHROMIUM`) the test prints
//! a notice that it is SKIPPED and passes, unless
//! `TRINOCULAR_REQUIRE_BROWSER=1`, when it fails.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod browser_common;
mod pages;
mod tracer_common;

use report::browser::{self, rgb};
use report::plot::{DOWN, HEIGHT, MAP_HEIGHT, MEAN, UP, diverging};

#[test]
fn indexing_report_renders_in_chromium() {
    let Some(chromium) =
        browser::browser_or_skip("probe indexing report.html in Chromium").unwrap()
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    std::fs::write(&page, pages::indexing(&pages::indexing_positions())).unwrap();
    browser_common::check_page(
        &chromium,
        &page,
        &[
            "plot-map-dA",
            "plot-map-dB",
            "plot-curve-dA",
            "plot-curve-dB",
        ],
        |id| {
            if id.starts_with("plot-map") {
                (MAP_HEIGHT, vec![rgb(diverging(-1.0)), rgb(diverging(1.0))])
            } else {
                (HEIGHT, vec![rgb(UP), rgb(MEAN), rgb(DOWN)])
            }
        },
    );
}
