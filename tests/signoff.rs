//! The sign-off report of `trinocular evaluate`: `--tolerances` judges each
//! limited figure (ISO 14253-1 or the simple rule), states the verdict on
//! the page, in report.json and on stderr, and exits 4 on nonconformance
//! only when asked; bad tolerance files are refused with the file and key,
//! nothing written. `--conditions conditions.toml`: the test conditions
//! on the report, and the correction to 20 °C. With a machine temperature
//! of 25 °C and α = 11.5 µm/(m·K) the mean deviations of a line tilt by
//! −57.5 µm/m against the uncorrected report (ISO 230-2 nominal
//! differential expansion), E follows from the corrected means, the
//! figures before the correction are kept under `uncorrected`; a target
//! calibrated at 30 °C scales the lengths; bad conditions are refused with
//! the file and key, nothing written. `--pdf` prints the archive copy
//! (rasterised and read back with poppler's pdftoppm and pdftotext).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::Path;

use common::{failure, ok, ok_stdout, read, s, trinocular};
use formats::{Axis, Direction, InstantKey, PointRow};
use serde_json::Value;

/// Commanded X of the targets (mm).
const TARGETS: [f64; 6] = [0.0, 80.0, 160.0, 240.0, 320.0, 400.0];
/// Positional error per target (µm), reversal (µm) and run scatter (µm).
const ERROR_UM: [f64; 6] = [0.0, 3.0, 4.5, 2.0, 6.0, 5.0];
const REVERSAL_UM: f64 = 2.0;
const SCATTER_UM: f64 = 0.5;

/// One X line, three runs each way, one capture per approach.
fn rows() -> Vec<PointRow> {
    let mut rows = Vec::new();
    for run in 1..=3u32 {
        let z = f64::from(run) - 2.0;
        for (direction, sign) in [(Direction::Up, 1.0), (Direction::Down, -1.0)] {
            for (k, &c) in TARGETS.iter().enumerate() {
                let along_um = ERROR_UM[k] + sign * REVERSAL_UM / 2.0 + SCATTER_UM * z;
                rows.push(PointRow::new(
                    InstantKey::new((Axis::X, direction), [run, k as u32, 1], [c, 0.0, 0.0]),
                    "A",
                    [c + along_um * 1e-3, 0.0, 0.0],
                    "2+3",
                    0.1,
                ));
            }
        }
    }
    rows
}

/// Evaluate the line into `dir/name` with `extra` arguments; report.json and report.html.
fn evaluate(dir: &Path, name: &str, extra: &[&str]) -> (Value, String) {
    let points = dir.join("points.csv");
    if !points.exists() {
        formats::write_csv(&points, &rows()).unwrap();
    }
    let out = dir.join(name);
    let mut args = vec!["evaluate", "--points", s(&points), "--out", s(&out)];
    args.extend(extra);
    ok(&trinocular(&args));
    (
        serde_json::from_slice(&read(&out.join("report.json"))).unwrap(),
        String::from_utf8(read(&out.join("report.html"))).unwrap(),
    )
}

/// Per target: (nominal, mean ↑, mean ↓) of the main X line (µm).
fn means(report: &Value) -> Vec<(f64, f64, f64)> {
    report["axes"]["X"]["positioning"]["targets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            (
                t["nominal"].as_f64().unwrap(),
                t["mean_up_um"].as_f64().unwrap(),
                t["mean_down_um"].as_f64().unwrap(),
            )
        })
        .collect()
}

const WARM: &str = "[machine]\nmaker = \"ACME\"\nmodel = \"VMC 800\"\nserial = \"4711\"\n\
    operator = \"R. Roe\"\n[temperature]\nmachine_c = 25.0\nmachine_u_c = 0.2\n\
    expansion_um_per_m_k = 11.5\nexpansion_u_um_per_m_k = 1.0\nair_c = 21.0\n";

