//! The point cloud `trinocular fit` reads: a CSV file with columns `x,y[,z]`
//! (mm) or a NIST `.ds` file ([`read_ds`](crate::read_ds)).

use std::path::Path;

use geom::Point3;
use serde::{Deserialize, Serialize};

use crate::{FormatError, Invalid, Record, Result, finite, read_csv, read_ds};

/// One row of an `x,y[,z]` CSV point file.
#[derive(Debug, Serialize, Deserialize)]
struct XyzRow {
    x: f64,
    y: f64,
    #[serde(default)]
    z: Option<f64>,
}

impl Record for XyzRow {
    const COLUMNS: &'static [&'static str] = &["x", "y"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("x", self.x)?;
        finite("y", self.y)?;
        if let Some(z) = self.z {
            finite("z", z)?;
        }
        Ok(())
    }
}

/// Read a point cloud: `.ds` by its extension, else CSV. A CSV without a `z`
/// column gives z = 0, or an error naming the first row when `need_z` (a
/// 3-D fit).
pub fn read_cloud(path: &Path, need_z: bool) -> Result<Vec<Point3<f64>>> {
    if path.extension().is_some_and(|e| e == "ds") {
        return read_ds(path);
    }
    read_csv::<XyzRow>(path)?
        .iter()
        .map(|r| match (r.record.z, need_z) {
            (Some(z), _) => Ok(Point3::new(r.record.x, r.record.y, z)),
            (None, false) => Ok(Point3::new(r.record.x, r.record.y, 0.0)),
            (None, true) => Err(FormatError::Row {
                path: path.to_path_buf(),
                line: r.line,
                column: Some("z".into()),
                message: "this fit needs 3-D points".into(),
            }),
        })
        .collect()
}
