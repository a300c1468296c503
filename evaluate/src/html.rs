//! `report.html`: one self-contained page (inline CSS and SVG, no scripts,
//! no external resources) with the figures in tables and the plots, for the
//! person who signs off a machine.

use std::fmt::Write;

use ::report::{Page, escape, num, num_u, num_u_in};
use formats::evaluation::{AxisReport, FlatnessReport, LineReport, PositioningReport, Report};

use crate::{Result, plot};

/// Render the whole page.
pub fn render(report: &Report) -> Result<String> {
    let mut h = Page::new(
        "trinocular — machine geometric error report",
        "Machine geometric error report",
    );
    h.meta(&format!(
        "Source: {} · {} point rows · spheres {} · figures from sphere <b>{}</b> · \
         positioning per ISO 230-2, straightness and flatness by least squares and minimum zone",
        escape(&report.source),
        report.rows,
        escape(&report.spheres.join(", ")),
        escape(&report.sphere),
    ));
    ::report::conformance::header(&mut h, &report.signoff);
    summary(&mut h, report);
    ::report::uncertainty::section_labelled(&mut h, report.uncertainty.as_ref(), &figure_label);
    for (axis, a) in report.axes.iter() {
        axis_section(&mut h, report, axis.name(), a)?;
    }
    if let Some(f) = &report.flatness {
        flatness_section(&mut h, report, f)?;
    }
    h.notes("Warnings", &report.warnings, true);
    h.notes("Conventions", &report.conventions, false);
    Ok(h.finish())
}

/// The one table a reader checks first: every axis's headline figures.
fn summary(h: &mut Page, report: &Report) {
    h.raw("<h2>Summary</h2>\n");
    // The figures are corrected to 20 °C: said where they are read.
    if let Some(correction) = &report.correction {
        let _ = writeln!(
            h,
            "<p class=\"meta\" id=\"correction\">Conditions applied: {}</p>",
            escape(correction)
        );
    }
    h.raw("<table id=\"summary\">\n<tr><th class=\"l\">figure (µm / µrad)</th>");
    let axes: Vec<(&str, &AxisReport)> = report.axes.iter().map(|(a, r)| (a.name(), r)).collect();
    for (name, _) in &axes {
        let _ = write!(h, "<th>{name} axis</th>");
    }
    h.raw("</tr>\n");
    type Get = fn(&LineReport) -> Option<f64>;
    // (the figure's key under axes.<axis>, value); labelled by `figure_name`.
    let rows: [(&str, Get); 13] = [
        ("positioning.A_um", |l| l.positioning.a_um),
        ("positioning.A_up_um", |l| l.positioning.a_up_um),
        ("positioning.A_down_um", |l| l.positioning.a_down_um),
        ("positioning.E_um", |l| l.positioning.e_um),
        ("positioning.M_um", |l| l.positioning.m_um),
        ("positioning.R_um", |l| l.positioning.r_um),
        ("positioning.R_up_um", |l| l.positioning.r_up_um),
        ("positioning.R_down_um", |l| l.positioning.r_down_um),
        ("positioning.B_um", |l| l.positioning.b_um),
        ("positioning.seed_3sigma_um", |l| {
            l.positioning.seed_3sigma_um
        }),
        ("angular.roll_urad", |l| {
            l.angular.as_ref().map(|a| a.roll_urad)
        }),
        ("angular.pitch_urad", |l| {
            l.angular.as_ref().map(|a| a.pitch_urad)
        }),
        ("angular.yaw_urad", |l| {
            l.angular.as_ref().map(|a| a.yaw_urad)
        }),
    ];
    for (key, get) in rows {
        let label = match figure_name(key) {
            Some((name, "")) => name,
            Some((name, what)) => format!("{name} — {what}"),
            None => key.to_string(),
        };
        let _ = write!(h, "<tr><td class=\"l\">{}</td>", escape(&label));
        for (name, a) in &axes {
            let u = report.expanded(&format!("axes.{name}.{key}"));
            let _ = write!(h, "<td>{}</td>", num_u(get(&a.main), u));
        }
        h.raw("</tr>\n");
    }
    if axes
        .iter()
        .any(|(_, a)| a.main.positioning.left_out.is_some())
    {
        h.raw("<tr><td class=\"l\">positioning left out</td>");
        for (_, a) in &axes {
            let reason = a.main.positioning.left_out.as_deref().unwrap_or("");
            let _ = write!(h, "<td class=\"l warn\">{}</td>", escape(reason));
        }
        h.raw("</tr>\n");
    }
    if axes
        .iter()
        .any(|(_, a)| a.main.straightness_left_out.is_some())
    {
        h.raw("<tr><td class=\"l\">straightness left out</td>");
        for (_, a) in &axes {
            let reason = a.main.straightness_left_out.as_deref().unwrap_or("");
            let _ = write!(h, "<td class=\"l warn\">{}</td>", escape(reason));
        }
        h.raw("</tr>\n");
    }
    for (name, a) in &axes {
        for (dir, s) in &a.main.straightness {
            let _ = write!(
                h,
                "<tr><td class=\"l\">straightness of {name} in {dir} (LSQ / min zone)</td>"
            );
            for (other, _) in &axes {
                if other == name {
                    let u =
                        |k: &str| report.expanded(&format!("axes.{name}.straightness.{dir}.{k}"));
                    let _ = write!(
                        h,
                        "<td>{} / {}</td>",
                        num_u(Some(s.lsq_um), u("lsq_um")),
                        num_u(Some(s.min_zone_um), u("min_zone_um"))
                    );
                } else {
                    h.raw("<td></td>");
                }
            }
            h.raw("</tr>\n");
        }
    }
    if let Some(f) = &report.flatness {
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">flatness (LSQ / min zone)</td><td colspan=\"{}\">{} / {}</td></tr>",
            axes.len().max(1),
            num_u(Some(f.lsq_um), report.expanded("flatness.lsq_um")),
            num_u(Some(f.min_zone_um), report.expanded("flatness.min_zone_um"))
        );
    }
    h.raw("</table>\n");
}

