//! `trinocular probe indexing` and `trinocular synth probe indexing`: the
//! docs/formats.md contract (files, columns, report keys), the check data
//! reproduced through the command line, `--force`, never writing over an
//! input, and every bad input refused with exit status 1 and one line that
//! names the file, the line and the column.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{kept_unless_forced, ok_stdout, one_line_refusal, s, trinocular};

/// `trinocular probe indexing --centres CENTRES --out OUT EXTRA…`.
fn probe(centres: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "probe",
        "indexing",
        "--centres",
        s(centres),
        "--out",
        s(out),
    ];
    args.extend(extra);
    trinocular(&args)
}

/// `trinocular synth probe indexing ARGS…`.
fn synth(args: &[&str]) -> Output {
    let mut all = vec!["synth", "probe", "indexing"];
    all.extend(args);
    trinocular(&all)
}

fn testdata(name: &str) -> PathBuf {
    common::probe_data("indexing", name)
}

/// The centres of the check data with `edit` applied to its data lines
/// (0-based; the header is not among them), written to `dir/name`.
fn edited(dir: &Path, name: &str, edit: impl Fn(&mut Vec<String>)) -> PathBuf {
    let text = std::fs::read_to_string(testdata("centres.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().skip(1).map(String::from).collect();
    edit(&mut lines);
    let path = dir.join(name);
    std::fs::write(&path, format!("a_deg,b_deg,x,y,z\n{}\n", lines.join("\n"))).unwrap();
    path
}

#[test]
fn synth_then_probe_follows_the_contract() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d");
    let out = ok_stdout(&synth(&["--out", s(&data), "--seed", "5"]));
    assert!(out.contains("720 positions"), "{out}");
    for f in ["centres.csv", "truth.json"] {
        assert!(data.join(f).is_file(), "{f}");
    }
    let report = dir.path().join("r");
    let centres = data.join("centres.csv");
    let out = ok_stdout(&probe(
        &centres,
        &report,
        &["--nominal-radius", "117", "--tolerance", "3"],
    ));
    for figure in [
        "rotation centre",
        "radius",
        "max |ΔθA|",
        "max |ΔθB|",
        "beyond ±3″",
    ] {
        assert!(out.contains(figure), "{figure} missing from:\n{out}");
    }
    let csv = std::fs::read_to_string(report.join("indexing.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("a_deg,b_deg,theta_a_deg,theta_b_deg,dA_arcsec,dB_arcsec"),
        "header"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 720);
    for r in &rows {
        assert_eq!(
            r[0] == "0.0",
            r[5].is_empty(),
            "dB empty exactly at A = 0: {r:?}"
        );
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("report.json")).unwrap())
            .unwrap();
    assert_eq!(json["rotation_centre"].as_array().unwrap().len(), 3);
    for key in [
        "radius_mm",
        "max_dA_arcsec",
        "max_dB_arcsec",
        "rms_dA_arcsec",
        "rms_dB_arcsec",
        "radius_deviation_um",
    ] {
        assert!(json[key].as_f64().is_some(), "{key}");
    }
    assert!(json["tolerance"]["exceeding"].is_array());
    let html = std::fs::read_to_string(report.join("report.html")).unwrap();
    assert!(html.contains("plot-map-dA") && html.contains("plot-curve-dB"));
    assert!(!html.contains("<script"), "self-contained, no scripts");
}

#[test]
fn check_data_through_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    ok_stdout(&probe(&testdata("centres.csv"), &out, &[]));
    let mut got = csv::Reader::from_path(out.join("indexing.csv")).unwrap();
    let mut want = csv::Reader::from_path(testdata("expected_indexing.csv")).unwrap();
    for (g, w) in got.records().zip(want.records()) {
        let (g, w) = (g.unwrap(), w.unwrap());
        let angle = |r: &csv::StringRecord, k: usize| r[k].parse::<f64>().unwrap();
        assert_eq!((angle(&g, 0), angle(&g, 1)), (angle(&w, 0), angle(&w, 1)));
        // ΔθB to the expected file's 6 decimals (ΔθA is held to it in probe/tests/indexing.rs).
        if !w[3].is_empty() {
            let d: f64 = g[5].parse::<f64>().unwrap() - w[3].parse::<f64>().unwrap();
            assert!(d.abs() < 5.1e-7, "{g:?} vs {w:?}");
        }
    }
}

#[test]
fn outputs_are_kept_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let centres = testdata("centres.csv");
    let args = [
        "probe",
        "indexing",
        "--centres",
        s(&centres),
        "--out",
        s(&out),
    ];
    let e = kept_unless_forced(&args, &out.join("report.json"));
    assert!(e.contains("already exists"), "{e}");

    let data = dir.path().join("d");
    ok_stdout(&synth(&["--out", s(&data)]));
    let e = one_line_refusal(&synth(&["--out", s(&data)]));
    assert!(e.contains("already exists"), "{e}");
}

