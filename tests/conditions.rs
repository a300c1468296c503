//! `trinocular evaluate --conditions conditions.toml`: the test conditions
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

use common::{failure, ok, read, s, trinocular};
use formats::{Axis, Direction, PointRow};
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
                rows.push(PointRow {
                    axis: Axis::X,
                    direction,
                    run,
                    target: k as u32,
                    capture: 1,
                    nominal_x: c,
                    nominal_y: 0.0,
                    nominal_z: 0.0,
                    sphere: "A".into(),
                    x: c + along_um * 1e-3,
                    y: 0.0,
                    z: 0.0,
                    cameras: "2+3".into(),
                    residual_px: 0.1,
                    u_x: None,
                    u_y: None,
                    u_z: None,
                    u_cal_x: None,
                    u_cal_y: None,
                    u_cal_z: None,
                });
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
    let tmp = tempfile::tempdir().unwrap();
    let points = tmp.path().join("points.csv");
    formats::write_csv(&points, &rows()).unwrap();
    for (text, key) in [
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
    ] {
        let cfg = tmp.path().join("conditions.toml");
        std::fs::write(&cfg, text).unwrap();
        let out = tmp.path().join("out");
        let (code, err) = failure(&trinocular(&[
            "evaluate",
            "--points",
            s(&points),
            "--conditions",
            s(&cfg),
            "--out",
            s(&out),
        ]));
        assert_eq!(code, 1, "{text}: {err}");
        assert!(
            err.contains("conditions.toml") && err.contains(key),
            "{text}: {err}"
        );
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
    evaluate(tmp.path(), "printed", &["--conditions", s(&cfg), "--pdf"]);
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
