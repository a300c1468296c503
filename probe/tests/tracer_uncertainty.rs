//! Coverage of the tracer's expanded uncertainties (docs/probe-tracer.md,
//! "Uncertainty"; docs/methods.md §7): campaigns of the generator with
//! different seeds, grids, station counts, noise levels, error fields and
//! missing readings; the true largest and RMS correction (from the
//! generator's truth) against the measured value ± U. The test runs 100
//! trials per campaign (the command's default is 200) to keep it short.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod coverage_common;
mod tracer_common;

use coverage_common::{Case, assert_coverage};
use formats::uncertainty::{Uncertainty, figures};
use geom::montecarlo::Propagation;
use probe::tracer::{self, Options};
use synth::probe::tracer::{TracerConfig, generate};
use tracer_common::network;

/// Campaigns of the test.
const CAMPAIGNS: u64 = 60;
/// Trials per campaign.
const TRIALS: usize = 100;

/// The k-th campaign: layouts, noise and error fields cycle at different
/// periods so that they combine differently.
fn campaign(k: u64) -> TracerConfig {
    let i = k as usize;
    let stations = [5, 6, 7, 8][i % 4];
    TracerConfig {
        counts: [[3, 3, 3], [4, 3, 3], [4, 4, 3], [3, 4, 4], [5, 4, 3]][i % 5],
        stations,
        noise_um: [0.05, 0.2, 0.5, 1.0, 0.3, 2.0, 0.1][i % 7],
        error_um: [0.5, 2.0, 5.0, 10.0, 1.0, 20.0][i % 6],
        // Readings left out only where every point keeps three stations.
        missing: if i % 3 == 2 && stations == 8 {
            0.05
        } else {
            0.0
        },
        station_distance: [1.3, 1.6, 2.5][i % 3],
        seed: 100 + k,
        noise_seed: 1000 + k,
        ..TracerConfig::default()
    }
}

/// The largest and RMS length of the true corrections (µm), computed here
/// from truth.json's vectors.
fn true_figures(c: &[[f64; 3]]) -> [f64; 2] {
    let lengths: Vec<f64> = c
        .iter()
        .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() * 1e3)
        .collect();
    let max = lengths.iter().copied().fold(0.0, f64::max);
    let rms = (lengths.iter().map(|l| l * l).sum::<f64>() / lengths.len() as f64).sqrt();
    [max, rms]
}

#[test]
fn the_truth_lies_within_u_as_often_as_k_2_promises() {
    let mut cases = Vec::new();
    for k in 0..CAMPAIGNS {
        let config = campaign(k);
        let d = generate(&config).unwrap();
        let net = network(&d);
        let options = Options::default();
        let s = tracer::solve(&net, &options).unwrap();
        let report = tracer::report(&net, &s);
        let u = tracer::uncertainty(
            &net,
            &s,
            &options,
            Propagation {
                trials: TRIALS,
                seed: k + 1,
            },
        )
        .unwrap();
        let Uncertainty::Given(p) = &u else {
            panic!("no U: {u:?}")
        };
        assert_eq!(p.failed_trials, 0);
        let values = figures(&report, &formats::probe::tracer::report::FIGURES).unwrap();
        let truth = true_figures(&d.truth.corrections_rigid_removed_mm);
        // Every figure of the report has its U, and only those two are figures.
        assert_eq!(
            values.keys().collect::<Vec<_>>(),
            p.expanded.keys().collect::<Vec<_>>()
        );
        for (name, t) in [
            ("max_correction_um", truth[0]),
            ("rms_correction_um", truth[1]),
        ] {
            if std::env::var("TRACER_CASES").is_ok() {
                println!(
                    "{k} {name} noise {} error {} counts {:?} m {} dist {}: truth {t:.4} value {:.4} U {:.4} ratio {:.2} sigma0 {:.4}",
                    config.noise_um,
                    config.error_um,
                    config.counts,
                    config.stations,
                    config.station_distance,
                    values[name],
                    p.expanded[name],
                    (values[name] - t) / p.expanded[name],
                    s.sigma0 * 1e3
                );
            }
            cases.push(Case {
                figure: name.into(),
                truth: t,
                value: values[name],
                u: p.expanded[name],
            });
        }
    }
    assert_coverage("tracer", &cases);
}

/// U follows the noise: the same field and layout with 4× the reading noise
/// has ≈ 4× the U of its RMS correction; a-priori σ is used as given.
#[test]
fn u_follows_the_reading_noise() {
    let u_of = |noise_um: f64, sigma_mm: Option<f64>| {
        let d = generate(&TracerConfig {
            noise_um,
            ..TracerConfig::default()
        })
        .unwrap();
        let net = network(&d);
        let options = Options {
            sigma_mm,
            ..Options::default()
        };
        let s = tracer::solve(&net, &options).unwrap();
        let u = tracer::uncertainty(&net, &s, &options, Propagation::default()).unwrap();
        u.of("rms_correction_um").unwrap()
    };
    let (quiet, noisy) = (u_of(0.1, None), u_of(0.4, None));
    println!("U of the RMS correction: noise 0.1 µm → {quiet:.4} µm, 0.4 µm → {noisy:.4} µm");
    assert!(
        noisy / quiet > 3.0 && noisy / quiet < 5.3,
        "{quiet} {noisy}"
    );
    let given = u_of(0.1, Some(0.4e-3));
    assert!(given / quiet > 3.0, "{given} {quiet}");
    let off = {
        let d = generate(&TracerConfig::default()).unwrap();
        let net = network(&d);
        let s = tracer::solve(&net, &Options::default()).unwrap();
        tracer::uncertainty(
            &net,
            &s,
            &Options::default(),
            Propagation { trials: 0, seed: 1 },
        )
        .unwrap()
    };
    assert!(matches!(off, Uncertainty::NotGiven { .. }));
}
