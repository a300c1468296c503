//! The rig: nominal cameras (what `nominal.json` tells calibration) and true
//! cameras (what renders the images and goes to `truth.json`), each with its
//! optics and sensor.

use formats::{NominalCamera, NominalOptics, NominalRig};
use geom::nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use geom::{Camera, Intrinsics};

use crate::config::{CameraConfig, Config, IlluminationModel};
use crate::illumination::{IlluminationSource, LensIllumination};
use crate::pattern::{Defects, PatternKey, Readout};
use crate::psf::Optics;
use crate::scene::Sphere;
use crate::sensor::{Exposure, Image16, NoiseKey, Sensor, StrayLight, expose_through};
use crate::{Result, SynthError};

/// One camera of the synthetic rig.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthCamera {
    /// Camera number 1, 2 or 3.
    pub id: u8,
    /// The true camera model (renders the images).
    pub camera: Camera,
    /// The nominal description (written to `nominal.json`).
    pub nominal: NominalCamera,
    /// Serial number (EXIF BodySerialNumber).
    pub serial: String,
    /// Lens in this camera's pixel units.
    pub optics: Optics,
    /// Sensor, with this camera's stray light.
    pub sensor: Sensor,
    /// The lens's relative illumination; `None`: radiance images.
    pub lens: Option<LensIllumination>,
    /// The sensor's ADC resolution and fixed pattern (`crate::pattern`).
    pub readout: Readout,
}

/// Fraction of the full scale that a flat field reaches where it is brightest.
pub(crate) const FLAT_FIELD_LEVEL: f64 = 0.75;

/// Frame numbers of the flat-field and dark frames in noise keys.
pub(crate) const FLAT_FIELD_FRAME: u64 = u64::MAX - 1;
/// See [`FLAT_FIELD_FRAME`].
pub(crate) const DARK_FRAME: u64 = u64::MAX - 2;
/// Noise-key frame of the calibration target at pose 1 (pose p: index p − 1).
pub(crate) const TARGET_POSE_FRAME: u64 = u64::MAX - 3;
/// Noise-key frame of the board at pose 0 (`synth board`; pose p: index p).
pub(crate) const BOARD_FRAME: u64 = u64::MAX - 4;

/// Noise-key frame of frame `index` of a calibration stack whose frame 0 is
/// `base` ([`FLAT_FIELD_FRAME`], [`DARK_FRAME`], and the placements of the
/// target and of the board): `base − index·2³²`, far from every campaign
/// frame and from the other series.
pub(crate) fn stack_frame(base: u64, index: u32) -> u64 {
    base - (u64::from(index) << 32)
}

impl SynthCamera {
    /// Render the spheres as this camera sees them.
    pub fn render(&self, spheres: &[Sphere], key: NoiseKey, max_depth: u8) -> Result<Image16> {
        crate::render::render(self, spheres, key, max_depth)
    }

    /// Expose signal layers on this camera's sensor, through its lens's
    /// relative illumination (background light) and its readout.
    pub fn expose(&self, layers: &[Exposure<'_>], key: NoiseKey) -> Image16 {
        expose_through(&self.sensor, &self.readout, layers, key, self.lens.as_ref())
    }

    /// The injected hot and dead pixels of this camera's sensor (empty
    /// without a fixed pattern); `truth.json` lists the same.
    pub fn defects(&self) -> Defects {
        self.readout.defects(self.sensor.width, self.sensor.height)
    }

    /// Radiance (electrons of a pixel at the principal point) of the flat
    /// field: ¾ of the full scale where it is brightest (`FLAT_FIELD_LEVEL`).
    pub fn flat_field_radiance_e(&self) -> f64 {
        let s = &self.sensor;
        let peak = self
            .lens
            .as_ref()
            .map_or(1.0, |l| l.max_in(s.width, s.height));
        (FLAT_FIELD_LEVEL * s.max_dn() - s.offset_dn) / s.gain_dn_per_e / peak
    }

    /// A flat-field frame: a uniform radiance source filling the view (no
    /// stray light, no spheres), through the lens, with the sensor's noise
    /// and fixed pattern. The same as [`Self::flat_field_at`] `(seed, 0)`.
    pub fn flat_field(&self, seed: u64) -> Image16 {
        self.flat_field_at(seed, 0)
    }

    /// Frame `index` of a stack of flat fields: independent temporal noise,
    /// the same fixed pattern.
    pub fn flat_field_at(&self, seed: u64, index: u32) -> Image16 {
        let sensor = Sensor {
            background_e: self.flat_field_radiance_e(),
            gradient_e_per_px: [0.0, 0.0],
            stray_light: Vec::new(),
            ..self.sensor.clone()
        };
        expose_through(
            &sensor,
            &self.readout,
            &[],
            self.key(seed, stack_frame(FLAT_FIELD_FRAME, index)),
            self.lens.as_ref(),
        )
    }

    /// A dark frame: the lens capped, the sensor's offset, read noise and
    /// fixed pattern (hot pixels, DSNU, column and row offsets). The same as
    /// [`Self::dark_frame_at`] `(seed, 0)`.
    pub fn dark_frame(&self, seed: u64) -> Image16 {
        self.dark_frame_at(seed, 0)
    }

    /// Frame `index` of a stack of dark frames.
    pub fn dark_frame_at(&self, seed: u64, index: u32) -> Image16 {
        let sensor = Sensor {
            background_e: 0.0,
            gradient_e_per_px: [0.0, 0.0],
            stray_light: Vec::new(),
            ..self.sensor.clone()
        };
        expose_through(
            &sensor,
            &self.readout,
            &[],
            self.key(seed, stack_frame(DARK_FRAME, index)),
            None,
        )
    }

    fn key(&self, seed: u64, frame: u64) -> NoiseKey {
        NoiseKey {
            seed,
            frame,
            camera: self.id,
        }
    }
}

/// The three (or fewer) cameras.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthRig {
    /// Cameras in configuration order.
    pub cameras: Vec<SynthCamera>,
}

