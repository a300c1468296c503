//! `report.html` of the volumetric method: one self-contained page (inline
//! CSS and SVG, no scripts) — set-up, the predicted circular test as a polar
//! plot, the fit table, the eighteen curves with both fits, the removed
//! straightness lines, the volumetric errors and the compensation tables.

use report::{Page, escape, plus_minus, plus_minus_in};

use super::curves::Motion;
use super::plot;
use super::report::{Analysis, Report, unit};
use super::series::Series;
use crate::Result;
use formats::uncertainty::Uncertainty;

/// A figure to `digits` decimals, or an em dash.
fn fig(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "—".into(), |v| format!("{v:.digits$}"))
}

/// Render the page: set-up, predicted circle, fit table, the curves of each
/// axis, volumetric errors, compensation tables, the campaign's sweeps; the
/// verdict and test conditions of `signoff` first.
pub fn render(
    a: &Analysis,
    u: &Uncertainty,
    signoff: &formats::conformance::SignOff,
) -> Result<String> {
    let mut h = Page::new(
        "trinocular — 21-error volumetric model",
        "21-error volumetric model",
    );
    report::conformance::header(&mut h, signoff);
    setup_section(&mut h, &a.report);
    circle_section(&mut h, a, u)?;
    fit_table(&mut h, &a.report);
    axis_sections(&mut h, a, u)?;
    volumetric_section(&mut h, &a.report, u);
    report::uncertainty::section(&mut h, Some(u));
    compensation_section(&mut h, &a.report);
    campaign_section(&mut h, &a.report);
    h.notes("Notes", &a.report.notes, false);
    h.notes("Warnings", &a.report.warnings, true);
    h.notes("Conventions", &a.report.conventions, false);
    Ok(h.finish())
}

/// Source, chain, tool, model and squareness.
fn setup_section(h: &mut Page, r: &Report) {
    h.meta(&format!(
        "Source: {} · chain <b>{}</b> · tool offset ({}, {}, {}) mm · predictions with the <b>{}</b> curves · \
         series order {}",
        escape(&r.source),
        escape(&r.chain),
        r.tool_mm[0],
        r.tool_mm[1],
        r.tool_mm[2],
        r.model.name(),
        escape(&r.order)
    ));
    h.table(
        Some("squareness"),
        &["squareness", "µrad"],
        &[
            vec![
                "EC0Y (Y against X)".to_string(),
                format!("{:.3}", r.squareness_urad.ec0y),
            ],
            vec![
                "EB0Z (Z against X)".to_string(),
                format!("{:.3}", r.squareness_urad.eb0z),
            ],
            vec![
                "EA0Z (Z against Y)".to_string(),
                format!("{:.3}", r.squareness_urad.ea0z),
            ],
        ],
    );
}

/// The predicted circular test (with `--circle`): figures and two plots.
fn circle_section(h: &mut Page, a: &Analysis, u: &Uncertainty) -> Result<()> {
    let r = &a.report;
    if let (Some(c), Some(cr)) = (&a.circles, &r.circle) {
        h.h2("circle", "Predicted circular test (ISO 230-4)");
        let f = |v: f64, path: &str| plus_minus_in(v, u.of(path), 3, "µm");
        h.paragraph(&format!(
            "Circle of radius {} mm about ({}, {}, {}) mm in the workpiece frame, plane XY, 1° steps. \
             Circular deviation about the least-squares centre {}, radial range {}; after \
             compensation with the Fourier series {} (range {}), with the polynomial {} \
             (range {}).",
            cr.radius_mm,
            cr.centre_mm[0],
            cr.centre_mm[1],
            cr.centre_mm[2],
            f(cr.circular_deviation_um, "circle.circular_deviation_um"),
            f(cr.radial_range_um, "circle.radial_range_um"),
            f(
                cr.compensated.fourier.circular_deviation_um,
                "circle.compensated.fourier.circular_deviation_um"
            ),
            f(
                cr.compensated.fourier.radial_range_um,
                "circle.compensated.fourier.radial_range_um"
            ),
            f(
                cr.compensated.polynomial.circular_deviation_um,
                "circle.compensated.polynomial.circular_deviation_um"
            ),
            f(
                cr.compensated.polynomial.radial_range_um,
                "circle.compensated.polynomial.radial_range_um"
            ),
        ));
        let (svg, m) = plot::polar("Predicted circle (polar)", c)?;
        h.figure(
            "plot-circle-polar",
            &svg,
            &format!(
                "Radius R + {m} × radial deviation: the deviation is magnified {m} times (1 µm drawn as {:.3} mm); \
                 dashed: the nominal circle.",
                m * 1e-3
            ),
        );
        let svg = plot::radial("Radial deviation against the angle", c)?;
        h.figure(
            "plot-circle-radial",
            &svg,
            "Radial deviation Δ·(cos θ, sin θ, 0) per degree, predicted and after compensation.",
        );
    }
    Ok(())
}

