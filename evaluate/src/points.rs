//! Reading `points.csv` and the checks that need more than one row: duplicate
//! instants and mixed units. Every error names the source, the row's line
//! (the header is line 1) and the column.

use std::collections::HashMap;
use std::path::Path;

use formats::{Axis, PointRow, Record, Row};

use crate::{EvaluateError, Result, RowProblem};

/// A row and where it came from.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Located<'a> {
    /// 1-based line in the source (the header is line 1).
    pub line: u64,
    /// The row.
    pub row: &'a PointRow,
}

/// A row is in mixed units when its measured position lies farther than this
/// from the one expected from its commanded position (mm) …
pub const UNITS_TOLERANCE_MM: f64 = 1.0;
/// … plus this fraction of the commanded travel of its axis: room for a
/// world frame turned by a few mrad against the machine's.
pub const UNITS_TOLERANCE_OF_TRAVEL: f64 = 0.02;
/// The factor between the units a stray row may have used and millimetres (µm, m).
pub(crate) const UNIT_FACTOR: f64 = 1000.0;
/// Largest coordinate (mm), measured or commanded: 10 m from the origin is
/// beyond the travel of any machine a rig of cameras measures, so a value
/// past it is a length in µm (a whole file in µm puts a 150 mm travel at
/// 150 000) or not a length at all (1e300).
pub const MAX_COORDINATE_MM: f64 = 10_000.0;

/// Read `points.csv`: the file contract's checks (header, parse, NaN, with
/// line and column) plus an empty file reported at line 1.
pub fn read_points(path: &Path) -> Result<Vec<Row<PointRow>>> {
    let bytes = std::fs::read(path).map_err(|e| EvaluateError::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(EvaluateError::Row {
            source_name: path.display().to_string(),
            line: 1,
            column: PointRow::COLUMNS[0],
            problem: Box::new(RowProblem::EmptyFile),
        });
    }
    Ok(formats::read_csv_from(bytes.as_slice(), path)?)
}

/// A row error.
pub(crate) fn row_error(
    source: &str,
    line: u64,
    column: &'static str,
    problem: RowProblem,
) -> EvaluateError {
    EvaluateError::Row {
        source_name: source.into(),
        line,
        column,
        problem: Box::new(problem),
    }
}

/// Name of the nominal column of world axis `a` (`nominal_x`, …).
pub(crate) fn nominal_column(a: Axis) -> &'static str {
    ["nominal_x", "nominal_y", "nominal_z"][a.index()]
}

/// Name of the measured column of world axis `a` (`x`, …).
pub(crate) fn measured_column(a: Axis) -> &'static str {
    ["x", "y", "z"][a.index()]
}

