//! The expanded uncertainty (k = 2) of every figure of the indexing report
//! (docs/probe-indexing.md, "Uncertainty") by Monte Carlo (GUM Supplement 1,
//! [`crate::uncertainty`]).
//!
//! The model re-runs the construction per trial: every measured centre is
//! re-drawn about its value with the noise of the sphere fit's residuals
//! (`s = √(Σr²/(n − 4))` per coordinate, Type A, t-distributed for its
//! n − 4 degrees of freedom), and the sphere, frame, angles and the report's
//! figures are recomputed.
//!
//! Extremes over positions that share one true value are bounded instead
//! ([`Bound`]): every position of an A detent has that detent's ΔθA, so
//! `max |ΔθA|` and a detent's smallest and largest ΔθA are the extreme of
//! many noisy copies of one value, biased by the largest of their noises;
//! re-drawing about the measured values reproduces that bias only in part.
//! Their error is at most the largest error of the positions they are taken
//! over (`|max|m| − max|t|| ≤ max|m − t|`), and U is the 95 % quantile of
//! that largest deviation in the same trials. At A = 0° ΔθA is the tilt's
//! magnitude (true value 0 for a head on its datum): the deviation there is
//! the tilt vector's, and the detent's mean magnitude is bounded by the mean
//! deviation.
//!
//! The RMS of ΔθA and ΔθB carry the noise's variance in their square
//! (`rms(m)² ≈ rms(t)² + σ̄²`); each trial's draw of them is the reflection
//! `√(2R² − T²)` of the re-run's T about the reported R
//! ([`crate::uncertainty::reflected_rms`]).
//!
//! Two sources, the same noise: the positions that fix the frame (the B
//! turn at A = 0° and the B = 0° sweep) and the other positions.

use std::collections::BTreeMap;

use formats::probe::indexing::report::{FIGURES, Report};
use formats::uncertainty::Uncertainty;
use geom::montecarlo::{Propagation, Trial};
use geom::nalgebra::Vector3;

use super::{ARCSEC_PER_DEG, Angles, Indexing, Options, Position, layout, report, solve};
use crate::uncertainty::{
    Bound, BoundKind, Source, Statement, TypeA, not_given, propagate as run, reflected_rms,
    report_figures,
};

/// µm per mm.
const UM_PER_MM: f64 = 1e3;

/// Source 0: the positions that fix the frame; source 1: the others.
const SOURCES: usize = 2;

/// What is not in U, in words.
const NOT_INCLUDED: &[&str] = &[
    "the probe's qualification (one probe offset for every position: it moves every centre alike and cancels)",
    "the reference sphere's form error, and any movement of the sphere during the campaign",
    "errors of the CMM over the small volume of the centres (a sphere of the stylus length): they appear as indexing errors",
    "temperature and expansion (no conditions are read)",
];

/// The headline figures with a budget.
const HEADLINE: [&str; 8] = [
    "max_dA_arcsec",
    "max_dB_arcsec",
    "rms_dA_arcsec",
    "rms_dB_arcsec",
    "max_detent_dA_arcsec",
    "max_detent_dB_arcsec",
    "radius_mm",
    "radius_deviation_um",
];

/// The root-mean-square figures, drawn by [`reflected_rms`]: the noise
/// adds its variance to their square.
const RMS: [&str; 2] = ["rms_dA_arcsec", "rms_dB_arcsec"];

/// The figures bounded by the deviations of ΔθA (first) and of ΔθB
/// (second) of the positions they are taken over (module docs).
fn bounds(solved: &Indexing) -> (Vec<Bound>, Vec<Bound>) {
    let angles = &solved.angles;
    let all = |keep: &dyn Fn(&Angles) -> bool| -> Vec<usize> {
        (0..angles.len()).filter(|&i| keep(&angles[i])).collect()
    };
    let mut on_a = vec![Bound {
        figure: "max_dA_arcsec".into(),
        over: all(&|_| true),
        kind: BoundKind::Largest,
    }];
    for (k, &level) in solved.layout.a_levels.iter().enumerate() {
        let key = layout::detent_key(level);
        let over = all(&|p| layout::detent_key(p.a_deg) == key);
        let mut extreme = |name: &str, kind| {
            on_a.push(Bound {
                figure: format!("a_detents.{k}.{name}"),
                over: over.clone(),
                kind,
            });
        };
        extreme("min_dA_arcsec", BoundKind::Largest);
        extreme("max_dA_arcsec", BoundKind::Largest);
        if key == 0 {
            extreme("mean_dA_arcsec", BoundKind::Mean);
        }
    }
    let on_b = vec![Bound {
        figure: "max_dB_arcsec".into(),
        over: all(&|p| p.d_b_arcsec.is_some()),
        kind: BoundKind::Largest,
    }];
    (on_a, on_b)
}

