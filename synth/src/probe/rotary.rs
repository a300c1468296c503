//! Check data for the rotary-table method (docs/probe-rotary.md) with known truth:
//! a C axis whose axis average line is offset and tilted (ISO 230-7
//! location errors), with component error motions, carrying a standard ball
//! at several places; the ball centres and the probed points a CMM reports
//! through a turn, with noise; and the true six errors per angle.
//!
//! # The simulated table
//! The table turns by θ about the line through `c = (X0C, Y0C, 0)` with
//! direction `Rt·z`, `Rt` the rotation by the rotation vector
//! `(A0C, B0C, 0)` (so the direction is ≈ (B0C, −A0C, 1)): `A(θ)·q =
//! c + R(Rt·z, θ)·(q − c)`, exactly. The component error motion `Ec(θ)`
//! (translations δc, rotations εc about the frame's axes, each a sum of
//! harmonics `a·cos nθ + b·sin nθ`, n ≥ 1, so zero mean over a turn) then
//! moves the table rigidly: a ball placed at `q` is at `P(θ) = Ec(θ)·A(θ)·q`.
//!
//! # Truth
//! The method refers everything to the centres at 0°, so the true errors at
//! θ are those of the rigid motion `Q(θ) = T(θ)·T(0)⁻¹·Rz(θ)⁻¹` (`T = Ec·A`),
//! which takes each ideal position `Rz(θ)·P(0)` to the measured `P(θ)`:
//! δ its translation, ε its rotation vector. The true location errors are
//! the configured ones; the true component errors are the true errors less
//! `(I − Rz)·(X0C, Y0C, 0)` and `(I − Rz)·(A0C, B0C, 0)`.
//!
//! The generator does not call the method: the truth comes from the
//! simulated motion alone.

use std::path::Path;

use formats::probe::rotary::{BallTruth, CentreRow, LocationErrors, RotaryTruth};
use geom::nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use geom::transform::{SmallError, rotation_from_vector};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::{Result, SynthError};

/// µm → mm.
const UM: f64 = 1e-3;
/// µrad → rad.
const URAD: f64 = 1e-6;
/// One turn (degrees).
const FULL_TURN_DEG: f64 = 360.0;
/// Angles within this of 360° (degrees) are the turn's end, not a new
/// angle: a step that divides the turn must not add 360° by rounding.
const TURN_END_TOLERANCE_DEG: f64 = 1e-9;
/// Fewest probed points per sphere the method accepts.
const MIN_POINTS: usize = 4;
/// Names of the six errors, in the order of `truth_mm_rad`'s columns.
pub const NAMES: [&str; 6] = ["EXC", "EYC", "EZC", "EAC", "EBC", "ECC"];

/// The documented default configuration (close to the check data of
/// `data/rotary/`), as `trinocular synth probe rotary --print-config` prints
/// it. Parses to [`RotaryConfig::default`].
pub const DEFAULT_TOML: &str = r#"# trinocular synth probe rotary: a C axis with known errors, a standard ball at
# several places, measured through a turn (docs/probe-rotary.md). Every key is optional.
# Lengths in mm unless the key says _um (micrometres); angles _deg, _urad.

seed = 0                 # random seed of the noise: same seed, same files
step_deg = 30.0          # angles 0, step, 2·step, … below 360
noise_um = 0.3           # noise of each centre in centres.csv, per coordinate (standard deviation)
probe_noise_um = 0.3     # noise of each probed point in points.csv, per coordinate
ball_radius_mm = 12.7    # radius of the standard ball

# Where the probe touches each ball (directions in the table frame, not turning
# with the table): the north pole, and rings at a polar angle from +Z.
[probe]
pole = true
rings = [{ polar_deg = 90.0, points = 4, phase_deg = 0.0 }]   # four on the equator

# Location errors of the axis average line (ISO 230-7): where it crosses Z = 0,
# and the right-hand rotations about X and Y that turn +Z onto it.
[location]
x0c_um = 12.0
y0c_um = -8.0
a0c_urad = 25.0
b0c_urad = 40.0

# Ball centres on the table at 0° (table frame: Z on the nominal axis).
[[balls]]
name = "1"
position = [150.0, 10.0, 60.0]
[[balls]]
name = "2"
position = [-70.0, 120.0, 95.0]
[[balls]]
name = "3"
position = [-55.0, -135.0, 30.0]