/// Every row on its own (the file contract: finite numbers, run and capture
/// ≥ 1, a sphere name), then no data rows, duplicates and mixed units.
pub(crate) fn check(rows: &[Located<'_>], source: &str) -> Result<()> {
    if rows.is_empty() {
        return Err(row_error(
            source,
            2,
            PointRow::COLUMNS[0],
            RowProblem::HeaderOnly,
        ));
    }
    for r in rows {
        r.row.validate().map_err(|inv| {
            row_error(
                source,
                r.line,
                inv.column,
                RowProblem::Contract(inv.message),
            )
        })?;
        check_reach(r, source, MAX_COORDINATE_MM * UNIT_FACTOR)?;
    }
    check_duplicates(rows, source)?;
    check_units(rows, source)?;
    // Rows that agree with each other may all be in the wrong unit.
    rows.iter()
        .try_for_each(|r| check_reach(r, source, MAX_COORDINATE_MM))
}

/// Every coordinate within ±`limit` mm: [`MAX_COORDINATE_MM`], or 1000 times
/// that for values that cannot be a length in any unit (checked first).
fn check_reach(r: &Located<'_>, source: &str, limit: f64) -> Result<()> {
    let p = r.row;
    for (column, value) in [
        ("nominal_x", p.nominal_x),
        ("nominal_y", p.nominal_y),
        ("nominal_z", p.nominal_z),
        ("x", p.x),
        ("y", p.y),
        ("z", p.z),
    ] {
        if value.abs() > limit {
            let problem = if value.abs() <= MAX_COORDINATE_MM * UNIT_FACTOR {
                RowProblem::BeyondTravel { column, value }
            } else {
                RowProblem::NotALength { column, value }
            };
            return Err(row_error(source, r.line, column, problem));
        }
    }
    Ok(())
}

/// Each (axis, direction, run, target, capture, sphere, nominal) once.
fn check_duplicates(rows: &[Located<'_>], source: &str) -> Result<()> {
    let mut seen: HashMap<_, u64> = HashMap::with_capacity(rows.len());
    for r in rows {
        let p = r.row;
        let key = (
            p.axis,
            p.direction,
            p.run,
            p.target,
            p.capture,
            p.sphere.as_str(),
            p.nominal().map(f64::to_bits),
        );
        if let Some(first) = seen.insert(key, r.line) {
            return Err(row_error(
                source,
                r.line,
                "capture",
                RowProblem::Duplicate {
                    sphere: p.sphere.clone(),
                    axis: p.axis,
                    direction: p.direction,
                    run: p.run,
                    target: p.target,
                    capture: p.capture,
                    first_line: first,
                },
            ));
        }
    }
    Ok(())
}

/// Median of the values (upper median for an even count); `values` non-empty.
fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Mixed units: per axis moved and sphere, the offset `measured − commanded`
/// is the sphere's place on the table plus micrometre-level errors (and
/// whatever a slightly turned world frame adds over the travel). A row whose
/// offset differs from the median offset of its group by more than
/// [`UNITS_TOLERANCE_MM`] + [`UNITS_TOLERANCE_OF_TRAVEL`] × travel in any
/// coordinate is an error; the column named is the value that, divided or
/// multiplied by 1000, would fit (else the measured coordinate farthest off).
fn check_units(rows: &[Located<'_>], source: &str) -> Result<()> {
    let mut groups: HashMap<(Axis, &str), Vec<Located<'_>>> = HashMap::new();
    for r in rows {
        groups
            .entry((r.row.axis, r.row.sphere.as_str()))
            .or_default()
            .push(*r);
    }
    let mut groups: Vec<_> = groups.into_iter().collect();
    groups.sort_by_key(|(_, g)| g.first().map_or(0, |r| r.line));
    let mut worst: Option<(u64, &'static str, RowProblem)> = None;
    for ((axis, _), group) in &groups {
        let nominal_axis: Vec<f64> = group
            .iter()
            .map(|r| r.row.nominal()[axis.index()])
            .collect();
        let travel = nominal_axis
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max)
            - nominal_axis.iter().copied().fold(f64::INFINITY, f64::min);
        let tolerance = UNITS_TOLERANCE_MM + UNITS_TOLERANCE_OF_TRAVEL * travel;
        let mut offset = [0.0; 3];
        for (c, o) in offset.iter_mut().enumerate() {
            let mut v: Vec<f64> = group
                .iter()
                .map(|r| r.row.position()[c] - r.row.nominal()[c])
                .collect();
            *o = median(&mut v);
        }
        for r in group {
            let (measured, nominal) = (r.row.position(), r.row.nominal());
            let Some((c, off)) = (0..3)
                .map(|c| (c, (measured[c] - nominal[c] - offset[c]).abs()))
                .filter(|(_, off)| *off > tolerance)
                .max_by(|a, b| a.1.total_cmp(&b.1))
            else {
                continue;
            };
            let world = Axis::from_index(c).unwrap_or(Axis::X);
            let expected = nominal[c] + offset[c];
            let fits = |v: f64, e: f64| {
                [v / UNIT_FACTOR, v * UNIT_FACTOR]
                    .iter()
                    .any(|s| (s - e).abs() <= tolerance)
            };
            let (column, problem) = if fits(measured[c], expected) {
                let column = measured_column(world);
                let ratio = ratio_word(measured[c], expected);
                (
                    column,
                    RowProblem::MeasuredScaled {
                        column,
                        value: measured[c],
                        ratio,
                        expected,
                        tolerance,
                    },
                )
            } else if fits(nominal[c], measured[c] - offset[c]) {
                let column = nominal_column(world);
                let expected = measured[c] - offset[c];
                (
                    column,
                    RowProblem::NominalScaled {
                        column,
                        value: nominal[c],
                        ratio: ratio_word(nominal[c], expected),
                        expected,
                    },
                )
            } else {
                let column = measured_column(world);
                (
                    column,
                    RowProblem::FarFromExpected {
                        column,
                        value: measured[c],
                        off,
                        expected,
                        sphere: r.row.sphere.clone(),
                        axis: *axis,
                        tolerance,
                    },
                )
            };
            if worst.as_ref().is_none_or(|w| r.line < w.0) {
                worst = Some((r.line, column, problem));
            }
            break;
        }
    }
    match worst {
        Some((line, column, message)) => Err(row_error(source, line, column, message)),
        None => Ok(()),
    }
}

/// "1000" or "1/1000", whichever `value / expected` is nearer.
fn ratio_word(value: f64, expected: f64) -> &'static str {
    if value.abs() >= expected.abs() {
        "1000"
    } else {
        "1/1000"
    }
}
