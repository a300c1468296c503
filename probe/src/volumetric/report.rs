//! The whole analysis of `trinocular probe volumetric` and its `report.json`
//! (docs/formats.md: `circle.radial_range_um`, `circle.circular_deviation_um`;
//! µm and µrad, mm for positions). The report's types live in
//! `formats::probe::volumetric::report`; [`analyse`] fills them.

use formats::Axis;
use formats::probe::volumetric::CompLine;
use geom::Vector3;

use super::campaign::CampaignCurves;
use super::chain::{Chain, Machine, Positions, Squareness};
use super::circle::{self, CirclePrediction, CircleSpec};
use super::compensation;
use super::curves::{AxisCurves, MeasuredAxis, Motion, RemovedSlope};
use super::model::{ErrorModel, Evaluation, Model, Order};
use super::series::{Figures, OrderScore, Series, SeriesFit};
use crate::{ProbeError, Result};

pub use formats::probe::volumetric::report::{
    AxisReport, CampaignReport, CircleFigures, CircleReport, CompensatedReport, CurveReport,
    FitReport, Report, SeriesReport, SlopeReport, VolumetricPoint, VolumetricReport,
};

/// mm → µm.
const UM: f64 = 1e3;
/// rad → µrad.
const URAD: f64 = 1e6;

/// What to compute, besides the curves.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Kinematic chain.
    pub chain: Chain,
    /// Squareness errors (rad).
    pub squareness: Squareness,
    /// Tool offset t (mm).
    pub tool: [f64; 3],
    /// Model of the curves for the predictions.
    pub model: Model,
    /// Order of the series.
    pub order: Order,
    /// Carriage positions for volumetric errors (`--at`), each with a label
    /// that names it in errors (e.g. `at.csv: line 5`).
    pub at: Vec<(String, Positions)>,
    /// Circle of the circular test (`--circle`).
    pub circle: Option<CircleSpec>,
    /// Where the curves came from (for the report).
    pub source: String,
    /// Standard uncertainty of the curves' readings, when known: judges
    /// whether a fit's residual is more than their noise.
    pub readings_u: Option<ReadingsU>,
}

/// Standard uncertainty of one reading of a curve (the instrument's, or a
/// campaign report's; docs/probe-volumetric.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadingsU {
    /// Of a translation value (mm).
    pub translation_mm: f64,
    /// Of a rotation value (rad).
    pub rotation_rad: f64,
}

/// The predicted circular tests.
#[derive(Debug, Clone, PartialEq)]
pub struct Circles {
    /// The circle.
    pub spec: CircleSpec,
    /// With the curves under the chosen model.
    pub predicted: CirclePrediction,
    /// What compensation with the Fourier series would leave.
    pub compensated_fourier: CirclePrediction,
    /// What compensation with the polynomial would leave.
    pub compensated_polynomial: CirclePrediction,
}

/// Everything computed.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    /// The error model (curves and fits).
    pub model: ErrorModel,
    /// Volumetric error (mm) at each position of `setup.at`.
    pub volumetric: Vec<(Positions, Vector3<f64>)>,
    /// The circular tests, with `--circle`.
    pub circles: Option<Circles>,
    /// Pitch compensation table per axis.
    pub compensation: Vec<(Axis, Vec<CompLine>)>,
    /// `report.json`.
    pub report: Report,
}

/// Run the analysis: check and fit the curves, build the machine, predict.
/// `campaign` describes curves that came from a vision campaign.
pub fn analyse(
    curves: Vec<MeasuredAxis>,
    setup: &Setup,
    campaign: Option<&CampaignCurves>,
) -> Result<Analysis> {
    let checked: Vec<AxisCurves> = curves
        .into_iter()
        .map(AxisCurves::new)
        .collect::<Result<_>>()?;
    let model = ErrorModel::new(checked, setup.order)?;
    predict(model, None, setup, campaign)
}

