//! `trinocular manifest` end to end: a campaign rendered as cameras save it
//! (`synth campaign --as-captured`), its manifest built from the camera
//! folders, and `measure` on that manifest giving the same `points.csv`,
//! byte for byte, as `measure` on the renderer's own manifest. Exit status 3
//! with the faults in `manifest.problems.csv`; no manifest replaced without `--force`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{render_campaign, s, trinocular, write_true_rig};

use std::path::Path;

#[test]
fn captured_folders_to_the_same_points() {
    let tmp = tempfile::tempdir().unwrap();
    let c = tmp.path().join("c");
    let config = tmp.path().join("capture.toml");
    // A frame of camera 1 dropped in an X sweep (X is measured with cameras 2 and 3)
    // and a stray trigger of camera 3.
    std::fs::write(
        &config,
        "[capture]\nmode = \"triggered\"\ndropped = [{camera = 1, instant = 30}]\n\
         stray = [{camera = 3, dwell = 10}]\n",
    )
    .unwrap();
    render_campaign(
        &c,
        (256, 192),
        [3, 2, 2],
        &["--config", s(&config), "--seed", "31"],
    );
    assert!(!c.join("manifest.csv").exists());
    write_true_rig(&c, &c.join("rig.json"));

    let built = tmp.path().join("built");
    std::fs::create_dir(&built).unwrap();
    let manifest = built.join("manifest.csv");
    let program = c.join("program.toml");
    let (cam1, cam2, cam3) = (
        c.join("TRN-SYN-0001"),
        c.join("TRN-SYN-0002"),
        c.join("TRN-SYN-0003"),
    );
    let args = [
        "manifest",
        "--program",
        s(&program),
        "--camera",
        "TRN-SYN-0001=1",
        "--camera",
        "TRN-SYN-0002=2",
        "--camera",
        "TRN-SYN-0003=3",
        "--out",
        s(&manifest),
        s(&cam1),
        s(&cam2),
        s(&cam3),
    ];
    let out = trinocular(&args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(err.contains("manifest.problems.csv"), "{err}");
    let problems = std::fs::read_to_string(built.join("manifest.problems.csv")).unwrap();
    assert_eq!(problems.lines().count(), 3, "{problems}");
    assert!(problems.contains("stray"), "{problems}");
    assert!(problems.contains("has no frame of camera 1"), "{problems}");

    // An existing manifest is kept unless --force.
    let before = std::fs::read(&manifest).unwrap();
    let out = trinocular(&args);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--force") && err.lines().count() == 1, "{err}");
    let mut forced = args.to_vec();
    forced.push("--force");
    assert_eq!(trinocular(&forced).status.code(), Some(3));
    assert_eq!(std::fs::read(&manifest).unwrap(), before);

    // measure on both manifests.
    let measure = |manifest: &Path, out: &Path| {
        std::fs::create_dir_all(out.parent().unwrap()).unwrap();
        let o = trinocular(&[
            "measure",
            "--rig",
            s(&c.join("rig.json")),
            "--manifest",
            s(manifest),
            "--spheres",
            s(&c.join("spheres.csv")),
            "--backend",
            "cpu",
            "--out",
            s(out),
        ]);
        assert!(
            matches!(o.status.code(), Some(0 | 3)),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        (o.status.code(), std::fs::read(out).unwrap())
    };
    let a = measure(&manifest, &tmp.path().join("a/points.csv"));
    let b = measure(
        &c.join("truth_manifest.csv"),
        &tmp.path().join("b/points.csv"),
    );
    // 72 instants × 3 spheres.
    assert_eq!(String::from_utf8_lossy(&a.1).lines().count(), 1 + 72 * 3);
    assert_eq!(a.0, b.0);
    assert!(a.1 == b.1, "points.csv differ");
}

#[test]
fn manifest_help_and_bad_input() {
    let out = trinocular(&["manifest", "--help"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for flag in ["--program", "--camera", "--out", "--continuous", "--force"] {
        assert!(text.contains(flag), "{flag} missing from:\n{text}");
    }
    let tmp = tempfile::tempdir().unwrap();
    let program = tmp.path().join("program.toml");
    std::fs::write(&program, "[procedure]\nruns = 2\n").unwrap();
    let out = trinocular(&[
        "manifest",
        "--program",
        s(&program),
        "--camera",
        "X=1",
        "--out",
        s(&tmp.path().join("m.csv")),
        s(tmp.path()),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("program.toml") && err.contains("procedure.captures"),
        "{err}"
    );
    let out = trinocular(&[
        "manifest",
        "--program",
        s(&program),
        "--camera",
        "X=one",
        "--out",
        "m.csv",
        ".",
    ]);
    assert_eq!(out.status.code(), Some(2));
}
