//! The rotary method against independent truth: the check data's expected
//! per-angle least squares (to its rounding) and its true errors (within
//! the noise, from centres and from probed points), and round trips through
//! the generator for several seeds, layouts and steps — including a pure
//! axis offset and a pure tilt recovered as location errors — with the
//! noise each estimate should have computed from the layout, not from the
//! method's own output. Degenerate layouts are refused.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;

use formats::probe::rotary::{RotaryTruth, read_centres, read_points};
use geom::nalgebra::{DMatrix, Point3, Rotation3, Vector3};
use geom::transform::SmallError;
use probe::ProbeError;
use probe::rotary::{Measurement, Solution, solve};
use synth::probe::rotary::{BallConfig, LocationConfig, RotaryConfig, RotaryData, generate};

fn testdata(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/probe/rotary")
        .join(name)
}

fn from_centres_file() -> Measurement {
    let input = read_centres(&testdata("centres.csv")).unwrap();
    Measurement::from_centres(input.angles_deg.clone(), input.centres())
}

fn from_points_file() -> Measurement {
    let input = read_points(&testdata("points.csv")).unwrap();
    Measurement::from_points(input.angles_deg.clone(), input.points()).unwrap()
}

fn truth() -> RotaryTruth {
    serde_json::from_str(&std::fs::read_to_string(testdata("truth.json")).unwrap()).unwrap()
}

/// Standard deviation of each of the six estimates at `angle_deg` for
/// centres with independent noise `sigma` (mm) per coordinate, from the
/// layout alone: `b = P(θ) − Rz·P0` carries the noise of two centres
/// (variance 2σ²), so `cov = 2σ²·(AᵀA)⁻¹` with A the §2 design.
fn expected_sd(reference: &[Point3<f64>], angle_deg: f64, sigma: f64) -> [f64; 6] {
    let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), angle_deg.to_radians());
    let mut a = DMatrix::zeros(3 * reference.len(), 6);
    for (i, p) in reference.iter().enumerate() {
        for (k, row) in SmallError::design_rows(&(rz * p)).iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                a[(3 * i + k, j)] = *v;
            }
        }
    }
    let inv = (a.transpose() * a).try_inverse().unwrap();
    std::array::from_fn(|k| (2.0 * sigma * sigma * inv[(k, k)]).sqrt())
}

/// Every estimate within `k` expected standard deviations of the truth.
/// With 6 × (angles − 1) estimates and k = 4.5, a correct method fails by
/// chance with probability below 0.05 %.
fn within_noise(s: &Solution, truth: &[[f64; 6]], sigma: f64, k: f64, what: &str) {
    assert_eq!(s.errors.len(), truth.len(), "{what}: angles");
    let mut worst: f64 = 0.0;
    for (e, t) in s.errors.iter().zip(truth) {
        let sd = expected_sd(&s.reference, e.angle_deg, sigma);
        for j in 0..6 {
            if e.angle_deg == 0.0 {
                assert_eq!(e.errors[j], 0.0, "{what}: the reference angle");
                continue;
            }
            let z = (e.errors[j] - t[j]).abs() / sd[j];
            worst = worst.max(z);
            assert!(
                z < k,
                "{what}: {} at {}°: {} vs true {} ({z:.1} sd of {:e})",
                probe::rotary::NAMES[j],
                e.angle_deg,
                e.errors[j],
                t[j],
                sd[j]
            );
        }
    }
    eprintln!("{what}: worst {worst:.2} expected sd");
}

