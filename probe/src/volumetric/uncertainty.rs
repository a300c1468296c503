//! The expanded uncertainty (k = 2) of the volumetric model's figures by
//! Monte Carlo (GUM Supplement 1; docs/probe-volumetric.md, "Uncertainty").
//!
//! Sources: the measured curves — every value of the eighteen curves plus a
//! normal deviate of the instrument's standard uncertainty (one for
//! translations, one for rotations, as its certificate states them: the
//! curves alone cannot tell their noise from their waviness between the
//! measured positions, so this is a Type B input the user gives) — and the
//! squareness, when its standard uncertainty is given.
//!
//! The figures are ranges, maxima and RMS values, biased by the noise, and
//! the bias depends on the true curves: the circle after compensation, a
//! range of what the series leaves, is mostly noise, and trials drawn about
//! the measured (already noisy) curves simulate the bias of curves inflated
//! by the noise, too small. So each trial measures a plausible truth: per
//! curve, the measured values with their residual r from the reported
//! Fourier series shrunk by λₜ, `λₜ² = max(0, 1 − |rₑ|²/|r|²)` (positive-part
//! James–Stein), |rₑ|² the residual energy of the series fitted to one draw
//! of the noise alone (what noise leaves beside a series, its spread
//! included). That truth is analysed as it is and with new noise, and the
//! trial's figure is the reported one plus the difference: the method's
//! error on a plausible machine. Each analysis re-runs the method: the
//! straightness lines removed again, the series refitted when the
//! predictions use a series, the volumetric errors and the circle predicted
//! through the exact chain, and the report's figures read back. The circle
//! after compensation keeps the reported series: that compensation is what
//! a controller would be given. Where the curves are large against the
//! noise, λ ≈ 1 and this is the plain Monte Carlo about the result.

use std::collections::BTreeMap;

use formats::probe::volumetric::report::FIGURES;
use formats::uncertainty::{Uncertainty, figures};
use geom::montecarlo::{Draws, Propagation};

use super::campaign::CampaignCurves;
use super::curves::{AxisCurves, MeasuredAxis, Motion};
use super::model::{AxisModel, ErrorModel};
use super::report::{Analysis, Report, Setup, predict};
use super::series::{Series, SeriesFit};
use crate::uncertainty::{METHOD, Source, Statement, not_given, propagate};

/// Index of the curves among the sources.
const CURVES: usize = 0;
/// Index of the squareness among the sources.
const SQUARENESS: usize = 1;

/// The standard uncertainties of the inputs (Type B, from the instrument's
/// and the squareness measurement's certificates).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Inputs {
    /// Standard uncertainty of a translation value of a curve (mm).
    pub translation_mm: Option<f64>,
    /// Standard uncertainty of a rotation value of a curve (rad).
    pub rotation_rad: Option<f64>,
    /// Standard uncertainty of each squareness error (rad).
    pub squareness_rad: Option<f64>,
    /// Whether the curves' uncertainties come from a campaign report's U
    /// (`--from-report`) rather than an instrument's certificate.
    pub from_report: bool,
}

/// Why the figures have no U when the curves' uncertainty is not given.
pub const CURVES_NOT_GIVEN: &str = "the standard uncertainty of the curves' values was not \
     given (--curve-u-um and --curve-u-urad, from the instrument's certificate): the curves alone \
     cannot tell their noise from their waviness between the measured positions";

/// Why a campaign's figures have no U: its report gives none.
pub const REPORT_GIVES_NO_U: &str = "the evaluate report's range figures carry no U (evaluated \
     with --trials 0?) and --curve-u-um/--curve-u-urad were not given: the standard uncertainty of \
     the curves' values is not known";

/// Why a campaign with curves of `--errors` has no U: the report's U covers its own curves only.
pub const ERRORS_NEED_U: &str = "the evaluate report's U covers its own curves, not those of \
     --errors: give --curve-u-um and --curve-u-urad (the standard uncertainty of every curve's values)";

/// The headline figures of the budget (those the report has).
const HEADLINE: [&str; 6] = [
    "volumetric.max_um",
    "volumetric.rms_um",
    "circle.circular_deviation_um",
    "circle.radial_range_um",
    "circle.compensated.fourier.circular_deviation_um",
    "circle.compensated.polynomial.circular_deviation_um",
];