/// Principal distance (mm) of a thin lens of focal length `f` focused at `s`: `f·s/(s − f)`.
pub(crate) fn principal_distance_mm(focal_mm: f64, focus_distance_mm: f64) -> f64 {
    focal_mm * focus_distance_mm / (focus_distance_mm - focal_mm)
}

impl SynthRig {
    /// Build the nominal and true cameras of a configuration.
    pub fn from_config(config: &Config) -> Result<Self> {
        config.validate()?;
        let cameras = config
            .rig
            .cameras
            .iter()
            .map(|c| build_camera(config, c))
            .collect::<Result<Vec<_>>>()?;
        Ok(Self { cameras })
    }

    /// The camera with this id.
    pub fn camera(&self, id: u8) -> Option<&SynthCamera> {
        self.cameras.iter().find(|c| c.id == id)
    }

    /// `nominal.json`.
    pub fn nominal(&self) -> NominalRig {
        NominalRig {
            cameras: self.cameras.iter().map(|c| c.nominal.clone()).collect(),
        }
    }
}

fn build_camera(config: &Config, c: &CameraConfig) -> Result<SynthCamera> {
    let s = &config.sensor;
    let o = &config.optics;
    let rig = &config.rig;
    let key = format!("rig.cameras[id = {}]", c.id);
    let view = Vector3::from(c.view);
    if view.norm().is_nan() || view.norm() <= 0.0 {
        return Err(SynthError::config(format!("{key}.view: zero vector")));
    }
    let wp = Point3::from(rig.working_point);
    let position = wp - view.normalize() * rig.working_distance_mm;
    let pd = principal_distance_mm(o.focal_mm, o.focus_distance_mm);
    let nominal = NominalCamera {
        id: c.id,
        position: position.coords.into(),
        look_at: wp.coords.into(),
        up: c.up,
        focal_mm: pd,
        pixel_mm: s.pixel_mm,
        width: s.width,
        height: s.height,
        // The lens as built, for the commissioning report's depth of field.
        optics: NominalOptics {
            coc_px: None,
            f_number: Some(o.f_number),
            focus_distance_mm: Some(o.focus_distance_mm),
            lens_focal_mm: Some(o.focal_mm),
        },
        extra: serde_json::Map::new(),
    };
    let nominal_camera = nominal
        .to_camera()
        .map_err(|m| SynthError::config(format!("{key}: {m}")))?;
    // True camera: rotation error in the camera frame, centre offset in the world.
    let r_err = Rotation3::new(Vector3::from(c.rotation_error_deg.map(f64::to_radians)));
    let r_true = r_err * nominal_camera.rotation();
    let centre = nominal_camera.centre() + Vector3::from(c.position_error_mm);
    let t = -(r_true * centre.coords);
    let focal_px = pd * (1.0 + c.focal_error_percent / 100.0) / s.pixel_mm;
    let mut k = Intrinsics::centred(focal_px, s.width, s.height);
    k.cx += c.principal_point_offset_um[0] / 1000.0 / s.pixel_mm;
    k.cy += c.principal_point_offset_um[1] / 1000.0 / s.pixel_mm;
    let profile = o.lens_profile()?;
    let mut distortion: geom::Distortion = c.distortion.into();
    if let Some(fit) = profile
        .as_ref()
        .and_then(|p| p.brown_in_pixels(&k, s.width, s.height, s.pixel_mm))
    {
        // The measured lens's focal length over the field and radial
        // distortion; the camera's p1, p2 stay.
        let fit = fit?;
        k.fx *= fit.scale;
        k.fy *= fit.scale;
        [distortion.k1, distortion.k2, distortion.k3] = fit.k;
    }
    let camera = Camera {
        intrinsics: k,
        distortion,
        pose: Isometry3::from_parts(
            Translation3::from(t),
            UnitQuaternion::from_rotation_matrix(&r_true),
        ),
        width: s.width,
        height: s.height,
    };
    let (w, h) = (f64::from(s.width), f64::from(s.height));
    let sensor = Sensor {
        width: s.width,
        height: s.height,
        bits: s.bits,
        gain_dn_per_e: s.gain_dn_per_e,
        offset_dn: s.offset_dn,
        read_noise_e: s.read_noise_e,
        shot_noise: s.shot_noise,
        background_e: s.background_e,
        gradient_e_per_px: [
            s.background_gradient_e[0] / w,
            s.background_gradient_e[1] / h,
        ],
        stray_light: c
            .stray_light
            .iter()
            .map(|b| StrayLight {
                u: b.u * w - 0.5,
                v: b.v * h - 0.5,
                sigma_px: b.sigma * w,
                peak_e: b.peak_e,
            })
            .collect(),
    };
    let optics = Optics {
        psf_sigma_px: o.psf_sigma_um / 1000.0 / s.pixel_mm,
        focal_mm: o.focal_mm,
        f_number: o.f_number,
        focus_distance_mm: o.focus_distance_mm,
        pixel_mm: s.pixel_mm,
    };
    let lens = match o.illumination {
        IlluminationModel::Lens => Some(LensIllumination::new(&camera, o.vignetting)?),
        IlluminationModel::Radiance => None,
        IlluminationModel::Profile => {
            let measured = profile
                .as_ref()
                .and_then(|p| p.vignetting_in_pixels(&k, s.pixel_mm, o.profile_centre_offset_um));
            // Validation requires a profile with vignetting here.
            let measured = measured.ok_or_else(|| {
                SynthError::config(
                    "optics.illumination: \"profile\" needs a lens profile with vignetting_pa",
                )
            })?;
            Some(LensIllumination::from_source(
                &camera,
                IlluminationSource::Profile(measured),
            )?)
        }
    };
    let readout = Readout::new(
        s.bits,
        s.adc_bits,
        s.pattern(),
        PatternKey::new(config.seed, &c.serial),
    );
    Ok(SynthCamera {
        id: c.id,
        camera,
        nominal,
        serial: c.serial.clone(),
        optics,
        sensor,
        lens,
        readout,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_rig_has_the_seed_scale() {
        let rig = SynthRig::from_config(&Config::default()).unwrap();
        assert_eq!(rig.cameras.len(), 3);
        for c in &rig.cameras {
            // ≈ 58 µm per pixel at 460 mm (docs/methods.md).
            let mm_per_px = 460.0 / c.camera.intrinsics.fx;
            assert!(
                (mm_per_px - 0.0578).abs() < 0.0005,
                "camera {}: {mm_per_px}",
                c.id
            );
            // The true camera still looks at the working point, within its mounting errors.
            let wp = c.camera.project(&Point3::new(0.0, 0.0, 30.0)).unwrap();
            assert!(
                (wp.x - 2047.5).abs() < 120.0 && (wp.y - 1535.5).abs() < 120.0,
                "{wp:?}"
            );
            // Nominal and true differ (mounting errors), but not wildly.
            let nom = c.nominal.to_camera().unwrap();
            let p = nom.project(&Point3::new(0.0, 0.0, 30.0)).unwrap();
            assert!((p - wp).norm() > 5.0);
        }
        // Camera 1 looks along +X: world +Z is up in its image.
        let c1 = &rig.camera(1).unwrap().camera;
        let a = c1.project(&Point3::new(0.0, 0.0, 30.0)).unwrap();
        let b = c1.project(&Point3::new(0.0, 0.0, 40.0)).unwrap();
        assert!(b.y < a.y);
    }
}
