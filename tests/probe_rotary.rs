//! `trinocular probe rotary` and `trinocular synth probe rotary` as
//! docs/formats.md states them: the output files and their columns, `--at`,
//! `--points`, refusal to overwrite without `--force` (and ever over an
//! input), one bad input per case of the issue, each a one-line error
//! naming the file, line and column with exit status 1, usage errors with
//! exit status 2, and a generator → method round trip.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::PathBuf;

use common::{failure, kept_unless_forced, ok_stdout, s, trinocular};

fn testdata(name: &str) -> PathBuf {
    common::probe_data("rotary", name)
}

/// Run the method (`flag`: `--centres` or `--points`) on the check data's
/// `source` with `edit` applied to its text: it must fail with exit status
/// 1, one line naming the file, and no output. Returns the line; each of
/// `parts` must be in it.
fn bad_input(flag: &str, source: &str, edit: impl Fn(&str) -> String, parts: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("input.csv");
    let text = std::fs::read_to_string(testdata(source)).unwrap();
    std::fs::write(&input, edit(&text)).unwrap();
    let out = dir.path().join("out");
    let (code, err) = failure(&trinocular(&[
        "probe",
        "rotary",
        flag,
        s(&input),
        "--out",
        s(&out),
    ]));
    assert_eq!(code, 1, "{err}");
    assert!(err.contains(s(&input)), "the file is not named: {err}");
    assert!(
        !out.join("rotary.csv").exists(),
        "wrote output on bad input"
    );
    for p in parts {
        assert!(err.contains(p), "{p:?} not in: {err}");
    }
    err
}

/// The header, then every data row through `f` (its fields).
fn each_row(text: &str, f: impl Fn(&[&str]) -> Option<String>) -> String {
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    for l in lines {
        if let Some(row) = f(&l.split(',').collect::<Vec<_>>()) {
            out.push_str(&row);
            out.push('\n');
        }
    }
    out
}

#[test]
fn centres_give_the_contract_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let stdout = ok_stdout(&trinocular(&[
        "probe",
        "rotary",
        "--centres",
        s(&testdata("centres.csv")),
        "--out",
        s(&out),
        "--at",
        "15",
        "-30",
        "400",
    ]));
    assert!(
        stdout.contains("location: X0C") && stdout.contains("ranges of the component errors"),
        "{stdout}"
    );
    let csv = std::fs::read_to_string(out.join("rotary.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "angle_deg,EXC,EYC,EZC,EAC,EBC,ECC,u_EXC,u_EYC,u_EZC,u_EAC,u_EBC,u_ECC"
    );
    assert_eq!(lines.count(), 12);
    // 30°, EXC as the check data expects it (mm).
    let row30: Vec<f64> = csv
        .lines()
        .nth(2)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(row30[0], 30.0);
    assert!((row30[1] - -0.00148133683773).abs() < 1e-13, "{}", row30[1]);
    let at = std::fs::read_to_string(out.join("rotary_at.csv")).unwrap();
    assert_eq!(at.lines().next().unwrap(), csv.lines().next().unwrap());
    let angles: Vec<f64> = at
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(angles, [15.0, -30.0, 400.0]);
    // 400° = 40°: a third of the way from 30° to 60°.
    let r400: Vec<f64> = at
        .lines()
        .nth(3)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let r60: Vec<f64> = csv
        .lines()
        .nth(3)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!((r400[1] - (row30[1] * 2.0 + r60[1]) / 3.0).abs() < 1e-15);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["errors"].as_array().unwrap().len(), 12);
    assert!((report["errors"][1]["EXC_um"].as_f64().unwrap() - -1.48133683773).abs() < 1e-9);
    for key in ["X0C_um", "Y0C_um", "A0C_urad", "B0C_urad"] {
        assert!(report["location"][key].is_f64(), "location.{key}");
    }
    assert!(report["condition"].as_f64().unwrap() > 1.0);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("plot-errors-translations") && html.contains("Sign-off figures"));
}

