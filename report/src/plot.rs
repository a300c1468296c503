//! SVG plots in memory (plotters' SVG backend): the chart set-up every line
//! plot shares, its legend, padded ranges, the report's colours and a
//! diverging colour scale for maps.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// The colour type of the plot constants.
pub use plotters::style::RGBColor;

use crate::{ReportError, Result};

/// Width of every plot (px).
pub const WIDTH: u32 = 900;
/// Height of the line plots (px).
pub const HEIGHT: u32 = 420;
/// Height of maps (px).
pub const MAP_HEIGHT: u32 = 560;

/// Colour of the ↑ direction (and of a first series).
pub const UP: RGBColor = RGBColor(31, 119, 180);
/// Colour of the ↓ direction (and of a second series).
pub const DOWN: RGBColor = RGBColor(214, 39, 40);
/// Colour of means and profiles.
pub const MEAN: RGBColor = RGBColor(40, 40, 40);
/// Colour of zones and tolerance bands.
pub const ZONE: RGBColor = RGBColor(44, 160, 44);
/// Colours of roll, pitch, yaw (rotations about x, y, z).
pub const RPY: [RGBColor; 3] = [
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];
/// Six distinct series colours: x, y, z translations then rotations.
pub const SIX: [RGBColor; 6] = [UP, DOWN, ZONE, RPY[0], RPY[1], RPY[2]];

/// Font family of every plot.
pub const FONT: &str = "sans-serif";

/// The drawing area a plot draws on.
pub type Area<'b> = DrawingArea<SVGBackend<'b>, Shift>;

/// A line plot's chart: caption, axes, light grid, f64 coordinates.
pub type LineChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// `(lo, hi)` of the finite values padded by 8 % (at least `min_half` around
/// the centre); `(-min_half, min_half)` when there is none.
pub fn padded(values: impl Iterator<Item = f64>, min_half: f64) -> (f64, f64) {
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
pub fn with_legend_room((lo, hi): (f64, f64)) -> (f64, f64) {
    (lo, hi + 0.35 * (hi - lo))
}

/// Build a line plot's chart on `root`: caption `title`, ranges, axis labels,
/// light grid.
pub fn line_chart<'a, 'b>(
    root: &'a Area<'b>,
    title: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    x_desc: &str,
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
        .x_desc(x_desc)
        .y_desc(y_desc)
        .light_line_style(RGBColor(240, 240, 240))
        .max_light_lines(2)
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(chart)
}

/// Draw a line plot's legend in its upper left corner.
pub fn legend<'a, 'b: 'a>(chart: &mut LineChart<'a, 'b>) -> std::result::Result<(), String> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .label_font((FONT, 13))
        .draw()
        .map_err(|e| e.to_string())
}

/// Draw into a fresh white SVG of `size` with `draw`; errors carry `title`.
pub fn svg(
    title: &str,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> std::result::Result<(), String>,
) -> Result<String> {
    let error = |e: &dyn std::fmt::Display| ReportError::Plot {
        plot: title.to_string(),
        message: e.to_string(),
    };
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| error(&e))?;
        draw(&root).map_err(|e| error(&e))?;
        root.present().map_err(|e| error(&e))?;
    }
    Ok(out)
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

/// A vertical colour bar of the [`diverging`] scale on `bar` (a strip about
/// 130 px wide beside a map): `±limit` at its ends, labelled with `unit`,
/// two lines of `caption` above it.
pub fn colour_bar(
    bar: &Area<'_>,
    height: u32,
    limit: f64,
    unit: &str,
    caption: [&str; 2],
) -> std::result::Result<(), String> {
    let steps = 40;
    let (top, height) = (60, height as i32 - 140);
    for k in 0..steps {
        let t = 1.0 - 2.0 * f64::from(k) / f64::from(steps - 1);
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
        (format!("{limit:+.2} {unit}"), top),
        ("0".to_string(), top + height / 2),
        (format!("{:+.2} {unit}", -limit), top + height),
    ] {
        bar.draw_text(&text, &style, (50, y - 6))
            .map_err(|e| e.to_string())?;
    }
    for (k, line) in caption.iter().enumerate() {
        bar.draw_text(line, &style, (6, top - 40 + 16 * k as i32))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
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

    #[test]
    fn svg_draws_a_chart() {
        let out = svg("t", (WIDTH, HEIGHT), |root| {
            let mut c = line_chart(root, "t", (0.0, 1.0), (0.0, 1.0), "x", "y")?;
            c.draw_series(LineSeries::new([(0.0, 0.0), (1.0, 1.0)], UP))
                .map_err(|e| e.to_string())?
                .label("s");
            legend(&mut c)
        })
        .unwrap_or_default();
        assert!(out.starts_with("<svg") && out.contains("<polyline"));
    }
}
