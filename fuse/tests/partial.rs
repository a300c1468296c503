//! Partial instants: a sphere whose image is clipped by a frame's border (it
//! leaves a camera's view at one end of a sweep) is missing from that
//! instant, the spheres that are whole are measured, the pose is missing,
//! and `points.problems.csv` names the sphere, camera and image — decided against
//! the renderer's truth: the true camera's image of the true sphere.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use formats::{InstantKey, InstantProblemRow, ManifestRow, Missing, PointRow, PoseRow, Truth};
use geom::{Point3, Vector3};

const WIDTH: u32 = 512;
const HEIGHT: u32 = 384;

/// The seed rig with sphere B moved 15 mm further out in +y: at the +y end of
/// the Y sweep (y = +50 mm) its image runs off camera 3's frame.
fn campaign(dir: &Path) {
    common::campaign_with(dir, WIDTH, 3, 2, 21, |c| {
        c.spheres[1].position_mm = [20.0, 35.0, 50.0];
    });
}

/// Pixel bounding box of a sphere's image through the full camera model, from
/// points spread over its surface (the extreme ones lie on the silhouette to
/// within 0.1 % of the radius).
fn image_box(camera: &geom::Camera, centre: &Point3<f64>, radius: f64) -> [f64; 4] {
    let (mut lo_u, mut hi_u, mut lo_v, mut hi_v) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let n = 120;
    for i in 0..=n {
        let theta = std::f64::consts::PI * f64::from(i) / f64::from(n);
        for j in 0..2 * n {
            let phi = std::f64::consts::PI * f64::from(j) / f64::from(n);
            let d = Vector3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            let p = camera.project(&(centre + d * radius)).unwrap();
            lo_u = lo_u.min(p.x);
            hi_u = hi_u.max(p.x);
            lo_v = lo_v.min(p.y);
            hi_v = hi_v.max(p.y);
        }
    }
    [lo_u, hi_u, lo_v, hi_v]
}

/// Distance (px) of a sphere's image from the nearest frame border; negative
/// when the image runs off the frame.
fn border_margin(camera: &geom::Camera, centre: &Point3<f64>, radius: f64) -> f64 {
    let [lo_u, hi_u, lo_v, hi_v] = image_box(camera, centre, radius);
    let (w, h) = (f64::from(WIDTH) - 0.5, f64::from(HEIGHT) - 0.5);
    (lo_u + 0.5).min(w - hi_u).min(lo_v + 0.5).min(h - hi_v)
}

