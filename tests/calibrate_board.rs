//! `calibrate --views --board chessboard:…` (issue 40): printed chessboards
//! rendered by `synth board` (a board under even light, 15 views per camera,
//! exact corners in truth), their corners found in every view, one bundle.
//! Over 20 seeds of the seed's 3-camera rig and of a 2-camera rig at
//! 640×480, each camera's fx, fy, cx, cy within 2σ (the joint solution's) of
//! the truth in ≥ 90 % of cases; the cameras' poses relative to camera 1
//! against the truth; and the board's bad views: not found, found
//! partially, a board spec whose orientation cannot be told; a view as an
//! 8-bit colour JPEG is read.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{failure, ok, s, trinocular};

use std::path::{Path, PathBuf};

use geom::Camera;

/// `synth board` at 640×480 with seed `seed`, for the cameras `ids` of the
/// seed's rig, into `dir/b`.
fn board(dir: &Path, seed: u64, ids: &[u8]) -> PathBuf {
    let mut config = synth::Config::default();
    config.rig.cameras.retain(|c| ids.contains(&c.id));
    let cfg = dir.join("config.toml");
    std::fs::write(&cfg, config.to_toml().unwrap()).unwrap();
    let out = dir.join("b");
    let seed = seed.to_string();
    ok(&trinocular(&[
        "synth",
        "board",
        "--config",
        s(&cfg),
        "--width",
        "640",
        "--height",
        "480",
        "--seed",
        &seed,
        "--out",
        s(&out),
    ]));
    out
}

/// `calibrate --views` of the board views (the lean model: the choice has
/// its own tests); stdout and stderr.
fn calibrate(b: &Path, views: &Path, extra: &[&str]) -> std::process::Output {
    let out = b.join("rig.json");
    let mut args = vec![
        "calibrate",
        "--views",
        s(views),
        "--board",
        "chessboard:9x6:12",
        "--model",
        "k1k2p1p2",
        "--out",
        s(&out),
    ];
    args.extend(extra);
    trinocular(&args)
}

/// (within 2σ, all) of the intrinsics, and per camera after the first its
/// rotation error relative to camera 1 (arcsec) with the σ it is judged
/// against: √(σ₁² + σ_k²) of the two cameras' rotations (each σ the norm of
/// its rx, ry, rz σ's: the cameras taken as independent, which their
/// common tie to the board's first pose makes conservative).
fn judge(b: &Path) -> ((usize, usize), Vec<(f64, f64)>) {
    let truth: formats::Truth = formats::read_json(&b.join("truth.json")).unwrap();
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(b.join("rig.json")).unwrap()).unwrap();
    let rig = formats::read_rig(&b.join("rig.json")).unwrap();
    let (mut within, mut all) = (0, 0);
    let mut relative = Vec::new();
    let camera = |id: u8| -> (Camera, Camera) {
        let t = truth.cameras.iter().find(|t| t.model.id == id).unwrap();
        (
            t.model.to_camera().unwrap(),
            rig.camera(id).unwrap().model.to_camera().unwrap(),
        )
    };
    let first = truth.cameras[0].model.id;
    let (t1, c1) = camera(first);
    for t in &truth.cameras {
        let id = t.model.id;
        let (tc, cc) = camera(id);
        let entry = json["cameras"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["id"] == id)
            .unwrap();
        let sd = &entry["calibration"]["std_dev"];
        let (ti, ci) = (tc.intrinsics, cc.intrinsics);
        for (name, got, want) in [
            ("fx", ci.fx, ti.fx),
            ("fy", ci.fy, ti.fy),
            ("cx", ci.cx, ti.cx),
            ("cy", ci.cy, ti.cy),
        ] {
            let sigma = sd[name].as_f64().unwrap();
            all += 1;
            if (got - want).abs() <= 2.0 * sigma {
                within += 1;
            }
        }
        if id != first {
            // Camera `id` in camera 1's frame: truth against calibrated.
            let rel = |a: &Camera, b: &Camera| b.pose * a.pose.inverse();
            let (tr, cr) = (rel(&t1, &tc), rel(&c1, &cc));
            let d = tr.inverse() * cr;
            let rotation_sigma = |e: &serde_json::Value| -> f64 {
                let sd = &e["calibration"]["std_dev"];
                ["rx", "ry", "rz"]
                    .iter()
                    .map(|k| sd[*k].as_f64().unwrap().powi(2))
                    .sum::<f64>()
            };
            let entry1 = json["cameras"]
                .as_array()
                .unwrap()
                .iter()
                .find(|c| c["id"] == first)
                .unwrap();
            let sigma = (rotation_sigma(entry1) + rotation_sigma(entry)).sqrt();
            let arcsec = 180.0 / std::f64::consts::PI * 3600.0;
            relative.push((d.rotation.angle() * arcsec, sigma * arcsec));
        }
    }
    ((within, all), relative)
}

