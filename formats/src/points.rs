//! Measured (or true) sphere centres per instant: `points.csv`.

use serde::{Deserialize, Serialize};

use crate::InstantKey;
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
    /// A sphere's centre at an instant, its uncertainties unknown (every
    /// `u_*` empty: the renderer's truth, a series written by hand; measured
    /// centres add theirs with [`PointRow::with_uncertainty`]).
    pub fn new(
        instant: InstantKey,
        sphere: &str,
        [x, y, z]: [f64; 3],
        cameras: &str,
        residual_px: f64,
    ) -> Self {
        let [nominal_x, nominal_y, nominal_z] = instant.nominal();
        Self {
            axis: instant.axis,
            direction: instant.direction,
            run: instant.run,
            target: instant.target,
            capture: instant.capture,
            nominal_x,
            nominal_y,
            nominal_z,
            sphere: sphere.to_string(),
            x,
            y,
            z,
            cameras: cameras.to_string(),
            residual_px,
            u_x: None,
            u_y: None,
            u_z: None,
            u_cal_x: None,
            u_cal_y: None,
            u_cal_z: None,
        }
    }

    /// The row with the standard uncertainties of its centre (mm): the
    /// centroids' random part and the calibration's, x, y, z.
    pub fn with_uncertainty(self, random: Option<[f64; 3]>, calibration: Option<[f64; 3]>) -> Self {
        let part = |u: Option<[f64; 3]>| u.map_or([None; 3], |u| u.map(Some));
        let ([u_x, u_y, u_z], [u_cal_x, u_cal_y, u_cal_z]) = (part(random), part(calibration));
        Self {
            u_x,
            u_y,
            u_z,
            u_cal_x,
            u_cal_y,
            u_cal_z,
            ..self
        }
    }

    /// Measured position (mm).
    pub fn position(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

impl Record for PointRow {
    const COLUMNS: &'static [&'static str] = instant_columns![
        ..InstantKey,
        "sphere",
        "x",
        "y",
        "z",
        "cameras",
        "residual_px"
    ];
    const OPTIONAL_COLUMNS: &'static [&'static str] =
        &["u_x", "u_y", "u_z", "u_cal_x", "u_cal_y", "u_cal_z"];

    fn validate(&self) -> Result<(), Invalid> {
        self.validate_instant()?;
        if self.sphere.trim().is_empty() {
            return Err(Invalid::new("sphere", "empty sphere name"));
        }
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
