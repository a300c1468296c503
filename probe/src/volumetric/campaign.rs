//! Error curves from a vision campaign (`--from-report DIR`): the figures
//! `trinocular evaluate` writes for each swept axis, converted to the
//! conventions of docs/probe-volumetric.md.
//!
//! What evaluate reports for the main line of an axis j, per target k at
//! commanded position `q_k`: the positional deviation `d_j` of the
//! evaluated sphere along the fitted axis direction (datum: first target),
//! its straightness deviations `d_o` in the two perpendicular world
//! directions (least-squares line removed), roll, pitch and yaw of the
//! table (rotation vector of the sphere set since the first target, world
//! axes: X roll = εx, pitch = εy, yaw = εz; Y roll = εy, pitch = εx,
//! yaw = εz; Z roll = εz, pitch = εx, yaw = εy), and the sphere's mean
//! centre `p_k` (flatness points).
//!
//! The conversion:
//! 1. ε_k = the rotation vector above (rad), re-referenced to zero at the
//!    reference position `r_j` (below) by subtracting its value there
//!    (linear between targets).
//! 2. Rotation reference point: §5 rotates a carriage about the machine
//!    origin carried by it, while the sphere sits at the lever
//!    `s_j = p − Σ q_m·e_m` from that point (the sum over j and the
//!    carriages between j and the frame on the workpiece side of the chain,
//!    at their commanded positions; mean over the targets). The translation
//!    at the reference point is `δ_k = d_k − ε_k × s_j` with
//!    `d_k = d_j·e_j + Σ_o d_o·e_o`.
//! 3. Positioning `δ_j` is zeroed at `r_j`; the straightness curves keep
//!    their least-squares line removed, and its slopes σ_o, refitted after
//!    step 2, turn the fitted direction into the carriage's direction
//!    `a_j ∝ d + Σ σ_o·p_o` (p_o ⟂ d).
//! 4. Squareness from those directions in the frame §5 defines (x along
//!    a_X, y in the plane of a_X and a_Y): `EC0Y = −asin(a_X·a_Y)`, and with
//!    a Z sweep `EA0Z = −asin(a_Z·ŷ)`, `EB0Z = asin((a_Z·x̂)/cos EA0Z)`.
//!
//! The reference position `r_j` is where the main line of another swept axis
//! crosses axis j (its off-axis coordinate j): there the errors of j are zero,
//! so the directions measured on the other lines are the directions the chain
//! uses. Without a crossing line it is the first target (noted).

use std::collections::BTreeMap;

use formats::Axis;
pub use formats::probe::volumetric::report::SweepInfo;
use formats::probe::volumetric::{EvaluateLine, EvaluateReport};
use geom::Vector3;

use super::chain::{Chain, DEFAULT_CHAIN, Side};
use super::curves::MeasuredAxis;
use super::report::ReadingsU;
use crate::{CampaignFault, ChainFault, ProbeError, Result};

/// µm → mm.
const UM: f64 = 1e-3;
/// µrad → rad.
const URAD: f64 = 1e-6;
/// Off-axis coordinates of lines closer than this (mm) are the same.
const LINE_TOLERANCE_MM: f64 = 0.01;

/// Squareness as measured by the campaign (rad); a value is absent when the
/// axes it relates were not both swept.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MeasuredSquareness {
    /// Y against X.
    pub ec0y: Option<f64>,
    /// Z against X.
    pub eb0z: Option<f64>,
    /// Z against Y.
    pub ea0z: Option<f64>,
}

/// The error curves of a campaign in the conventions of §5.
#[derive(Debug, Clone, PartialEq)]
pub struct CampaignCurves {
    /// One per swept axis (positions = commanded targets).
    pub axes: Vec<MeasuredAxis>,
    /// Squareness between the swept axes.
    pub squareness: MeasuredSquareness,
    /// Per swept axis, how it was converted.
    pub sweeps: Vec<SweepInfo>,
    /// Choices worth knowing (a reference at the first target, …).
    pub notes: Vec<String>,
    /// The readings' standard uncertainty from the report's U, when it has them.
    pub readings_u: Option<ReportReadingsU>,
}