/// The predictions of `model` under `setup` and the report. The circle
/// after compensation uses the series of `compensating` (the compensation a
/// controller was given) on `model`'s curves; `None`: `model`'s own.
pub(crate) fn predict(
    model: ErrorModel,
    compensating: Option<&ErrorModel>,
    setup: &Setup,
    campaign: Option<&CampaignCurves>,
) -> Result<Analysis> {
    let tool = Vector3::from(setup.tool);
    let machine = Machine::new(&setup.chain, setup.squareness, tool, &model)?;
    let compensated = match compensating {
        Some(c) => Machine::new(&setup.chain, setup.squareness, tool, c)?,
        None => machine,
    };
    let how = Evaluation::Model(setup.model);
    let volumetric = setup
        .at
        .iter()
        .map(|(label, q)| {
            machine
                .volumetric_error(q, how)
                .map(|d| (*q, d))
                .map_err(|e| ProbeError::At {
                    label: label.clone(),
                    error: Box::new(e),
                })
        })
        .collect::<Result<Vec<_>>>()?;
    let circles = match setup.circle {
        Some(spec) => Some(Circles {
            spec,
            predicted: circle::predict(&machine, &spec, how)?,
            compensated_fourier: circle::predict(
                &compensated,
                &spec,
                Evaluation::Residual(Series::Fourier),
            )?,
            compensated_polynomial: circle::predict(
                &compensated,
                &spec,
                Evaluation::Residual(Series::Polynomial),
            )?,
        }),
        None => None,
    };
    let compensation = model
        .axes
        .iter()
        .map(|a| (a.axis(), compensation::table(&a.curves)))
        .collect();
    let report = report(setup, &model, &volumetric, circles.as_ref(), campaign);
    Ok(Analysis {
        model,
        volumetric,
        circles,
        compensation,
        report,
    })
}

/// The curve unit of a motion in reports, and the factor from file units.
pub(crate) fn unit(motion: Motion) -> (&'static str, f64) {
    if motion.is_rotation() {
        ("urad", URAD)
    } else {
        ("um", UM)
    }
}

fn series_report(
    fit: &SeriesFit,
    values: &[f64],
    scale: f64,
    scores: Option<&Vec<OrderScore>>,
) -> SeriesReport {
    let f: Figures = fit.figures;
    SeriesReport {
        order: fit.order,
        r2: f.r2,
        sse: f.sse * scale * scale,
        rmse: f.rmse * scale,
        emax: f.emax * scale,
        fitted: values
            .iter()
            .zip(&fit.residuals)
            .map(|(v, r)| (v - r) * scale)
            .collect(),
        order_scores: scores.map(|s| {
            s.iter()
                .map(|o| OrderScore {
                    order: o.order,
                    loo_rmse: o.loo_rmse * scale,
                })
                .collect()
        }),
    }
}

fn circle_figures(c: &CirclePrediction) -> CircleFigures {
    CircleFigures {
        radial_range_um: c.radial_range * UM,
        circular_deviation_um: c.circular_deviation * UM,
        radial_um: c.points.iter().map(|p| p.radial * UM).collect(),
    }
}

