//! The expanded uncertainty (k = 2) of every figure of the rotary report
//! (docs/probe-rotary.md, "Uncertainty") by Monte Carlo (GUM Supplement 1,
//! [`crate::uncertainty`]).
//!
//! The model re-runs the method per trial: the measured inputs are re-drawn
//! about their values with the noise the method's own residuals show (Type A,
//! t-distributed for its degrees of freedom), the spheres re-fitted where the
//! input is probed points, and the six errors, the axis average line, the
//! component errors, their ranges and the interpolated rows recomputed. A
//! range is biased by the noise (the spread of noisy values exceeds the true
//! spread); U about the reported value holds that bias because every trial
//! adds its noise to the reported values again.
//!
//! - Centres: noise per coordinate `s² = Σr² / (2ν)` from the per-angle
//!   least squares (`b = P(θ) − Rz·P0` is a difference of two measured
//!   centres, variance 2σ²; ν = Σ(3n − 6) over the angles but 0°).
//! - Probed points: noise per coordinate `s² = Σr² / ν` from the sphere
//!   fits' radial residuals (ν = Σ(points − 4)); the fitted centres' noise is
//!   then anisotropic (the pole alone fixes the height), which re-fitting
//!   reproduces.
//!
//! Two sources, the same noise: the measurements at 0° (the reference of
//! every angle, so shared by all) and those at the other angles.

use formats::probe::rotary::report::{FIGURES, Report};
use formats::uncertainty::Uncertainty;
use geom::montecarlo::{Propagation, Trial};
use geom::nalgebra::Vector3;

use super::report::report;
use super::{Interpolated, Measurement, NAMES, Solution, solve};
use crate::uncertainty::{Source, Statement, TypeA, not_given, propagate as run, report_figures};

/// µm per mm.
const UM_PER_MM: f64 = 1e3;

/// The measured inputs the trials re-draw.
#[derive(Debug, Clone, Copy)]
pub enum Measured<'a> {
    /// Ball centres: the measurement itself.
    Centres(&'a Measurement),
    /// Probed points per ball and angle (mm), as
    /// [`Measurement::from_points`] takes them.
    Points {
        /// The angles (degrees).
        angles_deg: &'a [f64],
        /// Per ball its name and, per angle, its probed points.
        balls: &'a [(String, Vec<Vec<[f64; 3]>>)],
    },
}

/// Source 0: the measurements at 0°; source 1: those at the other angles.
const SOURCES: usize = 2;

/// What is not in U, in words.
const NOT_INCLUDED: &[&str] = &[
    "form errors of the ball and of the stylus tip (not given; a form error seen the same at every angle cancels in the differences to 0°)",
    "a displacement common to every ball at one angle (drift, thermal growth during the turn): indistinguishable from the table's error motion, it is reported as part of it",
    "temperature and expansion (no conditions are read)",
    "the model error of the linear interpolation between measured angles (interpolated rows carry the propagated noise only)",
    "component errors whose harmonics the measured angles alias onto a constant or once per turn (order n ≡ 0, ±1 modulo the number of angles): the location fit reads them as the axis average line",
];

/// The noise of the measured inputs (mm per coordinate), with the words
/// that say where it comes from; `None` without degrees of freedom.
fn noise(measured: Measured<'_>, solution: &Solution) -> Option<(TypeA, String)> {
    // (sum of squared residuals, degrees of freedom, residual variance in σ², what).
    let (ss, dof, scale, from) = match measured {
        Measured::Centres(_) => solution
            .errors
            .iter()
            .filter(|e| e.angle_deg != 0.0)
            .map(|e| (e.residual_rms_mm, e.residuals, 6))
            .fold(
                (0.0, 0, 2.0, "the per-angle least squares' residuals"),
                pool,
            ),
        Measured::Points { .. } => solution
            .fits
            .iter()
            .flatten()
            .map(|f| (f.rms_residual, f.points, 4))
            .fold((0.0, 0, 1.0, "the sphere fits' radial residuals"), pool),
    };
    let n = TypeA::from_sum_of_squares(ss, dof, scale)?;
    let words = format!(
        "{:.3} µm per coordinate from {from} ({} degrees of freedom)",
        n.sd * UM_PER_MM,
        n.dof
    );
    Some((n, words))
}

/// Add one fit's `(rms, residuals, unknowns)` to a pooled sum of squares
/// and degrees of freedom.
fn pool(
    (ss, dof, scale, from): (f64, usize, f64, &str),
    (rms, residuals, unknowns): (f64, usize, usize),
) -> (f64, usize, f64, &str) {
    (
        ss + rms * rms * residuals as f64,
        dof + residuals.saturating_sub(unknowns),
        scale,
        from,
    )
}

