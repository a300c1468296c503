//! The indexing method (docs/probe-indexing.md) against independent truth: the check
//! data's expected results (to their rounding) and injected errors (within
//! the noise), the generator's truth for several seeds and grids, an exact
//! noise-free round trip, and every bad input named.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;

use formats::probe::indexing::{IndexingTruth, read_centres};
use geom::nalgebra::{Point3, Vector3};
use probe::ProbeError;
use probe::indexing::{Indexing, Options, Position, report, solve};
use synth::probe::indexing::{AErrors, BErrors, IndexingConfig, generate};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/probe/indexing")
        .join(name)
}

fn check_positions() -> Vec<Position> {
    read_centres(&data("centres.csv"))
        .unwrap()
        .into_iter()
        .map(|r| {
            Position::new(
                r.record.a_deg,
                r.record.b_deg,
                [r.record.x, r.record.y, r.record.z],
            )
        })
        .collect()
}

fn positions_of(config: &IndexingConfig) -> (Vec<Position>, IndexingTruth) {
    let g = generate(config).unwrap();
    let p = g
        .centres
        .iter()
        .map(|r| Position::new(r.a_deg, r.b_deg, [r.x, r.y, r.z]))
        .collect();
    (p, g.truth)
}

/// Half a unit in the last place of the expected file (6 decimals).
const ROUNDING_ARCSEC: f64 = 5e-7;
/// Arc-seconds per radian.
const ARCSEC_PER_RAD: f64 = 206_264.806_247_096_36;

#[test]
fn reproduces_expected_indexing_to_rounding() {
    let ind = solve(&check_positions()).unwrap();
    let mut rdr = csv::Reader::from_path(data("expected_indexing.csv")).unwrap();
    let mut rows = 0;
    for (p, rec) in ind.angles.iter().zip(rdr.records()) {
        let rec = rec.unwrap();
        let (a, b): (f64, f64) = (rec[0].parse().unwrap(), rec[1].parse().unwrap());
        assert_eq!((p.a_deg, p.b_deg), (a, b), "row order");
        let d_a: f64 = rec[2].parse().unwrap();
        // At A = 0° the expected ΔθA (the stylus tilt, θA ≈ 1e-6 rad) carries
        // the digits arccos loses near n = 1: |δθ| ≈ ε/θ with ε a few ulps of
        // 1.0; here θA is computed as atan2(√(l² + m²), n), which keeps them.
        let theta = p.d_a_arcsec.abs() / ARCSEC_PER_RAD;
        let lost = if a == 0.0 {
            ARCSEC_PER_RAD * 8.0 * f64::EPSILON / theta
        } else {
            0.0
        };
        assert!(
            (p.d_a_arcsec - d_a).abs() <= ROUNDING_ARCSEC + lost + 1e-9,
            "ΔθA at A = {a}°, B = {b}°: {} vs {d_a}",
            p.d_a_arcsec
        );
        if rec[3].is_empty() {
            assert_eq!(a, 0.0);
            assert_eq!(p.d_b_arcsec, None);
        } else {
            let d_b: f64 = rec[3].parse().unwrap();
            let got = p.d_b_arcsec.unwrap();
            assert!(
                (got - d_b).abs() <= ROUNDING_ARCSEC + 1e-8,
                "ΔθB at A = {a}°, B = {b}°: {got} vs {d_b}"
            );
        }
        rows += 1;
    }
    assert_eq!(rows, 720);
}

/// Standardised errors (estimate − truth)/u of ΔθA and ΔθB over the
/// positions with A > 0°, and |ΔθA|/u at A = 0° (truth 0 there: the tilt's
/// magnitude, whose mean square is 2 per-component variances).
fn z_scores(ind: &Indexing, truth: &IndexingTruth) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut za, mut zb, mut zero) = (Vec::new(), Vec::new(), Vec::new());
    for (p, t) in ind.angles.iter().zip(&truth.truth) {
        assert_eq!((p.a_deg, p.b_deg), (t.0, t.1), "truth order");
        if p.a_deg == 0.0 {
            assert_eq!(t.3, None);
            zero.push((p.d_a_arcsec - t.2) / p.u_d_a_arcsec);
            continue;
        }
        za.push((p.d_a_arcsec - t.2) / p.u_d_a_arcsec);
        zb.push((p.d_b_arcsec.unwrap() - t.3.unwrap()) / p.u_d_b_arcsec.unwrap());
    }
    (za, zb, zero)
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// Every standardised error is a plausible draw of N(0, 1): none beyond
/// 4.9 (1e-6 per draw: for the ~6000 draws of the round trips the chance of
/// one is 0.6 %) and an RMS within `spread` of 1.
fn assert_within_noise(za: &[f64], zb: &[f64], zero: &[f64], spread: f64, what: &str) {
    for z in za.iter().chain(zb) {
        assert!(
            z.abs() < 4.9,
            "{what}: an error {z} standard uncertainties off"
        );
    }
    for (name, v) in [("ΔθA", za), ("ΔθB", zb)] {
        let r = rms(v);
        assert!((r - 1.0).abs() < spread, "{what}: {name} RMS z {r}");
    }
    let r = rms(zero) / 2f64.sqrt();
    eprintln!(
        "{what}: RMS z of ΔθA {:.3}, of ΔθB {:.3}, of the A = 0° tilt {r:.3}; largest |z| {:.2}",
        rms(za),
        rms(zb),
        za.iter().chain(zb).fold(0.0_f64, |m, z| m.max(z.abs()))
    );
    assert!(
        (r - 1.0).abs() < spread * 1.5,
        "{what}: A = 0° tilt RMS z {r}"
    );
}

