//! Wrong images are refused by their reprojection residual: two cameras'
//! images swapped, one camera's image given (as a copy) for another camera,
//! another instant's image. Each still triangulates, 26–39 mm off, so without
//! the gate they would be silent wrong results; with it they are problems and
//! every other instant is measured at its true centre. A resumed run draws
//! the same line (byte-identical outputs).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::collections::BTreeSet;
use std::panic::AssertUnwindSafe;
use std::path::Path;

use formats::{InstantKey, InstantProblemRow, ManifestRow, Missing, PointRow, Truth, write_csv};
use fuse::{Fusion, MeasureOptions};

/// Instants of the manifest, in order.
fn instants(rows: &[ManifestRow]) -> Vec<InstantKey> {
    let mut keys: Vec<InstantKey> = Vec::new();
    for r in rows {
        if !keys.contains(&r.instant()) {
            keys.push(r.instant());
        }
    }
    keys
}

/// Row of the manifest holding camera `camera`'s image of instant `k`.
fn row_of(rows: &[ManifestRow], k: &InstantKey, camera: u8) -> usize {
    rows.iter()
        .position(|r| r.instant() == *k && r.camera == camera)
        .unwrap()
}

/// Damage the manifest of a 3-target, 2-run campaign (36 instants, lines
/// starting at instants 0, 12, 24) and return the instants damaged. None is
/// the first of its line, the reference of the pixel-scale fusion.
fn damage(dir: &Path) -> BTreeSet<InstantKey> {
    let path = dir.join("manifest.csv");
    let mut rows: Vec<ManifestRow> = common::records(&path);
    let keys = instants(&rows);
    assert_eq!(keys.len(), 36);
    // X, cameras 2 and 3 swapped.
    let (a, b) = (row_of(&rows, &keys[4], 2), row_of(&rows, &keys[4], 3));
    let swapped = rows[a].image.clone();
    rows[a].image = rows[b].image.clone();
    rows[b].image = swapped;
    // X, camera 3's image copied and given as camera 2's too.
    let (a, b) = (row_of(&rows, &keys[9], 2), row_of(&rows, &keys[9], 3));
    std::fs::copy(dir.join(&rows[b].image), dir.join("copy_of_cam3.tif")).unwrap();
    rows[a].image = "copy_of_cam3.tif".into();
    // X (second line), a copy of camera 3's image of the next target of the
    // run (the file itself twice is refused before any work, see batch.rs).
    assert_ne!(keys[13].target, keys[14].target);
    let (a, b) = (row_of(&rows, &keys[13], 3), row_of(&rows, &keys[14], 3));
    std::fs::copy(dir.join(&rows[b].image), dir.join("next_target_cam3.tif")).unwrap();
    rows[a].image = "next_target_cam3.tif".into();
    // Y, cameras 1 and 3 swapped.
    let (a, b) = (row_of(&rows, &keys[29], 1), row_of(&rows, &keys[29], 3));
    let swapped = rows[a].image.clone();
    rows[a].image = rows[b].image.clone();
    rows[b].image = swapped;
    write_csv(&path, &rows).unwrap();
    [keys[4], keys[9], keys[13], keys[29]].into()
}

/// Largest distance of measured centres from the renderer's truth (mm).
fn worst_error(dir: &Path, points: &[PointRow]) -> f64 {
    let truth: Truth = formats::read_json(&dir.join("truth.json")).unwrap();
    points
        .iter()
        .map(|p| {
            let t = truth
                .instants
                .iter()
                .find(|t| {
                    (t.axis, t.direction, t.run, t.target, t.capture)
                        == (p.axis, p.direction, p.run, p.target, p.capture)
                        && t.nominal == p.nominal()
                })
                .unwrap();
            (geom::Point3::from(t.spheres[&p.sphere]) - geom::Point3::from(p.position())).norm()
        })
        .fold(0.0, f64::max)
}

