//! Files written by `trinocular measure` beside `points.csv`: what could not
//! be measured and why (`points.problems.csv`) and the table pose per instant
//! (`points.poses.csv`), named after the output's stem.

use serde::{Deserialize, Serialize};

use crate::campaign::InstantKey;
use crate::table::{Invalid, Record, finite};

/// What a problem leaves out of `measure`'s outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Missing {
    /// The whole instant: no row in `points.csv`, no pose.
    Instant,
    /// One sphere's row of `points.csv` (the instant's other spheres are
    /// there), and so the instant's pose.
    Sphere,
    /// The instant's pose only (every sphere is in `points.csv`).
    Pose,
    /// Nothing but one camera's view: the instant (or the sphere named) is in
    /// `points.csv`, measured from the other cameras (its `cameras` column);
    /// the row says which camera was left out and why.
    Camera,
}

instant_row! {
    /// Something of an instant that could not be measured, and why.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub struct InstantProblemRow {
        ..InstantKey,
        /// What is missing from the outputs because of this problem.
        pub missing: Missing,
        /// The sphere concerned, when the problem is one sphere's.
        pub sphere: Option<String>,
        /// Camera at fault, when one is.
        pub camera: Option<u8>,
        /// Image at fault, when one is.
        pub image: Option<String>,
        /// What is wrong.
        pub reason: String,
    }
}

impl InstantProblemRow {
    /// An instant that could not be measured at all.
    pub fn new(
        key: &InstantKey,
        camera: Option<u8>,
        image: Option<String>,
        reason: String,
    ) -> Self {
        Self::of(key, Missing::Instant, None, camera, image, reason)
    }

    /// A problem that leaves `missing` out of the outputs (`sphere` when it is one sphere's).
    pub fn of(
        key: &InstantKey,
        missing: Missing,
        sphere: Option<String>,
        camera: Option<u8>,
        image: Option<String>,
        reason: String,
    ) -> Self {
        let [x, y, z] = key.nominal();
        Self {
            axis: key.axis,
            direction: key.direction,
            run: key.run,
            target: key.target,
            capture: key.capture,
            nominal_x: x,
            nominal_y: y,
            nominal_z: z,
            missing,
            sphere,
            camera,
            image,
            reason,
        }
    }
}

impl Record for InstantProblemRow {
    const COLUMNS: &'static [&'static str] = &[
        "axis",
        "direction",
        "run",
        "target",
        "capture",
        "missing",
        "reason",
    ];

    fn validate(&self) -> Result<(), Invalid> {
        Ok(())
    }
}

instant_row! {
    /// The table's pose at an instant relative to the first instant of its line,
    /// from the rigid fit of the spheres' centres.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub struct PoseRow {
        ..InstantKey,
        /// Rotation about the moving axis (rad).
        pub roll: f64,
        /// Pitch (rad): about Y for an X axis, about X for a Y axis.
        pub pitch: f64,
        /// Yaw (rad): about Z for an X or Y axis.
        pub yaw: f64,
        /// Rotation vector x component (rad).
        pub rx: f64,
        /// Rotation vector y component (rad).
        pub ry: f64,
        /// Rotation vector z component (rad).
        pub rz: f64,
        /// Translation of the fit, x (mm).
        pub tx: f64,
        /// Translation of the fit, y (mm).
        pub ty: f64,
        /// Translation of the fit, z (mm).
        pub tz: f64,
        /// RMS distance of the spheres from the fitted rigid motion (mm).
        pub residual_mm: f64,
    }
}

impl Record for PoseRow {
    const COLUMNS: &'static [&'static str] = &[
        "axis",
        "direction",
        "run",
        "target",
        "capture",
        "roll",
        "pitch",
        "yaw",
    ];

    fn validate(&self) -> Result<(), Invalid> {
        finite("roll", self.roll)?;
        finite("pitch", self.pitch)?;
        finite("yaw", self.yaw)
    }
}

instant_row! {
    /// One row of `<stem>.observations.csv`: what one camera saw of one
    /// sphere at one instant — the centre its sphere centre was triangulated
    /// from and that centre's covariance — so that `evaluate` can propagate
    /// the uncertainty of every figure without reading an image again
    /// (docs/uncertainty.md).
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub struct ObservationRow {
        ..InstantKey,
        /// Sphere name.
        pub sphere: String,
        /// Camera id.
        pub camera: u8,
        /// Sphere radius the triangulation's image model used (mm; 0 when the
        /// perspective bias was not corrected).
        pub radius_mm: f64,
        /// Centre of the sphere's image, ideal (undistorted) pixels.
        pub u: f64,
        /// Centre of the sphere's image, ideal pixels.
        pub v: f64,
        /// Standard uncertainty of `u` from the image noise (px); empty when
        /// the camera's noise is unknown.
        pub u_sigma_px: Option<f64>,
        /// Standard uncertainty of `v` (px).
        pub v_sigma_px: Option<f64>,
        /// Correlation of the errors of `u` and `v` (−1 … 1).
        pub uv_correlation: Option<f64>,
    }
}

impl ObservationRow {
    /// The centre's covariance `[[σu², ρσuσv], [ρσuσv, σv²]]` (px²), when known.
    pub fn covariance(&self) -> Option<[[f64; 2]; 2]> {
        let (su, sv, r) = (self.u_sigma_px?, self.v_sigma_px?, self.uv_correlation?);
        Some([[su * su, r * su * sv], [r * su * sv, sv * sv]])
    }
}

impl Record for ObservationRow {
    const COLUMNS: &'static [&'static str] = instant_columns![
        ..InstantKey,
        "sphere",
        "camera",
        "radius_mm",
        "u",
        "v",
        "u_sigma_px",
        "v_sigma_px",
        "uv_correlation"
    ];

    fn validate(&self) -> Result<(), Invalid> {
        self.validate_instant()?;
        if self.sphere.trim().is_empty() {
            return Err(Invalid::new("sphere", "empty sphere name"));
        }
        if !(self.radius_mm.is_finite() && self.radius_mm >= 0.0) {
            return Err(Invalid::new(
                "radius_mm",
                format!("radius {} is not a finite number ≥ 0", self.radius_mm),
            ));
        }
        finite("u", self.u)?;
        finite("v", self.v)?;
        crate::table::standard_uncertainty("u_sigma_px", self.u_sigma_px)?;
        crate::table::standard_uncertainty("v_sigma_px", self.v_sigma_px)?;
        match self.uv_correlation {
            Some(r) if !(r.is_finite() && r.abs() <= 1.0) => Err(Invalid::new(
                "uv_correlation",
                format!("correlation {r} is not within −1 … 1"),
            )),
            _ => Ok(()),
        }
    }
}
