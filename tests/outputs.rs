//! Outputs through the command line: an existing output (sidecars included)
//! is replaced only with `--force`, no command writes over one of its
//! inputs (also through links), `evaluate` replaces its report as one set,
//! two `measure` runs on one folder cannot interleave, and an interrupted
//! run (SIGINT, SIGTERM, kill −9) leaves no temporary file and, run again,
//! gives the same bytes as a run that was never interrupted. A failed run
//! leaves the output location as it was; sidecars are named after the
//! output, so runs of different outputs never collide; missing output
//! folders are made.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{
    bin, leftovers, ok, read, refused, render_campaign, s, stderr, testdata, tree, trinocular,
};

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

/// A rendered campaign `dir/c` and its rig `dir/rig.json` (calibrated from
/// the renderer's correspondences).
fn campaign(dir: &Path, width: u32, targets: u32, runs: u32, captures: u32) -> PathBuf {
    let c = dir.join("c");
    render_campaign(&c, (width, width * 3 / 4), [targets, runs, captures], &[]);
    let cam3 = c.join("calib/points_cam3.csv");
    let calibrate = calibrate_args(&c, &cam3, &dir.join("rig.json"));
    ok(&bin().args(calibrate).output().unwrap());
    c
}

/// The calibration's three target images (not its flats and darks, which
/// have no blob and are problems to `extract`).
fn target_images(c: &Path) -> Vec<String> {
    (1..=3)
        .map(|k| s(&c.join(format!("calib/cam{k}.tif"))).to_string())
        .collect()
}

/// The small campaign of the output tests (256 px, 3 targets, 2 runs), its
/// rig, and its points measured into `dir/<name>`: the campaign and that path.
fn measured(dir: &Path, name: &str) -> (PathBuf, PathBuf) {
    let c = campaign(dir, 256, 3, 2, 1);
    let points = dir.join(name);
    ok(&measure(dir, &c, &points, &[]));
    (c, points)
}

fn measure_args<'a>(dir: &'a Path, c: &'a Path, out: &'a Path) -> Vec<String> {
    [
        "measure",
        "--backend",
        "cpu",
        "--rig",
        s(&dir.join("rig.json")),
        "--manifest",
        s(&c.join("manifest.csv")),
        "--spheres",
        s(&c.join("spheres.csv")),
        "--out",
        s(out),
    ]
    .map(str::to_string)
    .to_vec()
}

fn measure(dir: &Path, c: &Path, out: &Path, extra: &[&str]) -> Output {
    bin()
        .args(measure_args(dir, c, out))
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn extract_never_writes_over_its_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = campaign(d, 256, 2, 1, 1);
    let image = d.join("z.tif");
    std::fs::copy(c.join("calib/cam1.tif"), &image).unwrap();
    let before = read(&image);
    let extract = |out: &Path, input: &Path| {
        trinocular(&[
            "extract",
            "--backend",
            "cpu",
            "--force",
            "--out",
            s(out),
            s(input),
        ])
    };
    refused(
        &extract(&image, &image),
        &["z.tif: would overwrite an input"],
    );
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&image, d.join("soft.tif")).unwrap();
        std::fs::hard_link(&image, d.join("hard.tif")).unwrap();
        refused(
            &extract(&d.join("soft.tif"), &image),
            &["would overwrite an input"],
        );
        refused(
            &extract(&d.join("hard.tif"), &image),
            &["would overwrite an input"],
        );
        refused(
            &extract(&image, &d.join("soft.tif")),
            &["would overwrite an input"],
        );
    }
    // An image of a folder given as input.
    let images = c.join("calib");
    let out = images.join("flat_cam1.tif");
    let before_flat = read(&out);
    refused(
        &extract(&out, &images),
        &["flat_cam1.tif: would overwrite an input"],
    );
    assert_eq!(read(&out), before_flat);
    assert_eq!(read(&image), before);
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

