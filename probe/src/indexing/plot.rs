//! SVG plots of the indexing report: ΔθA and ΔθB as maps over (B, A) on the
//! diverging scale (robust to outliers, which are marked), and as curves
//! against A and B with the per-detent means.

use plotters::prelude::*;
use report::plot::{
    DOWN, HEIGHT, MAP_HEIGHT, MEAN, RGBColor, UP, WIDTH, angle_ticks, colour_bar, diverging,
    legend, line_chart, line_chart_ticked, outlier_key, outlier_mark, padded, robust_limit, svg,
    with_legend_room,
};

use super::Angles;
use crate::Result;

/// Fill of a cell without a value (ΔθB at A = 0°).
const UNDEFINED: RGBColor = RGBColor(215, 215, 215);
/// Outline of a cell beyond the tolerance.
const BEYOND: RGBColor = RGBColor(0, 0, 0);
/// Width of the colour bar beside a map (px).
const BAR_WIDTH: u32 = 130;

/// Cell edges around ascending `levels`: midpoints between neighbours, half
/// a spacing beyond the ends (±`lone` around a single level).
fn edges(levels: &[f64], lone: f64) -> Vec<(f64, f64)> {
    let n = levels.len();
    (0..n)
        .map(|k| {
            let below = if k > 0 {
                (levels[k] - levels[k - 1]) / 2.0
            } else if n > 1 {
                (levels[1] - levels[0]) / 2.0
            } else {
                lone
            };
            let above = if k + 1 < n {
                (levels[k + 1] - levels[k]) / 2.0
            } else {
                below
            };
            (levels[k] - below, levels[k] + above)
        })
        .collect()
}

/// Index of the level nearest to `v`.
fn nearest(levels: &[f64], v: f64) -> usize {
    levels
        .iter()
        .enumerate()
        .min_by(|p, q| (p.1 - v).abs().total_cmp(&(q.1 - v).abs()))
        .map_or(0, |p| p.0)
}

/// A map of `value` over commanded B (x) and A (y): one cell per position
/// coloured on the diverging scale ±L, L from [`robust_limit`] (the largest
/// |value| within 4 × the 90th percentile of |value|), so that one extreme
/// value does not wash out the others; a value beyond ±L is drawn at the
/// scale's end with a triangle (▲ above, ▼ below), counted under the colour
/// bar. Grey where undefined, outlined where |value| exceeds `tolerance` by
/// more than its U = 2·`u` (`super::summary::decision`).
pub(crate) fn map(
    title: &str,
    angles: &[Angles],
    value: impl Fn(&Angles) -> Option<f64>,
    u: impl Fn(&Angles) -> Option<f64>,
    (a_levels, b_levels): (&[f64], &[f64]),
    tolerance: Option<f64>,
    caption: [&str; 2],
) -> Result<String> {
    let a_edges = edges(a_levels, 1.0);
    let b_edges = edges(b_levels, 1.0);
    let span = |e: &[(f64, f64)]| {
        (
            e.first().map_or(0.0, |p| p.0),
            e.last().map_or(1.0, |p| p.1),
        )
    };
    let (x0, x1) = span(&b_edges);
    let (y0, y1) = span(&a_edges);
    let limit = robust_limit(angles.iter().filter_map(&value)).max(1e-3);
    let beyond: Vec<(&Angles, bool)> = angles
        .iter()
        .filter_map(|p| value(p).filter(|v| v.abs() > limit).map(|v| (p, v > 0.0)))
        .collect();
    let above = beyond.iter().filter(|(_, up)| *up).count();
    Ok(svg(title, (WIDTH, MAP_HEIGHT), |root| {
        let (plot, bar) = root.split_horizontally(WIDTH - BAR_WIDTH);
        let mut chart = line_chart(
            &plot,
            title,
            (x0, x1),
            (y0, y1),
            "commanded B (°)",
            "commanded A (°)",
        )?;
        let cell = |p: &Angles| {
            let (b0, b1) = b_edges[nearest(b_levels, super::layout::wrap_deg(p.b_deg))];
            let (a0, a1) = a_edges[nearest(a_levels, p.a_deg)];
            [(b0, a0), (b1, a1)]
        };
        chart
            .draw_series(angles.iter().map(|p| {
                let fill = value(p).map_or(UNDEFINED, |v| diverging(v / limit));
                Rectangle::new(cell(p), fill.filled())
            }))
            .map_err(|e| e.to_string())?;
        if let Some(t) = tolerance {
            chart
                .draw_series(
                    angles
                        .iter()
                        .filter(|p| {
                            value(p).zip(u(p)).is_some_and(|(v, u)| {
                                super::summary::decision(v, u, t)
                                    == formats::conformance::Decision::DoesNotConform
                            })
                        })
                        .map(|p| Rectangle::new(cell(p), BEYOND.stroke_width(2))),
                )
                .map_err(|e| e.to_string())?;
        }
        chart
            .draw_series(beyond.iter().map(|(p, up)| {
                let [(b0, a0), (b1, a1)] = cell(p);
                outlier_mark(((b0 + b1) / 2.0, (a0 + a1) / 2.0), *up)
            }))
            .map_err(|e| e.to_string())?;
        colour_bar(&bar, MAP_HEIGHT, limit, "″", caption)?;
        outlier_key(&bar, MAP_HEIGHT, limit, "″", (above, beyond.len() - above))
    })?)
}

