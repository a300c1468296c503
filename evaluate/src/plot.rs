//! SVG plots of the report (plotters, SVG backend, in memory): positioning
//! deviation per target with mean and ±2s bands per direction (the way
//! laser-calibration software shows it), straightness profiles with the
//! reference line and the minimum zone, angular errors, and a flatness map.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// The colour type of the plot constants.
pub use plotters::style::RGBColor;

use crate::report::{AngularReport, FlatnessReport, PositioningReport, StraightnessReport};
use crate::{EvaluateError, Result};

/// Width of every plot (px).
pub const WIDTH: u32 = 900;
/// Height of the line plots (px).
pub const HEIGHT: u32 = 420;
/// Height of the flatness map (px).
pub const MAP_HEIGHT: u32 = 560;

/// Colour of the ↑ direction.
pub const UP: RGBColor = RGBColor(31, 119, 180);
/// Colour of the ↓ direction.
pub const DOWN: RGBColor = RGBColor(214, 39, 40);
/// Colour of the bidirectional mean and of profiles.
pub const MEAN: RGBColor = RGBColor(40, 40, 40);
/// Colour of the minimum zone.
pub const ZONE: RGBColor = RGBColor(44, 160, 44);
/// Colours of roll, pitch, yaw.
pub const RPY: [RGBColor; 3] = [
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

const FONT: &str = "sans-serif";

/// A drawing error with the plot's title.
fn plot_error(title: &str, e: impl std::fmt::Display) -> EvaluateError {
    EvaluateError::Plot {
        plot: title.to_string(),
        message: e.to_string(),
    }
}

/// `(lo, hi)` of the values padded by 8 % (at least `min_half` around the centre).
fn padded(values: impl Iterator<Item = f64>, min_half: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo
        .partial_cmp(&hi)
        .is_none_or(|o| o == std::cmp::Ordering::Greater)
    {
        return (-min_half, min_half);
    }
    let centre = (lo + hi) / 2.0;
    let half = ((hi - lo) / 2.0 * 1.08).max(min_half);
    (centre - half, centre + half)
}

/// Raise the top of a range by 35 % so that the legend (upper left) sits
/// above the data.
fn with_legend_room((lo, hi): (f64, f64)) -> (f64, f64) {
    (lo, hi + 0.35 * (hi - lo))
}

/// A line plot's chart over the commanded position: caption, axes, light grid.
type LineChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Build a line plot's chart on `root` with its title, ranges and y-axis label.
fn line_chart<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, Shift>,
    title: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    y_desc: &str,
) -> std::result::Result<LineChart<'a, 'b>, String> {
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 20))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("commanded position (mm)")
        .y_desc(y_desc)
        .light_line_style(RGBColor(240, 240, 240))
        .max_light_lines(2)
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(chart)
}

/// Draw a line plot's legend in its upper left corner.
fn legend<'a, 'b: 'a>(chart: &mut LineChart<'a, 'b>) -> std::result::Result<(), String> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .label_font((FONT, 13))
        .draw()
        .map_err(|e| e.to_string())
}

/// Draw into a fresh SVG string of `size` with `draw`; errors carry `title`.
fn svg(
    title: &str,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> std::result::Result<(), String>,
) -> Result<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(title, e))?;
        draw(&root).map_err(|e| plot_error(title, e))?;
        root.present().map_err(|e| plot_error(title, e))?;
    }
    Ok(out)
}

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
    svg(title, (WIDTH, HEIGHT), |root| {
        let mut chart = line_chart(root, title, (x0, x1), (y0, y1), "positional deviation (µm)")?;
        type Get = fn(&crate::report::PositioningTarget) -> (Option<f64>, Option<f64>, &[f64]);
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
    })
}

/// Straightness profile: deviation from the least-squares reference line per
/// target, the reference line itself (0) and the minimum zone as a band.
pub fn straightness(title: &str, s: &StraightnessReport) -> Result<String> {
    let (x0, x1) = padded(s.targets.iter().map(|t| t.nominal), 1.0);
    let (y0, y1) = with_legend_room(padded(
        s.targets
            .iter()
            .flat_map(|t| [t.deviation_um, t.zone_low_um, t.zone_high_um]),
        0.5,
    ));
    svg(title, (WIDTH, HEIGHT), |root| {
        let mut chart = line_chart(
            root,
            title,
            (x0, x1),
            (y0, y1),
            "straightness deviation (µm)",
        )?;
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
            .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], ZONE.mix(0.3).filled()));
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
        legend(&mut chart)
    })
}

