//! `trinocular probe volumetric` and `trinocular synth probe volumetric`
//! through the binary: the docs/formats.md contract (files, columns,
//! `report.json` keys), the LinuxCNC compensation files against the format's
//! documented rules, bad input (exit status and a message naming the file,
//! line, column or flag), `--force`, and `--from-report` on vision campaigns
//! whose injected errors are known — exactly (evaluate run on the renderer's
//! exact sphere positions) and as measured by `trinocular demo`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{failure, kept_unless_forced, ok_stdout, s, trinocular};
use geom::Vector3;
use geom::nalgebra::{DMatrix, DVector};
use serde_json::Value;

fn check_data(name: &str) -> PathBuf {
    common::probe_data("volumetric", name)
}

fn read_json(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// The check data's set-up as flags.
fn check_flags() -> Vec<String> {
    let setup = read_json(&check_data("setup.json"));
    let sq = &setup["squareness_rad"];
    let t = &setup["tool_mm"];
    let c = &setup["circle"]["centre_mm"];
    vec![
        "--squareness".into(),
        format!("{},{},{}", sq["EC0Y"], sq["EB0Z"], sq["EA0Z"]),
        "--chain".into(),
        setup["chain"].as_str().unwrap().into(),
        "--tool".into(),
        format!("{},{},{}", t[0], t[1], t[2]),
        "--circle".into(),
        format!(
            "{},{},{},{}",
            c[0], c[1], c[2], setup["circle"]["radius_mm"]
        ),
    ]
}

/// The arguments of `trinocular probe volumetric` on the check data.
fn check_args(out: &Path, extra: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = vec![
        "probe".into(),
        "volumetric".into(),
        "--errors".into(),
        s(&check_data("errors.csv")).into(),
        "--at".into(),
        s(&check_data("at.csv")).into(),
        "--out".into(),
        s(out).into(),
    ];
    args.extend(check_flags());
    args.extend(extra.iter().map(|e| e.to_string()));
    args
}

fn run_check(out: &Path, extra: &[&str]) -> Output {
    let args = check_args(out, extra);
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    trinocular(&refs)
}

fn csv_rows(p: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::Reader::from_path(p).unwrap();
    let header = r.headers().unwrap().iter().map(str::to_string).collect();
    let rows = r
        .records()
        .map(|x| x.unwrap().iter().map(str::to_string).collect())
        .collect();
    (header, rows)
}

#[test]
fn check_data_through_the_binary_keeps_the_contract() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let stdout = ok_stdout(&run_check(&out, &[]));
    assert!(stdout.contains("circular deviation 7.560 µm"), "{stdout}");
    for f in [
        "report.json",
        "report.html",
        "fits.csv",
        "volumetric.csv",
        "circle.csv",
        "comp_X.txt",
        "comp_Y.txt",
        "comp_Z.txt",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // fits.csv: axis,error,model,r2,sse,rmse,emax; both models for every curve.
    let (h, rows) = csv_rows(&out.join("fits.csv"));
    assert_eq!(
        h[..7],
        ["axis", "error", "model", "r2", "sse", "rmse", "emax"]
    );
    assert_eq!(rows.len(), 3 * 6 * 2);
    let (_, want) = csv_rows(&check_data("expected_fits.csv"));
    for w in &want {
        let got = rows
            .iter()
            .find(|r| r[..3] == w[..3])
            .unwrap_or_else(|| panic!("{w:?} missing"));
        for k in 3..7 {
            let (g, e): (f64, f64) = (got[k].parse().unwrap(), w[k].parse().unwrap());
            // The expected file has 12 significant digits.
            assert!(((g - e) / e).abs() < 1e-9, "{w:?} column {k}: {g}");
        }
    }
    // volumetric.csv: x,y,z,dx,dy,dz (raw model, the default).
    let (h, rows) = csv_rows(&out.join("volumetric.csv"));
    assert_eq!(h, ["x", "y", "z", "dx", "dy", "dz"]);
    let (_, want) = csv_rows(&check_data("expected_volumetric.csv"));
    let raw: Vec<&Vec<String>> = want.iter().filter(|w| w[0] == "raw").collect();
    assert_eq!(rows.len(), raw.len());
    for (g, w) in rows.iter().zip(raw) {
        for k in 0..3 {
            let (gv, wv): (f64, f64) = (g[3 + k].parse().unwrap(), w[4 + k].parse().unwrap());
            // 1e-6 µm; the expected values have 12 significant digits (≤ 1e-14 mm).
            assert!((gv - wv).abs() < 1e-9, "{g:?} vs {w:?}");
        }
    }
    // circle.csv: angle_deg,dx,dy,dz,radial per degree.
    let (h, rows) = csv_rows(&out.join("circle.csv"));
    assert_eq!(h[..5], ["angle_deg", "dx", "dy", "dz", "radial"]);
    assert_eq!(rows.len(), 360);
    let (_, want) = csv_rows(&check_data("expected_circle.csv"));
    for (g, w) in rows.iter().zip(&want) {
        for k in 0..5 {
            let (gv, wv): (f64, f64) = (g[k].parse().unwrap(), w[k].parse().unwrap());
            assert!((gv - wv).abs() < 1e-9, "{g:?} vs {w:?}");
        }
    }
    let report = read_json(&out.join("report.json"));
    let figures = read_json(&check_data("expected_circle_figures.json"));
    for key in ["radial_range_um", "circular_deviation_um"] {
        let (g, w) = (
            report["circle"][key].as_f64().unwrap(),
            figures["raw"][key].as_f64().unwrap(),
        );
        assert!((g - w).abs() < 1e-6, "{key}: {g} vs {w}");
    }
    // The same with --model fourier, into a second folder.
    let out2 = dir.path().join("f");
    ok_stdout(&run_check(&out2, &["--model", "fourier"]));
    let report = read_json(&out2.join("report.json"));
    for key in ["radial_range_um", "circular_deviation_um"] {
        let (g, w) = (
            report["circle"][key].as_f64().unwrap(),
            figures["fourier"][key].as_f64().unwrap(),
        );
        assert!((g - w).abs() < 1e-6, "fourier {key}: {g} vs {w}");
    }
}

/// LinuxCNC `COMP_FILE` rules (docs/src/config/ini-config.adoc, `[JOINT_n]`,
/// and `usrmotLoadComp`): whitespace-separated triplets, one per line, in
/// machine units; the first value the nominal position, strictly ascending;
/// at most 256 triplets; reading stops at the first line that is not three
/// numbers, so nothing else may be in the file. Type 0: the second and third
/// values are the actual positions moving in + and in −.
fn check_comp_file(path: &Path) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.ends_with('\n'));
    let lines: Vec<[f64; 3]> = text
        .lines()
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|x| {
                    x.parse()
                        .unwrap_or_else(|_| panic!("{path:?}: '{l}' is not numbers"))
                })
                .collect();
            assert_eq!(v.len(), 3, "{path:?}: '{l}'");
            [v[0], v[1], v[2]]
        })
        .collect();
    assert!(!lines.is_empty() && lines.len() <= 256);
    assert!(
        lines.windows(2).all(|w| w[1][0] > w[0][0]),
        "{path:?}: not ascending"
    );
    lines
}