# Component error motions: error EXC, EYC, EZC (µm) or EAC, EBC, ECC (µrad)
# += cos·cos(order·θ) + sin·sin(order·θ), order ≥ 1.
[[components]]
error = "EXC"
order = 2
sin = 1.5
[[components]]
error = "EYC"
order = 2
cos = 0.9
sin = -0.5
[[components]]
error = "EZC"
order = 3
sin = 0.8
[[components]]
error = "EAC"
order = 2
cos = 1.8
sin = 5.7
[[components]]
error = "EBC"
order = 3
cos = -4.0
[[components]]
error = "ECC"
order = 1
sin = 9.0
[[components]]
error = "ECC"
order = 4
cos = 4.2
sin = 2.7
"#;

/// What the generator simulates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RotaryConfig {
    /// Seed of the noise.
    pub seed: u64,
    /// Angular step (degrees): angles 0, step, … below 360.
    pub step_deg: f64,
    /// Standard deviation of each centre coordinate's noise (µm).
    pub noise_um: f64,
    /// Standard deviation of each probed point coordinate's noise (µm).
    pub probe_noise_um: f64,
    /// Ball radius (mm).
    pub ball_radius_mm: f64,
    /// Where the probe touches each ball.
    pub probe: ProbePattern,
    /// Location errors of the axis average line.
    pub location: LocationConfig,
    /// The balls.
    pub balls: Vec<BallConfig>,
    /// Component error harmonics.
    pub components: Vec<Harmonic>,
}

/// The probing pattern of one ball at one angle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProbePattern {
    /// Probe the north pole (+Z).
    pub pole: bool,
    /// Rings of points at a polar angle from +Z.
    pub rings: Vec<Ring>,
}

/// A ring of probed points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ring {
    /// Polar angle from +Z (degrees; 90 = the equator).
    pub polar_deg: f64,
    /// Number of points, evenly spaced in azimuth.
    pub points: u32,
    /// Azimuth of the first point from +X (degrees).
    #[serde(default)]
    pub phase_deg: f64,
}

/// Location errors (ISO 230-7).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LocationConfig {
    /// X0C (µm).
    pub x0c_um: f64,
    /// Y0C (µm).
    pub y0c_um: f64,
    /// A0C (µrad).
    pub a0c_urad: f64,
    /// B0C (µrad).
    pub b0c_urad: f64,
}

/// A ball on the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BallConfig {
    /// Name.
    pub name: String,
    /// Centre at 0° without errors (mm, table frame).
    pub position: [f64; 3],
}

/// One harmonic of a component error motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Harmonic {
    /// Which error: EXC, EYC, EZC (µm) or EAC, EBC, ECC (µrad).
    pub error: String,
    /// Order n ≥ 1 (cycles per turn).
    pub order: u32,
    /// Amplitude of `cos nθ`.
    #[serde(default)]
    pub cos: f64,
    /// Amplitude of `sin nθ`.
    #[serde(default)]
    pub sin: f64,
}

impl Default for RotaryConfig {
    /// The values of [`DEFAULT_TOML`] (a test holds them equal).
    fn default() -> Self {
        let ball = |name: &str, position: [f64; 3]| BallConfig {
            name: name.into(),
            position,
        };
        let harmonic = |error: &str, order: u32, cos: f64, sin: f64| Harmonic {
            error: error.into(),
            order,
            cos,
            sin,
        };
        Self {
            seed: 0,
            step_deg: 30.0,
            noise_um: 0.3,
            probe_noise_um: 0.3,
            ball_radius_mm: 12.7,
            probe: ProbePattern::default(),
            location: LocationConfig {
                x0c_um: 12.0,
                y0c_um: -8.0,
                a0c_urad: 25.0,
                b0c_urad: 40.0,
            },
            balls: vec![
                ball("1", [150.0, 10.0, 60.0]),
                ball("2", [-70.0, 120.0, 95.0]),
                ball("3", [-55.0, -135.0, 30.0]),
            ],
            components: vec![
                harmonic("EXC", 2, 0.0, 1.5),
                harmonic("EYC", 2, 0.9, -0.5),
                harmonic("EZC", 3, 0.0, 0.8),
                harmonic("EAC", 2, 1.8, 5.7),
                harmonic("EBC", 3, -4.0, 0.0),
                harmonic("ECC", 1, 0.0, 9.0),
                harmonic("ECC", 4, 4.2, 2.7),
            ],
        }
    }
}

impl Default for ProbePattern {
    fn default() -> Self {
        Self {
            pole: true,
            rings: vec![Ring {
                polar_deg: 90.0,
                points: 4,
                phase_deg: 0.0,
            }],
        }
    }
}

