//! `report.html` of `probe tracer`: the figures, the residuals per station
//! (box plots, flagged readings marked), the correction vectors on the grid
//! (3-D view, magnified) and the uncertainty map (3-D view coloured against
//! the median uncertainty), the stations, the largest corrections, the
//! outliers and the weakly determined points and stations.

use plotters::prelude::*;
use report::plot::{
    DOWN, HEIGHT, MAP_HEIGHT, MEAN, RGBColor, SIX, UP, WIDTH, ZONE, chart_builder, colour_bar,
    diverging, mesh, outlier_key, outlier_mark, padded, percentile, robust_limit, svg,
    with_legend_room,
};
use report::{Page, plus_minus_in};

use super::report::{MAX_CORRECTION, RMS_CORRECTION};
use super::view::{arrows, grid_chart};
use super::{Network, Solution, TracerReport};
use crate::Result;
use formats::uncertainty::Uncertainty;

const UM: f64 = 1e3;
/// The longest correction arrow, as a fraction of the grid's largest extent.
const ARROW_FRACTION: f64 = 0.08;
/// Grids with more points than this get smaller marks in the uncertainty map.
const DENSE_GRID: usize = 2000;
/// Rows of the largest-corrections and outliers tables.
const TABLE_ROWS: usize = 20;

/// The colour of station `j` (the six series colours, repeated).
pub(crate) fn station_colour(j: usize) -> RGBColor {
    SIX[j % SIX.len()]
}

/// Residuals per station: the box holds the middle half, the bar the
/// median, whiskers the unflagged extremes; flagged readings are rings; the
/// dashed lines are the flag limit `k·σ_w·√r̄` at the mean redundancy.
fn residuals_plot(net: &Network, s: &Solution) -> Result<String> {
    let m = net.station_names.len();
    let mut per: Vec<Vec<f64>> = vec![Vec::new(); m];
    let mut flagged: Vec<(usize, f64)> = Vec::new();
    for (r, rd) in s.residuals.iter().zip(&net.readings) {
        if r.outlier {
            flagged.push((rd.station, r.value * UM));
        } else {
            per[rd.station].push(r.value * UM);
        }
    }
    for v in &mut per {
        v.sort_by(f64::total_cmp);
    }
    let mean_r =
        s.residuals.iter().map(|r| r.redundancy).sum::<f64>() / s.residuals.len().max(1) as f64;
    let limit = s.outlier_k * s.sigma_outliers * mean_r.sqrt() * UM;
    let values = s
        .residuals
        .iter()
        .map(|r| r.value * UM)
        .chain([limit, -limit]);
    let (y0, y1) = with_legend_room(padded(values, 0.05));
    let title = "Residuals per station";
    let names = net.station_names.clone();
    Ok(svg(title, (WIDTH, HEIGHT), |root| {
        let mut chart = chart_builder(root, title)
            .build_cartesian_2d(0.4..m as f64 + 0.6, y0..y1)
            .map_err(|e| e.to_string())?;
        let label = |x: &f64| {
            let k = x.round();
            if (x - k).abs() < 1e-9 && k >= 1.0 && k <= names.len() as f64 {
                names[k as usize - 1].clone()
            } else {
                String::new()
            }
        };
        mesh(&mut chart)
            .x_desc("station")
            .y_desc("residual (µm)")
            .x_labels(m + 2)
            .x_label_formatter(&label)
            .disable_x_mesh()
            .max_light_lines(2)
            .draw()
            .map_err(|e| e.to_string())?;
        let (x0, x1) = (0.4, m as f64 + 0.6);
        for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
            let series = chart
                .draw_series(DashedLineSeries::new(
                    [(x0, sign * limit), (x1, sign * limit)],
                    8,
                    5,
                    ZONE.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
            if k == 0 {
                series
                    .label(format!("flag limit ±{}·σ·√r̄ = ±{limit:.3} µm", s.outlier_k))
                    .legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], ZONE.stroke_width(2))
                    });
            }
        }
        for (j, v) in per.iter().enumerate() {
            if v.is_empty() {
                continue;
            }
            let colour = station_colour(j);
            let x = j as f64 + 1.0;
            let (q1, q2, q3) = (percentile(v, 0.25), percentile(v, 0.5), percentile(v, 0.75));
            let (lo, hi) = (v[0], v[v.len() - 1]);
            chart
                .draw_series([
                    Rectangle::new([(x - 0.28, q1), (x + 0.28, q3)], colour.mix(0.35).filled()),
                    Rectangle::new([(x - 0.28, q1), (x + 0.28, q3)], colour.stroke_width(2)),
                ])
                .map_err(|e| e.to_string())?;
            chart
                .draw_series([
                    PathElement::new(vec![(x - 0.28, q2), (x + 0.28, q2)], colour.stroke_width(3)),
                    PathElement::new(vec![(x, hi), (x, q3)], colour.stroke_width(2)),
                    PathElement::new(vec![(x, lo), (x, q1)], colour.stroke_width(2)),
                    PathElement::new(vec![(x - 0.12, hi), (x + 0.12, hi)], colour.stroke_width(2)),
                    PathElement::new(vec![(x - 0.12, lo), (x + 0.12, lo)], colour.stroke_width(2)),
                ])
                .map_err(|e| e.to_string())?;
        }
        chart
            .draw_series(
                flagged
                    .iter()
                    .map(|&(j, v)| Circle::new((j as f64 + 1.0, v), 6, DOWN.stroke_width(2))),
            )
            .map_err(|e| e.to_string())?
            .label(format!("flagged reading ({})", flagged.len()))
            .legend(|(x, y)| Circle::new((x + 10, y), 5, DOWN.stroke_width(2)));
        report::plot::legend(&mut chart)
    })?)
}