/// The figures of a line as the page names them (ISO 230-2 §2 symbols,
/// VDI/DGQ 3441, the angular ranges): (key under the line, name, what it
/// is; empty when the name says it). The one home of the labels of the
/// summary and the uncertainty budget.
const FIGURE_NAMES: [(&str, &str, &str); 21] = [
    ("positioning.A_um", "A", "bidirectional accuracy"),
    ("positioning.A_up_um", "A↑", "unidirectional accuracy"),
    ("positioning.A_down_um", "A↓", "unidirectional accuracy"),
    ("positioning.E_um", "E", "systematic positional deviation"),
    (
        "positioning.E_up_um",
        "E↑",
        "unidirectional systematic positional deviation",
    ),
    (
        "positioning.E_down_um",
        "E↓",
        "unidirectional systematic positional deviation",
    ),
    (
        "positioning.M_um",
        "M",
        "mean bidirectional positional deviation",
    ),
    ("positioning.R_um", "R", "bidirectional repeatability"),
    ("positioning.R_up_um", "R↑", ""),
    ("positioning.R_down_um", "R↓", ""),
    ("positioning.B_um", "B", "reversal value"),
    ("positioning.B_mean_um", "B̄", "mean reversal value"),
    ("positioning.seed_3sigma_um", "3σ band", ""),
    (
        "positioning.vdi3441.P_um",
        "P (VDI/DGQ 3441)",
        "positional uncertainty",
    ),
    (
        "positioning.vdi3441.Ps_um",
        "Ps (VDI/DGQ 3441)",
        "positional scatter",
    ),
    (
        "positioning.vdi3441.U_um",
        "U (VDI/DGQ 3441)",
        "reversal span",
    ),
    (
        "positioning.vdi3441.U_mean_um",
        "Ū (VDI/DGQ 3441)",
        "mean reversal span",
    ),
    (
        "positioning.vdi3441.Pa_um",
        "Pa (VDI/DGQ 3441)",
        "position deviation",
    ),
    ("angular.roll_urad", "roll range", ""),
    ("angular.pitch_urad", "pitch range", ""),
    ("angular.yaw_urad", "yaw range", ""),
];

/// Name and description of the figure at `key` under a line
/// (`positioning.A_down_um` → `A↓`, `straightness.Y.lsq_um` → `straightness
/// in Y (LSQ)`); `None` for a key the page does not name.
fn figure_name(key: &str) -> Option<(String, &'static str)> {
    if let Some(&(_, name, what)) = FIGURE_NAMES.iter().find(|(k, _, _)| *k == key) {
        return Some((name.to_string(), what));
    }
    let (direction, figure) = key.strip_prefix("straightness.")?.split_once('.')?;
    Some((
        format!("straightness in {direction} ({})", zone_name(figure)?),
        "",
    ))
}

/// `LSQ` or `min zone` for a straightness or flatness key.
fn zone_name(figure: &str) -> Option<&'static str> {
    match figure {
        "lsq_um" => Some("LSQ"),
        "min_zone_um" => Some("min zone"),
        _ => None,
    }
}

