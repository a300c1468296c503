//! `trinocular calibrate --views` (issue 40): the rig from many views in one
//! bundle, checked against Zhang's published calibration of a real camera
//! (testdata/zhang1998: five views of a planar model, 256 corners each) and
//! against its bad inputs.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{ok, refused, testdata, trinocular};

use std::path::{Path, PathBuf};

/// Zhang's model plane as `target.csv` (inches → mm, z = 0) and his five
/// views as `id,u,v` files with their `views.csv` (camera 1, poses 1–5):
/// corner k of line j is marker 4j + k in every file.
fn zhang(dir: &Path) -> PathBuf {
    let corners = |text: &str| -> Vec<(f64, f64)> {
        text.lines()
            .flat_map(|l| {
                let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                assert_eq!(v.len(), 8, "{l}");
                (0..4)
                    .map(move |k| (v[2 * k], v[2 * k + 1]))
                    .collect::<Vec<_>>()
            })
            .collect()
    };
    let model = corners(&std::fs::read_to_string(testdata("zhang1998/Model.txt")).unwrap());
    assert_eq!(model.len(), 256);
    let mut target = String::from("id,x,y,z\n");
    for (i, (x, y)) in model.iter().enumerate() {
        target.push_str(&format!("{i},{},{},0\n", 25.4 * x, 25.4 * y));
    }
    std::fs::write(dir.join("target.csv"), target).unwrap();
    let mut views = String::from("image,camera,pose\n");
    for n in 1..=5 {
        let data =
            corners(&std::fs::read_to_string(testdata(&format!("zhang1998/data{n}.txt"))).unwrap());
        let mut points = String::from("id,u,v\n");
        for (i, (u, v)) in data.iter().enumerate() {
            points.push_str(&format!("{i},{u},{v}\n"));
        }
        std::fs::write(dir.join(format!("view{n}.csv")), points).unwrap();
        views.push_str(&format!("view{n}.csv,1,{n}\n"));
    }
    let path = dir.join("views.csv");
    std::fs::write(&path, views).unwrap();
    path
}

fn calibrate(dir: &Path, views: &Path, extra: &[&str]) -> std::process::Output {
    let target = dir.join("target.csv");
    let out = dir.join("rig.json");
    let mut args = vec![
        "calibrate",
        "--views",
        views.to_str().unwrap(),
        "--target",
        target.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    if !extra.contains(&"--width") {
        args.extend_from_slice(&["--width", "640", "--height", "480"]);
    }
    args.extend_from_slice(extra);
    trinocular(&args)
}

/// The first camera of `rig.json` in `dir`: α, β, u₀, v₀, k1, k2, RMS, σ(α).
fn solution(dir: &Path) -> ([f64; 7], f64, serde_json::Value) {
    let rig: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("rig.json")).unwrap()).unwrap();
    let camera = rig["cameras"][0].clone();
    let k = &camera["K"];
    let d = &camera["distortion"];
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let values = [
        f(&k[0][0]),
        f(&k[1][1]),
        f(&k[0][2]),
        f(&k[1][2]),
        f(&d["k1"]),
        f(&d["k2"]),
        f(&camera["rms_px"]),
    ];
    let sd = f(&camera["calibration"]["std_dev"]["fx"]);
    (values, sd, camera)
}

/// Zhang's published result (README): α 832.5, β 832.53, u₀ 303.959,
/// v₀ 206.585 (with skew 0.2045), k1 −0.228601, k2 0.190353.
const ZHANG: [f64; 6] = [832.5, 832.53, 303.959, 206.585, -0.228601, 0.190353];
/// An independent solution without skew (OpenCV, k1 k2): fx 832.21,
/// fy 832.24, cx 304.07, cy 206.37, k1 −0.2285, k2 0.1910, RMS 0.337 px.
const INDEPENDENT: [f64; 6] = [832.21, 832.24, 304.07, 206.37, -0.2285, 0.1910];

#[test]
fn zhang_published_calibration_is_reproduced() {
    let dir = tempfile::tempdir().unwrap();
    let views = zhang(dir.path());
    // Zhang's own model: skew estimated, radial k1 k2, every point: his
    // published figures to their last digits.
    let zhang_model = ["--model", "k1k2", "--skew", "--keep-outliers"];
    ok(&calibrate(dir.path(), &views, &zhang_model));
    let (got, _, camera) = solution(dir.path());
    for (i, want) in ZHANG.iter().enumerate() {
        let tolerance = if i < 4 { 0.02 } else { 5e-4 };
        assert!(
            (got[i] - want).abs() < tolerance,
            "parameter {i}: {} vs Zhang's {want}",
            got[i]
        );
    }
    assert!((0.30..0.38).contains(&got[6]), "RMS {} px", got[6]);
    // Per view: five rows, each with its points and residuals.
    let views_csv = std::fs::read_to_string(dir.path().join("rig.views.csv")).unwrap();
    let lines: Vec<&str> = views_csv.lines().collect();
    assert_eq!(lines[0], "camera,pose,points,rms_px,max_px,outliers");
    assert_eq!(lines.len(), 6, "{views_csv}");
    assert_eq!(camera["views"].as_array().unwrap().len(), 5);
    // One camera: the volume's points are listed, none triangulated.
    let volume = std::fs::read_to_string(dir.path().join("rig.volume.csv")).unwrap();
    assert!(volume.starts_with("x,y,z,cameras,sigma_x_um,sigma_y_um,sigma_z_um\n"));
    assert_eq!(volume.lines().count(), 126);
    assert!(camera["covariance"]["matrix"].is_array());

    // Without skew, every point: the independent solution's figures.
    ok(&calibrate(
        dir.path(),
        &views,
        &["--model", "k1k2", "--keep-outliers", "--force"],
    ));
    let (got, _, _) = solution(dir.path());
    for (i, want) in INDEPENDENT.iter().enumerate() {
        let tolerance = if i < 4 { 0.05 } else { 5e-4 };
        assert!(
            (got[i] - want).abs() < tolerance,
            "parameter {i}: {} vs {want}",
            got[i]
        );
    }
    assert!((got[6] - 0.337).abs() < 0.002, "RMS {} px", got[6]);

    // The defaults (k·σ rejection on, which leaves out 3 of 1280 corners;
    // no skew): within 0.5 px of the solution of the same model, and within
    // half a σ of Zhang's (whose skew moves α by 0.3 px).
    ok(&calibrate(
        dir.path(),
        &views,
        &["--model", "k1k2", "--force"],
    ));
    let (got, sd, _) = solution(dir.path());
    for i in 0..4 {
        assert!(
            (got[i] - INDEPENDENT[i]).abs() < 0.5,
            "parameter {i}: {} vs {}",
            got[i],
            INDEPENDENT[i]
        );
        assert!(
            (got[i] - ZHANG[i]).abs() < 0.5 * sd,
            "parameter {i}: {} vs {} (σ {sd})",
            got[i],
            ZHANG[i]
        );
    }
    assert!((got[4] - ZHANG[4]).abs() < 0.005 && (got[5] - ZHANG[5]).abs() < 0.005);
}

