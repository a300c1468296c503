//! `report.html` of `probe tracer` in a real browser (`report::browser`:
//! headless Chromium over the DevTools protocol): the page of the check
//! data's solution logs no console errors, exceptions or failed loads, and
//! its three plots are laid out at full size and drawn — enough drawn
//! pixels, enough colours, and the series colours of each plot.
//!
//! Without `chromium` on the PATH (or `TRINOCULAR_CHROMIUM`) the test prints
//! a notice that it is SKIPPED and passes, unless
//! `TRINOCULAR_REQUIRE_BROWSER=1`, when it fails.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod browser_common;
mod pages;
mod tracer_common;

use report::browser::{self, rgb};
use report::plot::{HEIGHT, MAP_HEIGHT, MEAN, SIX, UP, ZONE, diverging};

#[test]
fn report_html_renders_in_chromium() {
    let Some(chromium) = browser::browser_or_skip("probe tracer report.html in Chromium").unwrap()
    else {
        return;
    };
    // With one gross error, so that the flagged-reading marks are on the page too.
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    std::fs::write(&page, pages::tracer()).unwrap();
    browser_common::check_page(
        &chromium,
        &page,
        &["plot-residuals", "plot-corrections", "plot-uncertainty"],
        |id| match id {
            // Six stations, each in its own colour, and the flag limit.
            "plot-residuals" => (
                HEIGHT,
                SIX.iter().map(|c| rgb(*c)).chain([rgb(ZONE)]).collect(),
            ),
            "plot-corrections" => (MAP_HEIGHT, vec![rgb(UP), rgb(MEAN)]),
            _ => (MAP_HEIGHT, vec![rgb(diverging(-1.0)), rgb(diverging(1.0))]),
        },
    );
}