#[test]
fn extract_keeps_its_outputs_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = campaign(d, 256, 2, 1, 1);
    // The target's images (the flats and darks beside them hold no blob).
    let images: Vec<PathBuf> = (1..=3)
        .map(|k| c.join(format!("calib/cam{k}.tif")))
        .collect();
    let out = d.join("b.csv");
    let run = |out: &Path, extra: &[&str]| {
        bin()
            .args(["extract", "--backend", "cpu", "--out", s(out)])
            .args(&images)
            .args(extra)
            .output()
            .unwrap()
    };
    ok(&run(&out, &[]));
    let first = read(&out);
    refused(&run(&out, &[]), &["b.csv: already exists", "--force"]);
    assert_eq!(read(&out), first);
    ok(&run(&out, &["--force"]));
    assert_eq!(read(&out), first, "same input, same bytes");

    // The problems file beside the output is an output too.
    std::fs::write(d.join("other.problems.csv"), "item,reason\nmine,kept\n").unwrap();
    refused(
        &run(&d.join("other.csv"), &[]),
        &["other.problems.csv: already exists"],
    );
    assert!(!d.join("other.csv").exists());
    // With --force a stale problems file is replaced (this run had no
    // problems: its header alone).
    ok(&run(&d.join("other.csv"), &["--force"]));
    assert_eq!(read(&d.join("other.problems.csv")), b"item,reason\n");
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

#[test]
fn calibrate_keeps_the_rig_and_its_sidecars_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = d.join("c");
    ok(&trinocular(&[
        "synth",
        "target",
        "--out",
        s(&c),
        "--width",
        "256",
        "--height",
        "192",
    ]));
    let run = |out: &Path, extra: &[&str]| {
        let cal = |n: u8| c.join(format!("calib/points_cam{n}.csv"));
        bin()
            .args(["calibrate", "--target", s(&c.join("target.csv"))])
            .args(["--nominal", s(&c.join("nominal.json")), "--points"])
            .args([s(&cal(1)), s(&cal(2)), s(&cal(3)), "--out", s(out)])
            .args(extra)
            .output()
            .unwrap()
    };
    let rig = d.join("out").join("rig.json");
    ok(&run(&rig, &[]));
    let files = [
        "rig.json",
        "rig.cam1.opencv.yml",
        "rig.cam3.opencv.yml",
        "rig.residuals.csv",
        "rig.commissioning.txt",
        "rig.commissioning.json",
    ];
    let before: Vec<Vec<u8>> = files.iter().map(|f| read(&d.join("out").join(f))).collect();
    refused(&run(&rig, &[]), &["rig.json: already exists", "--force"]);
    // A sidecar of the rig is an output too.
    std::fs::write(d.join("out").join("other.commissioning.txt"), "mine").unwrap();
    refused(
        &run(&d.join("out").join("other.json"), &[]),
        &["other.commissioning.txt: already exists"],
    );
    assert!(!d.join("out").join("other.json").exists());
    ok(&run(&rig, &["--force"]));
    for (f, b) in files.iter().zip(&before) {
        assert_eq!(&read(&d.join("out").join(f)), b, "{f}");
    }
    // Never over an input, even with --force.
    let target = read(&c.join("target.csv"));
    refused(
        &run(&c.join("target.csv"), &["--force"]),
        &["target.csv: would overwrite an input"],
    );
    assert_eq!(read(&c.join("target.csv")), target);
    // Nor a file beside the output over an input.
    let other = d.join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::copy(
        c.join("calib/points_cam1.csv"),
        other.join("rig.residuals.csv"),
    )
    .unwrap();
    let cal = |n: u8| c.join(format!("calib/points_cam{n}.csv"));
    let sidecar = bin()
        .args(["calibrate", "--target", s(&c.join("target.csv"))])
        .args(["--nominal", s(&c.join("nominal.json")), "--points"])
        .args([s(&other.join("rig.residuals.csv")), s(&cal(2)), s(&cal(3))])
        .args(["--out", s(&other.join("rig.json")), "--force"])
        .output()
        .unwrap();
    refused(&sidecar, &["rig.residuals.csv: would overwrite an input"]);
    assert_eq!(
        read(&other.join("rig.residuals.csv")),
        read(&c.join("calib/points_cam1.csv"))
    );
    assert!(!other.join("rig.json").exists());
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

