//! The ISO 230-2 check vector of docs/methods.md (`testdata/iso230-2/`): 5 targets
//! × 5 runs each way, reproduced to 1e-9 mm for every figure.

#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use evaluate::{TargetDeviations, iso230_2};
use serde::Deserialize;

/// Agreement required (mm).
const TOLERANCE_MM: f64 = 1e-9;

#[derive(Debug, Deserialize)]
struct Row {
    direction: String,
    run: u32,
    target: usize,
    target_mm: f64,
    measured_mm: f64,
}

fn check_vector() -> Vec<TargetDeviations> {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/iso230-2/check_vector.csv");
    let mut rdr = csv::Reader::from_path(&path).unwrap();
    let mut targets: Vec<TargetDeviations> = Vec::new();
    for row in rdr.deserialize::<Row>() {
        let row = row.unwrap();
        assert!(row.run >= 1);
        if targets.len() <= row.target {
            targets.resize(row.target + 1, TargetDeviations::default());
        }
        let x = row.measured_mm - row.target_mm;
        match row.direction.as_str() {
            "+" => targets[row.target].up.push(x),
            "-" => targets[row.target].down.push(x),
            d => panic!("direction {d}"),
        }
    }
    assert_eq!(targets.len(), 5);
    assert!(targets.iter().all(|t| t.up.len() == 5 && t.down.len() == 5));
    targets
}

#[test]
fn check_vector_figures() {
    let r = iso230_2(&check_vector()).unwrap();
    let (up, down, bi) = (r.up.unwrap(), r.down.unwrap(), r.bidirectional.unwrap());
    // Exact figures (mm): rational arithmetic on the file's decimals, square
    // roots to 40 digits, with the formulas of docs/methods.md (an independent
    // computation; the README's figures are these rounded to 1e-6 mm).
    let exact = [
        ("B", bi.b, 0.004564, 0.004564),
        ("B̄", bi.b_mean, 0.0006956, 0.000696),
        ("R↑", up.r, 0.007502351631322, 0.007502),
        ("R↓", down.r, 0.003882514649039, 0.003883),
        ("R", bi.r, 0.008353904021705, 0.008354),
        ("E↑", up.e, 0.015052, 0.015052),
        ("E↓", down.e, 0.014852, 0.014852),
        ("E", bi.e, 0.015988, 0.015988),
        ("M", bi.m, 0.014952, 0.014952),
        ("A↑", up.a, 0.018065408876286, 0.018065),
        ("A↓", down.a, 0.016542530489368, 0.016543),
        ("A", bi.a, 0.018571302808278, 0.018571),
    ];
    let mut worst: f64 = 0.0;
    for (name, got, want, printed) in exact {
        let diff = (got - want).abs();
        worst = worst.max(diff);
        assert!(
            diff <= TOLERANCE_MM,
            "{name}: {got} mm, check vector {want} mm"
        );
        // And the figure as the README prints it, to its last digit.
        assert!(
            (got - printed).abs() <= 5e-7 + 1e-12,
            "{name}: {got} vs printed {printed}"
        );
    }
    eprintln!("check vector: largest deviation {worst:e} mm");
}

#[test]
fn published_report_figures_are_the_wrong_ones() {
    // The published report printed R = 0.0075 (max(R↑, R↓)) and E = 0.01485;
    // the correct bidirectional figures differ by far more than rounding.
    let r = iso230_2(&check_vector()).unwrap();
    let bi = r.bidirectional.unwrap();
    assert!((bi.r - 0.0075).abs() > 5e-4 && (bi.e - 0.01485).abs() > 1e-3);
}

#[test]
fn check_vector_through_points() {
    // The same test as points.csv rows along X: positioning figures in µm
    // equal the check vector's (the axis frame and datum change nothing for
    // a perfectly straight axis).
    let mut rows = Vec::new();
    for (i, t) in check_vector().iter().enumerate() {
        let nominal = 15.0 + 10.2 * i as f64;
        for (direction, values) in [
            (formats::Direction::Up, &t.up),
            (formats::Direction::Down, &t.down),
        ] {
            for (j, x) in values.iter().enumerate() {
                rows.push(formats::PointRow::new(
                    formats::InstantKey::new(
                        (formats::Axis::X, direction),
                        [j as u32 + 1, i as u32, 1],
                        [nominal, 0.0, 0.0],
                    ),
                    "A",
                    [nominal + x, 0.0, 0.0],
                    "2+3",
                    0.0,
                ));
            }
        }
    }
    let report = evaluate::evaluate(&rows, &evaluate::Options::default()).unwrap();
    let p = &report.axes.x.as_ref().unwrap().main.positioning;
    for (name, got, want) in [
        ("B", p.b_um, 4.564),
        ("R", p.r_um, 8.353904021705),
        ("E", p.e_um, 15.988),
        ("M", p.m_um, 14.952),
        ("A", p.a_um, 18.571302808278),
        ("A↑", p.a_up_um, 18.065408876286),
    ] {
        let got = got.unwrap();
        assert!((got - want).abs() <= 1e-6, "{name}: {got} µm vs {want} µm");
    }
}