/// The standard uncertainty of one reading of the campaign's curves, from
/// the expanded uncertainties (k = 2) evaluate gives its range figures.
///
/// A range is the difference of two readings, `u(range) = √2·u`, so one
/// reading has `u = U(range)/(2√2)`. Translations: the largest U among the
/// swept main lines' M (range of the mean bidirectional deviations, the
/// positioning curve) and least-squares straightness (range of the
/// deviations); rotations: the largest U of their roll, pitch and yaw
/// ranges. One u for each kind, as an instrument's certificate states it.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportReadingsU {
    /// The uncertainties (mm, rad).
    pub u: ReadingsU,
    /// The report figure the translation u comes from, and its U (µm).
    pub translation_from: (String, f64),
    /// The report figure the rotation u comes from, and its U (µrad).
    pub rotation_from: (String, f64),
}

impl ReportReadingsU {
    /// One line saying where the readings' uncertainty came from.
    pub fn note(&self) -> String {
        format!(
            "the curves' readings take their uncertainty from the evaluate report: u = U/(2√2) of \
             the largest range U, {} = {:.3} µm → {:.3} µm (translations), {} = {:.2} µrad → \
             {:.2} µrad (rotations); --curve-u-um/--curve-u-urad override",
            self.translation_from.0,
            self.translation_from.1,
            self.u.translation_mm / UM,
            self.rotation_from.0,
            self.rotation_from.1,
            self.u.rotation_rad / URAD
        )
    }
}

/// The readings' uncertainty from the U of the main lines' range figures
/// ([`ReportReadingsU`]); `None` when a swept line lacks them (evaluated
/// with `--trials 0`) or has no angular table.
fn readings_u(lines: &[(Axis, &EvaluateLine)]) -> Option<ReportReadingsU> {
    let mut translation: Option<(String, f64)> = None;
    let mut rotation: Option<(String, f64)> = None;
    let larger = |best: &mut Option<(String, f64)>, name: String, u: f64| {
        if best.as_ref().is_none_or(|(_, b)| u > *b) {
            *best = Some((name, u));
        }
    };
    for &(axis, line) in lines {
        larger(
            &mut translation,
            format!("axes.{axis}.positioning.M_U_um"),
            line.positioning.m_u_um?,
        );
        for (across, s) in &line.straightness {
            larger(
                &mut translation,
                format!("axes.{axis}.straightness.{across}.lsq_U_um"),
                s.lsq_u_um?,
            );
        }
        let a = line.angular.as_ref()?;
        for (name, u) in [
            ("roll", a.roll_u_urad),
            ("pitch", a.pitch_u_urad),
            ("yaw", a.yaw_u_urad),
        ] {
            larger(
                &mut rotation,
                format!("axes.{axis}.angular.{name}_U_urad"),
                u?,
            );
        }
    }
    let (translation, rotation) = (translation?, rotation?);
    let per_reading = 2.0 * std::f64::consts::SQRT_2;
    Some(ReportReadingsU {
        u: ReadingsU {
            translation_mm: translation.1 / per_reading * UM,
            rotation_rad: rotation.1 / per_reading * URAD,
        },
        translation_from: translation,
        rotation_from: rotation,
    })
}

/// The world rotation vector (εx, εy, εz) of `axis`'s roll, pitch, yaw
/// (evaluate's angular convention).
pub(crate) fn rotation_vector(axis: Axis, roll: f64, pitch: f64, yaw: f64) -> Vector3<f64> {
    match axis {
        Axis::X => Vector3::new(roll, pitch, yaw),
        Axis::Y => Vector3::new(pitch, roll, yaw),
        Axis::Z => Vector3::new(pitch, yaw, roll),
    }
}

fn axis_of(name: &str) -> Option<Axis> {
    formats::probe::volumetric::axis_named(name)
}

/// A fault of the evaluate report `source`.
fn campaign_error(source: &str, fault: CampaignFault) -> ProbeError {
    ProbeError::Campaign {
        report: source.to_string(),
        fault,
    }
}