#[test]
fn synth_keeps_a_campaign_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = d.join("c");
    let args = [
        "synth",
        "campaign",
        "--out",
        s(&c),
        "--width",
        "256",
        "--height",
        "192",
        "--targets",
        "3",
        "--runs",
        "2",
        "--captures",
        "1",
    ];
    ok(&trinocular(&args));
    let manifest = read(&c.join("manifest.csv"));
    let image = read(&c.join("images/X1/run1-up/t000_c01_cam2.tif"));
    refused(&trinocular(&args), &["already exists", "--force"]);
    let mut forced = args.to_vec();
    forced.push("--force");
    ok(&trinocular(&forced));
    assert_eq!(read(&c.join("manifest.csv")), manifest);
    assert_eq!(read(&c.join("images/X1/run1-up/t000_c01_cam2.tif")), image);
    // Its own config.toml as the configuration: an input, never replaced.
    let config_path = c.join("config.toml");
    let config = read(&config_path);
    let mut again = forced.clone();
    again.extend(["--config", s(&config_path)]);
    refused(
        &trinocular(&again),
        &["config.toml: would overwrite an input"],
    );
    assert_eq!(read(&config_path), config);

    let t = d.join("t");
    let target = [
        "synth",
        "target",
        "--out",
        s(&t),
        "--width",
        "256",
        "--height",
        "192",
    ];
    ok(&trinocular(&target));
    refused(&trinocular(&target), &["already exists", "--force"]);
    // The probe generators refuse as well.
    for method in ["tracer", "volumetric", "rotary", "indexing"] {
        let out = d.join(method);
        let args = ["synth", "probe", method, "--out", s(&out)];
        ok(&trinocular(&args));
        refused(&trinocular(&args), &["already exists", "--force"]);
    }
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

#[test]
fn evaluate_replaces_its_report_as_one_set() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (_, points) = measured(d, "points.csv");
    let report = d.join("report");
    let run = |points: &Path, out: &Path, extra: &[&str]| {
        bin()
            .args(["evaluate", "--points", s(points), "--out", s(out)])
            .args(extra)
            .output()
            .unwrap()
    };
    ok(&run(&points, &report, &[]));
    assert!(report.join("positioning_Y.csv").exists());
    let json = read(&report.join("report.json"));
    refused(
        &run(&points, &report, &[]),
        &["report: already exists", "--force"],
    );
    assert_eq!(read(&report.join("report.json")), json);

    // An X-only report replaces the X-and-Y one whole: no stale Y table.
    let text = String::from_utf8(read(&points)).unwrap();
    let x_only: Vec<&str> = text
        .lines()
        .enumerate()
        .filter(|(i, l)| *i == 0 || l.starts_with("X,"))
        .map(|(_, l)| l)
        .collect();
    let x_points = d.join("x_points.csv");
    std::fs::write(&x_points, x_only.join("\n") + "\n").unwrap();
    ok(&run(&x_points, &report, &["--force"]));
    assert!(report.join("positioning_X.csv").exists());
    for y in ["positioning_Y.csv", "straightness_Y.csv", "angular_Y.csv"] {
        assert!(!report.join(y).exists(), "stale {y}");
    }
    // A file a report does not write is never deleted, even with --force.
    std::fs::write(report.join("notes.txt"), "mine").unwrap();
    refused(&run(&points, &report, &["--force"]), &["holds notes.txt"]);
    assert_eq!(read(&report.join("notes.txt")), b"mine");
    // Nor is the folder that holds the input.
    refused(
        &run(&points, d, &["--force"]),
        &["would overwrite an input", "points.csv"],
    );
    assert!(points.exists());
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

