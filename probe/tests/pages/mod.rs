//! The `report.html` of each probe method on the data its tests use, shared
//! by the browser tests and the plot checks (`tests/plots.rs`).

#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use std::path::{Path, PathBuf};

use formats::probe::rotary::read_points;
use formats::probe::volumetric::{SetupJson, read_errors};
use probe::indexing::{self, Options as IndexingOptions, Position};
use probe::rotary::{self, Measurement};
use probe::tracer::{self, Options as TracerOptions};
use probe::volumetric::{self, Chain, CircleSpec, Model, Order, Setup, analyse, measured_axes};
use synth::probe::indexing::IndexingConfig;
use synth::probe::tracer::TracerConfig;

use crate::tracer_common;

/// A file of the probe check data (`testdata/probe/METHOD/NAME`).
fn data(method: &str, name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/probe")
        .join(method)
        .join(name)
}

/// The rotary report of the check data's probed points, interpolated at
/// 15° and 345°.
pub fn rotary() -> String {
    let input = read_points(&data("rotary", "points.csv")).unwrap();
    let m = Measurement::from_points(input.angles_deg.clone(), input.points()).unwrap();
    let s = rotary::solve(&m).unwrap();
    let at = [s.at(15.0).unwrap(), s.at(345.0).unwrap()];
    rotary::html(
        &rotary::report::report(&s, "points.csv", &at),
        &Default::default(),
    )
    .unwrap()
}

/// The generator's PH10 positions.
pub fn indexing_positions() -> Vec<Position> {
    synth::probe::indexing::generate(&IndexingConfig::default())
        .unwrap()
        .centres
        .iter()
        .map(|r| Position::new(r.a_deg, r.b_deg, [r.x, r.y, r.z]))
        .collect()
}

/// The indexing report of `positions` with a tolerance of 2.5″.
pub fn indexing(positions: &[Position]) -> String {
    let solved = indexing::solve(positions).unwrap();
    let r = indexing::report(
        &solved,
        &IndexingOptions {
            nominal_radius_mm: Some(117.0),
            tolerance_arcsec: Some(2.5),
            source: "centres.csv".into(),
        },
    )
    .unwrap();
    indexing::html(&r, &solved.angles, &Default::default()).unwrap()
}

/// The tracer report of the generator's network with one gross error (so
/// that a flagged reading is on the page too).
pub fn tracer() -> String {
    let mut net =
        tracer_common::network(&synth::probe::tracer::generate(&TracerConfig::default()).unwrap());
    net.readings[123].l += 0.004;
    let solution = tracer::solve(&net, &TracerOptions::default()).unwrap();
    let report = tracer::report(&net, &solution);
    assert!(report.outliers.count >= 1);
    let u = tracer::uncertainty(
        &net,
        &solution,
        &TracerOptions::default(),
        geom::montecarlo::Propagation {
            trials: 50,
            seed: 1,
        },
    )
    .unwrap();
    tracer::html(&net, &solution, &report, &u, &Default::default()).unwrap()
}

/// The volumetric report of the check data with its circle and one
/// volumetric point.
pub fn volumetric() -> String {
    let rows: Vec<_> = read_errors(&data("volumetric", "errors.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    let s: SetupJson = formats::read_json(&data("volumetric", "setup.json")).unwrap();
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
        readings_u: None,
    };
    let measured = measured_axes(&rows);
    let a = analyse(measured.clone(), &setup, None).unwrap();
    let u = volumetric::uncertainty(
        &measured,
        &setup,
        None,
        &a,
        &volumetric::UncertaintyInputs {
            translation_mm: Some(5e-5),
            rotation_rad: Some(5e-8),
            squareness_rad: None,
            from_report: false,
        },
        geom::montecarlo::Propagation {
            trials: 50,
            seed: 1,
        },
    );
    volumetric::html(&a, &u, &Default::default()).unwrap()
}
