//! Coverage of the indexing method's expanded uncertainties (issue 25, "Must
//! hold"): over campaigns of the generator `synth::probe::indexing` with
//! different seeds, noise levels, grids, stylus lengths, mountings and
//! detent errors, the generator's true figure lies within measured ± U for
//! 90–99 % of all figures and ≥ 85 % of each figure type, and U is not
//! inflated (per type, median U ≤ 3 × RMS of the actual errors). 100 trials
//! per campaign (the command's default is 200) keep the test short.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod coverage_common;

use coverage_common::{Case, assert_coverage, assert_unchanged, unit};
use formats::probe::indexing::IndexingTruth;
use formats::probe::indexing::report::FIGURES;
use geom::montecarlo::Propagation;
use probe::indexing::uncertainty::propagate;
use probe::indexing::{Options, Position, report, solve};
use synth::probe::indexing::{AErrors, BErrors, Generated, IndexingConfig, generate};

/// Campaigns, each with its own seed, noise, grid, head and errors.
const CAMPAIGNS: u64 = 24;

/// The configuration of campaign `c` and the nominal radius given with it.
fn campaign(c: u64) -> (IndexingConfig, f64) {
    let i = c as usize;
    let stylus = [117.0, 50.0, 200.0, 80.0][i % 4];
    let config = IndexingConfig {
        seed: 500 + c,
        a_max_deg: [105.0, 90.0, 60.0][i % 3],
        a_step_deg: [15.0, 30.0, 7.5, 22.5][(i / 2) % 4],
        b_step_deg: [15.0, 30.0, 45.0, 20.0, 60.0][i % 5],
        stylus_mm: stylus,
        rotation_centre_mm: [400.0 * unit(c, 1), -300.0 * unit(c, 2), -400.0],
        mount_x_deg: 0.3 * (unit(c, 3) - 0.5),
        mount_y_deg: 0.3 * (unit(c, 4) - 0.5),
        mount_z_deg: 2.0 * (unit(c, 5) - 0.5),
        noise_um: [0.1, 0.3, 0.6, 1.0, 0.3, 2.0][i % 6],
        a_errors: AErrors {
            random_arcsec: 3.0 * unit(c, 6),
            gravity_arcsec: 2.0 * (unit(c, 7) - 0.5),
            values_arcsec: Vec::new(),
        },
        b_errors: BErrors {
            random_arcsec: 2.0 * unit(c, 8),
            once_per_turn_arcsec: 3.0 * unit(c, 9),
            phase_deg: 360.0 * unit(c, 10),
            values_arcsec: Vec::new(),
        },
    };
    (config, stylus - 0.02 + 0.04 * unit(c, 11))
}

/// The true value of the figure at `path`, or `None` where the truth does
/// not give it.
fn true_figure(path: &str, truth: &IndexingTruth, nominal: f64) -> Option<f64> {
    let rows = &truth.truth;
    let max_abs = |v: &mut dyn Iterator<Item = f64>| v.fold(0.0_f64, |m, x| m.max(x.abs()));
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let d_b: Vec<f64> = rows.iter().filter_map(|r| r.3).collect();
    let d_a: Vec<f64> = rows.iter().map(|r| r.2).collect();
    let head = truth.head.as_ref()?;
    let parts: Vec<&str> = path.split('.').collect();
    match parts.as_slice() {
        ["radius_mm"] => Some(head.radius_mm),
        ["radius_deviation_um"] => Some((head.radius_mm - nominal) * 1e3),
        ["max_dA_arcsec" | "max_detent_dA_arcsec"] => Some(max_abs(&mut d_a.iter().copied())),
        ["max_dB_arcsec" | "max_detent_dB_arcsec"] => Some(max_abs(&mut d_b.iter().copied())),
        ["rms_dA_arcsec"] => Some(rms(&d_a)),
        ["rms_dB_arcsec"] => Some(rms(&d_b)),
        _ => None,
    }
}