fn bad(key: &str, message: impl std::fmt::Display) -> SynthError {
    SynthError::config(format!("{key}: {message}"))
}

impl RotaryConfig {
    /// Parse a TOML configuration; `path` names the source in errors
    /// (unknown keys, bad values, with the line and column of a parse error).
    pub fn from_toml_str(text: &str, path: Option<&Path>) -> Result<Self> {
        crate::config::parse_toml(text, path, RotaryConfig::validate)
    }

    /// Read a TOML configuration file.
    pub fn from_file(path: &Path) -> Result<Self> {
        crate::config::read_toml(path, Self::from_toml_str)
    }

    /// The configuration as TOML (without the comments of [`DEFAULT_TOML`]).
    pub fn to_toml(&self) -> Result<String> {
        crate::config::to_toml(self)
    }

    /// Check every value: a positive step below a turn, non-negative noise,
    /// a positive radius, ≥ 4 probed points per sphere, named balls at
    /// finite places, harmonics of the six errors with order ≥ 1.
    pub fn validate(&self) -> Result<()> {
        if !(self.step_deg > 0.0 && self.step_deg < FULL_TURN_DEG) {
            return Err(bad(
                "step_deg",
                format!("{} is not in (0, 360)", self.step_deg),
            ));
        }
        for (key, v) in [
            ("noise_um", self.noise_um),
            ("probe_noise_um", self.probe_noise_um),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(bad(key, format!("{v} is not a non-negative number")));
            }
        }
        if !(self.ball_radius_mm > 0.0 && self.ball_radius_mm.is_finite()) {
            return Err(bad(
                "ball_radius_mm",
                format!("{} is not positive", self.ball_radius_mm),
            ));
        }
        let points = usize::from(self.probe.pole)
            + self
                .probe
                .rings
                .iter()
                .map(|r| r.points as usize)
                .sum::<usize>();
        if points < MIN_POINTS {
            return Err(bad(
                "probe",
                format!(
                    "{points} probed point(s) per sphere: a sphere needs at least {MIN_POINTS}"
                ),
            ));
        }
        super::check_rows(
            "step_deg, balls, probe",
            "angles × balls × (centre + probed points)",
            (FULL_TURN_DEG / self.step_deg).ceil()
                * self.balls.len() as f64
                * (points as f64 + 1.0),
        )?;
        for r in &self.probe.rings {
            if !(r.polar_deg > 0.0 && r.polar_deg <= 180.0 && r.phase_deg.is_finite()) {
                return Err(bad(
                    "probe.rings",
                    format!("polar_deg {} is not in (0, 180]", r.polar_deg),
                ));
            }
        }
        let loc = self.location;
        if ![loc.x0c_um, loc.y0c_um, loc.a0c_urad, loc.b0c_urad]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(bad("location", "values must be finite"));
        }
        if self.balls.is_empty() {
            return Err(bad("balls", "no balls"));
        }
        for (k, b) in self.balls.iter().enumerate() {
            if b.name.trim().is_empty() || b.name.contains(',') {
                return Err(bad(
                    "balls.name",
                    format!("ball {} needs a name without commas", k + 1),
                ));
            }
            if self.balls[..k].iter().any(|o| o.name == b.name) {
                return Err(bad("balls.name", format!("ball {} is given twice", b.name)));
            }
            if !b.position.iter().all(|v| v.is_finite()) {
                return Err(bad(
                    "balls.position",
                    format!("ball {} is not at a finite place", b.name),
                ));
            }
        }
        for h in &self.components {
            if !NAMES.contains(&h.error.as_str()) {
                return Err(bad(
                    "components.error",
                    format!("'{}' is not one of {}", h.error, NAMES.join(", ")),
                ));
            }
            if h.order < 1 {
                return Err(bad(
                    "components.order",
                    "order 0 would be a constant: give location errors in [location]",
                ));
            }
            if !(h.cos.is_finite() && h.sin.is_finite()) {
                return Err(bad(
                    "components",
                    format!("{} amplitudes must be finite", h.error),
                ));
            }
        }
        Ok(())
    }

    /// The measured angles: 0, step, … below 360 (degrees).
    pub fn angles_deg(&self) -> Vec<f64> {
        (0..)
            .map(|k| f64::from(k) * self.step_deg)
            .take_while(|a| *a < FULL_TURN_DEG - TURN_END_TOLERANCE_DEG)
            .collect()
    }

    /// The component error motion at `angle_deg`: δc (mm) and εc (rad).
    pub fn component(&self, angle_deg: f64) -> SmallError {
        let t = angle_deg.to_radians();
        let mut v = [0.0; 6];
        for h in &self.components {
            if let Some(k) = NAMES.iter().position(|n| *n == h.error) {
                let n = f64::from(h.order);
                v[k] += h.cos * (n * t).cos() + h.sin * (n * t).sin();
            }
        }
        SmallError {
            delta: Vector3::new(v[0], v[1], v[2]) * UM,
            epsilon: Vector3::new(v[3], v[4], v[5]) * URAD,
        }
    }

    /// The table's true rigid motion at `angle_deg`: `T = Ec(θ)·A(θ)`.
    pub(crate) fn table_motion(&self, angle_deg: f64) -> Isometry3<f64> {
        let l = self.location;
        let c = Vector3::new(l.x0c_um * UM, l.y0c_um * UM, 0.0);
        let tilt = rotation_from_vector(Vector3::new(l.a0c_urad * URAD, l.b0c_urad * URAD, 0.0));
        let axis = tilt * Vector3::z_axis();
        let turn = UnitQuaternion::from_axis_angle(&axis, angle_deg.to_radians());
        let about_axis = Translation3::from(c) * turn * Translation3::from(-c);
        self.component(angle_deg).to_isometry() * about_axis
    }

    /// The fixed-axis part of the six errors at `angle_deg`:
    /// `(I − Rz)·(X0C, Y0C, 0)` (mm), `(I − Rz)·(A0C, B0C, 0)` (rad).
    fn fixed_axis(&self, angle_deg: f64) -> [f64; 6] {
        let l = self.location;
        let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle_deg.to_radians());
        let c = Vector3::new(l.x0c_um * UM, l.y0c_um * UM, 0.0);
        let t = Vector3::new(l.a0c_urad * URAD, l.b0c_urad * URAD, 0.0);
        let (d, e) = (c - rz * c, t - rz * t);
        [d.x, d.y, d.z, e.x, e.y, e.z]
    }

    /// Unit directions (table frame) of the probed points on a ball.
    fn probe_directions(&self) -> Vec<Vector3<f64>> {
        let mut out = Vec::new();
        if self.probe.pole {
            out.push(Vector3::z());
        }
        for r in &self.probe.rings {
            let (sp, cp) = r.polar_deg.to_radians().sin_cos();
            for k in 0..r.points {
                let az =
                    (r.phase_deg + f64::from(k) * FULL_TURN_DEG / f64::from(r.points)).to_radians();
                out.push(Vector3::new(sp * az.cos(), sp * az.sin(), cp));
            }
        }
        out
    }
}

