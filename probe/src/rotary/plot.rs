//! SVG plots of the rotary report (plotters through `report::plot`): three
//! errors against the table angle with their ±u bars, and the path of a
//! pair of errors (EXC–EYC, EAC–EBC) over the turn with the circle a fixed
//! axis at the location errors draws and the axis average line marked.

use plotters::prelude::*;
use report::plot::{
    DOWN, HEIGHT, MAP_HEIGHT, MEAN, RGBColor, WIDTH, ZONE, angle_ticks, legend, line_chart,
    line_chart_ticked, padded, svg, with_legend_room,
};

use super::FULL_TURN_DEG;
use crate::Result;

/// One series of an angle plot: label, value per angle, optional ±u per angle.
pub(super) struct Series<'a> {
    /// Legend label.
    pub label: String,
    /// Values per measured angle (µm or µrad).
    pub values: &'a [f64],
    /// Standard uncertainties per angle, drawn as ±u bars.
    pub u: Option<&'a [f64]>,
    /// Colour.
    pub colour: RGBColor,
}

/// Width over height of a path plot's drawing area (px), for equal scales.
const PATH_AREA_ASPECT: f64 = 820.0 / 450.0;

/// Steps of the fixed-axis circle drawn in a path plot.
const CIRCLE_STEPS: u32 = 180;

/// Errors against the angle (0°…360°): each series as a line through the
/// measured angles, closed to 360° with the value at 0° (the wrap of the
/// interpolation), dots at the measured angles, ±u bars where given.
pub(super) fn against_angle(
    title: &str,
    y_desc: &str,
    angles_deg: &[f64],
    series: &[Series<'_>],
) -> Result<String> {
    let ys = series.iter().flat_map(|s| {
        s.values.iter().enumerate().flat_map(move |(k, v)| {
            let u = s.u.and_then(|u| u.get(k)).copied().unwrap_or(0.0);
            [v - u, v + u]
        })
    });
    let (y0, y1) = with_legend_room(padded(ys, 0.5));
    Ok(svg(title, (WIDTH, HEIGHT), |root| {
        // Ticked at the measured angles' step (30° steps every 30°).
        let ticks = angle_ticks(angles_deg, (0.0, FULL_TURN_DEG)).unwrap_or_default();
        let mut chart = line_chart_ticked(
            root,
            title,
            (0.0, FULL_TURN_DEG),
            (y0, y1),
            ("table angle θ (°)", y_desc),
            &ticks,
        )?;
        for s in series {
            let colour = s.colour;
            let mut line: Vec<(f64, f64)> = angles_deg
                .iter()
                .copied()
                .zip(s.values.iter().copied())
                .collect();
            if let Some(first) = s.values.first() {
                line.push((FULL_TURN_DEG, *first));
            }
            chart
                .draw_series(LineSeries::new(line, colour.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(s.label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(
                    angles_deg
                        .iter()
                        .zip(s.values)
                        .map(|(a, v)| Circle::new((*a, *v), 3, colour.filled())),
                )
                .map_err(|e| e.to_string())?;
            if let Some(u) = s.u {
                chart
                    .draw_series(angles_deg.iter().zip(s.values).zip(u).map(|((a, v), u)| {
                        PathElement::new(vec![(*a, v - u), (*a, v + u)], colour.stroke_width(1))
                    }))
                    .map_err(|e| e.to_string())?;
            }
        }
        legend(&mut chart)
    })?)
}

/// The path of a pair of errors over the turn.
pub(super) struct Path<'a> {
    /// The pair's names, e.g. `("EXC", "EYC")`.
    pub names: (&'a str, &'a str),
    /// Unit of both (µm or µrad).
    pub unit: &'a str,
    /// The measured pair per angle.
    pub measured: Vec<(f64, f64)>,
    /// The location (X0C, Y0C) or (A0C, B0C), when known.
    pub location: Option<(f64, f64)>,
}

/// The measured path of a pair (dark, joined in angle order and closed),
/// the circle `(I − Rz(θ))·a` a fixed axis at the location draws (green),
/// and the location itself (red), on axes of equal scale.
pub(super) fn path(title: &str, p: &Path<'_>) -> Result<String> {
    let circle: Vec<(f64, f64)> = p
        .location
        .map(|(ax, ay)| {
            (0..=CIRCLE_STEPS)
                .map(|k| {
                    let (s, c) =
                        (f64::from(k) / f64::from(CIRCLE_STEPS) * std::f64::consts::TAU).sin_cos();
                    (ax - (c * ax - s * ay), ay - (s * ax + c * ay))
                })
                .collect()
        })
        .unwrap_or_default();
    let xs = p.measured.iter().chain(&circle).map(|q| q.0).chain([0.0]);
    let ys = p.measured.iter().chain(&circle).map(|q| q.1).chain([0.0]);
    let (x0, x1) = padded(xs, 0.5);
    let (y0, y1) = with_legend_room(padded(ys, 0.5));
    let aspect = PATH_AREA_ASPECT;
    let (xc, yc) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let half_x = ((x1 - x0) / 2.0).max((y1 - y0) / 2.0 * aspect);
    let half_y = half_x / aspect;
    let (x0, x1, y0, y1) = (xc - half_x, xc + half_x, yc - half_y, yc + half_y);
    let (nx, ny) = p.names;
    let unit = p.unit;
    Ok(svg(title, (WIDTH, MAP_HEIGHT), |root| {
        let mut chart = line_chart(
            root,
            title,
            (x0, x1),
            (y0, y1),
            &format!("{nx} ({unit})"),
            &format!("{ny} ({unit})"),
        )?;
        if !circle.is_empty() {
            chart
                .draw_series(LineSeries::new(circle.clone(), ZONE.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label("fixed axis at the location errors: (I − Rz(θ))·location")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], ZONE.stroke_width(2)));
        }
        let mut closed = p.measured.clone();
        if let Some(first) = p.measured.first() {
            closed.push(*first);
        }
        chart
            .draw_series(LineSeries::new(closed, MEAN.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(format!(
                "measured {nx}, {ny} over the turn (0° at the origin)"
            ))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MEAN.stroke_width(2)));
        chart
            .draw_series(p.measured.iter().map(|q| Circle::new(*q, 3, MEAN.filled())))
            .map_err(|e| e.to_string())?;
        if let Some(loc) = p.location {
            chart
                .draw_series(std::iter::once(Circle::new(loc, 7, DOWN.filled())))
                .map_err(|e| e.to_string())?
                .label(format!(
                    "axis average line ({:.2}, {:.2}) {unit}",
                    loc.0, loc.1
                ))
                .legend(|(x, y)| Circle::new((x + 10, y), 5, DOWN.filled()));
        }
        legend(&mut chart)
    })?)
}
