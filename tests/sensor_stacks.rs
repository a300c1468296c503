//! Stacks of flat fields and dark frames through the command line (issue
//! 24): `calibrate` with a folder per camera writes the sensor's maps beside
//! `rig.json` with their checksums and records them; `measure` corrects the
//! frames with them and refuses a map that was changed; a bad stack is
//! refused naming the file, with nothing written; single files keep the
//! relative illumination alone, as before stacks.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{bin, ok, refused, render_campaign, s, stderr, tree};

use std::path::{Path, PathBuf};

/// The real sensor of these tests: a 12-bit ADC, fixed patterns, hot pixels,
/// stacks of 4.
const SENSOR: &str = "[sensor]\nadc_bits = 12\nprnu = 0.01\ndsnu_dn = 8.0\ncolumn_offset_dn = 12.0\n\
                      hot_pixels = 20\nhot_pixel_e = [1000.0, 8000.0]\ncalibration_frames = 4\n";

/// A small campaign `dir/c` rendered on the real sensor.
fn campaign(dir: &Path) -> PathBuf {
    let config = dir.join("sensor.toml");
    std::fs::write(&config, SENSOR).unwrap();
    let c = dir.join("c");
    render_campaign(&c, (320, 240), [3, 2, 1], &["--config", s(&config)]);
    c
}

/// `calibrate` from the correspondences with `flats` and `darks` per camera.
fn calibrate(c: &Path, flats: &[PathBuf], darks: &[PathBuf], out: &Path) -> std::process::Output {
    let mut args: Vec<String> = ["calibrate", "--target"]
        .iter()
        .map(|a| a.to_string())
        .collect();
    args.push(s(&c.join("target.csv")).into());
    args.push("--nominal".into());
    args.push(s(&c.join("nominal.json")).into());
    args.push("--points".into());
    for k in 1..=3 {
        args.push(s(&c.join(format!("calib/points_cam{k}.csv"))).into());
    }
    args.push("--flat-fields".into());
    args.extend(flats.iter().map(|p| s(p).to_string()));
    args.push("--dark-frames".into());
    args.extend(darks.iter().map(|p| s(p).to_string()));
    args.push("--out".into());
    args.push(s(out).into());
    bin().args(args).output().unwrap()
}

fn stacks(c: &Path, kind: &str) -> Vec<PathBuf> {
    (1..=3)
        .map(|k| c.join(format!("calib/{kind}_cam{k}")))
        .collect()
}

fn measure(c: &Path, rig: &Path, out: &Path) -> std::process::Output {
    bin()
        .args([
            "measure",
            "--backend",
            "cpu",
            "--rig",
            s(rig),
            "--manifest",
            s(&c.join("manifest.csv")),
            "--spheres",
            s(&c.join("spheres.csv")),
            "--out",
            s(out),
        ])
        .output()
        .unwrap()
}

#[test]
fn stacks_give_maps_that_measure_uses_and_checks() {
    let dir = tempfile::tempdir().unwrap();
    let c = campaign(dir.path());
    let out = dir.path().join("r/rig.json");
    ok(&calibrate(
        &c,
        &stacks(&c, "flat"),
        &stacks(&c, "dark"),
        &out,
    ));
    let rig: formats::Rig = formats::read_json(&out).unwrap();
    let truth: formats::Truth = formats::read_json(&c.join("truth.json")).unwrap();
    for cam in &rig.cameras {
        let id = cam.model.id;
        let sensor = cam.sensor.as_ref().expect("a sensor record from stacks");
        assert_eq!((sensor.adc_bits, sensor.container_bits), (12, 16));
        assert_eq!((sensor.stack.flats, sensor.stack.darks), (4, 4));
        let injected = truth
            .cameras
            .iter()
            .find(|t| t.model.id == id)
            .unwrap()
            .extra["sensor"]["hot_pixels"]
            .as_array()
            .unwrap()
            .len();
        assert_eq!(sensor.defects.hot, injected, "camera {id}");
        let defects = sensor.maps.defects.as_ref().expect("a defect map");
        let bytes = std::fs::read(out.with_file_name(&defects.file)).unwrap();
        assert_eq!(defects.file, format!("rig.cam{id}.defects.tif"));
        assert_eq!(sensor::maps::checksum(&bytes), defects.crc32);
    }
    let report = std::fs::read_to_string(dir.path().join("r/rig.commissioning.txt")).unwrap();
    assert!(
        report.contains("stacks of 4 flat and 4 dark frames"),
        "{report}"
    );
    assert!(report.contains("12-bit ADC"), "{report}");

    let points = dir.path().join("points.csv");
    let measured = measure(&c, &out, &points);
    assert!(
        stderr(&measured).contains("corrected pixel by pixel"),
        "{}",
        stderr(&measured)
    );
    assert!(points.exists(), "{}", stderr(&measured));

    // A map changed after calibration is refused by its checksum, naming it.
    let map = dir.path().join("r/rig.cam2.defects.tif");
    let mut bytes = std::fs::read(&map).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0xff;
    std::fs::write(&map, bytes).unwrap();
    let again = measure(&c, &out, &dir.path().join("points2.csv"));
    refused(&again, &["rig.cam2.defects.tif", "checksum"]);
}

