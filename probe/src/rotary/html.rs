//! `report.html` of the rotary method: one self-contained page (inline CSS
//! and SVG, no scripts) for the person who signs off a rotary axis — the
//! sign-off figures first (location errors, ranges), then the six errors
//! against the angle (translations in µm, rotations in µrad), the axis
//! average line, the component errors and the tables.

use std::fmt::Write;

use report::plot::SIX;
use report::{Page, escape, plus_minus};

use super::NAMES;
use super::plot::{self, Path, Series};
use super::report::{AngleReport, Report, Six};
use crate::Result;

/// Units of the six errors in the report.
const UNITS: [&str; 6] = ["µm", "µm", "µm", "µrad", "µrad", "µrad"];
/// What each error is, for the tables.
const MEANING: [&str; 6] = [
    "radial, x (δx)",
    "radial, y (δy)",
    "axial (δz)",
    "tilt about x (εx)",
    "tilt about y (εy)",
    "angular positioning (εz)",
];

/// A table whose first `left` columns are left-aligned text and whose
/// cells do not wrap (figures with their uncertainties stay on one line).
fn table<S: AsRef<str>>(h: &mut Page, id: &str, header: &[&str], rows: &[Vec<S>], left: usize) {
    let class = |k: usize| if k < left { " class=\"l\"" } else { "" };
    let _ = write!(h, "<table id=\"{}\">\n<tr>", escape(id));
    for (k, c) in header.iter().enumerate() {
        let _ = write!(h, "<th{}>{}</th>", class(k), escape(c));
    }
    h.raw("</tr>\n");
    for row in rows {
        h.raw("<tr>");
        for (k, c) in row.iter().enumerate() {
            let _ = write!(
                h,
                "<td{} style=\"white-space:nowrap\">{}</td>",
                class(k),
                escape(c.as_ref())
            );
        }
        h.raw("</tr>\n");
    }
    h.raw("</table>\n");
}

/// Column `k` of the errors of every angle.
fn column(rows: &[AngleReport], k: usize) -> Vec<f64> {
    rows.iter().map(|r| r.errors.values()[k]).collect()
}

/// Column `k` of the uncertainties (zero where absent).
fn u_column(rows: &[AngleReport], k: usize) -> Vec<f64> {
    rows.iter()
        .map(|r| {
            r.uncertainty.map_or(0.0, |u| {
                [
                    u.exc_um, u.eyc_um, u.ezc_um, u.eac_urad, u.ebc_urad, u.ecc_urad,
                ][k]
            })
        })
        .collect()
}

/// The two plots (translations, rotations) of a set of rows.
fn angle_plots(
    h: &mut Page,
    id: &str,
    what: &str,
    rows: &[AngleReport],
    ranges: &Six,
    with_u: bool,
    caption: &str,
) -> Result<()> {
    let angles: Vec<f64> = rows.iter().map(|r| r.angle_deg).collect();
    let values: Vec<Vec<f64>> = (0..6).map(|k| column(rows, k)).collect();
    let us: Vec<Vec<f64>> = (0..6).map(|k| u_column(rows, k)).collect();
    let range = ranges.values();
    for (part, ks, unit) in [("translations", 0..3, "µm"), ("rotations", 3..6, "µrad")] {
        let series: Vec<Series<'_>> = ks
            .map(|k| Series {
                label: format!("{} (range {:.3} {unit})", NAMES[k], range[k]),
                values: &values[k],
                u: with_u.then_some(us[k].as_slice()),
                colour: SIX[k],
            })
            .collect();
        let title = format!("{what}: {part} ({unit})");
        let svg = plot::against_angle(&title, &format!("{part} ({unit})"), &angles, &series)?;
        h.figure(&format!("plot-{id}-{part}"), &svg, caption);
    }
    Ok(())
}