/// One target of a sweep, gathered from the report's tables.
struct Target {
    nominal: f64,
    positioning: f64,
    up: Option<f64>,
    down: Option<f64>,
    across: [f64; 2],
    rotation: Vector3<f64>,
    sphere: Vector3<f64>,
}

/// The targets of a line, sorted by commanded position (strictly increasing).
fn targets(
    axis: Axis,
    line: &EvaluateLine,
    report: &EvaluateReport,
    others: [Axis; 2],
    source: &str,
) -> Result<Vec<Target>> {
    let angular = line
        .angular
        .as_ref()
        .ok_or_else(|| campaign_error(source, CampaignFault::NoAngular { axis }))?;
    let flatness = report
        .flatness
        .as_ref()
        .ok_or_else(|| campaign_error(source, CampaignFault::NoFlatness))?;
    let straight: Vec<BTreeMap<u32, f64>> = others
        .iter()
        .map(|o| {
            line.straightness
                .get(o.name())
                .map(|s| {
                    s.targets
                        .iter()
                        .map(|t| (t.target, t.deviation_um))
                        .collect()
                })
                .ok_or_else(|| {
                    campaign_error(source, CampaignFault::NoStraightness { axis, across: *o })
                })
        })
        .collect::<Result<_>>()?;
    let rotations: BTreeMap<u32, Vector3<f64>> = angular
        .targets
        .iter()
        .map(|t| {
            (
                t.target,
                rotation_vector(axis, t.roll_urad, t.pitch_urad, t.yaw_urad) * URAD,
            )
        })
        .collect();
    let spheres: BTreeMap<u32, Vector3<f64>> = flatness
        .points
        .iter()
        .filter(|p| axis_of(&p.axis) == Some(axis) && p.line == line.line)
        .map(|p| (p.target, Vector3::new(p.x, p.y, p.z)))
        .collect();
    let mut out = Vec::with_capacity(line.positioning.targets.len());
    for t in &line.positioning.targets {
        let k = t.target;
        let missing = |table: &'static str| {
            campaign_error(
                source,
                CampaignFault::NoValue {
                    axis,
                    table,
                    target: k,
                },
            )
        };
        let positioning = t
            .mean_um
            .or(t.mean_up_um)
            .or(t.mean_down_um)
            .ok_or_else(|| campaign_error(source, CampaignFault::NoMean { axis, target: k }))?;
        out.push(Target {
            nominal: t.nominal,
            positioning: positioning * UM,
            up: t.mean_up_um.map(|v| v * UM),
            down: t.mean_down_um.map(|v| v * UM),
            across: [
                *straight[0].get(&k).ok_or_else(|| missing("straightness"))? * UM,
                *straight[1].get(&k).ok_or_else(|| missing("straightness"))? * UM,
            ],
            rotation: *rotations
                .get(&k)
                .ok_or_else(|| missing("angular.targets"))?,
            sphere: *spheres.get(&k).ok_or_else(|| missing("flatness points"))?,
        });
    }
    out.sort_by(|a, b| a.nominal.total_cmp(&b.nominal));
    if let Some(w) = out.windows(2).find(|w| w[1].nominal <= w[0].nominal) {
        return Err(campaign_error(
            source,
            CampaignFault::TwoTargets {
                axis,
                position: w[0].nominal,
            },
        ));
    }
    if out.len() < 2 {
        return Err(campaign_error(
            source,
            CampaignFault::TooFewTargets {
                axis,
                count: out.len(),
            },
        ));
    }
    Ok(out)
}

/// The commanded off-axis coordinates of a line (mm), indexed x, y, z.
fn off_axis(line: &EvaluateLine) -> [f64; 3] {
    let mut c = [0.0; 3];
    for (k, v) in &line.off_axis {
        if let Some(a) = axis_of(k) {
            c[a.index()] = *v;
        }
    }
    c
}