#[test]
fn measure_keeps_its_outputs_and_sidecars_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (c, a) = measured(d, "a.csv");
    let (points, poses) = (read(&a), read(&d.join("a.poses.csv")));
    refused(
        &measure(d, &c, &a, &[]),
        &["a.csv: already exists", "--force"],
    );
    // The poses beside an output are an output too.
    std::fs::write(d.join("b.poses.csv"), "mine").unwrap();
    refused(
        &measure(d, &c, &d.join("b.csv"), &[]),
        &["b.poses.csv: already exists"],
    );
    assert!(!d.join("b.csv").exists());
    ok(&measure(d, &c, &a, &["--force"]));
    assert_eq!(read(&a), points);
    assert_eq!(read(&d.join("a.poses.csv")), poses);
    // Never over an input.
    refused(
        &measure(d, &c, &d.join("rig.json"), &["--force"]),
        &["rig.json: would overwrite an input"],
    );
    refused(
        &measure(
            d,
            &c,
            &c.join("images/X1/run1-up/t000_c01_cam2.tif"),
            &["--force"],
        ),
        &["would overwrite an input"],
    );
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

/// Run `args`, which must fail (not a batch that finished with problems),
/// and find `w` exactly as it was: no file or folder added, none changed.
/// Returns the failure's stderr.
fn fails_leaving_as_it_was<A: AsRef<std::ffi::OsStr> + std::fmt::Debug>(
    w: &Path,
    args: &[A],
) -> String {
    let before = tree(w);
    let out = bin().args(args).output().unwrap();
    let err = stderr(&out);
    assert!(
        !out.status.success() && out.status.code() != Some(3),
        "{args:?} did not fail: {err}"
    );
    assert_eq!(tree(w), before, "{args:?} left files behind: {err}");
    err
}

/// `calibrate` from the campaign `c`'s correspondences, the third camera's
/// from `cam3`, into `out`.
fn calibrate_args(c: &Path, cam3: &Path, out: &Path) -> Vec<String> {
    let cal = |n: u8| c.join(format!("calib/points_cam{n}.csv"));
    [
        "calibrate",
        "--target",
        s(&c.join("target.csv")),
        "--nominal",
        s(&c.join("nominal.json")),
        "--points",
        s(&cal(1)),
        s(&cal(2)),
        s(cam3),
        "--out",
        s(out),
    ]
    .map(str::to_string)
    .to_vec()
}

