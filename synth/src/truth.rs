//! Ground truth: `truth.json` (true cameras with K, R, t, P, distortion;
//! spheres; the exact sphere centres of every instant; the injected error
//! functions at the targets; the reference figures the evaluation gives on the
//! true positions) and `truth_points.csv`.

use std::collections::BTreeMap;

use formats::{Axis, PointRow, SphereRow, Truth, TruthCamera, TruthInstant};
use serde_json::{Map, Value, json};

use crate::config::Config;
use crate::illumination::IlluminationSource;
use crate::machine::{AxisErrorValues, axis_error_values};
use crate::procedure::Plan;
use crate::rig::{SynthCamera, SynthRig, principal_distance_mm};
use crate::{Result, SynthError};

/// The true cameras, with their serial, nominal description and optics in `extra`.
pub(crate) fn truth_cameras(rig: &SynthRig, config: &Config) -> Vec<TruthCamera> {
    rig.cameras
        .iter()
        .map(|c| {
            let mut t = TruthCamera::new(c.id, &c.camera);
            t.extra.insert("serial".into(), json!(c.serial));
            t.extra.insert("nominal".into(), json!(c.nominal));
            t.extra.insert(
                "optics".into(),
                json!({
                    "focal_mm": config.optics.focal_mm,
                    "principal_distance_mm": principal_distance_mm(config.optics.focal_mm, config.optics.focus_distance_mm),
                    "f_number": config.optics.f_number,
                    "focus_distance_mm": config.optics.focus_distance_mm,
                    "psf_sigma_px": c.optics.psf_sigma_px,
                    "pixel_mm": c.optics.pixel_mm,
                }),
            );
            // What a pixel's value is proportional to (see synth::illumination).
            t.extra.insert(
                "illumination".into(),
                match c.lens.as_ref().map(|l| l.source()) {
                    Some(IlluminationSource::Physical(v)) => json!({
                        "model": "lens",
                        "relative_illumination": "cos⁴θ·V(tan θ)·|∂ideal/∂observed|",
                        "vignetting": v,
                        "flat_field_radiance_e": c.flat_field_radiance_e(),
                    }),
                    Some(IlluminationSource::Profile(p)) => json!({
                        "model": "profile",
                        "relative_illumination": "1 + k1·ρ² + k2·ρ⁴ + k3·ρ⁶, ρ = |p − centre_px|/radius_px",
                        "centre_px": p.centre_px,
                        "radius_px": p.radius_px,
                        "k": p.k,
                        "flat_field_radiance_e": c.flat_field_radiance_e(),
                    }),
                    None => json!({"model": "radiance", "relative_illumination": 1.0}),
                },
            );
            if let Ok(Some(p)) = config.optics.lens_profile() {
                t.extra.insert("lens_profile".into(), lens_profile_truth(c, &p));
            }
            if config.sensor.has_readout_model() {
                t.extra.insert("sensor".into(), sensor_truth(c, config));
            }
            t
        })
        .collect()
}

/// A camera's lens profile: its numbers, lensfun's radii in mm, and the
/// Brown coefficients fitted to its distortion with the fit's largest residual.
fn lens_profile_truth(c: &SynthCamera, p: &crate::config::LensProfile) -> Value {
    let k = &c.camera.intrinsics;
    let fit = p
        .brown_in_pixels(k, c.sensor.width, c.sensor.height, c.optics.pixel_mm)
        .and_then(Result::ok);
    json!({
        "profile": p,
        "vignetting_radius_mm": p.vignetting_radius_mm(),
        "distortion_radius_mm": p.distortion_radius_mm(),
        "brown_k": fit.map(|f| f.k),
        "brown_fit_max_residual_px": fit.map(|f| f.max_residual_px),
    })
}

/// A camera's readout: file and ADC depth, gain (file DN per electron),
/// offset, read noise, the fixed-pattern parameters, the injected defects
/// (`hot_pixels` with their dark electrons, `dead_pixels`; x = column,
/// y = row, the centre of the top-left pixel at (0, 0)) and the calibration
/// stack size.
pub fn sensor_truth(c: &SynthCamera, config: &Config) -> Value {
    let s = &c.sensor;
    let p = c.readout.params();
    let defects = c.defects();
    json!({
        "bits": s.bits,
        "adc_bits": c.readout.adc_bits(),
        "gain_dn_per_e": s.gain_dn_per_e,
        "offset_dn": s.offset_dn,
        "read_noise_e": s.read_noise_e,
        "shot_noise": s.shot_noise,
        "prnu": p.prnu,
        "dsnu_dn": p.dsnu_dn,
        "column_offset_dn": p.column_offset_dn,
        "row_offset_dn": p.row_offset_dn,
        "hot_pixel_e": p.hot_pixel_e,
        "hot_pixels": defects
            .hot
            .iter()
            .map(|h| json!({"x": h.x, "y": h.y, "dark_e": h.dark_e}))
            .collect::<Vec<_>>(),
        "dead_pixels": defects
            .dead
            .iter()
            .map(|[x, y]| json!({"x": x, "y": y}))
            .collect::<Vec<_>>(),
        "calibration_frames": config.sensor.calibration_frames,
    })
}

