//! The volumetric `report.html` in a real browser (`report::browser`:
//! headless Chromium): a report of the check data with a circle and
//! volumetric points logs no console errors, and every plot — the polar
//! circle, the radial deviation, the eighteen curves — is laid out at its
//! full size and drawn, with its series colours.
//!
//! Without `chromium` on the PATH (or `TRINOCULAR_CHROMIUM`) the test prints
//! a notice that it is SKIPPED and passes, unless
//! `TRINOCULAR_REQUIRE_BROWSER=1`, when it fails.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod browser_common;
mod pages;
mod tracer_common;

use probe::volumetric::Motion;
use report::browser::{self, rgb};
use report::plot::{DOWN, HEIGHT, MAP_HEIGHT, MEAN, UP, ZONE};

#[test]
fn report_html_renders_in_chromium() {
    let Some(chromium) = browser::browser_or_skip("volumetric report.html in Chromium").unwrap()
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    std::fs::write(&page, pages::volumetric()).unwrap();
    let mut expected = vec![
        "plot-circle-polar".to_string(),
        "plot-circle-radial".to_string(),
    ];
    for axis in ["X", "Y", "Z"] {
        expected.extend(
            Motion::ALL
                .iter()
                .map(|m| format!("plot-{axis}-{}", m.name())),
        );
    }
    let ids: Vec<&str> = expected.iter().map(String::as_str).collect();
    browser_common::check_page(&chromium, &page, &ids, |id| match id {
        "plot-circle-polar" => (MAP_HEIGHT, vec![rgb(UP), rgb(ZONE), rgb(DOWN)]),
        "plot-circle-radial" => (HEIGHT, vec![rgb(UP), rgb(ZONE), rgb(DOWN)]),
        _ => (HEIGHT, vec![rgb(MEAN), rgb(UP), rgb(DOWN)]),
    });
}
