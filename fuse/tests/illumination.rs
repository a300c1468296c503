//! The relative illumination end to end: campaigns rendered through lenses
//! of different relative illumination (radiance images; an ideal cos⁴θ lens;
//! a lens with strong vignetting of its own, RI = cos⁴θ·(1 + 1.2·tan²θ)),
//! all with the seed rig's distortion, measured with the RI fitted from each
//! campaign's own flat field and dark frame. The renderer's true cameras are
//! the rig, so these tests judge the radiometry and fusion alone.
//!
//! Holds: sphere-A displacements within the end-to-end tolerance of these
//! 1024×768 campaigns (4 µm, see `end_to_end.rs`), and a scale error below
//! 10 ppm on X and Y. Negative control: the vignetted lens measured without
//! its flats (the ideal lens assumed) shows the scale error the
//! sphere-image model predicts, (v₁/2)·R²/(Z² − R²) — so the flats carry the
//! correction.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::Path;

use formats::{Axis, IlluminationJson, PointRow, Rig, read_csv};
use fuse::MeasureOptions;
use geom::Illumination;
use synth::IlluminationModel;

/// Render a 1024×768 campaign of the seed rig through `illumination` with vignetting `v`.
fn campaign(dir: &Path, illumination: IlluminationModel, v: [f64; 2], seed: u64) {
    common::campaign_with(dir, 1024, 6, 2, seed, |config| {
        config.optics.illumination = illumination;
        config.optics.vignetting = v;
    });
}

/// The true rig with each camera's RI fitted from the campaign's flat field
/// and dark frame (`with_flats`), or the ideal lens assumed.
fn rig(dir: &Path, with_flats: bool) -> Rig {
    let mut rig = common::true_rig(dir);
    if !with_flats {
        return rig;
    }
    for c in &mut rig.cameras {
        let id = c.model.id;
        let read = |name: &str| {
            image::open(dir.join(format!("calib/{name}_cam{id}.tif")))
                .unwrap()
                .into_luma16()
        };
        let (flat, dark) = (read("flat"), read("dark"));
        fn px(img: &image::ImageBuffer<image::Luma<u16>, Vec<u16>>) -> calib::Pixels<'_> {
            calib::Pixels {
                values: img.as_raw(),
                width: img.width(),
                height: img.height(),
                saturation: u16::MAX,
            }
        }
        let k = c.model.to_camera().unwrap().intrinsics;
        let fit = calib::fit_flat_field(&px(&flat), &px(&dark), [k.cx, k.cy], k.fx).unwrap();
        c.relative_illumination = IlluminationJson::from_model(&Illumination::Radial(fit.model));
    }
    rig
}

/// Measure the campaign with `rig`: (sphere-A displacement RMS µm, scale error ppm on X and Y).
fn measure_campaign(dir: &Path, rig: &Rig, name: &str) -> (f64, [f64; 2]) {
    let out = dir.join(name);
    let summary = common::measure_rig(
        dir,
        name,
        rig,
        &Default::default(),
        &MeasureOptions::default(),
        &|_, _| {},
        true,
    )
    .unwrap();
    assert_eq!(summary.problems, 0);
    let rows = |p: &Path| -> Vec<PointRow> {
        read_csv(p).unwrap().into_iter().map(|r| r.record).collect()
    };
    let errors =
        synth::truth::displacement_errors(&rows(&out), &rows(&dir.join("truth_points.csv")), "A");
    let rms = synth::truth::rms(&errors).unwrap() * 1e3;
    let scale = [Axis::X, Axis::Y].map(|a| synth::truth::scale_error_ppm(&errors, a).unwrap());
    eprintln!(
        "{name}: sphere A {rms:.2} µm RMS, scale error X {:+.1} ppm, Y {:+.1} ppm",
        scale[0], scale[1]
    );
    (rms, scale)
}

/// End-to-end tolerance of these campaigns (µm RMS), as `end_to_end.rs`.
const RMS_TOL_UM: f64 = 4.0;
/// Largest scale error with the flats (ppm), the requirement.
const SCALE_TOL_PPM: f64 = 10.0;

fn holds_with_flats(illumination: IlluminationModel, v: [f64; 2], seed: u64) -> std::path::PathBuf {
    let dir = tempfile::tempdir().unwrap().keep();
    campaign(&dir, illumination, v, seed);
    let (rms, scale) = measure_campaign(&dir, &rig(&dir, true), "points_flats.csv");
    assert!(rms < RMS_TOL_UM, "{rms} µm RMS");
    for s in scale {
        assert!(s.abs() < SCALE_TOL_PPM, "scale error {s} ppm");
    }
    dir
}

#[test]
fn radiance_images_with_their_flats() {
    let dir = holds_with_flats(IlluminationModel::Radiance, [0.0, 0.0], 21);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn ideal_lens_with_its_flats() {
    let dir = holds_with_flats(IlluminationModel::Lens, [0.0, 0.0], 22);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn vignetted_lens_with_its_flats_and_without_them() {
    let v1 = 1.2;
    let dir = holds_with_flats(IlluminationModel::Lens, [v1, 0.0], 23);
    // Negative control: the ideal lens assumed.
    let (_, scale) = measure_campaign(&dir, &rig(&dir, false), "points_ideal.csv");
    let depth = |id: u8| {
        common::true_camera(&dir, id)
            .to_camera(&geom::Point3::new(0.0, 0.0, 30.0))
            .z
    };
    let r: f64 = 10.0;
    // X is measured by cameras 2 and 3, Y by 1 and 3: their mean depth.
    for (s, z) in scale
        .iter()
        .zip([(depth(2) + depth(3)) / 2.0, (depth(1) + depth(3)) / 2.0])
    {
        let predicted = v1 / 2.0 * r * r / (z * z - r * r) * 1e6;
        eprintln!("without flats: {s:+.1} ppm, predicted {predicted:+.1} ppm");
        assert!(
            (s - predicted).abs() < 0.1 * predicted + SCALE_TOL_PPM,
            "{s} ppm against {predicted}"
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}
