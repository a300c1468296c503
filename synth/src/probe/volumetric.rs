//! Check data of the 21-error volumetric model (docs/probe-volumetric.md) with known
//! truth: the eighteen error motions of a machine as a 6D interferometer
//! reports them (`errors.csv`, with measurement noise and, in the
//! straightness curves, the axis misalignment the instrument sees), the
//! set-up (`setup.json`: squareness, chain, tool offset, a circle that keeps
//! every carriage inside its travel), carriage positions (`at.csv`), and
//! `truth.json`: the true curves in the conventions of §5 at the measured
//! positions, the straightness lines the model must remove, the reversal.
//!
//! Each true error motion is a smooth wavy function of the carriage
//! position q on a travel [0, L]:
//! `e(q) = A·(b·(1 − u²) + Σ_{k=1..3} c_k·sin(2π·m_k·q/L + φ_k))`,
//! `u = 2q/L − 1`, with random b, c_k, φ_k and non-integer cycle counts m_k
//! (so neither series fits it exactly), A the translation or rotation
//! amplitude. Straightness motions also carry a line (the misalignment),
//! which §5 assigns to squareness: the truth gives the curve without its
//! least-squares line and the slope that line has. The generator does not
//! call the volumetric solver.

use formats::Axis;
use formats::probe::volumetric::{AtRow, CircleJson, ErrorRow, SetupJson, Squareness};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal, StandardUniform};
use serde::Serialize;

use crate::sensor::chacha_key;
use crate::{Result, SynthError};

/// µm → mm.
const UM: f64 = 1e-3;
/// µrad → rad.
const URAD: f64 = 1e-6;
/// Purpose tags of the random streams.
const SHAPE_PURPOSE: u64 = 40;
const NOISE_PURPOSE: u64 = 41;
const AT_PURPOSE: u64 = 42;
/// Waves per error motion.
const WAVES: usize = 3;

/// Configuration of the generator, with the defaults of [`Default`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VolumetricConfig {
    /// Seed of the curves, the noise and the positions. Default 4.
    pub seed: u64,
    /// Kinematic chain. Default `WXYFZT` (the source's).
    pub chain: String,
    /// Travel of X, Y, Z from 0 (mm). Default 600, 400, 300.
    pub travel_mm: [f64; 3],
    /// Step between measured positions (mm). Default 25, 20, 10.
    pub step_mm: [f64; 3],
    /// Squareness EC0Y, EB0Z, EA0Z (rad). Default 18, −11, 7 µrad.
    pub squareness_rad: [f64; 3],
    /// Tool offset (mm). Default (0, 0, −100).
    pub tool_mm: [f64; 3],
    /// Radius of the circular test (mm). Default 100.
    pub circle_radius_mm: f64,
    /// Amplitude A of positioning and straightness (µm). Default 3.
    pub translation_um: f64,
    /// Amplitude A of roll, pitch and yaw (µrad). Default 6.
    pub rotation_urad: f64,
    /// Largest misalignment slope in a straightness curve (µrad). Default 20.
    pub misalignment_urad: f64,
    /// Reversal value B of each axis (µm): `positioning_up = ex + B/2`,
    /// `positioning_down = ex − B/2`. Default 2.
    pub reversal_um: f64,
    /// Standard deviation of the noise on translations (µm). Default 0.05.
    pub noise_um: f64,
    /// Standard deviation of the noise on rotations (µrad). Default 0.05.
    pub noise_urad: f64,
    /// Carriage positions in `at.csv`. Default 20.
    pub at_points: usize,
}

impl Default for VolumetricConfig {
    fn default() -> Self {
        Self {
            seed: 4,
            chain: "WXYFZT".into(),
            travel_mm: [600.0, 400.0, 300.0],
            step_mm: [25.0, 20.0, 10.0],
            squareness_rad: [18e-6, -11e-6, 7e-6],
            tool_mm: [0.0, 0.0, -100.0],
            circle_radius_mm: 100.0,
            translation_um: 3.0,
            rotation_urad: 6.0,
            misalignment_urad: 20.0,
            reversal_um: 2.0,
            noise_um: 0.05,
            noise_urad: 0.05,
            at_points: 20,
        }
    }
}

/// One true error motion: `A·(b·(1 − u²) + Σ c_k sin(2π m_k q/L + φ_k))`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Shape {
    /// Amplitude A (mm or rad).
    pub amplitude: f64,
    /// Bow b.
    pub bow: f64,
    /// Wave amplitudes c_k.
    pub waves: Vec<f64>,
    /// Cycles m_k over the travel.
    pub cycles: Vec<f64>,
    /// Phases φ_k (rad).
    pub phases: Vec<f64>,
}

impl Shape {
    /// Value at q on a travel L (mm or rad).
    pub fn value(&self, q: f64, travel: f64) -> f64 {
        let u = 2.0 * q / travel - 1.0;
        let waves: f64 = self
            .waves
            .iter()
            .zip(&self.cycles)
            .zip(&self.phases)
            .map(|((c, m), p)| c * (std::f64::consts::TAU * m * q / travel + p).sin())
            .sum();
        self.amplitude * (self.bow * (1.0 - u * u) + waves)
    }
}

