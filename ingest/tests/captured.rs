//! Manifests built from campaigns the renderer wrote as cameras save them
//! (`synth::config::CaptureConfig`), against the renderer's own manifest of what it wrote
//! (`truth_manifest.csv`). Campaigns are small: 256×192 px (the seed rig's
//! field of view), 3 targets per axis, 2 runs, 2 captures.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use formats::{ManifestRow, ProcedureConfig, read_csv};
use ingest::{Capture, Inputs, Options, Problem};
use synth::config::{CaptureMode, DroppedFrame, StrayFrame};

/// The seed rig at 256×192 px, 3 targets per axis, 2 runs, 2 captures.
fn config(seed: u64) -> synth::Config {
    let mut c = synth::Config::default();
    c.apply(&synth::Overrides {
        width: Some(256),
        height: Some(192),
        targets: Some(3),
        runs: Some(2),
        captures: Some(2),
        seed: Some(seed),
    })
    .unwrap();
    c
}

fn render(config: &synth::Config, dir: &Path) {
    synth::write_campaign(
        config,
        dir,
        &mut formats::OutputPlan::new(false),
        &synth::NoProgress,
    )
    .unwrap();
}

fn cameras(config: &synth::Config) -> Vec<(String, u8)> {
    config
        .rig
        .cameras
        .iter()
        .map(|c| (c.serial.clone(), c.id))
        .collect()
}

