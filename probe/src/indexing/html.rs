//! `report.html` of the indexing method: one self-contained page with the
//! construction's figures, ΔθA and ΔθB as maps and curves, the per-detent
//! means and the positions beyond the tolerance.

use report::{Page, escape, plus_minus_in};

use super::layout::wrap_deg;
use super::{Angles, Extreme, Report, plot};
use crate::Result;

/// Most positions beyond the tolerance listed on the page (all are in
/// `report.json`).
const EXCEEDING_SHOWN: usize = 40;

/// Render the page of `r` with the positions' `angles` (the rows of
/// `indexing.csv`), the verdict and test conditions of `signoff` first.
pub fn render(
    r: &Report,
    angles: &[Angles],
    signoff: &formats::conformance::SignOff,
) -> Result<String> {
    let mut h = Page::new(
        "trinocular — probe-head indexing errors",
        "Probe-head indexing errors",
    );
    h.meta(&format!(
        "Source: {} · {} positions · A {}…{}° · B turn of {} positions every {}° · construction of docs/probe-indexing.md",
        escape(&r.source),
        r.positions,
        r.grid.a_deg.first().copied().unwrap_or(0.0),
        r.grid.a_deg.last().copied().unwrap_or(0.0),
        r.axes.b_turn_positions,
        r.axes.b_turn_step_deg,
    ));
    report::conformance::header(&mut h, signoff);
    summary(&mut h, r);
    report::uncertainty::section(&mut h, r.uncertainty.as_ref());
    maps(&mut h, r, angles)?;
    curves(&mut h, r, angles)?;
    detents(&mut h, r);
    exceeding(&mut h, r);
    h.notes("Warnings", &r.warnings, true);
    h.notes("Conventions", &r.conventions, false);
    Ok(h.finish())
}

fn triple(v: [f64; 3], digits: usize) -> String {
    format!("({:.digits$}, {:.digits$}, {:.digits$})", v[0], v[1], v[2])
}

/// U (k = 2) of the figure at `path`, when the report gives it.
fn big_u(r: &Report, path: &str) -> Option<f64> {
    r.uncertainty.as_ref().and_then(|u| u.of(path))
}

/// `value ± U″` of the figure at `path` in arc-seconds.
fn arcsec(r: &Report, path: &str, value: f64) -> String {
    plus_minus_in(value, big_u(r, path), 3, "″")
}