#[test]
fn a_warm_machine_tilts_the_mean_deviations_by_its_expansion() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = tmp.path().join("conditions.toml");
    std::fs::write(&cfg, WARM).unwrap();
    let (plain, plain_html) = evaluate(tmp.path(), "plain", &[]);
    let (warm, html) = evaluate(tmp.path(), "warm", &["--conditions", s(&cfg)]);

    // −57.5 µm/m × (P − P₀), P₀ = 0: the difference of the means per target.
    let (a, b) = (means(&plain), means(&warm));
    for ((p, up0, down0), (_, up1, down1)) in a.iter().zip(&b) {
        let tilt = -57.5e-3 * p;
        assert!((up1 - up0 - tilt).abs() < 1e-9, "↑ at {p}: {up0} → {up1}");
        assert!(
            (down1 - down0 - tilt).abs() < 1e-9,
            "↓ at {p}: {down0} → {down1}"
        );
    }
    // E = the range of every directional mean (ISO 230-2 §3.4.5), from the corrected means.
    let range = |m: &[(f64, f64, f64)]| {
        let all: Vec<f64> = m.iter().flat_map(|(_, u, d)| [*u, *d]).collect();
        all.iter().copied().fold(f64::MIN, f64::max) - all.iter().copied().fold(f64::MAX, f64::min)
    };
    let e = |r: &Value| r["axes"]["X"]["positioning"]["E_um"].as_f64().unwrap();
    assert!((e(&plain) - range(&a)).abs() < 1e-9);
    assert!((e(&warm) - range(&b)).abs() < 1e-9);
    // Here the machine's own +5 µm over 400 mm and the −23 µm of the expansion.
    assert!(
        (e(&plain) - e(&warm)).abs() > 10.0,
        "{} {}",
        e(&plain),
        e(&warm)
    );
    // The figures before the correction, and the statement.
    let before = &warm["uncorrected"];
    assert_eq!(before["axes.X.positioning.E_um"].as_f64(), Some(e(&plain)));
    assert!(
        warm["conventions"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c.as_str().unwrap().contains("57.50 µm/m·(P − P₀)")),
        "{}",
        warm["conventions"]
    );
    // The conditions echoed and on the page.
    assert_eq!(warm["conditions"]["machine"]["serial"], "4711");
    assert_eq!(warm["conditions"]["temperature"]["machine_c"], 25.0);
    for text in [
        "Test conditions",
        "VMC 800",
        "R. Roe",
        "25 °C (u = 0.2 °C)",
        "21 °C",
    ] {
        assert!(html.contains(text), "{text} not on the page");
    }
    // Said on the terminal before the figures, with each unit right after its number.
    let out = tmp.path().join("warm-terminal");
    let stdout = ok_stdout(&trinocular(&[
        "evaluate",
        "--points",
        s(&tmp.path().join("points.csv")),
        "--out",
        s(&out),
        "--conditions",
        s(&cfg),
    ]));
    let said = stdout
        .find("conditions: positioning deviations corrected to 20 °C")
        .unwrap_or_else(|| panic!("no correction on the terminal: {stdout}"));
    assert!(said < stdout.find("X: A ").unwrap(), "{stdout}");
    assert!(stdout.contains(" µm, E "), "{stdout}");
    assert_eq!(
        warm["correction"],
        warm["conventions"]
            .as_array()
            .unwrap()
            .last()
            .unwrap()
            .clone()
    );
    assert!(html.contains("id=\"correction\">Conditions applied: positioning deviations"));
    // Without conditions: nothing of the kind.
    assert!(plain.get("conditions").is_none() && plain.get("uncorrected").is_none());
    assert!(!plain_html.contains("Test conditions"));
}

#[test]
fn a_target_calibrated_warm_scales_the_lengths() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = tmp.path().join("conditions.toml");
    std::fs::write(
        &cfg,
        "[temperature]\ntarget_c = 30.0\ntarget_expansion_um_per_m_k = 23.1\n",
    )
    .unwrap();
    let (plain, _) = evaluate(tmp.path(), "plain", &[]);
    let (scaled, _) = evaluate(tmp.path(), "scaled", &["--conditions", s(&cfg)]);
    // Lengths × (1 + 231 µm/m): the deviation at P grows by 0.231 µm per mm
    // of travel (and by 231 µm/m of the few µm of the deviation itself,
    // ≤ 0.002 µm here).
    for ((p, up0, _), (_, up1, _)) in means(&plain).iter().zip(&means(&scaled)) {
        let grow = 231e-3 * p;
        assert!((up1 - up0 - grow).abs() < 3e-3, "at {p}: {up0} → {up1}");
    }
}

#[test]
fn bad_conditions_are_refused_with_the_key_and_nothing_written() {
    refused_files(
        "--conditions",
        "conditions.toml",
        &[
            (
                "[temperature]\nmachine_c = 65.0\nexpansion_um_per_m_k = 11.5\n",
                "temperature.machine_c",
            ),
            (
                "[temperature]\nmachine_c = 25.0\nexpansion_um_per_m_k = -11.5\n",
                "temperature.expansion_um_per_m_k",
            ),
            ("[temperature]\nmachine_c = 25.0\n", "temperature.machine_c"),
            ("[weather]\nsunny = true\n", "weather"),
            ("machine_c = ", "conditions.toml"),
        ],
    );
}