/// 20 seeds of the rig of cameras `ids`: the share of intrinsics within 2σ
/// and of relative rotations within 2σ.
fn seeds(ids: &[u8]) -> (f64, f64) {
    let (mut within, mut all) = (0, 0);
    let (mut rot_within, mut rot_all, mut rot_ss) = (0, 0, 0.0);
    let (mut halves_within, mut halves_points) = (0, 0);
    for seed in 1..=20 {
        let dir = tempfile::tempdir().unwrap();
        let b = board(dir.path(), seed, ids);
        let out = calibrate(&b, &b.join("views.csv"), &[]);
        ok(&out);
        let (hw, hn) = common::halves(&String::from_utf8_lossy(&out.stdout));
        halves_within += hw;
        halves_points += hn;
        let ((w, a), relative) = judge(&b);
        within += w;
        all += a;
        for (error, sigma) in relative {
            rot_all += 1;
            rot_ss += error * error;
            if error <= 2.0 * sigma {
                rot_within += 1;
            }
        }
    }
    let share = within as f64 / all as f64;
    let rot_share = f64::from(rot_within) / f64::from(rot_all);
    eprintln!(
        "cameras {ids:?}: two halves: {halves_within} of {halves_points} grid points within twice \
         the predicted difference"
    );
    assert!(halves_within as f64 >= 0.9 * halves_points as f64);
    eprintln!(
        "cameras {ids:?}: {within} of {all} intrinsics within 2σ ({:.1} %); rotations relative \
         to camera {}: {rot_within} of {rot_all} within 2σ, RMS {:.1}″",
        100.0 * share,
        ids[0],
        (rot_ss / f64::from(rot_all)).sqrt()
    );
    (share, rot_share)
}

#[test]
fn the_seed_rig_from_board_views() {
    let (share, rotations) = seeds(&[1, 2, 3]);
    assert!(share >= 0.9, "{share}");
    assert!(rotations >= 0.9, "{rotations}");
}

#[test]
fn a_two_camera_rig_from_board_views() {
    let (share, rotations) = seeds(&[1, 2]);
    assert!(share >= 0.9, "{share}");
    assert!(rotations >= 0.9, "{rotations}");
}
#[test]
fn bad_board_views_are_left_out_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let b = board(dir.path(), 3, &[1, 2, 3]);
    // Pose 0's view in camera 1 shifted left by 250 px (part of the board out
    // of the frame), pose 1's replaced by a frame without a board.
    let image = image::open(b.join("board/pose0_cam1.tif"))
        .unwrap()
        .into_luma16();
    let shifted = image::ImageBuffer::from_fn(640, 480, |x, y| {
        if x + 250 < 640 {
            *image.get_pixel(x + 250, y)
        } else {
            image::Luma([900u16])
        }
    });
    shifted.save(b.join("board/partial.png")).unwrap();
    let empty = image::ImageBuffer::<image::Luma<u16>, _>::from_pixel(640, 480, image::Luma([900]));
    empty.save(b.join("board/empty.png")).unwrap();
    // Pose 3's view in camera 1 as a phone writes it: an 8-bit colour JPEG.
    let gray = image::open(b.join("board/pose3_cam1.tif"))
        .unwrap()
        .into_luma16();
    let colour = image::RgbImage::from_fn(640, 480, |x, y| {
        let v = (gray.get_pixel(x, y).0[0] >> 8) as u8;
        image::Rgb([v, v, v])
    });
    colour.save(b.join("board/phone.jpg")).unwrap();
    let text = std::fs::read_to_string(b.join("views.csv"))
        .unwrap()
        .replace("board/pose0_cam1.tif", "board/partial.png")
        .replace("board/pose1_cam1.tif", "board/empty.png")
        .replace("board/pose3_cam1.tif", "board/phone.jpg");
    let edited = b.join("edited.csv");
    std::fs::write(&edited, text).unwrap();
    let out = calibrate(&b, &edited, &[]);
    let stderr = ok(&out);
    assert!(
        stderr.contains("camera 1 at pose 0 left out") && stderr.contains("found partially"),
        "{stderr}"
    );
    assert!(
        stderr.contains("camera 1 at pose 1 left out") && stderr.contains("no chessboard found"),
        "{stderr}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(b.join("rig.json")).unwrap()).unwrap();
    let left: Vec<u64> = json["cameras"][0]["views_left_out"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["pose"].as_u64().unwrap())
        .collect();
    assert_eq!(left, [0, 1]);
    let used: Vec<u64> = json["cameras"][0]["views"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["pose"].as_u64().unwrap())
        .collect();
    assert!(used.contains(&3), "the JPEG view is used: {used:?}");

    // A board whose orientation cannot be told, and a spec that is not one.
    for (spec, says) in [
        ("chessboard:8x6:12", "180°"),
        ("charuco:9x6:12", "chessboard:COLSxROWS:SQUARE_MM"),
    ] {
        let views = b.join("views.csv");
        let rig = b.join("other.json");
        let (code, line) = failure(&trinocular(&[
            "calibrate",
            "--views",
            s(&views),
            "--board",
            spec,
            "--out",
            s(&rig),
        ]));
        assert_eq!(code, 2, "{line}");
        assert!(line.contains(says), "{line}");
        assert!(!rig.exists());
    }
}