/// The damaged instants, and only they, are refused; the rest is measured
/// within `tolerance_mm` of the truth.
fn check_refused(
    dir: &Path,
    out: &str,
    damaged: &BTreeSet<InstantKey>,
    summary: &fuse::Summary,
    tolerance_mm: f64,
) {
    assert_eq!(summary.instants, 36);
    assert_eq!(summary.implausible, damaged.len(), "{summary:?}");
    assert_eq!(summary.measured, 36 - damaged.len());
    let out = dir.join(out);
    let problems: Vec<InstantProblemRow> =
        common::records(&formats::beside(&out, "points", ".problems.csv"));
    let refused: BTreeSet<InstantKey> = problems.iter().map(InstantProblemRow::instant).collect();
    assert_eq!(&refused, damaged);
    let gate = summary.gate.unwrap();
    for p in &problems {
        assert_eq!(p.missing, Missing::Instant);
        assert!(
            p.reason.starts_with("implausible: reprojection residual"),
            "{}",
            p.reason
        );
        // The residual named is far above the limit named.
        let residual: f64 = p.reason["implausible: reprojection residual ".len()..]
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(residual > 10.0 * gate.limit_px, "{}", p.reason);
        assert!(p.reason.contains(&gate.describe()), "{}", p.reason);
    }
    let points: Vec<PointRow> = common::records(&out);
    assert_eq!(points.len(), 3 * summary.measured);
    assert!(points.iter().all(|p| !damaged.contains(&p.instant())));
    let good = points.iter().map(|p| p.residual_px).fold(0.0, f64::max);
    eprintln!(
        "{}: {}; largest residual kept {good:.4} px; largest error {:.4} mm",
        out.display(),
        gate.describe(),
        worst_error(dir, &points)
    );
    assert!(good < 0.5 * gate.limit_px);
    assert!(worst_error(dir, &points) < tolerance_mm);
}

#[test]
fn swapped_repeated_and_foreign_images_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::campaign(d, 512, 3, 2, 31);
    let damaged = damage(d);

    let summary = common::measure(d, "points.csv").unwrap();
    // 512 px: a pixel covers ≈ 0.46 mm of the table.
    check_refused(d, "points.csv", &damaged, &summary, 0.01);
    let triangulated: Vec<PointRow> = common::records(&d.join("points.csv"));

    // The pixel-scale fusion is held to the same residual: that of the images at
    // their least-squares centre, the same numbers as triangulation's.
    std::fs::create_dir(d.join("seed")).unwrap();
    let seed = MeasureOptions {
        fusion: Fusion::PixelScale,
        ..MeasureOptions::default()
    };
    let summary = common::measure_with(d, "seed/points.csv", &seed, &|_, _| {}, false).unwrap();
    // The seed's model error (the cameras' mounting tilt) is ≈ 0.2 mm here.
    check_refused(d, "seed/points.csv", &damaged, &summary, 0.3);
    let seeded: Vec<PointRow> = common::records(&d.join("seed/points.csv"));
    assert_eq!(seeded.len(), triangulated.len());
    for (s, t) in seeded.iter().zip(&triangulated) {
        assert_eq!((s.instant(), &s.sphere), (t.instant(), &t.sphere));
        assert_eq!(s.residual_px.to_bits(), t.residual_px.to_bits(), "{s:?}");
        assert!(s.residual_px > 0.0);
    }
}

#[test]
fn a_resumed_run_refuses_and_keeps_the_same_instants() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Sphere B moved out of camera 3's view at the +y end too: partial
    // instants, which a resumed run measures again.
    common::campaign_with(d, 512, 3, 2, 32, |c| {
        c.spheres[1].position_mm = [20.0, 35.0, 50.0];
    });
    let damaged = damage(d);
    for sub in ["whole", "resumed"] {
        std::fs::create_dir(d.join(sub)).unwrap();
    }
    let whole = common::measure(d, "whole/points.csv").unwrap();
    assert_eq!(whole.implausible, damaged.len());
    assert!(whole.partial > 0, "{whole:?}");

    let interrupted = std::panic::catch_unwind(AssertUnwindSafe(|| {
        common::measure_with(
            d,
            "resumed/points.csv",
            &MeasureOptions::default(),
            &|done, _| {
                if done >= 16 {
                    panic!("interrupted");
                }
            },
            false,
        )
    }));
    assert!(interrupted.is_err());
    assert!(d.join("resumed/points.csv.partial").exists());
    let resumed = common::measure(d, "resumed/points.csv").unwrap();
    assert!(resumed.resumed >= 8, "{resumed:?}");
    assert_eq!(
        (
            resumed.measured,
            resumed.partial,
            resumed.implausible,
            resumed.gate
        ),
        (whole.measured, whole.partial, whole.implausible, whole.gate)
    );
    for f in ["points.csv", "points.problems.csv", "points.poses.csv"] {
        assert_eq!(
            std::fs::read(d.join("resumed").join(f)).unwrap(),
            std::fs::read(d.join("whole").join(f)).unwrap(),
            "{f}"
        );
    }
}
