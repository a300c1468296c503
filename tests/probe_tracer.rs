//! `trinocular probe tracer` and `trinocular synth probe tracer`: the
//! docs/formats.md contract (files, columns, report keys), the check data
//! through the command line, `--query`, `--force`, and bad input — exit
//! status 1 with one line naming the file, line and column (2 for usage).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{failure, s, trinocular};

fn testdata(name: &str) -> PathBuf {
    common::probe_data("tracer", name)
}

/// Stderr of a failed run with exit status `status`: one line starting with the program name.
fn one_line_error(out: &Output, status: i32) -> String {
    let (code, err) = failure(out);
    assert_eq!(code, status, "{err}");
    err
}

fn header(path: &Path) -> String {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .next()
        .unwrap()
        .to_string()
}

fn tracer(grid: &Path, readings: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "probe",
        "tracer",
        "--nominal",
        s(grid),
        "--readings",
        s(readings),
        "--out",
        s(out),
    ];
    args.extend_from_slice(extra);
    trinocular(&args)
}

#[test]
fn check_data_through_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let q = dir.path().join("q.csv");
    std::fs::write(&q, "x,y,z\n0,0,0\n50,50,50\n400,400,300\n").unwrap();
    let run = tracer(
        &testdata("grid.csv"),
        &testdata("readings.csv"),
        &out,
        &["--query", s(&q)],
    );
    assert!(run.status.success(), "{run:?}");
    let stdout = String::from_utf8(run.stdout).unwrap();
    assert!(stdout.contains("residual RMS 0.1414 µm"), "{stdout}");

    assert_eq!(
        header(&out.join("corrections.csv")),
        "point,x,y,z,dx,dy,dz,u_dx,u_dy,u_dz"
    );
    assert!(header(&out.join("stations.csv")).starts_with("station,x,y,z,dead_path"));
    assert_eq!(header(&out.join("corrected.csv")), "x,y,z,dx,dy,dz");
    // corrections.csv against the reference within 0.01 µm (1e-5 mm).
    let ours = std::fs::read_to_string(out.join("corrections.csv")).unwrap();
    let reference = std::fs::read_to_string(testdata("expected_corrections.csv")).unwrap();
    let rows: Vec<(&str, &str)> = ours
        .lines()
        .skip(1)
        .zip(reference.lines().skip(1))
        .collect();
    assert_eq!(rows.len(), 100);
    for (a, b) in rows {
        let a: Vec<&str> = a.split(',').collect();
        let b: Vec<&str> = b.split(',').collect();
        assert_eq!(a[0], b[0]);
        for k in 4..7 {
            let (x, y): (f64, f64) = (a[k].parse().unwrap(), b[k].parse().unwrap());
            assert!((x - y).abs() < 1e-5, "point {}: {x} vs {y}", a[0]);
        }
    }
    // The query at node 1 is point 1's correction; the grid's far corner is point 100's.
    let corrected = std::fs::read_to_string(out.join("corrected.csv")).unwrap();
    let first: Vec<&str> = corrected.lines().nth(1).unwrap().split(',').collect();
    let point1: Vec<&str> = ours.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(first[3..6], point1[4..7]);
    assert_eq!(corrected.lines().count(), 4);

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    for key in [
        "residual_rms_um",
        "iterations",
        "points",
        "stations",
        "unknowns",
        "equations",
        "condition",
    ] {
        assert!(report.get(key).is_some(), "report.json lacks {key}");
    }
    assert_eq!(report["points"], 100);
    assert_eq!(report["stations"], 6);
    assert_eq!(report["unknowns"], 318);
    assert_eq!(report["equations"], 600);
    assert!((report["residual_rms_um"].as_f64().unwrap() - 0.141_387_8).abs() < 1e-4);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("plot-residuals") && html.contains("plot-uncertainty"));

    // A second run refuses to overwrite; --force replaces.
    let again = tracer(&testdata("grid.csv"), &testdata("readings.csv"), &out, &[]);
    let e = one_line_error(&again, 1);
    assert!(e.contains("already exists") && e.contains("--force"), "{e}");
    let forced = tracer(
        &testdata("grid.csv"),
        &testdata("readings.csv"),
        &out,
        &["--force"],
    );
    assert!(forced.status.success(), "{forced:?}");
}

#[test]
fn synth_then_solve_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("d");
    let generated = trinocular(&[
        "synth",
        "probe",
        "tracer",
        "--out",
        s(&d),
        "--counts",
        "4,3,3",
        "--stations",
        "5",
        "--seed",
        "9",
    ]);
    assert!(generated.status.success(), "{generated:?}");
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["stations_mm"].as_array().unwrap().len(), 5);
    let again = trinocular(&["synth", "probe", "tracer", "--out", s(&d)]);
    let e = one_line_error(&again, 1);
    assert!(e.contains("truth.json") || e.contains("grid.csv"), "{e}");
    // The outputs may go beside the inputs; they never replace them.
    let run = tracer(&d.join("grid.csv"), &d.join("readings.csv"), &d, &[]);
    assert!(run.status.success(), "{run:?}");
    let ours = std::fs::read_to_string(d.join("corrections.csv")).unwrap();
    let truth = truth["corrections_rigid_removed_mm"].as_array().unwrap();
    let u_of = |row: &[f64]| row[7].max(row[8]).max(row[9]);
    for (line, t) in ours.lines().skip(1).zip(truth) {
        let row: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        for a in 0..3 {
            let e = (row[4 + a] - t[a].as_f64().unwrap()).abs();
            assert!(e < 5.0 * u_of(&row), "{line}");
        }
    }
    let usage = trinocular(&[
        "synth",
        "probe",
        "tracer",
        "--out",
        s(&d),
        "--counts",
        "4,3",
    ]);
    let e = one_line_error(&usage, 2);
    assert!(e.contains("--counts") && e.contains("2 values"), "{e}");
}

