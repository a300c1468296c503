//! The tracer's 3-D views of the grid: plotters' 3-D chart of the grid's box
//! (machine x across, z up, y in depth) draws its back panels and grid;
//! drawn here on its projection: the tick labels and the axis titles with
//! units along the three front edges of the box, outside it, each label
//! left out where it would overlap one already placed or leave the plot;
//! and arrows with heads.

use plotters::coord::cartesian::Cartesian3d;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use report::plot::{
    AXIS_TITLE_SIZE, Area, CAPTION_SIZE, FONT, TEXT_SIZE, text_px, text_style, text_width,
};

/// A 3-D chart of the grid in plotters' order: machine x, z (up), y (depth).
pub(crate) type GridChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian3d<RangedCoordf64, RangedCoordf64, RangedCoordf64>>;

/// Most tick labels per axis.
const TICKS: usize = 6;
/// The view's turn about the vertical (rad).
const YAW: f64 = 0.6;
/// The view's tilt (rad).
const PITCH: f64 = 0.35;
/// The box's size in the plot, leaving room for the labels outside it.
const SCALE: f64 = 0.82;
/// Length of plotters' tick marks (px).
const TICK_PX: i32 = 6;
/// Gap between a tick and its label, and between labels and a title (px).
const GAP: f64 = 10.0;
/// Length of an arrow head (px); a shorter arrow's head is the arrow.
const HEAD_PX: f64 = 9.0;
/// An arrow head's half-width as a share of its length.
const HEAD_WIDTH: f64 = 0.45;
/// The axes' titles, machine x, y, z.
const TITLES: [&str; 3] = ["x (mm)", "y (mm)", "z (mm)"];

/// Screen position (px, relative to the area) of a machine point.
type Px = (f64, f64);

/// A machine point (x, y, z) in plotters' order (x, z, y).
fn plotted(p: [f64; 3]) -> (f64, f64, f64) {
    (p[0], p[2], p[1])
}

/// Where `chart` draws the machine point `p`, relative to `area`.
fn project(chart: &GridChart<'_, '_>, area: &Area<'_>, p: [f64; 3]) -> Px {
    let (u, v) = chart.as_coord_spec().translate(&plotted(p));
    let (bu, bv) = area.get_base_pixel();
    (f64::from(u - bu), f64::from(v - bv))
}

/// The 3-D chart of a grid spanning `ranges` (machine x, y, z; mm) on
/// `area`, with caption `title`: panels, grid, tick labels and axis titles.
pub(crate) fn grid_chart<'a, 'b>(
    area: &'a Area<'b>,
    title: &str,
    ranges: [(f64, f64); 3],
) -> Result<GridChart<'a, 'b>, String> {
    let [(x0, x1), (y0, y1), (z0, z1)] = ranges;
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, CAPTION_SIZE))
        .margin(16)
        .build_cartesian_3d(x0..x1, z0..z1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart.with_projection(|mut pb| {
        pb.yaw = YAW;
        pb.pitch = PITCH;
        pb.scale = SCALE;
        pb.into_matrix()
    });
    let blank = |_: &f64| String::new();
    chart
        .configure_axes()
        .light_grid_style(RGBColor(225, 225, 225))
        .max_light_lines(3)
        .x_labels(TICKS)
        .y_labels(TICKS)
        .z_labels(TICKS)
        .x_formatter(&blank)
        .y_formatter(&blank)
        .z_formatter(&blank)
        .tick_size(TICK_PX)
        .label_style((FONT, TEXT_SIZE))
        .draw()
        .map_err(|e| e.to_string())?;
    label_axes(&chart, area, ranges)?;
    Ok(chart)
}

/// The front edge of machine axis `axis` (its two ends): the lowest on the
/// screen for x and y, the leftmost for z — where plotters draws the axis.
fn front_edge(
    chart: &GridChart<'_, '_>,
    area: &Area<'_>,
    axis: usize,
    ranges: [(f64, f64); 3],
) -> ([f64; 3], [f64; 3]) {
    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
    let edges = [(0, 0), (0, 1), (1, 0), (1, 1)].map(|(i, j)| {
        let pick = |k: usize, end: usize| if end == 0 { ranges[k].0 } else { ranges[k].1 };
        let mut p = [0.0; 3];
        p[b] = pick(b, i);
        p[c] = pick(c, j);
        let (mut start, mut end) = (p, p);
        (start[axis], end[axis]) = ranges[axis];
        (start, end)
    });
    let midpoint = |(s, e): &([f64; 3], [f64; 3])| {
        let (ps, pe) = (project(chart, area, *s), project(chart, area, *e));
        ((ps.0 + pe.0) / 2.0, (ps.1 + pe.1) / 2.0)
    };
    let score = |e: &([f64; 3], [f64; 3])| {
        let m = midpoint(e);
        if axis == 2 { -m.0 } else { m.1 }
    };
    edges
        .into_iter()
        .max_by(|p, q| score(p).total_cmp(&score(q)))
        .unwrap_or(([0.0; 3], [0.0; 3]))
}

/// The box `[left, top, right, bottom]` of a text of `px` centred at `at`.
fn text_box(text: &str, px: f64, at: Px) -> [f64; 4] {
    let (w, h) = (text_width(text, px), px);
    [
        at.0 - w / 2.0,
        at.1 - h / 2.0,
        at.0 + w / 2.0,
        at.1 + h / 2.0,
    ]
}

/// How far the centre of a `w`×`h` box sits from its edge along the unit
/// direction `u`: its support distance.
fn support((w, h): (f64, f64), u: Px) -> f64 {
    u.0.abs() * w / 2.0 + u.1.abs() * h / 2.0
}

/// Texts placed so far on a view, none overlapping another or leaving the
/// area.
struct Placed {
    boxes: Vec<[f64; 4]>,
    area: [f64; 4],
}