/// `report.json` of the analysis.
fn report(
    setup: &Setup,
    model: &ErrorModel,
    volumetric: &[(Positions, Vector3<f64>)],
    circles: Option<&Circles>,
    campaign: Option<&CampaignCurves>,
) -> Report {
    let mut fits = Vec::new();
    let axes = model
        .axes
        .iter()
        .map(|a| {
            let c = &a.curves;
            let curves = Motion::ALL
                .iter()
                .map(|&m| {
                    let (unit, scale) = unit(m);
                    let values = c.curve(m);
                    let f = &a.fits[m.index()];
                    for s in Series::BOTH {
                        let fit = f.get(s);
                        fits.push(FitReport {
                            axis: a.axis(),
                            error: m,
                            model: s,
                            order: fit.order,
                            r2: fit.figures.r2,
                            sse: fit.figures.sse,
                            rmse: fit.figures.rmse,
                            emax: fit.figures.emax,
                        });
                    }
                    CurveReport {
                        error: m,
                        symbol: m.symbol(a.axis()),
                        unit,
                        values: values.iter().map(|v| v * scale).collect(),
                        fourier: series_report(
                            &f.fourier,
                            values,
                            scale,
                            f.scores.as_ref().map(|s| &s[0]),
                        ),
                        polynomial: series_report(
                            &f.polynomial,
                            values,
                            scale,
                            f.scores.as_ref().map(|s| &s[1]),
                        ),
                    }
                })
                .collect();
            let (lo, hi) = c.travel();
            AxisReport {
                axis: a.axis(),
                travel_mm: [lo, hi],
                points: c.positions.len(),
                positions_mm: c.positions.clone(),
                curves,
                straightness_lines: c
                    .removed
                    .iter()
                    .map(|r: &RemovedSlope| SlopeReport {
                        error: r.error,
                        slope_urad: r.slope * URAD,
                        intercept_um: r.intercept_mm * UM,
                    })
                    .collect(),
                compensation_bidirectional: compensation::bidirectional(c),
            }
        })
        .collect();
    let volumetric = (!volumetric.is_empty()).then(|| {
        let norms: Vec<f64> = volumetric.iter().map(|(_, d)| d.norm() * UM).collect();
        VolumetricReport {
            points: volumetric.len(),
            max_um: norms.iter().fold(0.0, |m, v| m.max(*v)),
            rms_um: (norms.iter().map(|v| v * v).sum::<f64>() / norms.len() as f64).sqrt(),
            rows: volumetric
                .iter()
                .map(|(q, d)| VolumetricPoint {
                    q_mm: *q,
                    d_um: [d.x * UM, d.y * UM, d.z * UM],
                })
                .collect(),
        }
    });
    let circle = circles.map(|c| CircleReport {
        centre_mm: c.spec.centre,
        radius_mm: c.spec.radius,
        radial_range_um: c.predicted.radial_range * UM,
        circular_deviation_um: c.predicted.circular_deviation * UM,
        lsq_centre_mm: c.predicted.lsq_centre,
        radial_um: c.predicted.points.iter().map(|p| p.radial * UM).collect(),
        compensated: CompensatedReport {
            fourier: circle_figures(&c.compensated_fourier),
            polynomial: circle_figures(&c.compensated_polynomial),
        },
    });
    let campaign = campaign.map(|c| CampaignReport {
        sweeps: c.sweeps.clone(),
        measured_squareness_urad: [
            ("EC0Y", c.squareness.ec0y),
            ("EB0Z", c.squareness.eb0z),
            ("EA0Z", c.squareness.ea0z),
        ]
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| (k.to_string(), v * URAD)))
        .collect(),
        notes: c.notes.clone(),
    });
    Report {
        method: "volumetric",
        source: setup.source.clone(),
        chain: setup.chain.text.clone(),
        workpiece_side: setup.chain.workpiece.clone(),
        tool_side: setup.chain.tool.clone(),
        tool_mm: setup.tool,
        squareness_urad: Squareness {
            ec0y: setup.squareness.ec0y * URAD,
            eb0z: setup.squareness.eb0z * URAD,
            ea0z: setup.squareness.ea0z * URAD,
        },
        model: setup.model,
        order: match setup.order {
            Order::Fixed(n) => n.to_string(),
            Order::Highest(n) => format!("{n} (or the highest the points allow)"),
            Order::Auto => "auto".into(),
        },
        axes,
        fits,
        volumetric,
        circle,
        campaign,
        conventions: conventions(),
        notes: model
            .axes
            .iter()
            .filter_map(|a| a.order_note(model.order))
            .collect(),
        warnings: poor_fits(model, setup),
    }
}

/// R² below which a series fit is flagged: it explains less than 80 % of
/// its curve's variance, so that its figures describe noise (or an order
/// that does not suit the curve) more than the machine.
pub const POOR_R2: f64 = 0.8;

/// Standard normal quantile of the residual test: 99 % one-sided.
const RESIDUAL_Z: f64 = 2.326;

/// The 99 % quantile of χ² with ν degrees of freedom, Wilson–Hilferty:
/// `χ²_p(ν) ≈ ν·(1 − 2/(9ν) + z_p·√(2/(9ν)))³` (within 3 % for ν ≥ 1).
fn chi2_99(dof: usize) -> f64 {
    let v = dof as f64;
    let a = 2.0 / (9.0 * v);
    v * (1.0 - a + RESIDUAL_Z * a.sqrt()).powi(3)
}