#[test]
fn outputs_never_replace_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let readings = dir.path().join("residuals.csv");
    std::fs::copy(testdata("readings.csv"), &readings).unwrap();
    let run = tracer(&testdata("grid.csv"), &readings, dir.path(), &["--force"]);
    let e = one_line_error(&run, 1);
    assert!(e.contains("would overwrite an input"), "{e}");
    assert_eq!(
        std::fs::read(&readings).unwrap(),
        std::fs::read(testdata("readings.csv")).unwrap()
    );
}

/// Write a copy of the check data with `edit` applied to the readings text.
fn edited(dir: &Path, edit: impl Fn(&str) -> String) -> PathBuf {
    let path = dir.join("readings.csv");
    let text = std::fs::read_to_string(testdata("readings.csv")).unwrap();
    std::fs::write(&path, edit(&text)).unwrap();
    path
}

fn bad_readings(edit: impl Fn(&str) -> String) -> String {
    let dir = tempfile::tempdir().unwrap();
    let readings = edited(dir.path(), edit);
    let run = tracer(&testdata("grid.csv"), &readings, &dir.path().join("r"), &[]);
    let e = one_line_error(&run, 1);
    assert!(!dir.path().join("r/report.json").exists());
    e
}

#[test]
fn bad_readings_name_file_line_and_column() {
    // Line 5 is station 1, point 4.
    let e = bad_readings(|t| t.replacen("1,4,108.3700020", "1,4,NaN", 1));
    assert!(e.contains("readings.csv: line 5, column 'l'"), "{e}");
    let e = bad_readings(|t| format!("{t}1,4,108.3700020\n"));
    assert!(
        e.contains("readings.csv: line 602, column 'point'") && e.contains("line 5"),
        "{e}"
    );
    let e = bad_readings(|t| t.replacen("1,4,108.3700020", "1,999,108.3700020", 1));
    assert!(
        e.contains("line 5, column 'point'") && e.contains("'999'"),
        "{e}"
    );
    // Readings in µm instead of mm.
    let e = bad_readings(|t| {
        let mut out = String::from("station,point,l\n");
        for line in t.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            let l: f64 = f[2].parse().unwrap();
            out.push_str(&format!("{},{},{}\n", f[0], f[1], l * 1000.0));
        }
        out
    });
    assert!(e.contains("column 'l'") && e.contains("µm"), "{e}");
    // A station reading too few points: station 6 keeps points 1–4 only.
    let e = bad_readings(|t| {
        t.lines()
            .filter(|l| {
                let f: Vec<&str> = l.split(',').collect();
                f[0] != "6" || f[1].parse::<u32>().unwrap() <= 4
            })
            .map(|l| format!("{l}\n"))
            .collect()
    });
    assert!(e.contains("station '6' reads 4 points"), "{e}");
}

/// Run `probe tracer --query` with the query `text` on `grid` and the
/// check data's readings; the one-line error.
fn query_error(dir: &Path, grid: &Path, text: &str) -> String {
    let q = dir.join("q.csv");
    std::fs::write(&q, text).unwrap();
    let out = dir.join("r");
    let run = tracer(grid, &testdata("readings.csv"), &out, &["--query", s(&q)]);
    let e = one_line_error(&run, 1);
    assert!(!out.join("report.json").exists(), "outputs written: {e}");
    e
}

#[test]
fn query_needs_a_lattice_and_points_inside_it() {
    let dir = tempfile::tempdir().unwrap();
    let grid = testdata("grid.csv");
    let e = query_error(dir.path(), &grid, "x,y,z\n10,20,30\n100,401,0\n");
    assert!(
        e.contains("q.csv: line 3, column 'y'") && e.contains("outside"),
        "{e}"
    );
    let e = query_error(dir.path(), &grid, "x,y,z\n10,nan,30\n");
    assert!(e.contains("q.csv: line 2, column 'y'"), "{e}");

    // Point 7 moved off the lattice: the solve works, the query refuses.
    let moved = dir.path().join("grid.csv");
    let text = std::fs::read_to_string(&grid).unwrap();
    let edited = text.replacen(
        "7,0.000000,100.000000,200.000000",
        "7,0.000000,100.000000,203.000000",
        1,
    );
    assert_ne!(edited, text);
    std::fs::write(&moved, edited).unwrap();
    let plain = tracer(
        &moved,
        &testdata("readings.csv"),
        &dir.path().join("plain"),
        &[],
    );
    assert!(plain.status.success(), "{plain:?}");
    let e = query_error(dir.path(), &moved, "x,y,z\n10,20,30\n");
    assert!(
        e.contains("grid.csv: line 8, column 'z'") && e.contains("lattice"),
        "{e}"
    );
}

#[test]
fn bad_grid_and_usage() {
    let dir = tempfile::tempdir().unwrap();
    let grid = dir.path().join("grid.csv");
    let text = std::fs::read_to_string(testdata("grid.csv")).unwrap();
    std::fs::write(&grid, format!("{text}3,1,2,3\n")).unwrap();
    let run = tracer(&grid, &testdata("readings.csv"), &dir.path().join("r"), &[]);
    let e = one_line_error(&run, 1);
    assert!(
        e.contains("grid.csv: line 102, column 'point'") && e.contains("line 4"),
        "{e}"
    );
    let run = trinocular(&["probe", "tracer", "--nominal", s(&grid)]);
    one_line_error(&run, 2);
    let run = tracer(
        &testdata("grid.csv"),
        &testdata("readings.csv"),
        &dir.path().join("r"),
        &["--k", "abc"],
    );
    one_line_error(&run, 2);
}
