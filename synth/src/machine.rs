//! The simulated machine: where the table really is at a commanded position.
//!
//! The table is a rigid body carrying the spheres at positions s relative to
//! its reference point, which sits at the world origin at the nominal zero.
//! At a commanded position `n`, a table point s is at
//! `P = n + s + δ + ε × s` (first-order small-error transform, docs/methods.md),
//! where δ and ε add up the error motions of every axis that has a travel in
//! the procedure, each evaluated at its commanded coordinate:
//! positioning (+ reversal ±B/2 for the moving axis, by approach direction)
//! and two straightnesses in δ; roll, pitch, yaw in ε. The moving axis adds a
//! random repeatability offset per approach and every capture a small random
//! offset (vibration).

use formats::{Axis, Direction};
use geom::nalgebra::Vector3;
use geom::transform::SmallError;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

use crate::config::{AxisErrors, AxisProcedure, Config};
use crate::sensor::chacha_key;

/// µm → mm.
const UM: f64 = 1e-3;
/// µrad → rad.
const URAD: f64 = 1e-6;

/// Purpose tags of the random streams.
const APPROACH_PURPOSE: u64 = 2;
const CAPTURE_PURPOSE: u64 = 3;

/// The deterministic error motions of one axis at one commanded position,
/// in the units of the configuration (µm, µrad).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct AxisErrorValues {
    /// Positioning error of a + approach (µm).
    pub positioning_up_um: f64,
    /// Positioning error of a − approach (µm).
    pub positioning_down_um: f64,
    /// Straightness in the first other axis (X: Y; Y: Z) (µm).
    pub straightness_a_um: f64,
    /// Straightness in the second other axis (X: Z; Y: X) (µm).
    pub straightness_b_um: f64,
    /// Roll: rotation about the moving axis (µrad).
    pub roll_urad: f64,
    /// Pitch: rotation about the other horizontal axis (µrad).
    pub pitch_urad: f64,
    /// Yaw: rotation about Z (µrad).
    pub yaw_urad: f64,
}

/// The axis about which `axis` pitches (X: Y, Y: X).
pub(crate) fn pitch_axis(axis: Axis) -> Axis {
    match axis {
        Axis::X => Axis::Y,
        Axis::Y => Axis::X,
        Axis::Z => Axis::X,
    }
}

/// Values of the error curves of `axis` at commanded position `p`.
pub(crate) fn axis_error_values(
    errors: &AxisErrors,
    travel: &AxisProcedure,
    p: f64,
) -> AxisErrorValues {
    let (start, len) = (travel.start_mm, travel.length_mm);
    let pos = errors.positioning.value(p, start, len);
    let [a, b] = travel.axis.others();
    let straight = |o: Axis| {
        errors
            .straightness
            .get(o.name())
            .map_or(0.0, |c| c.value(p, start, len))
    };
    AxisErrorValues {
        positioning_up_um: pos + errors.reversal_um / 2.0,
        positioning_down_um: pos - errors.reversal_um / 2.0,
        straightness_a_um: straight(a),
        straightness_b_um: straight(b),
        roll_urad: errors.roll.value(p, start, len),
        pitch_urad: errors.pitch.value(p, start, len),
        yaw_urad: errors.yaw.value(p, start, len),
    }
}

impl AxisErrorValues {
    /// As a small-error transform, for a given approach direction (`None`: the
    /// mean of both, i.e. no reversal — for an axis standing still).
    pub(crate) fn small_error(&self, axis: Axis, direction: Option<Direction>) -> SmallError {
        let mut delta = Vector3::zeros();
        let mut epsilon = Vector3::zeros();
        delta[axis.index()] = match direction {
            Some(Direction::Up) => self.positioning_up_um,
            Some(Direction::Down) => self.positioning_down_um,
            None => 0.5 * (self.positioning_up_um + self.positioning_down_um),
        } * UM;
        let [a, b] = axis.others();
        delta[a.index()] += self.straightness_a_um * UM;
        delta[b.index()] += self.straightness_b_um * UM;
        epsilon[axis.index()] += self.roll_urad * URAD;
        epsilon[pitch_axis(axis).index()] += self.pitch_urad * URAD;
        epsilon[Axis::Z.index()] += self.yaw_urad * URAD;
        SmallError { delta, epsilon }
    }
}

/// Identity of one approach (one run's visit of one target in one direction).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct ApproachKey {
    /// Axis moved.
    pub axis: Axis,
    /// Line index.
    pub line: u32,
    /// Run number.
    pub run: u32,
    /// Direction.
    pub direction: Direction,
    /// Target index.
    pub target: u32,
}