/// Round to 1e-12 mm so that JSON stays short (far below any measurable size).
fn clean(x: f64) -> f64 {
    (x * 1e12).round() / 1e12
}

/// One instant of `truth.json`, with its sequence number, line, time and pose error.
fn truth_instant(plan: &Plan, i: &crate::procedure::Instant) -> TruthInstant {
    let spheres: BTreeMap<String, [f64; 3]> = plan
        .centres(i)
        .iter()
        .zip(&plan.spheres)
        .map(|(c, s)| (s.name.clone(), [clean(c.x), clean(c.y), clean(c.z)]))
        .collect();
    let mut extra = Map::new();
    extra.insert("frame".into(), json!(i.index));
    extra.insert("line".into(), json!(i.line + 1));
    extra.insert("time_s".into(), json!(clean(i.time_s)));
    extra.insert(
        "delta_um".into(),
        json!(i.error.delta.map(|v| clean(v * 1e3)).as_slice()),
    );
    extra.insert(
        "epsilon_urad".into(),
        json!(i.error.epsilon.map(|v| clean(v * 1e6)).as_slice()),
    );
    TruthInstant {
        axis: i.axis,
        direction: i.direction,
        run: i.run,
        target: i.target,
        capture: i.capture,
        nominal: i.nominal,
        spheres,
        extra,
    }
}

fn values_json(axis: Axis, v: &AxisErrorValues) -> Map<String, Value> {
    let [a, b] = axis.others();
    let mut m = Map::new();
    m.insert(
        "positioning_up_um".into(),
        json!(clean(v.positioning_up_um)),
    );
    m.insert(
        "positioning_down_um".into(),
        json!(clean(v.positioning_down_um)),
    );
    m.insert(
        format!("straightness_{}_um", a.name()),
        json!(clean(v.straightness_a_um)),
    );
    m.insert(
        format!("straightness_{}_um", b.name()),
        json!(clean(v.straightness_b_um)),
    );
    m.insert("roll_urad".into(), json!(clean(v.roll_urad)));
    m.insert("pitch_urad".into(), json!(clean(v.pitch_urad)));
    m.insert("yaw_urad".into(), json!(clean(v.yaw_urad)));
    m
}

/// The injected error functions of each tested axis at its targets (µm, µrad,
/// without the random offsets), with the curve parameters, and per line the
/// constant contribution of the other axes standing at that line.
fn injected_errors(config: &Config) -> Value {
    let mut out = Map::new();
    for travel in &config.procedure.axes {
        let Some(errors) = config.machine.axis(travel.axis) else {
            continue;
        };
        let targets: Vec<Value> = (0..travel.targets())
            .map(|k| {
                let p = travel.target_position(k);
                let mut m = values_json(travel.axis, &axis_error_values(errors, travel, p));
                m.insert("target".into(), json!(k));
                m.insert("position_mm".into(), json!(p));
                Value::Object(m)
            })
            .collect();
        let lines: Vec<Value> = travel
            .lines_mm
            .iter()
            .enumerate()
            .map(|(l, &offset)| {
                let mut nominal = [0.0; 3];
                let other = if travel.axis == Axis::X {
                    Axis::Y
                } else {
                    Axis::X
                };
                nominal[other.index()] = offset;
                nominal[travel.axis.index()] = travel.start_mm;
                // Error of every axis but this one, at this line (no reversal).
                let mut delta = [0.0; 3];
                let mut eps = [0.0; 3];
                for t in &config.procedure.axes {
                    if t.axis == travel.axis {
                        continue;
                    }
                    if let Some(e) = config.machine.axis(t.axis) {
                        let se = axis_error_values(e, t, nominal[t.axis.index()])
                            .small_error(t.axis, None);
                        for k in 0..3 {
                            delta[k] += se.delta[k] * 1e3;
                            eps[k] += se.epsilon[k] * 1e6;
                        }
                    }
                }
                json!({
                    "line": l + 1,
                    "offset_axis": other.name(),
                    "offset_mm": offset,
                    "other_axes_delta_um": delta.map(clean),
                    "other_axes_epsilon_urad": eps.map(clean),
                })
            })
            .collect();
        out.insert(
            travel.axis.name().into(),
            json!({
                "model": errors,
                "lines": lines,
                "targets": targets,
            }),
        );
    }
    Value::Object(out)
}

/// The figures the evaluation gives on the exact positions (report.json shape).
pub fn figures(points: &[PointRow]) -> Result<Value> {
    let report =
        evaluate::evaluate(points, &evaluate::Options::default()).map_err(SynthError::Evaluate)?;
    serde_json::to_value(&report).map_err(SynthError::FiguresJson)
}

