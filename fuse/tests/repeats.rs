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