/// Whether a fit's residual is more than readings of standard uncertainty
/// `u` would leave: `SSE/u² > χ²₉₉(n − (2N + 1))`. An interpolating fit
/// (no degree of freedom left) leaves nothing to judge.
fn significant(fit: &SeriesFit, u: f64) -> bool {
    let dof = fit.residuals.len().saturating_sub(fit.coefficients.len());
    dof > 0 && fit.figures.sse > chi2_99(dof) * u * u
}

/// A warning for each fit with R² < [`POOR_R2`] of the series the
/// predictions use (`--model fourier|polynomial`; under `raw` they keep the
/// measured values, and the compensated circle shows what each series
/// leaves), whose order was asked for or cross-validated (not lowered to
/// the points), and — when the readings' U is known — whose residual is
/// significant against it ([`significant`]): a low R² of a residual within
/// the noise only says that the curve is noise. Each names the order
/// leave-one-out cross-validation chooses (`--order auto`) and its R².
fn poor_fits(model: &ErrorModel, setup: &Setup) -> Vec<String> {
    let Some(s) = setup.model.series() else {
        return Vec::new();
    };
    let mut warnings = Vec::new();
    for a in &model.axes {
        let c = &a.curves;
        for m in Motion::ALL {
            let what = format!("axis {} curve {}", c.axis, m.name());
            let fits = &a.fits[m.index()];
            let fit = fits.get(s);
            let Some(r2) = fit
                .figures
                .r2
                .filter(|r| *r < POOR_R2 && !fits.is_lowered(s))
            else {
                continue;
            };
            let u = setup.readings_u.map(|u| {
                if m.is_rotation() {
                    u.rotation_rad
                } else {
                    u.translation_mm
                }
            });
            if u.is_some_and(|u| !significant(fit, u)) {
                continue;
            }
            const NOISE: &str = "the series does not describe the curve (noise against its \
                 range, or a shape it cannot follow): its fitted shape is not significant, the raw \
                 model keeps the measured values";
            let chosen =
                || format!("it is the order leave-one-out cross-validation chooses: {NOISE}");
            // Under --order auto the fit is already cross-validation's choice.
            let (p, v) = (&c.positions, c.curve(m));
            let better = match setup.order {
                Order::Auto => None,
                Order::Fixed(_) | Order::Highest(_) => Some(
                    super::series::choose_order(s, p, v, &what)
                        .and_then(|(n, _)| Ok((n, SeriesFit::fit(s, n, p, v, &what)?.figures.r2))),
                ),
            };
            let advice = match better {
                Some(Ok((n, r))) if n != fit.order => format!(
                    "--order auto (leave-one-out) chooses N = {n} for it, R² {}{}",
                    r.map_or_else(|| "—".into(), |r| format!("{r:.3}")),
                    if r.is_some_and(|r| r >= POOR_R2) {
                        String::new()
                    } else {
                        format!(": {NOISE}")
                    }
                ),
                None | Some(Ok(_)) => chosen(),
                Some(Err(_)) => "too few points to cross-validate another order".into(),
            };
            let rms = match u {
                Some(u) => {
                    let (_, scale) = unit(m);
                    format!(
                        ", residual RMS {:.3} {} against the readings' u {:.3}",
                        fit.figures.rmse * scale,
                        super::plot::unit_label(m),
                        u * scale
                    )
                }
                None => String::new(),
            };
            warnings.push(format!(
                "{} {}: the {} fit of order {} has R² {r2:.3} < {POOR_R2}{rms}; {advice}",
                m.symbol(a.axis()),
                m.name(),
                s.name(),
                fit.order
            ));
        }
    }
    warnings
}