/// `p` moved by a normal draw of `sd` per coordinate from the source of
/// angle index `k` (0°: source 0), or as it is when that source is held.
fn drawn(trial: &mut Trial, k: usize, sd: f64, p: [f64; 3]) -> [f64; 3] {
    let source = usize::from(k != 0);
    match trial.draws(source) {
        Some(d) => {
            let v = Vector3::new(d.gaussian(sd), d.gaussian(sd), d.gaussian(sd));
            [p[0] + v.x, p[1] + v.y, p[2] + v.z]
        }
        None => p,
    }
}

/// The measurement of one trial: every input re-drawn.
fn trial_measurement(measured: Measured<'_>, trial: &mut Trial, sd: f64) -> Option<Measurement> {
    match measured {
        Measured::Centres(m) => {
            let balls = m
                .balls
                .iter()
                .map(|b| {
                    let centres = b
                        .centres
                        .iter()
                        .enumerate()
                        .map(|(k, c)| drawn(trial, k, sd, [c.x, c.y, c.z]))
                        .collect();
                    (b.name.clone(), centres)
                })
                .collect();
            Some(Measurement::from_centres(m.angles_deg.clone(), balls))
        }
        Measured::Points { angles_deg, balls } => {
            let balls = balls
                .iter()
                .map(|(name, groups)| {
                    let groups = groups
                        .iter()
                        .enumerate()
                        .map(|(k, points)| points.iter().map(|p| drawn(trial, k, sd, *p)).collect())
                        .collect();
                    (name.clone(), groups)
                })
                .collect();
            Measurement::from_points(angles_deg.to_vec(), balls).ok()
        }
    }
}

/// The headline figures: the location errors and the ranges.
fn headline() -> Vec<String> {
    let six: Vec<String> = NAMES
        .iter()
        .enumerate()
        .map(|(k, n)| format!("{n}_{}", if k < 3 { "um" } else { "urad" }))
        .collect();
    ["X0C_um", "Y0C_um", "A0C_urad", "B0C_urad"]
        .iter()
        .map(|f| format!("location.{f}"))
        .chain(six.iter().map(|f| format!("ranges.errors.{f}")))
        .chain(six.iter().map(|f| format!("ranges.components.{f}")))
        .collect()
}

/// U (k = 2) of every figure of `nominal` (the report of `solution`, its
/// interpolated rows included) by re-drawing `measured` (module docs).
pub fn propagate(
    measured: Measured<'_>,
    solution: &Solution,
    nominal: &Report,
    options: Propagation,
) -> Uncertainty {
    let Some((noise, words)) = noise(measured, solution) else {
        return not_given(
            "the residuals give no estimate of the noise (every sphere fitted through exactly 4 \
             points, or no angle but 0°): an uncertainty is not invented",
        );
    };
    let (what, re_run) = match measured {
        Measured::Centres(_) => ("ball centres", "the six errors re-solved"),
        Measured::Points { .. } => (
            "probed points",
            "the spheres re-fitted, the six errors re-solved",
        ),
    };
    let sources = vec![
        Source {
            name: "reference",
            description: format!(
                "noise of the {what} at 0° (the reference of every angle, shared by all): {words}"
            ),
        },
        Source {
            name: "angles",
            description: format!("noise of the {what} at the other angles: the same noise"),
        },
    ];
    let method = format!(
        "GUM Supplement 1 Monte Carlo: the {what} re-drawn about their measured values with the \
         noise s (t-distributed draws for its degrees of freedom), {re_run}, the axis average line, \
         component errors, ranges and interpolated rows recomputed per trial; U = half-width of the \
         symmetric interval about the reported value holding 95 % of the trials (k = 2)"
    );
    let statement = Statement {
        method,
        sources,
        not_included: NOT_INCLUDED.iter().map(|s| (*s).to_string()).collect(),
        headline: headline(),
    };
    let figures = report_figures(nominal, &FIGURES);
    let at: Vec<f64> = nominal.interpolated.iter().map(|r| r.angle_deg).collect();
    run(&figures, statement, options, |trial| {
        let sd = noise.shared_sd(trial, SOURCES)?;
        let m = trial_measurement(measured, trial, sd)?;
        let s = solve(&m).ok()?;
        let interpolated: Vec<Interpolated> =
            at.iter().map(|a| s.at(*a)).collect::<Result<_, _>>().ok()?;
        Some(report_figures(&report(&s, "", &interpolated), &FIGURES))
    })
}
