//! Calibration on real measured data: Heikkilä's two-plane 3-D target
//! (491 points, 768×576 px; `testdata/heikkila/README.md`).
//!
//! The image coordinates are used exactly as published (MATLAB convention,
//! probably 1-based), because the README's reference solution was computed on
//! the data as given: we compare like with like. In this project's 0-based
//! convention the principal point would be one pixel smaller in u and v; the
//! test `principal_point_follows_the_pixel_origin` shows that shifting the
//! data shifts only cx, cy.
//!
//! The reference figures are on all 491 points, so outlier rejection is off
//! where they are compared (`outlier_k: None`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use calib::{Calibration, Model, Observation, Options, calibrate};
use geom::{Point2, Point3};

const WIDTH: u32 = 768;
const HEIGHT: u32 = 576;

/// The README's reference solution (k1, k2, p1, p2 model, all points).
const REF_FX: f64 = 1037.4;
const REF_FY: f64 = 1034.0;
const REF_CX: f64 = 367.3;
const REF_CY: f64 = 306.6;

fn data() -> Vec<Observation> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../testdata/heikkila/data3d.csv"
    );
    let mut rdr = csv::Reader::from_path(path).expect("testdata/heikkila/data3d.csv");
    rdr.records()
        .enumerate()
        .map(|(i, r)| {
            let r = r.unwrap();
            let f = |k: usize| r[k].parse::<f64>().unwrap();
            Observation {
                id: i as u32 + 1,
                world: Point3::new(f(0), f(1), f(2)),
                pixel: Point2::new(f(3), f(4)),
                sphere_diameter: None,
            }
        })
        .collect()
}

fn all_points(model: Model) -> Options {
    Options {
        model,
        outlier_k: None,
        ..Options::default()
    }
}

fn fit(obs: &[Observation], model: Model) -> Calibration {
    calibrate(obs, WIDTH, HEIGHT, &all_points(model)).unwrap()
}

fn sd(c: &Calibration, name: &str) -> (f64, f64) {
    let p = c.parameter(name).unwrap();
    (p.value, p.std_dev.unwrap())
}

#[test]
fn normalised_dlt_rms_matches_the_reference() {
    let obs = data();
    assert_eq!(obs.len(), 491);
    let c = fit(&obs, Model::Pinhole);
    let world: Vec<_> = obs.iter().map(|o| o.world).collect();
    let image: Vec<_> = obs.iter().map(|o| o.pixel).collect();
    let max = calib::dlt_residuals(&c.dlt, &world, &image)
        .into_iter()
        .map(|r| r.unwrap().norm())
        .fold(0.0, f64::max);
    println!(
        "normalised DLT: RMS {:.4} px (max {max:.3}); pinhole + LM: RMS {:.4} px",
        c.dlt_rms_px, c.rms_px
    );
    // README: ≈ 0.958 (max ≈ 2.67); pinhole + LM ≈ 0.956.
    assert!(
        (c.dlt_rms_px - 0.958).abs() < 0.002,
        "DLT RMS {}",
        c.dlt_rms_px
    );
    assert!((max - 2.67).abs() < 0.02, "DLT max {max}");
    assert!(
        (c.rms_px - 0.956).abs() < 0.002,
        "pinhole LM RMS {}",
        c.rms_px
    );
    assert!(c.rms_px < c.dlt_rms_px);
}

#[test]
fn distortion_models_reach_the_reference_rms_and_intrinsics() {
    let obs = data();
    let k1k2 = fit(&obs, Model::K1K2);
    println!("k1, k2: RMS {:.5} px", k1k2.rms_px);
    assert!(
        (k1k2.rms_px - 0.073).abs() < 0.002,
        "k1k2 RMS {}",
        k1k2.rms_px
    );

    let c = fit(&obs, Model::K1K2P1P2);
    println!("k1, k2, p1, p2: RMS {:.5} px", c.rms_px);
    assert!(c.rms_px <= 0.0725, "RMS {}", c.rms_px);
    // Not suspiciously low either: the data carry ≈ 0.07 px of real noise.
    assert!(c.rms_px > 0.070, "RMS {}", c.rms_px);
    for (name, reference) in [
        ("fx", REF_FX),
        ("fy", REF_FY),
        ("cx", REF_CX),
        ("cy", REF_CY),
    ] {
        let (v, s) = sd(&c, name);
        println!("{name} = {v:.3} ± {s:.3} px (reference {reference})");
        assert!(
            (v - reference).abs() <= s,
            "{name} = {v} ± {s}, reference {reference}"
        );
    }
    let (k1, k2) = (
        c.parameter("k1").unwrap().value,
        c.parameter("k2").unwrap().value,
    );
    println!("k1 = {k1:.4}, k2 = {k2:.4}");
    assert!(
        (k1 + 0.218).abs() < 0.002 && (k2 - 0.214).abs() < 0.003,
        "k1 {k1}, k2 {k2}"
    );
}

