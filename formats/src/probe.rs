//! Files of the probe-based methods (`trinocular probe …`): inputs and
//! output tables of each method, and what their rows share.

pub mod indexing;
pub mod rotary;
pub mod tracer;
pub mod volumetric;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::FormatError;
use crate::table::{Invalid, Record, finite};

/// Fails unless every value is finite, naming the first column that is not.
pub(crate) fn finite_all(values: &[(&'static str, f64)]) -> Result<(), Invalid> {
    values.iter().try_for_each(|&(c, v)| finite(c, v))
}

/// The error of a row of `path` at `line`, `column`.
pub(crate) fn row_error(path: &Path, line: u64, column: &str, message: String) -> FormatError {
    FormatError::Row {
        path: path.to_path_buf(),
        line,
        column: Some(column.to_string()),
        message,
    }
}

/// Fails on an empty (or blank) name.
pub(crate) fn name(column: &'static str, value: &str) -> Result<(), Invalid> {
    if value.trim().is_empty() {
        Err(Invalid::new(column, "empty name"))
    } else {
        Ok(())
    }
}

/// Fails the test unless the error text `e` contains each of `parts`.
#[cfg(test)]
pub(crate) fn assert_mentions(e: &str, parts: &[&str]) {
    for p in parts {
        assert!(e.contains(p), "{p:?} not in: {e}");
    }
}

/// [`finite_all`] of the listed `f64` fields of a row, each column named
/// like its field: `finite_fields!(self, x, y, z)`.
macro_rules! finite_fields {
    ($row:expr, $($field:ident),+ $(,)?) => {
        $crate::probe::finite_all(&[$((stringify!($field), $row.$field)),+])
    };
}
pub(crate) use finite_fields;

/// A point and a displacement at it (mm): a row of `corrected.csv` of the
/// tracer (a query point and its correction by trilinear interpolation in the
/// grid cell that holds it) and of `volumetric.csv` (carriage positions and
/// the volumetric error there, workpiece frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PointDisplacementRow {
    /// x (mm).
    pub x: f64,
    /// y (mm).
    pub y: f64,
    /// z (mm).
    pub z: f64,
    /// Displacement along x (mm).
    pub dx: f64,
    /// Displacement along y (mm).
    pub dy: f64,
    /// Displacement along z (mm).
    pub dz: f64,
}

impl Record for PointDisplacementRow {
    const COLUMNS: &'static [&'static str] = &["x", "y", "z", "dx", "dy", "dz"];

    fn validate(&self) -> Result<(), Invalid> {
        finite_fields!(self, x, y, z, dx, dy, dz)
    }
}
