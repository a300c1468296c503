//! SVG plots of the report (plotters, SVG backend, in memory): positioning
//! deviation per target with mean and ±2s bands per direction (the way
//! laser-calibration software shows it), straightness profiles with the
//! reference line and the minimum zone, angular errors, and a flatness map.

use ::report::plot::{
    DOWN, HEIGHT, LineChart, MAP_HEIGHT, MEAN, RPY, UP, WIDTH, ZONE, colour_bar, diverging, legend,
    line_chart, padded, svg, with_legend_room,
};
use plotters::prelude::*;

/// The colour type of the plot constants.
pub use ::report::plot::RGBColor;

use crate::Result;
use formats::evaluation::{AngularReport, FlatnessReport, PositioningReport, StraightnessReport};

/// The x axis of the line plots.
const POSITION: &str = "commanded position (mm)";

/// Positioning deviation per target: each run as a dot, the mean per
/// direction as a solid line, `x̄ ± 2s` as dashed lines, the bidirectional
/// mean in black.
pub fn positioning(title: &str, p: &PositioningReport) -> Result<String> {
    let xs = || p.targets.iter().map(|t| t.nominal);
    let (x0, x1) = padded(xs(), 1.0);
    let ys = p.targets.iter().flat_map(|t| {
        let band = |m: Option<f64>, s: Option<f64>| match (m, s) {
            (Some(m), Some(s)) => vec![m - 2.0 * s, m + 2.0 * s],
            _ => vec![],
        };
        t.runs_up_um
            .iter()
            .chain(&t.runs_down_um)
            .copied()
            .chain(band(t.mean_up_um, t.s_up_um))
            .chain(band(t.mean_down_um, t.s_down_um))
            .collect::<Vec<f64>>()
    });
    let (y0, y1) = with_legend_room(padded(ys, 0.5));
    Ok(svg(title, (WIDTH, HEIGHT), |root| {
        let mut chart = line_chart(
            root,
            title,
            (x0, x1),
            (y0, y1),
            POSITION,
            "positional deviation (µm)",
        )?;
        type Get =
            fn(&formats::evaluation::PositioningTarget) -> (Option<f64>, Option<f64>, &[f64]);
        let directions: [(&str, RGBColor, Get); 2] = [
            ("↑", UP, |t| (t.mean_up_um, t.s_up_um, &t.runs_up_um)),
            ("↓", DOWN, |t| {
                (t.mean_down_um, t.s_down_um, &t.runs_down_um)
            }),
        ];
        for (name, colour, get) in directions {
            if p.targets.iter().all(|t| get(t).0.is_none()) {
                continue;
            }
            let runs: Vec<(f64, f64)> = p
                .targets
                .iter()
                .flat_map(|t| get(t).2.iter().map(move |v| (t.nominal, *v)))
                .collect();
            chart
                .draw_series(
                    runs.iter()
                        .map(|&c| Circle::new(c, 2, colour.mix(0.45).filled())),
                )
                .map_err(|e| e.to_string())?;
            let with = |f: fn(f64, f64) -> f64| -> Vec<(f64, f64)> {
                p.targets
                    .iter()
                    .filter_map(|t| match get(t) {
                        (Some(m), Some(s), _) => Some((t.nominal, f(m, s))),
                        _ => None,
                    })
                    .collect()
            };
            chart
                .draw_series(LineSeries::new(with(|m, _| m), colour.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(format!("{name} mean x̄"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
                let band = with(if sign > 0.0 {
                    |m, s| m + 2.0 * s
                } else {
                    |m, s| m - 2.0 * s
                });
                let series = chart
                    .draw_series(DashedLineSeries::new(band, 6, 4, colour.stroke_width(1)))
                    .map_err(|e| e.to_string())?;
                if k == 0 {
                    series
                        .label(format!("{name} x̄ ± 2s"))
                        .legend(move |(x, y)| {
                            EmptyElement::at((x, y))
                                + PathElement::new(vec![(0, 0), (7, 0)], colour)
                                + PathElement::new(vec![(12, 0), (19, 0)], colour)
                        });
                }
            }
        }
        let bi: Vec<(f64, f64)> = p
            .targets
            .iter()
            .filter_map(|t| t.mean_um.map(|m| (t.nominal, m)))
            .collect();
        if !bi.is_empty() {
            chart
                .draw_series(LineSeries::new(bi, MEAN.stroke_width(1)))
                .map_err(|e| e.to_string())?
                .label("bidirectional mean x̄")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MEAN));
        }
        legend(&mut chart)
    })?)
}

/// Straightness profile: deviation from the least-squares reference line per
/// target, the reference line itself (0) and the minimum zone as a band.
pub fn straightness(title: &str, s: &StraightnessReport) -> Result<String> {
    let values = s
        .targets
        .iter()
        .map(|t| (t.nominal, [t.deviation_um, t.zone_low_um, t.zone_high_um]));
    target_plot(
        title,
        values,
        0.5,
        "straightness deviation (µm)",
        |chart, (x0, x1)| {
            let mut band: Vec<(f64, f64)> = s
                .targets
                .iter()
                .map(|t| (t.nominal, t.zone_low_um))
                .collect();
            band.extend(s.targets.iter().rev().map(|t| (t.nominal, t.zone_high_um)));
            chart
                .draw_series(std::iter::once(Polygon::new(band, ZONE.mix(0.15).filled())))
                .map_err(|e| e.to_string())?
                .label(format!("minimum zone {:.3} µm", s.min_zone_um))
                .legend(|(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 20, y + 5)], ZONE.mix(0.3).filled())
                });
            for edge in [
                s.targets
                    .iter()
                    .map(|t| (t.nominal, t.zone_low_um))
                    .collect::<Vec<_>>(),
                s.targets
                    .iter()
                    .map(|t| (t.nominal, t.zone_high_um))
                    .collect(),
            ] {
                chart
                    .draw_series(LineSeries::new(edge, ZONE.stroke_width(1)))
                    .map_err(|e| e.to_string())?;
            }
            chart
                .draw_series(DashedLineSeries::new(
                    [(x0, 0.0), (x1, 0.0)],
                    8,
                    5,
                    UP.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?
                .label(format!(
                    "least-squares reference line (range {:.3} µm)",
                    s.lsq_um
                ))
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], UP.stroke_width(2)));
            let profile: Vec<(f64, f64)> = s
                .targets
                .iter()
                .map(|t| (t.nominal, t.deviation_um))
                .collect();
            chart
                .draw_series(LineSeries::new(profile.clone(), MEAN.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label("profile (per-target mean)")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MEAN.stroke_width(2)));
            chart
                .draw_series(
                    profile
                        .into_iter()
                        .map(|c| Circle::new(c, 3, MEAN.filled())),
                )
                .map_err(|e| e.to_string())?;
            Ok(())
        },
    )
}

