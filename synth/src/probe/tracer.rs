//! Check data of laser-tracer multilateration (docs/probe-tracer.md) with known
//! truth: a lattice grid of nominal CMM points, a smooth error field that
//! moves the true points off it, m tracer stations around the grid, and the
//! interferometric readings a tracer reports — each station zeroed at the
//! first point it reads (`l = 0` there), Gaussian noise, rounded to the
//! interferometer's resolution — plus `truth.json`.
//!
//! # Conventions
//! - Millimetres in the files, µm in the configuration's error figures.
//! - Points are numbered 1…n with z fastest, then y, then x (the order a
//!   serpentine-free probing program visits them); stations 1…m; each
//!   station reads the points in that order.
//! - Truth: corrections = true − nominal after the least-squares rigid
//!   alignment of the true points to the nominal grid (the datum of §4);
//!   `stations_mm` in the machine frame (where the true points are), as in
//!   the project's check data; `stations_aligned_mm` in the aligned frame,
//!   the one the solver reports stations in.
//!
//! Deterministic: the error field and station layout depend only on
//! `seed`, the noise only on `noise_seed` (a Monte-Carlo study keeps the
//! truth and varies the noise), dropped readings on both.

use formats::probe::tracer::{GridRow, ReadingRow, TracerTruth};
use geom::nalgebra::{Point3, Vector3};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal, StandardUniform};
use serde::{Deserialize, Serialize};

use crate::sensor::chacha_key;
use crate::{Result, SynthError};

const UM: f64 = 1e-3;
/// Purpose tags of the random streams (domain separation).
const FIELD_PURPOSE: u64 = 0x7472_6163_6572_0001;
const NOISE_PURPOSE: u64 = 0x7472_6163_6572_0002;
const MISSING_PURPOSE: u64 = 0x7472_6163_6572_0003;
/// Elevations of the stations seen from the grid centre, alternating (rad):
/// below and above the grid, so that no four stations share a plane.
const ELEVATIONS: [f64; 2] = [-0.26, 0.61];
/// Random spread of a station's azimuth (fraction of the spacing),
/// elevation (rad) and distance (fraction).
const JITTER: (f64, f64, f64) = (0.25, 0.09, 0.1);

/// Settings of the generator; [`TracerConfig::default`] is the project's
/// check data layout (5 × 5 × 4 points over 400 × 400 × 300 mm, 6 stations,
/// a 5 µm error field, 0.2 µm noise).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TracerConfig {
    /// Grid points along x, y, z (each ≥ 2). Default 5, 5, 4.
    pub counts: [usize; 3],
    /// Corner of the grid with the smallest coordinates (mm). Default 0, 0, 0.
    pub origin: [f64; 3],
    /// Size of the grid along x, y, z (mm, > 0). Default 400, 400, 300.
    pub size: [f64; 3],
    /// Number of tracer stations (≥ 1). Default 6.
    pub stations: usize,
    /// Distance of the stations from the grid centre, in half-diagonals of
    /// the grid (> 1: outside it). Default 1.6.
    pub station_distance: f64,
    /// RMS of the error field over the grid (µm, ≥ 0). Default 5.
    pub error_um: f64,
    /// Standard deviation of a reading (µm, ≥ 0). Default 0.2.
    pub noise_um: f64,
    /// Resolution the readings are rounded to (µm, ≥ 0; 0: none). Default 0.0001.
    pub resolution_um: f64,
    /// Share of readings left out at random (0 ≤ f < 1). Default 0.
    pub missing: f64,
    /// Seed of the error field and station layout. Default 1.
    pub seed: u64,
    /// Seed of the reading noise and the left-out readings. Default 1.
    pub noise_seed: u64,
}

impl Default for TracerConfig {
    fn default() -> Self {
        Self {
            counts: [5, 5, 4],
            origin: [0.0; 3],
            size: [400.0, 400.0, 300.0],
            stations: 6,
            station_distance: 1.6,
            error_um: 5.0,
            noise_um: 0.2,
            resolution_um: 1e-4,
            missing: 0.0,
            seed: 1,
            noise_seed: 1,
        }
    }
}

/// What the generator writes: `grid.csv`, `readings.csv` and `truth.json`.
#[derive(Debug, Clone, PartialEq)]
pub struct TracerData {
    /// Nominal grid points.
    pub grid: Vec<GridRow>,
    /// Readings, station by station, each in point order.
    pub readings: Vec<ReadingRow>,
    /// The truth.
    pub truth: TracerTruth,
}

