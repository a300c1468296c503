//! Camera descriptions: the nominal rig (`nominal.json`) that starts
//! calibration, and the calibrated rig (`rig.json`).

use std::path::Path;

use geom::camera::normalize_projection;
use geom::nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion};
use geom::{
    Camera, Distortion, Illumination, Intrinsics, Matrix3x4, Point2, Point3, RadialIllumination,
    Vector3,
};
use serde::{Deserialize, Serialize};

use crate::limits::MAX_IMAGE_SIDE_PX;
use crate::{FormatError, Result as FormatResult, RigError, read_json};

/// Tolerance on ‖RᵀR − I‖ for a rotation read from a file.
const ROTATION_TOLERANCE: f64 = 1e-6;

/// Largest disagreement (px) between where a camera's `P` and its K, R, t
/// put a point: far above the rounding of a file written with 7 significant
/// digits (≈ 0.001 px), far below any real difference between two cameras.
pub const P_TOLERANCE_PX: f64 = 0.05;

/// Camera ids of the contract (docs/formats.md: cameras `1`, `2`, `3`).
const CAMERA_IDS: std::ops::RangeInclusive<u8> = 1..=3;

/// Fails unless the camera ids are 1, 2 or 3 and each occurs once.
fn check_ids(ids: impl IntoIterator<Item = u8>) -> Result<(), RigError> {
    let mut seen = [false; 4];
    let mut count = 0;
    for id in ids {
        count += 1;
        if !CAMERA_IDS.contains(&id) {
            return Err(RigError::CameraId(id));
        }
        if std::mem::replace(&mut seen[usize::from(id)], true) {
            return Err(RigError::Duplicate(id));
        }
    }
    if count == 0 {
        return Err(RigError::NoCameras);
    }
    Ok(())
}

/// Fails unless a sensor size is 1..=[`MAX_IMAGE_SIDE_PX`] a side.
fn check_sensor(id: u8, width: u32, height: u32) -> Result<(), RigError> {
    if width == 0 || height == 0 || width > MAX_IMAGE_SIDE_PX || height > MAX_IMAGE_SIDE_PX {
        return Err(RigError::SensorSize { id, width, height });
    }
    Ok(())
}

/// An approximate camera: where it is, where it looks, its optics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NominalCamera {
    /// Camera number 1, 2 or 3.
    pub id: u8,
    /// Projection centre, world frame (mm).
    pub position: [f64; 3],
    /// A world point on the optical axis (mm).
    pub look_at: [f64; 3],
    /// World direction that appears upward in the image.
    pub up: [f64; 3],
    /// Lens focal length (mm).
    pub focal_mm: f64,
    /// Pixel pitch (mm).
    pub pixel_mm: f64,
    /// Sensor width (px).
    pub width: u32,
    /// Sensor height (px).
    pub height: u32,
    /// The lens as built, for the commissioning report's depth of field (optional keys).
    #[serde(flatten)]
    pub optics: NominalOptics,
    /// Further keys, kept as written.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// The optional lens keys of a `nominal.json` camera: each, when present, a
/// positive finite number ([`NominalCamera::to_camera`] refuses others);
/// absent keys take the commissioning report's defaults.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct NominalOptics {
    /// Diameter of the acceptable circle of confusion (px).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coc_px: Option<f64>,
    /// Working f-number.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub f_number: Option<f64>,
    /// Distance at which the lens is focused (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub focus_distance_mm: Option<f64>,
    /// The lens's focal length (mm), as opposed to the principal distance `focal_mm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lens_focal_mm: Option<f64>,
}

impl NominalOptics {
    /// Fails on a key that is present but not a positive finite number.
    fn check(&self, id: u8) -> Result<(), RigError> {
        for (key, value) in [
            ("coc_px", self.coc_px),
            ("f_number", self.f_number),
            ("focus_distance_mm", self.focus_distance_mm),
            ("lens_focal_mm", self.lens_focal_mm),
        ] {
            if let Some(value) = value
                && !(value.is_finite() && value > 0.0)
            {
                return Err(RigError::OpticsKey { id, key, value });
            }
        }
        Ok(())
    }
}