#[test]
fn compensation_files_follow_the_linuxcnc_format() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d");
    ok_stdout(&trinocular(&[
        "synth",
        "probe",
        "volumetric",
        "--out",
        s(&data),
    ]));
    let out = dir.path().join("r");
    ok_stdout(&trinocular(&[
        "probe",
        "volumetric",
        "--errors",
        s(&data.join("errors.csv")),
        "--out",
        s(&out),
    ]));
    let (_, rows) = csv_rows(&data.join("errors.csv"));
    for (axis, col) in [("X", 2), ("Y", 3), ("Z", 4)] {
        let lines = check_comp_file(&out.join(format!("comp_{axis}.txt")));
        let of_axis: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == axis).collect();
        assert_eq!(lines.len(), of_axis.len());
        for (l, r) in lines.iter().zip(of_axis) {
            let q: f64 = r[1].parse().unwrap();
            let (pos, up, down): (f64, f64, f64) = (
                r[col].parse().unwrap(),
                r[8].parse().unwrap(),
                r[9].parse().unwrap(),
            );
            // Written to 7 decimals (0.1 nm): actual = nominal + error per direction.
            assert!((l[0] - q).abs() < 1e-7);
            assert!((l[1] - (q + up)).abs() < 1e-7 && (l[2] - (q + down)).abs() < 1e-7);
            assert!(((l[1] + l[2]) / 2.0 - (q + pos)).abs() < 1e-7);
        }
    }
    let report = read_json(&out.join("report.json"));
    assert_eq!(
        report["axes"][0]["compensation_bidirectional"],
        Value::Bool(true)
    );
}

#[test]
fn outputs_refuse_to_overwrite_without_force_and_never_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let args = check_args(&out, &[]);
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let err = kept_unless_forced(&refs, &out.join("fits.csv"));
    assert!(err.contains("exists"), "{err}");
    // An output that is an input: refused even with --force.
    let inputs = dir.path().join("in");
    std::fs::create_dir_all(&inputs).unwrap();
    std::fs::copy(check_data("errors.csv"), inputs.join("fits.csv")).unwrap();
    let (code, err) = failure(&trinocular(&[
        "probe",
        "volumetric",
        "--errors",
        s(&inputs.join("fits.csv")),
        "--out",
        s(&inputs),
        "--force",
    ]));
    assert_eq!(code, 1);
    assert!(err.contains("would overwrite an input"), "{err}");
}