/// `extract` with stacks corrects the frames with the maps and counts the
/// defective pixels inside each blob; with single files the column is empty.
#[test]
fn extract_with_stacks_counts_defective_pixels_in_blobs() {
    let dir = tempfile::tempdir().unwrap();
    let c = campaign(dir.path());
    let image = c.join("calib/cam1.tif");
    let extract = |flat: &Path, dark: &Path, out: &Path| {
        bin()
            .args([
                "extract",
                "--backend",
                "cpu",
                "--flat-field",
                s(flat),
                "--dark-frame",
                s(dark),
                "--out",
                s(out),
                s(&image),
            ])
            .output()
            .unwrap()
    };
    let (flats, darks) = (&stacks(&c, "flat")[0], &stacks(&c, "dark")[0]);
    let with = dir.path().join("with.csv");
    let out = extract(flats, darks, &with);
    ok(&out);
    assert!(
        stderr(&out).contains("trinocular: sensor:"),
        "{}",
        stderr(&out)
    );
    let rows: Vec<formats::BlobRow> = formats::read_csv(&with)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    assert!(!rows.is_empty());
    assert!(rows.iter().all(|r| r.defect_pixels.is_some()));
    // K from the stacks' photon transfer: every centroid has its σ.
    let sigmas = |rows: &[formats::BlobRow]| -> Vec<(f64, f64, f64)> {
        rows.iter()
            .map(|r| {
                (
                    r.u_sigma_px.unwrap(),
                    r.v_sigma_px.unwrap(),
                    r.uv_correlation.unwrap(),
                )
            })
            .collect()
    };
    let from_stacks = sigmas(&rows);
    assert!(
        from_stacks.iter().all(|&(su, sv, r)| su > 0.0
            && su < 0.1
            && sv > 0.0
            && sv < 0.1
            && r.abs() <= 1.0),
        "{from_stacks:?}"
    );
    let first = |d: &Path| {
        std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().path())
            .min()
            .unwrap()
    };
    let without = dir.path().join("without.csv");
    ok(&extract(&first(flats), &first(darks), &without));
    let rows: Vec<formats::BlobRow> = formats::read_csv(&without)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    assert!(rows.iter().all(|r| r.defect_pixels.is_none()));
    // Single frames measure no K: no σ, unless K is given; the renderer's
    // K (4 DN/e⁻) gives the σ of the stacks' K to its accuracy.
    assert!(
        rows.iter()
            .all(|r| r.u_sigma_px.is_none() && r.uv_correlation.is_none())
    );
    let given = dir.path().join("given.csv");
    let out = bin()
        .args(["extract", "--backend", "cpu", "--gain-dn-per-e", "4"])
        .args([
            "--flat-field",
            s(&first(flats)),
            "--dark-frame",
            s(&first(darks)),
        ])
        .args(["--out", s(&given), s(&image)])
        .output()
        .unwrap();
    ok(&out);
    let rows: Vec<formats::BlobRow> = formats::read_csv(&given)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    for (g, k) in sigmas(&rows).iter().zip(&from_stacks) {
        assert!((g.0 / k.0 - 1.0).abs() < 0.05, "{g:?} {k:?}");
    }
}

#[test]
fn bad_stacks_are_refused_naming_the_file_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let c = campaign(dir.path());
    let out = dir.path().join("r/rig.json");

    // A frame of another size in camera 2's flats.
    let flats = stacks(&c, "flat");
    let odd = flats[1].join("zz_other_size.tif");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(64, 48, image::Luma([30000]))
        .save(&odd)
        .unwrap();
    let before = tree(dir.path());
    let e = refused(
        &calibrate(&c, &flats, &stacks(&c, "dark"), &out),
        &["zz_other_size.tif", "64×48"],
    );
    assert!(tree(dir.path()) == before, "{e}: files changed");
    std::fs::remove_file(&odd).unwrap();
    let before = tree(dir.path());

    // Flats given as darks: the flat is no brighter than its "dark".
    let e = refused(
        &calibrate(&c, &stacks(&c, "flat"), &stacks(&c, "flat"), &out),
        &["flat_cam1", "dark frame"],
    );
    assert!(tree(dir.path()) == before, "{e}: files changed");

    // A stack of one frame where a per-pixel map needs more.
    let lone = dir.path().join("lone");
    std::fs::create_dir(&lone).unwrap();
    let first = std::fs::read_dir(&flats[0])
        .unwrap()
        .map(|e| e.unwrap().path())
        .min()
        .unwrap();
    std::fs::copy(&first, lone.join("flat.tif")).unwrap();
    let before = tree(dir.path());
    let mut one = flats.clone();
    one[0] = lone.clone();
    let e = refused(
        &calibrate(&c, &one, &stacks(&c, "dark"), &out),
        &["lone", "1 frame"],
    );
    assert!(tree(dir.path()) == before, "{e}: files changed");

    // Single files: the relative illumination alone, no sensor record.
    let first_of = |d: &Path| {
        std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().path())
            .min()
            .unwrap()
    };
    let files =
        |kind: &str| -> Vec<PathBuf> { stacks(&c, kind).iter().map(|d| first_of(d)).collect() };
    ok(&calibrate(&c, &files("flat"), &files("dark"), &out));
    let rig: formats::Rig = formats::read_json(&out).unwrap();
    assert!(rig.cameras.iter().all(|cam| cam.sensor.is_none()));
    assert!(!dir.path().join("r/rig.cam1.defects.tif").exists());
}