impl NominalCamera {
    /// The pinhole camera this describes: square pixels, centred principal
    /// point, no distortion. Also checks the optional lens keys ([`NominalOptics`]).
    pub fn to_camera(&self) -> Result<Camera, RigError> {
        if !(self.focal_mm > 0.0 && self.pixel_mm > 0.0) {
            return Err(RigError::Optics {
                id: self.id,
                focal_mm: self.focal_mm,
                pixel_mm: self.pixel_mm,
            });
        }
        check_sensor(self.id, self.width, self.height)?;
        self.optics.check(self.id)?;
        if !self
            .position
            .iter()
            .chain(&self.look_at)
            .chain(&self.up)
            .all(|v| v.is_finite())
        {
            return Err(RigError::NonFinitePlacement { id: self.id });
        }
        let k = Intrinsics::centred(self.focal_mm / self.pixel_mm, self.width, self.height);
        Camera::look_at(
            Point3::from(self.position),
            Point3::from(self.look_at),
            Vector3::from(self.up),
            k,
            self.width,
            self.height,
        )
        .map_err(|source| RigError::Placement {
            id: self.id,
            source,
        })
    }
}

/// `nominal.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NominalRig {
    /// The cameras, any order.
    pub cameras: Vec<NominalCamera>,
}

impl NominalRig {
    /// Check the rig as a whole: camera ids 1, 2 or 3, each once, and every
    /// camera a pinhole camera ([`NominalCamera::to_camera`]).
    pub fn validate(&self) -> Result<(), RigError> {
        check_ids(self.cameras.iter().map(|c| c.id))?;
        for c in &self.cameras {
            c.to_camera()?;
        }
        Ok(())
    }
}

/// Read a rig file and check it with `validate`; errors name the file.
fn read_checked<T: serde::de::DeserializeOwned>(
    path: &Path,
    validate: impl Fn(&T) -> Result<(), RigError>,
) -> FormatResult<T> {
    let rig: T = read_json(path)?;
    validate(&rig).map_err(|source| FormatError::Rig {
        path: path.into(),
        source,
    })?;
    Ok(rig)
}

/// Read `nominal.json` and check it ([`NominalRig::validate`]); errors name the file.
pub fn read_nominal(path: &Path) -> FormatResult<NominalRig> {
    read_checked(path, NominalRig::validate)
}

/// Brown distortion coefficients as written in files (`k3` optional).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct DistortionJson {
    /// k1.
    pub k1: f64,
    /// k2.
    pub k2: f64,
    /// p1.
    pub p1: f64,
    /// p2.
    pub p2: f64,
    /// k3 (0 when absent).
    #[serde(default)]
    pub k3: f64,
}

impl From<Distortion> for DistortionJson {
    fn from(d: Distortion) -> Self {
        Self {
            k1: d.k1,
            k2: d.k2,
            p1: d.p1,
            p2: d.p2,
            k3: d.k3,
        }
    }
}

impl From<DistortionJson> for Distortion {
    fn from(d: DistortionJson) -> Self {
        Distortion {
            k1: d.k1,
            k2: d.k2,
            k3: d.k3,
            p1: d.p1,
            p2: d.p2,
        }
    }
}

/// A camera model as written in `rig.json` and `truth.json`: K, R, t
/// (world → camera, `x_cam = R·x_world + t`), distortion and sensor size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraJson {
    /// Camera number 1, 2 or 3.
    pub id: u8,
    /// Intrinsic matrix.
    #[serde(rename = "K")]
    pub k: [[f64; 3]; 3],
    /// World → camera rotation.
    #[serde(rename = "R")]
    pub r: [[f64; 3]; 3],
    /// World → camera translation (mm).
    pub t: [f64; 3],
    /// Lens distortion.
    pub distortion: DistortionJson,
    /// Sensor width (px).
    pub width: u32,
    /// Sensor height (px).
    pub height: u32,
}

fn rows3(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|i| [m[(i, 0)], m[(i, 1)], m[(i, 2)]])
}

impl CameraJson {
    /// Describe a camera.
    pub fn from_camera(id: u8, camera: &Camera) -> Self {
        Self {
            id,
            k: rows3(&camera.intrinsics.matrix()),
            r: rows3(camera.rotation().matrix()),
            t: camera.translation().into(),
            distortion: camera.distortion.into(),
            width: camera.width,
            height: camera.height,
        }
    }