/// The truth of one axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisTruth {
    /// The axis.
    pub axis: Axis,
    /// Measured positions (mm).
    pub positions_mm: Vec<f64>,
    /// The six true motions at the positions in §5 form (straightness
    /// without its least-squares line): `ex`, `ey`, `ez` (mm), `ea`, `eb`, `ec` (rad).
    pub curves: std::collections::BTreeMap<String, Vec<f64>>,
    /// Per straightness, the slope of the least-squares line of the
    /// noise-free reported curve (mm/mm): what the model removes.
    pub straightness_slopes: std::collections::BTreeMap<String, f64>,
    /// The true shapes (before the straightness lines were removed).
    pub shapes: std::collections::BTreeMap<String, Shape>,
}

/// `truth.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VolumetricTruth {
    /// The configuration the data came from.
    pub config: VolumetricConfig,
    /// Per axis.
    pub axes: Vec<AxisTruth>,
}

/// What the generator writes.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumetricData {
    /// `errors.csv` rows.
    pub errors: Vec<ErrorRow>,
    /// `at.csv` rows.
    pub at: Vec<AtRow>,
    /// `setup.json`.
    pub setup: SetupJson,
    /// `truth.json`.
    pub truth: VolumetricTruth,
}

fn rng(seed: u64, purpose: u64, words: &[u64]) -> ChaCha8Rng {
    let mut w = vec![seed];
    w.extend_from_slice(words);
    ChaCha8Rng::from_seed(chacha_key(purpose, &w))
}

fn normal(r: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(r)
}

fn uniform(r: &mut ChaCha8Rng) -> f64 {
    StandardUniform.sample(r)
}

/// The side (−1 workpiece, +1 tool) of each axis in a chain string, 0 when
/// absent; the chain must be `W…F…T` with each axis at most once.
fn sides(chain: &str) -> Result<[f64; 3]> {
    let c = chain.trim().to_uppercase();
    let f = c.find('F');
    let ok = c.starts_with('W')
        && c.ends_with('T')
        && f.is_some()
        && c.chars().all(|l| "WXYZFT".contains(l))
        && ["W", "F", "T", "X", "Y", "Z"]
            .iter()
            .all(|l| c.matches(l).count() <= 1);
    let Some(f) = f.filter(|_| ok) else {
        return Err(SynthError::config(format!(
            "chain '{chain}': expected W, the workpiece-side axes, F, the tool-side axes, T"
        )));
    };
    let mut s = [0.0; 3];
    for (k, l) in c.chars().enumerate() {
        let i = match l {
            'X' => 0,
            'Y' => 1,
            'Z' => 2,
            _ => continue,
        };
        s[i] = if k < f { -1.0 } else { 1.0 };
    }
    Ok(s)
}

/// Slope and intercept of the least-squares line `v = k·q + b`.
fn line(q: &[f64], v: &[f64]) -> (f64, f64) {
    let n = q.len() as f64;
    let (mq, mv) = (q.iter().sum::<f64>() / n, v.iter().sum::<f64>() / n);
    let sqq: f64 = q.iter().map(|x| (x - mq) * (x - mq)).sum();
    let sqv: f64 = q.iter().zip(v).map(|(x, y)| (x - mq) * (y - mv)).sum();
    let k = sqv / sqq;
    (k, mv - k * mq)
}

