//! Calibration target (`target.csv`) and image correspondences (`id,u,v`).

use serde::{Deserialize, Serialize};

use crate::table::{Invalid, Record, finite};

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
}

impl Record for TargetRow {
    const COLUMNS: &'static [&'static str] = &["id", "x", "y", "z"];

    fn validate(&self) -> Result<(), Invalid> {
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
        Ok(())
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

    fn validate(&self) -> Result<(), Invalid> {
        finite("u", self.u)?;
        finite("v", self.v)
    }
}
