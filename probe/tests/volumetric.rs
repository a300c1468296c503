//! The volumetric model against independent truth: the check vector of
//! docs/probe-volumetric.md (`testdata/probe/volumetric/`, copied from the shared check
//! data: fit figures, volumetric errors of the three models, the predicted
//! circle and its figures), the exact chain against §5's first-order formula
//! (the difference is of second order), the generator's known machine for
//! two chains against an independent homogeneous-matrix implementation, and
//! analytic cases (a curve inside the series, compensation that leaves
//! nothing).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod volumetric_common;

use volumetric_common::{generator_setup, true_machine};

use std::path::{Path, PathBuf};

use formats::Axis;
use formats::probe::volumetric::read_errors;
use geom::Vector3;
use probe::volumetric::{
    AxisCurves, Chain, CircleSpec, ErrorModel, Evaluation, Machine, MeasuredAxis, Model, Motion,
    Order, Series, Setup, Squareness, analyse, measured_axes, predict_circle,
};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/probe/volumetric")
        .join(name)
}

fn rows(name: &str) -> Vec<csv::StringRecord> {
    csv::Reader::from_path(data(name))
        .unwrap()
        .records()
        .map(|r| r.unwrap())
        .collect()
}

fn num(r: &csv::StringRecord, k: usize) -> f64 {
    r[k].parse().unwrap()
}

fn check_curves() -> Vec<MeasuredAxis> {
    let rows: Vec<_> = read_errors(&data("errors.csv"))
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    measured_axes(&rows)
}

fn check_setup() -> (Chain, Squareness, Vector3<f64>, CircleSpec) {
    let s: formats::probe::volumetric::SetupJson = formats::read_json(&data("setup.json")).unwrap();
    (
        Chain::parse(&s.chain).unwrap(),
        s.squareness_rad,
        Vector3::from(s.tool_mm),
        CircleSpec {
            centre: s.circle.centre_mm,
            radius: s.circle.radius_mm,
        },
    )
}

fn model_of(curves: Vec<MeasuredAxis>, order: Order) -> ErrorModel {
    let checked = curves
        .into_iter()
        .map(|c| AxisCurves::new(c).unwrap())
        .collect();
    ErrorModel::new(checked, order).unwrap()
}

#[test]
fn check_vector_fits_volumetric_errors_and_circle() {
    let model = model_of(check_curves(), Order::Fixed(3));
    // Fit figures: 1e-9 relative (the expected file has 12 significant digits).
    let mut worst = 0.0f64;
    for r in rows("expected_fits.csv") {
        let axis = formats::probe::volumetric::axis_named(&r[0]).unwrap();
        let m = Motion::from_name(&r[1]).unwrap();
        let s = if &r[2] == "fourier" {
            Series::Fourier
        } else {
            Series::Polynomial
        };
        let f = model.axis(axis).unwrap().fits[m.index()].get(s).figures;
        for (k, got) in [(3, f.r2.unwrap()), (4, f.sse), (5, f.rmse), (6, f.emax)] {
            worst = worst.max(((got - num(&r, k)) / num(&r, k)).abs());
        }
    }
    println!("fit figures: worst relative difference {worst:.1e}");
    assert!(worst < 1e-9);

    let (chain, squareness, tool, spec) = check_setup();
    let machine = Machine::new(&chain, squareness, tool, &model).unwrap();
    // Volumetric errors of the three models: 1e-6 µm.
    let mut worst = 0.0f64;
    let expected = rows("expected_volumetric.csv");
    assert_eq!(expected.len(), 36);
    for r in expected {
        let how = match &r[0] {
            "raw" => Model::Raw,
            "fourier" => Model::Fourier,
            _ => Model::Polynomial,
        };
        let q = [num(&r, 1), num(&r, 2), num(&r, 3)];
        let d = machine
            .volumetric_error(&q, Evaluation::Model(how))
            .unwrap();
        for k in 0..3 {
            worst = worst.max((d[k] - num(&r, 4 + k)).abs() * 1e3);
        }
    }
    println!("volumetric errors: worst difference {worst:.1e} µm");
    assert!(worst < 1e-6);

    // The circle per degree and its figures: 1e-6 µm.
    let c = predict_circle(&machine, &spec, Evaluation::Model(Model::Raw)).unwrap();
    let expected = rows("expected_circle.csv");
    assert_eq!(expected.len(), c.points.len());
    let mut worst = 0.0f64;
    for (r, p) in expected.iter().zip(&c.points) {
        assert_eq!(p.angle_deg, num(r, 0));
        for k in 0..3 {
            worst = worst.max((p.delta[k] - num(r, 1 + k)).abs() * 1e3);
        }
        worst = worst.max((p.radial - num(r, 4)).abs() * 1e3);
    }
    println!("circle: worst difference {worst:.1e} µm");
    assert!(worst < 1e-6);
    let figures: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(data("expected_circle_figures.json")).unwrap(),
    )
    .unwrap();
    for (name, how) in [("raw", Model::Raw), ("fourier", Model::Fourier)] {
        let c = predict_circle(&machine, &spec, Evaluation::Model(how)).unwrap();
        let f = &figures[name];
        let range = f["radial_range_um"].as_f64().unwrap();
        let dev = f["circular_deviation_um"].as_f64().unwrap();
        println!(
            "{name}: radial range {:.9} µm (expected {range:.9}), circular deviation {:.9} µm (expected {dev:.9})",
            c.radial_range * 1e3,
            c.circular_deviation * 1e3
        );
        assert!((c.radial_range * 1e3 - range).abs() < 1e-6);
        assert!((c.circular_deviation * 1e3 - dev).abs() < 1e-6);
    }
}