/// Convert the main line of every axis in `report` (read from `source`) to
/// §5 curves for `chain`; every swept axis must be on the workpiece side
/// (the spheres ride on the table).
pub fn from_evaluate(
    report: &EvaluateReport,
    chain: &Chain,
    source: &str,
) -> Result<CampaignCurves> {
    let lines = swept_lines(report, chain, source)?;
    let mut notes = Vec::new();
    let mut axes = Vec::new();
    let mut sweeps = Vec::new();
    let mut directions: BTreeMap<Axis, Vector3<f64>> = BTreeMap::new();
    for &(axis, line) in &lines {
        let mut others = axis.others();
        others.sort();
        let t = targets(axis, line, report, others, source)?;
        let nominal: Vec<f64> = t.iter().map(|t| t.nominal).collect();
        let (first, last) = (nominal[0], nominal[nominal.len() - 1]);

        let reference = reference_position(axis, &lines, (first, last), &mut notes);
        let off = off_axis(line);
        let lever = lever(chain, axis, off, &t);

        // 1. rotations referenced at r; 2. translations at the reference point.
        let rotations: Vec<Vector3<f64>> = t.iter().map(|t| t.rotation).collect();
        let at_reference = geom::interp::linear(&nominal, &rotations, reference)?;
        let epsilon: Vec<Vector3<f64>> = rotations.iter().map(|e| e - at_reference).collect();
        let abbe: Vec<Vector3<f64>> = epsilon.iter().map(|e| e.cross(&lever)).collect();
        let mut delta: Vec<Vector3<f64>> = t
            .iter()
            .zip(&abbe)
            .map(|(t, a)| {
                let mut d = Vector3::ith(axis.index(), t.positioning);
                d[others[0].index()] = t.across[0];
                d[others[1].index()] = t.across[1];
                d - a
            })
            .collect();
        // 3. positioning zero at r; straightness slopes → direction.
        let positioning: Vec<f64> = delta.iter().map(|d| d[axis.index()]).collect();
        let offset = geom::interp::linear(&nominal, &positioning, reference)?;
        for d in &mut delta {
            d[axis.index()] -= offset;
        }
        let fitted = Vector3::from(line.direction);
        let fitted = if fitted.norm() > 0.0 {
            fitted.normalize()
        } else {
            return Err(campaign_error(
                source,
                CampaignFault::ZeroDirection { axis },
            ));
        };
        let direction = carriage_direction(fitted, others, &nominal, &delta)?;
        directions.insert(axis, direction);
        let shifted =
            |v: Option<f64>, abbe: &Vector3<f64>| v.map(|v| v - abbe[axis.index()] - offset);
        let (up, down): (Option<Vec<f64>>, Option<Vec<f64>>) = (
            t.iter().zip(&abbe).map(|(t, a)| shifted(t.up, a)).collect(),
            t.iter()
                .zip(&abbe)
                .map(|(t, a)| shifted(t.down, a))
                .collect(),
        );
        axes.push(MeasuredAxis {
            axis,
            positions: nominal.clone(),
            values: std::array::from_fn(|m| {
                if m < 3 {
                    delta.iter().map(|d| d[m]).collect()
                } else {
                    epsilon.iter().map(|e| e[m - 3]).collect()
                }
            }),
            positioning_up: up,
            positioning_down: down,
        });
        sweeps.push(SweepInfo {
            axis,
            line: line.line,
            off_axis_mm: off,
            reference_mm: reference,
            lever_mm: [lever.x, lever.y, lever.z],
            fitted_direction: [fitted.x, fitted.y, fitted.z],
            direction: [direction.x, direction.y, direction.z],
        });
    }
    Ok(CampaignCurves {
        axes,
        squareness: squareness(&directions),
        sweeps,
        notes,
        readings_u: readings_u(&lines),
    })
}

/// The main line of every swept axis of `report` (read from `source`), in
/// axis order; at least one.
fn main_lines<'r>(
    report: &'r EvaluateReport,
    source: &str,
) -> Result<Vec<(Axis, &'r EvaluateLine)>> {
    let mut lines = report
        .axes
        .iter()
        .map(|(name, line)| {
            axis_of(name).map(|axis| (axis, line)).ok_or_else(|| {
                campaign_error(source, CampaignFault::NotAnAxis { name: name.clone() })
            })
        })
        .collect::<Result<Vec<_>>>()?;
    lines.sort_by_key(|(a, _)| *a);
    if lines.is_empty() {
        return Err(campaign_error(source, CampaignFault::NoAxis));
    }
    Ok(lines)
}

