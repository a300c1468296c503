//! Geometry checks in the ideal image: a campaign rendered through a strong
//! pincushion lens (k1 = 22 on every camera, 640×480 px, the seed rig's field
//! of view) stretches the spheres' images towards the edge of the field until
//! their observed moment ellipses are far from round (circularity < 0.7) and
//! their observed minor axes are inflated by the lens's tangential
//! magnification. A sphere is still a sphere: measured on the corrected light
//! in undistorted coordinates, every instant is measured, as accurately at
//! the edge of the field as at its centre. The renderer's true cameras are
//! the rig, so the test judges the blob checks and fusion alone.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use extract::{Backend, CpuBackend, ExtractParams, FrameReader};
use formats::{Axis, InstantKey, ManifestRow, PointRow};

/// Radial distortion of every camera (normalised coordinates): the observed
/// image of a sphere ≈ 0.13 off axis is ≈ 1.4× longer radially than across.
const K1: f64 = 22.0;

/// The seed rig behind the pincushion lens; X swept from −50 to +30 mm and Y
/// from −28.5 to +28.5 mm (3 targets, 1 run, one line each), so that every
/// sphere's image stays whole inside the frame.
fn campaign(dir: &Path) {
    common::campaign_with(dir, 640, 3, 1, 7, |c| {
        for camera in &mut c.rig.cameras {
            camera.distortion.k1 = K1;
            camera.distortion.k2 = 0.0;
            camera.distortion.k3 = 0.0;
        }
        for a in &mut c.procedure.axes {
            (a.start_mm, a.length_mm) = if a.axis == Axis::X {
                (-50.0, 80.0)
            } else {
                (-28.5, 57.0)
            };
            a.lines_mm = vec![0.0];
        }
    });
}

/// Whether the measurement uses `camera` for an axis by default: it does not
/// look along the motion.
fn used(axis: Axis, camera: u8) -> bool {
    Axis::of_camera(camera) != Some(axis)
}

/// Instants of which a used camera's frame has a sphere image that is not
/// round in observed pixels (circularity below fuse's limit), and the least
/// circularity seen. Every frame used shows the three spheres whole.
fn not_round_when_observed(dir: &Path) -> (BTreeSet<InstantKey>, f64) {
    let manifest: Vec<ManifestRow> = common::records(&dir.join("manifest.csv"));
    let mut reader = FrameReader::new();
    let mut instants = BTreeSet::new();
    let mut least: f64 = 1.0;
    for row in manifest.iter().filter(|r| used(r.axis, r.camera)) {
        let (frame, _) = reader.read(&dir.join(&row.image)).unwrap();
        let blobs = CpuBackend
            .extract(frame, &ExtractParams::default())
            .unwrap()
            .blobs;
        assert_eq!(blobs.len(), 3, "{}", row.image);
        assert!(blobs.iter().all(|b| !b.touches_border), "{}", row.image);
        for b in &blobs {
            least = least.min(b.circularity());
            if b.circularity() < fuse::MIN_CIRCULARITY {
                instants.insert(row.instant());
            }
        }
    }
    (instants, least)
}

#[test]
fn a_distorted_sphere_at_the_edge_of_the_field_is_still_a_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    campaign(d);
    // The campaign does what it is for: the observed images of spheres at
    // the edge of the field are far from round.
    let (edge, least) = not_round_when_observed(d);
    eprintln!(
        "{} instants with a sphere image of observed circularity below {}, the least {least:.3}",
        edge.len(),
        fuse::MIN_CIRCULARITY
    );
    assert!(edge.len() >= 4 && least < 0.65, "{edge:?}, {least}");

    let summary = common::measure(d, "points.csv").unwrap();
    let instants = summary.instants;
    eprintln!(
        "measured {} of {instants} instants, {} lacking a sphere; {} problems",
        summary.measured, summary.partial, summary.problems
    );
    assert_eq!(
        (summary.measured, summary.problems),
        (instants, 0),
        "{:?}",
        summary.first_problem
    );

    // Every sphere of every instant, as close to the truth at the edge of the
    // field as at its centre.
    let points: Vec<PointRow> = common::records(&d.join("points.csv"));
    assert_eq!(points.len(), 3 * instants);
    let truth: BTreeMap<(InstantKey, String), [f64; 3]> =
        common::records::<PointRow>(&d.join("truth_points.csv"))
            .into_iter()
            .map(|p| ((p.instant(), p.sphere.clone()), p.position()))
            .collect();
    let (mut at_edge, mut elsewhere) = (Vec::new(), Vec::new());
    for p in &points {
        let t = truth[&(p.instant(), p.sphere.clone())];
        let off = (geom::Point3::from(p.position()) - geom::Point3::from(t)).norm();
        if edge.contains(&p.instant()) {
            at_edge.push(off);
        } else {
            elsewhere.push(off);
        }
    }
    let rms = |v: &[f64]| (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt();
    let (edge_rms, centre_rms) = (rms(&at_edge), rms(&elsewhere));
    eprintln!(
        "distance from the truth: {:.2} µm RMS at the edge of the field ({} spheres), \
         {:.2} µm RMS elsewhere ({} spheres)",
        edge_rms * 1e3,
        at_edge.len(),
        centre_rms * 1e3,
        elsewhere.len()
    );
    // 640 px: a pixel covers ≈ 0.37 mm of the table; both well below 0.01 px.
    assert!(centre_rms < 4e-3, "{centre_rms} mm");
    assert!(
        edge_rms < 2.0 * centre_rms,
        "{edge_rms} against {centre_rms} mm"
    );
}