/// §5's first-order volumetric error of the default chain `WXYFZT`, with
/// p = z·e_z + t:
/// Δ = z(a_Z − e_z) − y(a_Y − e_y) + δ_Z + ε_Z × t − δ_Y − ε_Y × (p − y·e_y)
///     − δ_X − ε_X × (p − y·e_y − x·e_x).
fn first_order(model: &ErrorModel, sq: &Squareness, t: Vector3<f64>, q: [f64; 3]) -> Vector3<f64> {
    let how = Evaluation::Model(Model::Raw);
    let e = |a: Axis, v: f64| model.axis(a).unwrap().motions(v, how).unwrap();
    let ((dx, ex), (dy, ey), (dz, ez)) = (e(Axis::X, q[0]), e(Axis::Y, q[1]), e(Axis::Z, q[2]));
    let (x, y, z) = (q[0], q[1], q[2]);
    let a_y = Vector3::new(-sq.ec0y.sin(), sq.ec0y.cos(), 0.0);
    let a_z = Vector3::new(
        sq.eb0z.sin() * sq.ea0z.cos(),
        -sq.ea0z.sin(),
        sq.eb0z.cos() * sq.ea0z.cos(),
    );
    let p = Vector3::z() * z + t;
    (a_z - Vector3::z()) * z - (a_y - Vector3::y()) * y + dz + ez.cross(&t)
        - dy
        - ey.cross(&(p - Vector3::y() * y))
        - dx
        - ex.cross(&(p - Vector3::y() * y - Vector3::x() * x))
}

#[test]
fn exact_chain_agrees_with_the_first_order_formula_to_second_order() {
    let (chain, sq, tool, _) = check_setup();
    let at: Vec<[f64; 3]> = rows("at.csv")
        .iter()
        .map(|r| [num(r, 0), num(r, 1), num(r, 2)])
        .collect();
    // Scale every error (curves and squareness) by s: the first-order terms
    // scale by s, the difference exact − first order by s².
    let mut previous: Option<f64> = None;
    for k in 0..4 {
        let s = 0.5f64.powi(k) * 50.0;
        let curves: Vec<MeasuredAxis> = check_curves()
            .into_iter()
            .map(|mut c| {
                for v in &mut c.values {
                    v.iter_mut().for_each(|x| *x *= s);
                }
                c
            })
            .collect();
        let model = model_of(curves, Order::Fixed(3));
        let scaled = Squareness {
            ec0y: sq.ec0y * s,
            eb0z: sq.eb0z * s,
            ea0z: sq.ea0z * s,
        };
        let machine = Machine::new(&chain, scaled, tool, &model).unwrap();
        let (mut diff, mut size) = (0.0f64, 0.0f64);
        for q in &at {
            let exact = machine
                .volumetric_error(q, Evaluation::Model(Model::Raw))
                .unwrap();
            let linear = first_order(&model, &scaled, tool, *q);
            diff = diff.max((exact - linear).norm());
            size = size.max(exact.norm());
        }
        println!(
            "errors ×{s}: largest |Δ| {:.3} µm, exact − first order {:.3e} µm",
            size * 1e3,
            diff * 1e3
        );
        assert!(diff < 1e-2 * size, "not first order: {diff} of {size}");
        if let Some(p) = previous {
            // Halving the errors quarters the difference (second order).
            let ratio = p / diff;
            assert!((ratio - 4.0).abs() < 0.2, "ratio {ratio}");
        }
        previous = Some(diff);
    }
}