/// The generated check data.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryData {
    /// `centres.csv`: one noisy centre per ball and angle.
    pub centres: Vec<CentreRow>,
    /// `points.csv`: the noisy probed points per ball and angle.
    pub points: Vec<CentreRow>,
    /// `truth.json`.
    pub truth: RotaryTruth,
}

/// Generate the check data of `config` (validated first). Rows go by angle,
/// then ball; the noise is drawn in that order from one ChaCha stream of
/// the seed: same configuration, same data.
pub fn generate(config: &RotaryConfig) -> Result<RotaryData> {
    config.validate()?;
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let mut normal = |sigma_um: f64| -> f64 {
        let z: f64 = StandardNormal.sample(&mut rng);
        z * sigma_um * UM
    };
    let angles = config.angles_deg();
    let directions = config.probe_directions();
    let home = config.table_motion(0.0);
    let mut centres = Vec::new();
    let mut points = Vec::new();
    let mut truth_mm_rad = Vec::new();
    let mut components = Vec::new();
    for &a in &angles {
        let motion = config.table_motion(a);
        for b in &config.balls {
            let p = motion.transform_point(&Point3::from(b.position));
            let row = |q: Point3<f64>| CentreRow {
                ball: b.name.clone(),
                angle_deg: a,
                x: q.x,
                y: q.y,
                z: q.z,
            };
            let noise = Vector3::new(
                normal(config.noise_um),
                normal(config.noise_um),
                normal(config.noise_um),
            );
            centres.push(row(p + noise));
            for d in &directions {
                let noise = Vector3::new(
                    normal(config.probe_noise_um),
                    normal(config.probe_noise_um),
                    normal(config.probe_noise_um),
                );
                points.push(row(p + d * config.ball_radius_mm + noise));
            }
        }
        let ideal = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a.to_radians());
        let q = motion
            * home.inverse()
            * Isometry3::from_parts(Translation3::identity(), ideal.inverse());
        let six = SmallError::from_isometry(&q).components();
        let fixed = config.fixed_axis(a);
        components.push(std::array::from_fn(|k| six[k] - fixed[k]));
        truth_mm_rad.push(six);
    }
    let l = config.location;
    let truth = RotaryTruth {
        angles_deg: angles,
        columns: NAMES.iter().map(|n| (*n).to_string()).collect(),
        truth_mm_rad,
        location: Some(LocationErrors {
            x0c_um: l.x0c_um,
            y0c_um: l.y0c_um,
            a0c_urad: l.a0c_urad,
            b0c_urad: l.b0c_urad,
        }),
        components_mm_rad: Some(components),
        balls: config
            .balls
            .iter()
            .map(|b| BallTruth {
                ball: b.name.clone(),
                position: b.position,
            })
            .collect(),
        noise_um: Some(config.noise_um),
        probe_noise_um: Some(config.probe_noise_um),
        ball_radius_mm: Some(config.ball_radius_mm),
        seed: Some(config.seed),
    };
    Ok(RotaryData {
        centres,
        points,
        truth,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_text_is_the_default() {
        let parsed = RotaryConfig::from_toml_str(DEFAULT_TOML, None).unwrap();
        assert_eq!(parsed, RotaryConfig::default());
        assert_eq!(parsed.balls.len(), 3);
        assert_eq!(parsed.components.len(), 7);
        let again = RotaryConfig::from_toml_str(&parsed.to_toml().unwrap(), None).unwrap();
        assert_eq!(again, parsed);
    }

    #[test]
    fn noiseless_centres_are_the_true_motion() {
        let mut c = RotaryConfig {
            noise_um: 0.0,
            probe_noise_um: 0.0,
            ..RotaryConfig::default()
        };
        c.step_deg = 45.0;
        let d = generate(&c).unwrap();
        assert_eq!(d.truth.angles_deg.len(), 8);
        assert_eq!(d.centres.len(), 8 * 3);
        assert_eq!(d.points.len(), 8 * 3 * 5);
        // Truth is zero at 0° and reproduces each centre from its 0° centre to first order.
        assert!(d.truth.truth_mm_rad[0].iter().all(|v| v.abs() < 1e-15));
        for (k, a) in d.truth.angles_deg.iter().enumerate() {
            let t = d.truth.truth_mm_rad[k];
            let e = SmallError {
                delta: Vector3::new(t[0], t[1], t[2]),
                epsilon: Vector3::new(t[3], t[4], t[5]),
            };
            let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a.to_radians());
            for b in 0..3 {
                let r0 = &d.centres[b];
                let r = &d.centres[3 * k + b];
                let ideal = rz * Point3::new(r0.x, r0.y, r0.z);
                let got = Point3::new(r.x, r.y, r.z);
                // The first-order model leaves ½|ε|²·|P| ≈ ½·(1e-4)²·170 mm ≈ 1e-6 mm.
                let miss = (e.apply(&ideal) - got).norm();
                assert!(miss < 2e-6, "{a}° ball {b}: {miss}");
            }
        }
        // Probed points lie on the ball.
        let p = &d.points[0];
        let c0 = &d.centres[0];
        let r = ((p.x - c0.x).powi(2) + (p.y - c0.y).powi(2) + (p.z - c0.z).powi(2)).sqrt();
        assert!((r - 12.7).abs() < 1e-12);
    }

    #[test]
    fn same_seed_same_data() {
        let c = RotaryConfig::default();
        assert_eq!(generate(&c).unwrap(), generate(&c).unwrap());
        let other = RotaryConfig {
            seed: 7,
            ..c.clone()
        };
        assert_ne!(
            generate(&c).unwrap().centres,
            generate(&other).unwrap().centres
        );
    }

    #[test]
    fn bad_configurations_name_the_key() {
        let e = RotaryConfig::from_toml_str("step_deg = 0", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("step_deg"), "{e}");
        let e = RotaryConfig::from_toml_str("[[components]]\nerror = \"EXX\"\norder = 1", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("EXX"), "{e}");
        let e = RotaryConfig::from_toml_str(
            "[probe]\npole = false\nrings = [{ polar_deg = 90.0, points = 3 }]",
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("at least 4"), "{e}");
        let e = RotaryConfig::from_toml_str("stepdeg = 3", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("stepdeg"), "{e}");
    }
}
