//! ISO 230-2 (2014) §2–§4: positioning accuracy and repeatability of a
//! linear axis from the positional deviations `xᵢⱼ` of `n` approaches per
//! direction at each target (docs/methods.md, "Positioning error").
//!
//! Unit-agnostic: the figures come out in the unit of the deviations.
//!
//! Per target i and direction (↑ or ↓): `x̄ᵢ = mean_j xᵢⱼ`,
//! `sᵢ = √(Σ(xᵢⱼ − x̄ᵢ)²/(n − 1))`, `Rᵢ = 4sᵢ`; bidirectional:
//! `x̄ᵢ = (x̄ᵢ↑ + x̄ᵢ↓)/2`, `Bᵢ = x̄ᵢ↑ − x̄ᵢ↓`,
//! `Rᵢ = max(2sᵢ↑ + 2sᵢ↓ + |Bᵢ|, Rᵢ↑, Rᵢ↓)`. Axis figures:
//! `E↑ = max x̄ᵢ↑ − min x̄ᵢ↑`, `A↑ = max(x̄ᵢ↑ + 2sᵢ↑) − min(x̄ᵢ↑ − 2sᵢ↑)`,
//! `R↑ = max Rᵢ↑` (same for ↓); `B = max|Bᵢ|`, `B̄ = mean Bᵢ`, `R = max Rᵢ`,
//! `E = max(x̄↑, x̄↓) − min(x̄↑, x̄↓)`, `M = max x̄ᵢ − min x̄ᵢ`,
//! `A = max(x̄ + 2s) − min(x̄ − 2s)` over both directions.

use crate::error::Iso230_2Problem;
use crate::{EvaluateError, Result};

/// The positional deviations at one target: one value per approach (run),
/// the captures of an approach already averaged.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TargetDeviations {
    /// Deviations `xᵢⱼ↑` of the ↑ approaches (empty when ↑ was not measured).
    pub up: Vec<f64>,
    /// Deviations `xᵢⱼ↓` of the ↓ approaches (empty when ↓ was not measured).
    pub down: Vec<f64>,
}

/// Mean and standard uncertainty of one direction at one target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionStats {
    /// Mean unidirectional positional deviation `x̄ᵢ`.
    pub mean: f64,
    /// Estimator of the unidirectional standard uncertainty `sᵢ` (n − 1 divisor).
    pub s: f64,
}

impl DirectionStats {
    /// Unidirectional repeatability `Rᵢ = 4sᵢ`.
    pub fn repeatability(&self) -> f64 {
        4.0 * self.s
    }
}

/// The per-target figures.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TargetFigures {
    /// ↑ statistics, when ↑ was measured.
    pub up: Option<DirectionStats>,
    /// ↓ statistics, when ↓ was measured.
    pub down: Option<DirectionStats>,
    /// Both-direction figures, when both were measured.
    pub bidirectional: Option<TargetBidirectional>,
}

/// Per-target figures that need both directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetBidirectional {
    /// Mean bidirectional positional deviation `x̄ᵢ = (x̄ᵢ↑ + x̄ᵢ↓)/2`.
    pub mean: f64,
    /// Reversal value `Bᵢ = x̄ᵢ↑ − x̄ᵢ↓`.
    pub reversal: f64,
    /// Bidirectional repeatability `Rᵢ = max(2sᵢ↑ + 2sᵢ↓ + |Bᵢ|, Rᵢ↑, Rᵢ↓)`.
    pub repeatability: f64,
}

/// Unidirectional axis figures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unidirectional {
    /// Systematic positional deviation `E = max x̄ᵢ − min x̄ᵢ`.
    pub e: f64,
    /// Repeatability `R = max 4sᵢ`.
    pub r: f64,
    /// Accuracy `A = max(x̄ᵢ + 2sᵢ) − min(x̄ᵢ − 2sᵢ)`.
    pub a: f64,
}

/// Bidirectional axis figures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bidirectional {
    /// Reversal value `B = max |Bᵢ|`.
    pub b: f64,
    /// Mean reversal value `B̄ = mean Bᵢ`.
    pub b_mean: f64,
    /// Repeatability `R = max Rᵢ`.
    pub r: f64,
    /// Systematic positional deviation `E = max(x̄ᵢ↑, x̄ᵢ↓) − min(x̄ᵢ↑, x̄ᵢ↓)`.
    pub e: f64,
    /// Mean bidirectional positional deviation `M = max x̄ᵢ − min x̄ᵢ`.
    pub m: f64,
    /// Accuracy `A = max(x̄ᵢ↑ + 2sᵢ↑, x̄ᵢ↓ + 2sᵢ↓) − min(x̄ᵢ↑ − 2sᵢ↑, x̄ᵢ↓ − 2sᵢ↓)`.
    pub a: f64,
}