#[test]
fn probed_points_give_sphere_fits_too() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    ok_stdout(&trinocular(&[
        "probe",
        "rotary",
        "--points",
        s(&testdata("points.csv")),
        "--out",
        s(&out),
    ]));
    let spheres = std::fs::read_to_string(out.join("spheres.csv")).unwrap();
    assert!(spheres.starts_with("ball,angle_deg,x,y,z,radius,rms_residual,max_residual,points\n"));
    assert_eq!(spheres.lines().count(), 1 + 36);
    // spheres.csv is a centres file: the method runs on it.
    ok_stdout(&trinocular(&[
        "probe",
        "rotary",
        "--centres",
        s(&out.join("spheres.csv")),
        "--out",
        s(&dir.path().join("again")),
    ]));
    let a = std::fs::read_to_string(out.join("rotary.csv")).unwrap();
    let b = std::fs::read_to_string(dir.path().join("again/rotary.csv")).unwrap();
    assert_eq!(a, b);
}

#[test]
fn outputs_are_kept_unless_forced_and_inputs_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let centres = testdata("centres.csv");
    let args = [
        "probe",
        "rotary",
        "--centres",
        s(&centres),
        "--out",
        s(&out),
    ];
    let err = kept_unless_forced(&args, &out.join("rotary.csv"));
    assert!(err.contains("rotary.csv"), "{err}");
    // An input named like an output, in the output directory: refused even with --force.
    let input = dir.path().join("rotary.csv");
    std::fs::copy(testdata("centres.csv"), &input).unwrap();
    let (code, err) = failure(&trinocular(&[
        "probe",
        "rotary",
        "--centres",
        s(&input),
        "--out",
        s(dir.path()),
        "--force",
    ]));
    assert_eq!(code, 1);
    assert!(err.contains("input"), "{err}");
    assert_eq!(
        std::fs::read_to_string(&input).unwrap(),
        std::fs::read_to_string(testdata("centres.csv")).unwrap()
    );
}

#[test]
fn usage_errors_exit_with_2() {
    for args in [
        vec!["probe", "rotary", "--out", "x"],
        vec![
            "probe",
            "rotary",
            "--centres",
            "a.csv",
            "--points",
            "b.csv",
            "--out",
            "x",
        ],
        vec!["probe", "rotary", "--centres", "a.csv"],
        vec![
            "probe",
            "rotary",
            "--centres",
            "a.csv",
            "--out",
            "x",
            "--at",
            "ten",
        ],
    ] {
        let (code, err) = failure(&trinocular(&args));
        assert_eq!(code, 2, "{args:?}: {err}");
    }
}

#[test]
fn a_missing_angle_for_one_ball() {
    let drop = |v: &[&str]| (v[..2] != ["2", "120"]).then(|| v.join(","));
    bad_input(
        "--centres",
        "centres.csv",
        |t| each_row(t, drop),
        &["line 14, column 'angle_deg'", "ball 2 has no row at 120°"],
    );
}

#[test]
fn angles_not_shared_by_all_balls() {
    // Ball 3 measured at 45° instead of 30°.
    let err = bad_input(
        "--centres",
        "centres.csv",
        |t| t.replace("\n3,30,", "\n3,45,"),
        &["column 'angle_deg'"],
    );
    assert!(
        err.contains("ball 3 has no row at 30°")
            || err.contains("45° is measured for ball(s) 3 only"),
        "{err}"
    );
}

#[test]
fn a_duplicate_ball_and_angle() {
    bad_input(
        "--centres",
        "centres.csv",
        |t| format!("{t}1,90,-9.9966783,149.9747654,60.0090399\n"),
        &["line 38, column 'angle_deg'", "twice", "line 11"],
    );
}

#[test]
fn a_ball_with_fewer_than_four_points() {
    // Drop two of the five points of ball 2 at 60°.
    let n = std::cell::Cell::new(0);
    let drop = |v: &[&str]| {
        let hit = v[..2] == ["2", "60"] && n.get() < 2;
        n.set(n.get() + usize::from(hit));
        (!hit).then(|| v.join(","))
    };
    bad_input(
        "--points",
        "points.csv",
        |t| each_row(t, drop),
        &[
            "column 'ball'",
            "ball 2 at 60° has 3 probed point(s)",
            "at least 4",
        ],
    );
}

#[test]
fn a_nan() {
    bad_input(
        "--centres",
        "centres.csv",
        |t| t.replace("95.0018199", "NaN"),
        &["line 6, column 'z'", "not a finite"],
    );
}