/// Each `(file text, expected fragment)` given to `evaluate` as `option`
/// (written as `file`) is refused with exit 1, the file and the fragment
/// named, and nothing written.
fn refused_files(option: &str, file: &str, cases: &[(&str, &str)]) {
    let tmp = tempfile::tempdir().unwrap();
    let points = tmp.path().join("points.csv");
    formats::write_csv(&points, &rows()).unwrap();
    for (text, key) in cases {
        let path = tmp.path().join(file);
        std::fs::write(&path, text).unwrap();
        let out = tmp.path().join("out");
        let (code, err) = failure(&trinocular(&[
            "evaluate",
            "--points",
            s(&points),
            option,
            s(&path),
            "--out",
            s(&out),
        ]));
        assert_eq!(code, 1, "{text}: {err}");
        assert!(err.contains(file) && err.contains(key), "{text}: {err}");
        assert!(!out.exists(), "{text}: {} written", out.display());
    }
}

/// Run `tool` (poppler-utils) with `args`; `None` (with a notice) when it is
/// not installed and the environment does not require it.
fn poppler(tool: &str, args: &[&str]) -> Option<std::process::Output> {
    match std::process::Command::new(tool).args(args).output() {
        Ok(out) => {
            assert!(
                out.status.success(),
                "{tool} {args:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            Some(out)
        }
        Err(_) if std::env::var("TRINOCULAR_REQUIRE_BROWSER").as_deref() != Ok("1") => {
            eprintln!("NOTICE: {tool} not found (Debian poppler-utils): the PDF check is SKIPPED");
            None
        }
        Err(e) => panic!("{tool}: {e} (install the Debian package poppler-utils)"),
    }
}

#[test]
fn the_archive_copy_is_printed_on_a4_with_page_numbers() {
    if report::browser::browser_or_skip("the_archive_copy_is_printed")
        .unwrap()
        .is_none()
    {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let cfg = tmp.path().join("conditions.toml");
    std::fs::write(&cfg, WARM).unwrap();
    let tol = tmp.path().join("tol.toml");
    std::fs::write(&tol, "[X]\nA_um = 1.0\nR_um = 5.0\n").unwrap();
    evaluate(
        tmp.path(),
        "printed",
        &["--conditions", s(&cfg), "--tolerances", s(&tol), "--pdf"],
    );
    let pdf = tmp.path().join("printed/report.pdf");
    let bytes = read(&pdf);
    assert!(bytes.starts_with(b"%PDF-"), "not a PDF");
    // Page 1 as text: the heading, the conditions and the page number.
    let Some(text) = poppler(
        "pdftotext",
        &["-f", "1", "-l", "1", "-layout", s(&pdf), "-"],
    ) else {
        return;
    };
    let text = String::from_utf8_lossy(&text.stdout);
    for want in [
        "Machine geometric error report",
        "Test conditions",
        "VMC 800",
        "page 1 of",
    ] {
        assert!(text.contains(want), "page 1 lacks {want:?}:\n{text}");
    }
    // Page 1 rasterised: A4 (1 : 1.414) and drawn, not blank.
    let prefix = tmp.path().join("page");
    poppler(
        "pdftoppm",
        &[
            "-f",
            "1",
            "-l",
            "1",
            "-r",
            "40",
            "-png",
            s(&pdf),
            s(&prefix),
        ],
    )
    .unwrap();
    let png = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.file_name().unwrap().to_string_lossy().starts_with("page"))
        .unwrap();
    let img = image::open(&png).unwrap().to_luma8();
    let ratio = f64::from(img.height()) / f64::from(img.width());
    assert!(
        (ratio - 297.0 / 210.0).abs() < 0.01,
        "{}×{}",
        img.width(),
        img.height()
    );
    let inked = img.pixels().filter(|p| p.0[0] < 200).count();
    assert!(
        inked * 100 > img.pixels().len(),
        "page 1 nearly blank: {inked} dark pixels"
    );
    // The copy is part of the report's set: printed again with --force, and
    // a report written without --pdf leaves no stale copy beside it.
    let args = ["--tolerances", s(&tol), "--pdf", "--force"];
    evaluate(tmp.path(), "printed", &args);
    assert!(read(&pdf).starts_with(b"%PDF-"));
    evaluate(tmp.path(), "printed", &["--force"]);
    assert!(!pdf.exists(), "a stale report.pdf beside the new report");
}

#[test]
fn pdf_without_a_browser_is_a_usage_error_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let points = tmp.path().join("points.csv");
    formats::write_csv(&points, &rows()).unwrap();
    let out = tmp.path().join("out");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .args([
            "evaluate",
            "--points",
            s(&points),
            "--pdf",
            "--out",
            s(&out),
        ])
        .env("PATH", tmp.path())
        .env("TRINOCULAR_CHROMIUM", tmp.path().join("no-such-browser"))
        .output()
        .unwrap();
    let (code, err) = failure(&run);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--pdf") && err.contains("Chromium"), "{err}");
    assert!(!out.exists());
}