/// Write `E.csv` from the check data's rows, transformed by `edit`.
fn edited_errors(dir: &Path, edit: impl Fn(Vec<String>) -> Vec<String>) -> PathBuf {
    let text = std::fs::read_to_string(check_data("errors.csv")).unwrap();
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    let p = dir.join("E.csv");
    std::fs::write(&p, edit(lines).join("\n") + "\n").unwrap();
    p
}

#[test]
fn bad_input_is_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let probe = |errors: &Path, extra: &[&str]| {
        let mut a = vec![
            "probe",
            "volumetric",
            "--errors",
            s(errors),
            "--out",
            s(&out),
        ];
        a.extend_from_slice(extra);
        trinocular(&a)
    };
    let full = check_data("errors.csv");
    // An axis missing from the file (chain has Z, the file does not).
    let no_z = edited_errors(dir.path(), |l| {
        l.into_iter().filter(|x| !x.starts_with("Z,")).collect()
    });
    let (code, err) = failure(&probe(&no_z, &[]));
    assert_eq!(code, 1);
    assert!(
        err.contains("E.csv") && err.contains("axis Z") && err.contains("without error curves"),
        "{err}"
    );
    // An axis missing from the chain.
    let (code, err) = failure(&probe(&full, &["--chain", "WXYFT"]));
    assert_eq!(code, 1);
    assert!(
        err.contains("axis Z") && err.contains("not in the chain WXYFT"),
        "{err}"
    );
    // Positions not increasing: line 4 (X at 50 mm) moved before line 3.
    let swapped = edited_errors(dir.path(), |mut l| {
        l.swap(2, 3);
        l
    });
    let (code, err) = failure(&probe(&swapped, &[]));
    assert_eq!(code, 1);
    assert!(
        err.contains("E.csv: line 4, column 'position'") && err.contains("increase"),
        "{err}"
    );
    // A curve with fewer points than the coefficients of an explicit --order:
    // Z with 5 points, order 3 (without --order it takes the highest order
    // its points allow: short_campaign_runs_with_the_defaults).
    let short_z = edited_errors(dir.path(), |l| {
        let mut z = 0;
        l.into_iter()
            .filter(|x| {
                if x.starts_with("Z,") {
                    z += 1;
                    z <= 5
                } else {
                    true
                }
            })
            .collect()
    });
    let (code, err) = failure(&probe(&short_z, &["--order", "3"]));
    assert_eq!(code, 1);
    assert!(
        err.contains("E.csv: lines 48–52, axis Z: 5 points, fewer than the 7 coefficients")
            && err.contains("--order 3"),
        "{err}"
    );
    // Chain strings without W, F or T, or with a repeated axis.
    for (chain, says) in [
        ("XYFZT", "no W"),
        ("WXYZT", "no F"),
        ("WXYFZ", "no T"),
        ("WXYFXT", "axis X appears 2 times"),
    ] {
        let (code, err) = failure(&probe(&full, &["--chain", chain]));
        // A bad option value is a usage error.
        assert_eq!(code, 2);
        assert!(
            err.contains(&format!("--chain '{chain}'")) && err.contains(says),
            "{err}"
        );
    }
    // Squareness not three numbers: a usage error.
    let (code, err) = failure(&probe(&full, &["--squareness", "1e-5,2e-5"]));
    assert_eq!(code, 2);
    assert!(
        err.contains("--squareness") && err.contains("three numbers"),
        "{err}"
    );
    // A circle leaving the measured travel (X would need −100 … 100 mm).
    let (code, err) = failure(&probe(
        &full,
        &["--tool", "0,0,-100", "--circle", "0,-200,40,100"],
    ));
    assert_eq!(code, 1);
    assert!(
        err.contains("--circle")
            && err.contains("axis X")
            && err.contains("measured from 0 to 600"),
        "{err}"
    );
    // A position of --at outside the travel names the file and line.
    let at = dir.path().join("A.csv");
    std::fs::write(&at, "x,y,z\n10,10,10\n700,10,10\n").unwrap();
    let (code, err) = failure(&probe(&full, &["--at", s(&at)]));
    assert_eq!(code, 1);
    assert!(
        err.contains("A.csv: line 3") && err.contains("outside the measured travel"),
        "{err}"
    );
    // Values in µm instead of mm.
    let in_um = edited_errors(dir.path(), |mut l| {
        // Line 6: X at 100 mm with ex = −0.000487859382 mm written as µm.
        l[5] = "X,100,-4.87859382,0.00245888342,0.00141758187,-5.48047029e-06,-7.24743683e-06,-4.56755067e-06".into();
        l
    });
    let (code, err) = failure(&probe(&in_um, &[]));
    assert_eq!(code, 1);
    assert!(
        err.contains("E.csv: line 6, column 'ex'") && err.contains("µm"),
        "{err}"
    );
    assert!(!out.exists(), "nothing written on bad input");
}

