//! A small campaign written to disk follows docs/formats.md; the default
//! campaign's scenes keep every sphere in every frame and never overlap.

#![allow(clippy::unwrap_used)]

use std::collections::BTreeSet;

use formats::{
    Axis, ManifestRow, NominalRig, OutputPlan, PointRow, SphereRow, TargetRow, Truth, read_csv,
    read_json,
};
use synth::{
    Config, NoProgress, Overrides, Plan, SynthRig, check_plan, marker_spheres, markers,
    separation_px, write_campaign, write_target_scene,
};

fn small_config() -> Config {
    let mut c = Config::default();
    c.apply(&Overrides {
        width: Some(512),
        height: Some(384),
        targets: Some(3),
        runs: Some(2),
        captures: Some(2),
        seed: Some(5),
    })
    .unwrap();
    c
}

/// The records of a CSV file of the contract.
fn records<T: formats::Record>(path: &std::path::Path) -> Vec<T> {
    read_csv(path)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}

#[test]
fn small_campaign_follows_the_contract() {
    let config = small_config();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("campaign");
    let summary = write_campaign(&config, &out, &mut OutputPlan::new(false), &NoProgress).unwrap();
    // X: 3 targets × 2 directions × 2 runs × 2 captures × 2 lines; Y: one line.
    let instants = 3 * 2 * 2 * 2 * 2 + 3 * 2 * 2 * 2;
    assert_eq!(summary.instants, instants);
    assert_eq!(summary.frames, instants * 3);

    let manifest: Vec<ManifestRow> = records(&out.join("manifest.csv"));
    assert_eq!(manifest.len(), instants * 3);
    let mut per_instant = std::collections::BTreeMap::new();
    for row in &manifest {
        let img = image::open(out.join(&row.image)).unwrap().to_luma16();
        assert_eq!(img.dimensions(), (512, 384), "{}", row.image);
        per_instant
            .entry(row.instant())
            .or_insert_with(BTreeSet::new)
            .insert(row.camera);
    }
    assert_eq!(per_instant.len(), instants);
    assert!(per_instant.values().all(|cams| cams.len() == 3));
    assert!(
        manifest
            .iter()
            .any(|r| r.axis == Axis::Y && r.direction == formats::Direction::Down)
    );

    let spheres: Vec<SphereRow> = records(&out.join("spheres.csv"));
    assert_eq!(
        spheres
            .iter()
            .map(|s| (s.name.as_str(), s.diameter))
            .collect::<Vec<_>>(),
        [("A", 20.0), ("B", 15.0), ("C", 10.0)]
    );
    let nominal: NominalRig = read_json(&out.join("nominal.json")).unwrap();
    assert_eq!(nominal.cameras.len(), 3);
    let target: Vec<TargetRow> = records(&out.join("target.csv"));
    assert_eq!(target.len(), 49);
    for k in 1..=3 {
        let img = image::open(out.join(format!("calib/cam{k}.tif"))).unwrap();
        assert_eq!((img.width(), img.height()), (512, 384));
        assert!(out.join(format!("calib/points_cam{k}.csv")).exists());
    }

    let truth: Truth = read_json(&out.join("truth.json")).unwrap();
    assert_eq!(truth.instants.len(), instants);
    assert_eq!(truth.cameras.len(), 3);
    assert_eq!(truth.spheres.len(), 3);
    // The true camera in truth.json reproduces the renderer's camera.
    let rig = SynthRig::from_config(&config).unwrap();
    for (t, c) in truth.cameras.iter().zip(&rig.cameras) {
        let cam = t.model.to_camera().unwrap();
        let x = geom::Point3::new(10.0, -20.0, 35.0);
        assert!((cam.project(&x).unwrap() - c.camera.project(&x).unwrap()).norm() < 1e-9);
        let p = c.camera.projection_matrix();
        assert!((0..3).all(|i| (0..4).all(|j| (t.p[i][j] - p[(i, j)]).abs() <= 1e-9 * p.norm())));
    }
    // Instants carry the exact centres, and agree with truth_points.csv.
    let points: Vec<PointRow> = records(&out.join("truth_points.csv"));
    assert_eq!(points.len(), instants * 3);
    let first = &truth.instants[0];
    let a = first.spheres["A"];
    let pa = points.iter().find(|p| p.sphere == "A").unwrap();
    assert!((pa.x - a[0]).abs() < 1e-9 && (pa.y - a[1]).abs() < 1e-9 && (pa.z - a[2]).abs() < 1e-9);
    assert_eq!(pa.cameras, "truth");
    // Injected errors and reference figures are there.
    let errors = &truth.extra["errors"];
    assert_eq!(errors["X"]["targets"].as_array().unwrap().len(), 3);
    assert!(errors["X"]["targets"][0]["positioning_up_um"].is_number());
    let figures = &truth.extra["figures"];
    assert!(
        figures["axes"]["X"]["positioning"]["B_um"].is_number(),
        "{figures}"
    );
    // The reversal injected shows in the figures: B ≈ reversal (µm), within
    // the repeatability spread of 2 runs (σ 0.8 µm) — a loose check that the
    // figures come from these positions.
    let b = figures["axes"]["X"]["positioning"]["B_um"]
        .as_f64()
        .unwrap();
    assert!(b.abs() > 0.5 && b.abs() < 6.0, "B = {b}");
}