/// Ranges of the three axes over the points (mm), padded.
fn ranges(net: &Network) -> [(f64, f64); 3] {
    [0, 1, 2].map(|a| padded(net.points.iter().map(|p| p[a]), 1.0))
}

/// Correction vectors on the grid: each nominal point (dot) with an arrow
/// along its correction, magnified so that the longest is a fixed share of
/// the grid.
fn corrections_plot(net: &Network, s: &Solution) -> Result<String> {
    let r = ranges(net);
    let extent = r.iter().map(|(lo, hi)| hi - lo).fold(0.0, f64::max);
    let longest = s
        .corrections
        .iter()
        .map(|c| c.vector.norm())
        .fold(0.0, f64::max);
    let gain = if longest > 0.0 {
        ARROW_FRACTION * extent / longest
    } else {
        1.0
    };
    let title = format!(
        "Correction vectors (× {gain:.0}; longest {:.3} µm)",
        longest * UM
    );
    Ok(svg(&title, (WIDTH, MAP_HEIGHT), |root| {
        let mut chart = grid_chart(root, &title, r)?;
        let ends = net.points.iter().zip(&s.corrections).map(|(p, c)| {
            let q = p + c.vector * gain;
            ([p.x, p.y, p.z], [q.x, q.y, q.z])
        });
        arrows(&mut chart, root, ends, UP)?;
        chart
            .draw_series(
                net.points
                    .iter()
                    .map(|p| Circle::new((p.x, p.z, p.y), 2, MEAN.filled())),
            )
            .map_err(|e| e.to_string())?;
        Ok(())
    })?)
}

/// Uncertainty map: each point coloured by its largest standard uncertainty
/// against the median (blue: better determined, red: worse), on a scale ±L
/// robust to outliers ([`robust_limit`]): a few weakly determined points
/// are drawn at the scale's end and marked, not allowed to wash out the rest.
fn uncertainty_plot(net: &Network, s: &Solution) -> Result<String> {
    let r = ranges(net);
    let u: Vec<f64> = s.corrections.iter().map(|c| c.u.max() * UM).collect();
    let mut sorted = u.clone();
    sorted.sort_by(f64::total_cmp);
    let median = percentile(&sorted, 0.5);
    let spread = robust_limit(u.iter().map(|v| v - median)).max(1e-6);
    let beyond: Vec<_> = net
        .points
        .iter()
        .zip(&u)
        .filter(|(_, v)| (*v - median).abs() > spread)
        .map(|(p, v)| (p, *v > median))
        .collect();
    let above = beyond.iter().filter(|(_, up)| *up).count();
    let title = format!("Standard uncertainty of the corrections (median {median:.3} µm)");
    // Smaller marks where the grid is dense.
    let radius = if u.len() > DENSE_GRID { 3 } else { 5 };
    Ok(svg(&title, (WIDTH, MAP_HEIGHT), |root| {
        let (plot, bar) = root.split_horizontally(WIDTH - 130);
        let mut chart = grid_chart(&plot, &title, r)?;
        chart
            .draw_series(net.points.iter().zip(&u).map(|(p, v)| {
                EmptyElement::at((p.x, p.z, p.y))
                    + Circle::new((0, 0), radius, diverging((v - median) / spread).filled())
                    + Circle::new((0, 0), radius, RGBColor(90, 90, 90).stroke_width(1))
            }))
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(
                beyond
                    .iter()
                    .map(|(p, up)| outlier_mark((p.x, p.z, p.y), *up)),
            )
            .map_err(|e| e.to_string())?;
        colour_bar(&bar, MAP_HEIGHT, spread, "µm", ["largest u", "− median"])?;
        outlier_key(
            &bar,
            MAP_HEIGHT,
            spread,
            "µm",
            (above, beyond.len() - above),
        )
    })?)
}

