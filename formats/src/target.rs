//! Calibration target (`target.csv`), image correspondences (`id,u,v`) and
//! the per-point residuals of a calibration (`<stem>.residuals.csv`).

use std::collections::HashMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::table::{Invalid, Record, Row, finite, read_csv, standard_uncertainty};
use crate::{FormatError, Result};

/// One marker of the 3-D calibration target (target frame, mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetRow {
    /// Marker id.
    pub id: u32,
    /// x (mm).
    pub x: f64,
    /// y (mm).
    pub y: f64,
    /// z (mm).
    pub z: f64,
    /// Marker diameter (mm), when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub diameter: Option<f64>,
    /// Standard uncertainty of each of the marker's coordinates (mm), when
    /// known (the target's own calibration, e.g. a CMM's); it enters the
    /// cameras' parameter covariance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u_mm: Option<f64>,
}

impl Record for TargetRow {
    const COLUMNS: &'static [&'static str] = &["id", "x", "y", "z"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("x", self.x)?;
        finite("y", self.y)?;
        finite("z", self.z)?;
        if let Some(d) = self.diameter {
            finite("diameter", d)?;
            if d <= 0.0 {
                return Err(Invalid::new(
                    "diameter",
                    format!("diameter {d} mm is not positive"),
                ));
            }
        }
        standard_uncertainty("u_mm", self.u_mm)
    }
}

/// A detected marker and the target id it images: `id,u,v` (pixels).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CorrespondenceRow {
    /// Target marker id.
    pub id: u32,
    /// Image u (px, centre of the top-left pixel = 0).
    pub u: f64,
    /// Image v (px).
    pub v: f64,
}

impl Record for CorrespondenceRow {
    const COLUMNS: &'static [&'static str] = &["id", "u", "v"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("u", self.u)?;
        finite("v", self.v)
    }
}

/// One row of a calibration's `<stem>.residuals.csv`: a marker seen by a
/// camera, its target and image coordinates and the residual of the fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualRow {
    /// Camera id.
    pub camera: u8,
    /// The target's pose, for a calibration over views (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pose: Option<u32>,
    /// Target marker id.
    pub id: u32,
    /// Target x (mm).
    pub x: f64,
    /// Target y (mm).
    pub y: f64,
    /// Target z (mm).
    pub z: f64,
    /// Observed image u (px).
    pub u: f64,
    /// Observed image v (px).
    pub v: f64,
    /// Predicted − observed u (px).
    pub du: f64,
    /// Predicted − observed v (px).
    pub dv: f64,
    /// Rejected as an outlier (not used in the final fit).
    pub outlier: bool,
}

/// Read `target.csv` (or an `id,u,v` file): every row, and each marker id
/// once; errors name the file, line and column.
pub fn read_target(path: &Path) -> Result<Vec<Row<TargetRow>>> {
    let rows: Vec<Row<TargetRow>> = read_csv(path)?;
    unique_ids(&rows, |r| r.id, path)?;
    Ok(rows)
}

/// Read an `id,u,v` correspondence file: every row, each id once.
pub fn read_correspondences(path: &Path) -> Result<Vec<Row<CorrespondenceRow>>> {
    let rows: Vec<Row<CorrespondenceRow>> = read_csv(path)?;
    unique_ids(&rows, |r| r.id, path)?;
    Ok(rows)
}

/// Fails on the first row whose id an earlier row has.
fn unique_ids<T>(rows: &[Row<T>], id: impl Fn(&T) -> u32, path: &Path) -> Result<()> {
    let mut first: HashMap<u32, u64> = HashMap::with_capacity(rows.len());
    for r in rows {
        if let Some(line) = first.insert(id(&r.record), r.line) {
            return Err(FormatError::Row {
                path: path.to_path_buf(),
                line: r.line,
                column: Some("id".into()),
                message: format!(
                    "marker id {} appears twice (first on line {line})",
                    id(&r.record)
                ),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_marker_id_twice_is_named_with_both_lines() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("target.csv");
        std::fs::write(&path, "id,x,y,z\n1,0,0,0\n2,1,0,0\n1,0,1,0\n").unwrap();
        let e = read_target(&path).unwrap_err().to_string();
        assert!(
            e.contains(
                "target.csv: line 4, column 'id': marker id 1 appears twice (first on line 2)"
            ),
            "{e}"
        );
    }
}