/// A figure of `report.json` by its path as a reader names it, axis,
/// figure and unit (`axes.X.positioning.A_down_um` → `X, A↓, µm`,
/// `axes.Y.lines.2.angular.roll_urad` → `Y line 2, roll range, µrad`,
/// `flatness.lsq_um` → `flatness (LSQ), µm`); the path itself when the page
/// does not name it.
pub(crate) fn figure_label(path: &str) -> String {
    let unit = ::report::uncertainty::unit_of(path);
    let named = if let Some(figure) = path.strip_prefix("flatness.") {
        zone_name(figure).map(|z| format!("flatness ({z})"))
    } else {
        path.strip_prefix("axes.")
            .and_then(|rest| rest.split_once('.'))
            .and_then(|(axis, key)| {
                let (axis, key) = match key.strip_prefix("lines.").and_then(|k| k.split_once('.')) {
                    Some((line, key)) => (format!("{axis} line {line}"), key),
                    None => (axis.to_string(), key),
                };
                figure_name(key).map(|(name, _)| format!("{axis}, {name}"))
            })
    };
    match named {
        Some(label) if unit.is_empty() => label,
        Some(label) => format!("{label}, {unit}"),
        None => path.to_string(),
    }
}

/// `y = 0, z = 0 mm` for a line's off-axis coordinates.
fn off_axis(l: &LineReport) -> String {
    let parts: Vec<String> = l
        .off_axis
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect();
    format!("{} mm", parts.join(", "))
}

/// U of the figures under `prefix` (`axes.X`, `axes.X.lines.2`), by their
/// key below it (`positioning.A_um`).
fn expanded_under<'a>(report: &'a Report, prefix: &str) -> impl Fn(&str) -> Option<f64> + 'a {
    let prefix = prefix.to_string();
    move |key| report.expanded(&format!("{prefix}.{key}"))
}