/// Issue 23, defect 2: whatever fails — an input that names nothing, found
/// before the plan, or a bad input found only after it — the output location
/// is left as it was (no empty output, no problems file, no partial, no lock,
/// no folder made), and the corrected run then succeeds without `--force`.
#[test]
fn a_failed_run_leaves_the_output_location_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = campaign(d, 256, 3, 2, 1);
    let w = d.join("w");
    std::fs::create_dir(&w).unwrap();
    std::fs::write(w.join("earlier.txt"), "not this run's").unwrap();
    let bad = d.join("bad.tif");
    std::fs::write(&bad, b"II*\0not a tiff").unwrap();

    // extract: the issue's case, an input that names nothing ...
    let blobs = w.join("blobs.csv");
    let extract = |out: &Path, input: &Path| -> Vec<String> {
        ["extract", "--backend", "cpu", "--out", s(out), s(input)]
            .map(str::to_string)
            .to_vec()
    };
    let err = fails_leaving_as_it_was(&w, &extract(&blobs, Path::new("/nope/dir")));
    assert!(err.contains("/nope/dir: no such file or folder"), "{err}");
    // ... and images found unusable only when read, after the plan;
    let err = fails_leaving_as_it_was(&w, &extract(&blobs, &bad));
    assert!(
        err.contains("the only image could not be used") && err.contains("bad.tif"),
        "{err}"
    );
    // into folders that do not exist yet, the same.
    let deeper = w.join("new").join("deeper").join("blobs.csv");
    fails_leaving_as_it_was(&w, &extract(&deeper, &bad));
    // (the calibration's target images: its flats and darks have no blob)
    let mut corrected = extract(&blobs, &c.join("calib/cam1.tif"));
    corrected.extend(target_images(&c).into_iter().skip(1));
    ok(&bin().args(corrected).output().unwrap());

    // measure: spheres that match nothing in the images, found while
    // measuring (after the partial output and its fingerprint were written).
    let points = w.join("points.csv");
    let big = d.join("big_spheres.csv");
    std::fs::write(&big, "name,diameter\nA,60\nB,45\nC,30\n").unwrap();
    let mut args = measure_args(d, &c, &points);
    let spheres = args.iter().position(|a| a == "--spheres").unwrap() + 1;
    args[spheres] = s(&big).to_string();
    let err = fails_leaving_as_it_was(&w, &args);
    assert!(
        err.contains("instants could be measured; the first: "),
        "{err}"
    );
    // A manifest that names nothing.
    let mut args = measure_args(d, &c, &w.join("m").join("points.csv"));
    let manifest = args.iter().position(|a| a == "--manifest").unwrap() + 1;
    args[manifest] = s(&d.join("nope.csv")).to_string();
    fails_leaving_as_it_was(&w, &args);
    ok(&measure(d, &c, &points, &[]));

    // calibrate: camera 3's correspondences too few to calibrate it, found
    // after the outputs were planned; and a correspondence file that names nothing.
    let rig = w.join("cal").join("rig.json");
    let few = d.join("few.csv");
    std::fs::write(&few, "id,u,v\n1,10.5,20.5\n2,30.5,40.5\n").unwrap();
    fails_leaving_as_it_was(&w, &calibrate_args(&c, &few, &rig));
    fails_leaving_as_it_was(&w, &calibrate_args(&c, &d.join("nope.csv"), &rig));
    let cam3 = c.join("calib/points_cam3.csv");
    ok(&bin()
        .args(calibrate_args(&c, &cam3, &rig))
        .output()
        .unwrap());

    // evaluate and a probe method: inputs that name nothing.
    let report = w.join("reports").join("first");
    fails_leaving_as_it_was(
        &w,
        &[
            "evaluate",
            "--points",
            s(&d.join("nope.csv")),
            "--out",
            s(&report),
        ],
    );
    ok(&trinocular(&[
        "evaluate",
        "--points",
        s(&points),
        "--out",
        s(&report),
    ]));
    let rotary = w.join("probe").join("rotary");
    fails_leaving_as_it_was(
        &w,
        &[
            "probe",
            "rotary",
            "--centres",
            s(&d.join("nope.csv")),
            "--out",
            s(&rotary),
        ],
    );
    let centres = testdata("probe/rotary/centres.csv");
    ok(&trinocular(&[
        "probe",
        "rotary",
        "--centres",
        s(&centres),
        "--out",
        s(&rotary),
    ]));

    // manifest: a camera folder that names nothing.
    fails_leaving_as_it_was(
        &w,
        &[
            "manifest",
            "--program",
            s(&c.join("config.toml")),
            "--camera",
            "TRN-SYN-0001=1",
            "--out",
            s(&w.join("built").join("manifest.csv")),
            s(&d.join("nope")),
        ],
    );

    // demo: a step that fails removes what the earlier ones made, its folder too.
    fails_leaving_as_it_was(&w, &["demo", "--out", s(&w.join("demo")), "--width", "4"]);
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

