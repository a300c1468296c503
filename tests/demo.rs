//! End to end through the binary: `trinocular demo` renders a campaign with
//! injected errors, calibrates the cameras from the rendered target (the rig
//! starts from the nominal one, off by degrees and millimetres), measures,
//! evaluates; the results are judged against the renderer's truth.
//!
//! Scale: 1024×768 px instead of 4096×3072 with the seed's lens and field of
//! view, so a pixel covers 4× more of the table (≈ 0.23 mm). Centroid noise in
//! pixels is the same at both scales, so errors in mm grow by 4: the
//! full-resolution requirements (sphere-A displacements ≤ 1 µm RMS; ISO 230-2
//! A, E, R and straightness within 0.5 µm of the truth figures; roll, pitch,
//! yaw within 5 µrad) become 4 µm, 2 µm and 20 µrad here.
//!
//! The demo is deterministic (its seed is fixed), so each tolerance is twice
//! what this campaign measured (printed by the test, quoted in docs/measuring.md):
//! 1.59 µm RMS; ISO 230-2 within 0.73 µm; straightness within 0.70 µm;
//! flatness within 0.20 µm; roll, pitch, yaw per target within 30.3 µrad (a
//! short campaign: 8 instants per target, σ ≈ 25–28 µrad per instant, the
//! sphere set's shortest lever 8 mm).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use formats::{PointRow, PoseRow, read_csv, read_json};
use serde_json::Value;

fn rows<T: formats::Record>(p: &Path) -> Vec<T> {
    read_csv(p).unwrap().into_iter().map(|r| r.record).collect()
}

fn get(v: &Value, path: &str) -> f64 {
    v.pointer(path)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("{path} missing"))
}

#[test]
fn demo_measures_the_injected_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let run = Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .args([
            "demo",
            "--out",
            out.to_str().unwrap(),
            "--width",
            "1024",
            "--targets",
            "5",
            "--runs",
            "2",
            "--captures",
            "2",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}\n{}",
        stdout,
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        stdout.contains("measured") && stdout.contains("true"),
        "{stdout}"
    );
    for f in [
        "rig.json",
        "points.csv",
        "points.poses.csv",
        "report/report.json",
        "report/report.html",
        "campaign/truth.json",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    assert_eq!(
        std::fs::read_to_string(out.join("points.problems.csv"))
            .unwrap()
            .lines()
            .count(),
        1,
        "some instants could not be measured"
    );
    // The lenses' relative illumination was measured from the flat fields,
    // and the commissioning report says what a user must capture.
    let rig: Value = read_json(&out.join("rig.json")).unwrap();
    for c in rig["cameras"].as_array().unwrap() {
        let ri = &c["relative_illumination"];
        assert_eq!(ri["model"], "radial", "camera {}: {ri}", c["id"]);
        assert!(
            ri["flat_field"]
                .as_str()
                .unwrap()
                .ends_with(&format!("flat_cam{}.tif", c["id"]))
        );
    }
    let commissioning = std::fs::read_to_string(out.join("rig.commissioning.txt")).unwrap();
    assert!(
        commissioning.contains("relative illumination measured from the flat field")
            && commissioning.contains("Capture per"),
        "{commissioning}"
    );

    // Each step's printed command reruns it as written (issue 39: they
    // lacked --force and failed on the demo's own outputs).
    let said = String::from_utf8_lossy(&run.stderr);
    let evaluate = said
        .lines()
        .find_map(|l| l.strip_prefix("$ trinocular evaluate "))
        .unwrap_or_else(|| panic!("no evaluate step printed: {said}"));
    let rerun = Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .arg("evaluate")
        .args(evaluate.split(' '))
        .output()
        .unwrap();
    assert!(
        rerun.status.success(),
        "trinocular evaluate {evaluate}: {}",
        String::from_utf8_lossy(&rerun.stderr)
    );

    let f = judge(&out);
    assert!(f.rms_um <= 2.0 * 1.59, "{f:?}");
    assert!(f.iso_um <= 2.0 * 0.73, "{f:?}");
    assert!(f.straightness_um <= 2.0 * 0.70, "{f:?}");
    assert!(f.flatness_um <= 2.0 * 0.20, "{f:?}");
    assert!(f.angular_urad <= 2.0 * 30.3, "{f:?}");
}

