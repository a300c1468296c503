//! Coverage of the volumetric model's expanded uncertainties
//! (docs/probe-volumetric.md, "Uncertainty"; docs/methods.md §7): campaigns
//! of the generator with different seeds, chains, noise levels, error
//! amplitudes and position steps, each analysed with the generator's noise
//! given as the instrument's standard uncertainty; every figure of the
//! report (straightness slopes and intercepts, volumetric max and RMS, the
//! circle before and after compensation) against its truth — computed by
//! the independent 4×4-matrix implementation on the true curves at the
//! measured positions, linear between them, as the raw model interpolates
//! (the curves between positions were not measured and are not in U). The
//! test runs 100 trials per campaign (the command's default is 200).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod coverage_common;
mod volumetric_common;

use coverage_common::{Case, assert_coverage};
use formats::probe::volumetric::report::FIGURES;
use formats::uncertainty::{Uncertainty, figures};
use geom::montecarlo::Propagation;
use probe::volumetric::{Series, UncertaintyInputs, analyse, measured_axes, uncertainty};
use synth::probe::volumetric::{VolumetricConfig, VolumetricData, generate};
use volumetric_common::{TrueMachine, generator_setup, true_machine};

const CAMPAIGNS: u64 = 40;
const TRIALS: usize = 100;

fn campaign(k: u64) -> VolumetricConfig {
    let i = k as usize;
    VolumetricConfig {
        seed: 40 + k,
        chain: ["WXYFZT", "WYFXZT"][i % 2].into(),
        step_mm: [[25.0, 20.0, 10.0], [50.0, 40.0, 20.0], [20.0, 20.0, 15.0]][i % 3],
        noise_um: [0.05, 0.2, 0.5, 0.1][i % 4],
        noise_urad: [0.05, 0.3, 0.1, 0.5, 0.2][i % 5],
        translation_um: [3.0, 1.0, 6.0][i % 3],
        rotation_urad: [6.0, 2.0, 10.0, 4.0][i % 4],
        ..VolumetricConfig::default()
    }
}

/// Radial range and circular deviation of a true machine's circle (µm).
fn circle_truth(t: &TrueMachine, d: &VolumetricData) -> (f64, f64) {
    let c = &d.setup.circle;
    let (radial, deviation) = t.circle(c.centre_mm, c.radius_mm);
    (geom::stats::range(&radial).unwrap() * 1e3, deviation * 1e3)
}

/// The true value of every figure of the report.
fn truths(
    config: &VolumetricConfig,
    d: &VolumetricData,
    a: &probe::volumetric::Analysis,
) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for (i, ax) in a.report.axes.iter().enumerate() {
        let t = d.truth.axes.iter().find(|t| t.axis == ax.axis).unwrap();
        let travel = t.positions_mm.last().copied().unwrap();
        for (j, line) in ax.straightness_lines.iter().enumerate() {
            let name = line.error.name();
            // The reported curve is shape + tilt·q; the truth's curve is it less
            // its least-squares line k·q + b: curve − shape is the line
            // (tilt − k)·q − b, whose intercept gives b.
            let shape = &t.shapes[name];
            let q = &t.positions_mm;
            let diff: Vec<f64> = q
                .iter()
                .zip(&t.curves[name])
                .map(|(x, c)| c - shape.value(*x, travel))
                .collect();
            let n = q.len() as f64;
            let (mq, md) = (q.iter().sum::<f64>() / n, diff.iter().sum::<f64>() / n);
            let slope = q
                .iter()
                .zip(&diff)
                .map(|(x, y)| (x - mq) * (y - md))
                .sum::<f64>()
                / q.iter().map(|x| (x - mq).powi(2)).sum::<f64>();
            let b = -(md - slope * mq);
            let path = format!("axes.{i}.straightness_lines.{j}");
            out.push((
                format!("{path}.slope_urad"),
                t.straightness_slopes[name] * 1e6,
            ));
            out.push((format!("{path}.intercept_um"), b * 1e3));
        }
    }
    let t = true_machine(config, d, None);
    let errors: Vec<f64> = a
        .volumetric
        .iter()
        .map(|(q, _)| t.error(*q).norm() * 1e3)
        .collect();
    out.push((
        "volumetric.max_um".into(),
        errors.iter().copied().fold(0.0, f64::max),
    ));
    out.push((
        "volumetric.rms_um".into(),
        (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt(),
    ));
    let (range, deviation) = circle_truth(&t, d);
    out.push(("circle.radial_range_um".into(), range));
    out.push(("circle.circular_deviation_um".into(), deviation));
    for (series, key) in [
        (Series::Fourier, "fourier"),
        (Series::Polynomial, "polynomial"),
    ] {
        let fits: Vec<Vec<probe::volumetric::SeriesFit>> = [0, 1, 2]
            .iter()
            .map(|&k| {
                let axis = [formats::Axis::X, formats::Axis::Y, formats::Axis::Z][k];
                let m = a.model.axis(axis).unwrap();
                m.fits.iter().map(|f| f.get(series).clone()).collect()
            })
            .collect();
        let minus: volumetric_common::Compensation =
            Box::new(move |axis, m, q| fits[axis][m].value(q).unwrap());
        let t = true_machine(config, d, Some(minus));
        let (range, deviation) = circle_truth(&t, d);
        out.push((format!("circle.compensated.{key}.radial_range_um"), range));
        out.push((
            format!("circle.compensated.{key}.circular_deviation_um"),
            deviation,
        ));
    }
    out
}

