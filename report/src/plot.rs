//! SVG plots in memory (plotters' SVG backend): the chart set-up every line
//! plot shares, its legend, padded ranges, the report's colours and text
//! sizes, a diverging colour scale for maps with a scale robust to outliers,
//! and the texts of a drawn SVG as a reader sees them (for checks).
//!
//! Text sizes: plotters' SVG backend writes a font of size `s` as
//! `s / 1.24` px, so every size here is at least 13.64 — every text of
//! every plot is at least [`MIN_TEXT_PX`] = 11 px, readable at 100 % zoom.

use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::element::ComposedElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

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
/// The smallest text any plot draws (px): readable at 100 % zoom.
pub const MIN_TEXT_PX: f64 = 11.0;
/// plotters' SVG backend draws a font of size `s` at `s / SVG_FONT_DIVISOR` px.
const SVG_FONT_DIVISOR: f64 = 1.24;
/// Size of tick labels, legends, colour-bar labels and notes (12.1 px).
pub const TEXT_SIZE: f64 = 15.0;
/// Size of axis titles (12.9 px).
pub const AXIS_TITLE_SIZE: f64 = 16.0;
/// Size of a plot's caption (16.1 px).
pub const CAPTION_SIZE: f64 = 20.0;
/// A colour-scale value beyond this many times the 90th percentile of the
/// absolute values is an outlier ([`robust_limit`]): normally distributed
/// values stay inside (the 90th percentile of |v| is 1.64σ, the fence
/// 6.6σ), as does the tail of noise amplified where a method is weakly
/// determined (the indexing ΔθB at small A reaches 3.5 × it).
pub const OUTLIER_FENCE: f64 = 4.0;
/// Fill of the marks of values beyond a colour scale ([`outlier_mark`]).
pub const OUTLIER: RGBColor = RGBColor(0, 0, 0);

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

/// The px size of a text drawn at plotters' size `size` in the SVG.
pub fn text_px(size: f64) -> f64 {
    size / SVG_FONT_DIVISOR
}

/// The style of labels and notes drawn outside a chart's mesh (black,
/// [`TEXT_SIZE`]).
pub fn text_style() -> TextStyle<'static> {
    (FONT, TEXT_SIZE).into_font().color(&BLACK)
}

/// A line chart's chart on `root` with the report's caption and room for
/// the tick labels and axis titles.
pub fn chart_builder<'a, 'b>(
    root: &'a Area<'b>,
    title: &str,
) -> ChartBuilder<'a, 'b, SVGBackend<'b>> {
    let mut builder = ChartBuilder::on(root);
    builder
        .caption(title, (FONT, CAPTION_SIZE))
        .margin(12)
        .x_label_area_size(50)
        .y_label_area_size(76);
    builder
}

/// The mesh of a line chart with the report's text sizes and light grid;
/// the caller adds its axis titles and draws it.
pub fn mesh<'a, 'm, 'b>(
    chart: &'m mut LineChart<'a, 'b>,
) -> MeshStyle<'a, 'm, RangedCoordf64, RangedCoordf64, SVGBackend<'b>> {
    let mut mesh = chart.configure_mesh();
    mesh.label_style((FONT, TEXT_SIZE))
        .axis_desc_style((FONT, AXIS_TITLE_SIZE))
        .light_line_style(RGBColor(240, 240, 240));
    mesh
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
    chart_with_mesh(root, title, (x0, x1), (y0, y1), (x_desc, y_desc), None)
}

/// The chart of [`line_chart`], its mesh drawn with `x_labels` labels on
/// the x axis (plotters' choice when `None`).
fn chart_with_mesh<'a, 'b>(
    root: &'a Area<'b>,
    title: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    (x_desc, y_desc): (&str, &str),
    x_labels: Option<usize>,
) -> std::result::Result<LineChart<'a, 'b>, String> {
    let mut chart = chart_builder(root, title)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    let mut style = mesh(&mut chart);
    style.x_desc(x_desc).y_desc(y_desc).max_light_lines(2);
    if let Some(n) = x_labels {
        style.x_labels(n);
    }
    style.draw().map_err(|e| e.to_string())?;
    Ok(chart)
}