/// `report.html`: figures, plots and tables of a solution of `net`, the
/// verdict and test conditions of `signoff` first.
pub fn html(
    net: &Network,
    s: &Solution,
    r: &TracerReport,
    u: &Uncertainty,
    signoff: &formats::conformance::SignOff,
) -> Result<String> {
    let mut page = Page::new(
        "trinocular — laser-tracer multilateration",
        "CMM volumetric correction by laser-tracer multilateration",
    );
    page.meta(&format!(
        "{} grid points, {} stations, {} readings; {} unknowns after the datum, redundancy {}",
        r.points, r.stations, r.equations, r.unknowns, r.redundancy
    ));
    report::conformance::header(&mut page, signoff);
    figures_section(&mut page, net, s, r, u)?;
    report::uncertainty::section(&mut page, Some(u));
    stations_table(&mut page, r);
    largest_corrections(&mut page, net, s);
    outliers_section(&mut page, r);
    weak_notes(&mut page, r);
    Ok(page.finish())
}

/// The solution's figures, its datum and the three plots.
fn figures_section(
    page: &mut Page,
    net: &Network,
    s: &Solution,
    r: &TracerReport,
    u: &Uncertainty,
) -> Result<()> {
    page.h2("figures", "Figures");
    let rows: Vec<Vec<String>> = vec![
        vec![
            "residual RMS".into(),
            format!("{:.4} µm", r.residual_rms_um),
        ],
        vec![
            "σ of a reading".into(),
            format!(
                "{:.4} µm ({})",
                r.sigma_um,
                if r.sigma_a_priori {
                    format!("a priori; a posteriori {:.4} µm", r.sigma0_um)
                } else {
                    "a posteriori".into()
                }
            ),
        ],
        vec![
            "iterations".into(),
            format!("{} (last step {:.2e} µm)", r.iterations, r.last_step_um),
        ],
        vec![
            "condition (reduced normal matrix)".into(),
            format!("{:.3e}", r.condition),
        ],
        vec![
            "worst point geometry".into(),
            format!(
                "point {}: condition {:.1}",
                r.worst_point, r.worst_point_condition
            ),
        ],
        vec![
            "largest correction".into(),
            format!(
                "{} at point {}",
                plus_minus_in(r.max_correction_um, u.of(MAX_CORRECTION), 3, "µm"),
                r.max_correction_point
            ),
        ],
        vec![
            "RMS correction".into(),
            plus_minus_in(r.rms_correction_um, u.of(RMS_CORRECTION), 3, "µm"),
        ],
        vec![
            "standard uncertainty".into(),
            format!(
                "median {:.4} µm, largest {:.4} µm",
                r.median_u_um, r.max_u_um
            ),
        ],
        vec![
            "outliers".into(),
            format!(
                "{} at |w| > {} (≈ {:.1} expected by chance; σ_w {:.4} µm)",
                r.outliers.count, r.outliers.k, r.outliers.expected_by_chance, r.outliers.sigma_um
            ),
        ],
    ];
    page.table(Some("figures"), &["figure", "value"], &rows);
    page.paragraph(&format!("Datum: {}.", r.datum));
    page.figure(
        "plot-residuals",
        &residuals_plot(net, s)?,
        "Residuals |A − P| − d − l per station: box = middle half, bar = median, whiskers = \
         extremes of the unflagged readings, rings = flagged readings.",
    );
    page.figure(
        "plot-corrections",
        &corrections_plot(net, s)?,
        "Corrections (true − nominal, no rigid motion) as magnified blue arrows from the nominal \
         grid points (black dots); x along the left edge, y along the right edge, z up.",
    );
    page.figure(
        "plot-uncertainty",
        &uncertainty_plot(net, s)?,
        "Largest standard uncertainty of each point's correction, against the median.",
    );
    Ok(())
}

