//! `trinocular evaluate` on a flatness grid as it is measured in practice: a
//! main X line with several runs each way and off-axis X lines (y = ∓50 mm)
//! with a single run each way (runs 51 and 151). It exits 0; the main line's
//! figures are those of the main line evaluated alone; every line has its
//! straightness, the single-run lines the value built into their points; the
//! flatness covers all three lines; the single-run lines' positioning is left
//! out with its reason in report.json, report.html and a warning on stderr.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::Path;

use common::{ok, read, s, trinocular};
use formats::{Axis, Direction, InstantKey, PointRow};
use serde_json::Value;

/// Commanded X of the targets (mm).
const TARGETS: [f64; 5] = [-50.0, -25.0, 0.0, 25.0, 50.0];
/// A profile orthogonal to 1 and to the targets (and to [`BOW`]): its
/// least-squares line is zero, its range 4 and, being symmetric, its minimum
/// zone 4 too.
const SAG: [f64; 5] = [2.0, -1.0, -2.0, -1.0, 2.0];
/// Another such profile: range and minimum zone 10.
const BOW: [f64; 5] = [1.0, -4.0, 6.0, -4.0, 1.0];
/// 1 µm in mm.
const UM: f64 = 1e-3;

/// One X line: off-axis y, its runs, positional error per target (mm), the
/// reversal, the run scatter and the straightness in Y and Z (µm, scaling
/// [`SAG`] and [`BOW`]).
struct Line {
    y: f64,
    runs: Vec<u32>,
    p: [f64; 5],
    reversal: f64,
    scatter: f64,
    sag_um: f64,
    bow_um: f64,
}

impl Line {
    /// Sphere A's rows, two captures per approach (captures agree).
    fn rows(&self) -> Vec<PointRow> {
        let mut rows = Vec::new();
        let n = self.runs.len() as f64;
        for (j, &run) in self.runs.iter().enumerate() {
            // Run pattern of mean 0.
            let z = j as f64 - (n - 1.0) / 2.0;
            for (direction, sign) in [(Direction::Up, 1.0), (Direction::Down, -1.0)] {
                for (k, &c) in TARGETS.iter().enumerate() {
                    let along = self.p[k] + sign * self.reversal / 2.0 + self.scatter * z;
                    for capture in 1..=2 {
                        rows.push(PointRow::new(
                            InstantKey::new(
                                (Axis::X, direction),
                                [run, k as u32, capture],
                                [c, self.y, 0.0],
                            ),
                            "A",
                            [
                                c + along,
                                self.y + self.sag_um * UM * SAG[k],
                                self.bow_um * UM * BOW[k],
                            ],
                            "2+3",
                            0.1,
                        ));
                    }
                }
            }
        }
        rows
    }
}

/// The main line (y = 0, three runs each way) and the two single-run lines.
fn grid() -> [Line; 3] {
    [
        Line {
            y: -50.0,
            runs: vec![51],
            p: [0.0; 5],
            reversal: 3.0 * UM,
            scatter: 0.0,
            sag_um: 1.0,
            bow_um: 0.5,
        },
        Line {
            y: 0.0,
            runs: vec![1, 2, 3],
            // Orthogonal to SAG, so that the fitted axis is X.
            p: [0.0, 1.5 * UM, 2.0 * UM, 1.0 * UM, 3.25 * UM],
            reversal: 2.0 * UM,
            scatter: 0.4 * UM,
            sag_um: 0.5,
            bow_um: 0.0,
        },
        Line {
            y: 50.0,
            runs: vec![151],
            p: [0.0; 5],
            reversal: 2.5 * UM,
            scatter: 0.0,
            sag_um: 1.5,
            bow_um: -0.8,
        },
    ]
}