/// Roll, pitch and yaw per target (µrad).
pub fn angular(title: &str, a: &AngularReport) -> Result<String> {
    let (x0, x1) = padded(a.targets.iter().map(|t| t.nominal), 1.0);
    let (y0, y1) = with_legend_room(padded(
        a.targets
            .iter()
            .flat_map(|t| [t.roll_urad, t.pitch_urad, t.yaw_urad]),
        1.0,
    ));
    svg(title, (WIDTH, HEIGHT), |root| {
        let mut chart = line_chart(root, title, (x0, x1), (y0, y1), "angle (µrad)")?;
        type Get = fn(&crate::report::AngularTarget) -> f64;
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
        legend(&mut chart)
    })
}

/// Diverging colour for `t` in [−1, 1]: blue (low) – white – red (high).
pub fn diverging(t: f64) -> RGBColor {
    let t = t.clamp(-1.0, 1.0);
    let lerp = |a: f64, b: f64, u: f64| (a + (b - a) * u).round().clamp(0.0, 255.0) as u8;
    let (low, mid, high) = (
        (33.0, 102.0, 172.0),
        (247.0, 247.0, 247.0),
        (178.0, 24.0, 43.0),
    );
    let (from, to, u) = if t < 0.0 {
        (mid, low, -t)
    } else {
        (mid, high, t)
    };
    RGBColor(
        lerp(from.0, to.0, u),
        lerp(from.1, to.1, u),
        lerp(from.2, to.2, u),
    )
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
    svg(title, (WIDTH, MAP_HEIGHT), |root| {
        let (plot, bar) = root.split_horizontally(WIDTH - 130);
        let mut chart = ChartBuilder::on(&plot)
            .caption(title, (FONT, 20))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("x (mm)")
            .y_desc("y (mm)")
            .light_line_style(RGBColor(240, 240, 240))
            .max_light_lines(2)
            .draw()
            .map_err(|e| e.to_string())?;
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
        // Colour bar.
        let steps = 40;
        let (top, height) = (60, MAP_HEIGHT as i32 - 140);
        for k in 0..steps {
            let t = 1.0 - 2.0 * k as f64 / (steps - 1) as f64;
            let y = top + k * height / steps;
            bar.draw(&Rectangle::new(
                [(20, y), (44, y + height / steps + 1)],
                diverging(t).filled(),
            ))
            .map_err(|e| e.to_string())?;
        }
        bar.draw(&Rectangle::new(
            [(20, top), (44, top + height)],
            RGBColor(90, 90, 90).stroke_width(1),
        ))
        .map_err(|e| e.to_string())?;
        let style = (FONT, 13).into_font().color(&BLACK);
        for (text, y) in [
            (format!("{:+.2} µm", limit), top),
            ("0".to_string(), top + height / 2),
            (format!("{:+.2} µm", -limit), top + height),
        ] {
            bar.draw_text(&text, &style, (50, y - 6))
                .map_err(|e| e.to_string())?;
        }
        bar.draw_text("deviation from", &style, (6, top - 40))
            .map_err(|e| e.to_string())?;
        bar.draw_text("LSQ plane", &style, (6, top - 24))
            .map_err(|e| e.to_string())?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diverging_ends_and_middle() {
        assert_eq!(diverging(0.0), RGBColor(247, 247, 247));
        assert_eq!(diverging(-1.0), RGBColor(33, 102, 172));
        assert_eq!(diverging(2.0), RGBColor(178, 24, 43));
    }

    #[test]
    fn padded_range_never_collapses() {
        assert_eq!(padded([3.0, 3.0].into_iter(), 0.5), (2.5, 3.5));
        let (lo, hi) = padded([0.0, 10.0].into_iter(), 0.5);
        assert!(lo < 0.0 && hi > 10.0);
        assert_eq!(padded(std::iter::empty(), 1.0), (-1.0, 1.0));
    }
}