/// The main line of every swept axis, in axis order; each axis must be on
/// the workpiece side of the chain.
fn swept_lines<'r>(
    report: &'r EvaluateReport,
    chain: &Chain,
    source: &str,
) -> Result<Vec<(Axis, &'r EvaluateLine)>> {
    let lines = main_lines(report, source)?;
    if let Some(&(axis, _)) = lines
        .iter()
        .find(|(a, _)| chain.side(*a) != Some(Side::Workpiece))
    {
        return Err(ProbeError::Chain {
            text: chain.text.clone(),
            fault: ChainFault::SweptOnToolSide {
                axis,
                report: source.to_string(),
            },
        });
    }
    Ok(lines)
}

/// The chain when none is given with a campaign: [`DEFAULT_CHAIN`] keeping
/// only the axes that have error curves — those `report` (read from
/// `source`) swept and `others` (curves from elsewhere, e.g. `--errors`) —
/// with the note that says so when it leaves an axis out (an X and Y
/// campaign alone gives `WXYFT`).
pub fn default_chain(
    report: &EvaluateReport,
    others: &[Axis],
    source: &str,
) -> Result<(Chain, Option<String>)> {
    let swept: Vec<Axis> = main_lines(report, source)?
        .into_iter()
        .map(|(a, _)| a)
        .collect();
    let with_curves: Vec<Axis> = swept.iter().chain(others).copied().collect();
    let default = Chain::parse(DEFAULT_CHAIN)?;
    let chain = default.keeping(&with_curves);
    let left_out: Vec<Axis> = default
        .axes()
        .filter(|a| !with_curves.contains(a))
        .collect();
    let note = (!left_out.is_empty()).then(|| {
        format!(
            "chain {}: the default {DEFAULT_CHAIN} without {}, which {} no error curves (the campaign \
             swept {}); --chain chooses another",
            chain.text,
            names(&left_out),
            if left_out.len() == 1 { "has" } else { "have" },
            names(&swept)
        )
    });
    Ok((chain, note))
}

/// `X`, `X and Y`, `X, Y and Z`.
fn names(axes: &[Axis]) -> String {
    let n: Vec<&str> = axes.iter().map(|a| a.name()).collect();
    match n.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => n.join(""),
    }
}

/// The reference position of `axis` (mm): where another sweep's main line
/// crosses it, else (with a note) its first target.
fn reference_position(
    axis: Axis,
    lines: &[(Axis, &EvaluateLine)],
    (first, last): (f64, f64),
    notes: &mut Vec<String>,
) -> f64 {
    let crossing: Vec<f64> = lines
        .iter()
        .filter(|(b, _)| *b != axis)
        .map(|(_, l)| off_axis(l)[axis.index()])
        .collect();
    match crossing.first() {
        Some(&r) if r >= first && r <= last => {
            if crossing.iter().any(|c| (c - r).abs() > LINE_TOLERANCE_MM) {
                notes.push(format!(
                    "axis {axis}: the other lines cross it at different positions; its curves are zero at {r} mm"
                ));
            }
            r
        }
        Some(&r) => {
            notes.push(format!(
                "axis {axis}: the crossing line at {r} mm lies outside its travel [{first}, {last}] mm; \
                 its curves are zero at the first target"
            ));
            first
        }
        None => {
            notes.push(format!(
                "axis {axis}: no other line crosses it; its curves are zero at the first target"
            ));
            first
        }
    }
}