/// Run `trinocular evaluate` on `rows`; its report.json, report.html and stderr.
fn evaluate(dir: &Path, name: &str, rows: &[PointRow]) -> (Value, String, String) {
    let points = dir.join(format!("{name}.csv"));
    formats::write_csv(&points, rows).unwrap();
    let out = dir.join(name);
    let err = ok(&trinocular(&[
        "evaluate",
        "--points",
        s(&points),
        "--out",
        s(&out),
    ]));
    let json = serde_json::from_slice(&read(&out.join("report.json"))).unwrap();
    let html = String::from_utf8(read(&out.join("report.html"))).unwrap();
    (json, html, err)
}

fn close(what: &str, got: &Value, want: f64) {
    let got = got
        .as_f64()
        .unwrap_or_else(|| panic!("{what}: not a number: {got}"));
    assert!((got - want).abs() < 1e-6, "{what}: got {got}, want {want}");
}

#[test]
fn single_run_lines_are_evaluated_beside_the_main_line() {
    let dir = tempfile::tempdir().unwrap();
    let lines = grid();
    let all: Vec<PointRow> = lines.iter().flat_map(Line::rows).collect();
    let (json, html, err) = evaluate(dir.path(), "grid", &all);
    let (alone, _, _) = evaluate(dir.path(), "main", &lines[1].rows());

    // The main line (most runs) has the figures it has alone.
    let x = &json["axes"]["X"];
    let lines_json = x["lines"].as_array().unwrap();
    assert_eq!(lines_json.len(), 3);
    let main = &alone["axes"]["X"];
    assert_eq!(x["off_axis"]["y"], 0.0);
    for key in ["positioning", "straightness", "direction", "targets"] {
        assert_eq!(x[key], main[key], "axes.X.{key}");
        assert_eq!(lines_json[1][key], main[key], "axes.X.lines[1].{key}");
    }
    assert!(x["positioning"]["A_um"].is_f64() && x["positioning"].get("left_out").is_none());

    // Every line's straightness is the profile built into it.
    for (l, got) in lines.iter().zip(lines_json) {
        let at = format!("line y = {}", l.y);
        for (dir, um) in [("Y", 4.0 * l.sag_um.abs()), ("Z", 10.0 * l.bow_um.abs())] {
            let s = &got["straightness"][dir];
            close(&format!("{at}: straightness {dir} LSQ"), &s["lsq_um"], um);
            close(
                &format!("{at}: straightness {dir} zone"),
                &s["min_zone_um"],
                um,
            );
        }
    }

    // The single-run lines: no positioning figure, the reason instead.
    for i in [0, 2] {
        let p = &lines_json[i]["positioning"];
        for key in [
            "A_um",
            "A_up_um",
            "E_um",
            "E_down_um",
            "R_um",
            "B_um",
            "M_um",
        ] {
            assert!(p.get(key).is_none(), "lines[{i}].positioning.{key}: {p}");
        }
        assert!(p.get("seed_3sigma_um").is_none(), "{p}");
        let reason = p["left_out"].as_str().unwrap_or_else(|| panic!("{p}"));
        assert!(reason.contains("at least 2"), "{reason}");
        let run = lines[i].runs[0].to_string();
        assert!(reason.contains(&run), "{reason}");
        // Said on stderr, as a warning naming the line, and on the page.
        let warning = err
            .lines()
            .find(|w| w.contains(&format!("y = {}", lines[i].y)))
            .unwrap_or_else(|| panic!("no warning for line {i}: {err}"));
        assert!(warning.starts_with("trinocular: warning: "), "{warning}");
        assert!(warning.contains(reason), "{warning}");
        assert!(html.contains(reason), "{reason} not in report.html");
    }

    // Flatness over all 15 points: the profiles are orthogonal to x, y and
    // each other, so the least-squares plane is z = 0 and the flatness the
    // range of the heights, 0.5·6 − (−0.8·6) = 8 µm.
    let f = &json["flatness"];
    assert_eq!(f["points"].as_array().unwrap().len(), 15);
    close("flatness LSQ", &f["lsq_um"], 8.0);
    assert!(f["min_zone_um"].as_f64().unwrap() <= 8.0 + 1e-9);
}