#[test]
fn expected_rotary_is_reproduced_to_its_rounding() {
    let s = solve(&from_centres_file()).unwrap();
    let text = std::fs::read_to_string(testdata("expected_rotary.csv")).unwrap();
    let mut rows = 0;
    for (line, e) in text.lines().skip(1).zip(&s.errors) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(v[0], e.angle_deg);
        for j in 0..6 {
            // 12 significant digits in the file (≤ 5e-13 relative), and
            // another solver's rounding: ~1e-12 of the problem's largest
            // entries (|b| ≈ 0.03 mm), i.e. ~1e-14 mm in δ and, over the
            // 150 mm lever, ~1e-16 rad in ε.
            let tol = 5e-12 * v[1 + j].abs() + if j < 3 { 2e-14 } else { 2e-16 };
            assert!(
                (e.errors[j] - v[1 + j]).abs() <= tol,
                "{}° {}: {} vs {}",
                e.angle_deg,
                probe::rotary::NAMES[j],
                e.errors[j],
                v[1 + j]
            );
        }
        rows += 1;
    }
    assert_eq!(rows, 12);
}

#[test]
fn check_data_truth_within_the_noise_from_centres() {
    let s = solve(&from_centres_file()).unwrap();
    // README: centres with 0.3 µm noise.
    within_noise(&s, &truth().truth_mm_rad, 0.3e-3, 4.5, "centres");
    assert!(s.layout.condition < 2.0);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn check_data_truth_within_the_noise_from_probed_points() {
    let m = from_points_file();
    // Five points per sphere: the fitted centre is about as noisy as one
    // point (σ ≈ 0.3 µm per coordinate, 0.3/√2 in x and y from the two
    // equator points, the pole and the equator sharing z and the radius).
    let s = solve(&m).unwrap();
    within_noise(&s, &truth().truth_mm_rad, 0.3e-3, 4.5, "points");
    assert_eq!(s.fits.len(), 3);
    for f in s.fits.iter().flatten() {
        assert_eq!(f.points, 5);
        assert!((f.radius - 12.7).abs() < 2e-3, "radius {}", f.radius);
        assert!(f.max_residual < 2e-3);
    }
    // The same errors as from the centres, within the two noises.
    let c = solve(&from_centres_file()).unwrap();
    within_noise(
        &s,
        &c.errors
            .iter()
            .map(|e| std::array::from_fn(|j| e.errors[j]))
            .collect::<Vec<_>>(),
        0.3e-3 * 2f64.sqrt(),
        4.5,
        "points against centres",
    );
}

/// The location errors by their definition — the mean of EXC, EYC, EAC,
/// EBC over a full turn in equal steps — from true errors.
fn mean_location(errors: &[[f64; 6]]) -> [f64; 4] {
    let n = errors.len() as f64;
    let mean = |j: usize| errors.iter().map(|e| e[j]).sum::<f64>() / n;
    [mean(0), mean(1), mean(3), mean(4)]
}

fn location(s: &Solution) -> [f64; 4] {
    let l = s.axis.as_ref().expect("location").location;
    [l.x0c_mm, l.y0c_mm, l.a0c_rad, l.b0c_rad]
}

#[test]
fn check_data_location_within_the_noise() {
    let truth = mean_location(&truth().truth_mm_rad);
    for s in [
        solve(&from_centres_file()).unwrap(),
        solve(&from_points_file()).unwrap(),
    ] {
        let got = location(&s);
        // The mean of 12 angles: ≈ 0.3 µm/√12·√2 ≈ 0.12 µm and ≈ 1 µrad;
        // 0.5 µm and 4 µrad are about 4 of those.
        for (k, (name, tol)) in [
            ("X0C", 0.5e-3),
            ("Y0C", 0.5e-3),
            ("A0C", 4e-6),
            ("B0C", 4e-6),
        ]
        .into_iter()
        .enumerate()
        {
            assert!(
                (got[k] - truth[k]).abs() < tol,
                "{name} {} vs {}",
                got[k],
                truth[k]
            );
        }
        let u = s.axis.as_ref().unwrap().location.uncertainty;
        assert!(u[0] > 0.05e-3 && u[0] < 0.3e-3, "u(X0C) {}", u[0]);
        assert!(u[2] > 0.3e-6 && u[2] < 3e-6, "u(A0C) {}", u[2]);
    }
}

/// Balls of a generator configuration from names and positions (mm).
fn balls(list: &[(&str, [f64; 3])]) -> Vec<BallConfig> {
    list.iter()
        .map(|(name, position)| BallConfig {
            name: (*name).into(),
            position: *position,
        })
        .collect()
}

/// The generated centres as the method's input.
fn measurement_of(config: &RotaryConfig, data: &RotaryData) -> Measurement {
    let centres = config
        .balls
        .iter()
        .map(|b| {
            let c = data
                .centres
                .iter()
                .filter(|r| r.ball == b.name)
                .map(|r| [r.x, r.y, r.z])
                .collect();
            (b.name.clone(), c)
        })
        .collect();
    Measurement::from_centres(data.truth.angles_deg.clone(), centres)
}

/// What the first-order model of §2 leaves out at these errors (mm).
const MODEL_FLOOR_MM: f64 = 1e-6;

/// Generate, solve, compare with the generator's truth: errors per angle,
/// location and component errors.
fn round_trip(config: &RotaryConfig, what: &str) -> Solution {
    let data = generate(config).unwrap();
    let m = measurement_of(config, &data);
    let s = solve(&m).unwrap();
    // Without noise the floor is the first-order model's neglected
    // ½|ε|²·|P| ≈ ½·(1e-4)²·170 mm ≈ 1e-6 mm.
    let sigma = (config.noise_um * 1e-3).max(MODEL_FLOOR_MM);
    within_noise(&s, &data.truth.truth_mm_rad, sigma, 4.5, what);
    let truth = data.truth.location.unwrap();
    let got = location(&s);
    let u = s.axis.as_ref().unwrap().location.uncertainty;
    // u propagates the per-angle variance 2σ² as if angles were
    // independent; the reference centres' share (half) cancels in the
    // mean over a turn, so u overstates the noise: 4·u is a safe bound.
    let want = [
        truth.x0c_um * 1e-3,
        truth.y0c_um * 1e-3,
        truth.a0c_urad * 1e-6,
        truth.b0c_urad * 1e-6,
    ];
    for k in 0..4 {
        assert!(
            (got[k] - want[k]).abs() <= 4.0 * u[k] + 1e-9,
            "{what}: location {k}: {} vs {} (u {})",
            got[k],
            want[k],
            u[k]
        );
    }
    // A component is an error less the fixed-axis part of the location:
    // within the error's noise plus |(I − Rz)·Δlocation| ≤ 2·|Δlocation|
    // (x–y pairs only; EZC and ECC carry no location part).
    let comps = data.truth.components_mm_rad.unwrap();
    let axis = s.axis.as_ref().unwrap();
    let pair = [2.0 * 4.0 * u[0].hypot(u[1]), 2.0 * 4.0 * u[2].hypot(u[3])];
    for ((c, t), e) in axis.components.iter().zip(&comps).zip(&s.errors) {
        let sd = expected_sd(&s.reference, e.angle_deg, sigma);
        for j in 0..6 {
            let location_part = match j {
                0 | 1 => pair[0],
                3 | 4 => pair[1],
                _ => 0.0,
            };
            let bound = 4.5 * sd[j] + location_part;
            assert!(
                (c[j] - t[j]).abs() <= bound,
                "{what}: component {} at {}°: {} vs {} (bound {bound:e})",
                probe::rotary::NAMES[j],
                e.angle_deg,
                c[j],
                t[j]
            );
        }
    }
    s
}

#[test]
fn generator_round_trips_for_seeds_layouts_and_steps() {
    let base = RotaryConfig::default();
    for seed in [1, 2, 3] {
        round_trip(
            &RotaryConfig {
                seed,
                ..base.clone()
            },
            &format!("seed {seed}"),
        );
    }
    // Four balls at one height, 20° steps.
    let four = RotaryConfig {
        seed: 11,
        step_deg: 20.0,
        balls: balls(&[
            ("A", [200.0, 0.0, 40.0]),
            ("B", [0.0, 180.0, 40.0]),
            ("C", [-190.0, -20.0, 40.0]),
            ("D", [10.0, -210.0, 40.0]),
        ]),
        ..base.clone()
    };
    round_trip(&four, "four balls, 20° steps");
    // A small table, 45° steps, a larger noise.
    let small = RotaryConfig {
        seed: 5,
        step_deg: 45.0,
        noise_um: 1.0,
        balls: balls(&[
            ("1", [60.0, 5.0, 20.0]),
            ("2", [-35.0, 50.0, 70.0]),
            ("3", [-20.0, -55.0, 45.0]),
        ]),
        ..base.clone()
    };
    round_trip(&small, "small table, 45° steps");
    // 7.5° steps (48 angles), no noise: exact to the second order of the model.
    let fine = RotaryConfig {
        step_deg: 7.5,
        noise_um: 0.0,
        ..base
    };
    let s = round_trip(&fine, "7.5° steps, no noise");
    assert_eq!(s.errors.len(), 48);
}

fn pure(location: LocationConfig, seed: u64) -> RotaryConfig {
    RotaryConfig {
        seed,
        location,
        components: Vec::new(),
        ..RotaryConfig::default()
    }
}

#[test]
fn a_pure_axis_offset_is_all_location() {
    for seed in [21, 22, 23] {
        let c = pure(
            LocationConfig {
                x0c_um: 15.0,
                y0c_um: -6.0,
                a0c_urad: 0.0,
                b0c_urad: 0.0,
            },
            seed,
        );
        let s = round_trip(&c, "pure offset");
        let l = location(&s);
        eprintln!(
            "pure offset, seed {seed}: X0C {:+.3} µm, Y0C {:+.3} µm, A0C {:+.3} µrad, B0C {:+.3} µrad off",
            (l[0] - 15e-3) * 1e3,
            (l[1] + 6e-3) * 1e3,
            l[2] * 1e6,
            l[3] * 1e6
        );
        // The bound at 0.3 µm noise: 0.5 µm and 2 µrad.
        assert!(
            (l[0] - 15e-3).abs() < 0.5e-3 && (l[1] + 6e-3).abs() < 0.5e-3,
            "{l:?}"
        );
        assert!(l[2].abs() < 2e-6 && l[3].abs() < 2e-6, "{l:?}");
        // Nothing else: the component errors are noise.
        let r = s.axis.as_ref().unwrap().component_ranges();
        assert!(r[0] < 2e-3 && r[1] < 2e-3, "component ranges {r:?}");
    }
}

#[test]
fn a_pure_axis_tilt_is_all_location() {
    for seed in [31, 32, 33] {
        let c = pure(
            LocationConfig {
                x0c_um: 0.0,
                y0c_um: 0.0,
                a0c_urad: 30.0,
                b0c_urad: -20.0,
            },
            seed,
        );
        let s = round_trip(&c, "pure tilt");
        let l = location(&s);
        eprintln!(
            "pure tilt, seed {seed}: X0C {:+.3} µm, Y0C {:+.3} µm, A0C {:+.3} µrad, B0C {:+.3} µrad off",
            l[0] * 1e3,
            l[1] * 1e3,
            (l[2] - 30e-6) * 1e6,
            (l[3] + 20e-6) * 1e6
        );
        assert!(l[0].abs() < 0.5e-3 && l[1].abs() < 0.5e-3, "{l:?}");
        assert!(
            (l[2] - 30e-6).abs() < 2e-6 && (l[3] + 20e-6).abs() < 2e-6,
            "{l:?}"
        );
    }
}

#[test]
fn degenerate_layouts_are_refused_with_the_condition_number() {
    let on_a_line = RotaryConfig {
        balls: balls(&[
            ("1", [-150.0, 0.0, 50.0]),
            ("2", [0.0, 0.5, 50.0]),
            ("3", [150.0, 0.0, 50.0]),
        ]),
        ..RotaryConfig::default()
    };
    let on_the_axis = RotaryConfig {
        balls: balls(&[
            ("1", [0.0, 0.0, 20.0]),
            ("2", [0.2, 0.0, 60.0]),
            ("3", [0.0, 0.3, 100.0]),
        ]),
        ..RotaryConfig::default()
    };
    for (config, what) in [
        (on_a_line, "nearly on one line"),
        (on_the_axis, "on the axis"),
    ] {
        let d = generate(&config).unwrap();
        let m = measurement_of(&config, &d);
        match solve(&m) {
            Err(ProbeError::IllConditioned {
                condition, limit, ..
            }) => {
                assert!(condition > limit, "{what}: {condition}");
            }
            other => panic!("{what}: not refused: {other:?}"),
        }
        let text = solve(&m).unwrap_err().to_string();
        assert!(text.contains("condition number"), "{text}");
    }
    // Two balls only.
    let mut m = from_centres_file();
    m.balls.truncate(2);
    let e = solve(&m).unwrap_err().to_string();
    assert!(e.contains("2 ball(s)") && e.contains("at least 3"), "{e}");
}

#[test]
fn interpolation_is_linear_and_wraps_at_360() {
    let s = solve(&from_centres_file()).unwrap();
    let e = |k: usize| s.errors[k].errors;
    assert_eq!(s.at(60.0).unwrap().errors, e(2));
    let mid = s.at(45.0).unwrap().errors;
    assert!((mid - (e(1) + e(2)) / 2.0).amax() < 1e-18);
    let wrap = s.at(345.0).unwrap().errors;
    assert!((wrap - (e(11) + e(0)) / 2.0).amax() < 1e-18);
    assert!((s.at(-15.0).unwrap().errors - wrap).amax() < 1e-18);
    assert!((s.at(720.0 + 45.0).unwrap().errors - mid).amax() < 1e-18);
    let u = s.at(15.0).unwrap().uncertainty;
    assert!((u - s.errors[1].uncertainty / 2.0).amax() < 1e-18);
    assert!(s.at(f64::NAN).is_err());
}

#[test]
fn a_short_arc_has_no_location() {
    let mut m = from_centres_file();
    m.angles_deg.truncate(4);
    for b in &mut m.balls {
        b.centres.truncate(4);
    }
    let s = solve(&m).unwrap();
    assert!(s.axis.is_none());
    assert!(
        s.warnings.iter().any(|w| w.contains("full turn")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn clockwise_angles_are_refused_naming_the_centre() {
    let mut m = from_centres_file();
    // Present the same positions as if the table turned clockwise.
    for b in &mut m.balls {
        b.centres[1..].reverse();
    }
    let e = solve(&m).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("ball 1 at 30°") && text.contains("clockwise"),
        "{text}"
    );
}

#[test]
fn report_json_has_the_contract_keys() {
    let s = solve(&from_points_file()).unwrap();
    let at = [s.at(15.0).unwrap()];
    let r = probe::rotary::report::report(&s, "points.csv", &at);
    let v = serde_json::to_value(&r).unwrap();
    let e = &v["errors"][1];
    for key in [
        "angle_deg",
        "EXC_um",
        "EYC_um",
        "EZC_um",
        "EAC_urad",
        "EBC_urad",
        "ECC_urad",
        "u_EXC_um",
        "u_ECC_urad",
    ] {
        assert!(e.get(key).is_some(), "errors[1].{key} missing: {e}");
    }
    assert!((e["EXC_um"].as_f64().unwrap() - s.errors[1].errors[0] * 1e3).abs() < 1e-12);
    for key in ["X0C_um", "Y0C_um", "A0C_urad", "B0C_urad"] {
        assert!(v["location"][key].is_f64(), "location.{key}");
    }
    assert!(v["condition"].as_f64().unwrap() > 1.0);
    assert_eq!(v["input"], "points");
    assert_eq!(v["sphere_fits"].as_array().unwrap().len(), 36);
    assert_eq!(v["interpolated"][0]["angle_deg"], 15.0);
    assert!(v["ranges"]["components"]["EXC_um"].is_f64());
}