/// Roll, pitch and yaw per target (µrad).
pub fn angular(title: &str, a: &AngularReport) -> Result<String> {
    let values = a
        .targets
        .iter()
        .map(|t| (t.nominal, [t.roll_urad, t.pitch_urad, t.yaw_urad]));
    target_plot(title, values, 1.0, "angle (µrad)", |chart, _| {
        type Get = fn(&formats::evaluation::AngularTarget) -> f64;
        let series: [(&str, f64, Get); 3] = [
            ("roll", a.roll_urad, |t| t.roll_urad),
            ("pitch", a.pitch_urad, |t| t.pitch_urad),
            ("yaw", a.yaw_urad, |t| t.yaw_urad),
        ];
        for ((name, range, get), colour) in series.into_iter().zip(RPY) {
            let pts: Vec<(f64, f64)> = a.targets.iter().map(|t| (t.nominal, get(t))).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(format!("{name} (range {range:.2} µrad)"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(pts.into_iter().map(|c| Circle::new(c, 3, colour.filled())))
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    })
}

/// A line plot of three values per target against the commanded position:
/// x spans the `(position, values)` pairs' positions (padded to at least
/// ±1 mm), y their values (padded to at least ±`y_pad`, with room for the
/// legend); `draw` draws the series on the chart, given the x range, and the
/// legend follows.
fn target_plot(
    title: &str,
    targets: impl Iterator<Item = (f64, [f64; 3])> + Clone,
    y_pad: f64,
    y_desc: &str,
    draw: impl FnOnce(&mut LineChart<'_, '_>, (f64, f64)) -> std::result::Result<(), String>,
) -> Result<String> {
    let (x0, x1) = padded(targets.clone().map(|(x, _)| x), 1.0);
    let (y0, y1) = with_legend_room(padded(targets.flat_map(|(_, y)| y), y_pad));
    Ok(svg(title, (WIDTH, HEIGHT), |root| {
        let mut chart = line_chart(root, title, (x0, x1), (y0, y1), POSITION, y_desc)?;
        draw(&mut chart, (x0, x1))?;
        legend(&mut chart)
    })?)
}

/// Flatness map: the points in the XY plane, coloured by their deviation
/// from the least-squares plane, joined along their lines, with a colour bar.
pub fn flatness(title: &str, f: &FlatnessReport) -> Result<String> {
    let (x0, x1) = padded(f.points.iter().map(|p| p.x), 5.0);
    let (y0, y1) = padded(f.points.iter().map(|p| p.y), 5.0);
    let limit = f
        .points
        .iter()
        .map(|p| p.lsq_um.abs())
        .fold(0.0, f64::max)
        .max(1e-3);
    Ok(svg(title, (WIDTH, MAP_HEIGHT), |root| {
        let (plot, bar) = root.split_horizontally(WIDTH - 130);
        let mut chart = line_chart(&plot, title, (x0, x1), (y0, y1), "x (mm)", "y (mm)")?;
        let mut keys: Vec<(&str, usize)> =
            f.points.iter().map(|p| (p.axis.as_str(), p.line)).collect();
        keys.dedup();
        for (axis, line) in keys {
            let path: Vec<(f64, f64)> = f
                .points
                .iter()
                .filter(|p| p.axis == axis && p.line == line)
                .map(|p| (p.x, p.y))
                .collect();
            chart
                .draw_series(LineSeries::new(
                    path,
                    RGBColor(190, 190, 190).stroke_width(1),
                ))
                .map_err(|e| e.to_string())?;
        }
        chart
            .draw_series(f.points.iter().map(|p| {
                EmptyElement::at((p.x, p.y))
                    + Circle::new((0, 0), 7, diverging(p.lsq_um / limit).filled())
                    + Circle::new((0, 0), 7, RGBColor(90, 90, 90).stroke_width(1))
            }))
            .map_err(|e| e.to_string())?;
        colour_bar(
            &bar,
            MAP_HEIGHT,
            limit,
            "µm",
            ["deviation from", "LSQ plane"],
        )
    })?)
}