#[test]
fn values_in_micrometres() {
    // One centre 1000× too far for any table.
    bad_input(
        "--centres",
        "centres.csv",
        |t| t.replace("66.3397038", "66339.7038"),
        &["line 8, column 'x'", "µm instead of mm"],
    );
    // A whole file in µm.
    let um = |x: &str| x.parse::<f64>().unwrap() * 1000.0;
    bad_input(
        "--centres",
        "centres.csv",
        |t| {
            each_row(t, |v| {
                Some(format!(
                    "{},{},{},{},{}",
                    v[0],
                    v[1],
                    um(v[2]),
                    um(v[3]),
                    um(v[4])
                ))
            })
        },
        &["line 2, column 'x'", "µm"],
    );
    // A height in metres, within reach of any limit: the ball's other rows tell.
    bad_input(
        "--centres",
        "centres.csv",
        |t| t.replace("29.9940384", "0.0299940384"),
        &["line 10, column 'z'", "in m:"],
    );
}

#[test]
fn a_degenerate_layout_names_the_condition_number() {
    // Ball 2 0.2 mm off the line through balls 1 and 3, turned every 90°.
    let line = |_: &str| {
        let mut text = String::from("ball,angle_deg,x,y,z\n");
        for a in [0.0_f64, 90.0, 180.0, 270.0] {
            for (b, x, y) in [(1, -150.0, 0.0), (2, 0.0, 0.2), (3, 150.0, 0.0)] {
                let (sn, c) = a.to_radians().sin_cos();
                text.push_str(&format!(
                    "{b},{a},{},{},50\n",
                    c * x - sn * y,
                    sn * x + c * y
                ));
            }
        }
        text
    };
    bad_input(
        "--centres",
        "centres.csv",
        line,
        &["condition number", "exceeds"],
    );
}

#[test]
fn clockwise_angles_name_the_line() {
    // Angles counted the other way: θ → 360° − θ.
    let clockwise = |v: &[&str]| {
        let a: f64 = v[1].parse().unwrap();
        let a = if a == 0.0 { 0.0 } else { 360.0 - a };
        Some(format!("{},{a},{},{},{}", v[0], v[2], v[3], v[4]))
    };
    bad_input(
        "--centres",
        "centres.csv",
        |t| each_row(t, clockwise),
        &["line 35, column 'angle_deg'", "ball 1 at 30°", "clockwise"],
    );
}

#[test]
fn synth_then_method_recovers_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d");
    let stdout = ok_stdout(&trinocular(&[
        "synth",
        "probe",
        "rotary",
        "--out",
        s(&data),
        "--seed",
        "4",
        "--step-deg",
        "20",
    ]));
    assert!(stdout.contains("18 angles"), "{stdout}");
    for f in ["centres.csv", "points.csv", "truth.json", "config.toml"] {
        assert!(data.join(f).is_file(), "{f}");
    }
    // Same seed, same bytes; existing outputs refused without --force.
    let (code, _) = failure(&trinocular(&[
        "synth",
        "probe",
        "rotary",
        "--out",
        s(&data),
    ]));
    assert_eq!(code, 1);
    let again = dir.path().join("again");
    ok_stdout(&trinocular(&[
        "synth",
        "probe",
        "rotary",
        "--out",
        s(&again),
        "--config",
        s(&data.join("config.toml")),
    ]));
    assert_eq!(
        std::fs::read(data.join("points.csv")).unwrap(),
        std::fs::read(again.join("points.csv")).unwrap()
    );
    let out = dir.path().join("r");
    ok_stdout(&trinocular(&[
        "probe",
        "rotary",
        "--points",
        s(&data.join("points.csv")),
        "--out",
        s(&out),
    ]));
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data.join("truth.json")).unwrap()).unwrap();
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    // Mean of 18 angles at 0.3 µm noise: ≈ 0.1 µm, ≈ 1 µrad; bounds ≈ 5 of those.
    for (key, tol) in [
        ("X0C_um", 0.5),
        ("Y0C_um", 0.5),
        ("A0C_urad", 5.0),
        ("B0C_urad", 5.0),
    ] {
        let got = report["location"][key].as_f64().unwrap();
        let want = truth["location"][key].as_f64().unwrap();
        assert!((got - want).abs() < tol, "{key}: {got} vs {want}");
    }
    let printed = ok_stdout(&trinocular(&["synth", "probe", "rotary", "--print-config"]));
    assert!(printed.contains("[location]") && printed.contains("step_deg = 30.0"));
}