impl ApproachKey {
    fn words(&self, seed: u64) -> [u64; 6] {
        [
            seed,
            self.axis.index() as u64,
            u64::from(self.line),
            u64::from(self.run),
            u64::from(self.direction == Direction::Up),
            u64::from(self.target),
        ]
    }
}

fn normals(key: [u8; 32]) -> Vector3<f64> {
    let mut rng = ChaCha8Rng::from_seed(key);
    let mut z = || -> f64 { StandardNormal.sample(&mut rng) };
    Vector3::new(z(), z(), z())
}

/// Random repeatability offset of one approach (mm): σ along the axis,
/// σ_perp across it.
pub(crate) fn approach_offset(seed: u64, key: &ApproachKey, errors: &AxisErrors) -> Vector3<f64> {
    let z = normals(chacha_key(APPROACH_PURPOSE, &key.words(seed)));
    let mut d = z * (errors.repeatability_perp_um * UM);
    d[key.axis.index()] = z[key.axis.index()] * errors.repeatability_um * UM;
    d
}

/// Random offset of one capture (mm), σ in every direction.
pub(crate) fn capture_offset(
    seed: u64,
    key: &ApproachKey,
    capture: u32,
    errors: &AxisErrors,
) -> Vector3<f64> {
    let w = key.words(seed);
    let z = normals(chacha_key(
        CAPTURE_PURPOSE,
        &[w[0], w[1], w[2], w[3], w[4], w[5], u64::from(capture)],
    ));
    z * (errors.capture_noise_um * UM)
}

/// Total table error at a commanded position `nominal` while `moving` is the
/// axis under test approaching in `direction`: the moving axis' errors with
/// reversal, plus every other axis with a travel at its commanded coordinate
/// (no reversal), plus the random offsets `random` (mm) in δ.
pub(crate) fn table_error(
    config: &Config,
    moving: Axis,
    direction: Direction,
    nominal: [f64; 3],
    random: Vector3<f64>,
) -> SmallError {
    let mut total = SmallError {
        delta: random,
        epsilon: Vector3::zeros(),
    };
    for travel in &config.procedure.axes {
        let Some(errors) = config.machine.axis(travel.axis) else {
            continue;
        };
        let v = axis_error_values(errors, travel, nominal[travel.axis.index()]);
        let dir = (travel.axis == moving).then_some(direction);
        total = total.compose(&v.small_error(travel.axis, dir));
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_map_to_the_right_components() {
        let v = AxisErrorValues {
            positioning_up_um: 2.0,
            positioning_down_um: -1.0,
            straightness_a_um: 3.0,
            straightness_b_um: 4.0,
            roll_urad: 5.0,
            pitch_urad: 6.0,
            yaw_urad: 7.0,
        };
        let e = v.small_error(Axis::Y, Some(Direction::Down));
        // Y axis: positioning in y, straightness in Z (a) and X (b); roll about Y, pitch about X.
        assert_eq!(e.delta, Vector3::new(4.0, -1.0, 3.0) * 1e-3);
        assert_eq!(e.epsilon, Vector3::new(6.0, 5.0, 7.0) * 1e-6);
        let e = v.small_error(Axis::X, None);
        assert_eq!(e.delta, Vector3::new(0.5, 3.0, 4.0) * 1e-3);
        assert_eq!(e.epsilon, Vector3::new(5.0, 6.0, 7.0) * 1e-6);
    }

    #[test]
    fn reversal_splits_by_direction() {
        let config = Config::default();
        let up = table_error(
            &config,
            Axis::X,
            Direction::Up,
            [12.0, 0.0, 0.0],
            Vector3::zeros(),
        );
        let down = table_error(
            &config,
            Axis::X,
            Direction::Down,
            [12.0, 0.0, 0.0],
            Vector3::zeros(),
        );
        assert!((up.delta.x - down.delta.x - config.machine.x.reversal_um * 1e-3).abs() < 1e-15);
        assert_eq!(up.epsilon, down.epsilon);
    }

    #[test]
    fn repeatability_draws_have_the_configured_spread() {
        let errors = Config::default().machine.x;
        let n = 4000;
        let mut s = Vector3::zeros();
        for t in 0..n {
            let key = ApproachKey {
                axis: Axis::X,
                line: 0,
                run: 1,
                direction: Direction::Up,
                target: t,
            };
            let d = approach_offset(9, &key, &errors);
            s += d.component_mul(&d);
        }
        let sd = (s / f64::from(n)).map(f64::sqrt) * 1e3;
        // 4000 draws: relative standard error of σ ≈ 1/√8000 ≈ 1.1 %; allow 5 %.
        assert!(
            (sd.x / errors.repeatability_um - 1.0).abs() < 0.05,
            "{sd:?}"
        );
        assert!(
            (sd.y / errors.repeatability_perp_um - 1.0).abs() < 0.05,
            "{sd:?}"
        );
    }
}
