//! The system gain K from the campaign's own repeated captures (no flat and
//! dark stacks in the rig): the frames read for it are measured as they are
//! read, their centroids' covariances given K once it is known, so every
//! frame is decoded once; and every centroid's covariance is the one the
//! image gives at that K, computed here from the frame directly.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::collections::HashMap;

use extract::{Backend, CameraMap, Covariance, CpuBackend, FrameReader, Lattice, mapped_light};
use formats::{InstantKey, ManifestRow, ObservationRow, read_csv};
use fuse::{MeasureOptions, NoiseSource};

#[test]
fn k_from_repeats_reads_each_frame_once_and_gives_the_covariances_at_that_k() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    common::campaign_captured(dir, 640, 3, 1, 2, 5, |_| {});
    let options = MeasureOptions {
        all_cameras: true,
        ..MeasureOptions::default()
    };
    let summary = common::measure_with(dir, "points.csv", &options, &|_, _| {}, false).unwrap();
    assert_eq!(summary.problems, 0);
    // Every frame decoded once, the repeated captures K came from included.
    assert_eq!(summary.frames_read, 3 * summary.instants);
    let gains: HashMap<u8, f64> = summary
        .noise
        .iter()
        .map(|(&id, n)| {
            assert!(
                matches!(n.source, NoiseSource::Repeats { pairs: 2, .. }),
                "{n:?}"
            );
            (id, n.gain_dn_per_e.unwrap())
        })
        .collect();

    // Each observation's σ from its frame, extracted here at that K.
    let manifest: HashMap<(InstantKey, u8), String> =
        read_csv::<ManifestRow>(&dir.join("manifest.csv"))
            .unwrap()
            .into_iter()
            .map(|r| ((r.record.instant(), r.record.camera), r.record.image))
            .collect();
    let rig = common::true_rig(dir);
    let params = options.extract;
    let rows: Vec<ObservationRow> = common::records(&dir.join("points.observations.csv"));
    assert!(!rows.is_empty());
    let mut reader = FrameReader::new();
    let mut checked = 0;
    for camera in rig.cameras.iter().map(|c| c.model.id) {
        let model = common::true_camera(dir, camera);
        let lattice = Lattice::new(&model);
        let illumination = geom::Illumination::Ideal;
        let map = CameraMap::with_lattice(&model, &illumination, &lattice);
        let mut by_image: HashMap<&str, Vec<&ObservationRow>> = HashMap::new();
        for r in rows.iter().filter(|r| r.camera == camera) {
            by_image
                .entry(&manifest[&(r.instant(), camera)])
                .or_default()
                .push(r);
        }
        for (image, observed) in by_image {
            let (frame, _) = reader.read(&dir.join(image)).unwrap();
            let extraction = CpuBackend.extract(frame, &params).unwrap();
            for row in observed {
                let light = extraction
                    .blobs
                    .iter()
                    .filter_map(|b| {
                        mapped_light(
                            &frame,
                            b,
                            &extraction.level,
                            params.weighting,
                            &map,
                            Covariance::AtGain(gains[&camera]),
                        )
                    })
                    .find(|l| (l.centroid[0] - row.u).hypot(l.centroid[1] - row.v) < 1e-9)
                    .expect("the observation's blob");
                let c = light.covariance.unwrap();
                let (su, sv) = (row.u_sigma_px.unwrap(), row.v_sigma_px.unwrap());
                assert!((su / c.sigma_u_px() - 1.0).abs() < 1e-9, "{su} vs {c:?}");
                assert!((sv / c.sigma_v_px() - 1.0).abs() < 1e-9, "{sv} vs {c:?}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, rows.len());
}

/// One frame of the first pair of repeated captures cannot be read: K comes
/// from the pairs that remain (the next one taken in its place), the
/// passed-over pair is said, every observation keeps its σ, and only the
/// unreadable frame's camera is left out of its instant.
#[test]
fn an_unreadable_frame_of_the_first_pair_leaves_k_to_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    common::campaign_captured(dir, 640, 3, 1, 2, 5, |_| {});
    let rows = read_csv::<ManifestRow>(&dir.join("manifest.csv")).unwrap();
    let first = rows
        .iter()
        .filter(|r| r.record.camera == 2 && r.record.capture == 1)
        .min_by_key(|r| r.record.instant())
        .unwrap();
    let image = dir.join(&first.record.image);
    let bytes = std::fs::read(&image).unwrap();
    std::fs::write(&image, &bytes[..bytes.len() / 3]).unwrap();
    let options = MeasureOptions {
        all_cameras: true,
        ..MeasureOptions::default()
    };
    let summary = common::measure_with(dir, "points.csv", &options, &|_, _| {}, false).unwrap();
    let noise = &summary.noise[&2];
    let described = noise.describe();
    println!("camera 2: {described}");
    match &noise.source {
        NoiseSource::Repeats {
            pairs: 2,
            passed_over: Some((1, why)),
            ..
        } => assert!(why.contains("cannot be read"), "{why}"),
        other => panic!("{other:?}"),
    }
    assert!(described.contains("1 pair passed over"), "{described}");
    let k = noise.gain_dn_per_e.unwrap();
    let k1 = summary.noise[&1].gain_dn_per_e.unwrap();
    assert!(
        (k / k1 - 1.0).abs() < 0.1,
        "camera 2 K {k}, camera 1 K {k1}"
    );
    let observations: Vec<ObservationRow> = common::records(&dir.join("points.observations.csv"));
    assert!(observations.iter().any(|r| r.camera == 2));
    assert!(
        observations.iter().all(|r| r.u_sigma_px.is_some()),
        "every observation has its σ"
    );
    assert_eq!(
        summary.problems, 1,
        "the unreadable frame's camera left out"
    );
}