/// All ISO 230-2 figures of one axis (line).
#[derive(Debug, Clone, PartialEq)]
pub struct Iso230_2 {
    /// Per-target figures, in the order given.
    pub targets: Vec<TargetFigures>,
    /// ↑ figures, when ↑ was measured.
    pub up: Option<Unidirectional>,
    /// ↓ figures, when ↓ was measured.
    pub down: Option<Unidirectional>,
    /// Bidirectional figures, when both directions were measured.
    pub bidirectional: Option<Bidirectional>,
}

/// Number of approaches per direction ISO 230-2 needs at each target (at
/// least; the standard asks for 5, a sample standard deviation for 2).
pub const MIN_RUNS: usize = 2;

/// Mean and sample standard deviation of one direction's deviations.
fn direction_stats(
    values: &[f64],
    target: usize,
    direction: &'static str,
) -> Result<Option<DirectionStats>> {
    if values.is_empty() {
        return Ok(None);
    }
    if values.len() < MIN_RUNS {
        return Err(EvaluateError::Iso230_2(Iso230_2Problem::TooFewRuns {
            target,
            direction,
            runs: values.len(),
            needed: MIN_RUNS,
        }));
    }
    if let Some(v) = values.iter().find(|v| !v.is_finite()) {
        return Err(EvaluateError::Iso230_2(Iso230_2Problem::NonFinite {
            target,
            value: *v,
        }));
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let ss: f64 = values.iter().map(|v| (v - mean) * (v - mean)).sum();
    Ok(Some(DirectionStats {
        mean,
        s: (ss / (n - 1.0)).sqrt(),
    }))
}

/// `max − min` of the upper and lower ends: `max(hi) − min(lo)`.
fn spread(pairs: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (lo, hi) = pairs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (l, h)| {
        (lo.min(l), hi.max(h))
    });
    hi - lo
}

/// Unidirectional figures E, R, A from the per-target statistics of one direction.
fn unidirectional(stats: &[DirectionStats]) -> Unidirectional {
    Unidirectional {
        e: spread(stats.iter().map(|s| (s.mean, s.mean))),
        r: stats
            .iter()
            .map(DirectionStats::repeatability)
            .fold(0.0, f64::max),
        a: spread(
            stats
                .iter()
                .map(|s| (s.mean - 2.0 * s.s, s.mean + 2.0 * s.s)),
        ),
    }
}

/// Evaluate ISO 230-2 from the deviations at each target (ISO 230-2:2014
/// clauses 2.1–2.23 and 4): every target must have the same directions, each
/// with at least [`MIN_RUNS`] approaches.
pub fn iso230_2(targets: &[TargetDeviations]) -> Result<Iso230_2> {
    let Some(first) = targets.first() else {
        return Err(EvaluateError::Iso230_2(Iso230_2Problem::NoTargets));
    };
    let (has_up, has_down) = (!first.up.is_empty(), !first.down.is_empty());
    if !has_up && !has_down {
        return Err(EvaluateError::Iso230_2(Iso230_2Problem::NoApproaches));
    }
    let mut figures = Vec::with_capacity(targets.len());
    for (i, t) in targets.iter().enumerate() {
        if t.up.is_empty() == has_up || t.down.is_empty() == has_down {
            return Err(EvaluateError::Iso230_2(Iso230_2Problem::MixedDirections {
                target: i,
                has: directions(!t.up.is_empty(), !t.down.is_empty()),
                first: directions(has_up, has_down),
            }));
        }
        let up = direction_stats(&t.up, i, "↑")?;
        let down = direction_stats(&t.down, i, "↓")?;
        let bidirectional = match (up, down) {
            (Some(u), Some(d)) => {
                let reversal = u.mean - d.mean;
                Some(TargetBidirectional {
                    mean: (u.mean + d.mean) / 2.0,
                    reversal,
                    repeatability: (2.0 * u.s + 2.0 * d.s + reversal.abs())
                        .max(u.repeatability())
                        .max(d.repeatability()),
                })
            }
            _ => None,
        };
        figures.push(TargetFigures {
            up,
            down,
            bidirectional,
        });
    }
    let ups: Vec<DirectionStats> = figures.iter().filter_map(|f| f.up).collect();
    let downs: Vec<DirectionStats> = figures.iter().filter_map(|f| f.down).collect();
    let bis: Vec<TargetBidirectional> = figures.iter().filter_map(|f| f.bidirectional).collect();
    let bidirectional = (has_up && has_down).then(|| {
        let both = || ups.iter().chain(&downs);
        Bidirectional {
            b: bis.iter().map(|b| b.reversal.abs()).fold(0.0, f64::max),
            b_mean: bis.iter().map(|b| b.reversal).sum::<f64>() / bis.len() as f64,
            r: bis.iter().map(|b| b.repeatability).fold(0.0, f64::max),
            e: spread(both().map(|s| (s.mean, s.mean))),
            m: spread(bis.iter().map(|b| (b.mean, b.mean))),
            a: spread(both().map(|s| (s.mean - 2.0 * s.s, s.mean + 2.0 * s.s))),
        }
    });
    Ok(Iso230_2 {
        up: has_up.then(|| unidirectional(&ups)),
        down: has_down.then(|| unidirectional(&downs)),
        bidirectional,
        targets: figures,
    })
}

