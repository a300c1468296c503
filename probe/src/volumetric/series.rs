//! Models of one error curve (docs/probe-volumetric.md): a Fourier series of order N,
//! `Δ(p) = a0 + Σ_{n=1..N} (aₙ sin(nωp) + bₙ cos(nωp))`, `ω = 2π/L` over the
//! measured travel L, and a polynomial of degree 2N (the same 2N + 1
//! coefficients), fitted by linear least squares; their figures R², SSE,
//! RMSE, e_max; and the order chosen by leave-one-out cross-validation.

pub use formats::probe::volumetric::Series;
pub use formats::probe::volumetric::report::OrderScore;
use geom::nalgebra::{DMatrix, DVector, SVD};

use crate::{Conditioning, ProbeError, Result, Unsolvable, VolumetricFault};

/// Largest condition number (largest over smallest singular value of the
/// design matrix with unit-norm columns) accepted for a fit: beyond it the
/// positions do not determine the coefficients (e.g. 2N + 1 equally spaced
/// positions over one period give the Fourier series only 2N distinct phases).
pub(crate) const MAX_CONDITION: f64 = 1e10;
/// Largest order N tried by `--order auto`.
pub(crate) const MAX_AUTO_ORDER: usize = 10;
/// `--order auto` tries an order only with at least this many points per
/// coefficient: a fit that nearly interpolates leaves cross-validation a
/// handful of points of its own and picks noise.
pub const POINTS_PER_COEFFICIENT: usize = 2;
/// A leave-one-out hat value this close to 1 means the point is fitted
/// exactly whatever its value: the order leaves nothing to cross-validate.
const HAT_LIMIT: f64 = 1.0 - 1e-9;
/// A basis column smaller than this times √n is numerically zero (every
/// basis function is of order 1): e.g. `sin(3ωp)` at positions where it
/// vanishes holds only rounding, which unit-norm scaling would blow up.
const ZERO_COLUMN: f64 = 1e-9;
/// Iteration limit of the SVD.
const SVD_ITERATIONS: usize = 1000;

/// How well a model follows the measured values: residuals `r = v − v̂`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Figures {
    /// R² = 1 − SSE/SST; `None` when the values are all equal (SST = 0).
    pub r2: Option<f64>,
    /// SSE = Σ r² (value unit²).
    pub sse: f64,
    /// RMSE = √(SSE/n).
    pub rmse: f64,
    /// e_max = max |r|.
    pub emax: f64,
}

impl Figures {
    /// The figures of `residuals` of the values `values`.
    pub fn of(values: &[f64], residuals: &[f64]) -> Figures {
        let n = values.len().max(1) as f64;
        let mean = values.iter().sum::<f64>() / n;
        let sst: f64 = values.iter().map(|v| (v - mean) * (v - mean)).sum();
        let sse: f64 = residuals.iter().map(|r| r * r).sum();
        Figures {
            r2: (sst > 0.0).then(|| 1.0 - sse / sst),
            sse,
            rmse: (sse / n).sqrt(),
            emax: residuals.iter().fold(0.0, |m, r| m.max(r.abs())),
        }
    }
}

/// A series fitted to one curve.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesFit {
    /// Fourier or polynomial.
    pub series: Series,
    /// Order N (2N + 1 coefficients; the polynomial has degree 2N).
    pub order: usize,
    /// The coefficients: Fourier `[a0, a1, b1, …, aN, bN]` of `sin`, `cos`
    /// of `nω(p − start)`; polynomial `[c0 … c2N]` of Chebyshev `Tₖ(t)`,
    /// `t = 2(p − start)/L − 1`.
    pub coefficients: Vec<f64>,
    /// First measured position (mm).
    pub start: f64,
    /// Measured travel L (mm).
    pub length: f64,
    /// Figures at the measured positions.
    pub figures: Figures,
    /// Residuals `v − v̂` at the measured positions.
    pub residuals: Vec<f64>,
}

/// The 2N + 1 basis functions of `series` at position `p`.
fn basis(series: Series, order: usize, start: f64, length: f64, p: f64) -> Vec<f64> {
    let count = 2 * order + 1;
    let mut row = Vec::with_capacity(count);
    match series {
        Series::Fourier => {
            let omega = std::f64::consts::TAU / length;
            row.push(1.0);
            for n in 1..=order {
                let phase = n as f64 * omega * (p - start);
                row.push(phase.sin());
                row.push(phase.cos());
            }
        }
        Series::Polynomial => {
            // Chebyshev recurrence T₀ = 1, T₁ = t, Tₖ₊₁ = 2t·Tₖ − Tₖ₋₁.
            let t = 2.0 * (p - start) / length - 1.0;
            let (mut previous, mut current) = (1.0, t);
            row.push(previous);
            for _ in 1..count {
                row.push(current);
                (previous, current) = (current, 2.0 * t * current - previous);
            }
        }
    }
    row
}

