//! SVG plots of the volumetric report (plotters through `report::plot`): each
//! error curve with both fits, the predicted circular test as a polar plot
//! with the deviation magnified, and the radial deviation against the angle.

use plotters::prelude::*;
use report::plot::{
    CAPTION_SIZE, DOWN, FONT, HEIGHT, MAP_HEIGHT, MEAN, UP, WIDTH, ZONE, angle_ticks, legend,
    line_chart, line_chart_ticked, mesh, padded, svg, text_style, with_legend_room,
};

use super::circle::CirclePrediction;
use super::curves::Motion;
use super::model::AxisModel;
use super::report::{Circles, unit};
use super::series::Series;
use crate::Result;

/// Samples drawn along a fitted series.
const SAMPLES: usize = 240;
/// The magnified deviation of the polar plot reaches at most this fraction of the radius.
pub(crate) const POLAR_REACH: f64 = 0.2;

/// The plotted unit's label.
pub(crate) fn unit_label(motion: Motion) -> &'static str {
    if motion.is_rotation() { "µrad" } else { "µm" }
}

/// One curve: measured points and the raw polyline, the Fourier series and the polynomial.
pub(crate) fn curve(title: &str, axis: &AxisModel, motion: Motion) -> Result<String> {
    let c = &axis.curves;
    let (_, scale) = unit(motion);
    let measured: Vec<(f64, f64)> = c
        .positions
        .iter()
        .zip(c.curve(motion))
        .map(|(&q, &v)| (q, v * scale))
        .collect();
    let (lo, hi) = c.travel();
    let sampled = |s: Series| -> Vec<(f64, f64)> {
        let fit = axis.fits[motion.index()].get(s);
        (0..=SAMPLES)
            .filter_map(|k| {
                let q = lo + (hi - lo) * k as f64 / SAMPLES as f64;
                fit.value(q.min(hi)).map(|v| (q, v * scale))
            })
            .collect()
    };
    let fourier = sampled(Series::Fourier);
    let polynomial = sampled(Series::Polynomial);
    let (x0, x1) = padded(c.positions.iter().copied(), 1.0);
    let ys = measured
        .iter()
        .chain(&fourier)
        .chain(&polynomial)
        .map(|p| p.1);
    let (y0, y1) = with_legend_room(padded(ys, 0.05));
    let f = axis.fits[motion.index()].get(Series::Fourier);
    let p = axis.fits[motion.index()].get(Series::Polynomial);
    let y_desc = format!("{} ({})", motion.symbol(axis.axis()), unit_label(motion));
    Ok(svg(title, (WIDTH, HEIGHT), |root| {
        let mut chart = line_chart(
            root,
            title,
            (x0, x1),
            (y0, y1),
            "carriage position q (mm)",
            &y_desc,
        )?;
        chart
            .draw_series(LineSeries::new(measured.clone(), MEAN.stroke_width(1)))
            .map_err(|e| e.to_string())?
            .label("measured (raw: linear between points)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MEAN));
        chart
            .draw_series(measured.iter().map(|&m| Circle::new(m, 3, MEAN.filled())))
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(LineSeries::new(fourier, UP.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(format!(
                "Fourier N = {} (RMSE {:.3})",
                f.order,
                f.figures.rmse * scale
            ))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], UP.stroke_width(2)));
        chart
            .draw_series(LineSeries::new(polynomial, DOWN.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(format!(
                "polynomial degree {} (RMSE {:.3})",
                2 * p.order,
                p.figures.rmse * scale
            ))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], DOWN.stroke_width(2)));
        legend(&mut chart)
    })?)
}

/// The magnification of the polar plot: a 1-2-5 step such that the largest
/// |radial deviation| reaches about [`POLAR_REACH`] of the radius.
pub(crate) fn magnification(radius_mm: f64, largest_mm: f64) -> f64 {
    if largest_mm.is_nan() || largest_mm <= 0.0 {
        return 1.0;
    }
    let raw = POLAR_REACH * radius_mm / largest_mm;
    let decade = 10f64.powf(raw.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|m| *m <= raw)
        .unwrap_or(decade)
}