    /// The camera described; fails on a non-rotation R, a malformed K or non-finite values.
    pub fn to_camera(&self) -> Result<Camera, RigError> {
        let id = self.id;
        let k = Matrix3::from_fn(|i, j| self.k[i][j]);
        let r = Matrix3::from_fn(|i, j| self.r[i][j]);
        let t = Vector3::from(self.t);
        if !(r.iter().chain(t.iter()).all(|v| v.is_finite())) {
            return Err(RigError::NonFiniteExtrinsics { id });
        }
        let intrinsics =
            Intrinsics::from_matrix(&k).map_err(|source| RigError::Intrinsics { id, source })?;
        if (r.transpose() * r - Matrix3::identity()).norm() > ROTATION_TOLERANCE
            || r.determinant() <= 0.0
        {
            return Err(RigError::NotRotation { id });
        }
        let d = self.distortion;
        if ![d.k1, d.k2, d.k3, d.p1, d.p2].iter().all(|v| v.is_finite()) {
            return Err(RigError::NonFiniteDistortion { id });
        }
        check_sensor(self.id, self.width, self.height)?;
        let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&r));
        Ok(Camera {
            intrinsics,
            distortion: d.into(),
            pose: Isometry3::from_parts(Translation3::from(t), rotation),
            width: self.width,
            height: self.height,
        })
    }
}

/// A camera's relative illumination as written in `rig.json`
/// (`relative_illumination`, tagged by `model`): `ideal` (cos⁴θ natural
/// vignetting, energy-conserving under distortion: assumed when no flat field
/// was given, and when the key is absent), `uniform` (RI = 1, radiance
/// images) or `radial` (fitted from flat fields: `RI = Σ qₖ·ρ²ᵏ`,
/// `ρ = |p − centre_px|/scale_px`). Further keys (the fit's residual, dark
/// level, source files) are kept as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "lowercase")]
pub enum IlluminationJson {
    /// The ideal lens.
    Ideal {
        /// Further keys.
        #[serde(flatten)]
        extra: serde_json::Map<String, serde_json::Value>,
    },
    /// No fall-off.
    Uniform {
        /// Further keys.
        #[serde(flatten)]
        extra: serde_json::Map<String, serde_json::Value>,
    },
    /// Fitted from flat fields.
    Radial {
        /// Centre of the model (observed pixels).
        centre_px: [f64; 2],
        /// Scale of ρ (px).
        scale_px: f64,
        /// q₀, q₁, … of ρ⁰, ρ², ….
        coefficients: Vec<f64>,
        /// Further keys.
        #[serde(flatten)]
        extra: serde_json::Map<String, serde_json::Value>,
    },
}

impl Default for IlluminationJson {
    fn default() -> Self {
        IlluminationJson::Ideal {
            extra: serde_json::Map::new(),
        }
    }
}

impl IlluminationJson {
    /// Describe a model (no further keys).
    pub fn from_model(model: &Illumination) -> Self {
        let extra = serde_json::Map::new();
        match model {
            Illumination::Ideal => IlluminationJson::Ideal { extra },
            Illumination::Uniform => IlluminationJson::Uniform { extra },
            Illumination::Radial(r) => IlluminationJson::Radial {
                centre_px: r.centre,
                scale_px: r.scale_px,
                coefficients: r.coefficients.clone(),
                extra,
            },
        }
    }

    /// The further keys.
    pub fn extra_mut(&mut self) -> &mut serde_json::Map<String, serde_json::Value> {
        match self {
            IlluminationJson::Ideal { extra }
            | IlluminationJson::Uniform { extra }
            | IlluminationJson::Radial { extra, .. } => extra,
        }
    }

    /// The model, checked over a `width` × `height` image: finite
    /// coefficients, a positive scale, and RI positive at the centre, the
    /// edge midpoints and the corners.
    pub fn to_model(&self, width: u32, height: u32) -> Result<Illumination, RigError> {
        match self {
            IlluminationJson::Ideal { .. } => Ok(Illumination::Ideal),
            IlluminationJson::Uniform { .. } => Ok(Illumination::Uniform),
            IlluminationJson::Radial {
                centre_px,
                scale_px,
                coefficients,
                ..
            } => {
                if !(scale_px.is_finite() && *scale_px > 0.0) {
                    return Err(RigError::IlluminationScale(*scale_px));
                }
                if coefficients.is_empty()
                    || !coefficients
                        .iter()
                        .chain(centre_px.iter())
                        .all(|v| v.is_finite())
                {
                    return Err(RigError::IlluminationValues);
                }
                let r = RadialIllumination {
                    centre: *centre_px,
                    scale_px: *scale_px,
                    coefficients: coefficients.clone(),
                };
                let (w, h) = (f64::from(width) - 1.0, f64::from(height) - 1.0);
                for (u, v) in [
                    (w / 2.0, h / 2.0),
                    (0.0, 0.0),
                    (w, 0.0),
                    (0.0, h),
                    (w, h),
                    (w / 2.0, 0.0),
                    (0.0, h / 2.0),
                ] {
                    let ri = r.at(u, v);
                    if !(ri.is_finite() && ri > 0.0) {
                        return Err(RigError::IlluminationNotPositive { ri, u, v });
                    }
                }
                Ok(Illumination::Radial(r))
            }
        }
    }
}