/// Least squares of one design: coefficients, residuals and hat values.
struct Solution {
    coefficients: Vec<f64>,
    residuals: Vec<f64>,
    hat: Vec<f64>,
}

/// Solve `A·c ≈ v` by the SVD of `A` with unit-norm columns; fails when its
/// condition number exceeds [`MAX_CONDITION`].
fn solve(design: DMatrix<f64>, values: &[f64], what: &str) -> Result<Solution> {
    let (n, k) = design.shape();
    let scales: Vec<f64> = (0..k).map(|j| design.column(j).norm()).collect();
    if scales
        .iter()
        .any(|s| s.is_nan() || *s <= ZERO_COLUMN * (n as f64).sqrt())
    {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::VanishingBasis {
                fit: what.to_string(),
            },
            condition: f64::INFINITY,
            limit: MAX_CONDITION,
        });
    }
    let mut scaled = design.clone();
    for (j, s) in scales.iter().enumerate() {
        scaled.column_mut(j).scale_mut(1.0 / s);
    }
    // Condition number from the singular values; the solution and the hat
    // values from the (backward-stable) Householder QR of the same matrix.
    let svd = SVD::try_new(
        scaled.clone(),
        false,
        false,
        5.0 * f64::EPSILON,
        SVD_ITERATIONS,
    )
    .ok_or(ProbeError::NotConverged {
        what: "singular value decomposition of a curve fit",
        iterations: SVD_ITERATIONS,
    })?;
    let largest = svd.singular_values.max();
    let smallest = svd.singular_values.min();
    let condition = if smallest > 0.0 {
        largest / smallest
    } else {
        f64::INFINITY
    };
    if condition.is_nan() || condition > MAX_CONDITION {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::CurveFit {
                fit: what.to_string(),
            },
            condition,
            limit: MAX_CONDITION,
        });
    }
    let qr = scaled.qr();
    let (q, r) = (qr.q(), qr.r());
    let b = DVector::from_column_slice(values);
    let x = r
        .solve_upper_triangular(&(q.transpose() * &b))
        .ok_or_else(|| Unsolvable::SingularFactor {
            fit: what.to_string(),
        })?;
    let coefficients = DVector::from_iterator(k, (0..k).map(|j| x[j] / scales[j]));
    let fitted = &design * &coefficients;
    let residuals = (0..n).map(|i| values[i] - fitted[i]).collect();
    let coefficients = coefficients.iter().copied().collect();
    let hat = (0..n).map(|i| q.row(i).norm_squared()).collect();
    Ok(Solution {
        coefficients,
        residuals,
        hat,
    })
}

/// Design matrix of `series` of order N at `positions`.
fn design(
    series: Series,
    order: usize,
    start: f64,
    length: f64,
    positions: &[f64],
) -> DMatrix<f64> {
    let count = 2 * order + 1;
    let mut a = DMatrix::zeros(positions.len(), count);
    for (i, &p) in positions.iter().enumerate() {
        for (j, v) in basis(series, order, start, length, p)
            .into_iter()
            .enumerate()
        {
            a[(i, j)] = v;
        }
    }
    a
}

impl SeriesFit {
    /// Least-squares fit of `series` of order N to `values` at `positions`
    /// (strictly increasing; the travel L is their span). `what` names the
    /// curve in errors. Needs at least 2N + 1 points that determine the
    /// coefficients; order 0 is the constant a0 (the mean of the values).
    pub fn fit(
        series: Series,
        order: usize,
        positions: &[f64],
        values: &[f64],
        what: &str,
    ) -> Result<SeriesFit> {
        let count = 2 * order + 1;
        if positions.len() < count {
            return Err(ProbeError::Volumetric(VolumetricFault::TooFewForOrder {
                fit: what.to_string(),
                points: positions.len(),
                coefficients: count,
                series,
                order,
            }));
        }
        let start = positions[0];
        let length = positions[positions.len() - 1] - start;
        let label = format!("{} fit of order {order} to {what}", series.name());
        let s = solve(
            design(series, order, start, length, positions),
            values,
            &label,
        )?;
        Ok(SeriesFit {
            series,
            order,
            figures: Figures::of(values, &s.residuals),
            coefficients: s.coefficients,
            start,
            length,
            residuals: s.residuals,
        })
    }

