//! Bad input is an error naming the row (file line, the header is line 1)
//! and the column: empty file, header only, missing columns, NaN, text in a
//! number, mixed units, duplicates, a target commanded at two positions. A
//! target with one run, or without a direction, is no error: the line's
//! positioning leaves that direction out and says why.

#![allow(clippy::unwrap_used)]

mod common;

use std::path::{Path, PathBuf};

use common::LineModel;
use evaluate::{Options, evaluate_file};
use formats::Axis;

/// A small valid campaign as CSV text: X, 5 targets, 2 runs, 3 spheres.
fn good_text() -> String {
    let mut l = LineModel::new(Axis::X, [0.0, 0.0], 5, 30.0, 2, 0.3);
    l.captures = 2;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("points.csv");
    common::write_points(&path, &l.rows());
    std::fs::read_to_string(path).unwrap()
}

/// Write `text` to a fresh points.csv and evaluate it; the error message.
fn error_of(text: &str) -> (String, PathBuf, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("points.csv");
    std::fs::write(&path, text).unwrap();
    let e = evaluate_file(&path, &Options::default())
        .unwrap_err()
        .to_string();
    (e, path, dir)
}

/// Assert the message names `path`, `line` and `column`.
fn names(e: &str, path: &Path, line: u64, column: &str) {
    let want = format!("{}: line {line}, column '{column}'", path.display());
    assert!(e.contains(&want), "expected «{want}» in «{e}»");
}

/// The index (0-based, header 0) of the first of `lines` matching `pred`.
fn find(lines: &[String], pred: impl Fn(&[&str]) -> bool) -> usize {
    lines
        .iter()
        .position(|l| pred(&l.split(',').collect::<Vec<_>>()))
        .unwrap()
}

fn lines(text: &str) -> Vec<String> {
    text.lines().map(str::to_string).collect()
}

fn join(lines: &[String]) -> String {
    lines.join("\n") + "\n"
}

#[test]
fn good_file_evaluates() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("points.csv");
    std::fs::write(&path, good_text()).unwrap();
    let report = evaluate_file(&path, &Options::default()).unwrap();
    assert!(report.axes.x.is_some());
}

#[test]
fn empty_file_and_header_only() {
    let (e, path, _d) = error_of("");
    names(&e, &path, 1, "axis");
    assert!(e.contains("empty"), "{e}");
    let header = lines(&good_text())[0].clone();
    let (e, path, _d) = error_of(&(header + "\n"));
    names(&e, &path, 2, "axis");
    assert!(e.contains("no data rows"), "{e}");
}

#[test]
fn missing_column() {
    let text: String = good_text()
        .lines()
        .map(|l| {
            let mut fields: Vec<&str> = l.split(',').collect();
            fields.remove(13);
            fields.join(",") + "\n"
        })
        .collect();
    // The column residual_px (the 14th) is gone.
    let (e, path, _d) = error_of(&text);
    names(&e, &path, 1, "residual_px");
    assert!(e.contains("missing"), "{e}");
}

#[test]
fn nan_and_text_in_numbers() {
    let mut l = lines(&good_text());
    let fields: Vec<String> = l[7].split(',').map(str::to_string).collect();
    let mut bad = fields.clone();
    bad[10] = "NaN".into(); // y
    l[7] = bad.join(",");
    let (e, path, _d) = error_of(&join(&l));
    names(&e, &path, 8, "y");
    let mut bad = fields;
    bad[9] = "12,5".replace(',', ";"); // x
    l[7] = bad.join(",");
    let (e, path, _d) = error_of(&join(&l));
    names(&e, &path, 8, "x");
}

/// Evaluate `text` as a points.csv: the report.
fn report_of(text: &str) -> evaluate::Report {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("points.csv");
    std::fs::write(&path, text).unwrap();
    evaluate_file(&path, &Options::default()).unwrap()
}

/// The one line's positioning and its reason for leaving figures out.
fn positioning_of(report: &evaluate::Report) -> (&evaluate::PositioningReport, &str) {
    let p = &report.axes.x.as_ref().unwrap().main.positioning;
    let reason = p
        .left_out
        .as_deref()
        .unwrap_or_else(|| panic!("no reason: {p:?}"));
    assert!(
        report.warnings.iter().any(|w| w.contains(reason)),
        "{:?}",
        report.warnings
    );
    (p, reason)
}

#[test]
fn a_target_with_one_run() {
    // Drop run 2 of target 3 in the − direction: run 1 is left alone there.
    // Was refused; now the ↓ figures (and those needing both directions) are
    // left out, with the reason, and the ↑ figures given.
    let all = lines(&good_text());
    let kept: Vec<String> = all
        .iter()
        .filter(|l| !l.starts_with("X,-,2,3,"))
        .cloned()
        .collect();
    assert!(kept.len() < all.len());
    let report = report_of(&join(&kept));
    let (p, reason) = positioning_of(&report);
    assert!(
        reason.contains("target 3") && reason.contains("at least 2") && reason.contains("run 1"),
        "{reason}"
    );
    assert!(p.a_up_um.is_some() && p.a_down_um.is_none() && p.a_um.is_none());
    assert_eq!(p.targets[3].runs_down_um.len(), 1);
}

