//! One frame: each sphere's visible silhouette → exact coverage → times the
//! lens's relative illumination (when rendering through a lens) → its own
//! blur (PSF + defocus at its depth) → sensor exposure.

use geom::Camera;

use crate::coverage::{PixelRect, coverage};
use crate::illumination::LensIllumination;
use crate::psf::{Optics, Signal, blur, kernel_radius};
use crate::rig::SynthCamera;
use crate::scene::{Sphere, ViewedSphere, check_disjoint, outline_bounds};
use crate::sensor::{Exposure, Image16, NoiseKey};
use crate::{Result, SynthError};

/// The noise-free signal of each sphere (fraction of a fully covered pixel's
/// flux per pixel at the principal point, after occlusion, the lens's
/// relative illumination `lens` when given, and blur); `None` for a sphere
/// wholly outside the image. Signals extend past the image by the blur radius
/// so that light from just outside reaches the border pixels.
pub fn sphere_signals(
    camera: &Camera,
    optics: &Optics,
    spheres: &[Sphere],
    max_depth: u8,
    lens: Option<&LensIllumination>,
) -> Result<Vec<Option<Signal>>> {
    check_disjoint(spheres)?;
    let viewed = spheres
        .iter()
        .map(|s| ViewedSphere::new(camera, s))
        .collect::<Result<Vec<_>>>()?;
    let (w, h) = (i64::from(camera.width), i64::from(camera.height));
    let mut out = Vec::with_capacity(spheres.len());
    for (i, (sphere, v)) in spheres.iter().zip(&viewed).enumerate() {
        let occluders: Vec<ViewedSphere> = viewed
            .iter()
            .enumerate()
            .filter(|&(j, o)| j != i && v.occluded_by(o))
            .map(|(_, o)| *o)
            .collect();
        let sigma = optics.blur_sigma_px(v.centre.z);
        if !sigma.is_finite() {
            return Err(SynthError::BlurSigma(sigma));
        }
        let r = kernel_radius(sigma) as i64;
        let b = outline_bounds(camera, sphere)?;
        let rect = PixelRect {
            u0: (b[0].floor() as i64 - 1).max(-r),
            v0: (b[1].floor() as i64 - 1).max(-r),
            u1: (b[2].ceil() as i64 + 1).min(w - 1 + r),
            v1: (b[3].ceil() as i64 + 1).min(h - 1 + r),
        };
        if rect.is_empty() {
            out.push(None);
            continue;
        }
        let mut cov = coverage(camera, v, &occluders, rect, max_depth)?;
        if let Some(lens) = lens {
            lens.weigh(&mut cov);
        }
        out.push(Some(blur(&cov, sigma)));
    }
    Ok(out)
}

/// Render one frame of `cam`: the spheres over the sensor's background,
/// with noise, through the camera's readout (ADC, fixed pattern); through
/// its lens's relative illumination when it has one (the spheres' light and
/// the background light), radiance per pixel otherwise.
pub(crate) fn render(
    cam: &SynthCamera,
    spheres: &[Sphere],
    key: NoiseKey,
    max_depth: u8,
) -> Result<Image16> {
    let (camera, sensor) = (&cam.camera, &cam.sensor);
    if sensor.width != camera.width || sensor.height != camera.height {
        return Err(SynthError::SensorSize {
            sensor: (sensor.width, sensor.height),
            camera: (camera.width, camera.height),
        });
    }
    let signals = sphere_signals(camera, &cam.optics, spheres, max_depth, cam.lens.as_ref())?;
    let layers: Vec<Exposure<'_>> = signals
        .iter()
        .zip(spheres)
        .filter_map(|(s, sp)| {
            s.as_ref().map(|signal| Exposure {
                signal,
                radiance_e: sp.radiance_e,
            })
        })
        .collect();
    Ok(cam.expose(&layers, key))
}