fn axis_section(h: &mut Page, report: &Report, name: &str, a: &AxisReport) -> Result<()> {
    let l = &a.main;
    let main_u = expanded_under(report, &format!("axes.{name}"));
    let _ = write!(
        h,
        "<h2 id=\"axis-{name}\">{name} axis</h2>\n<p class=\"meta\">Line at {} · {} targets · {} ↑ runs, {} ↓ runs · \
         fitted direction ({:.6}, {:.6}, {:.6})</p>\n",
        escape(&off_axis(l)),
        l.targets,
        l.positioning.runs_up,
        l.positioning.runs_down,
        l.direction[0],
        l.direction[1],
        l.direction[2]
    );
    h.raw("<h3>Positioning (ISO 230-2)</h3>\n");
    if let Some(reason) = &l.positioning.left_out {
        let _ = writeln!(h, "<p class=\"warn\">{}</p>", escape(reason));
    }
    if has_iso(&l.positioning) {
        let title = format!("{name} axis — positional deviation");
        h.figure(
            &format!("plot-{name}-positioning"),
            &plot::positioning(&title, &l.positioning)?,
            "Dots: the deviation of every run (captures averaged); solid: mean per direction; dashed: mean ± 2s.",
        );
        positioning_tables(h, &l.positioning, &main_u);
    }

    h.raw("<h3>Straightness</h3>\n");
    if let Some(reason) = &l.straightness_left_out {
        let _ = writeln!(h, "<p class=\"warn\">{}</p>", escape(reason));
    }
    for (dir, s) in &l.straightness {
        let u = |k: &str| main_u(&format!("straightness.{dir}.{k}"));
        let title = format!(
            "{name} axis — straightness in {dir}: LSQ {}, min zone {}",
            num_u_in(Some(s.lsq_um), u("lsq_um"), "µm"),
            num_u_in(Some(s.min_zone_um), u("min_zone_um"), "µm")
        );
        h.figure(
            &format!("plot-{name}-straightness-{dir}"),
            &plot::straightness(&title, s)?,
            "Deviation of the per-target mean position from the least-squares reference line; \
             the band is the minimum zone (two parallel lines, ISO 12780).",
        );
    }
    if let Some(ang) = &l.angular {
        h.raw("<h3>Angular errors</h3>\n");
        let title = format!("{name} axis — roll, pitch, yaw");
        h.figure(
            &format!("plot-{name}-angular"),
            &plot::angular(&title, ang)?,
            &format!(
                "Rotation of the table relative to the first target, from spheres {} (rigid-fit RMS {:.3} µm).",
                ang.spheres.join(", "),
                ang.fit_rms_um
            ),
        );
        let _ = writeln!(
            h,
            "<table><tr><th class=\"l\">range (µrad)</th><th>roll</th><th>pitch</th><th>yaw</th></tr>\
             <tr><td class=\"l\">{name} axis</td><td>{}</td><td>{}</td><td>{}</td></tr></table>",
            num_u(Some(ang.roll_urad), main_u("angular.roll_urad")),
            num_u(Some(ang.pitch_urad), main_u("angular.pitch_urad")),
            num_u(Some(ang.yaw_urad), main_u("angular.yaw_urad"))
        );
    }
    if a.lines.len() > 1 {
        let _ = write!(
            h,
            "<h3>All lines of the {name} axis</h3>\n<table><tr><th class=\"l\">line</th><th class=\"l\">off-axis position</th>\
             <th>runs</th><th>A (µm)</th><th>E (µm)</th><th>M (µm)</th><th>R (µm)</th><th>B (µm)</th>"
        );
        // Every line's directions: the main line's may be left out.
        let dirs: std::collections::BTreeSet<&String> =
            a.lines.iter().flat_map(|l| l.straightness.keys()).collect();
        for d in &dirs {
            let _ = write!(h, "<th>straightness {d} LSQ / MZ (µm)</th>");
        }
        h.raw("</tr>\n");
        let mut partial = Vec::new();
        for line in &a.lines {
            let p = &line.positioning;
            let u = expanded_under(report, &format!("axes.{name}.lines.{}", line.line));
            let _ = write!(
                h,
                "<tr><td class=\"l\">{}{}</td><td class=\"l\">{}</td><td>{}</td>",
                line.line,
                if line.line == l.line { " (main)" } else { "" },
                escape(&off_axis(line)),
                p.runs_up + p.runs_down,
            );
            match &p.left_out {
                // Where the figures would be, the reason they are not.
                Some(reason) if !has_iso(p) => {
                    let _ = write!(
                        h,
                        "<td colspan=\"5\" class=\"l warn\">{}</td>",
                        escape(reason)
                    );
                }
                _ => {
                    let [a, e, r] = p.shown_a_e_r();
                    let pu = |k: &str| u(&format!("positioning.{k}"));
                    let _ = write!(
                        h,
                        "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
                        num_u(a.0, pu(a.1)),
                        num_u(e.0, pu(e.1)),
                        num_u(p.m_um, pu("M_um")),
                        num_u(r.0, pu(r.1)),
                        num_u(p.b_um, pu("B_um")),
                    );
                    if let Some(reason) = &p.left_out {
                        partial.push(format!("line {}: {reason}", line.line));
                    }
                }
            }
            if let Some(reason) = &line.straightness_left_out {
                partial.push(format!("line {}: {reason}", line.line));
            }
            for d in &dirs {
                match line.straightness.get(*d) {
                    Some(s) => {
                        let su = |k: &str| u(&format!("straightness.{d}.{k}"));
                        let _ = write!(
                            h,
                            "<td>{} / {}</td>",
                            num_u(Some(s.lsq_um), su("lsq_um")),
                            num_u(Some(s.min_zone_um), su("min_zone_um"))
                        );
                    }
                    None => {
                        h.raw("<td>—</td>");
                    }
                }
            }
            h.raw("</tr>\n");
        }
        h.raw("</table>\n");
        if !partial.is_empty() {
            h.raw("<ul class=\"notes warn\">\n");
            for note in &partial {
                let _ = writeln!(h, "<li>{}</li>", escape(note));
            }
            h.raw("</ul>\n");
        }
    }
    Ok(())
}

/// The line has ISO 230-2 figures of at least one direction.
fn has_iso(p: &PositioningReport) -> bool {
    p.a_up_um.is_some() || p.a_down_um.is_some()
}

