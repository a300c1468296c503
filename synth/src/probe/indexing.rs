//! Check data for the probe-head indexing method (docs/probe-indexing.md) with known
//! truth: the reference-sphere centre a CMM reports at every indexed (A, B)
//! position of a PH10-type head, and the injected indexing errors.
//!
//! The head: B axis along its z, A axis along its y, the stylus ball at
//! length L from the axes' intersection O. At (A, B) the direction from O
//! that turns with the head is `u = M·Rz(B + εB(B))·Ry(A + εA(A))·ẑ`, M the
//! mounting of the head on the ram (small rotations about the machine's X, Y,
//! Z), εA and εB the per-detent indexing errors. The CMM, with one probe
//! offset for all positions, reports the fixed sphere at `O + L·u` (it is
//! `const − t`, t = −L·u the head-centre-to-ball vector) plus noise.
//!
//! The zero detents are the datum: εA(0°) = 0 (the stylus lies on the B axis
//! at A = 0°) and εB(0°) = 0 (the B = 0° sweep fixes the frame's x–z plane),
//! so the §3 construction recovers ΔθA = εA(A) and ΔθB = εB(B) up to noise.
//! The generator never calls the method.

use geom::nalgebra::{Point3, Rotation3, Vector3};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use formats::probe::indexing::{CentreRow, IndexingTruth, TRUTH_COLUMNS, TrueHead};

use crate::Result;
use crate::config::{bad, finite, non_negative, parse_toml, positive};

/// Arc-seconds per degree.
const ARCSEC_PER_DEG: f64 = 3600.0;
/// Micrometres per millimetre.
const UM_PER_MM: f64 = 1000.0;
/// Slack (degrees) when counting detents in a range or a turn.
const STEP_SLACK_DEG: f64 = 1e-9;

/// The documented default configuration (a PH10 with a 117 mm stylus, the
/// seed's 720 positions), as `trinocular synth probe indexing --print-config`
/// prints it. Parses to [`IndexingConfig::default`].
pub const DEFAULT_TOML: &str = r#"# trinocular synth probe indexing: a probe head with known indexing errors.
# Angles in degrees (_deg) or arc-seconds (_arcsec), lengths in mm (_mm) or µm (_um).

# Seed of every random draw (detent errors, noise); same seed, same files.
seed = 2

# A detents: 0, a_step_deg, … up to a_max_deg (a PH10: 0…105° in 7.5° steps).
a_max_deg = 105.0
a_step_deg = 7.5
# B detents: the multiples of b_step_deg in [−180°, 180°); 360 / b_step_deg must be whole.
b_step_deg = 7.5

# Head-centre-to-stylus-ball length: the radius of the sphere of centres.
stylus_mm = 117.0
# Where the CMM reports the head's rotation centre O (mm, machine frame).
rotation_centre_mm = [412.45, -218.65, -422.2]

# Mounting of the head on the ram: small rotations about the machine's X, Y, Z.
mount_x_deg = 0.12
mount_y_deg = -0.075
mount_z_deg = 0.17

# Noise of every reported coordinate (µm, standard deviation).
noise_um = 0.3

# Per-detent A errors: random_arcsec (σ of an independent error per detent)
# plus gravity_arcsec·sin A (the stylus's moment); or values_arcsec, one per
# A detent from A = 0°, which replaces both (its first value must be 0).
[a_errors]
random_arcsec = 1.0
gravity_arcsec = 0.8
values_arcsec = []

# Per-detent B errors: random_arcsec plus once_per_turn_arcsec·sin(B + phase_deg)
# (an eccentric coupling); or values_arcsec, one per B detent from the first
# at or above −180°. The error at B = 0° is subtracted from all (the datum).
[b_errors]
random_arcsec = 0.8
once_per_turn_arcsec = 1.2
phase_deg = 30.0
values_arcsec = []
"#;

