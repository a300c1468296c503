//! Levenberg–Marquardt on nalgebra (the `levenberg-marquardt` crate, a port of
//! MINPACK's `lmder`), with parameter covariance and an analytic-Jacobian check.
//!
//! A problem implements [`Residuals`]: residual vector and analytic Jacobian at
//! given parameters. [`minimize`] runs the solver and returns the solution with
//! its covariance `s²·(JᵀJ)⁻¹`, `s² = Σr²/(m − n)`. [`jacobian_error`]
//! compares the analytic Jacobian against central differences — every problem
//! in the workspace has a test that calls it.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use crate::{GeomError, Result};

/// A non-linear least-squares problem `min ½‖r(p)‖²` with an analytic Jacobian.
pub trait Residuals {
    /// Residuals `r(p)`; the length must not depend on `p`.
    fn residuals(&self, params: &DVector<f64>) -> DVector<f64>;
    /// Jacobian `∂r/∂p` (one row per residual, one column per parameter).
    fn jacobian(&self, params: &DVector<f64>) -> DMatrix<f64>;
}

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Relative tolerance on the cost reduction and on the parameter step (MINPACK ftol = xtol).
    pub tolerance: f64,
    /// Maximum residual evaluations, as a multiple of (parameters + 1) (MINPACK `maxfev` factor).
    pub patience: usize,
    /// Compute the covariance at the minimum (an SVD of the Jacobian); off
    /// where the caller discards it (an outlier round) or computes its own.
    pub covariance: bool,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-15,
            patience: 200,
            covariance: true,
        }
    }
}

/// The minimiser and what is known about it.
#[derive(Debug, Clone)]
pub struct LmSolution {
    /// Parameters at the minimum.
    pub params: DVector<f64>,
    /// Residuals at the minimum.
    pub residuals: DVector<f64>,
    /// Root mean square of the residuals.
    pub rms: f64,
    /// Parameter covariance `s²·(JᵀJ)⁻¹` with `s² = Σr²/(m − n)`; `None` when
    /// `JᵀJ` is singular, there are no redundant observations, or it was not
    /// asked for ([`LmOptions::covariance`]).
    pub covariance: Option<DMatrix<f64>>,
    /// Residual evaluations used.
    pub evaluations: usize,
}

impl LmSolution {
    /// Standard deviations of the parameters (square roots of the covariance diagonal).
    pub fn std_devs(&self) -> Option<DVector<f64>> {
        self.covariance
            .as_ref()
            .map(|c| c.diagonal().map(|v| v.max(0.0).sqrt()))
    }
}

/// Adapter from [`Residuals`] to the crate's stateful problem trait.
struct Adapter<'a, P: Residuals> {
    problem: &'a P,
    params: DVector<f64>,
}

impl<P: Residuals> LeastSquaresProblem<f64, Dyn, Dyn> for Adapter<'_, P> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.params.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.params.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.problem.residuals(&self.params);
        r.iter().all(|v| v.is_finite()).then_some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let j = self.problem.jacobian(&self.params);
        j.iter().all(|v| v.is_finite()).then_some(j)
    }
}