fn summary(h: &mut Page, r: &Report) {
    h.h2("summary", "Summary (value ± U, k = 2)");
    let extreme = |label: &str, path: &str, e: &Extreme| {
        [
            label.to_string(),
            arcsec(r, path, e.value_arcsec.abs()),
            format!(
                "{:+.3}″ at A = {}°, B = {}°",
                e.value_arcsec, e.a_deg, e.b_deg
            ),
        ]
    };
    let mut rows: Vec<[String; 3]> = vec![
        extreme("max |ΔθA|", "max_dA_arcsec", &r.max_d_a_at),
        extreme("max |ΔθB| (A > 0°)", "max_dB_arcsec", &r.max_d_b_at),
        [
            "RMS ΔθA".into(),
            arcsec(r, "rms_dA_arcsec", r.rms_d_a_arcsec),
            String::new(),
        ],
        [
            "RMS ΔθB (A > 0°)".into(),
            arcsec(r, "rms_dB_arcsec", r.rms_d_b_arcsec),
            String::new(),
        ],
        [
            "max |mean ΔθA| per A detent (A > 0°) / |mean ΔθB| per B detent".into(),
            format!(
                "{} / {}",
                arcsec(r, "max_detent_dA_arcsec", r.max_detent_d_a_arcsec),
                arcsec(r, "max_detent_dB_arcsec", r.max_detent_d_b_arcsec)
            ),
            "the detents' own errors, noise averaged down".into(),
        ],
        [
            "standard uncertainty of one ΔθA / ΔθB (median)".into(),
            format!(
                "{:.3}″ / {:.3}″",
                r.median_u_d_a_arcsec, r.median_u_d_b_arcsec
            ),
            "first order, from the sphere fit's residual noise".into(),
        ],
        [
            "rotation centre O (mm)".into(),
            triple(r.rotation_centre, 4),
            format!("u = {} µm", triple(r.u_rotation_centre_um, 3)),
        ],
        [
            "radius (stylus length)".into(),
            match big_u(r, "radius_mm") {
                Some(u) => format!("{:.4} mm ± {:.3} µm", r.radius_mm, u * 1e3),
                None => format!("{:.4} mm", r.radius_mm),
            },
            format!("u = {:.3} µm", r.u_radius_um),
        ],
    ];
    if let (Some(n), Some(d)) = (r.nominal_radius_mm, r.radius_deviation_um) {
        rows.push([
            "radius − nominal".into(),
            match big_u(r, "radius_deviation_um") {
                Some(u) => format!("{d:+.1} ± {u:.1} µm"),
                None => format!("{d:+.1} µm"),
            },
            format!("nominal {n} mm"),
        ]);
    }
    let s = &r.sphere_fit;
    rows.extend([
        [
            "sphere fit residual RMS / max".into(),
            format!("{:.3} / {:.3} µm", s.residual_rms_um, s.residual_max_um),
            format!(
                "noise estimate {:.3} µm, condition {:.1}",
                s.noise_um, s.condition
            ),
        ],
        [
            "z (B axis) = unit(Q − O)".into(),
            triple(r.axes.z_b_axis, 7),
            format!(
                "Q = {} mm, {} positions",
                triple(r.axes.b_circle_centre, 4),
                r.axes.b_turn_positions
            ),
        ],
        [
            "y (A axis)".into(),
            triple(r.axes.y_a_axis, 7),
            format!(
                "from the B = 0° sweep, {} positions",
                r.axes.a_sweep_positions
            ),
        ],
        ["x = y × z".into(), triple(r.axes.x, 7), String::new()],
    ]);
    if let Some(t) = &r.tolerance {
        rows.push([
            format!("positions beyond ±{}″ by more than U", t.tolerance_arcsec),
            format!("{}", t.exceeding.len()),
            format!(
                "{} in ΔθA, {} in ΔθB; undecided (within U of ±{}″): {} in ΔθA, {} in ΔθB",
                t.count_d_a,
                t.count_d_b,
                t.tolerance_arcsec,
                t.inconclusive_d_a,
                t.inconclusive_d_b
            ),
        ]);
    }
    let rows: Vec<Vec<String>> = rows.into_iter().map(Vec::from).collect();
    h.table(Some("summary"), &["figure", "value", "note"], &rows);
}

fn maps(h: &mut Page, r: &Report, angles: &[Angles]) -> Result<()> {
    h.h2("maps", "Maps over the head positions");
    let levels = (r.grid.a_deg.as_slice(), r.grid.b_deg.as_slice());
    let tolerance = r.tolerance.as_ref().map(|t| t.tolerance_arcsec);
    let outlined = if tolerance.is_some() {
        " Outlined: beyond the tolerance by more than the position's U (2u)."
    } else {
        ""
    };
    h.figure(
        "plot-map-dA",
        &plot::map(
            "ΔθA = θA − A over the head positions",
            angles,
            |p| Some(p.d_a_arcsec),
            |p| Some(p.u_d_a_arcsec),
            levels,
            tolerance,
            ["ΔθA", "(arc-seconds)"],
        )?,
        &format!("One cell per position, scale ±L, L the largest |ΔθA| within 4 × its 90th percentile; ▲ ▼: beyond ±L (counted under the bar); at A = 0° the stylus's tilt from the B axis.{outlined}"),
    );
    h.figure(
        "plot-map-dB",
        &plot::map(
            "ΔθB = θB − B over the head positions",
            angles,
            |p| p.d_b_arcsec,
            |p| p.u_d_b_arcsec,
            levels,
            tolerance,
            ["ΔθB", "(arc-seconds)"],
        )?,
        &format!("One cell per position, scale ±L, L the largest |ΔθB| within 4 × its 90th percentile; ▲ ▼: beyond ±L (counted under the bar); grey: undefined at A = 0°; noisier at small A.{outlined}"),
    );
    Ok(())
}