fn not_included(inputs: &Inputs) -> Vec<String> {
    let mut out = vec![
        "the curves between the measured positions: the model interpolates them (raw) or fits \
         a series, and what the machine does between the positions was not measured"
            .to_string(),
        "the misfit of a series under --model fourier or polynomial (see its RMSE and e_max in \
         the fit table)"
            .to_string(),
        "thermal drift, load and dynamic effects (outside the 21-error model)".to_string(),
        "the reversal (positioning_up/down) of the compensation tables".to_string(),
    ];
    if inputs.from_report {
        out.push(
            "the machine's scatter between the campaign's runs (evaluate's R and s), as in the \
             evaluate report's U"
                .into(),
        );
    }
    if inputs.squareness_rad.is_none() {
        out.push("the squareness, taken as exact (give --squareness-u-urad)".into());
    }
    out
}

/// Every value of every curve of `axes` plus a normal deviate of `u_mm`
/// (translations) or `u_rad` (rotations).
fn perturbed(axes: &[MeasuredAxis], u_mm: f64, u_rad: f64, d: &mut Draws) -> Vec<MeasuredAxis> {
    let mut out = axes.to_vec();
    for axis in &mut out {
        for (m, values) in Motion::ALL.iter().zip(axis.values.iter_mut()) {
            let u = if m.is_rotation() { u_rad } else { u_mm };
            for v in values {
                *v += d.gaussian(u);
            }
        }
    }
    out
}

/// The curves of a trial with the reported series: the model the
/// compensated circle is predicted with.
fn with_reported_series(curves: &[AxisCurves], reported: &ErrorModel) -> Option<ErrorModel> {
    let axes = curves
        .iter()
        .map(|c| {
            Some(AxisModel {
                curves: c.clone(),
                fits: reported.axis(c.axis)?.fits.clone(),
            })
        })
        .collect::<Option<Vec<_>>>()?;
    let mut axes = axes;
    axes.sort_by_key(AxisModel::axis);
    Some(ErrorModel {
        axes,
        order: reported.order,
    })
}

/// U (k = 2) of every figure of `analysis.report` (the analysis of
/// `measured` under `setup`), with the budget of the headline figures; no U
/// without the curves' standard uncertainty or with `trials = 0`.
pub fn uncertainty(
    measured: &[MeasuredAxis],
    setup: &Setup,
    campaign: Option<&CampaignCurves>,
    analysis: &Analysis,
    inputs: &Inputs,
    propagation: Propagation,
) -> Uncertainty {
    let (Some(u_mm), Some(u_rad)) = (inputs.translation_mm, inputs.rotation_rad) else {
        return not_given(match campaign {
            Some(c) if c.readings_u.is_some() => ERRORS_NEED_U,
            Some(_) => REPORT_GIVES_NO_U,
            None => CURVES_NOT_GIVEN,
        });
    };
    let nominal = match figures(&analysis.report, &FIGURES) {
        Ok(f) => f,
        Err(e) => {
            return not_given(format!("the report's figures could not be read: {e}"));
        }
    };
    let mut sources = vec![Source {
        name: "curves",
        description: format!(
            "every value of the eighteen curves + N(0, u²), u = {} µm (translations), {} µrad \
             (rotations): {}",
            u_mm * 1e3,
            u_rad * 1e6,
            if inputs.from_report {
                "from the evaluate report's U of its range figures, u = U/(2√2) of the largest"
            } else {
                "the instrument's standard uncertainty (Type B)"
            }
        ),
    }];
    if let Some(u) = inputs.squareness_rad {
        sources.push(Source {
            name: "squareness",
            description: format!(
                "EC0Y, EB0Z, EA0Z each + N(0, u²), u = {} µrad (Type B)",
                u * 1e6
            ),
        });
    }
    let statement = Statement {
        method: METHOD.into(),
        sources,
        not_included: not_included(inputs),
        headline: HEADLINE.iter().map(|f| (*f).to_string()).collect(),
    };
    let plausible = Plausible::of(measured, analysis, u_mm, u_rad);
    let analyse_figures = |axes: Vec<MeasuredAxis>, s: &Setup| -> Option<BTreeMap<String, f64>> {
        let curves = axes
            .into_iter()
            .map(AxisCurves::new)
            .collect::<crate::Result<Vec<_>>>()
            .ok()?;
        let compensating = with_reported_series(&curves, &analysis.model)?;
        let predicting = match setup.model.series() {
            Some(_) => ErrorModel::new(curves, setup.order).ok()?,
            None => compensating.clone(),
        };
        let a = predict(predicting, Some(&compensating), s, campaign).ok()?;
        figures(&lean(a.report), &FIGURES).ok()
    };
    propagate(&nominal, statement, propagation, |trial| {
        let (truth, noisy) = match trial.draws(CURVES) {
            Some(d) => {
                let truth = plausible.draw(d)?;
                let noisy = perturbed(&truth, u_mm, u_rad, d);
                (truth, noisy)
            }
            None => (measured.to_vec(), measured.to_vec()),
        };
        let mut s = setup.clone();
        if let (Some(u), Some(d)) = (inputs.squareness_rad, trial.draws(SQUARENESS)) {
            s.squareness.ec0y += d.gaussian(u);
            s.squareness.eb0z += d.gaussian(u);
            s.squareness.ea0z += d.gaussian(u);
        }
        let want = analyse_figures(truth, setup)?;
        let got = analyse_figures(noisy, &s)?;
        Some(
            nominal
                .iter()
                .map(|(k, v)| {
                    let error = got.get(k).zip(want.get(k)).map_or(0.0, |(g, w)| g - w);
                    (k.clone(), v + error)
                })
                .collect(),
        )
    })
}