/// Minimise `½‖r(p)‖²` from `initial`.
///
/// Fails when the residuals are not finite at the start, when there are fewer
/// residuals than parameters, or when the solver gives up without meeting its
/// convergence criteria.
pub fn minimize<P: Residuals>(
    problem: &P,
    initial: DVector<f64>,
    options: &LmOptions,
) -> Result<LmSolution> {
    let n = initial.len();
    let r0 = problem.residuals(&initial);
    if r0.len() < n {
        return Err(GeomError::TooFewPoints {
            what: "least-squares problem",
            needed: n,
            got: r0.len(),
        });
    }
    if r0.iter().any(|v| !v.is_finite()) {
        return Err(GeomError::NonFinite("initial residuals"));
    }
    let solver = LevenbergMarquardt::new()
        .with_ftol(options.tolerance)
        .with_xtol(options.tolerance)
        .with_gtol(0.0)
        .with_patience(options.patience);
    let (adapter, report) = solver.minimize(Adapter {
        problem,
        params: initial,
    });
    let converged = match &report.termination {
        t if t.was_successful() => true,
        // At machine precision the tolerances cannot be met any more: a minimum.
        TerminationReason::NoImprovementPossible(_) => true,
        _ => false,
    };
    if !converged {
        return Err(GeomError::NotConverged {
            what: "Levenberg–Marquardt",
            iterations: report.number_of_evaluations,
            last_step: (2.0 * report.objective_function).sqrt(),
        });
    }
    let params = adapter.params;
    let residuals = problem.residuals(&params);
    let m = residuals.len();
    let ssr = residuals.norm_squared();
    let covariance = options
        .covariance
        .then(|| covariance(&problem.jacobian(&params), ssr, m, n))
        .flatten();
    Ok(LmSolution {
        rms: (ssr / m as f64).sqrt(),
        params,
        residuals,
        covariance,
        evaluations: report.number_of_evaluations,
    })
}

/// Smallest singular value of J, relative to the largest, for which the
/// covariance is defined (below it a parameter is not determined).
const COVARIANCE_RANK_TOLERANCE: f64 = 1e-12;

/// `s²·(JᵀJ)⁻¹`, `s² = ssr/(m − n)` (the usual first-order covariance of a
/// least-squares estimate), computed from the SVD `J = U·Σ·Vᵀ` as
/// `s²·V·Σ⁻²·Vᵀ` — without forming JᵀJ, whose condition number is the square
/// of J's; `None` when undefined (no redundancy, or J rank-deficient).
pub fn covariance(jacobian: &DMatrix<f64>, ssr: f64, m: usize, n: usize) -> Option<DMatrix<f64>> {
    if m <= n || jacobian.ncols() != n {
        return None;
    }
    let svd = nalgebra::SVD::try_new(
        jacobian.clone(),
        false,
        true,
        f64::EPSILON,
        crate::fit::SVD_MAX_ITERATIONS,
    )?;
    let v_t = svd.v_t?;
    let sigma = &svd.singular_values;
    let largest = sigma.max();
    let smallest = sigma.min();
    if sigma.len() < n || smallest.is_nan() || smallest <= COVARIANCE_RANK_TOLERANCE * largest {
        return None;
    }
    let scaled = DMatrix::from_fn(n, n, |k, j| v_t[(k, j)] / sigma[k]);
    Some(scaled.transpose() * scaled * (ssr / (m - n) as f64))
}

/// Central-difference Jacobian with a relative step `h·max(|p|, 1)` per parameter.
pub fn numerical_jacobian<P: Residuals>(
    problem: &P,
    params: &DVector<f64>,
    h: f64,
) -> DMatrix<f64> {
    let m = problem.residuals(params).len();
    let mut jac = DMatrix::zeros(m, params.len());
    let mut p = params.clone();
    for j in 0..params.len() {
        let step = h * params[j].abs().max(1.0);
        p[j] = params[j] + step;
        let plus = problem.residuals(&p);
        p[j] = params[j] - step;
        let minus = problem.residuals(&p);
        p[j] = params[j];
        jac.set_column(j, &((plus - minus) / (2.0 * step)));
    }
    jac
}