    /// The fit of the highest order N ≤ `max` that the positions allow: the
    /// first of `max`, `max − 1`, …, 1 with at least 2N + 1 points that
    /// determine its coefficients (condition number ≤ [`MAX_CONDITION`]),
    /// else order 0, the mean. Other faults are errors.
    pub fn highest(
        series: Series,
        max: usize,
        positions: &[f64],
        values: &[f64],
        what: &str,
    ) -> Result<SeriesFit> {
        for order in (1..=max).rev() {
            match SeriesFit::fit(series, order, positions, values, what) {
                Err(ProbeError::Volumetric(VolumetricFault::TooFewForOrder { .. }))
                | Err(ProbeError::IllConditioned { .. }) => continue,
                fit => return fit,
            }
        }
        SeriesFit::fit(series, 0, positions, values, what)
    }

    /// The series at `p`, which must lie in the measured travel.
    pub fn value(&self, p: f64) -> Option<f64> {
        let end = self.start + self.length;
        (p >= self.start && p <= end).then(|| {
            basis(self.series, self.order, self.start, self.length, p)
                .iter()
                .zip(&self.coefficients)
                .map(|(b, c)| b * c)
                .sum()
        })
    }
}

/// Leave-one-out scores of orders 1 ..= [`MAX_AUTO_ORDER`] (those with at
/// least [`POINTS_PER_COEFFICIENT`] points per coefficient that the points
/// determine) and the best order: the smallest RMSE, the lower order on a
/// tie. Fails when no order can be cross-validated.
pub(crate) fn choose_order(
    series: Series,
    positions: &[f64],
    values: &[f64],
    what: &str,
) -> Result<(usize, Vec<OrderScore>)> {
    let n = positions.len();
    let start = positions.first().copied().unwrap_or(0.0);
    let length = positions.last().copied().unwrap_or(0.0) - start;
    let mut scores = Vec::new();
    for order in 1..=MAX_AUTO_ORDER {
        if POINTS_PER_COEFFICIENT * (2 * order + 1) > n {
            break;
        }
        let label = format!("{} fit of order {order} to {what}", series.name());
        let Ok(s) = solve(
            design(series, order, start, length, positions),
            values,
            &label,
        ) else {
            continue;
        };
        if s.hat.iter().any(|h| *h >= HAT_LIMIT) {
            continue;
        }
        let press: f64 = s
            .residuals
            .iter()
            .zip(&s.hat)
            .map(|(r, h)| (r / (1.0 - h)).powi(2))
            .sum();
        scores.push(OrderScore {
            order,
            loo_rmse: (press / n as f64).sqrt(),
        });
    }
    let best = scores
        .iter()
        .fold(None::<OrderScore>, |best, s| match best {
            Some(b) if b.loo_rmse <= s.loo_rmse => Some(b),
            _ => Some(*s),
        })
        .ok_or_else(|| {
            ProbeError::Volumetric(VolumetricFault::NothingToCrossValidate {
                fit: what.to_string(),
                points: n,
                series,
            })
        })?;
    Ok((best.order, scores))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize, start: f64, step: f64) -> Vec<f64> {
        (0..n).map(|k| start + step * k as f64).collect()
    }

    #[test]
    fn a_series_in_the_model_is_fitted_exactly() {
        // 25 positions over 600 mm; a Fourier series of order 2 and a
        // polynomial of degree 4 come back to rounding with N = 2.
        let p = grid(25, 0.0, 25.0);
        let w = std::f64::consts::TAU / 600.0;
        let f = |q: f64| 0.3 + 0.1 * (w * q).sin() - 0.2 * (2.0 * w * q).cos();
        let v: Vec<f64> = p.iter().map(|&q| f(q)).collect();
        let fit = SeriesFit::fit(Series::Fourier, 2, &p, &v, "t").unwrap();
        assert!(fit.figures.sse < 1e-28, "{:?}", fit.figures);
        assert!((fit.value(312.5).unwrap() - f(312.5)).abs() < 1e-14);
        assert!(fit.value(600.1).is_none() && fit.value(-0.1).is_none());
        let g = |q: f64| 1e-3 * (q / 100.0 - 2.0).powi(4) - 0.01 * q / 100.0;
        let v: Vec<f64> = p.iter().map(|&q| g(q)).collect();
        let fit = SeriesFit::fit(Series::Polynomial, 2, &p, &v, "t").unwrap();
        assert!(fit.figures.emax < 1e-15, "{:?}", fit.figures);
        assert!((fit.value(1.0).unwrap() - g(1.0)).abs() < 1e-15);
    }

    #[test]
    fn figures_follow_their_definitions() {
        let v = [1.0, 2.0, 4.0, 3.0];
        let r = [0.5, -0.5, 0.0, 1.0];
        let f = Figures::of(&v, &r);
        // mean 2.5, SST = 2.25 + 0.25 + 2.25 + 0.25 = 5, SSE = 1.5.
        assert_eq!(f.sse, 1.5);
        assert!((f.r2.unwrap() - 0.7).abs() < 1e-15);
        assert!((f.rmse - (1.5f64 / 4.0).sqrt()).abs() < 1e-15);
        assert_eq!(f.emax, 1.0);
        assert_eq!(Figures::of(&[2.0, 2.0], &[0.0, 0.0]).r2, None);
    }

    #[test]
    fn too_few_points_and_lost_phases_are_errors() {
        let p = grid(6, 0.0, 1.0);
        let e = SeriesFit::fit(Series::Fourier, 3, &p, &[0.0; 6], "X ex").unwrap_err();
        assert!(e.to_string().contains("fewer than the 7"), "{e}");
        // 7 equally spaced points over one period: first and last share a phase.
        let p = grid(7, 0.0, 1.0);
        let e = SeriesFit::fit(Series::Fourier, 3, &p, &[0.0; 7], "X ex").unwrap_err();
        assert!(matches!(e, ProbeError::IllConditioned { .. }), "{e}");
        assert!(SeriesFit::fit(Series::Polynomial, 3, &p, &[0.0; 7], "X ex").is_ok());
    }

    #[test]
    fn the_highest_order_the_points_allow() {
        // 3 equally spaced points: a Fourier series of order 1 would see the
        // phases 0, π, 2π (= 0) — two — so order 0, the mean; the polynomial
        // of degree 2 interpolates them. 4 points: order 1 for both. 25
        // points: the asked order 3.
        let v3 = [1.0, 4.0, 2.0];
        let p = grid(3, -75.0, 75.0);
        let f = SeriesFit::highest(Series::Fourier, 3, &p, &v3, "t").unwrap();
        assert_eq!(f.order, 0);
        assert!((f.coefficients[0] - 7.0 / 3.0).abs() < 1e-15);
        assert!((f.value(0.0).unwrap() - 7.0 / 3.0).abs() < 1e-15);
        assert_eq!(f.figures.r2, Some(0.0));
        let f = SeriesFit::highest(Series::Polynomial, 3, &p, &v3, "t").unwrap();
        assert_eq!(f.order, 1);
        assert!(f.figures.emax < 1e-14 && (f.value(0.0).unwrap() - 4.0).abs() < 1e-14);
        let p = grid(4, 0.0, 50.0);
        for s in Series::BOTH {
            let f = SeriesFit::highest(s, 3, &p, &[0.0, 1.0, 3.0, 2.0], "t").unwrap();
            assert_eq!(f.order, 1, "{s:?}");
            let e = SeriesFit::fit(s, 3, &p, &[0.0; 4], "t").unwrap_err();
            assert!(e.to_string().contains("fewer than the 7"), "{e}");
        }
        let p = grid(25, 0.0, 25.0);
        let v: Vec<f64> = p.iter().map(|q| (q / 100.0).sin()).collect();
        assert_eq!(
            SeriesFit::highest(Series::Fourier, 3, &p, &v, "t")
                .unwrap()
                .order,
            3
        );
    }

    #[test]
    fn leave_one_out_scores_are_refits_without_the_point() {
        // PRESS from the hat values equals refitting n times with each point
        // left out; cross-validation rejects the underfitting order 1.
        let p = grid(31, 0.0, 10.0);
        let w = std::f64::consts::TAU / 300.0;
        // Pseudo-random noise from a linear congruential generator.
        let mut state = 12345u64;
        let mut noise = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let v: Vec<f64> = p
            .iter()
            .map(|&q| (w * q).sin() + 0.5 * (2.0 * w * q).cos() + 0.02 * noise())
            .collect();
        let (order, scores) = choose_order(Series::Fourier, &p, &v, "t").unwrap();
        for s in &scores {
            let mut press = 0.0;
            for leave in 0..p.len() {
                let (pk, vk): (Vec<f64>, Vec<f64>) = p
                    .iter()
                    .zip(&v)
                    .enumerate()
                    .filter(|(i, _)| *i != leave)
                    .map(|(_, (a, b))| (*a, *b))
                    .unzip();
                // The left-out fit keeps the full travel's ω and origin.
                let a = design(Series::Fourier, s.order, 0.0, 300.0, &pk);
                let c = solve(a, &vk, "t").unwrap().coefficients;
                let row = basis(Series::Fourier, s.order, 0.0, 300.0, p[leave]);
                let predicted: f64 = row.iter().zip(&c).map(|(b, c)| b * c).sum();
                press += (v[leave] - predicted).powi(2);
            }
            let brute = (press / p.len() as f64).sqrt();
            assert!(
                (brute - s.loo_rmse).abs() < 1e-12 * brute.max(1.0),
                "{s:?} vs {brute}"
            );
        }
        assert!(order >= 2, "{scores:?}");
        let best = scores.iter().find(|s| s.order == order).unwrap().loo_rmse;
        assert!(scores[0].loo_rmse > 10.0 * best, "{scores:?}");
        assert!(best < 0.02, "{scores:?}");
    }
}