/// Everything the generator needs (defaults: [`DEFAULT_TOML`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IndexingConfig {
    /// Seed of every random draw.
    pub seed: u64,
    /// Largest A (degrees, < 180).
    pub a_max_deg: f64,
    /// A step (degrees).
    pub a_step_deg: f64,
    /// B step (degrees; 360 / step whole, at least 3 detents).
    pub b_step_deg: f64,
    /// Head-centre-to-stylus-ball length (mm).
    pub stylus_mm: f64,
    /// Rotation centre O as the CMM reports it (mm).
    pub rotation_centre_mm: [f64; 3],
    /// Mounting rotation about the machine's X (degrees).
    pub mount_x_deg: f64,
    /// Mounting rotation about the machine's Y (degrees).
    pub mount_y_deg: f64,
    /// Mounting rotation about the machine's Z (degrees).
    pub mount_z_deg: f64,
    /// Noise of every reported coordinate (µm, standard deviation).
    pub noise_um: f64,
    /// A detent errors.
    pub a_errors: AErrors,
    /// B detent errors.
    pub b_errors: BErrors,
}

/// Per-detent A errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AErrors {
    /// σ of an independent error per detent (arc-seconds).
    pub random_arcsec: f64,
    /// Amplitude of `sin A` (arc-seconds): the stylus's moment under gravity.
    pub gravity_arcsec: f64,
    /// Explicit errors, one per A detent from 0° (the first must be 0);
    /// when given they replace the two terms above.
    pub values_arcsec: Vec<f64>,
}

/// Per-detent B errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BErrors {
    /// σ of an independent error per detent (arc-seconds).
    pub random_arcsec: f64,
    /// Amplitude of `sin(B + phase)` (arc-seconds): an eccentric coupling.
    pub once_per_turn_arcsec: f64,
    /// Phase of the once-per-turn term (degrees).
    pub phase_deg: f64,
    /// Explicit errors, one per B detent from the first at or above −180°;
    /// when given they replace the terms above. The B = 0° value is
    /// subtracted from all.
    pub values_arcsec: Vec<f64>,
}

impl Default for IndexingConfig {
    fn default() -> Self {
        Self {
            seed: 2,
            a_max_deg: 105.0,
            a_step_deg: 7.5,
            b_step_deg: 7.5,
            stylus_mm: 117.0,
            rotation_centre_mm: [412.45, -218.65, -422.2],
            mount_x_deg: 0.12,
            mount_y_deg: -0.075,
            mount_z_deg: 0.17,
            noise_um: 0.3,
            a_errors: AErrors::default(),
            b_errors: BErrors::default(),
        }
    }
}

impl Default for AErrors {
    fn default() -> Self {
        Self {
            random_arcsec: 1.0,
            gravity_arcsec: 0.8,
            values_arcsec: Vec::new(),
        }
    }
}

impl Default for BErrors {
    fn default() -> Self {
        Self {
            random_arcsec: 0.8,
            once_per_turn_arcsec: 1.2,
            phase_deg: 30.0,
            values_arcsec: Vec::new(),
        }
    }
}

/// The generated files: `centres.csv` rows and `truth.json`.
#[derive(Debug, Clone, PartialEq)]
pub struct Generated {
    /// One row per position: A ascending, then B ascending.
    pub centres: Vec<CentreRow>,
    /// The injected errors per position (same order) and the true head.
    pub truth: IndexingTruth,
}

impl IndexingConfig {
    /// Parse a TOML configuration; `path` names the source in errors.
    pub fn from_toml_str(text: &str, path: Option<&std::path::Path>) -> Result<Self> {
        parse_toml(text, path, IndexingConfig::validate)
    }

    /// Read a TOML configuration file.
    pub fn from_file(path: &std::path::Path) -> Result<Self> {
        crate::config::read_toml(path, Self::from_toml_str)
    }

    /// The A detents (degrees): 0, step, … ≤ a_max.
    pub fn a_detents(&self) -> Vec<f64> {
        let n = (self.a_max_deg / self.a_step_deg + STEP_SLACK_DEG).floor() as usize;
        (0..=n).map(|k| k as f64 * self.a_step_deg).collect()
    }

    /// The B detents (degrees): the multiples of the step in [−180°, 180°).
    pub fn b_detents(&self) -> Vec<f64> {
        let first = (-180.0 / self.b_step_deg - STEP_SLACK_DEG).ceil() as i64;
        let count = (360.0 / self.b_step_deg).round() as i64;
        (first..first + count)
            .map(|k| k as f64 * self.b_step_deg)
            .collect()
    }