#[test]
fn check_data_truth_within_the_stated_noise() {
    let ind = solve(&check_positions()).unwrap();
    let truth: IndexingTruth = formats::read_json(&data("truth.json")).unwrap();
    assert_eq!(truth.truth.len(), 720);
    let (za, zb, zero) = z_scores(&ind, &truth);
    // 672 draws each: the RMS of N(0, 1) lies within ±0.08 of 1 at 3 sd (0.027).
    assert_within_noise(&za, &zb, &zero, 0.08, "check data");
    // The README's figure: ΔθA off by ≈ 0.5″ (0.3 µm over 117 mm).
    let d: Vec<f64> = ind
        .angles
        .iter()
        .zip(&truth.truth)
        .filter(|(p, _)| p.a_deg > 0.0)
        .map(|(p, t)| p.d_a_arcsec - t.2)
        .collect();
    let r = rms(&d);
    eprintln!("check data: RMS of ΔθA − truth {r:.3}″");
    assert!((0.4..0.65).contains(&r), "ΔθA RMS error {r}″");
    // The 0.3 µm noise, from the sphere fit.
    assert!((ind.noise_mm * 1e3 - 0.3).abs() < 0.03, "{}", ind.noise_mm);
    assert!((ind.radius_mm - 117.0).abs() < 1e-3, "{}", ind.radius_mm);
}

#[test]
fn generator_round_trips_seeds_and_grids() {
    let grids = [
        // (A max, A step, B step, stylus): the PH10, 15° steps, a smaller A
        // range with a coarse B turn, a long stylus on an odd step.
        (105.0, 7.5, 7.5, 117.0),
        (90.0, 15.0, 15.0, 117.0),
        (45.0, 7.5, 40.0, 60.0),
        (100.0, 10.0, 24.0, 300.0),
    ];
    let (mut za, mut zb, mut zero) = (Vec::new(), Vec::new(), Vec::new());
    for (g, &(a_max, a_step, b_step, stylus)) in grids.iter().enumerate() {
        for seed in [1_u64, 7, 42] {
            let config = IndexingConfig {
                seed: seed + 100 * g as u64,
                a_max_deg: a_max,
                a_step_deg: a_step,
                b_step_deg: b_step,
                stylus_mm: stylus,
                noise_um: 0.5,
                ..Default::default()
            };
            let (positions, truth) = positions_of(&config);
            let ind = solve(&positions).unwrap();
            let head = truth.head.as_ref().unwrap();
            // O and the radius within 4.5 standard uncertainties.
            for k in 0..3 {
                let d = ind.frame.origin[k] - head.rotation_centre[k];
                assert!(d.abs() < 4.5 * ind.u_origin_mm[k], "O[{k}] off by {d} mm");
            }
            assert!((ind.radius_mm - stylus).abs() < 4.5 * ind.u_radius_mm);
            // The frame: the B axis within a few noise-over-radius radians.
            let b_axis = Vector3::from(head.b_axis);
            let tilt = ind.frame.z.angle(&b_axis);
            assert!(tilt < 10.0 * 0.5e-3 / stylus, "B axis off by {tilt} rad");
            let a_axis = Vector3::from(head.a_axis);
            assert!(ind.frame.y.angle(&a_axis) < 20.0 * 0.5e-3 / stylus);
            let (a, b, z) = z_scores(&ind, &truth);
            za.extend(a);
            zb.extend(b);
            zero.extend(z);
        }
    }
    // ~3000 draws each pooled (sd of the RMS 0.013): within ±0.1 of 1, which
    // leaves room for σ̂ estimated from few residuals on the small grids.
    assert_within_noise(&za, &zb, &zero, 0.1, "generator");
}