/// Generate the data of `config`.
pub fn generate(config: &VolumetricConfig) -> Result<VolumetricData> {
    let side = sides(&config.chain)?;
    for i in 0..3 {
        let (l, s) = (config.travel_mm[i], config.step_mm[i]);
        if !(l > 0.0 && s > 0.0 && s <= l && (l / s - (l / s).round()).abs() < 1e-9) {
            return Err(SynthError::config(format!(
                "travel {l} mm and step {s} mm of axis {}: the step must divide the travel",
                ["X", "Y", "Z"][i]
            )));
        }
    }
    let r = config.circle_radius_mm;
    if !(r > 0.0 && 2.0 * r < config.travel_mm[0].min(config.travel_mm[1])) {
        return Err(SynthError::config(format!(
            "circle radius {r} mm: the circle must fit the X and Y travels"
        )));
    }
    let mut errors = Vec::new();
    let mut axes = Vec::new();
    for (i, axis) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
        let travel = config.travel_mm[i];
        let n = (travel / config.step_mm[i]).round() as usize + 1;
        let q: Vec<f64> = (0..n).map(|k| config.step_mm[i] * k as f64).collect();
        let mut shape_rng = rng(config.seed, SHAPE_PURPOSE, &[i as u64]);
        let mut noise_rng = rng(config.seed, NOISE_PURPOSE, &[i as u64]);
        let mut reported: Vec<Vec<f64>> = Vec::new();
        let mut curves = std::collections::BTreeMap::new();
        let mut slopes = std::collections::BTreeMap::new();
        let mut shapes = std::collections::BTreeMap::new();
        for (m, name) in ["ex", "ey", "ez", "ea", "eb", "ec"].into_iter().enumerate() {
            let rotation = m >= 3;
            let shape = Shape {
                amplitude: if rotation {
                    config.rotation_urad * URAD
                } else {
                    config.translation_um * UM
                },
                bow: 0.5 * normal(&mut shape_rng),
                waves: (1..=WAVES)
                    .map(|k| 0.5 * normal(&mut shape_rng) / k as f64)
                    .collect(),
                cycles: (1..=WAVES)
                    .map(|k| k as f64 + 0.3 + 0.8 * uniform(&mut shape_rng))
                    .collect(),
                phases: (0..WAVES)
                    .map(|_| std::f64::consts::TAU * uniform(&mut shape_rng))
                    .collect(),
            };
            let truth: Vec<f64> = q.iter().map(|&x| shape.value(x, travel)).collect();
            let straightness = !rotation && m != i;
            let (curve, values) = if straightness {
                let tilt = config.misalignment_urad * URAD * (2.0 * uniform(&mut shape_rng) - 1.0);
                let tilted: Vec<f64> = q.iter().zip(&truth).map(|(x, v)| v + tilt * x).collect();
                let (k, b) = line(&q, &tilted);
                slopes.insert(name.to_string(), k);
                let curve: Vec<f64> = q
                    .iter()
                    .zip(&tilted)
                    .map(|(x, v)| v - (k * x + b))
                    .collect();
                (curve, tilted)
            } else {
                (truth.clone(), truth)
            };
            let sigma = if rotation {
                config.noise_urad * URAD
            } else {
                config.noise_um * UM
            };
            reported.push(
                values
                    .iter()
                    .map(|v| v + sigma * normal(&mut noise_rng))
                    .collect(),
            );
            curves.insert(name.to_string(), curve);
            shapes.insert(name.to_string(), shape);
        }
        let half_b = 0.5 * config.reversal_um * UM;
        for k in 0..n {
            errors.push(ErrorRow {
                axis: axis.name().to_string(),
                position: q[k],
                ex: reported[0][k],
                ey: reported[1][k],
                ez: reported[2][k],
                ea: reported[3][k],
                eb: reported[4][k],
                ec: reported[5][k],
                positioning_up: Some(reported[i][k] + half_b),
                positioning_down: Some(reported[i][k] - half_b),
            });
        }
        axes.push(AxisTruth {
            axis,
            positions_mm: q,
            curves,
            straightness_slopes: slopes,
            shapes,
        });
    }
    // The circle: every carriage in the chain at mid-travel at its centre.
    let t = config.tool_mm;
    let centre: [f64; 3] = std::array::from_fn(|i| t[i] + side[i] * config.travel_mm[i] / 2.0);
    let mut at_rng = rng(config.seed, AT_PURPOSE, &[]);
    let at = (0..config.at_points)
        .map(|_| {
            let mut p = [0.0; 3];
            for i in 0..3 {
                if side[i] != 0.0 {
                    // Whole µm, inside the travel.
                    p[i] = (uniform(&mut at_rng) * config.travel_mm[i] * 1e3).round() / 1e3;
                }
            }
            AtRow {
                x: p[0],
                y: p[1],
                z: p[2],
            }
        })
        .collect();
    let s = config.squareness_rad;
    Ok(VolumetricData {
        errors,
        at,
        setup: SetupJson {
            squareness_rad: Squareness {
                ec0y: s[0],
                eb0z: s[1],
                ea0z: s[2],
            },
            chain: config.chain.trim().to_uppercase(),
            tool_mm: t,
            circle: CircleJson {
                centre_mm: centre,
                radius_mm: r,
            },
        },
        truth: VolumetricTruth {
            config: config.clone(),
            axes,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_consistent() {
        let c = VolumetricConfig::default();
        let a = generate(&c).unwrap_or_else(|e| panic!("{e}"));
        let b = generate(&c).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(a, b);
        assert_eq!(a.errors.len(), 25 + 21 + 31);
        assert_eq!(a.setup.circle.centre_mm, [-300.0, -200.0, 50.0]);
        // Straightness truth has no least-squares line left.
        let x = &a.truth.axes[0];
        let (k, b0) = line(&x.positions_mm, &x.curves["ey"]);
        assert!(k.abs() < 1e-15 && b0.abs() < 1e-15, "{k} {b0}");
        // The reported positioning of X is the truth plus noise of 0.05 µm.
        let worst = a
            .errors
            .iter()
            .zip(&x.curves["ex"])
            .map(|(r, t)| (r.ex - t).abs())
            .fold(0.0, f64::max);
        assert!(worst > 0.0 && worst < 5.0 * c.noise_um * UM, "{worst}");
        let other = generate(&VolumetricConfig {
            chain: "WYFXZT".into(),
            ..c.clone()
        })
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(other.setup.circle.centre_mm, [300.0, -200.0, 50.0]);
        assert!(
            generate(&VolumetricConfig {
                chain: "WXYZ".into(),
                ..c
            })
            .is_err()
        );
    }
}