/// Issue 23, defect 3: sidecars are named after the output's stem, so two
/// runs with different `--out` in one folder never collide.
#[test]
fn sidecars_follow_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = campaign(d, 256, 3, 2, 1);
    let w = d.join("w");
    let cam3 = c.join("calib/points_cam3.csv");
    for stem in ["rig", "rig2"] {
        let out = w.join(format!("{stem}.json"));
        ok(&bin()
            .args(calibrate_args(&c, &cam3, &out))
            .output()
            .unwrap());
        for sidecar in [
            "cam1.opencv.yml",
            "cam3.opencv.yml",
            "residuals.csv",
            "commissioning.txt",
            "commissioning.json",
        ] {
            assert!(
                w.join(format!("{stem}.{sidecar}")).is_file(),
                "{stem}.{sidecar}"
            );
        }
    }
    assert_eq!(
        read(&w.join("rig.commissioning.json")),
        read(&w.join("rig2.commissioning.json")),
        "the same calibration, the same report"
    );
    for stem in ["a", "b"] {
        ok(&measure(d, &c, &w.join(format!("{stem}.csv")), &[]));
    }
    assert_eq!(read(&w.join("a.poses.csv")), read(&w.join("b.poses.csv")));
    // Problems too: an unreadable image beside a good one, two outputs.
    let bad = d.join("bad.tif");
    std::fs::write(&bad, b"II*\0not a tiff").unwrap();
    let good = c.join("calib/cam1.tif");
    for stem in ["blobs", "other"] {
        let out = w.join(format!("{stem}.csv"));
        let run = trinocular(&[
            "extract",
            "--backend",
            "cpu",
            "--out",
            s(&out),
            s(&bad),
            s(&good),
        ]);
        assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
        let problems = w.join(format!("{stem}.problems.csv"));
        assert!(stderr(&run).contains(s(&problems)), "{}", stderr(&run));
        assert!(
            String::from_utf8(read(&problems))
                .unwrap()
                .contains("bad.tif")
        );
    }
    for old in [
        "commissioning.txt",
        "commissioning.json",
        "poses.csv",
        "problems.csv",
    ] {
        assert!(!w.join(old).exists(), "{old}");
    }
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

/// Issue 23, defect 4: one rule for every command, the missing output
/// folders are made (extract and measure refused them).
#[test]
fn missing_output_folders_are_made() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = campaign(d, 256, 3, 2, 1);
    let blobs = d.join("x").join("y").join("blobs.csv");
    let mut args = ["extract", "--backend", "cpu", "--out", s(&blobs)]
        .map(str::to_string)
        .to_vec();
    args.extend(target_images(&c));
    ok(&bin().args(args).output().unwrap());
    assert!(blobs.is_file());
    let points = d.join("m").join("n").join("points.csv");
    ok(&measure(d, &c, &points, &[]));
    assert!(points.is_file() && d.join("m/n/points.poses.csv").is_file());
    let report = d.join("r").join("s").join("report");
    ok(&trinocular(&[
        "evaluate",
        "--points",
        s(&points),
        "--out",
        s(&report),
    ]));
    assert!(report.join("report.json").is_file());
    // A file where a folder is needed is named, and nothing is written.
    std::fs::write(d.join("f"), "mine").unwrap();
    let run = trinocular(&[
        "extract",
        "--backend",
        "cpu",
        "--out",
        s(&d.join("f").join("blobs.csv")),
        s(&c.join("calib")),
    ]);
    refused(&run, &["f: is a file, not a folder"]);
    assert_eq!(read(&d.join("f")), b"mine");
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

/// Signals and concurrent runs (Unix).
#[cfg(unix)]
mod interrupted {
    use super::*;

    /// Rows per chunk of the partial output: 16 instants × 3 spheres.
    const CHUNK_ROWS: usize = 48;

    fn signal(child: &Child, name: &str) {
        let pid = child.id().to_string();
        let status = Command::new("kill")
            .args([&format!("-{name}"), &pid])
            .status()
            .unwrap();
        assert!(status.success(), "kill -{name} {pid}");
    }

    fn spawn(args: &[String]) -> Child {
        bin()
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    }

    /// Wait until `ready` holds, the child still running; then stop it
    /// (SIGSTOP), so that what follows happens mid-run.
    fn stop_when(child: &mut Child, what: &str, ready: impl Fn() -> bool) {
        let start = std::time::Instant::now();
        while !ready() {
            assert!(
                child.try_wait().unwrap().is_none(),
                "the run ended before {what}"
            );
            assert!(start.elapsed().as_secs() < 120, "no {what} after 2 min");
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        signal(child, "STOP");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before {what}"
        );
    }

