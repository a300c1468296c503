//! `report.html`: one self-contained page (inline CSS and SVG, no scripts,
//! no external resources) with the figures in tables and the plots, for the
//! person who signs off a machine.

use std::fmt::Write;

use ::report::{Page, escape, num, num_u};
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
    ::report::uncertainty::section(&mut h, report.uncertainty.as_ref());
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
    h.raw("<h2>Summary</h2>\n<table id=\"summary\">\n<tr><th class=\"l\">figure (µm / µrad)</th>");
    let axes: Vec<(&str, &AxisReport)> = report.axes.iter().map(|(a, r)| (a.name(), r)).collect();
    for (name, _) in &axes {
        let _ = write!(h, "<th>{name} axis</th>");
    }
    h.raw("</tr>\n");
    type Get = fn(&LineReport) -> Option<f64>;
    // (label, the figure's key under axes.<axis>, value)
    let rows: [(&str, &str, Get); 13] = [
        ("A — bidirectional accuracy", "positioning.A_um", |l| {
            l.positioning.a_um
        }),
        (
            "A↑ — unidirectional accuracy",
            "positioning.A_up_um",
            |l| l.positioning.a_up_um,
        ),
        (
            "A↓ — unidirectional accuracy",
            "positioning.A_down_um",
            |l| l.positioning.a_down_um,
        ),
        (
            "E — systematic positional deviation",
            "positioning.E_um",
            |l| l.positioning.e_um,
        ),
        (
            "M — mean bidirectional positional deviation",
            "positioning.M_um",
            |l| l.positioning.m_um,
        ),
        (
            "R — bidirectional repeatability",
            "positioning.R_um",
            |l| l.positioning.r_um,
        ),
        ("R↑", "positioning.R_up_um", |l| l.positioning.r_up_um),
        ("R↓", "positioning.R_down_um", |l| l.positioning.r_down_um),
        ("B — reversal value", "positioning.B_um", |l| {
            l.positioning.b_um
        }),
        ("seed 3σ figure", "positioning.seed_3sigma_um", |l| {
            l.positioning.seed_3sigma_um
        }),
        ("roll range", "angular.roll_urad", |l| {
            l.angular.as_ref().map(|a| a.roll_urad)
        }),
        ("pitch range", "angular.pitch_urad", |l| {
            l.angular.as_ref().map(|a| a.pitch_urad)
        }),
        ("yaw range", "angular.yaw_urad", |l| {
            l.angular.as_ref().map(|a| a.yaw_urad)
        }),
    ];
    for (label, key, get) in rows {
        let _ = write!(h, "<tr><td class=\"l\">{}</td>", escape(label));
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
    for (dir, s) in &l.straightness {
        let u = |k: &str| main_u(&format!("straightness.{dir}.{k}"));
        let title = format!(
            "{name} axis — straightness in {dir}: LSQ {} µm, min zone {} µm",
            num_u(Some(s.lsq_um), u("lsq_um")),
            num_u(Some(s.min_zone_um), u("min_zone_um"))
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
             <th>runs</th><th>A</th><th>E</th><th>M</th><th>R</th><th>B</th>"
        );
        let dirs: Vec<&String> = l.straightness.keys().collect();
        for d in &dirs {
            let _ = write!(h, "<th>straightness {d} LSQ / MZ</th>");
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
         <tr><td class=\"l\">seed figure max(x̄+3s) − min(x̄−3s)</td><td>{}</td><td></td><td></td></tr>\n</table>",
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
        "<table><tr><th>target</th><th>nominal (mm)</th><th>x̄↑</th><th>s↑</th><th>x̄↓</th><th>s↓</th>\
         <th>B</th><th>x̄</th><th>R↑</th><th>R↓</th><th>R</th></tr>\n",
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
    let title = format!("Flatness: LSQ {lsq} µm, min zone {min_zone} µm");
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
