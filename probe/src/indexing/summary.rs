//! `report.json` of the indexing method: the construction's figures, the
//! maxima and RMS of ΔθA and ΔθB, the radius against a nominal, per-detent
//! means and the positions beyond a tolerance. The types live in
//! `formats::probe::indexing::report`; [`report()`] fills them.

pub use formats::probe::indexing::report::{
    ADetent, AxesReport, BDetent, Exceedance, Extreme, GridReport, Report, SphereReport,
    ToleranceReport,
};

use formats::conformance::{Decision, Rule, decide};
use geom::montecarlo::COVERAGE_FACTOR;

use super::{Angles, Indexing, UM_PER_MM, layout};
use crate::{ProbeError, Result, Unsolvable};

/// What the user adds to the measurement.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Options {
    /// Nominal head-centre-to-stylus-ball length (mm), to compare the radius with.
    pub nominal_radius_mm: Option<f64>,
    /// Tolerance on |ΔθA| and |ΔθB| (arc-seconds): positions beyond it by
    /// more than their U are counted and listed.
    pub tolerance_arcsec: Option<f64>,
    /// Where the centres came from (a file name), for the page.
    pub source: String,
}

/// Most missing positions a warning lists by name.
const MISSING_NAMED: usize = 6;

/// The figures of `report.json` from the construction and the user's options.
pub fn report(ind: &Indexing, options: &Options) -> Result<Report> {
    for (name, value) in [
        ("--nominal-radius", options.nominal_radius_mm),
        ("--tolerance", options.tolerance_arcsec),
    ] {
        if let Some(v) = value
            && !(v.is_finite() && v > 0.0)
        {
            return Err(ProbeError::NotPositive {
                option: name,
                value: v,
            });
        }
    }
    let a = &ind.angles;
    let d_a: Vec<f64> = a.iter().map(|p| p.d_a_arcsec).collect();
    let with_b: Vec<&Angles> = a.iter().filter(|p| p.d_b_arcsec.is_some()).collect();
    let d_b: Vec<f64> = with_b.iter().filter_map(|p| p.d_b_arcsec).collect();
    let extreme = |values: &[(f64, &Angles)]| {
        values
            .iter()
            .max_by(|p, q| p.0.abs().total_cmp(&q.0.abs()))
            .map(|(v, p)| Extreme {
                a_deg: p.a_deg,
                b_deg: p.b_deg,
                value_arcsec: *v,
            })
    };
    let max_a = extreme(&a.iter().map(|p| (p.d_a_arcsec, p)).collect::<Vec<_>>())
        .ok_or(Unsolvable::NoPositions)?;
    let max_b = extreme(
        &with_b
            .iter()
            .filter_map(|p| p.d_b_arcsec.map(|v| (v, *p)))
            .collect::<Vec<_>>(),
    )
    .ok_or(Unsolvable::NoTiltedPosition)?;
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let residuals: Vec<f64> = a.iter().map(|p| p.residual_um).collect();
    let f = &ind.frame;
    let xyz = |v: &geom::nalgebra::Vector3<f64>| [v.x, v.y, v.z];
    let nominal_deviation = options
        .nominal_radius_mm
        .map(|n| (ind.radius_mm - n) * UM_PER_MM);
    let mut warnings = Vec::new();
    if !ind.layout.missing.is_empty() {
        let named: Vec<String> = ind
            .layout
            .missing
            .iter()
            .take(MISSING_NAMED)
            .map(|(a, b)| format!("({a}°, {b}°)"))
            .collect();
        warnings.push(format!(
            "{} positions of the {} × {} grid of measured A and B values were not measured: {}{}",
            ind.layout.missing.len(),
            ind.layout.a_levels.len(),
            ind.layout.b_levels.len(),
            named.join(", "),
            if ind.layout.missing.len() > MISSING_NAMED {
                ", …"
            } else {
                ""
            }
        ));
    }
    let a_detents = a_detents(ind);
    let b_detents = b_detents(ind);
    Ok(Report {
        method: "probe-head indexing errors (docs/probe-indexing.md)".into(),
        source: options.source.clone(),
        positions: a.len(),
        rotation_centre: [f.origin.x, f.origin.y, f.origin.z],
        u_rotation_centre_um: ind.u_origin_mm.map(|u| u * UM_PER_MM),
        radius_mm: ind.radius_mm,
        u_radius_um: ind.u_radius_mm * UM_PER_MM,
        nominal_radius_mm: options.nominal_radius_mm,
        radius_deviation_um: nominal_deviation,
        sphere_fit: SphereReport {
            residual_rms_um: geom::stats::rms(&residuals)?,
            residual_max_um: max_abs(residuals.iter().copied()),
            noise_um: ind.noise_mm * UM_PER_MM,
            condition: ind.condition,
        },
        axes: AxesReport {
            x: xyz(&f.x),
            y_a_axis: xyz(&f.y),
            z_b_axis: xyz(&f.z),
            b_circle_centre: [
                f.b_circle_centre.x,
                f.b_circle_centre.y,
                f.b_circle_centre.z,
            ],
            b_turn_positions: ind.layout.b_turn.len(),
            b_turn_step_deg: ind.layout.b_step_deg,
            a_sweep_positions: ind.layout.a_sweep.len(),
        },
        max_d_a_arcsec: max_a.value_arcsec.abs(),
        max_d_a_at: max_a,
        max_d_b_arcsec: max_b.value_arcsec.abs(),
        max_d_b_at: max_b,
        rms_d_a_arcsec: geom::stats::rms(&d_a)?,
        rms_d_b_arcsec: geom::stats::rms(&d_b)?,
        median_u_d_a_arcsec: median(a.iter().map(|p| p.u_d_a_arcsec).collect()),
        median_u_d_b_arcsec: median(with_b.iter().filter_map(|p| p.u_d_b_arcsec).collect()),
        max_detent_d_a_arcsec: max_abs(
            a_detents
                .iter()
                .filter(|d| layout::detent_key(d.a_deg) != 0)
                .map(|d| d.mean_d_a_arcsec),
        ),
        max_detent_d_b_arcsec: max_abs(b_detents.iter().map(|d| d.mean_d_b_arcsec)),
        a_detents,
        b_detents,
        tolerance: options.tolerance_arcsec.map(|t| tolerance(a, t)),
        grid: GridReport {
            a_deg: ind.layout.a_levels.clone(),
            b_deg: ind.layout.b_levels.clone(),
            missing: ind.layout.missing.iter().map(|&(a, b)| [a, b]).collect(),
        },
        warnings,
        conventions: conventions(),
        uncertainty: None,
    })
}