#[test]
fn generator_round_trip_for_two_chains() {
    for chain in ["WXYFZT", "WYFXZT"] {
        let config = synth::probe::volumetric::VolumetricConfig {
            chain: chain.into(),
            ..Default::default()
        };
        let d = synth::probe::volumetric::generate(&config).unwrap();
        let truth = true_machine(&config, &d, None);
        let s = &d.setup;
        let setup = generator_setup(&d);
        let a = analyse(measured_axes(&d.errors), &setup, None).unwrap();

        // The removed straightness lines are the truth's, to the noise: the
        // slope of a least-squares line through values with noise σ has the
        // standard deviation σ/√Σ(q − q̄)² (0.055 µrad for X); allow 4 of them.
        for (axis, t) in a.model.axes.iter().zip(&d.truth.axes) {
            let q = &axis.curves.positions;
            let mean = q.iter().sum::<f64>() / q.len() as f64;
            let sxx: f64 = q.iter().map(|v| (v - mean).powi(2)).sum();
            let tolerance = 4.0 * config.noise_um * 1e-3 / sxx.sqrt();
            for r in &axis.curves.removed {
                let want = t.straightness_slopes[r.error.name()];
                assert!(
                    (r.slope - want).abs() < tolerance,
                    "{chain} {:?} {:?}: {} vs {want}",
                    axis.axis(),
                    r.error,
                    r.slope
                );
            }
        }
        // Volumetric errors against the independent implementation. Noise:
        // 0.05 µm on each translation, 0.05 µrad on each rotation; a component
        // sums three translations and six rotations × levers below 0.8 m:
        // σ ≈ √(3·0.05² + 6·0.04²) ≈ 0.13 µm; 0.5 µm is ≈ 4σ.
        let mut worst = 0.0f64;
        for (q, got) in &a.volumetric {
            worst = worst.max((got - truth.error(*q)).norm() * 1e3);
        }
        let size = a
            .volumetric
            .iter()
            .map(|(_, d)| d.norm())
            .fold(0.0, f64::max)
            * 1e3;
        println!("{chain}: volumetric errors up to {size:.2} µm, worst difference {worst:.3} µm");
        assert!(size > 5.0 && worst < 0.5, "{worst}");
        // The circle and its circular deviation.
        let c = a.circles.as_ref().unwrap();
        let (radial, deviation) = truth.circle(s.circle.centre_mm, s.circle.radius_mm);
        let worst = c
            .predicted
            .points
            .iter()
            .zip(&radial)
            .map(|(p, r)| (p.radial - r).abs())
            .fold(0.0, f64::max)
            * 1e3;
        println!(
            "{chain}: circular deviation {:.3} µm (truth {:.3} µm), radial worst difference {worst:.3} µm; \
             after Fourier compensation {:.3} µm, polynomial {:.3} µm",
            c.predicted.circular_deviation * 1e3,
            deviation * 1e3,
            c.compensated_fourier.circular_deviation * 1e3,
            c.compensated_polynomial.circular_deviation * 1e3
        );
        assert!(worst < 0.5);
        assert!((c.predicted.circular_deviation - deviation).abs() * 1e3 < 0.5);
    }
}