impl TracerConfig {
    /// Check every value; errors name the key.
    pub fn check(&self) -> Result<()> {
        let bad = |key: &str, why: String| Err(SynthError::config(format!("tracer.{key}: {why}")));
        if self.counts.iter().any(|c| *c < 2) {
            return bad(
                "counts",
                format!("{:?}: at least 2 points per axis", self.counts),
            );
        }
        if self.size.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return bad("size", format!("{:?}: sizes must be positive", self.size));
        }
        if self.origin.iter().any(|s| !s.is_finite()) {
            return bad("origin", format!("{:?} is not finite", self.origin));
        }
        if self.stations == 0 {
            return bad("stations", "at least one station".into());
        }
        let points: f64 = self.counts.iter().map(|&c| c as f64).product();
        super::check_rows(
            "tracer.counts, tracer.stations",
            "grid points × (1 + stations)",
            points * (1.0 + self.stations as f64),
        )?;
        if !(self.station_distance.is_finite() && self.station_distance > 1.0) {
            return bad(
                "station_distance",
                format!(
                    "{} half-diagonals: must exceed 1 (outside the grid)",
                    self.station_distance
                ),
            );
        }
        for (key, v) in [
            ("error_um", self.error_um),
            ("noise_um", self.noise_um),
            ("resolution_um", self.resolution_um),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(key, format!("{v} must be a number ≥ 0"));
            }
        }
        if !(self.missing >= 0.0 && self.missing < 1.0) {
            return bad("missing", format!("{} must lie in [0, 1)", self.missing));
        }
        Ok(())
    }

    /// Nominal grid points, z fastest, then y, then x.
    pub fn nominal(&self) -> Vec<Point3<f64>> {
        let [nx, ny, nz] = self.counts;
        let at = |a: usize, k: usize, n: usize| {
            self.origin[a] + self.size[a] * k as f64 / (n - 1) as f64
        };
        let mut out = Vec::with_capacity(nx * ny * nz);
        for i in 0..nx {
            for j in 0..ny {
                for k in 0..nz {
                    out.push(Point3::new(at(0, i, nx), at(1, j, ny), at(2, k, nz)));
                }
            }
        }
        out
    }

    fn centre(&self) -> Vector3<f64> {
        Vector3::from(self.origin) + Vector3::from(self.size) / 2.0
    }
}

/// The smooth error field: per component, linear terms (scale,
/// squareness, rotation), quadratic terms (bending) and one sinusoid over
/// the normalised coordinates ξ ∈ [−1, 1]³, with coefficients drawn from the
/// seed and scaled to the configured RMS.
struct Field {
    linear: [[f64; 3]; 3],
    quadratic: [[f64; 6]; 3],
    wave: [(f64, [f64; 3], f64); 3],
    centre: Vector3<f64>,
    half: Vector3<f64>,
    gain: f64,
}

impl Field {
    fn new(config: &TracerConfig, nominal: &[Point3<f64>]) -> Field {
        let mut rng = ChaCha8Rng::from_seed(chacha_key(FIELD_PURPOSE, &[config.seed]));
        let mut u = || -> f64 {
            let v: f64 = StandardUniform.sample(&mut rng);
            2.0 * v - 1.0
        };
        let mut field = Field {
            linear: [[0.0; 3]; 3],
            quadratic: [[0.0; 6]; 3],
            wave: [(0.0, [0.0; 3], 0.0); 3],
            centre: config.centre(),
            half: Vector3::from(config.size) / 2.0,
            gain: 1.0,
        };
        for c in 0..3 {
            field.linear[c] = [u(), u(), u()];
            field.quadratic[c] = [u(), u(), u(), u(), u(), u()];
            field.wave[c] = (u(), [u(), u(), u()], std::f64::consts::PI * u());
        }
        let ss: f64 = nominal.iter().map(|p| field.raw(p).norm_squared()).sum();
        let rms = (ss / nominal.len() as f64).sqrt();
        field.gain = if rms > 0.0 {
            config.error_um * UM / rms
        } else {
            0.0
        };
        field
    }