/// A curve plot: every position as a dot, the per-detent means as a line,
/// the tolerance as two dashed lines.
pub(crate) fn curve(
    title: &str,
    x_desc: &str,
    dots: &[(f64, f64)],
    means: &[(f64, f64)],
    labels: [&str; 2],
    tolerance: Option<f64>,
) -> Result<String> {
    let (x0, x1) = padded(dots.iter().map(|p| p.0), 1.0);
    let tol = tolerance.into_iter().flat_map(|t| [t, -t]);
    let (y0, y1) = with_legend_room(padded(dots.iter().map(|p| p.1).chain(tol), 0.5));
    Ok(svg(title, (WIDTH, HEIGHT), |root| {
        // The commanded angles ticked at their step.
        let xs: Vec<f64> = dots.iter().map(|p| p.0).collect();
        let ticks = angle_ticks(&xs, (x0, x1)).unwrap_or_default();
        let mut chart = line_chart_ticked(
            root,
            title,
            (x0, x1),
            (y0, y1),
            (x_desc, "error (″)"),
            &ticks,
        )?;
        chart
            .draw_series(
                dots.iter()
                    .map(|&c| Circle::new(c, 2, UP.mix(0.55).filled())),
            )
            .map_err(|e| e.to_string())?
            .label(labels[0])
            .legend(|(x, y)| Circle::new((x + 10, y), 3, UP.filled()));
        chart
            .draw_series(LineSeries::new(means.iter().copied(), MEAN.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(labels[1])
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MEAN.stroke_width(2)));
        chart
            .draw_series(means.iter().map(|&c| Circle::new(c, 3, MEAN.filled())))
            .map_err(|e| e.to_string())?;
        if let Some(t) = tolerance {
            for (k, level) in [t, -t].into_iter().enumerate() {
                let series = chart
                    .draw_series(DashedLineSeries::new(
                        [(x0, level), (x1, level)],
                        8,
                        5,
                        DOWN.stroke_width(2),
                    ))
                    .map_err(|e| e.to_string())?;
                if k == 0 {
                    series.label(format!("tolerance ±{t}″")).legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], DOWN.stroke_width(2))
                    });
                }
            }
        }
        legend(&mut chart)
    })?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_meet_halfway() {
        assert_eq!(
            edges(&[0.0, 10.0, 30.0], 1.0),
            vec![(-5.0, 5.0), (5.0, 20.0), (20.0, 40.0)]
        );
        assert_eq!(edges(&[3.0], 1.0), vec![(2.0, 4.0)]);
        assert_eq!(nearest(&[0.0, 7.5, 15.0], 8.0), 1);
    }
}
