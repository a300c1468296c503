//! Calibration views (`views.csv`, docs/formats.md): one row per image of
//! the target, `image,camera,pose`, optionally the machine's commanded move
//! of the target for that pose; and the per-view residuals of a
//! calibration over views (`<stem>.views.csv`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::table::{Invalid, Record, Row, finite, read_csv};
use crate::{FormatError, Result};

/// One view: a camera's image (or `id,u,v` correspondence file) of the
/// target at one pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewRow {
    /// The image or correspondence file, relative to `views.csv`.
    pub image: String,
    /// Camera id (≥ 1).
    pub camera: u8,
    /// Target placement: views of one pose saw the target in one place.
    pub pose: u32,
    /// The machine's commanded move of the target for this pose (mm), a
    /// start value where the machine moves the target.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_x: Option<f64>,
    /// y of the move (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_y: Option<f64>,
    /// z of the move (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_z: Option<f64>,
}

impl Record for ViewRow {
    const COLUMNS: &'static [&'static str] = &["image", "camera", "pose"];
    const OPTIONAL_COLUMNS: &'static [&'static str] = &["offset_x", "offset_y", "offset_z"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        if self.image.trim().is_empty() {
            return Err(Invalid::new("image", "no file named"));
        }
        if self.camera == 0 {
            return Err(Invalid::new("camera", "camera ids start at 1"));
        }
        for (column, v) in [
            ("offset_x", self.offset_x),
            ("offset_y", self.offset_y),
            ("offset_z", self.offset_z),
        ] {
            if let Some(v) = v {
                finite(column, v)?;
            }
        }
        Ok(())
    }
}

impl ViewRow {
    /// The file, resolved against the folder of `views`.
    pub fn path(&self, views: &Path) -> PathBuf {
        views
            .parent()
            .unwrap_or_else(|| Path::new(""))
            .join(&self.image)
    }
}

/// Read `views.csv`: every row checked, at least one, each camera at most
/// once per pose; errors name the file and line.
pub fn read_views(path: &Path) -> Result<Vec<Row<ViewRow>>> {
    let rows: Vec<Row<ViewRow>> = read_csv(path)?;
    if rows.is_empty() {
        return Err(FormatError::Row {
            path: path.to_path_buf(),
            line: 1,
            column: None,
            message: "no views: one row per image, image,camera,pose".into(),
        });
    }
    let mut first: HashMap<(u8, u32), u64> = HashMap::new();
    for r in &rows {
        if let Some(line) = first.insert((r.record.camera, r.record.pose), r.line) {
            return Err(FormatError::Row {
                path: path.to_path_buf(),
                line: r.line,
                column: Some("pose".into()),
                message: format!(
                    "camera {} has a second view of pose {} (first on line {line}); one image \
                     per camera and pose",
                    r.record.camera, r.record.pose
                ),
            });
        }
    }
    Ok(rows)
}

/// One view's residuals after a calibration over views (`<stem>.views.csv`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ViewResidualRow {
    /// Camera id.
    pub camera: u8,
    /// Pose.
    pub pose: u32,
    /// Points used (outliers aside).
    pub points: usize,
    /// RMS residual length of those points (px).
    pub rms_px: f64,
    /// Largest residual length of those points (px).
    pub max_px: f64,
    /// Points rejected as outliers.
    pub outliers: usize,
}

/// A point of the measuring volume and the σ of its triangulated position
/// from the calibration alone (`<stem>.volume.csv` of a calibration over
/// views): empty σ where fewer than two cameras see it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VolumeRow {
    /// x (mm, world frame).
    pub x: f64,
    /// y (mm).
    pub y: f64,
    /// z (mm).
    pub z: f64,
    /// The cameras that see it, `+`-joined (`1+2`).
    pub cameras: String,
    /// σ of x (µm).
    pub sigma_x_um: Option<f64>,
    /// σ of y (µm).
    pub sigma_y_um: Option<f64>,
    /// σ of z (µm).
    pub sigma_z_um: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn views_are_read_resolved_and_checked() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("views.csv");
        std::fs::write(&p, "image,camera,pose\na/1.txt,1,0\na/2.txt,2,0\n").unwrap();
        let rows = read_views(&p).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].record.path(&p), dir.path().join("a/2.txt"));
        std::fs::write(&p, "image,camera,pose\na.txt,1,3\nb.txt,1,3\n").unwrap();
        let e = read_views(&p).unwrap_err().to_string();
        assert!(
            e.contains("line 3") && e.contains("second view of pose 3"),
            "{e}"
        );
        std::fs::write(&p, "image,camera,pose\na.txt,0,3\n").unwrap();
        assert!(read_views(&p).unwrap_err().to_string().contains("camera"));
        std::fs::write(&p, "image,camera,pose\n").unwrap();
        assert!(read_views(&p).unwrap_err().to_string().contains("no views"));
    }
}
