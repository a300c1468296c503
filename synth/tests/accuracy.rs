//! Sub-pixel truth of rendered radiance images of spheres against the analytic
//! image of a sphere (geom::sphere_image): intensity centroid = ellipse centre
//! and perspective bias Δ = r_c·R²/(Z² − R²), with and without lens distortion
//! (after undistortion with the area Jacobian), within twice the measured errors.

#![allow(clippy::unwrap_used)]

use geom::nalgebra::{Point2, Vector2};
use geom::{Camera, Distortion};
use synth::{Config, Sphere, SynthRig, ellipse_centre_px, sphere_signals};

mod common;

use common::spheres;

/// The seed camera 3 rendering radiance images (the lens's relative
/// illumination has its own tests in `illumination.rs`), optionally without
/// distortion.
fn seed_camera(distortion: bool) -> synth::SynthCamera {
    let mut cam = common::seed_camera(distortion);
    cam.lens = None;
    cam
}

/// Noise-free centroid tolerance: twice the largest error measured (1.2e-7
/// px, the 5 mm sphere; exact areas and first moments, the blur's expansion).
const CENTROID_TOL_PX: f64 = 2.5e-7;

/// Through the 16-bit frame: twice the largest error measured (1.2e-6 px),
/// from rounding every pixel to an integer DN.
const QUANTISED_TOL_PX: f64 = 2.5e-6;

/// Over undistorted positions: twice the largest error measured (1.2e-5 px);
/// the blur acts in observed pixels, the centroid is taken through the
/// non-linear undistortion.
const UNDISTORTED_TOL_PX: f64 = 2.5e-5;

/// Perspective bias against r_c·R²/(Z² − R²), relative: twice the largest
/// departure measured (1.0e-4, the 5 mm sphere through the distortion).
const BIAS_TOL: f64 = 2e-4;

/// Intensity centroid of the noise-free rendered image of each sphere.
#[test]
fn centroid_is_the_ellipse_centre() {
    let cam = seed_camera(false);
    let s = spheres();
    let signals = sphere_signals(&cam.camera, &cam.optics, &s, 4, None).unwrap();
    for (sphere, signal) in s.iter().zip(&signals) {
        let c = signal.as_ref().unwrap().centroid().unwrap();
        let e = ellipse_centre_px(&cam.camera, sphere).unwrap();
        let err = (c - e.coords).norm();
        eprintln!("r = {} mm: centroid error {err:.2e} px", sphere.radius);
        assert!(
            err < CENTROID_TOL_PX,
            "centroid {c:?} vs ellipse centre {e:?}"
        );
    }
}

/// Centroid of the full pipeline (coverage → blur → sensor → 16-bit DN), noise off,
/// background removed by subtracting the offset.
#[test]
fn quantised_frame_centroid_is_the_ellipse_centre() {
    let mut cam = seed_camera(false);
    let s = spheres();
    let centroids = common::quantised_centroids(&mut cam, &s, false);
    for (sphere, c) in s.iter().zip(centroids) {
        let e = ellipse_centre_px(&cam.camera, sphere).unwrap();
        let err = (c - e.coords).norm();
        eprintln!(
            "r = {} mm: quantised centroid error {err:.2e} px",
            sphere.radius
        );
        assert!(
            err < QUANTISED_TOL_PX,
            "centroid {c:?} vs ellipse centre {e:?}"
        );
    }
}