#[test]
fn compensation_with_a_series_that_fits_exactly_leaves_nothing() {
    // Positioning, roll, pitch and yaw of every axis a Fourier series of
    // order 2 over its travel, straightness zero: the Fourier fit of order 3
    // reproduces every curve, so compensating with it (curves and
    // squareness) leaves no error, while the raw machine has micrometres.
    let curves: Vec<MeasuredAxis> = [(Axis::X, 600.0), (Axis::Y, 400.0), (Axis::Z, 300.0)]
        .into_iter()
        .enumerate()
        .map(|(i, (axis, l))| {
            let rows: Vec<[f64; 7]> = (0..=24)
                .map(|k| {
                    let q = l * f64::from(k) / 24.0;
                    let w = std::f64::consts::TAU / l;
                    let mut r = [q, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
                    for m in Motion::ALL.into_iter().filter(|m| !m.is_straightness(axis)) {
                        let a = if m.is_rotation() { 5e-6 } else { 2e-3 };
                        let ph = (i * 6 + m.index()) as f64;
                        r[m.index() + 1] =
                            a * ((w * q + ph).sin() + 0.5 * (2.0 * w * q + 0.3 * ph).cos());
                    }
                    r
                })
                .collect();
            MeasuredAxis::from_rows(axis, &rows)
        })
        .collect();
    let setup = Setup {
        chain: Chain::parse("WXYFZT").unwrap(),
        squareness: Squareness {
            ec0y: 2e-5,
            eb0z: -1e-5,
            ea0z: 1e-5,
        },
        tool: [0.0, 0.0, -100.0],
        model: Model::Raw,
        order: Order::Fixed(3),
        at: vec![],
        circle: Some(CircleSpec {
            centre: [-300.0, -200.0, 50.0],
            radius: 100.0,
        }),
        source: "analytic".into(),
        readings_u: None,
    };
    let a = analyse(curves, &setup, None).unwrap();
    // At the measured positions the raw curves are the measured values,
    // which the series holds exactly: nothing is left but rounding (the
    // curves are ~1e-3 mm, the fit exact to ~1e-16 relative).
    let chain = Chain::parse("WXYFZT").unwrap();
    let machine = Machine::new(
        &chain,
        setup.squareness,
        Vector3::from(setup.tool),
        &a.model,
    )
    .unwrap();
    let mut left = 0.0f64;
    for k in 0..=24 {
        let q = [
            25.0 * f64::from(k),
            400.0 * f64::from(24 - k) / 24.0,
            12.5 * f64::from(k),
        ];
        let e = machine
            .volumetric_error(&q, Evaluation::Residual(Series::Fourier))
            .unwrap();
        left = left.max(e.norm());
    }
    // Between them the raw curves are linear, the waves are not: the circle
    // keeps the interpolation error, (h²/8)·|e''| ≈ 0.1 µm for these waves.
    let c = a.circles.unwrap();
    println!(
        "raw circular deviation {:.3} µm; after Fourier compensation {:.3} µm, polynomial {:.3} µm; \
         left at the measured positions {left:.1e} mm",
        c.predicted.circular_deviation * 1e3,
        c.compensated_fourier.circular_deviation * 1e3,
        c.compensated_polynomial.circular_deviation * 1e3
    );
    assert!(left < 1e-12);
    assert!(c.predicted.circular_deviation * 1e3 > 1.0);
    assert!(c.compensated_fourier.circular_deviation < 0.1 * c.predicted.circular_deviation);
    assert!(c.compensated_fourier.circular_deviation < c.compensated_polynomial.circular_deviation);
}

#[test]
fn positions_outside_the_travel_are_errors() {
    let (chain, sq, tool, _) = check_setup();
    let model = model_of(check_curves(), Order::Fixed(3));
    let machine = Machine::new(&chain, sq, tool, &model).unwrap();
    let e = machine
        .volumetric_error(&[600.5, 10.0, 10.0], Evaluation::Model(Model::Fourier))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("axis X at 600.5 mm") && e.contains("does not extrapolate"),
        "{e}"
    );
    let spec = CircleSpec {
        centre: [-300.0, -350.0, 40.0],
        radius: 100.0,
    };
    let e = predict_circle(&machine, &spec, Evaluation::Model(Model::Raw))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("--circle") && e.contains("axis Y would run from 250 to 450 mm"),
        "{e}"
    );
}