/// At most this many ticks on an angle axis ([`angle_ticks`]).
pub const MAX_ANGLE_TICKS: usize = 13;

/// Ticks of an angle axis at the data's step (°): the lattice `a₀ + k·g`
/// through the distinct `angles_deg` (`g` their smallest gap, every angle on
/// it within 1e-6°) over `range`, every m-th tick with the smallest m of
/// 1, 2, 3, 4, 5, 6, … (divisors of 360) that leaves at most
/// [`MAX_ANGLE_TICKS`]: 30° steps are ticked every 30°, 5° steps every 30°.
/// `None` when the angles lie on no lattice (fewer than two, or uneven).
pub fn angle_ticks(angles_deg: &[f64], (x0, x1): (f64, f64)) -> Option<Vec<f64>> {
    const TOLERANCE_DEG: f64 = 1e-6;
    const MULTIPLES: [f64; 24] = [
        1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 9.0, 10.0, 12.0, 15.0, 18.0, 20.0, 24.0, 30.0, 36.0,
        40.0, 45.0, 60.0, 72.0, 90.0, 120.0, 180.0, 360.0,
    ];
    let mut sorted: Vec<f64> = angles_deg
        .iter()
        .copied()
        .filter(|a| a.is_finite())
        .collect();
    sorted.sort_by(f64::total_cmp);
    sorted.dedup_by(|a, b| (*a - *b).abs() < TOLERANCE_DEG);
    let first = *sorted.first()?;
    let gap = sorted
        .windows(2)
        .map(|w| w[1] - w[0])
        .min_by(f64::total_cmp)?;
    let on_lattice = |a: f64, step: f64| {
        let k = ((a - first) / step).round();
        (first + k * step - a).abs() < TOLERANCE_DEG
    };
    let ordered = x0 < x1;
    if !ordered || !sorted.iter().all(|&a| on_lattice(a, gap)) {
        return None;
    }
    MULTIPLES.iter().find_map(|m| {
        let step = gap * m;
        let k0 = ((x0 - first) / step - TOLERANCE_DEG).ceil();
        let k1 = ((x1 - first) / step + TOLERANCE_DEG).floor();
        let n = k1 - k0 + 1.0;
        (n >= 1.0 && n <= MAX_ANGLE_TICKS as f64).then(|| {
            (0..n as usize)
                .map(|k| first + (k0 + k as f64) * step)
                .collect()
        })
    })
}

/// [`line_chart`] with the x axis labelled and gridded at `x_ticks` (an
/// angle axis at its data's step, [`angle_ticks`]) instead of plotters'
/// round numbers; an empty `x_ticks` is [`line_chart`].
pub fn line_chart_ticked<'a, 'b>(
    root: &'a Area<'b>,
    title: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    (x_desc, y_desc): (&str, &str),
    x_ticks: &[f64],
) -> std::result::Result<LineChart<'a, 'b>, String> {
    if x_ticks.is_empty() {
        return line_chart(root, title, (x0, x1), (y0, y1), x_desc, y_desc);
    }
    let mut chart = chart_with_mesh(root, title, (x0, x1), (y0, y1), (x_desc, y_desc), Some(0))?;
    chart
        .draw_series(
            x_ticks
                .iter()
                .map(|&t| PathElement::new(vec![(t, y0), (t, y1)], BLACK.mix(0.2).stroke_width(1))),
        )
        .map_err(|e| e.to_string())?;
    let (bx, by) = root.get_base_pixel();
    let label = text_style().pos(Pos::new(HPos::Center, VPos::Top));
    for &t in x_ticks {
        let (px, py) = chart.backend_coord(&(t, y0));
        let (x, y) = (px - bx, py - by);
        root.draw(&PathElement::new(vec![(x, y), (x, y + 5)], BLACK))
            .map_err(|e| e.to_string())?;
        let text = if t.fract() == 0.0 {
            format!("{t:.0}")
        } else {
            format!("{t}")
        };
        root.draw(&Text::new(text, (x, y + 8), label.clone()))
            .map_err(|e| e.to_string())?;
    }
    Ok(chart)
}

