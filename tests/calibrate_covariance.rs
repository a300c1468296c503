//! `trinocular calibrate` stores each camera's parameter covariance in
//! `rig.json` and states the standard uncertainties and the target
//! uncertainty in the commissioning report (issue 25, point 3), from
//! `--points` correspondences on Heikkilä's real 3-D target (491 points).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{heikkila, ok, one_line_error, trinocular};

use std::path::Path;

fn calibrate(target: &Path, points: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let mut args = vec![
        "calibrate".to_string(),
        "--target".into(),
        s(target),
        "--points".into(),
        s(points),
        "--width".into(),
        "768".into(),
        "--height".into(),
        "576".into(),
        "--out".into(),
        s(out),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    trinocular(&args)
}

#[test]
fn calibrate_stores_the_covariance_and_reports_its_uncertainties() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (target, points) = heikkila(d, None);
    let out = calibrate(&target, &points, &d.join("rig.json"), &[]);
    ok(&out);
    let rig = formats::read_rig(&d.join("rig.json")).unwrap();
    let camera = &rig.cameras[0];
    let c = camera.covariance.as_ref().expect("a covariance");
    assert_eq!(
        c.parameters,
        [
            "fx", "fy", "cx", "cy", "rx", "ry", "rz", "tx", "ty", "tz", "k1", "k2", "p1", "p2"
        ]
    );
    let m = c.to_matrix().unwrap();
    assert!((&m - m.transpose()).amax() <= 1e-12 * m.amax());
    assert!(c.target_matrix().is_some());
    assert_eq!(
        c.target_uncertainty_um,
        calib::DEFAULT_TARGET_UNCERTAINTY_UM
    );
    assert!(
        c.target_uncertainty_source.starts_with("default 1 µm"),
        "{}",
        c.target_uncertainty_source
    );
    // 1 µm is far below what the 0.07 px residuals show: the covariance is
    // the residuals' s²·(JᵀJ)⁻¹ that the fit's standard deviations report.
    let std_dev = camera.extra["std_dev"].as_object().unwrap();
    for (j, name) in c.parameters.iter().enumerate() {
        let fit = std_dev[name].as_f64().unwrap();
        let u = m[(j, j)].sqrt();
        assert!((u / fit - 1.0).abs() < 0.02, "{name}: {u} against {fit}");
    }
    let text = std::fs::read_to_string(d.join("rig.commissioning.txt")).unwrap();
    assert!(
        text.contains("calibration standard uncertainties (k = 1): fx ")
            && text.contains("target marker coordinates 1.00 µm each (default 1 µm"),
        "{text}"
    );

    // A target uncertainty beyond the residuals (200 µm ≈ 0.2 px here) is
    // said, and makes the covariance larger.
    let out = calibrate(
        &target,
        &points,
        &d.join("wide.json"),
        &["--target-uncertainty-um", "200"],
    );
    assert!(
        ok(&out).contains("the target uncertainty (--target-uncertainty-um 200) explains more"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let wide = formats::read_rig(&d.join("wide.json")).unwrap();
    let w = wide.cameras[0].covariance.as_ref().unwrap();
    assert_eq!(w.target_uncertainty_source, "--target-uncertainty-um 200");
    let wm = w.to_matrix().unwrap();
    assert!(
        wm[(0, 0)] > 2.0 * m[(0, 0)],
        "{} vs {}",
        wm[(0, 0)],
        m[(0, 0)]
    );
}

#[test]
fn target_csv_u_mm_is_used_and_a_bad_one_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (target, points) = heikkila(d, Some("0.002"));
    let out = calibrate(&target, &points, &d.join("rig.json"), &[]);
    ok(&out);
    let rig = formats::read_rig(&d.join("rig.json")).unwrap();
    let c = rig.cameras[0].covariance.as_ref().unwrap();
    assert_eq!(c.target_uncertainty_source, "target.csv u_mm");
    assert!((c.target_uncertainty_um - 2.0).abs() < 1e-12);

    let (target, points) = heikkila(d, Some("-0.001"));
    let e = one_line_error(&calibrate(&target, &points, &d.join("bad.json"), &[]));
    assert!(
        e.contains("target.csv: line 2, column 'u_mm'")
            && e.contains("standard uncertainty -0.001 is not a finite number ≥ 0"),
        "{e}"
    );
    let (target, points) = heikkila(d, None);
    let e = one_line_error(&calibrate(
        &target,
        &points,
        &d.join("bad.json"),
        &["--target-uncertainty-um", "-1"],
    ));
    assert!(e.contains("--target-uncertainty-um"), "{e}");
}