#[test]
fn a_direction_missing_at_a_target() {
    // Target 2 loses its ↑ approaches: was refused; now the ↑ figures are
    // left out, with the reason, and the ↓ figures given.
    let all = lines(&good_text());
    let kept: Vec<String> = all
        .iter()
        .filter(|l| !(l.starts_with("X,+,1,2,") || l.starts_with("X,+,2,2,")))
        .cloned()
        .collect();
    let report = report_of(&join(&kept));
    let (p, reason) = positioning_of(&report);
    assert!(reason.contains("target 2 has no ↑ run"), "{reason}");
    assert!(p.a_down_um.is_some() && p.a_up_um.is_none() && p.b_um.is_none());
}

#[test]
fn mixed_units() {
    let mut l = lines(&good_text());
    // A row of target 4 (x = +60 mm) written in micrometres.
    let i = find(&l, |f| f[0] == "X" && f[3] == "4" && f[8] == "B");
    let mut f: Vec<String> = l[i].split(',').map(str::to_string).collect();
    for v in &mut f[9..12] {
        *v = (v.parse::<f64>().unwrap() * 1000.0).to_string();
    }
    l[i] = f.join(",");
    let (e, path, _d) = error_of(&join(&l));
    names(&e, &path, i as u64 + 1, "x");
    assert!(e.contains("1000") && e.contains("units"), "{e}");

    // A commanded position in micrometres.
    let mut l = lines(&good_text());
    let i = find(&l, |f| f[3] == "0" && f[8] == "C");
    let mut f: Vec<String> = l[i].split(',').map(str::to_string).collect();
    f[5] = (f[5].parse::<f64>().unwrap() * 1000.0).to_string();
    l[i] = f.join(",");
    let (e, path, _d) = error_of(&join(&l));
    names(&e, &path, i as u64 + 1, "nominal_x");
    assert!(e.contains("units"), "{e}");
}

/// A file in µm throughout agrees with itself; its coordinates are beyond
/// any machine. A value like 1e300 is not a length at all.
#[test]
fn a_file_in_micrometres_and_absurd_values() {
    let mut l = lines(&good_text());
    for line in l.iter_mut().skip(1) {
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        for i in (5..8).chain(9..12) {
            f[i] = (f[i].parse::<f64>().unwrap() * 1000.0).to_string();
        }
        *line = f.join(",");
    }
    let (e, path, _d) = error_of(&join(&l));
    // The first row: target 0 at x = −60 mm commanded, now −60000.
    names(&e, &path, 2, "nominal_x");
    assert!(e.contains("= -60000 mm") && e.contains("in µm?"), "{e}");

    let mut l = lines(&good_text());
    let i = find(&l, |f| f[3] == "2" && f[8] == "A");
    let mut f: Vec<String> = l[i].split(',').map(str::to_string).collect();
    f[11] = "1e300".into();
    l[i] = f.join(",");
    let (e, path, _d) = error_of(&join(&l));
    names(&e, &path, i as u64 + 1, "z");
    assert!(e.contains("1e300"), "{e}");
}

#[test]
fn duplicates_and_inconsistent_targets() {
    let mut l = lines(&good_text());
    let row = l[5].clone();
    l.push(row);
    let n = l.len() as u64;
    let (e, path, _d) = error_of(&join(&l));
    names(&e, &path, n, "capture");
    assert!(e.contains("twice") && e.contains("line 6"), "{e}");

    // Half a millimetre off: not a unit slip, but a target commanded at two positions.
    let mut l = lines(&good_text());
    let i = find(&l, |f| f[1] == "-" && f[3] == "1");
    let mut f: Vec<String> = l[i].split(',').map(str::to_string).collect();
    f[5] = (f[5].parse::<f64>().unwrap() + 0.5).to_string();
    l[i] = f.join(",");
    let (e, path, _d) = error_of(&join(&l));
    names(&e, &path, i as u64 + 1, "nominal_x");
    assert!(e.contains("target 1"), "{e}");
}

#[test]
fn in_memory_rows_are_numbered_as_in_a_file() {
    let mut l = LineModel::new(Axis::X, [0.0, 0.0], 4, 30.0, 2, 0.3);
    l.captures = 1;
    let mut rows = l.rows();
    rows[4].z = f64::NAN;
    let e = evaluate::evaluate(&rows, &Options::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("points: line 6, column 'z'"), "{e}");
}
