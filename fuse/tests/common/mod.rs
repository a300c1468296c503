//! Shared fixtures of the fuse tests: rendered campaigns and their true rig.

#![allow(dead_code, clippy::unwrap_used)]

use std::path::Path;

use formats::{Rig, RigCamera, SphereRow, Truth, read_csv, read_json};

/// Render a campaign of the seed rig at `width` px (same field of view), with
/// `targets` per axis, `runs` runs, one capture.
pub fn campaign(dir: &Path, width: u32, targets: u32, runs: u32, seed: u64) {
    campaign_with(dir, width, targets, runs, seed, |_| {});
}

/// As [`campaign`], with the seed's configuration changed by `edit` first.
pub fn campaign_with(
    dir: &Path,
    width: u32,
    targets: u32,
    runs: u32,
    seed: u64,
    edit: impl FnOnce(&mut synth::Config),
) {
    campaign_captured(dir, width, targets, runs, 1, seed, edit);
}

/// As [`campaign_with`], each instant captured `captures` times.
pub fn campaign_captured(
    dir: &Path,
    width: u32,
    targets: u32,
    runs: u32,
    captures: u32,
    seed: u64,
    edit: impl FnOnce(&mut synth::Config),
) {
    let mut config = synth::Config::default();
    edit(&mut config);
    config
        .apply(&synth::Overrides {
            width: Some(width),
            height: Some(width * 3 / 4),
            targets: Some(targets),
            runs: Some(runs),
            captures: Some(captures),
            seed: Some(seed),
        })
        .unwrap();
    synth::write_campaign(
        &config,
        dir,
        &mut formats::OutputPlan::new(false),
        &synth::NoProgress,
    )
    .unwrap();
}

/// The renderer's true cameras as a rig.json: measurements then judge fusion alone.
pub fn true_rig(dir: &Path) -> Rig {
    let truth: Truth = read_json(&dir.join("truth.json")).unwrap();
    Rig {
        cameras: truth
            .cameras
            .iter()
            .map(|c| RigCamera::new(c.model.id, &c.model.to_camera().unwrap(), 0.0, 0))
            .collect(),
    }
}

/// The renderer's true camera `id` of the campaign in `dir`.
pub fn true_camera(dir: &Path, id: u8) -> geom::Camera {
    let truth: Truth = read_json(&dir.join("truth.json")).unwrap();
    truth
        .cameras
        .iter()
        .find(|c| c.model.id == id)
        .unwrap()
        .model
        .to_camera()
        .unwrap()
}

/// The campaign's spheres.
pub fn spheres(dir: &Path) -> Vec<SphereRow> {
    read_csv(&dir.join("spheres.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}

/// Measure a campaign with the true rig and default options into `dir/out`.
pub fn measure(dir: &Path, out: &str) -> fuse::Result<fuse::Summary> {
    measure_with(
        dir,
        out,
        &fuse::MeasureOptions::default(),
        &|_, _| {},
        false,
    )
}

/// Measure a campaign with the true rig into `dir/out`; existing outputs
/// are replaced only when `force`.
pub fn measure_with(
    dir: &Path,
    out: &str,
    options: &fuse::MeasureOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
    force: bool,
) -> fuse::Result<fuse::Summary> {
    measure_rig(
        dir,
        out,
        &true_rig(dir),
        &Default::default(),
        options,
        progress,
        force,
    )
}

/// Measure a campaign with `rig` and the cameras' sensor maps `sensor` into `dir/out`.
pub fn measure_rig(
    dir: &Path,
    out: &str,
    rig: &Rig,
    sensor: &std::collections::BTreeMap<u8, sensor::SensorMaps>,
    options: &fuse::MeasureOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
    force: bool,
) -> fuse::Result<fuse::Summary> {
    fuse::measure(
        &fuse::Inputs {
            manifest: &dir.join("manifest.csv"),
            rig,
            spheres: &spheres(dir),
            sensor,
        },
        &dir.join(out),
        options,
        &extract::CpuBackend,
        &mut formats::OutputPlan::new(force),
        progress,
    )
}

/// The records of a CSV file.
pub fn records<T: formats::Record>(path: &Path) -> Vec<T> {
    read_csv(path)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect()
}