/// Offset of the centroid from the projected centre against
/// Δ = r_c·R²/(Z² − R²) (docs/methods.md), radially outward, within 2 %.
fn check_bias(camera: &Camera, sphere: &Sphere, centroid: Vector2<f64>) {
    let proj = camera.project_pinhole(&sphere.centre).unwrap();
    let pp = Vector2::new(camera.intrinsics.cx, camera.intrinsics.cy);
    let r_c = (proj.coords - pp).norm();
    let z = camera.to_camera(&sphere.centre).z;
    let r2 = sphere.radius * sphere.radius;
    let expected = r_c * r2 / (z * z - r2);
    let delta = centroid - proj.coords;
    let radial = delta.dot(&(proj.coords - pp).normalize());
    eprintln!(
        "r = {} mm: Δ = {:.4} px (radial {:.4}), formula {expected:.4} px, ratio {:.5}",
        sphere.radius,
        delta.norm(),
        radial,
        delta.norm() / expected
    );
    assert!(
        expected > 0.05,
        "test sphere too close to the axis to test the bias"
    );
    assert!((delta.norm() / expected - 1.0).abs() < BIAS_TOL);
    assert!(radial > 0.99 * delta.norm(), "bias is not radially outward");
}

#[test]
fn perspective_bias_matches_the_formula() {
    let cam = seed_camera(false);
    let s = spheres();
    let signals = sphere_signals(&cam.camera, &cam.optics, &s, 4, None).unwrap();
    for (sphere, signal) in s.iter().zip(&signals) {
        check_bias(
            &cam.camera,
            sphere,
            signal.as_ref().unwrap().centroid().unwrap(),
        );
    }
}

/// With the camera's Brown distortion on: the centroid over undistorted pixel
/// positions, weighted by intensity × area Jacobian of the undistortion
/// (docs/methods.md), is the ellipse centre, and its bias matches the formula.
#[test]
fn undistorted_centroid_is_the_ellipse_centre() {
    let cam = seed_camera(true);
    assert!(!cam.camera.distortion.is_none());
    let s = spheres();
    let signals = sphere_signals(&cam.camera, &cam.optics, &s, 4, None).unwrap();
    for (sphere, signal) in s.iter().zip(&signals) {
        let sig = signal.as_ref().unwrap();
        let mut sum = Vector2::zeros();
        let mut total = 0.0;
        for r in 0..sig.height {
            for c in 0..sig.width {
                let f = sig.values[r * sig.width + c];
                if f == 0.0 {
                    continue;
                }
                let p = Point2::new((sig.x0 + c as i64) as f64, (sig.y0 + r as i64) as f64);
                let (ideal, jac) = cam.camera.undistort_pixel_area(p).unwrap();
                sum += ideal.coords * (f * jac);
                total += f * jac;
            }
        }
        let c = sum / total;
        let e = ellipse_centre_px(&cam.camera, sphere).unwrap();
        let plain = sig.centroid().unwrap();
        let err = (c - e.coords).norm();
        eprintln!(
            "r = {} mm: undistorted centroid error {err:.2e} px (distorted centroid is {:.3} px away)",
            sphere.radius,
            (plain - e.coords).norm()
        );
        assert!(
            err < UNDISTORTED_TOL_PX,
            "centroid {c:?} vs ellipse centre {e:?}"
        );
        check_bias(&cam.camera, sphere, c);
    }
}

/// Variance of a signal about its centroid along u (`axis` 0) or v (1), px².
fn variance(s: &synth::Signal, axis: usize) -> f64 {
    let c = s.centroid().unwrap();
    let (mut var, mut total) = (0.0, 0.0);
    for r in 0..s.height {
        for k in 0..s.width {
            let val = s.values[r * s.width + k];
            let p = [(s.x0 + k as i64) as f64, (s.y0 + r as i64) as f64];
            let d = p[axis] - c[axis];
            var += val * d * d;
            total += val;
        }
    }
    var / total
}