/// The covariance of a camera's calibrated parameters (`rig.json`
/// `covariance`, docs/uncertainty.md): `s²·(JᵀJ)⁻¹` of the calibration's
/// least squares, plus the propagated uncertainty of the target's marker
/// coordinates. A draw δ of the parameters gives the camera
/// [`geom::Camera::perturbed`]: `rx, ry, rz` a small rotation ω about the
/// camera's own axes, `R = exp([ω]×)·R̂`; `tx, ty, tz` added to t of
/// `x_cam = R·x + t` (mm); the rest added to their values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraCovariance {
    /// Parameter names, in the order of the matrix.
    pub parameters: Vec<String>,
    /// The full covariance, one row per parameter (units of the parameters²).
    pub matrix: Vec<Vec<f64>>,
    /// Of it, the part due to the target's marker coordinates.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<Vec<Vec<f64>>>,
    /// Standard uncertainty of each coordinate of each marker (µm).
    pub target_uncertainty_um: f64,
    /// Where that uncertainty came from (`target.csv u_mm`, the option, the default).
    pub target_uncertainty_source: String,
}

impl CameraCovariance {
    /// The matrix as nalgebra's, checked square and of the parameters' size.
    pub fn to_matrix(&self) -> Option<geom::nalgebra::DMatrix<f64>> {
        square(&self.matrix, self.parameters.len())
    }

    /// The target's part, when given.
    pub fn target_matrix(&self) -> Option<geom::nalgebra::DMatrix<f64>> {
        square(self.target.as_ref()?, self.parameters.len())
    }
}

fn square(rows: &[Vec<f64>], n: usize) -> Option<geom::nalgebra::DMatrix<f64>> {
    (rows.len() == n && rows.iter().all(|r| r.len() == n))
        .then(|| geom::nalgebra::DMatrix::from_fn(n, n, |i, j| rows[i][j]))
}

/// One calibrated camera of `rig.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RigCamera {
    /// K, R, t, distortion, size.
    #[serde(flatten)]
    pub model: CameraJson,
    /// 3×4 projection of the undistorted pinhole model, third row's first
    /// three entries of unit norm.
    #[serde(rename = "P")]
    pub p: [[f64; 4]; 3],
    /// RMS reprojection error of the calibration (px).
    pub rms_px: f64,
    /// Number of points the calibration used.
    pub points: usize,
    /// The lens's relative illumination (absent in older files: the ideal lens).
    #[serde(default)]
    pub relative_illumination: IlluminationJson,
    /// The sensor's calibration and per-pixel maps (absent: frames are used
    /// as they are).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<crate::SensorJson>,
    /// The covariance of the calibrated parameters (absent in older files:
    /// the figures measured with the rig carry no calibration uncertainty).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance: Option<CameraCovariance>,
    /// Anything else the calibration reports (standard deviations, model, outliers).
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

impl RigCamera {
    /// The camera, checked in full: K, R, t and distortion
    /// ([`CameraJson::to_camera`]), `P` consistent with them
    /// (`check_projection`), the relative illumination over the image and
    /// finite figures.
    pub fn validate(&self) -> Result<Camera, RigError> {
        let id = self.model.id;
        let in_camera = |source| RigError::Camera {
            id,
            source: Box::new(source),
        };
        let camera = self.model.to_camera()?;
        check_projection(&self.p, &camera).map_err(in_camera)?;
        self.relative_illumination
            .to_model(self.model.width, self.model.height)
            .map_err(in_camera)?;
        if !(self.rms_px.is_finite() && self.rms_px >= 0.0) {
            return Err(RigError::RmsPx {
                id,
                rms_px: self.rms_px,
            });
        }
        Ok(camera)
    }

