//! Automatic correspondences over many random nominal-rig errors: the seed
//! rig and target, each camera's true pose turned by up to ±4° about each
//! axis and moved by up to ±6 mm along each (up to ≈ 7° and 10 mm in all,
//! hundreds of pixels in the image), 20 % of the markers missing, 20 %
//! spurious blobs, 0.01 px of centroid noise. Every assignment must be right.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use calib::{CorrespondOptions, Marker, correspond};
use geom::nalgebra::{Translation3, UnitQuaternion};
use geom::{Isometry3, Point2, Rotation3, Vector2, Vector3};

const TRIALS: usize = 90;
const MAX_DEG: f64 = 4.0;
const MAX_MM: f64 = 6.0;

#[test]
fn random_nominal_errors_missing_and_extra_detections() {
    let config = synth::Config::default();
    let rig = synth::SynthRig::from_config(&config).unwrap();
    let markers = synth::markers(&config.target);
    let target: Vec<Marker> = markers
        .iter()
        .map(|m| Marker {
            id: m.id,
            centre: m.centre,
        })
        .collect();
    let mut next = common::uniform(7);
    let mut largest_shift: f64 = 0.0;
    for trial in 0..TRIALS {
        let cam = &rig.cameras[trial % 3];
        let nominal = cam.nominal.to_camera().unwrap();
        let turn = Vector3::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0, next() * 2.0 - 1.0)
            * MAX_DEG.to_radians();
        let shift =
            Vector3::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0, next() * 2.0 - 1.0) * MAX_MM;
        let r = Rotation3::new(turn) * nominal.rotation();
        let c = nominal.centre() + shift;
        let mut truth = cam.camera.clone();
        truth.pose = Isometry3::from_parts(
            Translation3::from(-(r * c.coords)),
            UnitQuaternion::from_rotation_matrix(&r),
        );
        let (mut dets, mut ids) = (Vec::new(), Vec::new());
        for m in &markers {
            let p = truth.project(&m.centre).unwrap();
            largest_shift = largest_shift.max((p - nominal.project(&m.centre).unwrap()).norm());
            if next() < 0.2 || p.x < 0.0 || p.y < 0.0 || p.x > 4095.0 || p.y > 3071.0 {
                continue;
            }
            dets.push(p + Vector2::new(next() - 0.5, next() - 0.5) * 0.035);
            ids.push(m.id);
        }
        let real = dets.len();
        for _ in 0..10 {
            dets.push(Point2::new(next() * 4095.0, next() * 3071.0));
        }
        let c = correspond(&target, &dets, &nominal, &CorrespondOptions::default())
            .unwrap_or_else(|e| panic!("trial {trial}, camera {}: {e}", cam.id));
        assert_eq!(
            c.matches.len(),
            real,
            "trial {trial}: {} of {real} matched",
            c.matches.len()
        );
        for m in &c.matches {
            assert!(
                m.detection < real && ids[m.detection] == m.id,
                "trial {trial}: marker {} wrong",
                m.id
            );
        }
    }
    println!("{TRIALS} trials, markers up to {largest_shift:.0} px from their nominal image");
    assert!(largest_shift > 500.0);
}