/// Draw a line plot's legend in its upper left corner.
pub fn legend<'a, 'b: 'a>(chart: &mut LineChart<'a, 'b>) -> std::result::Result<(), String> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .label_font((FONT, TEXT_SIZE))
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
    let style = text_style();
    for (text, y) in [
        (format!("{limit:+.2} {unit}"), top),
        ("0".to_string(), top + height / 2),
        (format!("{:+.2} {unit}", -limit), top + height),
    ] {
        bar.draw_text(&text, &style, (50, y - 6))
            .map_err(|e| e.to_string())?;
    }
    for (k, line) in caption.iter().enumerate() {
        bar.draw_text(line, &style, (6, top - 42 + 18 * k as i32))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Percentile `q` (0…1) of ascending `sorted` values, by linear
/// interpolation between order statistics; 0 when there is none.
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let x = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x.fract());
    let j = (i + 1).min(sorted.len() - 1);
    sorted[i] * (1.0 - f) + sorted[j] * f
}

/// The half-range L of a diverging colour scale ±L over `values`, robust
/// to outliers: the largest |v| within [`OUTLIER_FENCE`] × the 90th
/// [`percentile`] of |v|. A few extreme values leave the 90th percentile,
/// and so the scale of the others, as it is; they are drawn at the scale's
/// end and marked ([`outlier_mark`], [`outlier_key`]). Without outliers L
/// is max |v|; 0 without finite values.
pub fn robust_limit(values: impl Iterator<Item = f64>) -> f64 {
    let mut magnitudes: Vec<f64> = values.filter(|v| v.is_finite()).map(f64::abs).collect();
    magnitudes.sort_by(f64::total_cmp);
    let fence = OUTLIER_FENCE * percentile(&magnitudes, 0.9);
    magnitudes
        .iter()
        .rev()
        .find(|v| **v <= fence)
        .copied()
        .unwrap_or(0.0)
}

/// A triangle of half-size `r` (px offsets around its place) pointing up
/// or down.
fn triangle(up: bool, r: i32) -> Vec<(i32, i32)> {
    let s = if up { 1 } else { -1 };
    vec![(0, -s * r), (r, s * r), (-r, s * r)]
}

/// A triangle drawn at pixel offsets from its place.
type Triangle = Polygon<(i32, i32)>;

/// A mark of a value beyond a colour scale (a triangle in a halo) at a `C`.
pub type OutlierMark<'b, C> = ComposedElement<C, SVGBackend<'b>, Triangle, Triangle>;

/// The mark of a value beyond a colour scale, at `at`: a black triangle in
/// a white halo pointing up (above +L) or down (below −L).
pub fn outlier_mark<'b, C>(at: C, above: bool) -> OutlierMark<'b, C> {
    EmptyElement::at(at)
        + Polygon::new(triangle(above, 8), WHITE.filled())
        + Polygon::new(triangle(above, 5), OUTLIER.filled())
}

/// The key of the outlier marks under a [`colour_bar`] of `height`: a mark
/// and how many values lie beyond the scale, for each side that has any.
pub fn outlier_key(
    bar: &Area<'_>,
    height: u32,
    limit: f64,
    unit: &str,
    (above, below): (usize, usize),
) -> std::result::Result<(), String> {
    let style = text_style();
    let mut y = height as i32 - 66;
    for (count, is_above, sign) in [(above, true, '+'), (below, false, '−')] {
        if count == 0 {
            continue;
        }
        bar.draw(&outlier_mark((14, y + 7), is_above))
            .map_err(|e| e.to_string())?;
        bar.draw_text(&format!("{count} beyond"), &style, (26, y))
            .map_err(|e| e.to_string())?;
        bar.draw_text(&format!("{sign}{limit:.2} {unit}"), &style, (26, y + 16))
            .map_err(|e| e.to_string())?;
        y += 34;
    }
    Ok(())
}

/// A text of a drawn SVG as a reader sees it: its content, size and the box
/// it covers (for checks that text is readable and does not overlap).
#[derive(Debug, Clone, PartialEq)]
pub struct SvgText {
    /// The text, entities decoded.
    pub text: String,
    /// Font size (px).
    pub size_px: f64,
    /// `[left, top, right, bottom]` (px); the width by [`text_width`].
    pub bounds: [f64; 4],
}

impl SvgText {
    /// Whether the boxes of two texts overlap.
    pub fn overlaps(&self, other: &SvgText) -> bool {
        let (a, b) = (self.bounds, other.bounds);
        a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
    }
}