#[test]
fn noise_free_round_trip_is_exact() {
    let config = IndexingConfig {
        noise_um: 0.0,
        a_errors: AErrors {
            random_arcsec: 3.0,
            gravity_arcsec: 5.0,
            ..Default::default()
        },
        b_errors: BErrors {
            random_arcsec: 3.0,
            once_per_turn_arcsec: 4.0,
            ..Default::default()
        },
        ..Default::default()
    };
    let (positions, truth) = positions_of(&config);
    let ind = solve(&positions).unwrap();
    for (p, t) in ind.angles.iter().zip(&truth.truth) {
        // Double-precision rounding of 117 mm coordinates: ~1e-14 mm, 1e-10″.
        assert!((p.d_a_arcsec - t.2).abs() < 1e-6, "{p:?} vs {t:?}");
        if let (Some(d), Some(e)) = (p.d_b_arcsec, t.3) {
            assert!((d - e).abs() < 1e-6, "{p:?} vs {t:?}");
        }
    }
}

#[test]
fn report_figures_follow_the_angles() {
    let ind = solve(&check_positions()).unwrap();
    let r = report(
        &ind,
        &Options {
            nominal_radius_mm: Some(116.99),
            tolerance_arcsec: Some(2.5),
            source: "centres.csv".into(),
        },
    )
    .unwrap();
    let d_a: Vec<f64> = ind.angles.iter().map(|p| p.d_a_arcsec).collect();
    let d_b: Vec<f64> = ind.angles.iter().filter_map(|p| p.d_b_arcsec).collect();
    let max = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    assert_eq!(r.max_d_a_arcsec, max(&d_a));
    assert_eq!(r.max_d_b_arcsec, max(&d_b));
    assert!((r.rms_d_a_arcsec - rms(&d_a)).abs() < 1e-12);
    assert!((r.rms_d_b_arcsec - rms(&d_b)).abs() < 1e-12);
    assert!((r.radius_deviation_um.unwrap() - (ind.radius_mm - 116.99) * 1e3).abs() < 1e-9);
    let t = r.tolerance.as_ref().unwrap();
    // Beyond by more than U = 2u (ISO 14253-1), and undecided within U.
    let beyond = |d: f64, u: f64| d.abs() - 2.0 * u > 2.5;
    let undecided = |d: f64, u: f64| !beyond(d, u) && d.abs() + 2.0 * u > 2.5;
    let listed = ind
        .angles
        .iter()
        .filter(|p| {
            beyond(p.d_a_arcsec, p.u_d_a_arcsec)
                || p.d_b_arcsec
                    .zip(p.u_d_b_arcsec)
                    .is_some_and(|(d, u)| beyond(d, u))
        })
        .count();
    assert_eq!(t.exceeding.len(), listed);
    assert!(listed > 0);
    let count = |f: &dyn Fn(f64, f64) -> bool, b: bool| {
        ind.angles
            .iter()
            .filter(|p| match b {
                false => f(p.d_a_arcsec, p.u_d_a_arcsec),
                true => p
                    .d_b_arcsec
                    .zip(p.u_d_b_arcsec)
                    .is_some_and(|(d, u)| f(d, u)),
            })
            .count()
    };
    assert_eq!(t.count_d_a, count(&beyond, false));
    assert_eq!(t.count_d_b, count(&beyond, true));
    assert_eq!(t.inconclusive_d_a, count(&undecided, false));
    assert_eq!(t.inconclusive_d_b, count(&undecided, true));
    // Noise alone is not counted: at most as many as by the value alone.
    let by_value = ind
        .angles
        .iter()
        .filter(|p| p.d_a_arcsec.abs() > 2.5)
        .count();
    assert!(t.count_d_a <= by_value);
    assert_eq!(r.a_detents.len(), 15);
    assert_eq!(r.b_detents.len(), 48);
    // The JSON keys of the contract.
    let json = serde_json::to_value(&r).unwrap();
    for key in [
        "rotation_centre",
        "radius_mm",
        "max_dA_arcsec",
        "max_dB_arcsec",
        "rms_dA_arcsec",
        "rms_dB_arcsec",
    ] {
        assert!(json.get(key).is_some(), "{key} missing");
    }
    assert!(json.get("angles").is_none());
}