/// Both series of every curve, the better RMSE marked.
fn fit_table(h: &mut Page, r: &Report) {
    h.h2("fits", "Fit table");
    h.paragraph(
        "Both series of every curve over its measured travel: Fourier of order N against the polynomial of \
         degree 2N (same number of coefficients). The better RMSE of each curve is marked.",
    );
    let mut rows = Vec::new();
    for ax in &r.axes {
        for c in &ax.curves {
            let better = if c.fourier.rmse <= c.polynomial.rmse {
                "Fourier"
            } else {
                "polynomial"
            };
            let u = if c.unit == "um" { "µm" } else { "µrad" };
            for (name, s) in [("Fourier", &c.fourier), ("polynomial", &c.polynomial)] {
                rows.push(vec![
                    format!("{} {}", c.symbol, c.error.name()),
                    format!("{name} N={}", s.order),
                    match s.r2 {
                        Some(r) if r < super::report::POOR_R2 => {
                            format!("{r:.6} (< {})", super::report::POOR_R2)
                        }
                        r => fig(r, 6),
                    },
                    format!("{:.4e} {u}²", s.sse),
                    format!("{:.4} {u}", s.rmse),
                    format!("{:.4} {u}", s.emax),
                    if name == better {
                        "✓".into()
                    } else {
                        String::new()
                    },
                ]);
            }
        }
    }
    h.table(
        Some("fit-table"),
        &["curve", "model", "R²", "SSE", "RMSE", "e_max", "lower RMSE"],
        &rows,
    );
}

/// Per axis: its curves with both fits, the removed straightness lines and the orders chosen.
fn axis_sections(h: &mut Page, a: &Analysis, unc: &Uncertainty) -> Result<()> {
    let r = &a.report;
    for (index, (axis, ar)) in a.model.axes.iter().zip(&r.axes).enumerate() {
        let name = axis.axis().name();
        h.h2(
            &format!("axis-{name}"),
            &format!(
                "Axis {name}: {} positions from {} to {} mm",
                ar.points, ar.travel_mm[0], ar.travel_mm[1]
            ),
        );
        for m in Motion::ALL {
            let title = format!("{}: {} ({})", name, m.symbol(axis.axis()), m.name());
            let svg = plot::curve(&title, axis, m)?;
            let (u, _) = unit(m);
            h.figure(
                &format!("plot-{name}-{}", m.name()),
                &svg,
                &format!(
                    "{} of axis {name} in {}: measured (black), Fourier series (blue), polynomial (red).",
                    m.symbol(axis.axis()),
                    if u == "um" { "µm" } else { "µrad" }
                ),
            );
        }
        let slopes: Vec<Vec<String>> = ar
            .straightness_lines
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let path = format!("axes.{index}.straightness_lines.{k}");
                vec![
                    format!("{} {}", s.error.symbol(axis.axis()), s.error.name()),
                    plus_minus(s.slope_urad, unc.of(&format!("{path}.slope_urad")), 3),
                    plus_minus(s.intercept_um, unc.of(&format!("{path}.intercept_um")), 3),
                ]
            })
            .collect();
        h.h3("Least-squares lines removed from the straightness curves");
        h.table(
            None,
            &["curve", "slope (µrad)", "intercept at q = 0 (µm)"],
            &slopes,
        );
        if ar.curves.iter().any(|c| c.fourier.order_scores.is_some()) {
            h.h3("Order chosen by leave-one-out cross-validation");
            let mut rows = Vec::new();
            for c in &ar.curves {
                for (s, sr) in [
                    (Series::Fourier, &c.fourier),
                    (Series::Polynomial, &c.polynomial),
                ] {
                    let list = sr
                        .order_scores
                        .as_ref()
                        .map(|v| {
                            v.iter()
                                .map(|o| format!("N={}: {:.4}", o.order, o.loo_rmse))
                                .collect::<Vec<_>>()
                                .join(", ")
                        })
                        .unwrap_or_default();
                    rows.push(vec![
                        format!("{} {}", c.symbol, s.name()),
                        sr.order.to_string(),
                        list,
                    ]);
                }
            }
            h.table(
                None,
                &["curve", "chosen N", "leave-one-out RMSE per N"],
                &rows,
            );
        }
    }
    Ok(())
}