/// The three predictions of a circle with their colours and names.
fn circle_series(c: &Circles) -> [(&CirclePrediction, RGBColor, &'static str); 3] {
    [
        (&c.predicted, UP, "predicted"),
        (&c.compensated_fourier, ZONE, "after Fourier compensation"),
        (
            &c.compensated_polynomial,
            DOWN,
            "after polynomial compensation",
        ),
    ]
}

/// The predicted circle as a polar plot: radius R + M·radial deviation, with
/// the nominal circle; predicted (blue), after Fourier (green) and polynomial
/// (red) compensation. Returns the SVG and the magnification M.
pub(crate) fn polar(title: &str, c: &Circles) -> Result<(String, f64)> {
    let r = c.spec.radius;
    let paths = circle_series(c);
    let largest = paths
        .iter()
        .flat_map(|(p, _, _)| p.points.iter().map(|q| q.radial.abs()))
        .fold(0.0, f64::max);
    let m = magnification(r, largest);
    let reach = r * (1.0 + 2.5 * POLAR_REACH);
    let svg_text = svg(title, (WIDTH, MAP_HEIGHT), |root| {
        let (plot, side) = root.split_horizontally(MAP_HEIGHT);
        let mut chart = ChartBuilder::on(&plot)
            .caption(title, (FONT, CAPTION_SIZE))
            .margin(12)
            .x_label_area_size(50)
            .y_label_area_size(50)
            .build_cartesian_2d(-reach..reach, -reach..reach)
            .map_err(|e| e.to_string())?;
        mesh(&mut chart)
            .max_light_lines(1)
            .x_labels(5)
            .y_labels(5)
            .x_desc("x − centre (mm)")
            .y_desc("y − centre (mm)")
            .draw()
            .map_err(|e| e.to_string())?;
        let ring = |radius: &dyn Fn(usize) -> f64| -> Vec<(f64, f64)> {
            (0..=360)
                .map(|d| {
                    let t = (d as f64).to_radians();
                    let rr = radius(d % 360);
                    (rr * t.cos(), rr * t.sin())
                })
                .collect()
        };
        chart
            .draw_series(DashedLineSeries::new(
                ring(&|_| r),
                6,
                4,
                MEAN.stroke_width(1),
            ))
            .map_err(|e| e.to_string())?;
        for (p, colour, _) in paths {
            let path = ring(&|d| r + m * p.points.get(d).map_or(0.0, |q| q.radial));
            chart
                .draw_series(LineSeries::new(path, colour.stroke_width(2)))
                .map_err(|e| e.to_string())?;
        }
        let style = text_style();
        let lines = [
            format!("circle R = {r} mm"),
            format!("deviation magnified × {m}"),
            format!("(1 µm drawn as {:.3} mm)", m * 1e-3),
            String::new(),
        ];
        for (k, l) in lines.iter().enumerate() {
            side.draw_text(l, &style, (10, 40 + 22 * k as i32))
                .map_err(|e| e.to_string())?;
        }
        let mut y = 40 + 22 * lines.len() as i32;
        for (p, colour, name) in paths {
            side.draw(&PathElement::new(
                vec![(10, y + 8), (34, y + 8)],
                colour.stroke_width(3),
            ))
            .map_err(|e| e.to_string())?;
            side.draw_text(name, &style, (42, y))
                .map_err(|e| e.to_string())?;
            for (k, line) in [
                format!("circular deviation {:.2} µm,", p.circular_deviation * 1e3),
                format!("radial range {:.2} µm", p.radial_range * 1e3),
            ]
            .iter()
            .enumerate()
            {
                side.draw_text(line, &style, (42, y + 20 + 17 * k as i32))
                    .map_err(|e| e.to_string())?;
            }
            y += 68;
        }
        side.draw(&PathElement::new(
            vec![(10, y + 8), (34, y + 8)],
            MEAN.stroke_width(1),
        ))
        .map_err(|e| e.to_string())?;
        side.draw_text("nominal circle", &style, (42, y))
            .map_err(|e| e.to_string())?;
        Ok(())
    })?;
    Ok((svg_text, m))
}

/// Radial deviation against the angle: predicted and after each compensation.
pub(crate) fn radial(title: &str, c: &Circles) -> Result<String> {
    let series = circle_series(c);
    let ys = series
        .iter()
        .flat_map(|(p, _, _)| p.points.iter().map(|q| q.radial * 1e3));
    let (y0, y1) = with_legend_room(padded(ys, 0.05));
    // Ticked at the angles' step.
    let angles: Vec<f64> = series
        .iter()
        .flat_map(|(p, _, _)| p.points.iter().map(|q| q.angle_deg))
        .collect();
    let ticks = angle_ticks(&angles, (0.0, 360.0)).unwrap_or_default();
    Ok(svg(title, (WIDTH, HEIGHT), |root| {
        let mut chart = line_chart_ticked(
            root,
            title,
            (0.0, 360.0),
            (y0, y1),
            ("angle θ (°)", "radial deviation (µm)"),
            &ticks,
        )?;
        for (p, colour, name) in series {
            let pts: Vec<(f64, f64)> = p
                .points
                .iter()
                .map(|q| (q.angle_deg, q.radial * 1e3))
                .collect();
            chart
                .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
        }
        legend(&mut chart)
    })?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn magnification_is_a_round_step() {
        // 15 µm on a 100 mm circle: 0.2·100/0.015 = 1333 → 1000.
        assert_eq!(magnification(100.0, 0.015), 1000.0);
        assert_eq!(magnification(100.0, 0.0035), 5000.0);
        assert_eq!(magnification(100.0, 0.0), 1.0);
    }
}
