//! `trinocular fit`: the point cloud it reads — a CSV file with columns
//! `x,y[,z]` (mm) or a NIST `.ds` file ([`read_ds`](crate::read_ds)) — and
//! the JSON object it prints ([`FitResult`]; keys in alphabetical order).

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

/// Residuals of a least-squares fit (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ResidualSummary {
    /// Root mean square.
    pub rms: f64,
    /// Smallest (signed).
    pub min: f64,
    /// Largest (signed).
    pub max: f64,
    /// Number of points.
    pub points: usize,
}

/// The element fitted, tagged by `element` (mm; directions and normals are
/// unit vectors).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "element", rename_all = "lowercase")]
pub enum FitResult {
    /// 2-D line through `point` along `direction` (orthogonal least squares).
    Line2d {
        /// A point of the line.
        point: [f64; 2],
        /// Its direction.
        direction: [f64; 2],
        /// Orthogonal residuals.
        residuals: ResidualSummary,
    },
    /// 3-D line.
    Line3d {
        /// A point of the line.
        point: [f64; 3],
        /// Its direction.
        direction: [f64; 3],
        /// Orthogonal residuals.
        residuals: ResidualSummary,
    },
    /// Plane.
    Plane {
        /// A point of the plane.
        point: [f64; 3],
        /// Its normal.
        normal: [f64; 3],
        /// Signed distances.
        residuals: ResidualSummary,
    },
    /// Circle in space.
    Circle {
        /// Centre.
        centre: [f64; 3],
        /// Normal of its plane.
        normal: [f64; 3],
        /// Diameter.
        diameter: f64,
        /// Radial residuals.
        residuals: ResidualSummary,
    },
    /// Sphere.
    Sphere {
        /// Centre.
        centre: [f64; 3],
        /// Diameter.
        diameter: f64,
        /// Radial residuals.
        residuals: ResidualSummary,
    },
    /// Cylinder.
    Cylinder {
        /// A point of the axis.
        point: [f64; 3],
        /// Direction of the axis.
        direction: [f64; 3],
        /// Diameter.
        diameter: f64,
        /// Radial residuals.
        residuals: ResidualSummary,
    },
    /// Straightness of an (x, y) profile.
    Straightness {
        /// Range of the residuals from the least-squares line.
        lsq: f64,
        /// Minimum-zone width.
        min_zone: f64,
        /// Direction of the minimum-zone lines.
        direction: [f64; 2],
    },
    /// Flatness of (x, y, z) points.
    Flatness {
        /// Range of the vertical residuals from the least-squares plane.
        lsq: f64,
        /// The least-squares plane z = a·x + b·y + c: [a, b, c].
        lsq_plane: [f64; 3],
        /// Minimum-zone width (vertical).
        min_zone: f64,
        /// Centre plane of the minimum zone: [a, b, c].
        min_zone_plane: [f64; 3],
    },
}

impl FitResult {
    /// The printed form: pretty JSON, keys in alphabetical order (as the
    /// command has always printed them).
    pub fn to_json(&self) -> serde_json::Result<String> {
        serde_json::to_string_pretty(&serde_json::to_value(self)?)
    }
}