    /// Describe a calibrated camera.
    pub fn new(id: u8, camera: &Camera, rms_px: f64, points: usize) -> Self {
        let p: Matrix3x4<f64> = camera.projection_matrix();
        Self {
            model: CameraJson::from_camera(id, camera),
            p: [0, 1, 2].map(|i| [p[(i, 0)], p[(i, 1)], p[(i, 2)], p[(i, 3)]]),
            rms_px,
            points,
            relative_illumination: IlluminationJson::default(),
            sensor: None,
            covariance: None,
            extra: serde_json::Map::new(),
        }
    }
}

/// `rig.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Rig {
    /// The cameras, any order.
    pub cameras: Vec<RigCamera>,
}

impl Rig {
    /// The camera with this id.
    pub fn camera(&self, id: u8) -> Option<&RigCamera> {
        self.cameras.iter().find(|c| c.model.id == id)
    }

    /// Check the rig as a whole: camera ids 1, 2 or 3, each once, and every
    /// camera ([`RigCamera::validate`]).
    pub fn validate(&self) -> Result<(), RigError> {
        check_ids(self.cameras.iter().map(|c| c.model.id))?;
        for c in &self.cameras {
            c.validate()?;
        }
        Ok(())
    }
}

/// Read `rig.json` and check it ([`Rig::validate`]); errors name the file.
pub fn read_rig(path: &Path) -> FormatResult<Rig> {
    read_checked(path, Rig::validate)
}