    /// Check every value; errors name the key.
    pub fn validate(&self) -> Result<()> {
        positive("a_step_deg", self.a_step_deg)?;
        positive("b_step_deg", self.b_step_deg)?;
        positive("stylus_mm", self.stylus_mm)?;
        non_negative("noise_um", self.noise_um)?;
        finite("rotation_centre_mm", &self.rotation_centre_mm)?;
        finite(
            "mount_x_deg, mount_y_deg, mount_z_deg",
            &[self.mount_x_deg, self.mount_y_deg, self.mount_z_deg],
        )?;
        if !(self.a_max_deg.is_finite()
            && self.a_max_deg >= self.a_step_deg
            && self.a_max_deg < 180.0)
        {
            return Err(bad(
                "a_max_deg",
                format!(
                    "{} must be at least a_step_deg ({}) and below 180",
                    self.a_max_deg, self.a_step_deg
                ),
            ));
        }
        let turn = 360.0 / self.b_step_deg;
        super::check_rows(
            "a_step_deg, b_step_deg",
            "A detents × B detents",
            (self.a_max_deg / self.a_step_deg + 1.0).floor() * turn.round(),
        )?;
        if (turn - turn.round()).abs() > STEP_SLACK_DEG * turn || turn.round() < 3.0 {
            return Err(bad(
                "b_step_deg",
                format!(
                    "{} must divide 360° into at least 3 whole steps (a full B turn at A = 0°)",
                    self.b_step_deg
                ),
            ));
        }
        let a = &self.a_errors;
        non_negative("a_errors.random_arcsec", a.random_arcsec)?;
        finite("a_errors.gravity_arcsec", &[a.gravity_arcsec])?;
        finite("a_errors.values_arcsec", &a.values_arcsec)?;
        let b = &self.b_errors;
        non_negative("b_errors.random_arcsec", b.random_arcsec)?;
        finite(
            "b_errors.once_per_turn_arcsec, b_errors.phase_deg",
            &[b.once_per_turn_arcsec, b.phase_deg],
        )?;
        finite("b_errors.values_arcsec", &b.values_arcsec)?;
        for (key, values, detents) in [
            (
                "a_errors.values_arcsec",
                &a.values_arcsec,
                self.a_detents().len(),
            ),
            (
                "b_errors.values_arcsec",
                &b.values_arcsec,
                self.b_detents().len(),
            ),
        ] {
            if !values.is_empty() && values.len() != detents {
                return Err(bad(
                    key,
                    format!("{} values for {detents} detents", values.len()),
                ));
            }
        }
        if a.values_arcsec.first().is_some_and(|v| *v != 0.0) {
            return Err(bad(
                "a_errors.values_arcsec",
                "the error at A = 0° must be 0: that detent puts the stylus on the B axis (the datum)",
            ));
        }
        Ok(())
    }
}