/// c + ω × n fitted to vector differences d(n) (least squares, 6 unknowns):
/// a change of the workpiece frame's origin and orientation, which §5 fixes
/// by convention (x along the X motion, y in the plane of X and Y).
fn remove_frame(points: &[(Vector3<f64>, Vector3<f64>)]) -> Vec<Vector3<f64>> {
    let m = points.len() * 3;
    let mut a = DMatrix::zeros(m, 6);
    let mut b = DVector::zeros(m);
    for (i, (n, d)) in points.iter().enumerate() {
        for k in 0..3 {
            a[(3 * i + k, k)] = 1.0;
            b[3 * i + k] = d[k];
        }
        // ω × n = (ωy·nz − ωz·ny, ωz·nx − ωx·nz, ωx·ny − ωy·nx)
        a[(3 * i, 4)] = n.z;
        a[(3 * i, 5)] = -n.y;
        a[(3 * i + 1, 3)] = -n.z;
        a[(3 * i + 1, 5)] = n.x;
        a[(3 * i + 2, 3)] = n.y;
        a[(3 * i + 2, 4)] = -n.x;
    }
    let x = a.clone().svd(true, true).solve(&b, 1e-12).unwrap();
    let r = b - a * x;
    (0..points.len())
        .map(|i| Vector3::new(r[3 * i], r[3 * i + 1], r[3 * i + 2]))
        .collect()
}

/// The true table error (δ mm, ε rad) at target `k` of the main line of
/// `axis` from truth.json's injected errors (no random offsets; the mean of
/// the two approach directions), with the other axis standing at the line.
fn true_error(errors: &Value, axis: &str, k: usize) -> (Vector3<f64>, Vector3<f64>) {
    let t = &errors[axis]["targets"][k];
    let f = |key: &str| t[key].as_f64().unwrap();
    let pos = (f("positioning_up_um") + f("positioning_down_um")) / 2.0;
    let (delta, eps) = if axis == "X" {
        (
            Vector3::new(pos, f("straightness_Y_um"), f("straightness_Z_um")),
            // X: roll about X, pitch about Y, yaw about Z.
            Vector3::new(f("roll_urad"), f("pitch_urad"), f("yaw_urad")),
        )
    } else {
        (
            Vector3::new(f("straightness_X_um"), pos, f("straightness_Z_um")),
            // Y: roll about Y, pitch about X, yaw about Z.
            Vector3::new(f("pitch_urad"), f("roll_urad"), f("yaw_urad")),
        )
    };
    let line = &errors[axis]["lines"][0];
    let v = |key: &str| {
        let a = line[key].as_array().unwrap();
        Vector3::new(
            a[0].as_f64().unwrap(),
            a[1].as_f64().unwrap(),
            a[2].as_f64().unwrap(),
        )
    };
    (
        (delta + v("other_axes_delta_um")) * 1e-3,
        (eps + v("other_axes_epsilon_urad")) * 1e-6,
    )
}

/// The tool point of the `--from-report` tests: above the table, off the
/// spheres, so that every rotation acts with a lever of 50–150 mm.
const TOOL: [f64; 3] = [20.0, -10.0, 100.0];

/// A measured position n with the predicted and the true volumetric error (mm).
type Compared = (Vector3<f64>, Vector3<f64>, Vector3<f64>);

/// Run `--from-report report_dir` with chain WXYFT at the targets of the
/// main X and Y lines; return (n, predicted Δ, true Δ) per target, both in mm.
fn from_report(report_dir: &Path, errors: &Value, out: &Path) -> (Vec<Compared>, Value) {
    let mut targets = Vec::new();
    for axis in ["X", "Y"] {
        for (k, t) in errors[axis]["targets"]
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
        {
            let q = t["position_mm"].as_f64().unwrap();
            let n = if axis == "X" {
                Vector3::new(q, 0.0, 0.0)
            } else {
                Vector3::new(0.0, q, 0.0)
            };
            targets.push((axis, k, n));
        }
    }
    let at = out.with_extension("at.csv");
    let mut text = String::from("x,y,z\n");
    for (_, _, n) in &targets {
        text.push_str(&format!("{},{},{}\n", n.x, n.y, n.z));
    }
    std::fs::write(&at, text).unwrap();
    let tool = format!("{},{},{}", TOOL[0], TOOL[1], TOOL[2]);
    ok_stdout(&trinocular(&[
        "probe",
        "volumetric",
        "--from-report",
        s(report_dir),
        "--chain",
        "WXYFT",
        "--tool",
        &tool,
        "--at",
        s(&at),
        "--order",
        "1",
        "--out",
        s(out),
    ]));
    let (_, rows) = csv_rows(&out.join("volumetric.csv"));
    let t = Vector3::from(TOOL);
    let rows = targets
        .iter()
        .zip(rows)
        .map(|((axis, k, n), r)| {
            let d: Vec<f64> = r[3..6].iter().map(|v| v.parse().unwrap()).collect();
            let (delta, eps) = true_error(errors, axis, *k);
            // The table point under the tool is t − n: Δ = −(δ + ε × (t − n)).
            let truth = -(delta + eps.cross(&(t - n)));
            (*n, Vector3::new(d[0], d[1], d[2]), truth)
        })
        .collect();
    (rows, read_json(&out.join("report.json")))
}

