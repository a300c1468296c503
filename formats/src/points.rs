//! Measured (or true) sphere centres per instant: `points.csv`.

use serde::{Deserialize, Serialize};

use crate::table::{Invalid, Record, finite};

instant_row! {
    /// One row of `points.csv`: one sphere at one instant.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub struct PointRow {
        ..InstantKey,
        /// Sphere name.
        pub sphere: String,
        /// Sphere centre x, world frame (mm).
        pub x: f64,
        /// Sphere centre y, world frame (mm).
        pub y: f64,
        /// Sphere centre z, world frame (mm).
        pub z: f64,
        /// Cameras used, like `2+3`.
        pub cameras: String,
        /// RMS reprojection residual (px): the RMS distance, in ideal pixels,
        /// between the sphere's image centre in each camera and the image its
        /// least-squares centre projects to — how well the cameras' images agree
        /// (0 in the renderer's exact points).
        pub residual_px: f64,
        /// Standard uncertainty of x from the centroids' noise (mm): the
        /// random part, independent between instants; empty when the noise
        /// of the centroids is unknown (docs/uncertainty.md).
        #[serde(default)]
        pub u_x: Option<f64>,
        /// Standard uncertainty of y from the centroids' noise (mm).
        #[serde(default)]
        pub u_y: Option<f64>,
        /// Standard uncertainty of z from the centroids' noise (mm).
        #[serde(default)]
        pub u_z: Option<f64>,
        /// Standard uncertainty of x from the cameras' calibration (mm): the
        /// part shared by every instant, which averaging does not reduce.
        #[serde(default)]
        pub u_cal_x: Option<f64>,
        /// Standard uncertainty of y from the calibration (mm).
        #[serde(default)]
        pub u_cal_y: Option<f64>,
        /// Standard uncertainty of z from the calibration (mm).
        #[serde(default)]
        pub u_cal_z: Option<f64>,
    }
}

impl PointRow {
    /// Measured position (mm).
    pub fn position(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

impl Record for PointRow {
    const COLUMNS: &'static [&'static str] = &[
        "axis",
        "direction",
        "run",
        "target",
        "capture",
        "nominal_x",
        "nominal_y",
        "nominal_z",
        "sphere",
        "x",
        "y",
        "z",
        "cameras",
        "residual_px",
    ];
    const OPTIONAL_COLUMNS: &'static [&'static str] =
        &["u_x", "u_y", "u_z", "u_cal_x", "u_cal_y", "u_cal_z"];

    fn validate(&self) -> Result<(), Invalid> {
        if self.run < 1 {
            return Err(Invalid::new("run", "runs are numbered from 1"));
        }
        if self.capture < 1 {
            return Err(Invalid::new("capture", "captures are numbered from 1"));
        }
        if self.sphere.trim().is_empty() {
            return Err(Invalid::new("sphere", "empty sphere name"));
        }
        finite("nominal_x", self.nominal_x)?;
        finite("nominal_y", self.nominal_y)?;
        finite("nominal_z", self.nominal_z)?;
        finite("x", self.x)?;
        finite("y", self.y)?;
        finite("z", self.z)?;
        finite("residual_px", self.residual_px)?;
        for (column, u) in [
            ("u_x", self.u_x),
            ("u_y", self.u_y),
            ("u_z", self.u_z),
            ("u_cal_x", self.u_cal_x),
            ("u_cal_y", self.u_cal_y),
            ("u_cal_z", self.u_cal_z),
        ] {
            crate::table::standard_uncertainty(column, u)?;
        }
        Ok(())
    }
}