/// Centres and truth from a configuration (validated first).
pub fn generate(config: &IndexingConfig) -> Result<Generated> {
    config.validate()?;
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
    let a_detents = config.a_detents();
    let b_detents = config.b_detents();
    let a = &config.a_errors;
    let a_errors: Vec<f64> = if a.values_arcsec.is_empty() {
        a_detents
            .iter()
            .map(|&deg| {
                let random = a.random_arcsec * normal();
                if deg == 0.0 {
                    0.0
                } else {
                    a.gravity_arcsec * deg.to_radians().sin() + random
                }
            })
            .collect()
    } else {
        a.values_arcsec.clone()
    };
    let b = &config.b_errors;
    let raw: Vec<f64> = if b.values_arcsec.is_empty() {
        b_detents
            .iter()
            .map(|&deg| {
                b.once_per_turn_arcsec * (deg + b.phase_deg).to_radians().sin()
                    + b.random_arcsec * normal()
            })
            .collect()
    } else {
        b.values_arcsec.clone()
    };
    let datum = b_detents
        .iter()
        .zip(&raw)
        .find(|(deg, _)| **deg == 0.0)
        .map_or(0.0, |(_, e)| *e);
    let b_errors: Vec<f64> = raw.iter().map(|e| e - datum).collect();

    let mount = Rotation3::from_axis_angle(&Vector3::z_axis(), config.mount_z_deg.to_radians())
        * Rotation3::from_axis_angle(&Vector3::y_axis(), config.mount_y_deg.to_radians())
        * Rotation3::from_axis_angle(&Vector3::x_axis(), config.mount_x_deg.to_radians());
    let o = Point3::from(config.rotation_centre_mm);
    let noise_mm = config.noise_um / UM_PER_MM;
    let mut centres = Vec::with_capacity(a_detents.len() * b_detents.len());
    let mut truth = Vec::with_capacity(centres.capacity());
    for (&a_deg, &e_a) in a_detents.iter().zip(&a_errors) {
        for (&b_deg, &e_b) in b_detents.iter().zip(&b_errors) {
            let u = mount
                * Rotation3::from_axis_angle(
                    &Vector3::z_axis(),
                    (b_deg + e_b / ARCSEC_PER_DEG).to_radians(),
                )
                * Rotation3::from_axis_angle(
                    &Vector3::y_axis(),
                    (a_deg + e_a / ARCSEC_PER_DEG).to_radians(),
                )
                * Vector3::z();
            let p =
                o + u * config.stylus_mm + Vector3::new(normal(), normal(), normal()) * noise_mm;
            centres.push(CentreRow {
                a_deg,
                b_deg,
                x: p.x,
                y: p.y,
                z: p.z,
            });
            truth.push((a_deg, b_deg, e_a, (a_deg > 0.0).then_some(e_b)));
        }
    }
    let axis = |v: Vector3<f64>| {
        let w = mount * v;
        [w.x, w.y, w.z]
    };
    Ok(Generated {
        centres,
        truth: IndexingTruth {
            columns: TRUTH_COLUMNS.map(String::from).to_vec(),
            truth,
            head: Some(TrueHead {
                rotation_centre: config.rotation_centre_mm,
                radius_mm: config.stylus_mm,
                b_axis: axis(Vector3::z()),
                a_axis: axis(Vector3::y()),
                noise_um: config.noise_um,
            }),
            config: serde_json::to_value(config).ok(),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_toml_is_the_default() {
        assert_eq!(
            IndexingConfig::from_toml_str(DEFAULT_TOML, None).unwrap(),
            IndexingConfig::default()
        );
    }

    #[test]
    fn grids_follow_the_steps() {
        let c = IndexingConfig::default();
        assert_eq!(c.a_detents().len(), 15);
        let b = c.b_detents();
        assert_eq!((b.len(), b[0], b[47]), (48, -180.0, 172.5));
        let c = IndexingConfig {
            b_step_deg: 40.0,
            a_max_deg: 60.0,
            a_step_deg: 15.0,
            ..Default::default()
        };
        assert_eq!(c.a_detents(), vec![0.0, 15.0, 30.0, 45.0, 60.0]);
        assert_eq!(c.b_detents().first(), Some(&-160.0));
        assert_eq!(c.b_detents().len(), 9);
        assert!(c.b_detents().contains(&0.0));
    }

    #[test]
    fn same_seed_same_data_datum_errors_zero() {
        let c = IndexingConfig::default();
        let g = generate(&c).unwrap();
        assert_eq!(g, generate(&c).unwrap());
        assert_eq!(g.centres.len(), 720);
        for &(a, b, d_a, d_b) in &g.truth.truth {
            if a == 0.0 {
                assert_eq!((d_a, d_b), (0.0, None));
            }
            if b == 0.0 && a > 0.0 {
                assert_eq!(d_b, Some(0.0));
            }
        }
        let other = generate(&IndexingConfig { seed: 3, ..c }).unwrap();
        assert_ne!(g.centres, other.centres);
    }

    #[test]
    fn centres_lie_on_the_stylus_sphere_without_noise() {
        let c = IndexingConfig {
            noise_um: 0.0,
            ..Default::default()
        };
        let g = generate(&c).unwrap();
        let o = Point3::from(c.rotation_centre_mm);
        for r in &g.centres {
            let d = (Point3::new(r.x, r.y, r.z) - o).norm();
            assert!((d - c.stylus_mm).abs() < 1e-12, "{d}");
        }
    }

    #[test]
    fn bad_values_name_their_key() {
        for (text, key) in [
            ("b_step_deg = 7.0", "b_step_deg"),
            ("a_max_deg = 200.0", "a_max_deg"),
            ("noise_um = -1.0", "noise_um"),
            (
                "[a_errors]\nvalues_arcsec = [1.0, 2.0]",
                "a_errors.values_arcsec",
            ),
            ("stylus = 3", "stylus"),
        ] {
            let e = IndexingConfig::from_toml_str(text, None)
                .unwrap_err()
                .to_string();
            assert!(e.contains(key), "{text}: {e}");
        }
    }
}