impl Placed {
    /// Whether `b` lies inside the area and clear of every placed box;
    /// if so it is placed.
    fn take(&mut self, b: [f64; 4]) -> bool {
        let inside = b[0] >= self.area[0]
            && b[1] >= self.area[1]
            && b[2] <= self.area[2]
            && b[3] <= self.area[3];
        let clear = self
            .boxes
            .iter()
            .all(|o| b[2] <= o[0] || o[2] <= b[0] || b[3] <= o[1] || o[3] <= b[1]);
        if inside && clear {
            self.boxes.push(b);
        }
        inside && clear
    }
}

/// One axis's labels: the ticks' texts and the title, each with its place
/// on the screen.
struct AxisLabels {
    ticks: Vec<(String, Px)>,
    title: (&'static str, Px),
}

/// The labels of machine axis `axis` along its front edge: tick values at
/// plotters' grid lines, pushed outward from the box's centre.
fn axis_labels(
    chart: &GridChart<'_, '_>,
    area: &Area<'_>,
    axis: usize,
    ranges: [(f64, f64); 3],
) -> AxisLabels {
    let (start, end) = front_edge(chart, area, axis, ranges);
    let centre = project(chart, area, ranges.map(|(lo, hi)| (lo + hi) / 2.0));
    let (a, b) = (project(chart, area, start), project(chart, area, end));
    let mid = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
    let (dx, dy) = (mid.0 - centre.0, mid.1 - centre.1);
    let norm = dx.hypot(dy).max(1e-9);
    let outward = (dx / norm, dy / norm);
    let px = text_px(TEXT_SIZE);
    let (lo, hi) = ranges[axis];
    let ticks: Vec<(String, Px)> = RangedCoordf64::from(lo..hi)
        .key_points(TICKS)
        .into_iter()
        .map(|t| {
            let mut p = start;
            p[axis] = t;
            let at = project(chart, area, p);
            let text = format!("{t:.0}");
            let d = GAP + support((text_width(&text, px), px), outward);
            (text, (at.0 + outward.0 * d, at.1 + outward.1 * d))
        })
        .collect();
    let reach = ticks
        .iter()
        .map(|(t, _)| support((text_width(t, px), px), outward) * 2.0)
        .fold(0.0, f64::max);
    let title = TITLES[axis];
    let title_px = text_px(AXIS_TITLE_SIZE);
    let d = GAP + reach + GAP / 2.0 + support((text_width(title, title_px), title_px), outward);
    AxisLabels {
        ticks,
        title: (title, (mid.0 + outward.0 * d, mid.1 + outward.1 * d)),
    }
}

/// Draw the tick labels and axis titles of the three axes: titles first,
/// then the labels that fit.
fn label_axes(
    chart: &GridChart<'_, '_>,
    area: &Area<'_>,
    ranges: [(f64, f64); 3],
) -> Result<(), String> {
    let (w, h) = area.dim_in_pixel();
    let mut placed = Placed {
        boxes: Vec::new(),
        area: [0.0, 0.0, f64::from(w), f64::from(h)],
    };
    let centred = Pos::new(HPos::Center, VPos::Center);
    let labels: Vec<AxisLabels> = (0..3)
        .map(|a| axis_labels(chart, area, a, ranges))
        .collect();
    let draw = |text: &str, style: &TextStyle<'_>, at: Px| {
        area.draw_text(text, style, (at.0.round() as i32, at.1.round() as i32))
            .map_err(|e| e.to_string())
    };
    let title_style = (FONT, AXIS_TITLE_SIZE)
        .into_font()
        .color(&BLACK)
        .pos(centred);
    for l in &labels {
        let (title, at) = l.title;
        placed.take(text_box(title, text_px(AXIS_TITLE_SIZE), at));
        draw(title, &title_style, at)?;
    }
    let style = text_style().pos(centred);
    for l in &labels {
        for (text, at) in &l.ticks {
            if placed.take(text_box(text, text_px(TEXT_SIZE), *at)) {
                draw(text, &style, *at)?;
            }
        }
    }
    Ok(())
}

/// Arrows from each machine point to its pair's second point: the shaft
/// in the chart and a filled head of [`HEAD_PX`] at the tip on the screen
/// (an arrow shorter than that is all head); none for a zero arrow.
pub(crate) fn arrows(
    chart: &mut GridChart<'_, '_>,
    area: &Area<'_>,
    ends: impl Iterator<Item = ([f64; 3], [f64; 3])>,
    colour: RGBColor,
) -> Result<(), String> {
    let ends: Vec<([f64; 3], [f64; 3])> = ends.collect();
    chart
        .draw_series(
            ends.iter().map(|(p, q)| {
                PathElement::new(vec![plotted(*p), plotted(*q)], colour.stroke_width(2))
            }),
        )
        .map_err(|e| e.to_string())?;
    for (p, q) in &ends {
        let (from, tip) = (project(chart, area, *p), project(chart, area, *q));
        let (dx, dy) = (tip.0 - from.0, tip.1 - from.1);
        let length = dx.hypot(dy);
        if length == 0.0 {
            continue;
        }
        let (ux, uy) = (dx / length, dy / length);
        let head = HEAD_PX.min(length);
        let half = HEAD_WIDTH * head;
        let base = (tip.0 - ux * head, tip.1 - uy * head);
        let corner = |s: f64| {
            (
                (base.0 - uy * half * s).round() as i32,
                (base.1 + ux * half * s).round() as i32,
            )
        };
        let tip = (tip.0.round() as i32, tip.1.round() as i32);
        area.draw(&Polygon::new(
            vec![tip, corner(1.0), corner(-1.0)],
            colour.filled(),
        ))
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}