#[test]
fn a_sphere_leaving_a_camera_s_view_leaves_the_others_measured() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    campaign(d);
    let truth: Truth = formats::read_json(&d.join("truth.json")).unwrap();
    let manifest: Vec<ManifestRow> = common::records(&d.join("manifest.csv"));
    let cameras: BTreeMap<u8, geom::Camera> = truth
        .cameras
        .iter()
        .map(|c| (c.model.id, c.model.to_camera().unwrap()))
        .collect();
    let radius: BTreeMap<&str, f64> = truth
        .spheres
        .iter()
        .map(|s| (s.name.as_str(), s.diameter / 2.0))
        .collect();

    // From the truth: every (instant, camera used, sphere) whose image leaves
    // the frame. A 4 px margin keeps the blur and threshold out of the
    // decision: no sphere of this campaign is nearer the border than that
    // without leaving it.
    let used = |axis: formats::Axis| -> &[u8] {
        match axis {
            formats::Axis::X => &[2, 3],
            _ => &[1, 3],
        }
    };
    let mut expected: BTreeSet<(InstantKey, u8, String)> = BTreeSet::new();
    let mut instants = 0;
    for t in &truth.instants {
        instants += 1;
        let key = t.instant();
        for &c in used(t.axis) {
            for (name, centre) in &t.spheres {
                let m = border_margin(&cameras[&c], &Point3::from(*centre), radius[name.as_str()]);
                assert!(
                    !(-1.0..4.0).contains(&m),
                    "sphere {name} is {m:.1} px from camera {c}'s border: too close to decide"
                );
                if m < 0.0 {
                    expected.insert((key, c, name.clone()));
                }
            }
        }
    }
    // The campaign does what it is for: B leaves camera 3 at the +y end.
    assert!(!expected.is_empty());
    assert!(
        expected
            .iter()
            .all(|(k, c, s)| s == "B" && *c == 3 && k.axis == formats::Axis::Y)
    );
    let partial: BTreeSet<InstantKey> = expected.iter().map(|e| e.0).collect();

    let summary = common::measure(d, "points.csv").unwrap();
    assert_eq!(summary.instants, instants);
    assert_eq!(summary.measured, instants, "{summary:?}");
    assert_eq!(summary.partial, partial.len());
    assert_eq!((summary.implausible, summary.without_pose), (0, 0));

    // points.problems.csv: one row per missing sphere and camera, naming the image.
    let problems: Vec<InstantProblemRow> = common::records(&d.join("points.problems.csv"));
    let got: BTreeSet<(InstantKey, u8, String)> = problems
        .iter()
        .map(|p| (p.instant(), p.camera.unwrap(), p.sphere.clone().unwrap()))
        .collect();
    assert_eq!(got, expected);
    assert_eq!(problems.len(), expected.len());
    for p in &problems {
        assert_eq!(p.missing, Missing::Sphere);
        let image = manifest
            .iter()
            .find(|m| m.instant() == p.instant() && Some(m.camera) == p.camera)
            .unwrap();
        assert_eq!(
            p.image.as_deref(),
            Some(d.join(&image.image).to_str().unwrap())
        );
        assert!(
            p.reason.contains("sphere B not found")
                && p.reason.contains("touches the image border"),
            "{}",
            p.reason
        );
    }

    // points.csv: the whole spheres of every instant, at their true centres.
    let points: Vec<PointRow> = common::records(&d.join("points.csv"));
    assert_eq!(points.len(), 3 * instants - partial.len());
    let true_centre = |p: &PointRow| {
        let t = truth
            .instants
            .iter()
            .find(|t| t.instant() == p.instant())
            .unwrap();
        Point3::from(t.spheres[&p.sphere])
    };
    let mut worst: f64 = 0.0;
    for p in &points {
        let lacking = partial.contains(&p.instant());
        assert!(!(lacking && p.sphere == "B"));
        let off = (Point3::from(p.position()) - true_centre(p)).norm();
        worst = worst.max(off);
        // 512 px: a pixel covers ≈ 0.46 mm of the table.
        assert!(off < 0.01, "{p:?}: {off} mm from the truth");
    }
    eprintln!("largest distance of a measured centre from the truth: {worst:.4} mm");

    // points.poses.csv: every instant but the partial ones.
    let poses: Vec<PoseRow> = common::records(&d.join("points.poses.csv"));
    assert_eq!(poses.len(), instants - partial.len());
    assert!(poses.iter().all(|p| {
        let k = InstantKey {
            axis: p.axis,
            direction: p.direction,
            run: p.run,
            target: p.target,
            capture: p.capture,
            nominal_bits: [p.nominal_x, p.nominal_y, p.nominal_z].map(f64::to_bits),
        };
        !partial.contains(&k)
    }));

    // evaluate copes: positioning of Y from sphere A at every target; no
    // angular errors for Y, whose last target never has B (with the reason);
    // X complete.
    let report =
        evaluate::evaluate_file(&d.join("points.csv"), &evaluate::Options::default()).unwrap();
    let y = &report.axes.y.as_ref().unwrap().main;
    assert_eq!(y.positioning.targets.len(), 3);
    assert!(y.positioning.a_um.is_some() && y.angular.is_none());
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("axis Y") && w.contains("sphere(s) B missing")),
        "{:?}",
        report.warnings
    );
    assert!(report.axes.x.as_ref().unwrap().main.angular.is_some());
}