fn truth_manifest(dir: &Path) -> Vec<ManifestRow> {
    read_csv(&dir.join("truth_manifest.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}

fn program(dir: &Path) -> ProcedureConfig {
    ingest::read_program(&dir.join("program.toml")).unwrap()
}

fn build(dir: &Path, config: &synth::Config, manifest: &Path, options: &Options) -> ingest::Built {
    let dirs: Vec<PathBuf> = config
        .rig
        .cameras
        .iter()
        .map(|c| dir.join(&c.serial))
        .collect();
    ingest::build(
        &Inputs {
            program: &program(dir),
            cameras: &cameras(config),
            dirs: &dirs,
            manifest,
        },
        options,
    )
    .unwrap()
}

fn describe(p: &[Problem]) -> String {
    p.iter()
        .map(|p| format!("{:?} cam {:?}: {}", p.image, p.camera, p.reason))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The triggered campaign of the issue: camera clocks seconds apart, moves
/// 15 % longer than programmed, one dropped frame, one stray trigger.
#[test]
fn triggered_capture_places_every_frame_and_names_the_faults() {
    let mut c = config(21);
    c.capture.mode = CaptureMode::Triggered;
    c.capture.clock_offset_s = [0.0, 2.375, -3.8125];
    c.capture.move_time_factor = 1.15;
    // Instant 13: X line 1 run 2 + target 0 capture 2 (camera 2 sees X motion).
    c.capture.dropped = vec![DroppedFrame {
        camera: 2,
        instant: 13,
    }];
    // Half-way through the move to dwell 4 (X line 1 run 1 − target 1).
    c.capture.stray = vec![StrayFrame {
        camera: 1,
        dwell: 4,
    }];
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    render(&c, dir);
    let built = build(dir, &c, &dir.join("manifest.csv"), &Options::default());

    // Every other frame at its instant, in the renderer's order.
    assert_eq!(built.rows, truth_manifest(dir));
    assert_eq!(built.rows.len(), 72 * 3 - 1);

    // The two faults, by file name: the stray trigger, and the instant that
    // lacks camera 2 (with the file of camera 2's shortened burst).
    let truth: formats::Truth = formats::read_json(&dir.join("truth.json")).unwrap();
    let stray_image = truth.extra["capture"]["stray"][0]["image"]
        .as_str()
        .unwrap()
        .to_string();
    assert_eq!(built.problems.len(), 2, "{}", describe(&built.problems));
    let stray = &built.problems[0];
    assert_eq!(stray.image.as_deref(), Some(stray_image.as_str()));
    assert_eq!(stray.camera, Some(1));
    assert!(stray.reason.contains("stray"), "{}", stray.reason);
    let missing = &built.problems[1];
    assert_eq!(missing.image, None);
    assert_eq!(
        (
            missing.camera,
            missing.axis,
            missing.direction,
            missing.run,
            missing.target,
            missing.capture
        ),
        (
            Some(2),
            Some(formats::Axis::X),
            Some(formats::Direction::Up),
            Some(2),
            Some(0),
            Some(2)
        )
    );
    let kept = built
        .rows
        .iter()
        .find(|r| {
            r.camera == 2
                && r.axis == formats::Axis::X
                && r.run == 2
                && r.target == 0
                && r.capture == 1
                && r.nominal_y == 0.0
                && r.direction == formats::Direction::Up
        })
        .unwrap();
    assert!(missing.reason.contains(&kept.image), "{}", missing.reason);
    // The campaign ran 15 % slower than programmed between captures (a little
    // less over whole gaps: settling and the captures themselves keep their time).
    for (_, s) in &built.summary.scales {
        assert!((1.05..1.15).contains(s), "{s}");
    }
}

/// The continuous stream of free-running cameras, with motion blur and a
/// dropped frame: the instants are the renderer's, frame for frame.
#[test]
fn continuous_stream_gives_the_renderers_manifest() {
    let mut c = config(23);
    c.procedure.runs = 1;
    c.procedure.fps = 20.0;
    c.procedure.feed_mm_per_s = 40.0;
    c.procedure.settle_s = 0.5;
    c.procedure.overshoot_mm = 5.0;
    for a in &mut c.procedure.axes {
        a.start_mm = -20.0;
        a.length_mm = 40.0;
        a.lines_mm = vec![0.0];
    }
    c.sensor.exposure_s = 0.01;
    c.capture.mode = CaptureMode::Continuous;
    c.capture.blur_steps = 4;
    // X run 1 − target 1, capture 1 (instant 8) loses camera 3's frame.
    c.capture.dropped = vec![DroppedFrame {
        camera: 3,
        instant: 8,
    }];
    c.validate().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    render(&c, dir);
    let options = Options {
        capture: Capture::Continuous,
        ..Options::default()
    };
    let built = build(dir, &c, &dir.join("manifest.csv"), &options);
    assert_eq!(
        built.rows,
        truth_manifest(dir),
        "{}",
        describe(&built.problems)
    );
    assert_eq!(built.problems.len(), 1, "{}", describe(&built.problems));
    let p = &built.problems[0];
    assert_eq!(
        (p.camera, p.axis, p.direction, p.run, p.target, p.capture),
        (
            Some(3),
            Some(formats::Axis::X),
            Some(formats::Direction::Down),
            Some(1),
            Some(1),
            Some(1)
        )
    );
    // Pixels are read only where needed: one frame in `stride` (4 here: a
    // third of the 10 + 2 frames of the shortest stay), a few more per stay
    // to find its first still frame and check the last capture.
    let s = &built.summary;
    let dwells = 12;
    assert!(
        s.decoded <= s.files / 4 + 3 + 3 * dwells * 4,
        "{} of {} decoded",
        s.decoded,
        s.files
    );
    assert_eq!(s.placed + s.not_at_instants, s.files);
}

/// PNG frames (EXIF in an eXIf chunk), a manifest in another folder.
#[test]
fn png_frames_and_paths_relative_to_the_manifest() {
    let mut c = config(25);
    c.output.format = synth::config::ImageFormat::Png;
    c.capture.mode = CaptureMode::Triggered;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    render(&c, dir);
    std::fs::create_dir(dir.join("out")).unwrap();
    let built = build(dir, &c, &dir.join("out/manifest.csv"), &Options::default());
    assert!(built.problems.is_empty(), "{}", describe(&built.problems));
    let want: Vec<ManifestRow> = truth_manifest(dir)
        .into_iter()
        .map(|mut r| {
            r.image = format!("../{}", r.image);
            r
        })
        .collect();
    assert_eq!(built.rows, want);
}

/// Frames whose metadata exiftool rewrote (other serials, other clock
/// offsets, millisecond stamps), renamed and moved into nested folders; a
/// frame without a time, one of an unknown camera, a file that is no image.
#[test]
fn exiftool_metadata_other_names_and_bad_files() {
    if std::process::Command::new("exiftool")
        .arg("-ver")
        .output()
        .is_err()
    {
        assert!(
            std::env::var_os("TRINOCULAR_REQUIRE_EXIFTOOL").is_none(),
            "exiftool is required"
        );
        eprintln!("notice: exiftool not found; test skipped");
        return;
    }
    let mut c = config(27);
    c.capture.mode = CaptureMode::Triggered;
    c.capture.move_time_factor = 1.3;
    c.capture.move_extra_s = 0.05;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    render(&c, dir);
    let truth = truth_manifest(dir);

    // New homes and names, new serials, new clocks (an hour off, 40 s back).
    let serials = ["LEFT-17", "RIGHT 0042", "TOP/3"];
    let offsets_s = [-40.0, 3600.25, 0.777];
    let captured = dir.join("captured");
    let mut args = String::new();
    let mut renamed = std::collections::HashMap::new();
    for (k, cam) in c.rig.cameras.iter().enumerate() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join(&cam.serial))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        let folder = captured.join(format!("day1/cam{}", k + 1));
        std::fs::create_dir_all(&folder).unwrap();
        for (n, f) in files.iter().enumerate() {
            let meta = ingest::read_metadata(f).unwrap();
            let t = ingest::parse_time(meta.datetime.as_deref().unwrap()).unwrap();
            let ns = t.ns + (offsets_s[k] * 1e9) as i64;
            let secs = ns.div_euclid(1_000_000_000);
            let ms = ns.rem_euclid(1_000_000_000) / 1_000_000;
            let date = jiff::tz::TimeZone::UTC
                .to_datetime(jiff::Timestamp::from_second(secs).unwrap())
                .strftime("%Y:%m:%d %H:%M:%S")
                .to_string();
            let name = folder.join(format!("frame-{}.tiff", 7 + n));
            std::fs::copy(f, &name).unwrap();
            renamed.insert(
                f.strip_prefix(dir).unwrap().to_string_lossy().into_owned(),
                format!("captured/day1/cam{}/frame-{}.tiff", k + 1, 7 + n),
            );
            args.push_str(&format!(
                "-overwrite_original\n-DateTimeOriginal={date}\n-SubSecTimeOriginal={ms:03}\n\
                 -SerialNumber={}\n{}\n-execute\n",
                serials[k],
                name.display()
            ));
        }
    }
    let argfile = dir.join("exiftool.args");
    std::fs::write(&argfile, args).unwrap();
    let out = std::process::Command::new("exiftool")
        .arg("-@")
        .arg(&argfile)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // Bad inputs beside them.
    let bad = captured.join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    let first = captured.join("day1/cam1/frame-7.tiff");
    std::fs::copy(&first, bad.join("no-time.tif")).unwrap();
    let status = std::process::Command::new("exiftool")
        .args(["-overwrite_original", "-DateTimeOriginal=", "-ModifyDate="])
        .arg(bad.join("no-time.tif"))
        .output()
        .unwrap();
    assert!(status.status.success());
    std::fs::copy(&first, bad.join("stranger.tif")).unwrap();
    let status = std::process::Command::new("exiftool")
        .args(["-overwrite_original", "-SerialNumber=SOMEONE-ELSE"])
        .arg(bad.join("stranger.tif"))
        .output()
        .unwrap();
    assert!(status.status.success());
    std::fs::write(bad.join("notes.txt"), "no image").unwrap();
    std::fs::write(bad.join("broken.tif"), b"II*\0\xff\xff\xff\x7f").unwrap();

    let program = program(dir);
    let mut cams: Vec<(String, u8)> = serials
        .iter()
        .enumerate()
        .map(|(k, s)| ((*s).to_string(), k as u8 + 1))
        .collect();
    let build = |cameras: &[(String, u8)]| {
        ingest::build(
            &Inputs {
                program: &program,
                cameras,
                dirs: std::slice::from_ref(&captured),
                manifest: &dir.join("manifest.csv"),
            },
            &Options::default(),
        )
    };
    cams.push(("NEVER-SEEN".into(), 3));
    let err = build(&cams).unwrap_err();
    assert!(err.to_string().contains("twice"), "{err}");
    cams.pop();
    let built = build(&cams).unwrap();
    let want: Vec<ManifestRow> = truth
        .into_iter()
        .map(|mut r| {
            r.image = renamed[&r.image].clone();
            r
        })
        .collect();
    assert_eq!(built.rows, want);
    let reasons: Vec<(String, String)> = built
        .problems
        .iter()
        .map(|p| (p.image.clone().unwrap_or_default(), p.reason.clone()))
        .collect();
    assert_eq!(reasons.len(), 3, "{reasons:?}");
    assert!(
        reasons
            .iter()
            .any(|(f, r)| f.ends_with("no-time.tif") && r.contains("no time"))
    );
    assert!(
        reasons.iter().any(|(f, r)| f.ends_with("stranger.tif")
            && r.contains("unknown camera serial 'SOMEONE-ELSE'"))
    );
    assert!(
        reasons
            .iter()
            .any(|(f, r)| f.ends_with("broken.tif") && r.contains("unreadable"))
    );
    assert_eq!(built.summary.other_files, 1); // notes.txt
}

/// A camera given on the command line that left no frame is reported once.
#[test]
fn a_camera_without_frames_is_reported() {
    let mut c = config(29);
    c.capture.mode = CaptureMode::Triggered;
    c.rig.cameras.retain(|k| k.id != 3);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    render(&c, dir);
    let mut cams = cameras(&c);
    cams.push(("TRN-SYN-0003".into(), 3));
    let dirs = vec![dir.join("TRN-SYN-0001"), dir.join("TRN-SYN-0002")];
    let built = ingest::build(
        &Inputs {
            program: &program(dir),
            cameras: &cams,
            dirs: &dirs,
            manifest: &dir.join("manifest.csv"),
        },
        &Options::default(),
    )
    .unwrap();
    assert_eq!(built.rows, truth_manifest(dir));
    assert_eq!(built.problems.len(), 1, "{}", describe(&built.problems));
    assert_eq!(built.problems[0].camera, Some(3));
    assert!(built.problems[0].reason.contains("no frames"));
}