    fn raw(&self, p: &Point3<f64>) -> Vector3<f64> {
        let x = (p.coords - self.centre).component_div(&self.half);
        let quad = [
            x.x * x.x,
            x.y * x.y,
            x.z * x.z,
            x.x * x.y,
            x.y * x.z,
            x.z * x.x,
        ];
        Vector3::from_fn(|c, _| {
            let l = &self.linear[c];
            let q = &self.quadratic[c];
            let (amp, k, phase) = self.wave[c];
            l[0] * x.x
                + l[1] * x.y
                + l[2] * x.z
                + 0.5 * quad.iter().zip(q).map(|(a, b)| a * b).sum::<f64>()
                + 0.5
                    * amp
                    * (std::f64::consts::PI * (k[0] * x.x + k[1] * x.y + k[2] * x.z) + phase).sin()
        })
    }

    fn at(&self, p: &Point3<f64>) -> Vector3<f64> {
        self.raw(p) * self.gain
    }
}

/// Stations around the grid centre: azimuths spread evenly, elevations
/// alternating below and above the grid, distances `station_distance`
/// half-diagonals, each with a random jitter from the seed.
fn stations(config: &TracerConfig) -> Vec<Point3<f64>> {
    let mut rng = ChaCha8Rng::from_seed(chacha_key(FIELD_PURPOSE, &[config.seed, 1]));
    let mut u = || -> f64 {
        let v: f64 = StandardUniform.sample(&mut rng);
        2.0 * v - 1.0
    };
    let half_diagonal = Vector3::from(config.size).norm() / 2.0;
    let m = config.stations;
    (0..m)
        .map(|j| {
            let azimuth = std::f64::consts::TAU * (j as f64 + JITTER.0 * u()) / m as f64;
            let elevation = ELEVATIONS[j % 2] + JITTER.1 * u();
            let r = config.station_distance * half_diagonal * (1.0 + JITTER.2 * u());
            Point3::from(
                config.centre()
                    + r * Vector3::new(
                        elevation.cos() * azimuth.cos(),
                        elevation.cos() * azimuth.sin(),
                        elevation.sin(),
                    ),
            )
        })
        .collect()
}

/// `v` rounded to a multiple of `step`; a step that is 1/N (N whole) divides
/// by N, so that the result is the double nearest the decimal and prints short.
fn round_to(v: f64, step: f64) -> f64 {
    if step.is_nan() || step <= 0.0 {
        return v;
    }
    let per = 1.0 / step;
    let whole = per.round();
    if whole >= 1.0 && (per - whole).abs() < 1e-9 * whole {
        (v * whole).round() / whole
    } else {
        (v / step).round() * step
    }
}