/// Every station: position, dead path, uncertainties, readings, residual.
fn stations_table(page: &mut Page, r: &TracerReport) {
    page.h2("stations", "Stations");
    let rows: Vec<Vec<String>> = r
        .station_positions
        .iter()
        .map(|st| {
            vec![
                st.station.clone(),
                format!("{:.4}", st.position[0]),
                format!("{:.4}", st.position[1]),
                format!("{:.4}", st.position[2]),
                format!("{:.4}", st.dead_path),
                format!(
                    "{:.2} / {:.2} / {:.2}",
                    st.u_position_um[0], st.u_position_um[1], st.u_position_um[2]
                ),
                format!("{:.3}", st.u_dead_path_um),
                st.readings.to_string(),
                format!("{:.4}", st.residual_rms_um),
            ]
        })
        .collect();
    page.table(
        Some("stations"),
        &[
            "station",
            "x (mm)",
            "y (mm)",
            "z (mm)",
            "dead path (mm)",
            "u x/y/z (µm)",
            "u dead path (µm)",
            "readings",
            "residual RMS (µm)",
        ],
        &rows,
    );
}

/// The largest corrections, largest first.
fn largest_corrections(page: &mut Page, net: &Network, s: &Solution) {
    page.h2("largest", "Largest corrections");
    let mut order: Vec<usize> = (0..s.corrections.len()).collect();
    order.sort_by(|&a, &b| {
        s.corrections[b]
            .vector
            .norm()
            .total_cmp(&s.corrections[a].vector.norm())
    });
    let rows: Vec<Vec<String>> = order
        .iter()
        .take(TABLE_ROWS)
        .map(|&i| {
            let (p, c) = (&net.points[i], &s.corrections[i]);
            vec![
                net.point_names[i].clone(),
                format!("{:.3}, {:.3}, {:.3}", p.x, p.y, p.z),
                format!("{:.3}", c.vector.x * UM),
                format!("{:.3}", c.vector.y * UM),
                format!("{:.3}", c.vector.z * UM),
                format!("{:.3} / {:.3} / {:.3}", c.u.x * UM, c.u.y * UM, c.u.z * UM),
            ]
        })
        .collect();
    page.table(
        Some("largest-corrections"),
        &[
            "point",
            "nominal (mm)",
            "dx (µm)",
            "dy (µm)",
            "dz (µm)",
            "u x/y/z (µm)",
        ],
        &rows,
    );
}

/// The flagged readings, when there are any.
fn outliers_section(page: &mut Page, r: &TracerReport) {
    if r.outliers.count > 0 {
        page.h2("outliers", "Flagged readings");
        page.paragraph(&format!(
            "{} readings with |w| > {}; they are kept in the solution (re-measure them or remove \
             them from the readings and solve again). The largest {} by |w|:",
            r.outliers.count,
            r.outliers.k,
            TABLE_ROWS.min(r.outliers.count)
        ));
        let rows: Vec<Vec<String>> = r
            .outliers
            .readings
            .iter()
            .take(TABLE_ROWS)
            .map(|o| {
                vec![
                    o.station.clone(),
                    o.point.clone(),
                    format!("{:.3}", o.residual_um),
                    format!("{:.2}", o.normalized),
                ]
            })
            .collect();
        page.table(
            Some("outliers"),
            &["station", "point", "residual (µm)", "w"],
            &rows,
        );
    }
}

/// Stations and points the layout determines weakly.
fn weak_notes(page: &mut Page, r: &TracerReport) {
    let weak: Vec<String> = r
        .weak
        .stations
        .iter()
        .map(|w| format!("station {}: {}", w.name, w.reason))
        .chain(
            r.weak
                .points
                .iter()
                .map(|w| format!("point {}: {}", w.name, w.reason)),
        )
        .collect();
    page.notes("Weakly determined", &weak, true);
}
