//! The expanded uncertainty (k = 2) of the tracer's figures by Monte Carlo
//! (GUM Supplement 1; docs/probe-tracer.md, "Uncertainty").
//!
//! One source, the interferometric readings, each with normal noise of
//! standard deviation σ. The figures are biased by the noise (a length,
//! its maximum and its RMS grow with it), and the bias depends on the true
//! field — it is largest where the field is small against the noise. Trials
//! drawn about the reported field would simulate the bias of a field
//! already inflated by the noise: too small (in a noise-dominated network
//! ≈ 0.4 of the real one for the RMS). So each trial is the error of a
//! measurement of a plausible true field: the reported corrections shrunk
//! to the energy the truth may have, `λₜ² = max(0, 1 − |e|² / Σ|ĉᵢ|²)`
//! (positive-part James–Stein) with |e|² the squared length of one noise
//! realisation (the corrections of the James–Stein field, λ² = 1 − tr Σ /
//! Σ|ĉᵢ|², re-measured, less that field: the spread of the noise energy
//! and the uncertainty of the truth's energy enter with it); that field's
//! exact readings plus new noise are solved (Gauss–Newton from it, the datum
//! alignment), and the trial's figure is the reported figure plus the
//! measured-minus-true figure of that field. U is the 95 % half-width of
//! the trial figures about the reported one ([`geom::montecarlo::expanded`]):
//! the bias inside it. Where the field is large against the noise λ ≈ 1 and
//! this is the plain Monte Carlo about the reported result.
//! σ is the a-priori one (`--sigma-um`) or the a-posteriori σ̂ from the
//! residuals, a Type A estimate with ν = redundancy degrees of freedom:
//! each trial then draws its σ from σ̂'s distribution, `σ² = ν·σ̂²/χ²_ν`
//! (JCGM 101 §6.4.9: a scaled-and-shifted t for the readings), so a small
//! network's uncertain σ̂ widens U. Station positions and dead paths are
//! unknowns of the same solve: their uncertainty enters through it.

use std::collections::BTreeMap;

use formats::uncertainty::Uncertainty;
use geom::montecarlo::{Draws, Propagation};
use geom::nalgebra::{Point3, Vector3, Vector4};

use super::normal::{self, State, Structure};
use super::report::{CorrectionFigures, MAX_CORRECTION, RMS_CORRECTION};
use super::{Network, Options, Solution};
use crate::Result;
use crate::uncertainty::{METHOD, Source, Statement, TypeA, propagate};

/// Index of the readings among the sources.
const READINGS: usize = 0;

/// What is not in U, in words.
fn not_included() -> Vec<String> {
    [
        "the interferometer's length scale (air refraction, wavelength) and the reflector's \
         offset: readings.csv is taken as corrected for them",
        "a length-dependent part of the reading noise and drift between stations: the readings \
         have one σ",
        "the CMM's repeatability between the stations' runs beyond the residuals",
    ]
    .iter()
    .map(|s| (*s).to_string())
    .collect()
}

/// σ of the readings in a trial: given, or drawn from σ̂'s distribution.
#[derive(Debug, Clone, Copy)]
enum Sigma {
    /// Given a priori (mm).
    Given(f64),
    /// Estimated from the residuals (mm), with its degrees of freedom.
    Estimated(TypeA),
}

impl Sigma {
    fn of(solution: &Solution) -> Sigma {
        if solution.sigma_a_priori {
            Sigma::Given(solution.sigma)
        } else {
            Sigma::Estimated(TypeA {
                sd: solution.sigma0,
                dof: solution.redundancy,
            })
        }
    }

    /// One trial's σ: given, or `σ̂·√(ν/χ²_ν)` for an estimate ([`TypeA::trial_sd`]).
    fn draw(self, d: &mut Draws) -> f64 {
        match self {
            Sigma::Given(s) => s,
            Sigma::Estimated(estimate) => estimate.trial_sd(d),
        }
    }

    fn describe(self) -> String {
        match self {
            Sigma::Given(s) => format!(
                "each reading + N(0, σ²), σ = {:.4} µm given a priori (--sigma-um)",
                s * 1e3
            ),
            Sigma::Estimated(TypeA { sd, dof }) => format!(
                "each reading + N(0, σ²), σ from the residuals (Type A: σ̂ = {:.4} µm, \
                 ν = {dof}; each trial draws σ² = ν·σ̂²/χ²_ν)",
                sd * 1e3
            ),
        }
    }
}

/// The shrinkage factor λ of a field of squared length `energy` measured
/// with noise of squared length `noise`: `λ² = max(0, 1 − noise / energy)`
/// (positive-part James–Stein), so that λ·ĉ has the squared length the
/// true field is expected to have (`E Σ|ĉᵢ|² = Σ|cᵢ|² + tr Σ`).
fn lambda_of(energy: f64, noise: f64) -> f64 {
    if energy > 0.0 {
        (1.0 - noise / energy).max(0.0).sqrt()
    } else {
        0.0
    }
}

