//! `trinocular measure`'s exit status tells the truth: 0 when every instant
//! was measured, 3 when some were not (each in points.problems.csv), 1 when
//! none was (a failure: nothing is left), 2 for a usage error. The campaign is tiny (384×288 px, 3 targets,
//! 2 runs) and the rig is the renderer's true one.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{render_campaign, write_true_rig};

use std::path::Path;
use std::process::{Command, Output};

use formats::{InstantProblemRow, ManifestRow, Missing, PointRow};

fn trinocular<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trinocular"))
        .args(args)
        .env("TRINOCULAR_NO_GPU", "1")
        .output()
        .expect("run trinocular")
}

fn records<T: formats::Record>(p: &Path) -> Vec<T> {
    formats::read_csv(p)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}

/// Render the campaign into `dir/c` and write the true rig as `dir/rig.json`.
fn campaign(dir: &Path) -> usize {
    let c = dir.join("c");
    render_campaign(&c, (384, 288), [3, 2, 1], &[]);
    write_true_rig(&c, &dir.join("rig.json")).instants.len()
}

/// Run measure into `dir/NAME/points.csv` with `spheres`; (status, last stderr line).
fn measure(dir: &Path, name: &str, spheres: &Path, extra: &[&str]) -> (i32, String) {
    let out_dir = dir.join(name);
    std::fs::create_dir_all(&out_dir).unwrap();
    let mut args: Vec<std::ffi::OsString> = vec![
        "measure".into(),
        "--rig".into(),
        dir.join("rig.json").into(),
        "--manifest".into(),
        dir.join("c/manifest.csv").into(),
        "--spheres".into(),
        spheres.into(),
        "--out".into(),
        out_dir.join("points.csv").into(),
        "--backend".into(),
        "cpu".into(),
    ];
    args.extend(extra.iter().map(Into::into));
    let out = trinocular(&args);
    let err = String::from_utf8(out.stderr).unwrap();
    (
        out.status.code().unwrap(),
        err.trim_end().lines().last().unwrap_or("").to_string(),
    )
}

#[test]
fn exit_status_counts_the_instants_measured() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let instants = campaign(d);
    let spheres = d.join("c/spheres.csv");

    // All measured: 0, no problems file.
    let (status, last) = measure(d, "all", &spheres, &[]);
    assert_eq!(status, 0, "{last}");
    assert_eq!(
        last,
        format!(
            "measured {instants} of {instants} instants → {}",
            d.join("all/points.csv").display()
        )
    );
    // The problems file is written always: its header alone.
    let problems = std::fs::read_to_string(d.join("all/points.problems.csv")).unwrap();
    assert_eq!(problems.lines().count(), 1, "{problems}");
    assert!(
        problems.starts_with("axis,direction,run,target,capture"),
        "{problems}"
    );
    assert_eq!(
        records::<PointRow>(&d.join("all/points.csv")).len(),
        3 * instants
    );

    // Usage error: 2, nothing written.
    let (status, last) = measure(d, "usage", &spheres, &["--k", "nan"]);
    assert_eq!(status, 2, "{last}");
    assert!(
        last.starts_with("trinocular: error: invalid value 'nan' for '--k <K>'"),
        "{last}"
    );
    assert!(!d.join("usage/points.csv").exists());

    // One frame unreadable: 3, the instant in the problems file, the rest measured.
    let manifest: Vec<ManifestRow> = records(&d.join("c/manifest.csv"));
    let broken = d.join("c").join(&manifest[4].image);
    std::fs::write(&broken, b"II*\0not a tiff").unwrap();
    let (status, last) = measure(d, "some", &spheres, &[]);
    assert_eq!(status, 3, "{last}");
    let problems_csv = d.join("some/points.problems.csv");
    assert_eq!(
        last,
        format!(
            "trinocular: finished with problems: 1 of {instants} instants could not be measured; listed in {}",
            problems_csv.display()
        )
    );
    let problems: Vec<InstantProblemRow> = records(&problems_csv);
    assert_eq!(problems.len(), 1);
    assert_eq!(problems[0].missing, Missing::Instant);
    assert_eq!(problems[0].instant(), manifest[4].instant());
    assert_eq!(problems[0].image.as_deref(), Some(broken.to_str().unwrap()));
    assert_eq!(
        records::<PointRow>(&d.join("some/points.csv")).len(),
        3 * (instants - 1)
    );

    // Spheres three times the size of those in the images: nothing matches,
    // none measured: 1, a failure, so nothing is left in the output folder
    // (issue 23; it kept an empty points.csv and the problems before), and
    // the message gives the first problem.
    let big = d.join("big_spheres.csv");
    std::fs::write(&big, "name,diameter\nA,60\nB,45\nC,30\n").unwrap();
    let (status, last) = measure(d, "none", &big, &[]);
    assert_eq!(status, 1, "{last}");
    assert!(
        last.starts_with(&format!(
            "trinocular: error: none of the {instants} instants could be measured; the first: "
        )) && last.contains("spheres A, B, C not found"),
        "{last}"
    );
    assert_eq!(std::fs::read_dir(d.join("none")).unwrap().count(), 0);
}