/// Fit half the points (alternate rows), check the other half.
#[test]
fn cross_validation_half_and_half() {
    let obs = data();
    let (even, odd): (Vec<_>, Vec<_>) = obs.iter().enumerate().partition(|(i, _)| i % 2 == 0);
    let even: Vec<Observation> = even.into_iter().map(|(_, o)| *o).collect();
    let odd: Vec<Observation> = odd.into_iter().map(|(_, o)| *o).collect();
    let full = fit(&obs, Model::K1K2P1P2);
    let mut halves = Vec::new();
    for (name, train, test) in [("even", &even, &odd), ("odd", &odd, &even)] {
        let c = fit(train, Model::K1K2P1P2);
        let cam = &c.camera;
        let sq: f64 = test
            .iter()
            .map(|o| (cam.project(&o.world).unwrap() - o.pixel).norm_squared())
            .sum();
        let rms = (sq / test.len() as f64).sqrt();
        println!(
            "fit on {name} rows ({} points): fit RMS {:.4}, check RMS {rms:.4} px",
            train.len(),
            c.rms_px
        );
        assert!(rms <= 0.08, "check RMS {rms}");
        halves.push(c);
    }
    // The standard deviations are right: half the data gives ≈ √2 larger
    // ones, and the two independent halves agree within them.
    for name in ["fx", "fy", "cx", "cy", "k1", "k2"] {
        let (_, s_full) = sd(&full, name);
        let (a, sa) = sd(&halves[0], name);
        let (b, sb) = sd(&halves[1], name);
        let ratio = (sa * sb).sqrt() / s_full;
        println!(
            "{name}: σ full {s_full:.5}, halves {sa:.5} / {sb:.5}, difference {:.5}",
            a - b
        );
        assert!(
            (ratio - 2f64.sqrt()).abs() < 0.15,
            "{name}: σ ratio {ratio}"
        );
        assert!(
            (a - b).abs() <= 3.0 * (sa * sa + sb * sb).sqrt(),
            "{name}: halves differ by {}",
            a - b
        );
    }
}

#[test]
fn principal_point_follows_the_pixel_origin() {
    let obs = data();
    let shifted: Vec<Observation> = obs
        .iter()
        .map(|o| Observation {
            pixel: o.pixel - geom::Vector2::new(1.0, 1.0),
            ..*o
        })
        .collect();
    let a = fit(&obs, Model::K1K2P1P2);
    let b = fit(&shifted, Model::K1K2P1P2);
    let (ka, kb) = (a.camera.intrinsics, b.camera.intrinsics);
    assert!((ka.cx - kb.cx - 1.0).abs() < 1e-6 && (ka.cy - kb.cy - 1.0).abs() < 1e-6);
    assert!((ka.fx - kb.fx).abs() < 1e-6 && (ka.fy - kb.fy).abs() < 1e-6);
    assert!((a.rms_px - b.rms_px).abs() < 1e-9);
}

/// Gross errors on a few points are found and reported; the fit on the rest
/// is as good as without them.
#[test]
fn outliers_are_rejected_and_reported() {
    let clean = data();
    let mut obs = clean.clone();
    let bad = [7u32, 100, 222, 345, 480];
    for o in obs.iter_mut().filter(|o| bad.contains(&o.id)) {
        o.pixel.x += 2.0;
        o.pixel.y -= 1.5;
    }
    let options = Options::default();
    let c = calibrate(&obs, WIDTH, HEIGHT, &options).unwrap();
    let reference = calibrate(&clean, WIDTH, HEIGHT, &options).unwrap();
    println!(
        "rejected {:?} in {} rounds; RMS {:.4} px (clean data with rejection: {:.4}, rejected {:?})",
        c.outliers, c.rounds, c.rms_px, reference.rms_px, reference.outliers
    );
    for id in bad {
        assert!(
            c.outliers.contains(&id),
            "corrupted point {id} not rejected"
        );
    }
    assert!(c.residuals.iter().filter(|r| r.outlier).count() == c.outliers.len());
    assert!(c.rms_px < 0.0725);
    assert!((c.camera.intrinsics.fx - reference.camera.intrinsics.fx).abs() < 0.05);
    // Without rejection the corrupted points spoil the fit.
    let kept = calibrate(&obs, WIDTH, HEIGHT, &all_points(Model::K1K2P1P2)).unwrap();
    assert!(
        kept.rms_px > 0.2,
        "RMS with the corrupted points {}",
        kept.rms_px
    );
}