/// The reported solution with its corrections scaled by `lambda`, in the
/// aligned frame (stations and dead paths as reported).
fn shrunk_state(net: &Network, solution: &Solution, lambda: f64) -> State {
    State {
        points: net
            .points
            .iter()
            .zip(&solution.corrections)
            .map(|(p, c)| p.coords + lambda * c.vector)
            .collect(),
        stations: solution
            .stations
            .iter()
            .map(|s| Vector4::new(s.position.x, s.position.y, s.position.z, s.dead_path))
            .collect(),
    }
}

/// Replace the readings of `st` by the exact ones of `state`:
/// `l = |A − P| − d` (a network without residuals around which the trials
/// draw their noise).
fn exact_readings(st: &mut Structure, state: &State) {
    for i in 0..st.n {
        for e in st.entries(i) {
            let s = state.stations[st.station_of[e]];
            st.l[e] = (state.points[i] - s.xyz()).norm() - s.w;
        }
    }
}

/// The reported corrections and what the trials need of them.
struct Field<'a> {
    net: &'a Network,
    solution: &'a Solution,
    structure: Structure,
    options: &'a Options,
    /// Σ|ĉᵢ|² (mm²).
    energy: f64,
    /// The James–Stein factor of the reported field (its noise energy tr Σ).
    lambda: f64,
}

impl Field<'_> {
    /// The reported corrections scaled by `lambda`.
    fn scaled(&self, lambda: f64) -> Vec<Vector3<f64>> {
        self.solution
            .corrections
            .iter()
            .map(|c| lambda * c.vector)
            .collect()
    }

    /// The corrections measured on the network of the field λ·ĉ: its exact
    /// readings plus noise of σ = `sigma`, solved from it, aligned to the
    /// nominal grid; `None` when the solve fails.
    fn measured(&self, lambda: f64, d: &mut Draws, sigma: f64) -> Option<Vec<Vector3<f64>>> {
        let state = shrunk_state(self.net, self.solution, lambda);
        let mut st = self.structure.clone();
        exact_readings(&mut st, &state);
        for l in &mut st.l {
            *l += sigma * d.normal();
        }
        let mut solved = state;
        normal::gauss_newton(self.net, &st, &mut solved, self.options.max_iterations).ok()?;
        let estimated: Vec<Point3<f64>> = solved.points.iter().map(|p| Point3::from(*p)).collect();
        let align = geom::transform::rigid_fit(&estimated, &self.net.points).ok()?;
        Some(
            estimated
                .iter()
                .zip(&self.net.points)
                .map(|(e, n)| align * e - n)
                .collect(),
        )
    }

    /// One trial's error of the figures: a plausible true field λₜ·ĉ (λₜ
    /// from the reported energy less that of one noise realisation about the
    /// James–Stein field), measured with new noise, less its own figures.
    fn error(&self, d: &mut Draws, sigma: Sigma) -> Option<BTreeMap<String, f64>> {
        let s = sigma.draw(d);
        let noise: f64 = self
            .measured(self.lambda, d, s)?
            .iter()
            .zip(self.scaled(self.lambda))
            .map(|(c, t)| (c - t).norm_squared())
            .sum();
        let lambda = lambda_of(self.energy, noise);
        let got = CorrectionFigures::of(self.measured(lambda, d, s)?.iter()).named();
        let truth = CorrectionFigures::of(self.scaled(lambda).iter()).named();
        Some(
            got.into_iter()
                .map(|(k, v)| {
                    let t = truth.get(&k).copied().unwrap_or(v);
                    (k, v - t)
                })
                .collect(),
        )
    }
}

/// U (k = 2) of the largest and RMS correction of `solution` (a solution of
/// `net` under `options`), with their budget; no U with `trials = 0`.
pub fn uncertainty(
    net: &Network,
    solution: &Solution,
    options: &Options,
    propagation: Propagation,
) -> Result<Uncertainty> {
    let energy: f64 = solution
        .corrections
        .iter()
        .map(|c| c.vector.norm_squared())
        .sum();
    let trace: f64 = solution
        .corrections
        .iter()
        .map(|c| c.u.norm_squared())
        .sum();
    let field = Field {
        net,
        solution,
        structure: Structure::new(net)?,
        options,
        energy,
        lambda: lambda_of(energy, trace),
    };
    let sigma = Sigma::of(solution);
    let nominal = CorrectionFigures::of(solution.corrections.iter().map(|c| &c.vector)).named();
    let statement = Statement {
        method: METHOD.into(),
        sources: vec![Source {
            name: "readings",
            description: sigma.describe(),
        }],
        not_included: not_included(),
        headline: vec![MAX_CORRECTION.into(), RMS_CORRECTION.into()],
    };
    Ok(propagate(&nominal, statement, propagation, |trial| {
        let error = match trial.draws(READINGS) {
            Some(d) => field.error(d, sigma)?,
            None => BTreeMap::new(),
        };
        Some(
            nominal
                .iter()
                .map(|(k, v)| (k.clone(), v + error.get(k).copied().unwrap_or(0.0)))
                .collect(),
        )
    }))
}