/// With `--all-cameras`, an instant whose frame of one camera is unreadable
/// is measured from the other two: every instant is in points.csv, and the
/// camera left out is a `camera` row of points.problems.csv — a problem
/// listed, so the status is 3, and the message says what it is.
#[test]
fn a_camera_left_out_is_listed_with_status_3() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let instants = campaign(d);
    let manifest: Vec<ManifestRow> = records(&d.join("c/manifest.csv"));
    let broken = d.join("c").join(&manifest[4].image);
    std::fs::write(&broken, b"II*\0not a tiff").unwrap();
    let (status, last) = measure(d, "all", &d.join("c/spheres.csv"), &["--all-cameras"]);
    assert_eq!(status, 3, "{last}");
    let problems_csv = d.join("all/points.problems.csv");
    assert_eq!(
        last,
        format!(
            "trinocular: finished with problems: 1 instant measured without one of its cameras; listed in {}",
            problems_csv.display()
        )
    );
    let problems: Vec<InstantProblemRow> = records(&problems_csv);
    assert_eq!(problems.len(), 1);
    assert_eq!(problems[0].missing, Missing::Camera);
    assert_eq!(problems[0].camera, Some(manifest[4].camera));
    assert_eq!(problems[0].instant(), manifest[4].instant());
    assert_eq!(
        records::<PointRow>(&d.join("all/points.csv")).len(),
        3 * instants
    );
}

/// Sphere images whose pixels reach the sensor's maximum are measured (the
/// instants are not lost) but said to be saturated, per camera, on stderr:
/// their flat tops bias the centres. The same campaign at the seed's
/// brightness says nothing of the kind.
#[test]
fn saturated_sphere_images_are_warned_about() {
    let tmp = tempfile::tempdir().unwrap();
    let config = common::ok_stdout(&trinocular(&["synth", "config"]));
    let mut bright: toml::Table = config.parse().unwrap();
    for sphere in bright["spheres"].as_array_mut().unwrap() {
        let t = sphere.as_table_mut().unwrap();
        let r = t["radiance_e"].as_float().unwrap();
        t.insert("radiance_e".into(), toml::Value::Float(4.0 * r));
    }
    let bright_cfg = tmp.path().join("bright.toml");
    std::fs::write(&bright_cfg, toml::to_string(&bright).unwrap()).unwrap();
    for (name, saturated) in [("seed", false), ("bright", true)] {
        let dir = tmp.path().join(name);
        let c = dir.join("c");
        let extra: &[&str] = if saturated {
            &["--config", common::s(&bright_cfg)]
        } else {
            &[]
        };
        render_campaign(&c, (384, 288), [3, 2, 1], extra);
        write_true_rig(&c, &dir.join("rig.json"));
        let out = trinocular(&[
            "measure",
            "--rig",
            common::s(&dir.join("rig.json")),
            "--manifest",
            common::s(&c.join("manifest.csv")),
            "--spheres",
            common::s(&c.join("spheres.csv")),
            "--out",
            common::s(&dir.join("points.csv")),
            "--backend",
            "cpu",
        ]);
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(out.status.code(), Some(0), "{name}: {err}");
        let warnings: Vec<&str> = err
            .lines()
            .filter(|l| l.contains("have saturated pixels"))
            .collect();
        if saturated {
            assert!(!warnings.is_empty(), "{name}: no saturation warning: {err}");
            assert!(
                warnings
                    .iter()
                    .all(|w| w.contains("camera ") && w.contains(" of "))
            );
        } else {
            assert!(warnings.is_empty(), "{name}: {warnings:?}");
        }
    }
}