/// Largest magnitude of the values (0 when there are none).
fn max_abs(values: impl Iterator<Item = f64>) -> f64 {
    values.fold(0.0, |m, v| m.max(v.abs()))
}

/// Mean, smallest and largest ΔθA per A detent.
fn a_detents(ind: &Indexing) -> Vec<ADetent> {
    ind.layout
        .a_levels
        .iter()
        .map(|&level| {
            let values: Vec<f64> = ind
                .angles
                .iter()
                .filter(|p| layout::detent_key(p.a_deg) == layout::detent_key(level))
                .map(|p| p.d_a_arcsec)
                .collect();
            let n = values.len().max(1) as f64;
            ADetent {
                a_deg: level,
                positions: values.len(),
                mean_d_a_arcsec: values.iter().sum::<f64>() / n,
                min_d_a_arcsec: values.iter().copied().fold(f64::INFINITY, f64::min),
                max_d_a_arcsec: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            }
        })
        .collect()
}

/// Inverse-variance weighted mean ΔθB per B detent over A > 0°.
fn b_detents(ind: &Indexing) -> Vec<BDetent> {
    ind.layout
        .b_levels
        .iter()
        .filter_map(|&level| {
            let (mut sw, mut swx, mut count) = (0.0, 0.0, 0);
            for p in &ind.angles {
                if let (Some(d), Some(u)) = (p.d_b_arcsec, p.u_d_b_arcsec)
                    && layout::detent_key(layout::wrap_deg(p.b_deg)) == layout::detent_key(level)
                {
                    let w = 1.0 / (u * u).max(f64::MIN_POSITIVE);
                    sw += w;
                    swx += w * d;
                    count += 1;
                }
            }
            (count > 0).then(|| BDetent {
                b_deg: level,
                positions: count,
                mean_d_b_arcsec: swx / sw,
                u_mean_d_b_arcsec: sw.recip().sqrt(),
            })
        })
        .collect()
}

/// The expanded uncertainty U = k·u (k = 2) of a standard uncertainty.
fn expanded(u: f64) -> f64 {
    COVERAGE_FACTOR * u
}

/// The decision on a position's error `d` with standard uncertainty `u`
/// against the tolerance ±`t` (ISO 14253-1 with U = 2u).
pub(crate) fn decision(d: f64, u: f64, t: f64) -> Decision {
    decide(d.abs(), Some(expanded(u)), t, Rule::Iso14253)
}

/// The decisions on ΔθA and ΔθB (none at A = 0°) of position `p`.
fn decisions(p: &Angles, t: f64) -> (Decision, Option<Decision>) {
    (
        decision(p.d_a_arcsec, p.u_d_a_arcsec, t),
        p.d_b_arcsec
            .zip(p.u_d_b_arcsec)
            .map(|(d, u)| decision(d, u, t)),
    )
}