/// Fails unless the projection `p` of a file agrees with `camera`'s K, R, t:
/// `p` must have a regular left 3×3 block (scale and sign are free), and
/// points seen at the image centre and corners, at half and twice the
/// distance of the world origin, must project through `p` within
/// [`P_TOLERANCE_PX`] of where the camera's pinhole model puts them.
pub fn check_projection(p: &[[f64; 4]; 3], camera: &Camera) -> Result<(), RigError> {
    let m = Matrix3x4::from_fn(|i, j| p[i][j]);
    if !m.iter().all(|v| v.is_finite()) {
        return Err(RigError::ProjectionNonFinite);
    }
    let m = normalize_projection(&m).map_err(|_| RigError::ProjectionSingular)?;
    let k = camera.intrinsics;
    let depth = camera.translation().norm().max(1.0);
    let (w, h) = (
        f64::from(camera.width) - 1.0,
        f64::from(camera.height) - 1.0,
    );
    for scale in [0.5, 2.0] {
        for (u, v) in [(w / 2.0, h / 2.0), (0.0, 0.0), (w, 0.0), (0.0, h), (w, h)] {
            let n = k.to_normalized(Point2::new(u, v));
            let z = scale * depth;
            let in_camera = Point3::new(n.x * z, n.y * z, z);
            let world = camera.pose.inverse_transform_point(&in_camera);
            let q = m * world.to_homogeneous();
            let (pu, pv) = (q.x / q.z, q.y / q.z);
            let off = (pu - u).hypot(pv - v);
            if !(q.z > 0.0 && off <= P_TOLERANCE_PX) {
                return Err(RigError::ProjectionContradicts {
                    u,
                    v,
                    depth_mm: z,
                    pu,
                    pv,
                    behind: q.z <= 0.0 || q.z.is_nan(),
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_json_round_trip() {
        let mut cam = nominal(3).to_camera().unwrap();
        cam.distortion.k1 = -0.05;
        let json = serde_json::to_string(&RigCamera::new(3, &cam, 0.01, 40)).unwrap();
        let back: RigCamera = serde_json::from_str(&json).unwrap();
        let cam2 = back.model.to_camera().unwrap();
        let x = Point3::new(10.0, -20.0, 5.0);
        assert!((cam.project(&x).unwrap() - cam2.project(&x).unwrap()).norm() < 1e-9);
        assert!(json.contains("\"P\"") && json.contains("\"K\"") && json.contains("\"rms_px\""));
    }

    #[test]
    fn illumination_is_ideal_when_absent_and_round_trips() {
        let cam = NominalCamera {
            position: [-460.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            width: 400,
            height: 300,
            ..nominal(1)
        }
        .to_camera()
        .unwrap();
        let mut json = serde_json::to_value(RigCamera::new(1, &cam, 0.01, 40)).unwrap();
        assert_eq!(json["relative_illumination"]["model"], "ideal");
        json.as_object_mut()
            .unwrap()
            .remove("relative_illumination");
        let old: RigCamera = serde_json::from_value(json.clone()).unwrap();
        assert_eq!(
            old.relative_illumination.to_model(400, 300).unwrap(),
            Illumination::Ideal
        );
        json["relative_illumination"] = serde_json::json!({
            "model": "radial", "centre_px": [200.0, 150.0], "scale_px": 7000.0,
            "coefficients": [1.0, -1.9], "residual_rms": 1e-4
        });
        let fitted: RigCamera = serde_json::from_value(json.clone()).unwrap();
        let Illumination::Radial(r) = fitted.relative_illumination.to_model(400, 300).unwrap()
        else {
            panic!("not radial")
        };
        assert_eq!(r.coefficients, vec![1.0, -1.9]);
        let back = serde_json::to_value(&fitted).unwrap();
        assert_eq!(back["relative_illumination"]["residual_rms"], 1e-4);
        json["relative_illumination"]["coefficients"] = serde_json::json!([1.0, -1e9]);
        let bad: RigCamera = serde_json::from_value(json).unwrap();
        assert!(
            bad.relative_illumination
                .to_model(400, 300)
                .unwrap_err()
                .to_string()
                .contains("not positive")
        );
    }

    fn nominal(id: u8) -> NominalCamera {
        NominalCamera {
            id,
            position: [0.0, 0.0, 560.0],
            look_at: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            focal_mm: 40.0,
            pixel_mm: 0.0055,
            width: 4096,
            height: 3072,
            optics: NominalOptics::default(),
            extra: serde_json::Map::new(),
        }
    }

    #[test]
    fn rigs_with_twice_the_same_camera_are_refused() {
        let rig = NominalRig {
            cameras: vec![nominal(1), nominal(2), nominal(1)],
        };
        assert_eq!(rig.validate().unwrap_err(), RigError::Duplicate(1));
        let rig = NominalRig {
            cameras: vec![nominal(4)],
        };
        assert_eq!(rig.validate().unwrap_err(), RigError::CameraId(4));
        let mut bad = nominal(2);
        bad.up = [f64::NAN, 1.0, 0.0];
        let e = NominalRig { cameras: vec![bad] }
            .validate()
            .unwrap_err()
            .to_string();
        assert!(e.contains("camera 2") && e.contains("finite"), "{e}");
        let cam = nominal(3).to_camera().unwrap();
        let rig = Rig {
            cameras: vec![
                RigCamera::new(3, &cam, 0.01, 40),
                RigCamera::new(3, &cam, 0.01, 40),
            ],
        };
        assert_eq!(rig.validate().unwrap_err(), RigError::Duplicate(3));
    }

    #[test]
    fn a_projection_that_contradicts_the_camera_is_refused() {
        let cam = nominal(3).to_camera().unwrap();
        let good = RigCamera::new(3, &cam, 0.01, 40);
        good.validate().unwrap();
        // Any scale and sign of P is the same projection.
        let mut scaled = good.clone();
        scaled.p = good.p.map(|r| r.map(|v| -2.5 * v));
        scaled.validate().unwrap();
        // Seven significant digits are enough.
        let mut rounded = good.clone();
        rounded.p = good
            .p
            .map(|r| r.map(|v| format!("{v:.6e}").parse().unwrap()));
        rounded.validate().unwrap();
        // A focal length 0.1 % off is not.
        let mut wrong = good.clone();
        wrong.p[0][0] *= 1.001;
        let e = wrong.validate().unwrap_err().to_string();
        assert!(e.starts_with("camera 3: P contradicts K, R and t"), "{e}");
        let mut zero = good.clone();
        zero.p = [[0.0; 4]; 3];
        let e = zero.validate().unwrap_err().to_string();
        assert!(e.contains("P is singular"), "{e}");
        let mut nan = good;
        nan.p[1][3] = f64::NAN;
        assert!(
            nan.validate()
                .unwrap_err()
                .to_string()
                .contains("not a finite number")
        );
    }

    #[test]
    fn bad_rotation_is_rejected() {
        let mut j = CameraJson::from_camera(
            1,
            &Camera::look_at(
                Point3::new(-460.0, 0.0, 0.0),
                Point3::origin(),
                Vector3::z(),
                Intrinsics::centred(7000.0, 100, 100),
                100,
                100,
            )
            .unwrap(),
        );
        j.r[0][0] = 2.0;
        assert_eq!(j.to_camera().unwrap_err(), RigError::NotRotation { id: 1 });
    }
}
