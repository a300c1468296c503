//! What a new user met in the first hour (issue 39), each through the
//! command line as the user typed it: flats and darks of another camera,
//! a one-camera commissioning, the GPU driver's own messages, folders of
//! folders, a campaign the disk cannot hold, clap's suggestions and the
//! files `synth target` writes.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{bin, ok, ok_stdout, refused, s, stderr, tree, trinocular};

use std::path::{Path, PathBuf};

/// The calibration target of a 320 × 240 px rig, rendered into `dir/t`:
/// its frames carry the cameras' serials TRN-SYN-000k in their tags.
fn target(dir: &Path) -> PathBuf {
    let t = dir.join("t");
    ok(&trinocular(&[
        "synth",
        "target",
        "--out",
        s(&t),
        "--width",
        "320",
        "--height",
        "240",
    ]));
    t
}

/// `calibrate` from the target images with flats and darks in the order given.
fn calibrate(t: &Path, flats: [u8; 3], darks: [u8; 3], out: &Path) -> std::process::Output {
    let file = |kind: &str, k: u8| s(&t.join(format!("calib/{kind}{k}.tif"))).to_string();
    let mut args: Vec<String> = vec![
        "calibrate".into(),
        "--target".into(),
        s(&t.join("target.csv")).into(),
        "--nominal".into(),
        s(&t.join("nominal.json")).into(),
        "--images".into(),
    ];
    args.extend((1..=3).map(|k| file("cam", k)));
    args.push("--flat-fields".into());
    args.extend(flats.map(|k| file("flat_cam", k)));
    args.push("--dark-frames".into());
    args.extend(darks.map(|k| file("dark_cam", k)));
    args.extend(["--out".into(), s(out).into()]);
    bin().args(args).output().unwrap()
}

#[test]
fn flats_and_darks_of_another_camera_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let t = target(dir.path());
    let out = dir.path().join("r/rig.json");
    let before = tree(dir.path());

    // Camera 2's flat given for camera 1: its serial is not the image's.
    let e = refused(
        &calibrate(&t, [2, 1, 3], [1, 2, 3], &out),
        &["flat_cam2.tif", "TRN-SYN-0002", "cam1.tif", "TRN-SYN-0001"],
    );
    assert!(tree(dir.path()) == before, "{e}: files changed");
    // The darks in the wrong order.
    let e = refused(
        &calibrate(&t, [1, 2, 3], [1, 3, 2], &out),
        &["dark_cam3.tif", "TRN-SYN-0003", "TRN-SYN-0002"],
    );
    assert!(tree(dir.path()) == before, "{e}: files changed");
    ok(&calibrate(&t, [1, 2, 3], [1, 2, 3], &out));

    // `extract --flat-field` of camera 2 over frames of cameras 1 and 2:
    // camera 1's frame is a problem, camera 2's is corrected.
    let blobs = dir.path().join("e/blobs.csv");
    let run = trinocular(&[
        "extract",
        "--backend",
        "cpu",
        "--flat-field",
        s(&t.join("calib/flat_cam2.tif")),
        "--dark-frame",
        s(&t.join("calib/dark_cam2.tif")),
        "--out",
        s(&blobs),
        s(&t.join("calib/cam1.tif")),
        s(&t.join("calib/cam2.tif")),
    ]);
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    let problems = std::fs::read_to_string(dir.path().join("e/blobs.problems.csv")).unwrap();
    assert_eq!(problems.lines().count(), 2, "{problems}");
    assert!(
        problems.contains("cam1.tif")
            && problems.contains("TRN-SYN-0001")
            && problems.contains("TRN-SYN-0002"),
        "{problems}"
    );
    let written = std::fs::read_to_string(&blobs).unwrap();
    assert!(written.lines().skip(1).all(|l| l.contains("cam2.tif")));
    assert!(written.lines().count() > 40, "{written}");
}

