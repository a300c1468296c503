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
//! exact readings plus new noise are solved (by the solution's linear
//! response to its readings, `normal::Response`: the normal equations
//! factorised once for all trials, exact to first order in the noise;
//! checked against Gauss–Newton to convergence in the tests), aligned to
//! the nominal grid as the solve is, and the trial's figure is the reported figure plus the
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

/// How a trial's network is solved.
enum Solver<'a> {
    /// The solution's linear response to the readings' noise (one
    /// factorisation for every trial; [`normal::Response`]).
    Linear(Box<normal::Response<'a>>),
    /// Gauss–Newton to convergence from the trial's true field (the
    /// reference the linear response is checked against).
    Exact,
}

/// The reported corrections and what the trials need of them.
struct Field<'a> {
    net: &'a Network,
    solution: &'a Solution,
    structure: &'a Structure,
    options: &'a Options,
    solver: Solver<'a>,
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
    /// readings plus noise of σ = `sigma`, solved, aligned to the nominal
    /// grid; `None` when the solve fails.
    fn measured(&self, lambda: f64, d: &mut Draws, sigma: f64) -> Option<Vec<Vector3<f64>>> {
        let state = shrunk_state(self.net, self.solution, lambda);
        let noise: Vec<f64> = (0..self.structure.l.len())
            .map(|_| sigma * d.normal())
            .collect();
        let solved = match &self.solver {
            Solver::Linear(response) => normal::add(&state, &response.step(&noise)),
            Solver::Exact => {
                let mut st = self.structure.clone();
                exact_readings(&mut st, &state);
                for (l, n) in st.l.iter_mut().zip(&noise) {
                    *l += n;
                }
                let mut solved = state;
                normal::gauss_newton(self.net, &st, &mut solved, self.options.max_iterations)
                    .ok()?;
                solved
            }
        };
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
    propagate_with(net, solution, options, propagation, false)
}

/// [`uncertainty`], each trial solved by the solution's linear response or,
/// with `exact`, by Gauss–Newton to convergence.
fn propagate_with(
    net: &Network,
    solution: &Solution,
    options: &Options,
    propagation: Propagation,
    exact: bool,
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
    let structure = Structure::new(net)?;
    let solver = if exact || propagation.trials == 0 {
        Solver::Exact
    } else {
        Solver::Linear(Box::new(normal::Response::new(
            net,
            &structure,
            &shrunk_state(net, solution, 1.0),
        )?))
    };
    let field = Field {
        net,
        solution,
        structure: &structure,
        options,
        solver,
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

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use geom::montecarlo::{self, Propagation};
    use synth::probe::tracer::{TracerConfig, generate};

    use super::*;
    use crate::tracer::{Reading, solve};

    /// The generator's network (points and stations in file order).
    fn network(config: &TracerConfig) -> Network {
        let d = generate(config).unwrap();
        let index: HashMap<&str, usize> = d
            .grid
            .iter()
            .enumerate()
            .map(|(i, g)| (g.point.as_str(), i))
            .collect();
        let mut station_names: Vec<String> = Vec::new();
        let readings = d
            .readings
            .iter()
            .map(|r| {
                if station_names.last() != Some(&r.station) {
                    station_names.push(r.station.clone());
                }
                Reading {
                    station: station_names.len() - 1,
                    point: index[r.point.as_str()],
                    l: r.l,
                }
            })
            .collect();
        Network {
            points: d.grid.iter().map(|g| Point3::new(g.x, g.y, g.z)).collect(),
            point_names: d.grid.iter().map(|g| g.point.clone()).collect(),
            station_names,
            readings,
        }
    }

    /// The trials solved by the solution's linear response give the U of
    /// trials solved by Gauss–Newton to convergence, at a noise 10× the
    /// generator's default and on a small network whose figures are
    /// noise-dominated (the same draws: U agrees to far below its own
    /// Monte Carlo noise).
    #[test]
    fn linear_trials_give_the_u_of_converged_trials() {
        for (noise_um, error_um) in [(2.0, 5.0), (1.0, 0.5)] {
            let net = network(&TracerConfig {
                counts: [4, 4, 3],
                stations: 6,
                noise_um,
                error_um,
                ..TracerConfig::default()
            });
            let options = Options::default();
            let s = solve(&net, &options).unwrap();
            let p = Propagation {
                trials: 100,
                seed: 4,
            };
            let linear = propagate_with(&net, &s, &options, p, false).unwrap();
            let exact = propagate_with(&net, &s, &options, p, true).unwrap();
            for figure in [MAX_CORRECTION, RMS_CORRECTION] {
                let (a, b) = (linear.of(figure).unwrap(), exact.of(figure).unwrap());
                println!("noise {noise_um} µm, {figure}: U {a:.6} linear, {b:.6} converged");
                assert!((a - b).abs() < 1e-3 * b, "{figure}: {a} linear, {b} exact");
            }
        }
    }

    /// Each correction's standard uncertainty from the solution's covariance
    /// (corrections.csv) is the scatter of that correction over noise draws
    /// through the linear response: 2000 draws, σ of a σ ≈ 1.6 %.
    #[test]
    fn the_covariance_is_the_scatter_of_the_corrections() {
        let net = network(&TracerConfig {
            counts: [4, 4, 3],
            stations: 6,
            ..TracerConfig::default()
        });
        let options = Options {
            sigma_mm: Some(0.5e-3),
            ..Options::default()
        };
        let s = solve(&net, &options).unwrap();
        let structure = Structure::new(&net).unwrap();
        let state = shrunk_state(&net, &s, 1.0);
        let response = normal::Response::new(&net, &structure, &state).unwrap();
        let draws = 2000;
        // Sums of squared deviations, and the draws summed (a propagation
        // may run its model more than once per trial).
        let sums = std::sync::Mutex::new((vec![Vector3::<f64>::zeros(); net.points.len()], 0));
        let p = Propagation {
            trials: draws,
            seed: 9,
        };
        montecarlo::propagate(&BTreeMap::new(), &["readings"], p, |t| {
            let d = t.draws(0)?;
            let noise: Vec<f64> = structure.l.iter().map(|_| 0.5e-3 * d.normal()).collect();
            let solved = normal::add(&state, &response.step(&noise));
            let estimated: Vec<Point3<f64>> =
                solved.points.iter().map(|p| Point3::from(*p)).collect();
            let align = geom::transform::rigid_fit(&estimated, &net.points).unwrap();
            let mut sums = sums.lock().unwrap();
            for (i, (e, c)) in estimated.iter().zip(&s.corrections).enumerate() {
                let dev = align * e - net.points[i] - c.vector;
                sums.0[i] += dev.component_mul(&dev);
            }
            sums.1 += 1;
            None
        });
        let (sum_sq, count) = sums.into_inner().unwrap();
        let ratios: Vec<f64> = sum_sq
            .iter()
            .zip(&s.corrections)
            .flat_map(|(ss, c)| (0..3).map(move |a| (ss[a] / count as f64).sqrt() / c.u[a]))
            .collect();
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        let (lo, hi) = ratios
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), r| (l.min(*r), h.max(*r)));
        println!(
            "scatter / u over {} axes: mean {mean:.4}, {lo:.3}…{hi:.3}",
            ratios.len()
        );
        assert!((mean - 1.0).abs() < 0.02, "mean ratio {mean}");
        assert!(lo > 0.9 && hi < 1.1, "ratios {lo}…{hi}");
    }
}