#[test]
fn per_detent_means_recover_the_injected_detent_errors() {
    // Each A detent's mean over its 48 B positions, and each B detent's
    // weighted mean over A, average the noise down; the frame's own
    // uncertainty does not average, so allow 4 × (u/√n + u_frame).
    let (positions, truth) = positions_of(&IndexingConfig::default());
    let ind = solve(&positions).unwrap();
    let r = report(&ind, &Options::default()).unwrap();
    for d in r.a_detents.iter().filter(|d| d.a_deg > 0.0) {
        let t = truth.truth.iter().find(|t| t.0 == d.a_deg).unwrap().2;
        assert!(
            (d.mean_d_a_arcsec - t).abs() < 4.0 * (0.55 / 48f64.sqrt() + 0.15),
            "A = {}: {} vs {t}",
            d.a_deg,
            d.mean_d_a_arcsec
        );
    }
    for d in &r.b_detents {
        let t = truth
            .truth
            .iter()
            .find(|t| (t.1 - d.b_deg).rem_euclid(360.0) == 0.0 && t.0 > 0.0)
            .and_then(|t| t.3)
            .unwrap();
        assert!(
            (d.mean_d_b_arcsec - t).abs() < 4.0 * (d.u_mean_d_b_arcsec + 0.15),
            "B = {}: {} vs {t}",
            d.b_deg,
            d.mean_d_b_arcsec
        );
    }
}

fn grid(a: &[f64], b_step: f64) -> Vec<Position> {
    let n = (360.0 / b_step).round() as usize;
    a.iter()
        .flat_map(|&a| {
            (0..n).map(move |k| {
                let b = -180.0 + b_step * k as f64;
                let (ar, br) = (a.to_radians(), b.to_radians());
                Position {
                    a_deg: a,
                    b_deg: b,
                    centre: Point3::new(ar.sin() * br.cos(), ar.sin() * br.sin(), ar.cos()) * 100.0,
                }
            })
        })
        .collect()
}

fn input_error(positions: &[Position]) -> (String, String) {
    match solve(positions) {
        Err(ProbeError::Layout(fault)) => fault.located(),
        other => panic!("expected an input error, got {other:?}"),
    }
}

#[test]
fn bad_input_is_named() {
    let good = grid(&[0.0, 30.0, 60.0], 45.0);
    assert!(solve(&good).is_ok());

    let mut nan = good.clone();
    nan[9].centre.y = f64::NAN;
    assert_eq!(input_error(&nan).0, "row 10, column 'y'");

    let mut dup = good.clone();
    dup.push(Position {
        b_deg: 180.0,
        ..good[8]
    });
    let (what, message) = input_error(&dup);
    assert_eq!(what, "row 25, column 'b_deg'");
    assert!(
        message.contains("row 9") && message.contains("twice"),
        "{message}"
    );

    let no_turn: Vec<Position> = good.iter().copied().filter(|p| p.a_deg > 0.0).collect();
    assert!(input_error(&no_turn).1.contains("no position at A = 0°"));

    let mut uneven = good.clone();
    uneven[2].b_deg = -80.0;
    let (what, message) = input_error(&uneven);
    assert_eq!(what, "row 3, column 'b_deg'");
    assert!(message.contains("full B turn at even steps"), "{message}");

    let no_sweep: Vec<Position> = good
        .iter()
        .copied()
        .filter(|p| p.a_deg == 0.0 || p.b_deg != 0.0)
        .collect();
    assert!(input_error(&no_sweep).1.contains("B = 0° sweep"));

    let (_, message) = input_error(&good[..4]);
    assert!(
        message.contains("4 positions") && message.contains("at least 5"),
        "{message}"
    );

    let mut negative = good.clone();
    negative[12].a_deg = -30.0;
    assert_eq!(input_error(&negative).0, "row 13, column 'a_deg'");

    // All on one great circle (B = 0° and 180° sweeps only): no sphere.
    let flat: Vec<Position> = good
        .iter()
        .copied()
        .filter(|p| p.a_deg == 0.0 || p.b_deg == 0.0 || p.b_deg == -180.0)
        .collect();
    let e = solve(&flat).unwrap_err();
    assert!(
        matches!(e, ProbeError::IllConditioned { .. } | ProbeError::Geom(_)),
        "{e}"
    );
}

#[test]
fn bad_options_are_named() {
    let ind = solve(&grid(&[0.0, 30.0, 60.0], 45.0)).unwrap();
    for options in [
        Options {
            tolerance_arcsec: Some(-1.0),
            ..Default::default()
        },
        Options {
            nominal_radius_mm: Some(f64::NAN),
            ..Default::default()
        },
    ] {
        assert!(matches!(
            report(&ind, &options),
            Err(ProbeError::NotPositive { .. })
        ));
    }
}