#[test]
fn a_single_camera_commissioning_says_only_what_is_known() {
    let dir = tempfile::tempdir().unwrap();
    let t = target(dir.path());
    let rig = dir.path().join("one/rig.json");
    let run = trinocular(&[
        "calibrate",
        "--target",
        s(&t.join("target.csv")),
        "--points",
        s(&t.join("calib/points_cam1.csv")),
        "--width",
        "320",
        "--height",
        "240",
        "--out",
        s(&rig),
    ]);
    let said = ok_stdout(&run);
    assert!(said.contains("(1 camera)"), "{said}");
    let text = std::fs::read_to_string(dir.path().join("one/rig.commissioning.txt")).unwrap();
    for invented in [
        "  working distance",
        "mm/px",
        "leaves the image",
        "1 cameras",
    ] {
        assert!(!text.contains(invented), "'{invented}' in\n{text}");
        assert!(!said.contains(invented), "'{invented}' in\n{said}");
    }
    assert!(text.contains("Working point: unknown"), "{text}");
    let json: serde_json::Value =
        formats::read_json(&dir.path().join("one/rig.commissioning.json")).unwrap();
    let camera = &json["cameras"][0];
    assert!(camera.get("working_distance_mm").is_none(), "{camera}");
    assert!(camera.get("pixel_size_mm").is_none(), "{camera}");
    assert!(json["working_point_mm"].is_null(), "{json}");
}

/// `--backend auto` probes the GPU: the driver's own messages ("MESA: error:
/// … XDG_RUNTIME_DIR …" without a desktop session) stay out of the user's
/// stream, whose every line is trinocular's.
#[test]
fn the_drivers_messages_stay_out_of_the_users_stream() {
    let dir = tempfile::tempdir().unwrap();
    let t = target(dir.path());
    let run = bin()
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("TRINOCULAR_NO_GPU")
        .args([
            "extract",
            "--backend",
            "auto",
            "--out",
            s(&dir.path().join("blobs.csv")),
            s(&t.join("calib/cam1.tif")),
        ])
        .output()
        .unwrap();
    let err = ok(&run);
    for line in err.lines() {
        assert!(line.starts_with("trinocular: "), "not trinocular's: {line}");
        assert!(!line.to_lowercase().contains("error"), "{line}");
    }
}

#[test]
fn extract_searches_subfolders_and_says_what_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let t = target(dir.path());
    let frames = dir.path().join("frames");
    std::fs::create_dir_all(frames.join("cam1/day1")).unwrap();
    std::fs::copy(
        t.join("calib/cam1.tif"),
        frames.join("cam1/day1/frame_001.tif"),
    )
    .unwrap();
    std::fs::copy(t.join("calib/cam2.tif"), frames.join("frame_000.tif")).unwrap();
    let blobs = dir.path().join("blobs.csv");
    let said = ok_stdout(&trinocular(&[
        "extract",
        "--backend",
        "cpu",
        "--out",
        s(&blobs),
        s(&frames),
    ]));
    let markers = std::fs::read_to_string(t.join("target.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    let written = std::fs::read_to_string(&blobs).unwrap();
    assert!(
        written.contains("day1/frame_001.tif"),
        "subfolder not searched"
    );
    let n = written.lines().count() - 1;
    assert_eq!(n, 2 * markers, "{written}");
    assert!(
        said.contains(&format!("extract: {n} blobs from 2 of 2 images")),
        "{said}"
    );
    // No problems: the problems file says so, with its header alone.
    assert_eq!(
        std::fs::read_to_string(dir.path().join("blobs.problems.csv")).unwrap(),
        "item,reason\n"
    );
}

#[test]
fn a_campaign_the_disk_cannot_hold_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big");
    // Free-running cameras at 16384 px: tens of terabytes.
    let e = refused(
        &trinocular(&[
            "synth",
            "campaign",
            "--out",
            s(&out),
            "--width",
            "16384",
            "--continuous",
        ]),
        &["big", "GB", "free"],
    );
    assert!(!out.exists(), "{e}: started writing");
}

#[test]
fn usage_errors_keep_clap_suggestions() {
    let e = stderr(&trinocular(&["evalute"]));
    assert!(e.contains("'evaluate'"), "{e}");
    let e = stderr(&trinocular(&["evaluate", "--point", "x"]));
    assert!(e.contains("'--points'"), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
}

#[test]
fn synth_target_help_lists_the_flats_and_darks_it_writes() {
    let said = ok_stdout(&trinocular(&["synth", "target", "--help"]));
    for file in ["calib/flat_cam{k}.tif", "calib/dark_cam{k}.tif"] {
        assert!(said.contains(file), "synth target --help: {said}");
    }
}
