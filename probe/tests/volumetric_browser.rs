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

use std::path::Path;

use formats::probe::volumetric::{SetupJson, read_errors};
use probe::volumetric::{
    Chain, CircleSpec, Model, Motion, Order, Setup, analyse, html, measured_axes,
};
use report::browser::{self, rgb};
use report::plot::{DOWN, HEIGHT, MAP_HEIGHT, MEAN, UP, ZONE};

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/probe/volumetric")
        .join(name)
}

#[test]
fn report_html_renders_in_chromium() {
    let Some(chromium) = browser::browser_or_skip("volumetric report.html in Chromium").unwrap()
    else {
        return;
    };
    let rows: Vec<_> = read_errors(&data("errors.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    let curves = measured_axes(&rows);
    let s: SetupJson = formats::read_json(&data("setup.json")).unwrap();
    let setup = Setup {
        chain: Chain::parse(&s.chain).unwrap(),
        squareness: s.squareness_rad,
        tool: s.tool_mm,
        model: Model::Raw,
        order: Order::Fixed(3),
        at: vec![("at".into(), [300.0, 200.0, 150.0])],
        circle: Some(CircleSpec {
            centre: s.circle.centre_mm,
            radius: s.circle.radius_mm,
        }),
        source: "check data".into(),
    };
    let analysis = analyse(curves, &setup, None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    std::fs::write(&page, html(&analysis).unwrap()).unwrap();
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