/// Largest discrepancy between the analytic and the central-difference
/// Jacobian, each entry scaled by `max(|J_num|, 1)`. A correct Jacobian gives
/// ≈ 1e-7 or less with the default step.
pub fn jacobian_error<P: Residuals>(problem: &P, params: &DVector<f64>) -> f64 {
    let analytic = problem.jacobian(params);
    let numeric = numerical_jacobian(problem, params, 1e-6);
    analytic
        .iter()
        .zip(numeric.iter())
        .map(|(a, b)| (a - b).abs() / b.abs().max(1.0))
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exponential decay y = a·exp(−b·t) + c, a classic small NLLS test.
    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
    }

    impl Residuals for Decay {
        fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
            DVector::from_iterator(
                self.t.len(),
                self.t
                    .iter()
                    .zip(&self.y)
                    .map(|(t, y)| p[0] * (-p[1] * t).exp() + p[2] - y),
            )
        }
        fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
            DMatrix::from_fn(self.t.len(), 3, |i, j| {
                let e = (-p[1] * self.t[i]).exp();
                match j {
                    0 => e,
                    1 => -p[0] * self.t[i] * e,
                    _ => 1.0,
                }
            })
        }
    }

    fn decay(noise: f64) -> Decay {
        let t: Vec<f64> = (0..40).map(|i| i as f64 * 0.25).collect();
        // Deterministic ±noise pattern.
        let y = t
            .iter()
            .enumerate()
            .map(|(i, t)| 5.0 * (-0.7 * t).exp() + 1.5 + if i % 2 == 0 { noise } else { -noise })
            .collect();
        Decay { t, y }
    }

    /// The decay's fit from a start far from its parameters.
    fn fit_decay(noise: f64) -> LmSolution {
        minimize(
            &decay(noise),
            DVector::from_vec(vec![1.0, 0.1, 0.0]),
            &LmOptions::default(),
        )
        .unwrap()
    }

    #[test]
    fn recovers_exact_parameters() {
        let sol = fit_decay(0.0);
        assert!((sol.params[0] - 5.0).abs() < 1e-10);
        assert!((sol.params[1] - 0.7).abs() < 1e-10);
        assert!((sol.params[2] - 1.5).abs() < 1e-10);
        assert!(sol.rms < 1e-10);
    }

    #[test]
    fn covariance_matches_residual_scatter() {
        let sol = fit_decay(0.01);
        let sd = sol.std_devs().unwrap();
        // σ of the offset c is of the order of noise/√n.
        assert!(sd[2] > 0.0005 && sd[2] < 0.01, "σc = {}", sd[2]);
    }

    /// The covariance from the SVD of J equals s²·(JᵀJ)⁻¹ on a well
    /// conditioned J, and is undefined for a rank-deficient one.
    #[test]
    fn covariance_from_the_svd_of_j() {
        let j = DMatrix::from_fn(7, 3, |i, k| ((i * 3 + k * 5) % 7) as f64 + 0.25 * k as f64);
        let direct = (j.transpose() * &j).try_inverse().unwrap() * (2.0 / 4.0);
        let c = covariance(&j, 2.0, 7, 3).unwrap();
        assert!(
            (&c - &direct).abs().max() < 1e-12 * direct.abs().max(),
            "{c} vs {direct}"
        );
        let mut deficient = j.clone();
        let col = deficient.column(0).into_owned() * 2.0;
        deficient.set_column(2, &col);
        assert!(covariance(&deficient, 2.0, 7, 3).is_none());
        assert!(covariance(&j, 2.0, 3, 3).is_none());
    }

    #[test]
    fn jacobian_check_detects_errors() {
        let p = decay(0.0);
        let x = DVector::from_vec(vec![2.0, 0.5, 1.0]);
        assert!(jacobian_error(&p, &x) < 1e-7);

        struct Wrong(Decay);
        impl Residuals for Wrong {
            fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
                self.0.residuals(p)
            }
            fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
                let mut j = self.0.jacobian(p);
                j[(3, 1)] *= 1.01;
                j
            }
        }
        assert!(jacobian_error(&Wrong(decay(0.0)), &x) > 1e-4);
    }

    #[test]
    fn too_few_residuals_is_an_error() {
        let p = Decay {
            t: vec![0.0, 1.0],
            y: vec![1.0, 2.0],
        };
        assert!(
            minimize(
                &p,
                DVector::from_vec(vec![1.0, 0.1, 0.0]),
                &LmOptions::default()
            )
            .is_err()
        );
    }
}