/// The true value of a per-detent figure: the injected error of its detent.
fn true_detent(path: &str, report: &serde_json::Value, truth: &IndexingTruth) -> Option<f64> {
    let parts: Vec<&str> = path.split('.').collect();
    let [table, k, _] = parts.as_slice() else {
        return None;
    };
    let row = &report[*table][k.parse::<usize>().ok()?];
    let wrap = |b: f64| {
        let r = b.rem_euclid(360.0);
        if r > 180.0 { r - 360.0 } else { r }
    };
    match *table {
        "a_detents" => {
            let a = row["a_deg"].as_f64()?;
            truth.truth.iter().find(|r| r.0 == a).map(|r| r.2)
        }
        "b_detents" => {
            let b = row["b_deg"].as_f64()?;
            truth
                .truth
                .iter()
                .find(|r| r.0 > 0.0 && (wrap(r.1) - b).abs() < 1e-9)
                .and_then(|r| r.3)
        }
        _ => None,
    }
}

/// The generated centres as the method's positions.
fn positions(g: &Generated) -> Vec<Position> {
    g.centres
        .iter()
        .map(|r| Position::new(r.a_deg, r.b_deg, [r.x, r.y, r.z]))
        .collect()
}

#[test]
fn the_true_figures_lie_within_u_as_often_as_k_2_promises() {
    let mut cases = Vec::new();
    let propagation = Propagation {
        trials: 100,
        seed: 1,
    };
    for c in 0..CAMPAIGNS {
        let (config, nominal) = campaign(c);
        let g = generate(&config).unwrap();
        let positions = positions(&g);
        let solved = solve(&positions).unwrap();
        let options = Options {
            nominal_radius_mm: Some(nominal),
            ..Options::default()
        };
        let r = report(&solved, &options).unwrap();
        let u = propagate(&positions, &solved, &r, &options, propagation);
        let expanded = u.expanded().expect("propagated");
        let values = formats::uncertainty::figures(&r, &FIGURES).unwrap();
        assert_eq!(
            expanded.len(),
            values.len(),
            "campaign {c}: every figure has its U"
        );
        let json = serde_json::to_value(&r).unwrap();
        for (path, value) in &values {
            let truth = true_figure(path, &g.truth, nominal)
                .or_else(|| true_detent(path, &json, &g.truth))
                .unwrap_or_else(|| panic!("no truth for {path}"));
            cases.push(Case::at(path, truth, *value, expanded[path]));
        }
    }
    assert_coverage("indexing", &cases);
}

/// `report.json` adds `F_U_arcsec` beside the figures and changes no value.
#[test]
fn report_json_adds_u_and_changes_nothing() {
    let (config, nominal) = campaign(1);
    let g = generate(&config).unwrap();
    let positions = positions(&g);
    let solved = solve(&positions).unwrap();
    let options = Options {
        nominal_radius_mm: Some(nominal),
        tolerance_arcsec: Some(1.0),
        ..Options::default()
    };
    let mut r = report(&solved, &options).unwrap();
    let plain = serde_json::to_value(&r).unwrap();
    let propagation = Propagation {
        trials: 30,
        seed: 2,
    };
    r.uncertainty = Some(propagate(&positions, &solved, &r, &options, propagation));
    let json = probe::uncertainty::report_json(&r, r.uncertainty.as_ref(), &FIGURES).unwrap();
    assert_unchanged(&plain, &json, "");
    for key in [
        "radius_U_mm",
        "max_dA_U_arcsec",
        "rms_dB_U_arcsec",
        "max_detent_dB_U_arcsec",
    ] {
        assert!(json[key].as_f64().unwrap() > 0.0, "{key}");
    }
    assert!(json["max_dA_at"].get("value_U_arcsec").is_none());
    assert!(
        json["tolerance"]["exceeding"][0]
            .get("dA_U_arcsec")
            .is_none()
    );
}