/// "↑ and ↓", "↑ only", "↓ only" or "neither direction".
fn directions(up: bool, down: bool) -> &'static str {
    match (up, down) {
        (true, true) => "↑ and ↓",
        (true, false) => "↑ only",
        (false, true) => "↓ only",
        (false, false) => "neither direction",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(up: &[f64], down: &[f64]) -> TargetDeviations {
        TargetDeviations {
            up: up.to_vec(),
            down: down.to_vec(),
        }
    }

    #[test]
    fn two_targets_by_hand() {
        // Target 0: ↑ {0, 2} (x̄ 1, s √2), ↓ {−1, −1} (x̄ −1, s 0), B 2.
        // Target 1: ↑ {4, 4}, ↓ {3, 5} (x̄ 4, s √2), B 0.
        let r = iso230_2(&[t(&[0.0, 2.0], &[-1.0, -1.0]), t(&[4.0, 4.0], &[3.0, 5.0])]).unwrap();
        let s2 = 2.0_f64.sqrt();
        let bi = r.bidirectional.unwrap();
        assert_eq!((bi.b, bi.b_mean), (2.0, 1.0));
        // R₀ = max(2√2 + 0 + 2, 4√2, 0) = 4√2, R₁ = max(2√2, 0, 4√2) = 4√2.
        assert!((bi.r - 4.0 * s2).abs() < 1e-15, "{}", bi.r);
        assert_eq!((bi.e, bi.m), (5.0, 4.0));
        // max(x̄ + 2s) = 4 + 2√2 (↓ at 1), min(x̄ − 2s) = 1 − 2√2 (↑ at 0).
        assert!((bi.a - (3.0 + 4.0 * s2)).abs() < 1e-14, "{}", bi.a);
        let t0 = r.targets[0].bidirectional.unwrap();
        assert_eq!((t0.mean, t0.reversal), (0.0, 2.0));
        let up = r.up.unwrap();
        assert_eq!(up.e, 3.0);
        assert!((up.r - 4.0 * s2).abs() < 1e-15);
        assert!((up.a - (4.0 - (1.0 - 2.0 * s2))).abs() < 1e-15);
    }

    #[test]
    fn one_direction_gives_unidirectional_figures_only() {
        let r = iso230_2(&[t(&[], &[1.0, 2.0]), t(&[], &[3.0, 3.0])]).unwrap();
        assert!(r.up.is_none() && r.bidirectional.is_none());
        assert_eq!(r.down.unwrap().e, 1.5);
    }

    #[test]
    fn too_few_runs_and_mismatched_directions_are_errors() {
        let e = iso230_2(&[t(&[1.0], &[1.0, 2.0])]).unwrap_err().to_string();
        assert!(e.contains("target 0") && e.contains("at least 2"), "{e}");
        let e = iso230_2(&[t(&[1.0, 2.0], &[1.0, 2.0]), t(&[1.0, 2.0], &[])])
            .unwrap_err()
            .to_string();
        assert!(e.contains("target 1") && e.contains("↑ only"), "{e}");
        assert!(iso230_2(&[]).is_err());
    }
}