/// A second demo into a folder that holds files is refused at once, for the
/// command the user typed, before anything is rendered (issue 39: its inner
/// step asked for --force after announcing the frames).
#[test]
fn a_demo_into_a_used_folder_asks_for_force_at_the_start() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("points.csv"), "an earlier run's\n").unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .args(["demo", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{said}");
    assert_eq!(said.trim_end().lines().count(), 1, "{said}");
    assert!(said.contains("--force") && said.contains("demo"), "{said}");
    assert_eq!(
        std::fs::read_dir(&out).unwrap().count(),
        1,
        "the demo wrote into the used folder"
    );
}

/// The demo's largest differences from the truth.
#[derive(Debug)]
struct Figures {
    /// Sphere-A displacements, RMS (µm).
    rms_um: f64,
    /// ISO 230-2 A, E, R (µm).
    iso_um: f64,
    /// Straightness, LSQ and minimum zone (µm).
    straightness_um: f64,
    /// Flatness, LSQ and minimum zone (µm).
    flatness_um: f64,
    /// Roll, pitch and yaw per target on each axis's main line (µrad).
    angular_urad: f64,
}

/// The demo's results in `out` against the renderer's truth.
fn judge(out: &Path) -> Figures {
    // Sphere-A displacements against the truth, per line from its first instant.
    let measured: Vec<PointRow> = rows(&out.join("points.csv"));
    let truth: Vec<PointRow> = rows(&out.join("campaign/truth_points.csv"));
    let errors = synth::truth::displacement_errors(&measured, &truth, "A");
    let rms_um = synth::truth::rms(&errors).unwrap() * 1e3;
    println!(
        "sphere A displacement error: {rms_um:.2} µm RMS over {} instants",
        errors.len()
    );
    assert_eq!(errors.len() * 3, measured.len());

    // ISO 230-2 and straightness against the figures of the exact positions.
    let report: Value = read_json(&out.join("report/report.json")).unwrap();
    let truth_json: Value = read_json(&out.join("campaign/truth.json")).unwrap();
    let figures = &truth_json["figures"];
    let (mut iso, mut straightness) = (0.0_f64, 0.0_f64);
    for axis in ["X", "Y"] {
        for k in ["A_um", "E_um", "R_um"] {
            let p = format!("/axes/{axis}/positioning/{k}");
            let (m, t) = (get(&report, &p), get(figures, &p));
            println!("{axis} {k}: measured {m:.2}, true {t:.2}");
            iso = iso.max((m - t).abs());
        }
        let dirs: Vec<String> = report
            .pointer(&format!("/axes/{axis}/straightness"))
            .unwrap()
            .as_object()
            .unwrap()
            .keys()
            .cloned()
            .collect();
        assert_eq!(dirs.len(), 2);
        for d in dirs {
            for k in ["lsq_um", "min_zone_um"] {
                let p = format!("/axes/{axis}/straightness/{d}/{k}");
                let (m, t) = (get(&report, &p), get(figures, &p));
                straightness = straightness.max((m - t).abs());
            }
        }
    }

    let mut flatness = 0.0_f64;
    for k in ["lsq_um", "min_zone_um"] {
        let p = format!("/flatness/{k}");
        flatness = flatness.max((get(&report, &p) - get(figures, &p)).abs());
    }
    println!(
        "ISO 230-2 within {iso:.2} µm, straightness within {straightness:.2} µm, flatness within {flatness:.2} µm"
    );

    // Roll, pitch, yaw per target against the truth; the scatter of the
    // instants' poses at a target (σ of one instant) is printed beside.
    let poses: Vec<PoseRow> = rows(&out.join("points.poses.csv"));
    let mut angular = 0.0_f64;
    for axis in ["X", "Y"] {
        let main = report
            .pointer(&format!("/axes/{axis}/angular/targets"))
            .unwrap()
            .as_array()
            .unwrap()
            .clone();
        let exact = figures
            .pointer(&format!("/axes/{axis}/angular/targets"))
            .unwrap()
            .as_array()
            .unwrap()
            .clone();
        // Main line's off-axis coordinate: where the report says it is.
        let line: Vec<&PoseRow> = poses
            .iter()
            .filter(|p| {
                p.axis.name() == axis
                    && (if axis == "X" {
                        p.nominal_y
                    } else {
                        p.nominal_x
                    }) == 0.0
            })
            .collect();
        let mut by_target: BTreeMap<u32, Vec<[f64; 3]>> = BTreeMap::new();
        for p in &line {
            by_target
                .entry(p.target)
                .or_default()
                .push([p.roll, p.pitch, p.yaw]);
        }
        let (mut var, mut dof, mut per) = (0.0, 0usize, 0usize);
        for v in by_target.values() {
            for c in 0..3 {
                let m = v.iter().map(|x| x[c]).sum::<f64>() / v.len() as f64;
                var += v.iter().map(|x| (x[c] - m).powi(2)).sum::<f64>();
            }
            dof += 3 * (v.len() - 1);
            per = v.len();
        }
        let sigma_urad = (var / dof as f64).sqrt() * 1e6;
        let mut worst = 0.0_f64;
        for (m, t) in main.iter().zip(&exact) {
            for k in ["roll_urad", "pitch_urad", "yaw_urad"] {
                worst = worst.max((m[k].as_f64().unwrap() - t[k].as_f64().unwrap()).abs());
            }
        }
        println!(
            "{axis}: roll, pitch, yaw per target within {worst:.1} µrad; σ per instant {sigma_urad:.1} µrad ({per} instants per target)"
        );
        angular = angular.max(worst);
    }
    Figures {
        rms_um,
        iso_um: iso,
        straightness_um: straightness,
        flatness_um: flatness,
        angular_urad: angular,
    }
}

/// The full-resolution demo the README quotes (4096×3072 px, 4 targets, 3
/// runs, 3 captures: 648 frames, ≈ 17 GB, ≈ 10 minutes on 2 cores):
/// `cargo test --release --test demo -- --ignored --nocapture`. Last result
/// (README): 0.34 µm RMS; ISO 230-2 within 0.11 µm; straightness within
/// 0.12 µm; flatness within 0.03 µm; roll, pitch, yaw per target within
/// 3.3 µrad. Each allowed twice.
#[test]
#[ignore = "long: the full-resolution demo, 17 GB of frames (README)"]
fn full_resolution_demo() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("full");
    let run = Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .args(["demo", "--out", out.to_str().unwrap(), "--width", "4096"])
        .args(["--targets", "4", "--runs", "3", "--captures", "3"])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let f = judge(&out);
    assert!(f.rms_um <= 2.0 * 0.34, "{f:?}");
    assert!(f.iso_um <= 2.0 * 0.11, "{f:?}");
    assert!(f.straightness_um <= 2.0 * 0.12, "{f:?}");
    assert!(f.flatness_um <= 2.0 * 0.03, "{f:?}");
    assert!(f.angular_urad <= 2.0 * 3.3, "{f:?}");
}