/// Generate the grid, the readings and the truth of `config`.
pub fn generate(config: &TracerConfig) -> Result<TracerData> {
    config.check()?;
    let nominal = config.nominal();
    let field = Field::new(config, &nominal);
    let truth_points: Vec<Point3<f64>> = nominal.iter().map(|p| p + field.at(p)).collect();
    let stations = stations(config);

    let mut noise = ChaCha8Rng::from_seed(chacha_key(NOISE_PURPOSE, &[config.noise_seed]));
    let mut drop = ChaCha8Rng::from_seed(chacha_key(
        MISSING_PURPOSE,
        &[config.seed, config.noise_seed],
    ));
    let mut readings = Vec::with_capacity(nominal.len() * stations.len());
    let mut dead_paths = Vec::with_capacity(stations.len());
    for (j, s) in stations.iter().enumerate() {
        let mut zero: Option<f64> = None;
        for (i, a) in truth_points.iter().enumerate() {
            let eps: f64 = StandardNormal.sample(&mut noise);
            let keep: f64 = StandardUniform.sample(&mut drop);
            if keep < config.missing {
                continue;
            }
            // What the interferometer counts: the distance with its noise,
            // zeroed at the station's first point.
            let counted = (a - s).norm() + eps * config.noise_um * UM;
            let zero = *zero.get_or_insert_with(|| {
                dead_paths.push((a - s).norm());
                counted
            });
            readings.push(ReadingRow {
                station: (j + 1).to_string(),
                point: (i + 1).to_string(),
                l: round_to(counted - zero, config.resolution_um * UM),
            });
        }
        if zero.is_none() {
            return Err(SynthError::config(format!(
                "tracer.missing: {} leaves station {} without readings",
                config.missing,
                j + 1
            )));
        }
    }

    let align = geom::transform::rigid_fit(&truth_points, &nominal)
        .map_err(|e| SynthError::geometry("rigid alignment of the true grid", e))?;
    let corrections = truth_points
        .iter()
        .zip(&nominal)
        .map(|(t, n)| (align * t - n).into())
        .collect();
    let mut extra = serde_json::Map::new();
    extra.insert(
        "stations_aligned_mm".into(),
        serde_json::json!(
            stations
                .iter()
                .map(|s| <[f64; 3]>::from(align * s))
                .collect::<Vec<_>>()
        ),
    );
    extra.insert(
        "config".into(),
        serde_json::to_value(config).map_err(|e| SynthError::config(e.to_string()))?,
    );
    let grid = nominal
        .iter()
        .enumerate()
        .map(|(i, p)| GridRow {
            point: (i + 1).to_string(),
            x: p.x,
            y: p.y,
            z: p.z,
        })
        .collect();
    Ok(TracerData {
        grid,
        readings,
        truth: TracerTruth {
            corrections_rigid_removed_mm: corrections,
            stations_mm: stations.iter().map(|s| [s.x, s.y, s.z]).collect(),
            dead_paths_mm: dead_paths,
            noise_um: Some(config.noise_um),
            extra,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_layout_is_the_check_data_layout() {
        let d = generate(&TracerConfig::default()).unwrap();
        assert_eq!(d.grid.len(), 100);
        assert_eq!(d.readings.len(), 600);
        assert_eq!(d.grid[1].position(), [0.0, 0.0, 100.0]);
        assert_eq!(d.grid[99].position(), [400.0, 400.0, 300.0]);
        // Each station is zeroed at its first point.
        assert!(
            d.readings
                .iter()
                .filter(|r| r.point == "1")
                .all(|r| r.l == 0.0)
        );
        // The field has the configured RMS before the rigid part is removed,
        // and keeps most of it after.
        let c = &d.truth.corrections_rigid_removed_mm;
        let rms = (c
            .iter()
            .map(|v| v.iter().map(|x| x * x).sum::<f64>())
            .sum::<f64>()
            / c.len() as f64)
            .sqrt();
        assert!(rms > 1e-3 && rms <= 5.0e-3 * (1.0 + 1e-12), "rms {rms}");
    }

    #[test]
    fn readings_follow_the_geometry_and_noise_is_separate() {
        let quiet = TracerConfig {
            noise_um: 0.0,
            resolution_um: 0.0,
            ..TracerConfig::default()
        };
        let a = generate(&quiet).unwrap();
        let b = generate(&TracerConfig {
            noise_seed: 7,
            ..quiet.clone()
        })
        .unwrap();
        // No noise: the noise seed changes no reading.
        assert_eq!((&a.grid, &a.readings), (&b.grid, &b.readings));
        let noisy = generate(&TracerConfig::default()).unwrap();
        let diff: Vec<f64> = a
            .readings
            .iter()
            .zip(&noisy.readings)
            .map(|(p, q)| (p.l - q.l) / UM)
            .collect();
        let sd = (diff.iter().map(|d| d * d).sum::<f64>() / diff.len() as f64).sqrt();
        // Noise σ 0.2 µm on each reading minus the zeroing reading's: ≈ 0.28 µm.
        assert!(sd > 0.2 && sd < 0.36, "{sd}");
        assert_eq!(
            a.truth.corrections_rigid_removed_mm,
            noisy.truth.corrections_rigid_removed_mm
        );
        assert_eq!(a.truth.stations_mm, noisy.truth.stations_mm);
    }

    #[test]
    fn missing_readings_and_bad_settings() {
        let d = generate(&TracerConfig {
            missing: 0.2,
            ..TracerConfig::default()
        })
        .unwrap();
        assert!(
            d.readings.len() > 400 && d.readings.len() < 560,
            "{}",
            d.readings.len()
        );
        for bad in [
            TracerConfig {
                counts: [1, 5, 5],
                ..TracerConfig::default()
            },
            TracerConfig {
                station_distance: 0.5,
                ..TracerConfig::default()
            },
            TracerConfig {
                missing: 1.0,
                ..TracerConfig::default()
            },
            TracerConfig {
                noise_um: f64::NAN,
                ..TracerConfig::default()
            },
        ] {
            assert!(generate(&bad).is_err(), "{bad:?}");
        }
    }
}