fn curves(h: &mut Page, r: &Report, angles: &[Angles]) -> Result<()> {
    h.h2("curves", "Curves");
    let tolerance = r.tolerance.as_ref().map(|t| t.tolerance_arcsec);
    let dots: Vec<(f64, f64)> = angles.iter().map(|p| (p.a_deg, p.d_a_arcsec)).collect();
    let means: Vec<(f64, f64)> = r
        .a_detents
        .iter()
        .map(|d| (d.a_deg, d.mean_d_a_arcsec))
        .collect();
    h.figure(
        "plot-curve-dA",
        &plot::curve(
            "ΔθA against A",
            "commanded A (°)",
            &dots,
            &means,
            ["ΔθA of every position", "mean over the B positions"],
            tolerance,
        )?,
        "Dots: ΔθA of every position at that A; line: its mean over B per A detent.",
    );
    let dots: Vec<(f64, f64)> = angles
        .iter()
        .filter_map(|p| p.d_b_arcsec.map(|d| (wrap_deg(p.b_deg), d)))
        .collect();
    let means: Vec<(f64, f64)> = r
        .b_detents
        .iter()
        .map(|d| (d.b_deg, d.mean_d_b_arcsec))
        .collect();
    h.figure(
        "plot-curve-dB",
        &plot::curve(
            "ΔθB against B (A > 0°)",
            "commanded B (°)",
            &dots,
            &means,
            [
                "ΔθB of every position with A > 0°",
                "weighted mean over A (1/u²)",
            ],
            tolerance,
        )?,
        "Dots: ΔθB of every position with A > 0°; line: per B detent, the mean over A weighted by 1/u².",
    );
    Ok(())
}

fn detents(h: &mut Page, r: &Report) {
    h.h2("detents", "Per detent");
    let rows: Vec<Vec<String>> = r
        .a_detents
        .iter()
        .enumerate()
        .map(|(k, d)| {
            let cell = |name: &str, v: f64| {
                let u = big_u(r, &format!("a_detents.{k}.{name}"));
                format!(
                    "{v:+.3}{}",
                    u.map_or_else(String::new, |u| format!(" ± {u:.3}"))
                )
            };
            vec![
                format!("{}", d.a_deg),
                d.positions.to_string(),
                cell("mean_dA_arcsec", d.mean_d_a_arcsec),
                cell("min_dA_arcsec", d.min_d_a_arcsec),
                cell("max_dA_arcsec", d.max_d_a_arcsec),
            ]
        })
        .collect();
    h.table(
        Some("a-detents"),
        &["A (°)", "positions", "mean ΔθA (″)", "min (″)", "max (″)"],
        &rows,
    );
    let rows: Vec<Vec<String>> = r
        .b_detents
        .iter()
        .enumerate()
        .map(|(k, d)| {
            let u = big_u(r, &format!("b_detents.{k}.mean_dB_arcsec"));
            vec![
                format!("{}", d.b_deg),
                d.positions.to_string(),
                format!(
                    "{:+.3}{}",
                    d.mean_d_b_arcsec,
                    u.map_or_else(String::new, |u| format!(" ± {u:.3}"))
                ),
                format!("{:.3}", d.u_mean_d_b_arcsec),
            ]
        })
        .collect();
    h.table(
        Some("b-detents"),
        &[
            "B (°)",
            "positions (A > 0°)",
            "mean ΔθB (″)",
            "u if independent (″)",
        ],
        &rows,
    );
}

fn exceeding(h: &mut Page, r: &Report) {
    let Some(t) = &r.tolerance else {
        return;
    };
    h.h2(
        "tolerance",
        &format!("Positions beyond ±{}″", t.tolerance_arcsec),
    );
    h.paragraph(&format!(
        "Beyond by more than the position's U = 2u (ISO 14253-1: non-conformance proven); {} ΔθA and {} \
         ΔθB lie within U of the tolerance and are not counted either way.",
        t.inconclusive_d_a, t.inconclusive_d_b
    ));
    if t.exceeding.is_empty() {
        h.paragraph("None: no |ΔθA| or |ΔθB| is beyond the tolerance by more than its U.");
        return;
    }
    let rows: Vec<Vec<String>> = t
        .exceeding
        .iter()
        .take(EXCEEDING_SHOWN)
        .map(|e| {
            vec![
                format!("{}", e.a_deg),
                format!("{}", e.b_deg),
                report::uncertainty::plus_minus(e.d_a_arcsec, Some(e.expanded_d_a_arcsec), 3),
                e.d_b_arcsec.map_or_else(
                    || "—".into(),
                    |d| report::uncertainty::plus_minus(d, e.expanded_d_b_arcsec, 3),
                ),
                e.exceeds.clone(),
            ]
        })
        .collect();
    h.table(
        Some("exceeding"),
        &["A (°)", "B (°)", "ΔθA ± U (″)", "ΔθB ± U (″)", "beyond"],
        &rows,
    );
    if t.exceeding.len() > EXCEEDING_SHOWN {
        h.paragraph(&format!(
            "… and {} more, worst first, in report.json (tolerance.exceeding).",
            t.exceeding.len() - EXCEEDING_SHOWN
        ));
    }
}