/// The conventions written into every report.
pub(crate) fn conventions() -> Vec<String> {
    [
        "docs/probe-volumetric.md: error motions of each carriage relative to the body it rides on, translations along and rotations about the machine X, Y, Z, rotations about the machine origin carried by the carriage",
        "T_j(q) = Trans(q·a_j + δ_j(q))·Rot(ε_j(q)), Rot by Rodrigues' formula; a_X = (1,0,0), a_Y = (−sin EC0Y, cos EC0Y, 0), a_Z = Ry(EB0Z)·Rx(EA0Z)·(0,0,1)",
        "chain W a1…ak F b1…bl T: T_W = T_ak⋯T_a1, T_T = T_b1⋯T_bl, w = T_W⁻¹·T_T·t; volumetric error = w − w(no errors, no squareness), workpiece frame",
        "straightness curves: least-squares line v = k·q + b removed, slopes reported",
        "Fourier series of order N with ω = 2π/L over the measured travel L; polynomial of degree 2N (same 2N + 1 coefficients); R² = 1 − SSE/SST, RMSE = √(SSE/n), e_max = max|r|",
        "circular test (ISO 230-4) in the workpiece frame, plane XY, 1° steps: q_L = s_L·(w₀_L − t_L), s = −1 workpiece side, +1 tool side; circular deviation = range of the radial distances from the least-squares centre",
        "compensated prediction: the raw curves minus the series, squareness removed",
        "outside the measured travel is an error, never an extrapolation",
        "report units: µm and µrad (curves, figures), mm (positions); fits.csv in mm and rad",
    ]
    .iter()
    .map(|s| (*s).to_string())
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantile_follows_the_tables() {
        // χ²₀.₉₉(ν) from the tables: 6.635, 9.210, 23.209, 50.892.
        for (dof, table) in [(1, 6.635), (2, 9.210), (10, 23.209), (30, 50.892)] {
            let w = chi2_99(dof);
            assert!(
                (w / table - 1.0).abs() < 0.01,
                "ν = {dof}: {w} against {table}"
            );
        }
    }

    /// X with 41 positions: `ex` a pseudo-random noise of σ = 1 µm, the
    /// other curves a wave the series follows.
    fn noisy_x() -> Vec<MeasuredAxis> {
        // Seeded standard normal deviates (σ = 1).
        let mut draws = geom::montecarlo::Draws::seeded(7);
        let mut gauss = || draws.normal();
        let rows: Vec<[f64; 7]> = (0..41)
            .map(|k| {
                let q = 10.0 * k as f64;
                let wave = (std::f64::consts::TAU * q / 400.0).sin();
                [
                    q,
                    1e-3 * gauss(),
                    0.0,
                    0.0,
                    1e-6 * wave,
                    1e-6 * wave,
                    1e-6 * wave,
                ]
            })
            .collect();
        vec![MeasuredAxis::from_rows(Axis::X, &rows)]
    }

    fn setup(model: Model, readings_u: Option<ReadingsU>) -> Setup {
        Setup {
            chain: Chain::parse("WXFT").unwrap(),
            squareness: Squareness::default(),
            tool: [0.0; 3],
            model,
            order: Order::Highest(3),
            at: vec![],
            circle: None,
            source: "noise".into(),
            readings_u,
        }
    }

    #[test]
    fn a_low_r2_warns_only_when_the_residual_is_more_than_the_noise() {
        let u = |um: f64| {
            Some(ReadingsU {
                translation_mm: um * 1e-3,
                rotation_rad: 1e-6,
            })
        };
        let warnings = |model, readings| {
            analyse(noisy_x(), &setup(model, readings), None)
                .unwrap()
                .report
                .warnings
        };
        // Without a u, R² alone: the noise curve is flagged.
        let w = warnings(Model::Fourier, None);
        assert!(
            w.len() == 1 && w[0].starts_with("EXX ex: the fourier fit of order 3"),
            "{w:?}"
        );
        // With the noise's own u (1 µm) the residual is what the noise leaves: no warning.
        assert_eq!(warnings(Model::Fourier, u(1.0)), Vec::<String>::new());
        assert_eq!(warnings(Model::Polynomial, u(1.0)), Vec::<String>::new());
        // With a u 5 times smaller the residual is significant: flagged, with its RMS.
        let w = warnings(Model::Fourier, u(0.2));
        assert!(
            w.len() == 1 && w[0].contains("against the readings' u 0.200"),
            "{w:?}"
        );
        // Under raw the predictions use no series: nothing to flag.
        assert_eq!(warnings(Model::Raw, None), Vec::<String>::new());
    }
}