/// The mean lever from the carriage's reference point to the sphere (mm):
/// the sphere less the travel of the carriages that carry it.
fn lever(chain: &Chain, axis: Axis, off: [f64; 3], t: &[Target]) -> Vector3<f64> {
    let own = chain.workpiece.iter().position(|&a| a == axis).unwrap_or(0);
    let carriers = &chain.workpiece[own..];
    t.iter()
        .map(|t| {
            let mut q = Vector3::from(off);
            q[axis.index()] = t.nominal;
            let moved: Vector3<f64> = carriers
                .iter()
                .map(|m| Vector3::ith(m.index(), q[m.index()]))
                .sum();
            t.sphere - moved
        })
        .sum::<Vector3<f64>>()
        / t.len() as f64
}

/// The carriage's direction: the fitted sweep direction turned by the slopes
/// of the straightness profiles (which §5 counts as direction, not error).
fn carriage_direction(
    fitted: Vector3<f64>,
    others: [Axis; 2],
    nominal: &[f64],
    delta: &[Vector3<f64>],
) -> Result<Vector3<f64>> {
    let mut direction = fitted;
    for o in others {
        let profile: Vec<geom::Point2<f64>> = nominal
            .iter()
            .zip(delta)
            .map(|(&q, d)| geom::Point2::new(q, d[o.index()]))
            .collect();
        let slope = geom::fit::line_y_on_x(&profile)?.k;
        let e = Vector3::ith(o.index(), 1.0);
        direction += (e - fitted * e.dot(&fitted)).normalize() * slope;
    }
    Ok(direction.normalize())
}

/// Squareness (§5) from carriage directions in any frame: the §5 frame has x
/// along a_X and y in the plane of a_X and a_Y.
pub(crate) fn squareness(directions: &BTreeMap<Axis, Vector3<f64>>) -> MeasuredSquareness {
    let (Some(x), Some(y)) = (directions.get(&Axis::X), directions.get(&Axis::Y)) else {
        return MeasuredSquareness::default();
    };
    let e1 = x.normalize();
    let e2 = (y - e1 * y.dot(&e1)).normalize();
    let ec0y = -(y.normalize().dot(&e1)).asin();
    let (eb0z, ea0z) = match directions.get(&Axis::Z) {
        Some(z) => {
            let z = z.normalize();
            let a = -(z.dot(&e2)).asin();
            (Some((z.dot(&e1) / a.cos()).asin()), Some(a))
        }
        None => (None, None),
    };
    MeasuredSquareness {
        ec0y: Some(ec0y),
        eb0z,
        ea0z,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volumetric::chain::{Squareness, direction};

    #[test]
    fn squareness_comes_back_from_directions_in_a_turned_frame() {
        let s = Squareness {
            ec0y: 2e-5,
            eb0z: -3e-5,
            ea0z: 1.5e-5,
        };
        // The same three directions seen from a frame turned by a few mrad.
        let turn = geom::Rotation3::new(Vector3::new(3e-3, -2e-3, 5e-3));
        let d: BTreeMap<Axis, Vector3<f64>> = [Axis::X, Axis::Y, Axis::Z]
            .into_iter()
            .map(|a| (a, turn * direction(&s, a)))
            .collect();
        let m = squareness(&d);
        assert!((m.ec0y.unwrap_or(0.0) - s.ec0y).abs() < 1e-15);
        assert!((m.eb0z.unwrap_or(0.0) - s.eb0z).abs() < 1e-15);
        assert!((m.ea0z.unwrap_or(0.0) - s.ea0z).abs() < 1e-15);
    }

    #[test]
    fn roll_pitch_yaw_map_to_world_axes() {
        // evaluate: X roll εx pitch εy yaw εz; Y roll εy pitch εx yaw εz; Z roll εz pitch εx yaw εy.
        assert_eq!(
            rotation_vector(Axis::X, 1.0, 2.0, 3.0),
            Vector3::new(1.0, 2.0, 3.0)
        );
        assert_eq!(
            rotation_vector(Axis::Y, 1.0, 2.0, 3.0),
            Vector3::new(2.0, 1.0, 3.0)
        );
        assert_eq!(
            rotation_vector(Axis::Z, 1.0, 2.0, 3.0),
            Vector3::new(2.0, 3.0, 1.0)
        );
    }
}