/// Every text under [`MIN_TEXT_PX`] in the plots of a report `page` (as
/// `plot id: "text" at N px`), after the number of plots it has.
pub fn small_texts(page: &str) -> (usize, Vec<String>) {
    let plots = crate::figures(page);
    let small = plots
        .iter()
        .flat_map(|(id, svg)| {
            svg_texts(svg)
                .into_iter()
                .filter(|t| t.size_px < MIN_TEXT_PX)
                .map(move |t| format!("{id}: {:?} at {:.2} px", t.text, t.size_px))
        })
        .collect();
    (plots.len(), small)
}

/// The width (px) a sans-serif `text` of `px` takes, estimated generously
/// (0.62 em a character: DejaVu Sans digits are 0.64 em, most letters
/// narrower).
pub fn text_width(text: &str, px: f64) -> f64 {
    0.62 * px * text.chars().count() as f64
}

/// The value of attribute `name` in an element's opening tag.
fn attribute<'t>(tag: &'t str, name: &str) -> Option<&'t str> {
    let key = format!(" {name}=\"");
    let start = tag.find(&key)? + key.len();
    let len = tag[start..].find('"')?;
    Some(&tag[start..start + len])
}

/// The non-empty `<text>` elements of an SVG written by plotters' SVG
/// backend: anchored at x by `text-anchor`, at y by `dy` (`0.76em`: top,
/// `0.5ex`: middle, none: baseline), rotated ones upright in their box.
pub fn svg_texts(svg: &str) -> Vec<SvgText> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(open) = rest.find("<text") {
        rest = &rest[open..];
        let (Some(tag_end), Some(close)) = (rest.find('>'), rest.find("</text>")) else {
            break;
        };
        let tag = &rest[..tag_end];
        let text = rest[tag_end + 1..close]
            .trim()
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&#39;", "'")
            .replace("&amp;", "&");
        rest = &rest[close..];
        let number = |name: &str| attribute(tag, name).and_then(|v| v.parse::<f64>().ok());
        let (Some(x), Some(y), Some(size_px)) = (number("x"), number("y"), number("font-size"))
        else {
            continue;
        };
        if text.is_empty() {
            continue;
        }
        let width = text_width(&text, size_px);
        let left = match attribute(tag, "text-anchor") {
            Some("middle") => x - width / 2.0,
            Some("end") => x - width,
            _ => x,
        };
        let top = match attribute(tag, "dy") {
            Some("0.76em") => y,
            Some("0.5ex") => y - size_px / 2.0,
            _ => y - 0.8 * size_px,
        };
        let bounds = if attribute(tag, "transform").is_some_and(|t| t.starts_with("rotate")) {
            let (cx, cy) = (left + width / 2.0 - x, top + size_px / 2.0 - y);
            // Turned by ±90° about (x, y): the box's centre turns, its sides swap.
            let (cx, cy) = (x - cy, y + cx);
            [
                cx - size_px / 2.0,
                cy - width / 2.0,
                cx + size_px / 2.0,
                cy + width / 2.0,
            ]
        } else {
            [left, top, left + width, top + size_px]
        };
        out.push(SvgText {
            text,
            size_px,
            bounds,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn angle_axes_are_ticked_at_the_data_step() {
        let every = |step: f64| -> Vec<f64> {
            (0..)
                .map(|k| step * f64::from(k))
                .take_while(|a| *a < 360.0)
                .collect()
        };
        // 30° steps over the turn: every 30° (plotters' own ticks were every 50°).
        assert_eq!(
            super::angle_ticks(&every(30.0), (0.0, 360.0)),
            Some(every(30.0).into_iter().chain([360.0]).collect())
        );
        // 5° steps: every sixth, 30°.
        let ticks = super::angle_ticks(&every(5.0), (0.0, 360.0)).unwrap();
        assert_eq!(ticks[1] - ticks[0], 30.0);
        // A lattice through 15°: 15, 45, …; uneven angles: none.
        assert_eq!(
            super::angle_ticks(&[15.0, 45.0, 75.0], (0.0, 100.0)),
            Some(vec![15.0, 45.0, 75.0])
        );
        assert_eq!(super::angle_ticks(&[0.0, 30.0, 50.0], (0.0, 60.0)), None);
        assert_eq!(super::angle_ticks(&[10.0], (0.0, 60.0)), None);
    }

    #[test]
    fn ticked_charts_label_their_ticks() {
        let ticks: Vec<f64> = (0..=12).map(|k| 30.0 * f64::from(k)).collect();
        let svg = super::svg("t", (super::WIDTH, super::HEIGHT), |root| {
            super::line_chart_ticked(root, "t", (0.0, 360.0), (-1.0, 1.0), ("θ (°)", "e"), &ticks)
                .map(|_| ())
        })
        .unwrap();
        let texts: Vec<String> = super::svg_texts(&svg).into_iter().map(|t| t.text).collect();
        for label in ["30", "90", "330", "360"] {
            assert!(
                texts.iter().any(|t| t == label),
                "no tick {label}: {texts:?}"
            );
        }
        assert!(!texts.iter().any(|t| t == "50"), "{texts:?}");
    }

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
    fn texts_are_read_with_their_boxes() {
        let svg = "<svg><text x=\"100\" y=\"20\" dy=\"0.76em\" text-anchor=\"middle\" \
                   font-family=\"sans-serif\" font-size=\"10\" fill=\"#000\">\nab&lt;c\n</text>\
                   <text x=\"5\" y=\"50\" font-size=\"12\">\n\n</text></svg>";
        let t = svg_texts(svg);
        assert_eq!(t.len(), 1, "the empty text is left out");
        assert_eq!(t[0].text, "ab<c");
        assert_eq!(t[0].size_px, 10.0);
        let w = text_width("ab<c", 10.0);
        let want = [100.0 - w / 2.0, 20.0, 100.0 + w / 2.0, 30.0];
        assert!(
            t[0].bounds
                .iter()
                .zip(want)
                .all(|(a, b)| (a - b).abs() < 1e-9),
            "{:?}",
            t[0].bounds
        );
    }

    /// Every text of a line plot with a legend and of a colour bar with an
    /// outlier key is at least 11 px.
    #[test]
    fn every_text_is_readable() {
        let out = svg("t", (WIDTH, MAP_HEIGHT), |root| {
            let (plot, bar) = root.split_horizontally(WIDTH - 130);
            let mut c = line_chart(&plot, "title", (0.0, 1.0), (0.0, 1.0), "x (mm)", "y (µm)")?;
            c.draw_series(LineSeries::new([(0.0, 0.0), (1.0, 1.0)], UP))
                .map_err(|e| e.to_string())?
                .label("series")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], UP));
            legend(&mut c)?;
            colour_bar(&bar, MAP_HEIGHT, 2.0, "µm", ["deviation", "(µm)"])?;
            outlier_key(&bar, MAP_HEIGHT, 2.0, "µm", (1, 2))
        })
        .unwrap_or_default();
        let texts = svg_texts(&out);
        for needed in [
            "title",
            "x (mm)",
            "y (µm)",
            "series",
            "deviation",
            "2 beyond",
            "0.0",
        ] {
            assert!(texts.iter().any(|t| t.text == needed), "{needed} missing");
        }
        for t in &texts {
            assert!(t.size_px >= MIN_TEXT_PX, "{:?}: {} px", t.text, t.size_px);
        }
    }

    #[test]
    fn one_outlier_leaves_the_scale_of_the_others() {
        let rest: Vec<f64> = (0..40).map(|k| (f64::from(k) * 0.7).sin() * 1.5).collect();
        let max = rest.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert_eq!(robust_limit(rest.iter().copied()), max);
        for outlier in [1e3, -50.0, 10.0 * max] {
            let with: Vec<f64> = rest.iter().copied().chain([outlier]).collect();
            assert_eq!(robust_limit(with.into_iter()), max, "{outlier}");
        }
        // A value inside the fence is no outlier: the scale reaches it.
        let near = 2.0 * max;
        assert_eq!(robust_limit(rest.iter().copied().chain([near])), near);
        assert_eq!(robust_limit(std::iter::empty()), 0.0);
        assert_eq!(percentile(&[1.0, 2.0, 3.0, 4.0], 0.5), 2.5);
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