#[test]
fn order_auto_chooses_per_curve_and_reports_the_scores() {
    let d = synth::probe::volumetric::generate(&Default::default()).unwrap();
    let model = model_of(measured_axes(&d.errors), Order::Auto);
    for axis in &model.axes {
        for f in &axis.fits {
            let [fs, ps] = f.scores.as_ref().unwrap();
            for (fit, scores) in [(&f.fourier, fs), (&f.polynomial, ps)] {
                let best = scores
                    .iter()
                    .min_by(|a, b| a.loo_rmse.total_cmp(&b.loo_rmse))
                    .unwrap();
                assert_eq!(fit.order, best.order);
                // 21 points or more: orders 1 to 4 at 2 points per coefficient.
                assert!(scores.len() >= 4);
            }
        }
    }
}

/// Fits that explain little of their curve are flagged (R² < 0.8) with
/// the order leave-one-out chooses: a wave of five periods that order 3
/// cannot follow (auto chooses 5 and fits it), a curve of noise alone
/// (no order explains it: said to be noise); the smooth curves are not.
#[test]
fn poor_fits_are_flagged_with_the_order_cross_validation_chooses() {
    let l = 600.0;
    let w = std::f64::consts::TAU / l;
    // A deterministic stand-in for noise: the fractional part of a fast
    // irrational sequence, centred (independent of any series' basis).
    let noise = |k: usize| ((k as f64 * 0.754_877_666_2).fract() - 0.5) * 2e-3;
    let curves: Vec<MeasuredAxis> = [(Axis::X, l), (Axis::Y, 400.0), (Axis::Z, 300.0)]
        .into_iter()
        .map(|(axis, len)| {
            let rows: Vec<[f64; 7]> = (0..=40)
                .map(|k| {
                    let q = len * k as f64 / 40.0;
                    let mut r = [q, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
                    // Straightness zero: its removed line would leave a
                    // curve no series of the travel's period follows.
                    for m in Motion::ALL.into_iter().filter(|m| !m.is_straightness(axis)) {
                        let a = if m.is_rotation() { 5e-6 } else { 2e-3 };
                        r[m.index() + 1] = a * (w * q * l / len).sin();
                    }
                    if axis == Axis::X {
                        r[Motion::ALL[0].index() + 1] = 2e-3 * (5.0 * w * q).sin();
                        r[Motion::ALL[1].index() + 1] = noise(k);
                    }
                    r
                })
                .collect();
            MeasuredAxis::from_rows(axis, &rows)
        })
        .collect();
    let setup = |order| Setup {
        chain: Chain::parse("WXYFZT").unwrap(),
        squareness: Squareness {
            ec0y: 0.0,
            eb0z: 0.0,
            ea0z: 0.0,
        },
        tool: [0.0, 0.0, -100.0],
        model: Model::Fourier,
        order,
        at: vec![],
        circle: None,
        source: "analytic".into(),
        readings_u: None,
    };
    let fixed = analyse(curves.clone(), &setup(Order::Fixed(3)), None).unwrap();
    let w = &fixed.report.warnings;
    println!("{w:#?}");
    let [wave, noisy] = [0, 1].map(|i| Motion::ALL[i].symbol(Axis::X));
    assert_eq!([wave.as_str(), noisy.as_str()], ["EXX", "EYX"]);
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(
        w[0].starts_with(&wave) && w[0].contains("chooses N = 5 for it, R² 1.000"),
        "{}",
        w[0]
    );
    assert!(
        w[1].starts_with(&noisy) && w[1].contains("not significant"),
        "{}",
        w[1]
    );
    // Chosen by cross-validation, the wave is fitted; the noise stays flagged.
    let auto = analyse(curves, &setup(Order::Auto), None).unwrap();
    let w = &auto.report.warnings;
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with(&noisy) && w[0].contains("not significant"),
        "{}",
        w[0]
    );
}