/// The report without its tables (curves, fits, per-position and
/// per-degree rows): none of their numbers is a figure, and the trials
/// read figures only.
fn lean(mut r: Report) -> Report {
    for a in &mut r.axes {
        a.curves.clear();
        a.positions_mm.clear();
    }
    r.fits.clear();
    if let Some(v) = &mut r.volumetric {
        v.rows.clear();
    }
    if let Some(c) = &mut r.circle {
        c.radial_um.clear();
        c.compensated.fourier.radial_um.clear();
        c.compensated.polynomial.radial_um.clear();
    }
    r
}

/// The measured curves and, per curve, its residual from the reported
/// Fourier series: what the plausible truths shrink.
struct Plausible<'a> {
    measured: &'a [MeasuredAxis],
    /// Per axis (in `measured`'s order), per motion: residual and series order.
    residuals: Vec<Vec<(Vec<f64>, usize)>>,
    u_mm: f64,
    u_rad: f64,
}

impl<'a> Plausible<'a> {
    fn of(measured: &'a [MeasuredAxis], analysis: &Analysis, u_mm: f64, u_rad: f64) -> Self {
        let residuals = measured
            .iter()
            .map(|m| {
                let model = analysis.model.axis(m.axis);
                Motion::ALL
                    .iter()
                    .map(|motion| {
                        model.map_or((vec![0.0; m.positions.len()], 1), |a| {
                            let fit = &a.fits[motion.index()].fourier;
                            (fit.residuals.clone(), fit.order)
                        })
                    })
                    .collect()
            })
            .collect();
        Plausible {
            measured,
            residuals,
            u_mm,
            u_rad,
        }
    }

    /// One plausible truth: every curve less (1 − λₜ) of its residual.
    fn draw(&self, d: &mut Draws) -> Option<Vec<MeasuredAxis>> {
        let mut out = self.measured.to_vec();
        for (axis, residuals) in out.iter_mut().zip(&self.residuals) {
            for ((motion, values), (r, order)) in Motion::ALL
                .iter()
                .zip(axis.values.iter_mut())
                .zip(residuals)
            {
                let u = if motion.is_rotation() {
                    self.u_rad
                } else {
                    self.u_mm
                };
                let noise: Vec<f64> = r.iter().map(|_| d.gaussian(u)).collect();
                let left =
                    SeriesFit::fit(Series::Fourier, *order, &axis.positions, &noise, "noise")
                        .ok()?
                        .figures
                        .sse;
                let energy: f64 = r.iter().map(|v| v * v).sum();
                let lambda = if energy > 0.0 {
                    (1.0 - left / energy).max(0.0).sqrt()
                } else {
                    0.0
                };
                for (v, r) in values.iter_mut().zip(r) {
                    *v -= (1.0 - lambda) * r;
                }
            }
        }
        Some(out)
    }
}
