//! A frame whose header claims a huge image, inside a measure batch (issue
//! 12, item 1): the frame is refused before anything is allocated for it,
//! its instant goes to points.problems.csv naming the file and the size, and every
//! other instant is measured exactly as without it — also when the run is
//! repeated.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::Path;

use formats::{InstantProblemRow, ManifestRow, PointRow, read_csv};
use fuse::{MeasureOptions, Summary};

/// A baseline little-endian TIFF header claiming `width × height` 16-bit
/// pixels in one strip of 4 bytes.
fn tiff_header(width: u32, height: u32) -> Vec<u8> {
    let entries: [(u16, u16, u32); 9] = [
        (256, 4, width),
        (257, 4, height),
        (258, 3, 16),
        (259, 3, 1),
        (262, 3, 1),
        (273, 4, 122),
        (277, 3, 1),
        (278, 4, height),
        (279, 4, 4),
    ];
    let mut out = b"II*\0".to_vec();
    out.extend_from_slice(&8u32.to_le_bytes());
    out.extend_from_slice(&9u16.to_le_bytes());
    for (tag, kind, value) in entries {
        out.extend_from_slice(&tag.to_le_bytes());
        out.extend_from_slice(&kind.to_le_bytes());
        out.extend_from_slice(&1u32.to_le_bytes());
        out.extend_from_slice(&value.to_le_bytes());
    }
    out.extend_from_slice(&[0; 4 + 4]);
    assert_eq!(out.len(), 122 + 4);
    out
}

fn rows<T: formats::Record>(path: &Path) -> Vec<T> {
    read_csv(path)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}

fn run(dir: &Path, out: &str, force: bool) -> Summary {
    common::measure_with(dir, out, &MeasureOptions::default(), &|_, _| {}, force).unwrap()
}

#[test]
fn a_huge_header_frame_is_one_problem_and_the_batch_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::campaign(d, 640, 3, 2, 7);
    // The reference in a folder of its own: its outputs are not the later
    // runs' to replace.
    std::fs::create_dir(d.join("reference")).unwrap();
    let reference = run(d, "reference/points.csv", false);
    assert_eq!(reference.problems, 0);
    let expected: Vec<PointRow> = rows(&d.join("reference/points.csv"));

    // Camera 2's frame of the third instant claims 4294967295² pixels.
    let manifest: Vec<ManifestRow> = rows(&d.join("manifest.csv"));
    let mut instants = Vec::new();
    for r in &manifest {
        if !instants.contains(&r.instant()) {
            instants.push(r.instant());
        }
    }
    let hit = instants[2];
    let image = manifest
        .iter()
        .find(|r| r.instant() == hit && r.camera == 2)
        .unwrap()
        .image
        .clone();
    std::fs::write(d.join(&image), tiff_header(u32::MAX, u32::MAX)).unwrap();

    for force in [false, true] {
        let summary = run(d, "points.csv", force);
        assert_eq!(summary.instants, instants.len());
        assert_eq!(summary.problems, 1);
        assert_eq!(summary.measured, instants.len() - 1);
        let problems: Vec<InstantProblemRow> = rows(&d.join("points.problems.csv"));
        assert_eq!(problems.len(), 1);
        let p = &problems[0];
        assert_eq!(p.camera, Some(2));
        assert!(p.image.as_deref().unwrap().ends_with(&image), "{p:?}");
        assert!(
            p.reason.contains("4294967295×4294967295") && p.reason.contains("65536 px a side"),
            "{}",
            p.reason
        );
        assert_eq!(
            (p.axis, p.direction, p.run, p.target, p.capture),
            (hit.axis, hit.direction, hit.run, hit.target, hit.capture)
        );
        // Every other instant exactly as measured without the bad frame.
        let measured: Vec<PointRow> = rows(&d.join("points.csv"));
        let others: Vec<PointRow> = expected
            .iter()
            .filter(|r| r.instant() != hit)
            .cloned()
            .collect();
        assert_eq!(measured, others);
        assert!(!d.join("points.csv.partial").exists());
    }

    // And those are the spheres' true centres (the true rig measures them
    // within a few micrometres at 640 px).
    let truth: Vec<PointRow> = rows(&d.join("truth_points.csv"));
    let measured: Vec<PointRow> = rows(&d.join("points.csv"));
    for m in &measured {
        let t = truth
            .iter()
            .find(|t| t.instant() == m.instant() && t.sphere == m.sphere)
            .unwrap();
        let off = (0..3)
            .map(|i| (m.position()[i] - t.position()[i]).abs())
            .fold(0.0, f64::max);
        assert!(off < 0.02, "{} {:?}: {off} mm off", m.sphere, m.instant());
    }
}