/// The target's further placements, `target_poses`: `[{pose, offset_mm}]`
/// (pose 0, home, first), where `[target] poses_mm` gives any.
pub(crate) fn insert_target_poses(extra: &mut Map<String, Value>, config: &Config) {
    if config.target.poses_mm.is_empty() {
        return;
    }
    let poses: Vec<Value> = crate::target::poses(&config.target)
        .iter()
        .map(|(pose, o)| json!({"pose": pose, "offset_mm": [o.x, o.y, o.z]}))
        .collect();
    extra.insert("target_poses".into(), Value::Array(poses));
}

/// The `truth.json` of a scene without spheres (the target, the board):
/// the true cameras and `extra`.
pub(crate) fn cameras_truth(rig: &SynthRig, config: &Config, extra: Map<String, Value>) -> Truth {
    Truth {
        cameras: truth_cameras(rig, config),
        spheres: Vec::new(),
        instants: Vec::new(),
        extra,
    }
}

/// The whole `truth.json` of a campaign.
pub(crate) fn campaign_truth(
    config: &Config,
    rig: &SynthRig,
    plan: &Plan,
    points: &[PointRow],
) -> Result<Truth> {
    let mut extra = Map::new();
    extra.insert("seed".into(), json!(config.seed));
    extra.insert("start_time".into(), json!(config.procedure.start_time));
    extra.insert("errors".into(), injected_errors(config));
    insert_target_poses(&mut extra, config);
    // A procedure evaluate cannot evaluate at all (one target per line) still
    // gets its images and truth; the reason replaces the figures. One run is
    // evaluated: its figures say what ISO 230-2 leaves out (`left_out`).
    match figures(points) {
        Ok(f) => extra.insert("figures".into(), f),
        Err(e) => extra.insert("figures_error".into(), json!(e.to_string())),
    };
    Ok(Truth {
        cameras: truth_cameras(rig, config),
        spheres: plan
            .spheres
            .iter()
            .map(|s| SphereRow {
                name: s.name.clone(),
                diameter: 2.0 * s.radius,
            })
            .collect(),
        instants: plan
            .instants
            .iter()
            .map(|i| truth_instant(plan, i))
            .collect(),
        extra,
    })
}

/// How far a measured sphere moved from the first instant of its sweep line,
/// against how far it truly moved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisplacementError {
    /// The instant.
    pub instant: formats::InstantKey,
    /// True displacement along the moving axis since the line's first instant (mm).
    pub travel: f64,
    /// Measured minus true displacement vector (mm).
    pub error: [f64; 3],
}

/// Displacement errors of `sphere` over every instant present in both
/// `measured` and `truth` (points.csv rows), in the order of `measured`;
/// each line's reference is its first instant in `measured`.
pub fn displacement_errors(
    measured: &[PointRow],
    truth: &[PointRow],
    sphere: &str,
) -> Vec<DisplacementError> {
    let exact: BTreeMap<formats::InstantKey, [f64; 3]> = truth
        .iter()
        .filter(|p| p.sphere == sphere)
        .map(|p| (p.instant(), p.position()))
        .collect();
    let mut first: BTreeMap<formats::LineKey, ([f64; 3], [f64; 3])> = BTreeMap::new();
    measured
        .iter()
        .filter(|p| p.sphere == sphere)
        .filter_map(|p| {
            let key = p.instant();
            let t = *exact.get(&key)?;
            let m = p.position();
            let (m0, t0) = *first.entry(key.line()).or_insert((m, t));
            let a = key.axis.index();
            Some(DisplacementError {
                instant: key,
                travel: t[a] - t0[a],
                error: [0, 1, 2].map(|i| (m[i] - m0[i]) - (t[i] - t0[i])),
            })
        })
        .collect()
}

/// Scale error (ppm) of the displacements along `axis`: the least-squares
/// slope of the error component along the axis against the true travel,
/// pooled over the lines of that axis with an offset per line (so that the
/// error of each line's reference instant, common to all its displacements,
/// does not tilt the slope). `None` without travel.
pub fn scale_error_ppm(errors: &[DisplacementError], axis: formats::Axis) -> Option<f64> {
    let mut lines: BTreeMap<formats::LineKey, Vec<(f64, f64)>> = BTreeMap::new();
    for e in errors.iter().filter(|e| e.instant.axis == axis) {
        lines
            .entry(e.instant.line())
            .or_default()
            .push((e.travel, e.error[axis.index()]));
    }
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for points in lines.values() {
        let n = points.len() as f64;
        let (md, me) = points
            .iter()
            .fold((0.0, 0.0), |(a, b), (d, e)| (a + d / n, b + e / n));
        for (d, e) in points {
            sxy += (d - md) * (e - me);
            sxx += (d - md) * (d - md);
        }
    }
    (sxx > 0.0).then(|| sxy / sxx * 1e6)
}

/// Root mean square length of displacement errors (mm); `None` when there are none.
pub fn rms(errors: &[DisplacementError]) -> Option<f64> {
    (!errors.is_empty()).then(|| {
        let ss: f64 = errors
            .iter()
            .map(|e| e.error.iter().map(|v| v * v).sum::<f64>())
            .sum();
        (ss / errors.len() as f64).sqrt()
    })
}
