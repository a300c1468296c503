//! The predicted circular test (ISO 230-4, docs/probe-volumetric.md) in the workpiece
//! frame, where a ballbar sits: nominal path `w₀(θ) = c + R(cos θ, sin θ, 0)`
//! in 1° steps, each carriage at `q_L = s_L·(w₀_L − t_L)`, radial deviation
//! `Δ·(cos θ, sin θ, 0)`, and the circular deviation: the range of the radial
//! distances of the predicted path `w₀ + Δ` from its least-squares circle
//! centre, in the plane.

use formats::Axis;
use geom::{Point2, Vector3};

use super::chain::{Machine, Positions};
use super::model::{Evaluation, TRAVEL_TOLERANCE_MM};
use crate::{ProbeError, Result, VolumetricFault};

/// Angular step of the predicted path (degrees).
pub(crate) const STEP_DEG: usize = 1;

/// A circle in the workpiece frame, in the plane XY.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircleSpec {
    /// Centre c (mm).
    pub centre: [f64; 3],
    /// Radius R (mm).
    pub radius: f64,
}

/// One point of the predicted path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CirclePoint {
    /// θ (degrees).
    pub angle_deg: f64,
    /// Volumetric error Δ (mm).
    pub delta: [f64; 3],
    /// Radial deviation `Δ·(cos θ, sin θ, 0)` (mm).
    pub radial: f64,
}

/// The predicted circular test.
#[derive(Debug, Clone, PartialEq)]
pub struct CirclePrediction {
    /// The path, θ = 0°, 1°, … 359°.
    pub points: Vec<CirclePoint>,
    /// Range (max − min) of the radial deviations (mm).
    pub radial_range: f64,
    /// ISO 230-4 circular deviation: range of the distances of `w₀ + Δ` from
    /// their least-squares circle centre (mm).
    pub circular_deviation: f64,
    /// Least-squares circle centre (x, y) of the predicted path (mm).
    pub lsq_centre: [f64; 2],
    /// Its radius (mm).
    pub lsq_radius: f64,
}

/// The nominal path point at `angle_deg`.
fn nominal(spec: &CircleSpec, angle_deg: f64) -> Vector3<f64> {
    let t = angle_deg.to_radians();
    Vector3::new(
        spec.centre[0] + spec.radius * t.cos(),
        spec.centre[1] + spec.radius * t.sin(),
        spec.centre[2],
    )
}

/// The carriage positions of the whole path, checked against the measured
/// travel of every axis before anything is predicted: a circle that leaves
/// it is an error naming `--circle`, the axis and the span it needs.
pub(crate) fn positions(machine: &Machine<'_>, spec: &CircleSpec) -> Result<Vec<Positions>> {
    if !(spec.radius > 0.0 && spec.radius.is_finite() && spec.centre.iter().all(|c| c.is_finite()))
    {
        return Err(ProbeError::Volumetric(VolumetricFault::CircleRadius {
            radius: spec.radius,
        }));
    }
    for a in [Axis::X, Axis::Y] {
        if machine.chain.side(a).is_none() {
            return Err(ProbeError::Volumetric(VolumetricFault::CircleOffChain {
                axis: a,
                chain: machine.chain.text.clone(),
            }));
        }
    }
    let q: Vec<Positions> = (0..360)
        .step_by(STEP_DEG)
        .map(|d| machine.positions_for(&nominal(spec, d as f64)))
        .collect::<Result<_>>()
        .map_err(|e| ProbeError::At {
            label: "--circle".into(),
            error: Box::new(e),
        })?;
    for a in machine.chain.axes() {
        let i = a.index();
        let (lo, hi) = q
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[i]), hi.max(p[i]))
            });
        if let Some(model) = machine.model.axis(a) {
            let (t0, t1) = model.curves.travel();
            if lo < t0 - TRAVEL_TOLERANCE_MM || hi > t1 + TRAVEL_TOLERANCE_MM {
                return Err(ProbeError::Volumetric(
                    VolumetricFault::CircleOutsideTravel {
                        axis: a,
                        from: lo,
                        to: hi,
                        lo: t0,
                        hi: t1,
                    },
                ));
            }
        }
    }
    Ok(q)
}

/// Predict the circular test under `how`.
pub fn predict(
    machine: &Machine<'_>,
    spec: &CircleSpec,
    how: Evaluation,
) -> Result<CirclePrediction> {
    let q = positions(machine, spec)?;
    let mut points = Vec::with_capacity(q.len());
    let mut path = Vec::with_capacity(q.len());
    for (k, qk) in q.iter().enumerate() {
        let angle_deg = (k * STEP_DEG) as f64;
        let delta = machine.volumetric_error(qk, how)?;
        let t = angle_deg.to_radians();
        let radial = delta.x * t.cos() + delta.y * t.sin();
        let w = nominal(spec, angle_deg) + delta;
        path.push(Point2::new(w.x, w.y));
        points.push(CirclePoint {
            angle_deg,
            delta: [delta.x, delta.y, delta.z],
            radial,
        });
    }
    let radial: Vec<f64> = points.iter().map(|p| p.radial).collect();
    let fit = geom::fit::circle_2d(&path)?;
    Ok(CirclePrediction {
        points,
        radial_range: geom::stats::range(&radial)?,
        circular_deviation: geom::stats::range(&fit.residuals)?,
        lsq_centre: [fit.centre.x, fit.centre.y],
        lsq_radius: fit.radius,
    })
}
