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

use std::path::Path;

use formats::probe::volumetric::{SetupJson, read_errors};
use probe::volumetric::{
    Chain, CircleSpec, Model, Motion, Order, Setup, analyse, html, measured_axes,
};
use report::browser::{self, PAGE_WIDTH, check_region, rgb};
use report::plot::{DOWN, HEIGHT, MAP_HEIGHT, MEAN, UP, WIDTH, ZONE};

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
    std::fs::write(&page, html::render(&analysis).unwrap()).unwrap();
    let shown = browser::render(&chromium, &page).unwrap();
    assert!(
        shown.errors.is_empty(),
        "console errors: {:#?}",
        shown.errors
    );
    let ids: Vec<&str> = shown.plots.iter().map(|p| p.id.as_str()).collect();
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
    assert_eq!(ids, expected, "plots on the page");
    assert!(
        shown.width <= PAGE_WIDTH,
        "page {} px wider than the window",
        shown.width
    );
    for p in &shown.plots {
        let (height, colours) = match p.id.as_str() {
            "plot-circle-polar" => (MAP_HEIGHT, vec![rgb(UP), rgb(ZONE), rgb(DOWN)]),
            "plot-circle-radial" => (HEIGHT, vec![rgb(UP), rgb(ZONE), rgb(DOWN)]),
            _ => (HEIGHT, vec![rgb(MEAN), rgb(UP), rgb(DOWN)]),
        };
        assert_eq!(
            (p.w, p.h),
            (WIDTH, height),
            "{} laid out at {}×{}",
            p.id,
            p.w,
            p.h
        );
        check_region(&shown.screenshot, p, &colours).unwrap();
    }
    if let Ok(keep) = std::env::var("TRINOCULAR_KEEP_SCREENSHOT") {
        shown.screenshot.save(&keep).unwrap();
        eprintln!("screenshot saved to {keep}");
    }
}