/// The table the README prints is the default demo's own output: the
/// figures measured from the rendered images beside the true ones, and the
/// sphere-A line. `TRINOCULAR_BLESS=1 cargo test --test demo readme` writes
/// the demo's table into the README when the demo changes on purpose.
#[test]
fn readme_shows_the_default_demos_table() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let run = Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .args(["demo", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let table = demo_table(&stdout).unwrap_or_else(|| panic!("no table in {stdout}"));

    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let readme = std::fs::read_to_string(&path).unwrap();
    let start = readme
        .find("```\nfigure (µm, µrad)")
        .expect("the README's demo table")
        + "```\n".len();
    let end = start + readme[start..].find("```").expect("the table's end");
    if std::env::var_os("TRINOCULAR_BLESS").is_some() {
        let blessed = format!("{}{table}{}", &readme[..start], &readme[end..]);
        std::fs::write(&path, blessed).unwrap();
    } else {
        assert_eq!(
            readme[start..end],
            table,
            "the README's demo table differs from the demo's output; \
             TRINOCULAR_BLESS=1 cargo test --test demo readme rewrites it"
        );
    }
}

/// The demo's table in its stdout: from its header to the sphere-A line.
fn demo_table(stdout: &str) -> Option<String> {
    let start = stdout.find("figure (µm, µrad)")?;
    let rest = &stdout[start..];
    let end = rest.find("sphere A displacement")?;
    let line_end = end + rest[end..].find('\n')? + 1;
    Some(rest[..line_end].to_string())
}