/// The blur has the physical width: the rendered image's variance about its
/// centroid is the silhouette's (a circle of radius ρ px on the axis: ρ²/4
/// per axis) plus the PSF's σ² plus the pixel's 1/12 px² (sampling of
/// S ∗ G ∗ box). Tolerance 2e-3 px² (0.5 % of the smallest blur variance):
/// the edge pixels' second-order shape terms and the sampling of a
/// σ ≥ 0.55 px blur are ≈ 1e-4 px²; dropping the pixel's 1/12 would fail it.
#[test]
fn blur_width_is_psf_plus_pixel() {
    use synth::ViewedSphere;
    use synth::{PixelRect, coverage};
    let cam = seed_camera(false);
    // On the optical axis of camera 3 at 460 mm: a circle.
    let c = cam.camera.centre() + cam.camera.optical_axis().into_inner() * 460.0;
    let sphere = Sphere {
        centre: c,
        radius: 5.0,
        radiance_e: 1.0,
    };
    let v = ViewedSphere::new(&cam.camera, &sphere).unwrap();
    let f = cam.camera.intrinsics.fx;
    let rho = f * 5.0 / (460.0f64 * 460.0 - 25.0).sqrt();
    let e = ellipse_centre_px(&cam.camera, &sphere).unwrap();
    let rect = PixelRect {
        u0: (e.x - rho) as i64 - 3,
        v0: (e.y - rho) as i64 - 3,
        u1: (e.x + rho) as i64 + 3,
        v1: (e.y + rho) as i64 + 3,
    };
    let cov = coverage(&cam.camera, &v, &[], rect, 5).unwrap();
    for sigma in [0.55, 1.0, 2.5] {
        let s = synth::blur(&cov, sigma);
        let added = variance(&s, 0) - rho * rho / 4.0;
        eprintln!(
            "σ = {sigma}: variance added {added:.4} px², expected {:.4}",
            sigma * sigma + 1.0 / 12.0
        );
        assert!(
            (added - sigma * sigma - 1.0 / 12.0).abs() < 2e-3,
            "σ = {sigma}: added {added}"
        );
    }
}

/// Defocus: camera 1 looks along X, so a sphere moved along X changes depth
/// and blurs by the thin-lens circle of confusion c = f²/(N(s − f))·|z − s|/z,
/// added as (c/4)² to the PSF's variance. Checked on the rendered image of a
/// sphere on camera 1's axis at the focus distance and 75 mm nearer/farther,
/// computing c here from the lens data (independently of `synth::blur`).
#[test]
fn defocus_grows_off_the_focus_plane() {
    let config = Config::default();
    let rig = SynthRig::from_config(&config).unwrap();
    let mut cam = rig.camera(1).unwrap().clone();
    cam.camera.distortion = Distortion::NONE;
    let o = &config.optics;
    let pixel = config.sensor.pixel_mm;
    let sigma_psf = o.psf_sigma_um / 1000.0 / pixel;
    let mut added_prev: f64 = 0.0;
    for z in [460.0, 535.0, 385.0] {
        let centre = cam.camera.centre() + cam.camera.optical_axis().into_inner() * z;
        let sphere = Sphere {
            centre,
            radius: 5.0,
            radiance_e: 1.0,
        };
        let s = sphere_signals(&cam.camera, &cam.optics, &[sphere], 5, None).unwrap();
        let s = s[0].as_ref().unwrap();
        let rho = cam.camera.intrinsics.fy * 5.0 / (z * z - 25.0f64).sqrt();
        let added = variance(s, 1) - rho * rho / 4.0;
        let coc = o.focal_mm * o.focal_mm / (o.f_number * (o.focus_distance_mm - o.focal_mm))
            * (z - o.focus_distance_mm).abs()
            / z
            / pixel;
        let expected = sigma_psf * sigma_psf + coc * coc / 16.0 + 1.0 / 12.0;
        eprintln!(
            "z = {z} mm: blur variance {added:.4} px², expected {expected:.4} (c = {coc:.2} px)"
        );
        assert!(
            (added / expected - 1.0).abs() < 0.01,
            "z = {z}: {added} vs {expected}"
        );
        if z != 460.0 {
            assert!(added > 10.0 * added_prev.max(0.3), "defocus did not grow");
        } else {
            added_prev = added;
        }
    }
}