/// Per position, |trial − reported| of ΔθA (at A = 0° that of the tilt
/// vector (l, m)) and of ΔθB (0 where undefined), in arc-seconds.
fn deviations(trial: &[Angles], reported: &[Angles]) -> (Vec<f64>, Vec<f64>) {
    let arcsec = |rad: f64| rad.to_degrees() * ARCSEC_PER_DEG;
    trial
        .iter()
        .zip(reported)
        .map(|(t, r)| {
            let a = if r.d_b_arcsec.is_none() {
                arcsec((t.cosines.xy() - r.cosines.xy()).norm())
            } else {
                (t.d_a_arcsec - r.d_a_arcsec).abs()
            };
            let b = match (t.d_b_arcsec, r.d_b_arcsec) {
                (Some(t), Some(r)) => (t - r).abs(),
                _ => 0.0,
            };
            (a, b)
        })
        .unzip()
}

/// The positions of one trial: every centre re-drawn, from source 0 where
/// `frame[i]`, else from source 1.
fn trial_positions(
    positions: &[Position],
    frame: &[bool],
    trial: &mut Trial,
    sd: f64,
) -> Vec<Position> {
    positions
        .iter()
        .zip(frame)
        .map(|(p, &in_frame)| match trial.draws(usize::from(!in_frame)) {
            Some(d) => Position {
                centre: p.centre + Vector3::new(d.gaussian(sd), d.gaussian(sd), d.gaussian(sd)),
                ..*p
            },
            None => *p,
        })
        .collect()
}

/// U (k = 2) of every figure of `nominal` (the report of `solved` with
/// `options`) by re-drawing the centres of `positions` (module docs).
pub fn propagate(
    positions: &[Position],
    solved: &Indexing,
    nominal: &Report,
    options: &Options,
    propagation: Propagation,
) -> Uncertainty {
    let Some(noise) = TypeA::from_sum_of_squares(
        solved.noise_mm.powi(2) * positions.len().saturating_sub(4) as f64,
        positions.len().saturating_sub(4),
        1.0,
    ) else {
        return not_given(
            "the sphere fit has no residual to estimate the noise from: an uncertainty is not invented",
        );
    };
    let words = format!(
        "{:.3} µm per coordinate from the sphere fit's radial residuals ({} degrees of freedom)",
        noise.sd * UM_PER_MM,
        noise.dof
    );
    let mut frame = vec![false; positions.len()];
    for &i in solved.layout.b_turn.iter().chain(&solved.layout.a_sweep) {
        if let Some(f) = frame.get_mut(i) {
            *f = true;
        }
    }
    let sources = vec![
        Source {
            name: "frame",
            description: format!(
                "noise of the centres that fix the frame (the B turn at A = 0°, the B = 0° sweep): {words}"
            ),
        },
        Source {
            name: "positions",
            description: "noise of the other centres: the same noise".to_string(),
        },
    ];
    let statement = Statement {
        method:
            "GUM Supplement 1 Monte Carlo: every centre re-drawn about its measured value with \
                 the noise s (t-distributed draws for its degrees of freedom), the sphere, frame, \
                 angles and figures recomputed per trial; U = half-width of the symmetric interval \
                 about the reported value holding 95 % of the trials (k = 2); extremes over the \
                 positions of a detent: the 95 % quantile of the largest deviation of those \
                 positions (docs/probe-indexing.md)"
                .to_string(),
        sources,
        not_included: NOT_INCLUDED.iter().map(|s| (*s).to_string()).collect(),
        headline: HEADLINE.iter().map(|s| (*s).to_string()).collect(),
    };
    let figures = report_figures(nominal, &FIGURES);
    let (on_a, on_b) = bounds(solved);
    run(&figures, statement, propagation, |trial| {
        let sd = noise.shared_sd(trial, SOURCES)?;
        let moved = trial_positions(positions, &frame, trial, sd);
        let ind = solve(&moved).ok()?;
        let r = report(&ind, options).ok()?;
        let mut f: BTreeMap<String, f64> = report_figures(&r, &FIGURES);
        let (dev_a, dev_b) = deviations(&ind.angles, &solved.angles);
        for b in &on_a {
            b.apply(&figures, &dev_a, &mut f);
        }
        for b in &on_b {
            b.apply(&figures, &dev_b, &mut f);
        }
        for name in RMS {
            if let (Some(r), Some(t)) = (figures.get(name), f.get_mut(name)) {
                *t = reflected_rms(*r, *t);
            }
        }
        Some(f)
    })
}