/// The line's figures without U (no observations): decided by their value,
/// said so; the verdict on stderr; exit 0, or 4 with
/// `--fail-on-nonconformance` (the report written all the same).
#[test]
fn tolerances_give_decisions_a_verdict_and_exit_4_only_when_asked() {
    let tmp = tempfile::tempdir().unwrap();
    let (plain, _) = evaluate(tmp.path(), "plain", &[]);
    let figure = |k: &str| plain["axes"]["X"]["positioning"][k].as_f64().unwrap();
    let (e, r) = (figure("E_um"), figure("R_um"));
    let tol = tmp.path().join("tol.toml");
    std::fs::write(
        &tol,
        format!(
            "[X]\nE_um = {}\nR_um = {}\nstraightness_Y_um = 1\n",
            e + 0.5,
            r - 0.5
        ),
    )
    .unwrap();
    let points = tmp.path().join("points.csv");
    let run = |name: &str, extra: &[&str]| {
        let out = tmp.path().join(name);
        let mut args = vec![
            "evaluate",
            "--points",
            s(&points),
            "--tolerances",
            s(&tol),
            "--out",
            s(&out),
        ];
        args.extend(extra);
        let output = trinocular(&args);
        let report: Value = serde_json::from_slice(&read(&out.join("report.json"))).unwrap();
        let html = String::from_utf8(read(&out.join("report.html"))).unwrap();
        (output, report, html)
    };
    let (output, report, html) = run("judged", &[]);
    let err = ok(&output);
    let decisions: Vec<(String, String)> = report["conformance"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            assert_eq!(c["axis"], "X");
            (
                c["figure"].as_str().unwrap().to_string(),
                c["decision"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(
        decisions,
        [
            ("E_um".to_string(), "conforms".to_string()),
            ("R_um".to_string(), "does not conform".to_string()),
            ("straightness_Y_um".to_string(), "conforms".to_string()),
        ]
    );
    assert_eq!(report["verdict"], "does not conform");
    assert!(
        report["decision_rule"]
            .as_str()
            .unwrap()
            .contains("decided by their value alone")
    );
    let line = err
        .lines()
        .find(|l| l.contains("verdict:"))
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        line.contains("does not conform (X R_um")
            && line.contains("2 conform, 0 inconclusive, 1 do not conform"),
        "{line}"
    );
    // The page: the verdict first, each figure with its limit and decision.
    let verdict_at = html.find("id=\"verdict\"").unwrap();
    assert!(verdict_at < html.find("id=\"summary\"").unwrap());
    assert!(html.contains("Verdict: does not conform"));
    assert!(html.contains(&format!("{:.3} µm", e + 0.5)));
    // --fail-on-nonconformance: exit 4, the report written.
    let (output, report, _) = run("failing", &["--fail-on-nonconformance"]);
    assert_eq!(
        output.status.code(),
        Some(4),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert_eq!(report["verdict"], "does not conform");
    // The simple rule says so.
    let (_, report, _) = run("simple", &["--decision-rule", "simple"]);
    assert!(
        report["decision_rule"]
            .as_str()
            .unwrap()
            .starts_with("simple acceptance")
    );
    // Without --tolerances: no conformance at all.
    assert!(plain.get("conformance").is_none() && plain.get("verdict").is_none());
}

#[test]
fn bad_tolerance_files_are_refused_with_the_key_and_nothing_written() {
    refused_files(
        "--tolerances",
        "tol.toml",
        &[
            ("[X]\nQ_um = 3.0\n", "[X] Q_um: not a figure"),
            ("[W]\nA_um = 3.0\n", "[W]: not a table of figures"),
            ("[X]\nA_um = -3.0\n", "[X] A_um: the limit -3"),
            ("[X]\nA_um = nan\n", "[X] A_um: the limit NaN"),
            ("[X]\nA_um = inf\n", "[X] A_um: the limit inf"),
            ("[X]\nA_um = \"ten\"\n", "[X] A_um: \"ten\" is not a number"),
            (
                "[Y]\nA_um = 3.0\n",
                "[Y] A_um: the report has no such figure",
            ),
            (
                "flatness_um = 3.0\n",
                "flatness_um: the report has no such figure",
            ),
            ("[X\nA_um = 3.0\n", "not a tolerance file"),
        ],
    );
    let tmp = tempfile::tempdir().unwrap();
    let points = tmp.path().join("points.csv");
    formats::write_csv(&points, &rows()).unwrap();
    // Options: a rule that does not exist, and the exit-4 flag without limits.
    for args in [
        vec!["--tolerances", "tol.toml", "--decision-rule", "lenient"],
        vec!["--fail-on-nonconformance"],
    ] {
        let out = tmp.path().join("out");
        let mut all = vec!["evaluate", "--points", s(&points), "--out", s(&out)];
        all.extend(args.iter().copied());
        let (code, err) = failure(&trinocular(&all));
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(!out.exists());
    }
}

/// Each probe method's inputs (the check data), the figures a limit is set
/// on (their report paths: top level, a table, a nested table; a signed
/// one among them) and the unit suffix of their U keys.
fn probe_cases() -> Vec<(&'static str, Vec<String>, [&'static str; 2])> {
    let data = |m: &str, f: &str| s(&common::probe_data(m, f)).to_string();
    vec![
        (
            "rotary",
            vec!["--centres".into(), data("rotary", "centres.csv")],
            ["location.X0C_um", "ranges.errors.EXC_um"],
        ),
        (
            "indexing",
            vec!["--centres".into(), data("indexing", "centres.csv")],
            ["max_dA_arcsec", "rms_dB_arcsec"],
        ),
        (
            "tracer",
            vec![
                "--nominal".into(),
                data("tracer", "grid.csv"),
                "--readings".into(),
                data("tracer", "readings.csv"),
            ],
            ["max_correction_um", "rms_correction_um"],
        ),
        (
            "volumetric",
            vec![
                "--errors".into(),
                data("volumetric", "errors.csv"),
                "--at".into(),
                data("volumetric", "at.csv"),
                "--circle=-300,-200,50,100".into(),
                // The curves' standard uncertainty, for U.
                "--curve-u-um=0.5".into(),
                "--curve-u-urad=1".into(),
            ],
            ["volumetric.max_um", "circle.radial_range_um"],
        ),
    ]
}

/// `trinocular probe METHOD INPUTS --out OUT --trials 50 EXTRA…`.
fn probe(method: &str, inputs: &[String], out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["probe", method];
    args.extend(inputs.iter().map(String::as_str));
    args.extend(["--out", s(out), "--trials", "50"]);
    args.extend(extra);
    trinocular(&args)
}

/// The value at dotted `path` of a report and its U (`F_U_unit` beside it).
fn value_and_u(report: &Value, path: &str) -> (f64, f64) {
    let (table, key) = path.rsplit_once('.').unwrap_or(("", path));
    let object = table
        .split('.')
        .filter(|t| !t.is_empty())
        .fold(report, |v, t| &v[t]);
    let (stem, unit) = key.rsplit_once('_').unwrap();
    let u_key = format!("{stem}_U_{unit}");
    (
        object[key].as_f64().unwrap_or_else(|| panic!("{path}")),
        object[&u_key].as_f64().unwrap_or_else(|| panic!("{u_key}")),
    )
}

/// A tolerance file's line for `path` = `limit` (the table as its header).
fn limit_line(path: &str, limit: f64) -> String {
    match path.rsplit_once('.') {
        Some((table, key)) => format!("[{table}]\n{key} = {limit}\n"),
        None => format!("{path} = {limit}\n"),
    }
}

/// Every probe method judges its figures named as in its report: the
/// decisions are ISO 14253-1's on |value| and U as report.json states
/// them (limits set on each side of the boundaries), the verdict is on
/// stderr and the page opens with it and the conditions, exit 4 only with
/// `--fail-on-nonconformance`.
#[test]
fn probe_reports_are_judged_by_their_figure_names() {
    let tmp = tempfile::tempdir().unwrap();
    let cond = tmp.path().join("conditions.toml");
    std::fs::write(&cond, WARM).unwrap();
    for (method, inputs, [first, second]) in probe_cases() {
        let plain = tmp.path().join(format!("{method}-plain"));
        ok(&probe(method, &inputs, &plain, &[]));
        let report: Value = serde_json::from_slice(&read(&plain.join("report.json"))).unwrap();
        assert!(report.get("verdict").is_none() && report.get("conditions").is_none());
        let (v1, u1) = value_and_u(&report, first);
        let (v2, u2) = value_and_u(&report, second);
        assert!(u1 > 0.0 && u2 > 0.0, "{method}: U {u1}, {u2}");
        // The first conforms (limit beyond |v| + U), the second does not
        // (limit below |v| − U), or is inconclusive when U reaches zero.
        let l1 = v1.abs() + 1.01 * u1;
        let l2 = (v2.abs() - 1.01 * u2).max(0.0) * 0.999;
        let expected = |v: f64, u: f64, l: f64| {
            if v.abs() + u <= l {
                "conforms"
            } else if v.abs() - u > l {
                "does not conform"
            } else {
                "inconclusive"
            }
        };
        let tol = tmp.path().join(format!("{method}.toml"));
        // Tables after the top-level keys, as TOML requires.
        let mut lines = [limit_line(first, l1), limit_line(second, l2)];
        lines.sort_by_key(|l| l.starts_with('['));
        std::fs::write(&tol, lines.concat()).unwrap();
        let out = tmp.path().join(method);
        let args = ["--tolerances", s(&tol), "--conditions", s(&cond)];
        let err = ok(&probe(method, &inputs, &out, &args));
        let judged: Value = serde_json::from_slice(&read(&out.join("report.json"))).unwrap();
        let decisions = judged["conformance"].as_array().unwrap();
        assert_eq!(decisions.len(), 2, "{method}");
        for (path, v, u, l) in [(first, v1, u1, l1), (second, v2, u2, l2)] {
            let key = path.rsplit('.').next().unwrap();
            let d = decisions
                .iter()
                .find(|d| d["figure"] == key)
                .unwrap_or_else(|| panic!("{method}: {key} not judged"));
            // serde_json reads a float to within an ulp of what it wrote.
            let near = |key: &str, want: f64| {
                let got = d[key].as_f64().unwrap();
                assert!(
                    (got - want).abs() <= 1e-14 * want.abs(),
                    "{method} {path} {key}: {got} against {want}"
                );
            };
            near("value", v);
            near("U", u);
            near("limit", l);
            assert_eq!(d["decision"], expected(v, u, l), "{method} {path}");
        }
        let verdict = judged["verdict"].as_str().unwrap();
        assert_eq!(verdict, expected(v2, u2, l2), "{method}");
        assert!(
            err.contains(&format!("trinocular: verdict: {verdict}")),
            "{method}: {err}"
        );
        assert_eq!(judged["conditions"]["machine"]["model"], "VMC 800");
        assert!(
            judged["decision_rule"]
                .as_str()
                .unwrap()
                .contains("ISO 14253-1")
        );
        let page = String::from_utf8(read(&out.join("report.html"))).unwrap();
        let (at_verdict, at_conditions) = (
            page.find("id=\"verdict\"").unwrap(),
            page.find("id=\"conditions\"").unwrap(),
        );
        assert!(
            at_verdict < at_conditions,
            "{method}: the verdict comes first"
        );
        assert!(page.contains("VMC 800"), "{method}");
        // Exit 4 when asked, the report written all the same.
        let again = tmp.path().join(format!("{method}-fail"));
        let mut fail_args = args.to_vec();
        fail_args.push("--fail-on-nonconformance");
        let run = probe(method, &inputs, &again, &fail_args);
        let want = if verdict == "does not conform" { 4 } else { 0 };
        assert_eq!(
            run.status.code(),
            Some(want),
            "{method}: {}",
            common::stderr(&run)
        );
        assert!(again.join("report.json").exists());
    }
}

/// A probe tolerance file naming what the report does not have is refused
/// with the file, the key and the report's figures, before anything is
/// written.
#[test]
fn probe_tolerance_files_name_the_known_figures() {
    let tmp = tempfile::tempdir().unwrap();
    for (method, inputs, [first, _]) in probe_cases() {
        for (text, says) in [
            ("nonsense_um = 1\n".to_string(), "nonsense_um"),
            ("[nowhere]\nmax_um = 1\n".to_string(), "[nowhere]"),
            (limit_line(first, -1.0), "not a finite value ≥ 0"),
        ] {
            let tol = tmp.path().join("tol.toml");
            std::fs::write(&tol, &text).unwrap();
            let out = tmp.path().join(method);
            let (code, err) = failure(&probe(method, &inputs, &out, &["--tolerances", s(&tol)]));
            assert_eq!(code, 1, "{method} {text}: {err}");
            assert!(
                err.contains("tol.toml") && err.contains(says),
                "{method}: {err}"
            );
            if !text.contains("-1") {
                let key = first.rsplit('.').next().unwrap();
                assert!(
                    err.contains("known:") && err.contains(key),
                    "{method}: {err}"
                );
            }
            assert!(!out.exists(), "{method}: {} written", out.display());
        }
    }
}

/// `--pdf` on a probe report: report.pdf beside report.html, page 1 with
/// the verdict.
#[test]
fn probe_reports_print_their_archive_copy() {
    if report::browser::browser_or_skip("probe_reports_print_their_archive_copy")
        .unwrap()
        .is_none()
    {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let (method, inputs, [first, _]) = probe_cases().swap_remove(1);
    let tol = tmp.path().join("tol.toml");
    std::fs::write(&tol, limit_line(first, 100.0)).unwrap();
    let out = tmp.path().join("out");
    let err = ok(&probe(
        method,
        &inputs,
        &out,
        &["--tolerances", s(&tol), "--pdf"],
    ));
    assert!(err.contains("printed"), "{err}");
    let pdf = out.join("report.pdf");
    assert!(read(&pdf).starts_with(b"%PDF-"));
    let Some(text) = poppler("pdftotext", &["-f", "1", "-l", "1", s(&pdf), "-"]) else {
        return;
    };
    let text = String::from_utf8_lossy(&text.stdout);
    for want in [
        "Probe-head indexing errors",
        "Verdict: conforms",
        "page 1 of",
    ] {
        assert!(text.contains(want), "page 1 lacks {want:?}:\n{text}");
    }
    // An existing archive copy is replaced only with --force.
    let (code, again) = failure(&probe(method, &inputs, &out, &["--pdf"]));
    assert_eq!(code, 1, "{again}");
    assert!(again.contains("--force"), "{again}");
}

/// The conditions' date and equipment default to what the campaign and the
/// rig record: the images' capture times (earliest – latest, through the
/// manifest; the renderer's clock starts at its configured start time) and
/// each camera's make, model and serial with the calibration's time
/// (rig.json, from the calibration images' metadata); given ones are kept.
#[test]
fn date_and_equipment_default_to_the_images_and_the_rig() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = tmp.path().join("demo");
    ok(&trinocular(&["demo", "--out", s(&demo)]));
    let config: toml::Table =
        toml::from_str(&std::fs::read_to_string(demo.join("campaign/config.toml")).unwrap())
            .unwrap();
    let start = config["procedure"]["start_time"]
        .as_str()
        .unwrap()
        .to_string();
    let images = formats::read_csv::<formats::ManifestRow>(&demo.join("campaign/manifest.csv"))
        .unwrap()
        .len();
    let cond = tmp.path().join("conditions.toml");
    let run = |conditions: &str, name: &str| -> Value {
        std::fs::write(&cond, conditions).unwrap();
        let out = tmp.path().join(name);
        ok(&trinocular(&[
            "evaluate",
            "--points",
            s(&demo.join("points.csv")),
            "--rig",
            s(&demo.join("rig.json")),
            "--manifest",
            s(&demo.join("campaign/manifest.csv")),
            "--conditions",
            s(&cond),
            "--trials",
            "0",
            "--out",
            s(&out),
        ]));
        let report: Value = serde_json::from_slice(&read(&out.join("report.json"))).unwrap();
        let page = String::from_utf8(read(&out.join("report.html"))).unwrap();
        let machine = report["conditions"]["machine"].clone();
        for key in ["date", "equipment"] {
            let text = machine[key].as_str().unwrap();
            assert!(
                page.contains(&report::escape(text)),
                "{key} not on the page"
            );
        }
        machine
    };
    let machine = run(WARM, "defaults");
    let date = machine["date"].as_str().unwrap();
    let (first, last) = date.split_once(" – ").unwrap();
    assert!(first.starts_with(&start) && first <= last, "{date}");
    assert!(
        date.contains(&format!("capture times of {images} images")),
        "{date}"
    );
    let equipment = machine["equipment"].as_str().unwrap();
    for camera in config["rig"]["cameras"].as_array().unwrap() {
        let serial = camera["serial"].as_str().unwrap();
        assert!(
            equipment.contains(&format!("serial {serial}")),
            "{equipment}"
        );
    }
    let make = config["output"]["make"].as_str().unwrap();
    assert!(equipment.contains(make), "{equipment}");
    assert!(
        equipment.contains(&format!("calibrated {}", &start[..10])),
        "{equipment}"
    );
    // What the file says is kept.
    let given = WARM.replace(
        "[temperature]",
        "date = \"2026-11-28\"\nequipment = \"rig B\"\n[temperature]",
    );
    let machine = run(&given, "given");
    assert_eq!(machine["date"], "2026-11-28");
    assert_eq!(machine["equipment"], "rig B");
}

/// A manifest of the line's instants (one image each) with the machine's
/// temperature per instant from `t(row)`.
fn manifest_with_temperatures(path: &Path, t: impl Fn(&PointRow) -> f64) {
    let mut text = String::from(
        "image,camera,axis,direction,run,target,capture,nominal_x,nominal_y,nominal_z,machine_c\n",
    );
    for r in rows() {
        let d = if r.direction == Direction::Up {
            "+"
        } else {
            "-"
        };
        text.push_str(&format!(
            "img_{}{}{}.tif,1,X,{d},{},{},{},{},0,0,{}\n",
            r.run,
            d,
            r.target,
            r.run,
            r.target,
            r.capture,
            r.nominal_x,
            t(&r)
        ));
    }
    std::fs::write(path, text).unwrap();
}

/// Temperatures per instant (the manifest's `machine_c`): each capture is
/// corrected at its own temperature, so a mean moves by α·(mean T of its
/// captures − 20 °C)·(P − P₀); a constant column gives what the
/// conditions' single temperature gives. Without α, a disagreeing
/// instant, a value out of range or an instant without a temperature:
/// refused, naming the file.
#[test]
fn temperatures_per_instant_correct_each_capture() {
    let tmp = tempfile::tempdir().unwrap();
    let alpha_only = tmp.path().join("alpha.toml");
    std::fs::write(
        &alpha_only,
        "[temperature]\nmachine_u_c = 0.2\nexpansion_um_per_m_k = 11.5\n",
    )
    .unwrap();
    let manifest = tmp.path().join("manifest.csv");
    let (plain, _) = evaluate(tmp.path(), "plain", &[]);
    // A constant 25 °C column, the same as the conditions' 25 °C.
    manifest_with_temperatures(&manifest, |_| 25.0);
    let args = ["--conditions", s(&alpha_only), "--manifest", s(&manifest)];
    let (constant, _) = evaluate(tmp.path(), "constant", &args);
    let warm_cfg = tmp.path().join("warm.toml");
    std::fs::write(&warm_cfg, WARM).unwrap();
    let (warm, _) = evaluate(tmp.path(), "warm", &["--conditions", s(&warm_cfg)]);
    for ((_, u0, d0), (_, u1, d1)) in means(&constant).iter().zip(&means(&warm)) {
        assert!((u0 - u1).abs() < 1e-9 && (d0 - d1).abs() < 1e-9);
    }
    // A drift: the machine warms by 0.5 °C a run, and 0.1 °C per target.
    let t = |r: &PointRow| 22.0 + 0.5 * f64::from(r.run) + 0.1 * f64::from(r.target);
    manifest_with_temperatures(&manifest, t);
    let (drift, _) = evaluate(tmp.path(), "drift", &{
        let mut a = args.to_vec();
        a.push("--force");
        a
    });
    let mean_t = |k: usize, d: Direction| {
        let all: Vec<f64> = rows()
            .iter()
            .filter(|r| r.target as usize == k && r.direction == d)
            .map(t)
            .collect();
        all.iter().sum::<f64>() / all.len() as f64
    };
    for (k, ((p, u0, d0), (_, u1, d1))) in means(&plain).iter().zip(&means(&drift)).enumerate() {
        let shift = |d| -11.5e-3 * (mean_t(k, d) - 20.0) * p;
        assert!((u1 - u0 - shift(Direction::Up)).abs() < 1e-9, "↑ {p}");
        assert!((d1 - d0 - shift(Direction::Down)).abs() < 1e-9, "↓ {p}");
    }
    let all: Vec<f64> = rows().iter().map(t).collect();
    let (lo, hi) = (
        all.iter().copied().fold(f64::MAX, f64::min),
        all.iter().copied().fold(f64::MIN, f64::max),
    );
    let said = drift["conventions"].to_string();
    assert!(
        said.contains("T per instant") && said.contains(&format!("({lo}–{hi} °C)")),
        "{said}"
    );
    // Refused: the column without α (a usage error), a disagreeing
    // instant, a value out of range, an instant without a temperature.
    let points = tmp.path().join("points.csv");
    let refuse = |manifest_text: Option<&str>, conditions: &Path, code: i32, says: &str| {
        if let Some(text) = manifest_text {
            std::fs::write(&manifest, text).unwrap();
        }
        let out = tmp.path().join("refused");
        let (got, err) = failure(&trinocular(&[
            "evaluate",
            "--points",
            s(&points),
            "--conditions",
            s(conditions),
            "--manifest",
            s(&manifest),
            "--out",
            s(&out),
        ]));
        assert_eq!(got, code, "{err}");
        assert!(err.contains(says), "{err}");
        assert!(!out.exists());
    };
    let no_alpha = tmp.path().join("no_alpha.toml");
    std::fs::write(&no_alpha, "[machine]\nmaker = \"ACME\"\n").unwrap();
    refuse(None, &no_alpha, 2, "expansion_um_per_m_k");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let header = text.lines().next().unwrap();
    let first = text.lines().nth(1).unwrap();
    let (stem, _) = first.rsplit_once(',').unwrap();
    let twice = format!("{header}\n{first}\n{stem},30\n");
    refuse(Some(&twice), &alpha_only, 1, "line 3");
    let hot = format!("{header}\n{stem},80\n");
    refuse(Some(&hot), &alpha_only, 1, "machine_c");
    let one = format!("{header}\n{first}\n");
    refuse(Some(&one), &alpha_only, 1, "has no machine temperature");
}
