//! `report.html`: one self-contained page (inline CSS and SVG, no scripts,
//! no external resources) with the figures in tables and the plots, for the
//! person who signs off a machine.

use std::fmt::Write;

use crate::report::{AxisReport, FlatnessReport, LineReport, PositioningReport, Report};
use crate::{Result, plot};

/// Escape text for HTML content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A figure to 3 decimals, or an em dash when absent.
fn num(v: Option<f64>) -> String {
    v.map_or_else(|| "—".into(), |v| format!("{v:.3}"))
}

const STYLE: &str = "
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;margin:0;background:#f5f6f8;color:#1d2127}
main{max-width:960px;margin:0 auto;padding:16px 24px 48px}
h1{font-size:26px;margin:18px 0 4px}h2{font-size:21px;margin:34px 0 8px;border-bottom:2px solid #d0d5dd;padding-bottom:4px}
h3{font-size:17px;margin:22px 0 8px}p.meta{color:#555;margin:0 0 12px}
table{border-collapse:collapse;margin:8px 0 14px;background:#fff;font-size:13.5px}
th,td{border:1px solid #d0d5dd;padding:3px 8px;text-align:right}th{background:#eef1f5}
td.l,th.l{text-align:left}
figure.plot{margin:10px 0 16px;background:#fff;border:1px solid #d0d5dd;padding:6px;width:max-content}
figure.plot svg{display:block}figcaption{font-size:13px;color:#444;padding:4px 2px 0}
ul.notes{font-size:13px;color:#444}.warn{color:#8a4b00}
";

/// Render the whole page.
pub fn render(report: &Report) -> Result<String> {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>trinocular — machine geometric error report</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<main>\n\
         <h1>Machine geometric error report</h1>\n\
         <p class=\"meta\">Source: {} · {} point rows · spheres {} · figures from sphere <b>{}</b> · \
         positioning per ISO 230-2, straightness and flatness by least squares and minimum zone</p>\n",
        escape(&report.source),
        report.rows,
        escape(&report.spheres.join(", ")),
        escape(&report.sphere),
    );
    summary(&mut h, report);
    for (axis, a) in report.axes.iter() {
        axis_section(&mut h, axis.name(), a)?;
    }
    if let Some(f) = &report.flatness {
        flatness_section(&mut h, f)?;
    }
    if !report.warnings.is_empty() {
        h.push_str("<h2>Warnings</h2>\n<ul class=\"notes warn\">\n");
        for w in &report.warnings {
            let _ = writeln!(h, "<li>{}</li>", escape(w));
        }
        h.push_str("</ul>\n");
    }
    h.push_str("<h2>Conventions</h2>\n<ul class=\"notes\">\n");
    for c in &report.conventions {
        let _ = writeln!(h, "<li>{}</li>", escape(c));
    }
    h.push_str("</ul>\n</main>\n</body>\n</html>\n");
    Ok(h)
}

/// The one table a reader checks first: every axis's headline figures.
fn summary(h: &mut String, report: &Report) {
    h.push_str(
        "<h2>Summary</h2>\n<table id=\"summary\">\n<tr><th class=\"l\">figure (µm / µrad)</th>",
    );
    let axes: Vec<(&str, &AxisReport)> = report.axes.iter().map(|(a, r)| (a.name(), r)).collect();
    for (name, _) in &axes {
        let _ = write!(h, "<th>{name} axis</th>");
    }
    h.push_str("</tr>\n");
    type Get = fn(&LineReport) -> Option<f64>;
    let rows: [(&str, Get); 13] = [
        ("A — bidirectional accuracy", |l| l.positioning.a_um),
        ("A↑ — unidirectional accuracy", |l| {
            l.positioning.a_up_um
        }),
        ("A↓ — unidirectional accuracy", |l| {
            l.positioning.a_down_um
        }),
        ("E — systematic positional deviation", |l| {
            l.positioning.e_um
        }),
        ("M — mean bidirectional positional deviation", |l| {
            l.positioning.m_um
        }),
        ("R — bidirectional repeatability", |l| l.positioning.r_um),
        ("R↑", |l| l.positioning.r_up_um),
        ("R↓", |l| l.positioning.r_down_um),
        ("B — reversal value", |l| l.positioning.b_um),
        ("seed 3σ figure", |l| Some(l.positioning.seed_3sigma_um)),
        ("roll range", |l| l.angular.as_ref().map(|a| a.roll_urad)),
        ("pitch range", |l| l.angular.as_ref().map(|a| a.pitch_urad)),
        ("yaw range", |l| l.angular.as_ref().map(|a| a.yaw_urad)),
    ];
    for (label, get) in rows {
        let _ = write!(h, "<tr><td class=\"l\">{}</td>", escape(label));
        for (_, a) in &axes {
            let _ = write!(h, "<td>{}</td>", num(get(&a.main)));
        }
        h.push_str("</tr>\n");
    }
    for (name, a) in &axes {
        for (dir, s) in &a.main.straightness {
            let _ = write!(
                h,
                "<tr><td class=\"l\">straightness of {name} in {dir} (LSQ / min zone)</td>"
            );
            for (other, _) in &axes {
                if other == name {
                    let _ = write!(h, "<td>{:.3} / {:.3}</td>", s.lsq_um, s.min_zone_um);
                } else {
                    h.push_str("<td></td>");
                }
            }
            h.push_str("</tr>\n");
        }
    }
    if let Some(f) = &report.flatness {
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">flatness (LSQ / min zone)</td><td colspan=\"{}\">{:.3} / {:.3}</td></tr>",
            axes.len().max(1),
            f.lsq_um,
            f.min_zone_um
        );
    }
    h.push_str("</table>\n");
}

/// A plot in a titled figure.
fn figure(h: &mut String, id: &str, svg: &str, caption: &str) {
    let _ = write!(
        h,
        "<figure class=\"plot\" id=\"{}\">\n{svg}\n<figcaption>{}</figcaption>\n</figure>\n",
        escape(id),
        escape(caption)
    );
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

fn axis_section(h: &mut String, name: &str, a: &AxisReport) -> Result<()> {
    let l = &a.main;
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
    h.push_str("<h3>Positioning (ISO 230-2)</h3>\n");
    let title = format!("{name} axis — positional deviation");
    figure(
        h,
        &format!("plot-{name}-positioning"),
        &plot::positioning(&title, &l.positioning)?,
        "Dots: the deviation of every run (captures averaged); solid: mean per direction; dashed: mean ± 2s.",
    );
    positioning_tables(h, &l.positioning);

    h.push_str("<h3>Straightness</h3>\n");
    for (dir, s) in &l.straightness {
        let title = format!(
            "{name} axis — straightness in {dir}: LSQ {:.3} µm, min zone {:.3} µm",
            s.lsq_um, s.min_zone_um
        );
        figure(
            h,
            &format!("plot-{name}-straightness-{dir}"),
            &plot::straightness(&title, s)?,
            "Deviation of the per-target mean position from the least-squares reference line; \
             the band is the minimum zone (two parallel lines, ISO 12780).",
        );
    }
    if let Some(ang) = &l.angular {
        h.push_str("<h3>Angular errors</h3>\n");
        let title = format!("{name} axis — roll, pitch, yaw");
        figure(
            h,
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
             <tr><td class=\"l\">{name} axis</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td></tr></table>",
            ang.roll_urad, ang.pitch_urad, ang.yaw_urad
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
        h.push_str("</tr>\n");
        for line in &a.lines {
            let p = &line.positioning;
            let _ = write!(
                h,
                "<tr><td class=\"l\">{}{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
                line.line,
                if line.line == l.line { " (main)" } else { "" },
                escape(&off_axis(line)),
                p.runs_up + p.runs_down,
                num(p.a_um.or(p.a_up_um).or(p.a_down_um)),
                num(p.e_um.or(p.e_up_um).or(p.e_down_um)),
                num(p.m_um),
                num(p.r_um.or(p.r_up_um).or(p.r_down_um)),
                num(p.b_um),
            );
            for d in &dirs {
                match line.straightness.get(*d) {
                    Some(s) => {
                        let _ = write!(h, "<td>{:.3} / {:.3}</td>", s.lsq_um, s.min_zone_um);
                    }
                    None => h.push_str("<td>—</td>"),
                }
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</table>\n");
    }
    Ok(())
}

fn positioning_tables(h: &mut String, p: &PositioningReport) {
    h.push_str(
        "<table><tr><th class=\"l\">ISO 230-2 (µm)</th><th>bidirectional</th><th>↑</th><th>↓</th></tr>\n",
    );
    type Row<'a> = (&'a str, Option<f64>, Option<f64>, Option<f64>);
    let rows: [Row<'_>; 4] = [
        ("A — accuracy", p.a_um, p.a_up_um, p.a_down_um),
        (
            "E — systematic positional deviation",
            p.e_um,
            p.e_up_um,
            p.e_down_um,
        ),
        ("R — repeatability", p.r_um, p.r_up_um, p.r_down_um),
        (
            "M — mean bidirectional positional deviation",
            p.m_um,
            None,
            None,
        ),
    ];
    for (label, b, u, d) in rows {
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">{label}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            num(b),
            num(u),
            num(d)
        );
    }
    let _ = writeln!(
        h,
        "<tr><td class=\"l\">B — reversal value (B̄ mean)</td><td>{} ({})</td><td></td><td></td></tr>\n\
         <tr><td class=\"l\">seed figure max(x̄+3s) − min(x̄−3s)</td><td>{:.3}</td><td></td><td></td></tr>\n</table>",
        num(p.b_um),
        num(p.b_mean_um),
        p.seed_3sigma_um
    );
    if let Some(v) = &p.vdi3441 {
        let _ = writeln!(
            h,
            "<table><tr><th class=\"l\">VDI/DGQ 3441 (µm)</th><th>P</th><th>Ps</th><th>U</th><th>Ū</th><th>Pa</th></tr>\
             <tr><td class=\"l\">figures</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td></tr></table>",
            v.p_um, v.ps_um, v.u_um, v.u_mean_um, v.pa_um
        );
    }
    h.push_str(
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
    h.push_str("</table>\n");
}

fn flatness_section(h: &mut String, f: &FlatnessReport) -> Result<()> {
    h.push_str("<h2 id=\"flatness\">Flatness</h2>\n");
    let title = format!(
        "Flatness: LSQ {:.3} µm, min zone {:.3} µm",
        f.lsq_um, f.min_zone_um
    );
    figure(
        h,
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
         <tr><td class=\"l\">X and Y lines</td><td>{:.3}</td><td>{:.3}</td><td>{}</td></tr></table>",
        f.lsq_um,
        f.min_zone_um,
        f.points.len()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup() {
        assert_eq!(escape("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
    }
}