/// The figure type of a path: the report's key, the straightness lines of
/// every axis and curve together (`axes.0.straightness_lines.1.slope_urad`
/// → `straightness_lines.slope_urad`).
fn figure_type(path: &str) -> String {
    match path.strip_prefix("axes.") {
        Some(rest) => {
            let key = rest.rsplit('.').next().unwrap();
            format!("straightness_lines.{key}")
        }
        None => path.to_string(),
    }
}

#[test]
fn the_truth_lies_within_u_as_often_as_k_2_promises() {
    let mut cases = Vec::new();
    for k in 0..CAMPAIGNS {
        let config = campaign(k);
        let d = generate(&config).unwrap();
        let setup = generator_setup(&d);
        let measured = measured_axes(&d.errors);
        let a = analyse(measured.clone(), &setup, None).unwrap();
        let u = uncertainty(
            &measured,
            &setup,
            None,
            &a,
            &UncertaintyInputs {
                translation_mm: Some(config.noise_um * 1e-3),
                rotation_rad: Some(config.noise_urad * 1e-6),
                squareness_rad: None,
                from_report: false,
            },
            Propagation {
                trials: TRIALS,
                seed: k + 1,
            },
        );
        let Uncertainty::Given(p) = &u else {
            panic!("no U: {u:?}")
        };
        assert_eq!(p.failed_trials, 0);
        let values = figures(&a.report, &FIGURES).unwrap();
        let truth = truths(&config, &d, &a);
        // Every figure of the report has its U and its truth here.
        assert_eq!(
            values.keys().collect::<Vec<_>>(),
            p.expanded.keys().collect::<Vec<_>>()
        );
        assert_eq!(truth.len(), values.len());
        for (path, t) in truth {
            let case = Case {
                figure: figure_type(&path),
                truth: t,
                value: values[&path],
                u: p.expanded[&path],
            };
            if std::env::var("VOLUMETRIC_CASES").is_ok() {
                println!(
                    "{k} {path}: truth {t:.4} value {:.4} U {:.4} ratio {:.2}",
                    case.value,
                    case.u,
                    (case.value - t) / case.u
                );
            }
            cases.push(case);
        }
    }
    assert_coverage("volumetric", &cases);
}

/// Without the curves' uncertainty the figures get no U, and the report says
/// why; squareness uncertainty widens the volumetric U (the budget follows it).
#[test]
fn u_needs_the_curves_uncertainty_and_follows_the_squareness() {
    let config = VolumetricConfig::default();
    let d = generate(&config).unwrap();
    let setup = generator_setup(&d);
    let measured = measured_axes(&d.errors);
    let a = analyse(measured.clone(), &setup, None).unwrap();
    let run = |inputs: UncertaintyInputs| {
        uncertainty(&measured, &setup, None, &a, &inputs, Propagation::default())
    };
    let none = run(UncertaintyInputs::default());
    assert!(matches!(none, Uncertainty::NotGiven { .. }));
    let curves = UncertaintyInputs {
        translation_mm: Some(5e-5),
        rotation_rad: Some(5e-8),
        squareness_rad: None,
        from_report: false,
    };
    let plain = run(curves).of("volumetric.max_um").unwrap();
    let with_square = run(UncertaintyInputs {
        squareness_rad: Some(5e-6),
        ..curves
    });
    let Uncertainty::Given(p) = &with_square else {
        panic!()
    };
    let budget = p
        .budget
        .iter()
        .find(|b| b.figure == "volumetric.max_um")
        .unwrap();
    println!(
        "U of the largest volumetric error: curves alone {plain:.4} µm, with 5 µrad squareness {:.4} µm; budget {:?}",
        budget.expanded, budget.contributions
    );
    assert!(budget.expanded > 2.0 * plain);
    assert!(budget.contributions["squareness"] > budget.contributions["curves"]);
}