/// The volumetric errors (with `--at`), the first rows.
fn volumetric_section(h: &mut Page, r: &Report, u: &Uncertainty) {
    if let Some(v) = &r.volumetric {
        h.h2("volumetric", "Volumetric errors");
        h.paragraph(&format!(
            "{} positions; largest |Δ| {}, RMS {} (workpiece frame; all rows in volumetric.csv).",
            v.points,
            plus_minus_in(v.max_um, u.of("volumetric.max_um"), 3, "µm"),
            plus_minus_in(v.rms_um, u.of("volumetric.rms_um"), 3, "µm"),
        ));
        let rows: Vec<Vec<String>> = v
            .rows
            .iter()
            .take(MAX_TABLE_ROWS)
            .map(|p| {
                vec![
                    format!("({}, {}, {})", p.q_mm[0], p.q_mm[1], p.q_mm[2]),
                    format!("{:.3}", p.d_um[0]),
                    format!("{:.3}", p.d_um[1]),
                    format!("{:.3}", p.d_um[2]),
                ]
            })
            .collect();
        h.table(
            Some("volumetric-table"),
            &["carriages x, y, z (mm)", "Δx (µm)", "Δy (µm)", "Δz (µm)"],
            &rows,
        );
    }
}

/// The LinuxCNC compensation files.
fn compensation_section(h: &mut Page, r: &Report) {
    h.h2("compensation", "Pitch compensation tables (LinuxCNC)");
    h.paragraph(
        "comp_<axis>.txt per axis: COMP_FILE_TYPE = 0, each line the nominal position, the actual position \
         moving in + and moving in − (mm), from the positioning curve at the measured positions.",
    );
    let rows: Vec<Vec<String>> = r
        .axes
        .iter()
        .map(|ax| {
            vec![
                format!("comp_{}.txt", ax.axis.name()),
                ax.points
                    .min(formats::probe::volumetric::COMP_FILE_MAX_LINES)
                    .to_string(),
                if ax.compensation_bidirectional {
                    "forward and reverse measured".into()
                } else {
                    "one curve for both directions".into()
                },
            ]
        })
        .collect();
    h.table(None, &["file", "lines", "directions"], &rows);
}

/// How a vision campaign's sweeps became curves (with `--from-report`).
fn campaign_section(h: &mut Page, r: &Report) {
    if let Some(c) = &r.campaign {
        h.h2("campaign", "Curves from a vision campaign");
        let rows: Vec<Vec<String>> = c
            .sweeps
            .iter()
            .map(|s| {
                vec![
                    format!("{} (line {})", s.axis.name(), s.line),
                    format!("{}", s.reference_mm),
                    format!(
                        "({:.3}, {:.3}, {:.3})",
                        s.lever_mm[0], s.lever_mm[1], s.lever_mm[2]
                    ),
                ]
            })
            .collect();
        h.table(
            None,
            &["axis", "curves zero at (mm)", "lever to the sphere (mm)"],
            &rows,
        );
        let sq: Vec<String> = c
            .measured_squareness_urad
            .iter()
            .map(|(k, v)| format!("measured {k} = {v:.3} µrad"))
            .collect();
        h.notes("Campaign notes", &[sq, c.notes.clone()].concat(), false);
    }
}

/// Rows of the volumetric table on the page (the CSV has them all).
const MAX_TABLE_ROWS: usize = 60;