    fn rows(path: &Path) -> usize {
        std::fs::read_to_string(path)
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0)
    }

    /// The campaign of the interruption tests: 180 instants (12 chunks) at
    /// 512×384 px, so that a run takes a while after its first chunk.
    fn big(d: &Path) -> PathBuf {
        campaign(d, 512, 5, 3, 2)
    }

    /// An uninterrupted run's points.csv and its poses.
    fn reference(d: &Path, c: &Path) -> (Vec<u8>, Vec<u8>) {
        let r = d.join("reference");
        std::fs::create_dir(&r).unwrap();
        ok(&measure(d, c, &r.join("points.csv"), &[]));
        (
            read(&r.join("points.csv")),
            read(&r.join("points.poses.csv")),
        )
    }

    /// Interrupt a measure run after its first chunk with `how`; then run it
    /// again: the same bytes as the reference, nothing left over.
    fn interrupt_then_resume(how: &str, status: Option<i32>) {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let c = big(d);
        let (points, poses) = reference(d, &c);
        let run = d.join("run");
        std::fs::create_dir(&run).unwrap();
        let out = run.join("points.csv");
        let partial = run.join("points.csv.partial");
        let mut child = spawn(&measure_args(d, &c, &out));
        stop_when(&mut child, "the first chunk", || {
            rows(&partial) >= CHUNK_ROWS
        });
        signal(&child, how);
        signal(&child, "CONT");
        let ended = child.wait_with_output().unwrap();
        assert_eq!(ended.status.code(), status, "{}", stderr(&ended));
        let kept = rows(&partial);
        assert!((CHUNK_ROWS..180 * 3).contains(&kept), "{kept} rows kept");
        assert!(!out.exists());
        let left = leftovers(&run);
        if how == "KILL" {
            // Nothing runs on SIGKILL: the lock stays, and whatever
            // temporary file was open at that instant.
            assert!(left.contains(&run.join(".trinocular.lock")), "{left:?}");
        } else {
            assert!(
                stderr(&ended).contains(&format!("interrupted by SIG{how}")),
                "{}",
                stderr(&ended)
            );
            // The message says what a rerun does.
            assert!(
                stderr(&ended).contains("run the same command again to resume"),
                "{}",
                stderr(&ended)
            );
            assert!(left.is_empty(), "{left:?}");
        }

        let again = ok(&measure(d, &c, &out, &[]));
        assert!(again.contains("resumed from an interrupted run"), "{again}");
        if how == "KILL" {
            assert!(
                again.contains("took over the lock of a run that is no longer running"),
                "{again}"
            );
        }
        assert_eq!(read(&out), points, "points.csv as uninterrupted");
        assert_eq!(
            read(&run.join("points.poses.csv")),
            poses,
            "points.poses.csv as uninterrupted"
        );
        assert!(!partial.exists() && !run.join("points.csv.resume.json").exists());
        assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
    }

    #[test]
    fn measure_resumes_after_sigint() {
        interrupt_then_resume("INT", Some(130));
    }

    #[test]
    fn measure_resumes_after_kill_9() {
        interrupt_then_resume("KILL", None);
    }

    #[test]
    fn a_second_measure_on_the_same_output_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let c = big(d);
        let (points, poses) = reference(d, &c);
        let out = d.join("points.csv");
        let mut first = spawn(&measure_args(d, &c, &out));
        let lock = d.join(".trinocular.lock");
        stop_when(&mut first, "the lock", || {
            std::fs::read_to_string(&lock).is_ok_and(|t| t.ends_with('\n'))
        });
        let holder = format!("pid {}, trinocular measure", first.id());
        for second in [&out, &d.join("other.csv")] {
            refused(
                &measure(d, &c, second, &[]),
                &[
                    &format!("another trinocular run ({holder}) is writing into this folder"),
                    "choose another --out",
                ],
            );
        }
        // The same goes for --force: a run in progress is never replaced.
        refused(&measure(d, &c, &out, &["--force"]), &[&holder]);
        signal(&first, "CONT");
        let done = first.wait_with_output().unwrap();
        assert!(done.status.success(), "{}", stderr(&done));
        assert_eq!(read(&out), points, "the first run's output is complete");
        assert_eq!(read(&d.join("points.poses.csv")), poses);
        assert!(!d.join("other.csv").exists());
        assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
    }

    /// Extract with a FIFO among the images: the run blocks on it, its
    /// output's temporary file open, until it is interrupted.
    fn interrupt_extract(how: &str, status: Option<i32>) {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let c = campaign(d, 256, 2, 1, 1);
        let images = d.join("images");
        std::fs::create_dir(&images).unwrap();
        for k in 1..=3 {
            std::fs::copy(
                c.join(format!("calib/cam{k}.tif")),
                images.join(format!("cam{k}.tif")),
            )
            .unwrap();
        }
        let last = images.join("cam3.tif");
        let saved = read(&last);
        std::fs::remove_file(&last).unwrap();
        assert!(
            Command::new("mkfifo")
                .arg(&last)
                .status()
                .unwrap()
                .success()
        );
        let run = d.join("run");
        std::fs::create_dir(&run).unwrap();
        let out = run.join("b.csv");
        let extract = |out: &Path| -> Vec<String> {
            let mut args: Vec<String> = ["extract", "--backend", "cpu", "--out", s(out)]
                .map(str::to_string)
                .to_vec();
            args.extend((1..=3).map(|k| s(&images.join(format!("cam{k}.tif"))).to_string()));
            args
        };
        let args = extract(&out);
        let mut child = spawn(&args);
        stop_when(&mut child, "the temporary output", || {
            leftovers(&run).iter().any(|p| {
                p.file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with(".b.csv."))
            })
        });
        signal(&child, how);
        signal(&child, "CONT");
        let ended = child.wait_with_output().unwrap();
        assert_eq!(ended.status.code(), status, "{}", stderr(&ended));
        assert!(!out.exists());
        if how != "KILL" {
            assert!(leftovers(&run).is_empty(), "{:?}", leftovers(&run));
        }
        // The image back, the run again: as if never interrupted.
        std::fs::remove_file(&last).unwrap();
        std::fs::write(&last, saved).unwrap();
        let again = bin().args(&args).output().unwrap();
        let note = ok(&again);
        if how == "KILL" {
            assert!(
                note.contains("removed the temporary file it left"),
                "{note}"
            );
        }
        let reference = d.join("reference.csv");
        ok(&bin().args(extract(&reference)).output().unwrap());
        assert_eq!(read(&out), read(&reference));
        assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
    }

    #[test]
    fn extract_leaves_no_temporary_file_on_sigint() {
        interrupt_extract("INT", Some(130));
    }

    #[test]
    fn extract_leaves_no_temporary_file_on_sigterm() {
        interrupt_extract("TERM", Some(143));
    }

    #[test]
    fn extract_after_kill_9_cleans_up_and_gives_the_same_bytes() {
        interrupt_extract("KILL", None);
    }
    /// A `synth campaign` interrupted while it renders frames: run again, it
    /// says the folder holds an incomplete rendering and how to go on
    /// (`--force`), and with `--force` it writes the whole campaign.
    #[test]
    fn an_interrupted_synth_campaign_says_so_when_run_again() {
        let dir = tempfile::tempdir().unwrap();
        let c = dir.path().join("c");
        let args: Vec<String> = [
            "synth",
            "campaign",
            "--out",
            s(&c),
            "--width",
            "512",
            "--height",
            "384",
            "--targets",
            "5",
            "--runs",
            "3",
            "--captures",
            "2",
        ]
        .map(str::to_string)
        .to_vec();
        let mut child = spawn(&args);
        // The calibration images are written before the frames.
        stop_when(&mut child, "the calibration images", || {
            c.join("calib/points_cam3.csv").exists()
        });
        signal(&child, "INT");
        signal(&child, "CONT");
        let ended = child.wait_with_output().unwrap();
        assert_eq!(ended.status.code(), Some(130), "{}", stderr(&ended));
        assert!(!c.join("manifest.csv").exists());

        refused(
            &bin().args(&args).output().unwrap(),
            &[s(&c), "incomplete rendering", "--force"],
        );
        let mut forced = args.clone();
        forced.push("--force".into());
        ok(&bin().args(&forced).output().unwrap());
        assert!(c.join("manifest.csv").exists() && c.join("truth.json").exists());
        assert!(
            leftovers(dir.path()).is_empty(),
            "{:?}",
            leftovers(dir.path())
        );
    }
}