/// The ISO 230-2 and VDI/DGQ 3441 tables of a line, its figures ± U (`u`:
/// U by the key under the line) and the per-target statistics.
fn positioning_tables(h: &mut Page, p: &PositioningReport, u: &dyn Fn(&str) -> Option<f64>) {
    let pu = |k: &str| u(&format!("positioning.{k}"));
    h.raw(
        "<table><tr><th class=\"l\">ISO 230-2 (µm)</th><th>bidirectional</th><th>↑</th><th>↓</th></tr>\n",
    );
    // (label, figure key, bidirectional, ↑, ↓)
    type Row<'a> = (&'a str, &'a str, Option<f64>, Option<f64>, Option<f64>);
    let rows: [Row<'_>; 4] = [
        ("A — accuracy", "A", p.a_um, p.a_up_um, p.a_down_um),
        (
            "E — systematic positional deviation",
            "E",
            p.e_um,
            p.e_up_um,
            p.e_down_um,
        ),
        ("R — repeatability", "R", p.r_um, p.r_up_um, p.r_down_um),
        (
            "M — mean bidirectional positional deviation",
            "M",
            p.m_um,
            None,
            None,
        ),
    ];
    for (label, key, both, up, down) in rows {
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">{label}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            num_u(both, pu(&format!("{key}_um"))),
            num_u(up, pu(&format!("{key}_up_um"))),
            num_u(down, pu(&format!("{key}_down_um")))
        );
    }
    let _ = writeln!(
        h,
        "<tr><td class=\"l\">B — reversal value (B̄ mean)</td><td>{} ({})</td><td></td><td></td></tr>\n\
         <tr><td class=\"l\">3σ band max(x̄+3s) − min(x̄−3s)</td><td>{}</td><td></td><td></td></tr>\n</table>",
        num_u(p.b_um, pu("B_um")),
        num_u(p.b_mean_um, pu("B_mean_um")),
        num_u(p.seed_3sigma_um, pu("seed_3sigma_um"))
    );
    if let Some(v) = &p.vdi3441 {
        let _ = writeln!(
            h,
            "<table><tr><th class=\"l\">VDI/DGQ 3441 (µm)</th><th>P</th><th>Ps</th><th>U</th><th>Ū</th><th>Pa</th></tr>\
             <tr><td class=\"l\">figures</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr></table>",
            num_u(Some(v.p_um), pu("vdi3441.P_um")),
            num_u(Some(v.ps_um), pu("vdi3441.Ps_um")),
            num_u(Some(v.u_um), pu("vdi3441.U_um")),
            num_u(Some(v.u_mean_um), pu("vdi3441.U_mean_um")),
            num_u(Some(v.pa_um), pu("vdi3441.Pa_um"))
        );
    }
    h.raw(
        "<table><tr><th>target</th><th>nominal (mm)</th><th>x̄↑ (µm)</th><th>s↑ (µm)</th><th>x̄↓ (µm)</th>\
         <th>s↓ (µm)</th><th>B (µm)</th><th>x̄ (µm)</th><th>R↑ (µm)</th><th>R↓ (µm)</th><th>R (µm)</th></tr>\n",
    );
    for t in &p.targets {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{:.3}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            t.target,
            t.nominal,
            num(t.mean_up_um),
            num(t.s_up_um),
            num(t.mean_down_um),
            num(t.s_down_um),
            num(t.b_um),
            num(t.mean_um),
            num(t.r_up_um),
            num(t.r_down_um),
            num(t.r_um)
        );
    }
    h.raw("</table>\n");
}

fn flatness_section(h: &mut Page, report: &Report, f: &FlatnessReport) -> Result<()> {
    h.raw("<h2 id=\"flatness\">Flatness</h2>\n");
    let lsq = num_u(Some(f.lsq_um), report.expanded("flatness.lsq_um"));
    let min_zone = num_u(Some(f.min_zone_um), report.expanded("flatness.min_zone_um"));
    let title = format!(
        "Flatness: LSQ {}, min zone {}",
        num_u_in(Some(f.lsq_um), report.expanded("flatness.lsq_um"), "µm"),
        num_u_in(
            Some(f.min_zone_um),
            report.expanded("flatness.min_zone_um"),
            "µm"
        )
    );
    h.figure(
        "plot-flatness",
        &plot::flatness(&title, f)?,
        &format!(
            "Per-target mean positions of every X and Y line, coloured by the vertical deviation from the \
             least-squares plane z = {:.6}·x + {:.6}·y + {:.4} mm.",
            f.a, f.b, f.c
        ),
    );
    let _ = writeln!(
        h,
        "<table><tr><th class=\"l\">flatness (µm)</th><th>least squares</th><th>minimum zone</th><th>points</th></tr>\
         <tr><td class=\"l\">X and Y lines</td><td>{lsq}</td><td>{min_zone}</td><td>{}</td></tr></table>",
        f.points.len()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::figure_label;

    #[test]
    fn figures_are_labelled_by_axis_name_and_unit() {
        for (path, label) in [
            ("axes.X.positioning.A_down_um", "X, A↓, µm"),
            ("axes.Z.positioning.vdi3441.P_um", "Z, P (VDI/DGQ 3441), µm"),
            (
                "axes.Y.lines.2.angular.roll_urad",
                "Y line 2, roll range, µrad",
            ),
            (
                "axes.X.straightness.Z.lsq_um",
                "X, straightness in Z (LSQ), µm",
            ),
            ("flatness.min_zone_um", "flatness (min zone), µm"),
            // A figure the page does not name keeps its path.
            (
                "axes.X.positioning.unknown_um",
                "axes.X.positioning.unknown_um",
            ),
        ] {
            assert_eq!(figure_label(path), label);
        }
    }
}