/// The positions whose |ΔθA| or |ΔθB| exceed `t` by more than U, worst
/// first, and the counts of those beyond and of those undecided.
fn tolerance(angles: &[Angles], t: f64) -> ToleranceReport {
    let beyond = Decision::DoesNotConform;
    let mut exceeding: Vec<(f64, Exceedance)> = angles
        .iter()
        .filter_map(|p| {
            let (a, b) = decisions(p, t);
            let over_a = a == beyond;
            let over_b = b == Some(beyond);
            let exceeds = match (over_a, over_b) {
                (true, true) => "A+B",
                (true, false) => "A",
                (false, true) => "B",
                (false, false) => return None,
            };
            let worst = p.d_a_arcsec.abs().max(p.d_b_arcsec.map_or(0.0, f64::abs));
            Some((
                worst,
                Exceedance {
                    a_deg: p.a_deg,
                    b_deg: p.b_deg,
                    d_a_arcsec: p.d_a_arcsec,
                    d_b_arcsec: p.d_b_arcsec,
                    expanded_d_a_arcsec: expanded(p.u_d_a_arcsec),
                    expanded_d_b_arcsec: p.u_d_b_arcsec.map(expanded),
                    exceeds: exceeds.into(),
                },
            ))
        })
        .collect();
    exceeding.sort_by(|p, q| q.0.total_cmp(&p.0));
    let decided: Vec<(Decision, Option<Decision>)> =
        angles.iter().map(|p| decisions(p, t)).collect();
    let count_a = |d: Decision| decided.iter().filter(|x| x.0 == d).count();
    let count_b = |d: Decision| decided.iter().filter(|x| x.1 == Some(d)).count();
    ToleranceReport {
        tolerance_arcsec: t,
        count_d_a: count_a(beyond),
        count_d_b: count_b(beyond),
        inconclusive_d_a: count_a(Decision::Inconclusive),
        inconclusive_d_b: count_b(Decision::Inconclusive),
        exceeding: exceeding.into_iter().map(|(_, e)| e).collect(),
    }
}

fn conventions() -> Vec<String> {
    [
        "O: geometric least-squares sphere through all centres; Q: mean of the A = 0° centres; \
         z = unit(Q − O) (B axis); y = unit(z × Σ unit(Oᵢ − O)) over the B = 0°, A > 0° centres \
         (A axis); x = y × z (docs/probe-indexing.md).",
        "θA = arccos n, θB = atan2(m, l) from the direction cosines (l, m, n) of O→Oᵢ; \
         ΔθA = θA − A; ΔθB = θB − B wrapped to (−180°, 180°], undefined at A = 0°.",
        "Centres and radius in mm (machine frame); angles in degrees; ΔθA, ΔθB in arc-seconds; \
         uncertainties are standard (k = 1), first order, from the sphere fit's residual noise.",
    ]
    .map(String::from)
    .to_vec()
}

#[cfg(test)]
mod tests {
    use super::super::ARCSEC_PER_DEG;
    use super::*;

    fn angle(a_deg: f64, b_deg: f64, d_a: f64, d_b: Option<f64>) -> Angles {
        Angles {
            a_deg,
            b_deg,
            cosines: geom::nalgebra::Vector3::z(),
            theta_a_deg: a_deg + d_a / ARCSEC_PER_DEG,
            theta_b_deg: b_deg,
            d_a_arcsec: d_a,
            d_b_arcsec: d_b,
            u_d_a_arcsec: 0.1,
            u_d_b_arcsec: d_b.map(|_| 0.1),
            residual_um: 0.0,
        }
    }

    /// Beyond the tolerance means beyond by more than U = 2u = 0.2″ here:
    /// 2.15″ and 2.1″ against 2″ are inconclusive, not counted.
    #[test]
    fn tolerance_lists_the_worst_first() {
        let angles = [
            angle(0.0, 0.0, 2.5, None),
            angle(15.0, 0.0, 0.1, Some(-3.0)),
            angle(15.0, 90.0, 2.3, Some(2.25)),
            angle(30.0, 90.0, 2.15, Some(2.1)),
            angle(30.0, 0.0, 1.0, Some(1.0)),
        ];
        let t = tolerance(&angles, 2.0);
        assert_eq!((t.count_d_a, t.count_d_b), (2, 2));
        assert_eq!((t.inconclusive_d_a, t.inconclusive_d_b), (1, 1));
        let order: Vec<(f64, &str)> = t
            .exceeding
            .iter()
            .map(|e| (e.a_deg, e.exceeds.as_str()))
            .collect();
        assert_eq!(order, vec![(15.0, "B"), (0.0, "A"), (15.0, "A+B")]);
    }
}