#[test]
fn target_scene_is_written() {
    let config = small_config();
    let dir = tempfile::tempdir().unwrap();
    let summary = write_target_scene(
        &config,
        dir.path(),
        &mut OutputPlan::new(false),
        &NoProgress,
    )
    .unwrap();
    assert_eq!(summary.markers, 49);
    let truth: Truth = read_json(&dir.path().join("truth.json")).unwrap();
    assert_eq!(truth.cameras.len(), 3);
    assert!(truth.instants.is_empty());
    for k in 1..=3 {
        assert!(dir.path().join(format!("calib/cam{k}.tif")).exists());
    }
}

/// Every instant of the default (seed) campaign, in every camera: all
/// spheres at least 20 px inside the frame and at least 20 px apart (at the
/// seed's ≈ 8000 px focal length, 20 px ≈ 1.2 mm at the table), from the
/// analytic silhouettes.
#[test]
fn default_campaign_keeps_spheres_apart_and_in_frame() {
    let config = Config::default();
    let rig = SynthRig::from_config(&config).unwrap();
    let plan = Plan::new(&config).unwrap();
    let check = check_plan(&rig, &plan).unwrap();
    eprintln!("{check:?}");
    assert!(check.min_frame_clearance_px > 20.0, "{check:?}");
    assert!(check.min_separation_px > 20.0, "{check:?}");
}

/// The calibration target: non-coplanar, 40–100 markers, none overlapping
/// in any camera (≥ 20 px apart) and all inside every frame.
#[test]
fn calibration_target_markers_are_separated() {
    let config = Config::default();
    let rig = SynthRig::from_config(&config).unwrap();
    let m = markers(&config.target);
    assert!((40..=100).contains(&m.len()));
    let zs: BTreeSet<i64> = m.iter().map(|k| (k.centre.z * 1e6) as i64).collect();
    assert!(zs.len() > 3, "markers are coplanar");
    let spheres = marker_spheres(&m, 1.0);
    for cam in &rig.cameras {
        let mut worst = f64::INFINITY;
        for (i, a) in spheres.iter().enumerate() {
            assert!(synth::frame_clearance_px(&cam.camera, a).unwrap() > 20.0);
            for b in &spheres[i + 1..] {
                worst = worst.min(separation_px(&cam.camera, a, b).unwrap());
            }
        }
        eprintln!("camera {}: closest markers {worst:.1} px apart", cam.id);
        assert!(worst > 20.0, "camera {}: markers {worst} px apart", cam.id);
    }
}

/// The reference figures of the default campaign (evaluate on the exact
/// positions) show the injected reversal: the mean reversal B̄ of each axis
/// equals the configured B. Its standard error from the repeatability noise
/// is σ·√(2/(runs·targets)) ≈ 0.07 µm (X) and 0.19 µm (Y); 0.5 µm is > 2.5 of
/// them for Y and far tighter than a missing or doubled reversal (≥ 2.5 µm off).
#[test]
fn reference_figures_show_the_injected_reversal() {
    let config = Config::default();
    let plan = Plan::new(&config).unwrap();
    let figures = synth::truth::figures(&plan.truth_points()).unwrap();
    for (axis, b) in [
        ("X", config.machine.x.reversal_um),
        ("Y", config.machine.y.reversal_um),
    ] {
        let b_mean = figures["axes"][axis]["positioning"]["B_mean_um"]
            .as_f64()
            .unwrap();
        eprintln!("{axis}: B̄ = {b_mean:.3} µm (injected {b})");
        assert!((b_mean - b).abs() < 0.5, "{axis}: B̄ {b_mean} vs {b}");
    }
}