/// Least-squares line removed from values at positions.
fn without_line(q: &[f64], v: &[f64]) -> Vec<f64> {
    let n = q.len() as f64;
    let (mq, mv) = (q.iter().sum::<f64>() / n, v.iter().sum::<f64>() / n);
    let k = q
        .iter()
        .zip(v)
        .map(|(a, b)| (a - mq) * (b - mv))
        .sum::<f64>()
        / q.iter().map(|a| (a - mq) * (a - mq)).sum::<f64>();
    q.iter()
        .zip(v)
        .map(|(a, b)| b - mv - k * (a - mq))
        .collect()
}

#[test]
fn from_report_on_exact_positions_follows_the_conventions() {
    // The renderer's exact sphere positions (truth_points.csv of `synth
    // campaign`) of a machine without repeatability or capture noise (the
    // default configuration with those three keys zeroed), evaluated by
    // `trinocular evaluate`. 11 targets: x = 0 and y = 0 are targets.
    let dir = tempfile::tempdir().unwrap();
    let config = ok_stdout(&trinocular(&["synth", "config"]))
        .lines()
        .map(|l| {
            let key = l.split('=').next().unwrap_or("").trim();
            if [
                "repeatability_um",
                "repeatability_perp_um",
                "capture_noise_um",
            ]
            .contains(&key)
            {
                format!("{key} = 0.0")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        config.matches(" = 0.0").count() >= 6,
        "three keys per axis zeroed"
    );
    let toml = dir.path().join("exact.toml");
    std::fs::write(&toml, config).unwrap();
    let campaign = dir.path().join("campaign");
    ok_stdout(&trinocular(&[
        "synth",
        "campaign",
        "--config",
        s(&toml),
        "--width",
        "320",
        "--height",
        "240",
        "--targets",
        "11",
        "--runs",
        "2",
        "--captures",
        "1",
        "--out",
        s(&campaign),
    ]));
    let eval = dir.path().join("eval");
    ok_stdout(&trinocular(&[
        "evaluate",
        "--points",
        s(&campaign.join("truth_points.csv")),
        "--out",
        s(&eval),
    ]));
    let errors = read_json(&campaign.join("truth.json"))["errors"].clone();

    let (rows, out) = from_report(&eval, &errors, &dir.path().join("r"));
    // The curves, sign by sign (µm, µrad): positioning and rotations are zero
    // where the other axis's line crosses (x = 0 for X, y = 0 for Y);
    // straightness keeps its least-squares line removed. Rotations are about
    // the machine origin: the Abbe terms of sphere A at 30 mm above the
    // table reference are gone from the translations.
    for (i, axis) in ["X", "Y"].into_iter().enumerate() {
        let targets = errors[axis]["targets"].as_array().unwrap();
        let f =
            |key: &str| -> Vec<f64> { targets.iter().map(|t| t[key].as_f64().unwrap()).collect() };
        let q = f("position_mm");
        let zero = q.iter().position(|v| *v == 0.0).unwrap();
        let at_zero = |v: Vec<f64>| -> Vec<f64> { v.iter().map(|x| x - v[zero]).collect() };
        let pos: Vec<f64> = f("positioning_up_um")
            .iter()
            .zip(f("positioning_down_um"))
            .map(|(u, d)| (u + d) / 2.0)
            .collect();
        let (along, across) = if axis == "X" {
            (0, ["Y", "Z"])
        } else {
            (1, ["X", "Z"])
        };
        let mut want: [Vec<f64>; 6] = Default::default();
        want[along] = at_zero(pos);
        for o in across {
            let k = ["X", "Y", "Z"].iter().position(|a| *a == o).unwrap();
            want[k] = without_line(&q, &f(&format!("straightness_{o}_um")));
        }
        let (roll, pitch, yaw) = (
            at_zero(f("roll_urad")),
            at_zero(f("pitch_urad")),
            at_zero(f("yaw_urad")),
        );
        // X: ea = roll, eb = pitch, ec = yaw; Y: ea = pitch, eb = roll, ec = yaw.
        if axis == "X" {
            (want[3], want[4], want[5]) = (roll, pitch, yaw);
        } else {
            (want[3], want[4], want[5]) = (pitch, roll, yaw);
        }
        let curves = out["axes"][i]["curves"].as_array().unwrap();
        for (m, w) in want.iter().enumerate() {
            let got: Vec<f64> = curves[m]["values"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            let worst = got
                .iter()
                .zip(w)
                .map(|(g, w)| (g - w).abs())
                .fold(0.0, f64::max);
            // Exact but for the first-order motion of the renderer against
            // Kabsch's rotations: far below 1 nm and 0.001 µrad.
            assert!(
                worst < 1e-3,
                "{axis} {}: {worst} off\n{got:?}\n{w:?}",
                curves[m]["error"]
            );
        }
    }
    // Squareness: the synthetic machine's X and Y least-squares directions.
    let ec0y = out["squareness_urad"]["EC0Y"].as_f64().unwrap();
    assert!(ec0y.abs() < 100.0, "{ec0y}");

    // Volumetric errors at the measured positions against the truth, after
    // the frame convention (c + ω × n) is taken out.
    let diffs: Vec<(Vector3<f64>, Vector3<f64>)> =
        rows.iter().map(|(n, p, t)| (*n, p - t)).collect();
    let residual = remove_frame(&diffs);
    let worst = residual.iter().map(|r| r.norm()).fold(0.0, f64::max) * 1e3;
    let size = rows.iter().map(|(_, _, t)| t.norm()).fold(0.0, f64::max) * 1e3;
    println!("exact positions: volumetric residual {worst:.5} µm of errors up to {size:.2} µm");
    assert!(size > 2.0, "the errors are not negligible");
    assert!(worst < 1e-3, "{worst} µm");
}

#[test]
fn from_report_on_a_demo_campaign_agrees_within_its_accuracy() {
    // docs/probe-methods.md's example of `--from-report`, run as written in a fresh
    // folder: `trinocular demo` (into ./trinocular-demo), then
    // `trinocular probe volumetric --from-report trinocular-demo/report --out vol`.
    let dir = tempfile::tempdir().unwrap();
    let in_dir = |args: &[&str]| {
        common::bin()
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    ok_stdout(&in_dir(&["demo"]));
    let demo = dir.path().join("trinocular-demo");
    let readme = in_dir(&[
        "probe",
        "volumetric",
        "--from-report",
        "trinocular-demo/report",
        "--out",
        "vol",
    ]);
    let note = common::ok(&readme);
    assert!(note.contains("note: chain WXYFT"), "{note}");
    assert_eq!(
        read_json(&dir.path().join("vol/report.json"))["chain"],
        "WXYFT"
    );
    let truth = read_json(&demo.join("campaign/truth.json"));
    let (rows, out) = from_report(
        &demo.join("report"),
        &truth["errors"],
        &dir.path().join("r"),
    );
    let diffs: Vec<(Vector3<f64>, Vector3<f64>)> =
        rows.iter().map(|(n, p, t)| (*n, p - t)).collect();
    let residual = remove_frame(&diffs);
    let rms = (residual.iter().map(|r| r.norm_squared()).sum::<f64>() / residual.len() as f64)
        .sqrt()
        * 1e3;
    let worst = residual.iter().map(|r| r.norm()).fold(0.0, f64::max) * 1e3;
    println!(
        "demo campaign: volumetric residual {rms:.2} µm RMS, {worst:.2} µm worst over {} positions; EC0Y {:.1} µrad",
        rows.len(),
        out["squareness_urad"]["EC0Y"]
    );
    // The demo's accuracy at its 1024-px scale (tests/demo.rs): sphere
    // displacements ≤ 4 µm RMS, roll/pitch/yaw within 20 µrad. A volumetric
    // error adds the rotation error times the lever from the sphere to the
    // tool, here ≤ 0.13 m: 4 µm + 20 µrad × 0.13 m ≈ 6.6 µm per point.
    let lever = rows
        .iter()
        .map(|(n, _, _)| (Vector3::from(TOOL) - n - Vector3::new(0.0, 0.0, 30.0)).norm())
        .fold(0.0, f64::max);
    let allowance = 4.0 + 20.0 * lever * 1e-3;
    assert!(rms <= 4.0, "{rms} µm RMS");
    assert!(worst <= allowance, "{worst} µm > {allowance} µm");
}

/// `points.csv` of a campaign that swept X (at y = 0) and Y (at x = 0), 2
/// runs each way, with known error motions: sphere set A (0, 0, 30),
/// B (20, 20, 50), C (−15, −15, 45) mm translated by a positioning error
/// 2 µm·sin(q/30 mm) and a straightness 1 µm·(q/50 mm)² across, turned by a
/// yaw 5 µrad·q/50 mm about the sphere set's origin.
fn xy_campaign_points() -> String {
    let spheres = [
        ("A", Vector3::new(0.0, 0.0, 30.0)),
        ("B", Vector3::new(20.0, 20.0, 50.0)),
        ("C", Vector3::new(-15.0, -15.0, 45.0)),
    ];
    let mut text = String::from(
        "axis,direction,run,target,capture,nominal_x,nominal_y,nominal_z,sphere,x,y,z,cameras,residual_px\n",
    );
    for (axis, targets) in [("X", 11), ("Y", 9)] {
        let along = if axis == "X" { 0 } else { 1 };
        for (direction, runs) in [("+", [1, 2]), ("-", [1, 2])] {
            for run in runs {
                for k in 0..targets {
                    let q = -50.0 + 10.0 * k as f64;
                    let mut nominal = Vector3::zeros();
                    nominal[along] = q;
                    let mut error = Vector3::zeros();
                    error[along] = 2e-3 * (q / 30.0).sin();
                    error[1 - along] = 1e-3 * (q / 50.0).powi(2);
                    let yaw = 5e-6 * q / 50.0;
                    for (name, s) in &spheres {
                        let turned = Vector3::new(-yaw * s.y, yaw * s.x, 0.0);
                        let p = nominal + s + error + turned;
                        text.push_str(&format!(
                            "{axis},{direction},{run},{k},1,{},{},0,{name},{},{},{},truth,0\n",
                            nominal.x, nominal.y, p.x, p.y, p.z
                        ));
                    }
                }
            }
        }
    }
    text
}

#[test]
fn from_report_of_an_xy_campaign_takes_the_chain_of_its_axes() {
    // Issue 23, defect 6: the default chain WXYFZT asked for Z curves a vision
    // campaign of X and Y does not have. Without --chain the chain keeps the
    // axes with curves, WXYFT, says so on stderr and in the report, and the
    // model equals the one of `--chain WXYFT`.
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("points.csv");
    std::fs::write(&points, xy_campaign_points()).unwrap();
    let eval = dir.path().join("report");
    ok_stdout(&trinocular(&[
        "evaluate",
        "--points",
        s(&points),
        "--out",
        s(&eval),
    ]));
    let run = |out: &Path, extra: &[&str]| {
        let mut a = vec![
            "probe",
            "volumetric",
            "--from-report",
            s(&eval),
            "--circle",
            "0,0,0,30",
            "--out",
            s(out),
        ];
        a.extend_from_slice(extra);
        trinocular(&a)
    };
    let default = dir.path().join("default");
    let out = run(&default, &[]);
    let err = common::ok(&out);
    assert!(
        err.contains("chain WXYFT") && err.contains("without Z"),
        "stderr: {err}"
    );
    let report = read_json(&default.join("report.json"));
    assert_eq!(report["chain"], "WXYFT");
    let axes: Vec<&str> = report["axes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["axis"].as_str().unwrap())
        .collect();
    assert_eq!(axes, ["X", "Y"]);
    let notes = report["campaign"]["notes"].as_array().unwrap();
    assert!(
        notes.iter().any(|n| n
            .as_str()
            .unwrap()
            .starts_with("chain WXYFT: the default WXYFZT without Z")),
        "{notes:?}"
    );
    assert!(
        std::fs::read_to_string(default.join("report.html"))
            .unwrap()
            .contains("chain WXYFT: the default WXYFZT without Z")
    );
    // The same model as the explicit chain; only the note differs.
    let explicit = dir.path().join("explicit");
    let err = common::ok(&run(&explicit, &["--chain", "WXYFT"]));
    assert!(!err.contains("note:"), "{err}");
    let mut with_chain = read_json(&explicit.join("report.json"));
    let mut without = report.clone();
    without["campaign"]["notes"] = Value::Null;
    with_chain["campaign"]["notes"] = Value::Null;
    assert_eq!(without, with_chain);
    for name in ["fits.csv", "circle.csv", "comp_X.txt", "comp_Y.txt"] {
        assert_eq!(
            common::read(&default.join(name)),
            common::read(&explicit.join(name)),
            "{name}"
        );
    }
    // A chain that names an axis without curves is still refused, clearly.
    let (code, err) = failure(&run(&dir.path().join("z"), &["--chain", "WXYFZT"]));
    assert_eq!(code, 1);
    assert!(
        err.contains("axis Z") && err.contains("in the chain WXYFZT but without error curves"),
        "{err}"
    );
}

/// stderr lines of `out` that are warnings.
fn warnings(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| l.contains("warning:"))
        .map(str::to_string)
        .collect()
}

#[test]
fn short_campaign_runs_with_the_defaults() {
    // Issue 39, item 5: a campaign of 4 targets per axis failed under the
    // defaults ("4 points, fewer than the 7 coefficients of a fourier of
    // order 3"), under --model raw and --order auto, and said the report gave
    // no U. Now: the highest order the points allow, said per axis; no R²
    // warning on those fits; the readings' u from the report's U, so every
    // figure gets its U.
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("demo");
    ok_stdout(&trinocular(&[
        "demo",
        "--targets",
        "4",
        "--width",
        "640",
        "--out",
        s(&demo),
    ]));
    let report = demo.join("report");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut a = vec![
            "probe",
            "volumetric",
            "--from-report",
            s(&report),
            "--circle",
            "0,0,0,20",
            "--out",
            s(&out),
        ];
        a.extend_from_slice(extra);
        (trinocular(&a), out)
    };
    let mut default_err = String::new();
    for (name, extra, why) in [
        ("default", &[][..], "too few for the default order 3"),
        (
            "raw",
            &["--model", "raw"][..],
            "too few for the default order 3",
        ),
        (
            "auto",
            &["--order", "auto"][..],
            "too few to cross-validate an order",
        ),
    ] {
        let (output, out) = run(name, extra);
        let err = common::ok(&output);
        if name == "default" {
            default_err = err.clone();
        }
        for axis in ["X", "Y"] {
            let note = format!("note: axis {axis}: 4 points, {why}");
            let line = err.lines().find(|l| l.contains(&note));
            let line = line.unwrap_or_else(|| panic!("{name}: no '{note}' in {err}"));
            assert!(
                line.contains("fourier N = 1, polynomial N = 1"),
                "{name}: {line}"
            );
        }
        assert!(warnings(&output).is_empty(), "{name}: {err}");
        assert!(
            err.contains(
                "note: the curves' readings take their uncertainty from the evaluate report"
            ),
            "{err}"
        );
        let r = read_json(&out.join("report.json"));
        assert_eq!(r["notes"].as_array().unwrap().len(), 2, "{name}");
        for f in &r["fits"].as_array().unwrap()[..] {
            assert_eq!(f["order"], 1, "{name}: {f}");
        }
        // U from the report: every figure has one, and the source says where from.
        assert!(
            r["uncertainty"].get("reason").is_none(),
            "{name}: {}",
            r["uncertainty"]
        );
        let u = r["circle"]["circular_deviation_U_um"].as_f64().unwrap();
        assert!(u > 0.0, "{name}: {u}");
        let source = r["uncertainty"]["sources"]["curves"].as_str().unwrap();
        assert!(source.contains("evaluate report"), "{source}");
    }
    // The translation u is U/(2√2) of the largest range U of the report.
    let eval = read_json(&report.join("report.json"));
    let mut largest: f64 = 0.0;
    for axis in ["X", "Y"] {
        let a = &eval["axes"][axis];
        largest = largest.max(a["positioning"]["M_U_um"].as_f64().unwrap());
        for s in a["straightness"].as_object().unwrap().values() {
            largest = largest.max(s["lsq_U_um"].as_f64().unwrap());
        }
    }
    let want = format!(
        "{:.3} µm → {:.3} µm (translations)",
        largest,
        largest / 8f64.sqrt()
    );
    assert!(default_err.contains(&want), "{want} not in {default_err}");
    // The flags override the report.
    let (output, _) = run("flags", &["--curve-u-um", "0.1", "--curve-u-urad", "1"]);
    assert!(!common::ok(&output).contains("readings take their uncertainty"));
    // An explicit order the points cannot carry is still refused, clearly.
    let (output, _) = run("three", &["--order", "3", "--chain", "WXYFT"]);
    let (code, err) = failure(&output);
    assert_eq!(code, 1);
    assert!(
        err.contains("4 points, fewer than the 7 coefficients"),
        "{err}"
    );
}

#[test]
fn the_generators_next_command_runs_without_warnings() {
    // Issue 39, item 5: the generator's printed next: command gave 9 R²
    // warnings. Under the raw model (its default) the predictions keep the
    // measured values: no fit is judged. Under --model fourier the fits are
    // the model, and a warning stands only where the residual is significant
    // against the readings' u (0.05 µm, 0.05 µrad): the generator's waves of
    // non-integer cycle counts leave 0.5–1.7 µm (µrad) beside an order-3 series.
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d");
    let printed = ok_stdout(&trinocular(&[
        "synth",
        "probe",
        "volumetric",
        "--out",
        s(&data),
    ]));
    let next = printed
        .lines()
        .find_map(|l| l.strip_prefix("next: trinocular "))
        .unwrap();
    let out = dir.path().join("r");
    let args: Vec<String> = next
        .replace("<DIR>", s(&out))
        .split_whitespace()
        .map(str::to_string)
        .collect();
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let output = trinocular(&refs);
    let err = common::ok(&output);
    assert!(warnings(&output).is_empty(), "{err}");
    assert!(!err.contains("note: axis"), "{err}");
    assert_eq!(
        read_json(&out.join("report.json"))["warnings"],
        Value::Array(vec![])
    );
    let mut fourier = refs.clone();
    fourier.extend(["--model", "fourier", "--force"]);
    let output = trinocular(&fourier);
    let w = warnings(&output);
    assert!(!w.is_empty(), "{}", common::ok(&output));
    for line in &w {
        let rms: f64 = line
            .split("residual RMS ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("{line}"));
        assert!(rms > 5.0 * 0.05, "{line}");
    }
}