/// Render the whole page, the verdict and test conditions of `signoff`
/// first.
pub fn render(report: &Report, signoff: &formats::conformance::SignOff) -> Result<String> {
    let mut h = Page::new(
        "trinocular — rotary table error report",
        "Rotary table errors (C axis, standard ball)",
    );
    let angles: Vec<f64> = report.errors.iter().map(|e| e.angle_deg).collect();
    h.meta(&format!(
        "Source: {} ({}) · {} balls ({}) · {} angles from {}° to {}° · layout condition number \
         <b>{:.2}</b> (limit {}) · residual RMS {:.3} µm · docs/probe-rotary.md, ISO 230-7 names",
        escape(&report.source),
        match report.input {
            super::report::InputKind::Centres => "ball centres",
            super::report::InputKind::Points => "probed points, a sphere fitted per ball and angle",
        },
        report.balls.len(),
        escape(
            &report
                .balls
                .iter()
                .map(|b| b.ball.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
        angles.len(),
        angles.first().copied().unwrap_or(0.0),
        angles.last().copied().unwrap_or(0.0),
        report.condition,
        report.condition_limit,
        report.residual_rms_um
    ));
    report::conformance::header(&mut h, signoff);
    summary(&mut h, report);
    report::uncertainty::section(&mut h, report.uncertainty.as_ref());

    h.h2("errors", "Errors against the table angle");
    angle_plots(
        &mut h,
        "errors",
        "Errors",
        &report.errors,
        &report.ranges.errors,
        true,
        "Per-angle least squares (dots, ±u bars); the line is the interpolation, closed to 360° = 0°.",
    )?;

    if let Some(loc) = &report.location {
        h.h2("location", "Axis average line (location errors)");
        for (id, names, unit, ks, at) in [
            (
                "offset",
                ("EXC", "EYC"),
                "µm",
                (0, 1),
                (loc.errors.x0c_um, loc.errors.y0c_um),
            ),
            (
                "tilt",
                ("EAC", "EBC"),
                "µrad",
                (3, 4),
                (loc.errors.a0c_urad, loc.errors.b0c_urad),
            ),
        ] {
            let measured = report
                .errors
                .iter()
                .map(|r| (r.errors.values()[ks.0], r.errors.values()[ks.1]))
                .collect();
            let title = format!(
                "{} over the turn: axis average line at ({:.2}, {:.2}) {unit}",
                if id == "offset" {
                    "Radial errors"
                } else {
                    "Tilt errors"
                },
                at.0,
                at.1
            );
            let svg = plot::path(
                &title,
                &Path {
                    names,
                    unit,
                    measured,
                    location: Some(at),
                },
            )?;
            h.figure(
                &format!("plot-location-{id}"),
                &svg,
                &format!(
                    "A fixed axis at the location alone would trace the green circle; red: ({}).",
                    if id == "offset" {
                        "X0C, Y0C"
                    } else {
                        "A0C, B0C"
                    }
                ),
            );
        }
    }

    if let (Some(components), Some(ranges)) = (&report.components, &report.ranges.components) {
        h.h2(
            "components",
            "Component errors (axis average line taken out)",
        );
        angle_plots(
            &mut h,
            "components",
            "Component errors",
            components,
            ranges,
            false,
            "Errors less those of a fixed axis at the location errors; their ranges are the sign-off figures.",
        )?;
    }

    tables(&mut h, report);
    h.notes("Warnings", &report.warnings, true);
    h.notes("Conventions", &report.conventions, false);
    Ok(h.finish())
}

/// The sign-off figures: location errors and the ranges.
fn summary(h: &mut Page, report: &Report) {
    h.h2("summary", "Sign-off figures (value ± U, k = 2)");
    if let Some(l) = &report.location {
        let rows: Vec<Vec<String>> = [
            (
                "X0C",
                "position of the axis average line in x at Z = 0",
                l.errors.x0c_um,
                l.u_x0c_um,
                "µm",
            ),
            (
                "Y0C",
                "position of the axis average line in y at Z = 0",
                l.errors.y0c_um,
                l.u_y0c_um,
                "µm",
            ),
            (
                "A0C",
                "tilt of the axis average line about x",
                l.errors.a0c_urad,
                l.u_a0c_urad,
                "µrad",
            ),
            (
                "B0C",
                "tilt of the axis average line about y",
                l.errors.b0c_urad,
                l.u_b0c_urad,
                "µrad",
            ),
        ]
        .iter()
        .map(|(name, meaning, v, u, unit)| {
            let big_u = expanded(report, &format!("location.{name}_{}", key_unit(unit)));
            vec![
                (*name).to_string(),
                (*meaning).to_string(),
                plus_minus(*v, big_u, 3),
                format!("{u:.3}"),
                (*unit).to_string(),
            ]
        })
        .collect();
        table(
            h,
            "location",
            &[
                "location error (ISO 230-7)",
                "meaning",
                "value ± U (k = 2)",
                "u",
                "unit",
            ],
            &rows,
            2,
        );
    } else {
        h.paragraph("The axis average line is not reported: the measured angles do not separate it (see the warnings).");
    }
    let errors = report.ranges.errors.values();
    let components = report.ranges.components.map(|c| c.values());
    let rows: Vec<Vec<String>> = (0..6)
        .map(|k| {
            let path = |which: &str| format!("ranges.{which}.{}_{}", NAMES[k], key_unit(UNITS[k]));
            vec![
                NAMES[k].to_string(),
                MEANING[k].to_string(),
                plus_minus(errors[k], expanded(report, &path("errors")), 3),
                components.map_or_else(
                    || "—".into(),
                    |c| plus_minus(c[k], expanded(report, &path("components")), 3),
                ),
                UNITS[k].to_string(),
            ]
        })
        .collect();
    table(
        h,
        "ranges",
        &[
            "error",
            "meaning",
            "range of the errors",
            "range of the component errors",
            "unit",
        ],
        &rows,
        2,
    );
    let _ = writeln!(
        h,
        "<p class=\"meta\">Largest standard uncertainty: {:.3} µm (translations), {:.3} µrad (rotations).</p>",
        report.max_u_translation_um, report.max_u_rotation_urad
    );
}

/// The key suffix of a unit: `um` for µm, `urad` for µrad.
fn key_unit(unit: &str) -> &'static str {
    if unit == "µm" { "um" } else { "urad" }
}

/// U (k = 2) of the figure at `path`, when the report gives it.
fn expanded(report: &Report, path: &str) -> Option<f64> {
    report.uncertainty.as_ref().and_then(|u| u.of(path))
}

/// Six values with their uncertainties, formatted for a table row.
fn six_cells(r: &AngleReport) -> Vec<String> {
    let v = r.errors.values();
    let u = r.uncertainty.map(|u| {
        [
            u.exc_um, u.eyc_um, u.ezc_um, u.eac_urad, u.ebc_urad, u.ecc_urad,
        ]
    });
    (0..6)
        .map(|k| match u {
            Some(u) => format!("{:.3} ± {:.3}", v[k], u[k]),
            None => format!("{:.3}", v[k]),
        })
        .collect()
}

/// One table row per angle: the angle and the six cells.
fn angle_rows(rows: &[AngleReport]) -> Vec<Vec<String>> {
    rows.iter()
        .map(|r| {
            let mut row = vec![format!("{}", r.angle_deg)];
            row.extend(six_cells(r));
            row
        })
        .collect()
}

/// The tables: errors per angle, interpolated angles, balls, sphere fits.
fn tables(h: &mut Page, report: &Report) {
    let header: Vec<String> = std::iter::once("angle (°)".to_string())
        .chain((0..6).map(|k| format!("{} ({})", NAMES[k], UNITS[k])))
        .collect();
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    h.h2(
        "table-errors",
        "Errors per angle (value ± standard uncertainty)",
    );
    let mut with_residual = header_refs.clone();
    with_residual.push("residual RMS (µm)");
    let mut rows = angle_rows(&report.errors);
    for (row, r) in rows.iter_mut().zip(&report.errors) {
        row.push(
            r.residual_rms_um
                .map_or_else(|| "—".into(), |v| format!("{v:.3}")),
        );
    }
    table(h, "errors", &with_residual, &rows, 0);
    if let Some(components) = &report.components {
        h.h2("table-components", "Component errors per angle");
        table(h, "components", &header_refs, &angle_rows(components), 0);
    }
    if !report.interpolated.is_empty() {
        h.h2(
            "table-interpolated",
            "Errors at the angles asked for (interpolated)",
        );
        table(
            h,
            "interpolated",
            &header_refs,
            &angle_rows(&report.interpolated),
            0,
        );
    }
    h.h2("balls", "Ball layout (reference centres at 0°)");
    let rows: Vec<Vec<String>> = report
        .balls
        .iter()
        .map(|b| {
            vec![
                b.ball.clone(),
                format!("{:.4}", b.centre[0]),
                format!("{:.4}", b.centre[1]),
                format!("{:.4}", b.centre[2]),
                format!("{:.3}", b.radius_mm),
            ]
        })
        .collect();
    table(
        h,
        "layout",
        &[
            "ball",
            "x (mm)",
            "y (mm)",
            "z (mm)",
            "distance from the axis (mm)",
        ],
        &rows,
        1,
    );
    let _ = writeln!(
        h,
        "<p class=\"meta\">Condition number {:.3} of the design with the rotation columns scaled by {:.3} mm \
         (the balls' RMS distance from their centroid); layouts above {} are refused.</p>",
        report.condition, report.scale_mm, report.condition_limit
    );
    if !report.sphere_fits.is_empty() {
        h.h2("spheres", "Sphere fits (probed points)");
        let rows: Vec<Vec<String>> = report
            .sphere_fits
            .iter()
            .map(|f| {
                vec![
                    f.ball.clone(),
                    format!("{}", f.angle_deg),
                    format!("{}", f.points),
                    format!("{:.4}", f.radius_mm),
                    format!("{:.3}", f.rms_residual_um),
                    format!("{:.3}", f.max_residual_um),
                ]
            })
            .collect();
        table(
            h,
            "sphere-fits",
            &[
                "ball",
                "angle (°)",
                "points",
                "radius (mm)",
                "RMS residual (µm)",
                "max residual (µm)",
            ],
            &rows,
            1,
        );
    }
}
