//! The measure batch on damaged campaigns: every problem reported, nothing
//! lost, nothing duplicated, what is whole still measured. The campaign is small (640×480 px, same field of
//! view as the seed rig) and the rig is the renderer's true one.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};

use formats::{
    FormatError, InstantProblemRow, ManifestRow, Missing, OutputPlan, PointRow, PoseRow, Rig,
    SphereRow, read_csv, write_csv,
};
use fuse::{FuseError, Inputs, MeasureOptions, Summary, measure};
use image::{ImageBuffer, Luma};

/// 640×480 px, 3 targets per axis, 2 runs.
fn campaign(dir: &Path) {
    common::campaign(dir, 640, 3, 2, 5);
}

fn rig(dir: &Path) -> Rig {
    common::true_rig(dir)
}

fn spheres(dir: &Path) -> Vec<SphereRow> {
    common::spheres(dir)
}

fn manifest(dir: &Path) -> Vec<ManifestRow> {
    read_csv(&dir.join("manifest.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}

/// Measure into `dir/out` (its folder created), existing outputs kept.
fn run(dir: &Path, out: &str, progress: &(dyn Fn(u64, u64) + Sync)) -> fuse::Result<Summary> {
    if let Some(folder) = dir.join(out).parent() {
        std::fs::create_dir_all(folder).unwrap();
    }
    common::measure_with(dir, out, &MeasureOptions::default(), progress, false)
}

fn points(path: &Path) -> Vec<PointRow> {
    read_csv(path)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}

fn problems(dir: &Path) -> Vec<InstantProblemRow> {
    read_csv(&dir.join("points.problems.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}

/// Image of `camera` for the i-th instant of the manifest.
fn image_of(dir: &Path, instant: usize, camera: u8) -> (PathBuf, ManifestRow) {
    let rows = manifest(dir);
    let keys: Vec<_> = {
        let mut k = Vec::new();
        for r in &rows {
            if !k.contains(&r.instant()) {
                k.push(r.instant());
            }
        }
        k
    };
    let row = rows
        .iter()
        .find(|r| r.instant() == keys[instant] && r.camera == camera)
        .unwrap()
        .clone();
    (dir.join(&row.image), row)
}

/// Paint a disc of value `dn` (radius r px) at the projected position of a
/// world point seen by a camera of the true rig.
fn paint(path: &Path, camera: &geom::Camera, at: geom::Point3<f64>, r: f64, dn: u16) {
    let mut img: ImageBuffer<Luma<u16>, Vec<u16>> = image::open(path).unwrap().into_luma16();
    let c = camera.project(&at).unwrap();
    for (x, y, p) in img.enumerate_pixels_mut() {
        if (f64::from(x) - c.x).hypot(f64::from(y) - c.y) <= r {
            *p = Luma([dn]);
        }
    }
    img.save_with_format(path, image::ImageFormat::Tiff)
        .unwrap();
}

/// True centre of a sphere at an instant.
fn true_centre(dir: &Path, row: &ManifestRow, sphere: &str) -> geom::Point3<f64> {
    let t = points(&dir.join("truth_points.csv"));
    let p = t
        .iter()
        .find(|p| {
            p.sphere == sphere
                && p.axis == row.axis
                && p.direction == row.direction
                && p.run == row.run
                && p.target == row.target
                && p.capture == row.capture
                && p.nominal() == [row.nominal_x, row.nominal_y, row.nominal_z]
        })
        .unwrap();
    geom::Point3::from(p.position())
}

/// Instants of the campaign.
fn instant_count(dir: &Path) -> usize {
    let mut k: Vec<_> = manifest(dir).iter().map(ManifestRow::instant).collect();
    k.sort();
    k.dedup();
    k.len()
}

/// Make a frame unreadable: a TIFF header and nothing it promises.
fn corrupt(path: &Path) {
    std::fs::write(path, b"II*\0garbage").unwrap();
}

/// Paint sphere `sphere` (diameter `diameter` mm) out of `camera`'s frame of
/// the i-th instant at the background level; the image and its manifest row.
fn paint_out(
    dir: &Path,
    instant: usize,
    camera: u8,
    sphere: &str,
    diameter: f64,
) -> (PathBuf, ManifestRow) {
    let (path, row) = image_of(dir, instant, camera);
    let cam = common::true_camera(dir, camera);
    let c = true_centre(dir, &row, sphere);
    let r_px = diameter / 2.0 * cam.intrinsics.fx / cam.to_camera(&c).z + 3.0; // + blur margin
    paint(&path, &cam, c, r_px, 1200);
    (path, row)
}

#[test]
fn damaged_frames_are_reported_and_the_rest_measured() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    campaign(d);
    let instants = instant_count(d);

    // Instant 1: camera 3's frame is corrupt.
    let (corrupt_frame, _) = image_of(d, 1, 3);
    corrupt(&corrupt_frame);
    // Instant 2: sphere C painted out of camera 2's frame (background level): A, B measured.
    let (missing, _) = paint_out(d, 2, 2, "C", 10.0);
    // Instant 3: an extra blob (a reflection, 4 mm) in camera 3: rejected, instant measured.
    let (extra, row3) = image_of(d, 3, 3);
    let cam3 = common::true_camera(d, 3);
    let a = true_centre(d, &row3, "A");
    paint(
        &extra,
        &cam3,
        a + geom::Vector3::new(-40.0, 35.0, 0.0),
        4.0,
        40_000,
    );
    // Instant 4: a twin of sphere B (same size) in camera 3: B ambiguous, reported.
    let (twin, row4) = image_of(d, 4, 3);
    let b = true_centre(d, &row4, "B");
    let r_px = 7.5 * cam3.intrinsics.fx / cam3.to_camera(&b).z;
    paint(
        &twin,
        &cam3,
        b + geom::Vector3::new(-45.0, 30.0, 0.0),
        r_px,
        49_000,
    );

    let summary = run(d, "points.csv", &|_, _| {}).unwrap();
    assert_eq!(summary.instants, instants);
    // Instant 1 is lost; instants 2 and 4 keep the spheres every camera found.
    assert_eq!(summary.measured, instants - 1, "{:?}", problems(d));
    assert_eq!((summary.partial, summary.problems), (2, 3));
    let p = problems(d);
    assert!(
        p[0].reason.contains("cannot decode")
            && p[0].missing == Missing::Instant
            && p[0].image.as_deref() == Some(corrupt_frame.to_str().unwrap()),
        "{:?}",
        p[0]
    );
    assert!(
        p[1].reason.contains("sphere C not found")
            && p[1].missing == Missing::Sphere
            && p[1].sphere.as_deref() == Some("C")
            && p[1].camera == Some(2)
            && p[1].image.as_deref() == Some(missing.to_str().unwrap()),
        "{:?}",
        p[1]
    );
    assert!(
        p[2].reason.contains("sphere B ambiguous")
            && p[2].sphere.as_deref() == Some("B")
            && p[2].camera == Some(3),
        "{:?}",
        p[2]
    );
    // Every measured instant once, with the spheres it has; poses of the
    // complete ones.
    let rows = points(&d.join("points.csv"));
    assert_eq!(rows.len(), 3 * (instants - 3) + 2 * 2);
    let of = |i: usize| {
        let (_, row) = image_of(d, i, 3);
        let mut names: Vec<String> = rows
            .iter()
            .filter(|p| p.instant() == row.instant())
            .map(|p| p.sphere.clone())
            .collect();
        names.sort();
        names
    };
    assert!(of(1).is_empty());
    assert_eq!(
        (of(2), of(4)),
        (
            vec!["A".to_string(), "B".into()],
            vec!["A".to_string(), "C".into()]
        )
    );
    let poses: Vec<PoseRow> = read_csv(&d.join("points.poses.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    assert_eq!(poses.len(), instants - 3);
    assert!(!d.join("points.csv.partial").exists());
}

#[test]
fn an_unusable_manifest_is_reported_in_full_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    campaign(d);
    let mut rows = manifest(d);
    let gone1 = rows[0].image.clone();
    let gone2 = rows[5].image.clone();
    std::fs::remove_file(d.join(&gone1)).unwrap();
    std::fs::remove_file(d.join(&gone2)).unwrap();
    rows.remove(7); // an instant loses a camera
    rows[10].nominal_x += 0.5; // a camera disagrees on the nominal position
    let dup = rows[20].clone();
    rows.push(dup); // the same image twice
    // One file given for two frames (another camera of the same instant).
    assert_ne!(rows[30].camera, rows[31].camera);
    rows[31].image = rows[30].image.clone();
    let twice = format!("line 33: image {}", d.join(&rows[30].image).display());
    write_csv(&d.join("manifest.csv"), &rows).unwrap();
    let err = run(d, "points.csv", &|_, _| {}).unwrap_err();
    let FuseError::Campaign { problems, .. } = &err else {
        panic!("{err}");
    };
    let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
    let text = text.join("\n");
    assert!(text.contains(&gone1) && text.contains(&gone2), "{text}");
    assert!(text.contains("has no image of camera"), "{text}");
    assert!(text.contains("disagree on the nominal position"), "{text}");
    assert!(text.contains("already has an image"), "{text}");
    assert!(
        text.contains(&twice) && text.contains("one file cannot be two frames"),
        "{text}"
    );
    assert!(!d.join("points.csv").exists() && !d.join("points.csv.partial").exists());

    // A row that breaks the manifest's contract is named by line and column.
    let mut rows = manifest(d);
    rows[3].camera = 7;
    write_csv(&d.join("manifest.csv"), &rows).unwrap();
    let err = run(d, "points.csv", &|_, _| {}).unwrap_err().to_string();
    assert!(err.contains("line 5, column 'camera'"), "{err}");
}

#[test]
fn an_interrupted_run_resumes_without_loss_or_duplicates() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    campaign(d);
    // Each run in its own folder, its outputs of the same names.
    let reference = run(d, "reference/points.csv", &|_, _| {}).unwrap();
    assert_eq!(reference.problems, 0);
    // The same bytes on one thread as on many.
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    one.install(|| run(d, "single/points.csv", &|_, _| {}))
        .unwrap();
    assert_eq!(
        std::fs::read(d.join("single/points.csv")).unwrap(),
        std::fs::read(d.join("reference/points.csv")).unwrap()
    );

    // Interrupt after the second chunk, then tear the partial file's last line
    // as a crash in the middle of a write would.
    let interrupted = std::panic::catch_unwind(AssertUnwindSafe(|| {
        run(d, "points.csv", &|done, _| {
            if done >= 32 {
                panic!("interrupted");
            }
        })
    }));
    assert!(interrupted.is_err());
    let partial = d.join("points.csv.partial");
    let text = std::fs::read_to_string(&partial).unwrap();
    let kept_lines = text.lines().count() - 1;
    std::fs::write(&partial, format!("{text}X,+,9,9,9,0.0,0.0,0.0,A,1.2")).unwrap();

    // Resuming with other options is refused…
    let (rig, spheres) = (rig(d), spheres(d));
    let other = MeasureOptions {
        all_cameras: true,
        ..MeasureOptions::default()
    };
    let inputs = Inputs {
        manifest: &d.join("manifest.csv"),
        rig: &rig,
        spheres: &spheres,
        sensor: &Default::default(),
    };
    let err = measure(
        &inputs,
        &d.join("points.csv"),
        &other,
        &extract::CpuBackend,
        &mut OutputPlan::new(false),
        &|_, _| {},
    )
    .unwrap_err();
    assert!(matches!(err, FuseError::ResumeMismatch(_)), "{err}");
    // …with the same ones it finishes the job.
    let resumed = run(d, "points.csv", &|_, _| {}).unwrap();
    assert_eq!(resumed.resumed * 3, kept_lines);
    assert!(resumed.resumed >= 32);
    assert_eq!(resumed.measured, reference.measured);
    assert_eq!(
        points(&d.join("points.csv")),
        points(&d.join("reference/points.csv"))
    );
    assert!(!partial.exists() && !d.join("points.csv.resume.json").exists());

    // A finished output is not overwritten silently.
    let err = run(d, "points.csv", &|_, _| {}).unwrap_err();
    assert!(
        matches!(&err, FuseError::Format(FormatError::Exists { path }) if path == &d.join("points.csv")),
        "{err}"
    );
}

/// With every camera in use (`all_cameras`), a camera that cannot serve an
/// instant — its frame corrupt, or a sphere it does not show — is left out
/// and the other two measure the instant: `points.problems.csv` names the
/// camera left out, its image and why (`missing` = `camera`, the instant in
/// `points.csv` with the cameras that measured it, and its pose). With one
/// camera left the instant is lost, one row naming both frames; an instant
/// measured without a camera that the residual gate refuses has that row
/// alone. A resumed run measures the instants without a camera again and
/// gives the same outputs.
#[test]
fn a_camera_that_cannot_serve_an_instant_is_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    campaign(d);
    let instants = instant_count(d);
    let all = MeasureOptions {
        all_cameras: true,
        ..MeasureOptions::default()
    };

    // Instant 1: camera 3's frame is corrupt.
    let (corrupt_frame, row1) = image_of(d, 1, 3);
    corrupt(&corrupt_frame);
    // Instant 2: sphere C painted out of camera 2's frame (background level).
    let (missing, row2) = paint_out(d, 2, 2, "C", 10.0);
    // Instant 3: cameras 2's and 3's frames are corrupt.
    let (lost2, row3) = image_of(d, 3, 2);
    let (lost3, _) = image_of(d, 3, 3);
    corrupt(&lost2);
    corrupt(&lost3);
    // Instant 4: camera 3's frame is corrupt and camera 2's upside down: the
    // two cameras left disagree on the height of spheres B and C by ≈ 40 mm.
    let (refused3, row4) = image_of(d, 4, 3);
    corrupt(&refused3);
    let (flipped, _) = image_of(d, 4, 2);
    let img = image::open(&flipped).unwrap().into_luma16();
    image::imageops::flip_vertical(&img)
        .save_with_format(&flipped, image::ImageFormat::Tiff)
        .unwrap();

    std::fs::create_dir_all(d.join("reference")).unwrap();
    let summary = common::measure_with(d, "reference/points.csv", &all, &|_, _| {}, false).unwrap();
    assert_eq!(
        summary.measured,
        instants - 2,
        "{:?}",
        summary.first_problem
    );
    assert_eq!(
        (summary.partial, summary.without_pose, summary.reduced),
        (0, 0, 2)
    );
    let p: Vec<InstantProblemRow> = read_csv(&d.join("reference/points.problems.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    assert_eq!(p.len(), 4, "{p:?}");
    assert!(
        p[0].instant() == row1.instant()
            && p[0].missing == Missing::Camera
            && (p[0].camera, p[0].sphere.as_deref()) == (Some(3), None)
            && p[0].image.as_deref() == Some(corrupt_frame.to_str().unwrap())
            && p[0].reason.starts_with("camera 3 left out: ")
            && p[0].reason.contains("cannot decode"),
        "{:?}",
        p[0]
    );
    assert!(
        p[1].instant() == row2.instant()
            && p[1].missing == Missing::Camera
            && (p[1].camera, p[1].sphere.as_deref()) == (Some(2), Some("C"))
            && p[1].image.as_deref() == Some(missing.to_str().unwrap())
            && p[1]
                .reason
                .starts_with("camera 2 left out: sphere C not found")
            && p[1].reason.ends_with("sphere C measured from cameras 1+3"),
        "{:?}",
        p[1]
    );
    assert!(
        p[2].instant() == row3.instant()
            && p[2].missing == Missing::Instant
            && (p[2].camera, p[2].image.as_deref()) == (None, None)
            && p[2]
                .reason
                .contains(&format!("camera 2: {}: cannot decode", lost2.display()))
            && p[2]
                .reason
                .contains(&format!("camera 3: {}: cannot decode", lost3.display())),
        "{:?}",
        p[2]
    );
    assert!(
        p[3].instant() == row4.instant()
            && p[3].missing == Missing::Instant
            && p[3].reason.starts_with("implausible"),
        "{:?}",
        p[3]
    );

    // points.csv: every sphere of every instant but the lost ones, from the
    // cameras that saw it, at its true centre.
    let rows = points(&d.join("reference/points.csv"));
    assert_eq!(rows.len(), 3 * (instants - 2));
    for r in &rows {
        let cameras = if r.instant() == row1.instant() {
            "1+2"
        } else if r.instant() == row2.instant() && r.sphere == "C" {
            "1+3"
        } else {
            "1+2+3"
        };
        assert_eq!(r.cameras, cameras, "{r:?}");
        assert!(r.instant() != row3.instant() && r.instant() != row4.instant());
        let row = manifest(d)
            .into_iter()
            .find(|m| m.instant() == r.instant())
            .unwrap();
        let off = (geom::Point3::from(r.position()) - true_centre(d, &row, &r.sphere)).norm();
        // 640 px: a pixel covers ≈ 0.37 mm of the table.
        assert!(off < 0.01, "{r:?}: {off} mm from the truth");
    }
    let poses: Vec<PoseRow> = read_csv(&d.join("reference/points.poses.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    assert_eq!(poses.len(), instants - 2);

    // Interrupted after the first chunk (instants 0–15), then resumed: the
    // instants measured without a camera are measured again, so their rows
    // of the problems file are there too.
    let interrupted = std::panic::catch_unwind(AssertUnwindSafe(|| {
        common::measure_with(
            d,
            "points.csv",
            &all,
            &|done, _| {
                if done >= 16 {
                    panic!("interrupted");
                }
            },
            false,
        )
    }));
    assert!(interrupted.is_err());
    let resumed = common::measure_with(d, "points.csv", &all, &|_, _| {}, false).unwrap();
    assert_eq!(resumed.resumed, 16 - 4);
    for name in ["points.csv", "points.problems.csv", "points.poses.csv"] {
        assert_eq!(
            std::fs::read(d.join(name)).unwrap(),
            std::fs::read(d.join("reference").join(name)).unwrap(),
            "{name}"
        );
    }
}