#[test]
fn an_input_is_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let centres = dir.path().join("indexing.csv");
    std::fs::copy(testdata("centres.csv"), &centres).unwrap();
    let e = one_line_refusal(&probe(&centres, dir.path(), &["--force"]));
    assert!(e.contains("overwrite an input"), "{e}");
    assert_eq!(
        std::fs::read(&centres).unwrap(),
        std::fs::read(testdata("centres.csv")).unwrap()
    );
}

#[test]
fn bad_input_names_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // (file, what the message must hold). Data line k is file line k + 2.
    let cases: Vec<(PathBuf, Vec<&str>)> = vec![
        (
            edited(d, "dup.csv", |l| {
                let again = l[100].clone();
                l.push(again);
            }),
            vec!["dup.csv: line 722, column 'b_deg'", "twice", "line 102"],
        ),
        (
            edited(d, "no_a0.csv", |l| l.retain(|r| !r.starts_with("0,"))),
            vec!["no_a0.csv", "column 'a_deg'", "no position at A = 0°"],
        ),
        (
            edited(d, "no_sweep.csv", |l| {
                l.retain(|r| r.starts_with("0,") || r.split(',').nth(1).is_none_or(|b| b != "0"))
            }),
            vec!["no_sweep.csv", "column 'b_deg'", "B = 0° sweep"],
        ),
        (
            edited(d, "nan.csv", |l| {
                let mut f: Vec<&str> = l[40].split(',').collect();
                f[1] = "NaN";
                l[40] = f.join(",");
            }),
            vec!["nan.csv: line 42, column 'b_deg'", "not a finite number"],
        ),
        (
            edited(d, "um.csv", |l| {
                for r in l.iter_mut() {
                    let v: Vec<String> = r
                        .split(',')
                        .enumerate()
                        .map(|(k, x)| {
                            if k < 2 {
                                x.to_string()
                            } else {
                                format!("{}", x.parse::<f64>().unwrap() * 1000.0)
                            }
                        })
                        .collect();
                    *r = v.join(",");
                }
            }),
            vec!["um.csv: line 2, column 'x'", "µm"],
        ),
        (
            edited(d, "few.csv", |l| l.truncate(4)),
            vec!["few.csv", "4 positions", "at least 5"],
        ),
        (
            // One A = 0° position dropped: 47 B values cannot be 360°/47 apart.
            edited(d, "turn.csv", |l| {
                l.remove(5);
            }),
            vec![
                "turn.csv",
                "column 'b_deg'",
                "full B turn at even steps",
                "circle",
            ],
        ),
        (
            // One A = 0° B moved off its step: that line is named.
            edited(d, "step.csv", |l| l[3] = l[3].replacen("-157.5", "-156", 1)),
            vec![
                "step.csv: line 5, column 'b_deg'",
                "full B turn at even steps",
            ],
        ),
        (
            edited(d, "negative.csv", |l| l[700] = format!("-{}", l[700])),
            vec!["negative.csv: line 702, column 'a_deg'", "[0°, 180°)"],
        ),
        (
            {
                let p = d.join("header.csv");
                std::fs::write(&p, "a_deg,b,x,y,z\n0,0,1,2,3\n").unwrap();
                p
            },
            vec!["header.csv: line 1, column 'b_deg'", "missing"],
        ),
    ];
    for (file, wants) in cases {
        let out = d.join(format!(
            "out-{}",
            file.file_stem().unwrap().to_str().unwrap()
        ));
        let e = one_line_refusal(&probe(&file, &out, &[]));
        for w in wants {
            assert!(e.contains(w), "{}: '{w}' missing from {e}", file.display());
        }
        assert!(!out.exists(), "no output directory for bad input");
    }
}

#[test]
fn usage_errors_exit_2_and_options_are_checked() {
    let out = trinocular(&["probe", "indexing", "--out", "x"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--centres"));
    let dir = tempfile::tempdir().unwrap();
    let out = probe(
        &testdata("centres.csv"),
        &dir.path().join("r"),
        &["--tolerance=-2"],
    );
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("--tolerance") && e.contains("-2"), "{e}");
}

#[test]
fn synth_config_is_printed_read_and_checked() {
    let text = ok_stdout(&synth(&["--print-config"]));
    assert!(text.contains("b_step_deg = 7.5") && text.contains("[a_errors]"));
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("head.toml");
    std::fs::write(
        &config,
        "a_max_deg = 60.0\na_step_deg = 15.0\nb_step_deg = 15.0\nnoise_um = 0.1\n",
    )
    .unwrap();
    let data = dir.path().join("d");
    let out = ok_stdout(&synth(&["--config", s(&config), "--out", s(&data)]));
    assert!(out.contains("120 positions"), "{out}");
    ok_stdout(&probe(
        &data.join("centres.csv"),
        &dir.path().join("r"),
        &[],
    ));
    std::fs::write(&config, "b_step_deg = 7\n").unwrap();
    let e = one_line_refusal(&synth(&[
        "--config",
        s(&config),
        "--out",
        s(&dir.path().join("bad")),
    ]));
    assert!(e.contains("head.toml") && e.contains("b_step_deg"), "{e}");
}