#[test]
fn views_bad_input_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let views = zhang(dir.path());
    // A views.csv naming a missing file.
    let broken = dir.path().join("broken.csv");
    std::fs::write(
        &broken,
        "image,camera,pose\nview1.csv,1,1\nnowhere.csv,1,2\n",
    )
    .unwrap();
    refused(
        &calibrate(dir.path(), &broken, &[]),
        &["broken.csv line 3", "nowhere.csv", "no such file"],
    );
    // Two views of one pose by one camera.
    std::fs::write(&broken, "image,camera,pose\nview1.csv,1,1\nview2.csv,1,1\n").unwrap();
    refused(
        &calibrate(dir.path(), &broken, &[]),
        &["broken.csv", "second view of pose 1"],
    );
    // A camera that never shares a pose with the others.
    std::fs::write(
        &broken,
        "image,camera,pose\nview1.csv,1,1\nview2.csv,1,2\nview3.csv,1,3\nview4.csv,2,4\nview5.csv,2,5\n",
    )
    .unwrap();
    refused(
        &calibrate(dir.path(), &broken, &[]),
        &["camera 2", "not connected"],
    );
    // Three views that are one view: the focal length undetermined.
    std::fs::write(
        &broken,
        "image,camera,pose\nview1.csv,1,1\nview1.csv,1,2\nview1.csv,1,3\n",
    )
    .unwrap();
    refused(
        &calibrate(dir.path(), &broken, &[]),
        &["undetermined", "condition number"],
    );
    // A view with fewer points than the model and its pose need: how many.
    let few: String = std::fs::read_to_string(dir.path().join("view1.csv"))
        .unwrap()
        .lines()
        .take(8)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(dir.path().join("few.csv"), few).unwrap();
    std::fs::write(&broken, "image,camera,pose\nfew.csv,1,1\n").unwrap();
    refused(
        &calibrate(dir.path(), &broken, &[]),
        &["camera 1: 7 points in 1 view", "fewer than the 8"],
    );
    // Nothing written on refusal.
    assert!(!dir.path().join("rig.json").exists());
    // An image of a marker target without the nominal rig: a usage error
    // naming the row and what is missing.
    std::fs::write(dir.path().join("view.png"), b"not looked at").unwrap();
    std::fs::write(&broken, "image,camera,pose\nview.png,1,1\n").unwrap();
    let (code, line) = common::failure(&calibrate(dir.path(), &broken, &[]));
    assert_eq!(code, 2, "{line}");
    for f in ["broken.csv line 2", "view.png", "--nominal"] {
        assert!(line.contains(f), "'{f}' missing from {line}");
    }
    assert!(!dir.path().join("rig.json").exists());
    let _ = views;
}

#[test]
fn one_pose_is_the_one_image_calibration() {
    // Heikkilä's real 3-D target (491 points), one camera: --views with a
    // single view and --points give the same camera.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::heikkila(d, None);
    std::fs::write(d.join("views.csv"), "image,camera,pose\npoints.csv,1,7\n").unwrap();
    let s = |p: PathBuf| p.to_str().unwrap().to_string();
    let common = ["--width", "768", "--height", "576"];
    let mut one: Vec<String> = ["calibrate", "--target"].map(String::from).to_vec();
    one.extend([
        s(d.join("target.csv")),
        "--points".into(),
        s(d.join("points.csv")),
    ]);
    one.extend(common.map(String::from));
    one.extend(["--out".into(), s(d.join("one.json"))]);
    ok(&trinocular(
        &one.iter().map(String::as_str).collect::<Vec<_>>(),
    ));
    ok(&calibrate(
        d,
        &d.join("views.csv"),
        &["--width", "768", "--height", "576"],
    ));
    let p = |name: &str| -> Vec<f64> {
        let rig: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(name)).unwrap()).unwrap();
        rig["cameras"][0]["P"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|r| r.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()))
            .collect()
    };
    let (a, b) = (p("one.json"), p("rig.json"));
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-9 * scale, "P {x} vs {y}");
    }
}
