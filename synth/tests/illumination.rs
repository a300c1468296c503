//! Radiometric truth of rendered images through a lens
//! (`[optics] illumination = "lens"`), against integrals computed here,
//! independently of the renderer's pixel machinery:
//! - pure cos⁴θ (no distortion, V = 1): the intensity centroid of a sphere's
//!   image is the projection of its centre — no perspective bias at all;
//! - V·cos⁴θ ≡ 1 (V = (1 + tan²θ)²): a radiance image, centroid at the
//!   ellipse centre (`geom::sphere_image`);
//! - any V, with distortion: the flux centroid over ideal (undistorted)
//!   pixel positions equals `K·∫d_xy·V dΩ / ∫d_z·V dΩ` over the sphere's
//!   cone of directions d (the image-plane weight cos⁴θ·V per ideal area is
//!   V·cosθ per solid angle, and x = d_xy/d_z), which METHODS-style
//!   reasoning turns into the rule that a lens with V = 1 + v₁·tan²θ moves
//!   the centroid by (v₁/2)·Δ from the projected centre (Δ the ellipse
//!   centre's perspective bias; cosⁿθ ≈ cos⁴θ·(1 + (4 − n)/2·tan²θ));
//! - flat-field and dark frames: their mean levels against the sensor model.

#![allow(clippy::unwrap_used)]

use geom::Camera;
use geom::nalgebra::{Point2, Vector2, Vector3};
use synth::{
    Config, LensIllumination, Sphere, SynthCamera, SynthRig, ellipse_centre_px, sphere_signals,
};

mod common;

use common::spheres;

/// The seed camera 3 through a lens with vignetting `v`, optionally without distortion.
fn lens_camera(v: [f64; 2], distortion: bool) -> SynthCamera {
    let mut cam = common::seed_camera(distortion);
    cam.lens = Some(LensIllumination::new(&cam.camera, v).unwrap());
    cam
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on Pₙ).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (1..=n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 - 0.25) / (n as f64 + 0.5)).cos();
            for _ in 0..100 {
                let (p, dp) = legendre(n, x);
                let dx = p / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    let (_, dq) = legendre(n, x);
                    return (x, 2.0 / ((1.0 - x * x) * dq * dq));
                }
            }
            (x, 0.0)
        })
        .collect()
}

/// Pₙ(x) and Pₙ′(x) by the three-term recurrence
/// `k·Pₖ = (2k − 1)·x·Pₖ₋₁ − (k − 1)·Pₖ₋₂`, `Pₙ′ = n·(x·Pₙ − Pₙ₋₁)/(x² − 1)`.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
}

/// Flux centroid in ideal pixels of a sphere seen through a lens with
/// vignetting `v`: `K·∫d_xy·V dΩ / ∫d_z·V dΩ` over its cone (Gauss–Legendre
/// in the polar angle β about the cone's axis, the periodic trapezoid rule in
/// the azimuth φ — both converge far below 1e-9 px here).
fn cone_centroid(camera: &Camera, sphere: &Sphere, v: [f64; 2]) -> Point2<f64> {
    let c = camera.to_camera(&sphere.centre).coords;
    let a = c.normalize();
    let alpha = (sphere.radius / c.norm()).asin();
    let e1 = a.cross(&Vector3::x()).normalize();
    let e2 = a.cross(&e1);
    let (mut sxy, mut sz) = (Vector2::zeros(), 0.0);
    let phis = 512;
    for (x, w) in gauss_legendre(64) {
        let beta = alpha * (x + 1.0) / 2.0;
        let wb = w * alpha / 2.0 * beta.sin();
        for k in 0..phis {
            let phi = 2.0 * std::f64::consts::PI * k as f64 / phis as f64;
            let d = a * beta.cos() + (e1 * phi.cos() + e2 * phi.sin()) * beta.sin();
            let t2 = (d.x * d.x + d.y * d.y) / (d.z * d.z);
            let weight = wb * (1.0 + v[0] * t2 + v[1] * t2 * t2);
            sxy += Vector2::new(d.x, d.y) * weight;
            sz += d.z * weight;
        }
    }
    camera.intrinsics.to_pixel(sxy / sz)
}

/// Flux centroid of a rendered signal over ideal pixel positions: `Σ p_ideal·f / Σ f`
/// (the signal already carries J, the light's change of area under distortion).
fn ideal_centroid(camera: &Camera, sig: &synth::Signal) -> Vector2<f64> {
    let (mut sum, mut total) = (Vector2::zeros(), 0.0);
    for r in 0..sig.height {
        for c in 0..sig.width {
            let f = sig.values[r * sig.width + c];
            if f == 0.0 {
                continue;
            }
            let p = Point2::new((sig.x0 + c as i64) as f64, (sig.y0 + r as i64) as f64);
            let ideal = if camera.distortion.is_none() {
                p
            } else {
                camera.undistort_pixel(p).unwrap()
            };
            sum += ideal.coords * f;
            total += f;
        }
    }
    sum / total
}

/// Noise-free centroid tolerance without distortion (px): twice the largest
/// error measured (1.2e-7 px, the 5 mm sphere): the coverage's exact areas
/// and moments, and RI expanded to second order between nodes (≈ 1e-8
/// relative); the test's integral converges far below that.
const LENS_TOL_PX: f64 = 2.5e-7;

/// With distortion (px): twice the largest error measured (4.0e-6 px). The
/// blur acts in observed pixels and the centroid is taken over undistorted
/// positions, a non-linear map: second-order terms of ≈ 1e-6 px.
const DISTORTED_TOL_PX: f64 = 8e-6;

/// Through the 16-bit frame (px): twice the largest error measured (7.7e-6
/// px): each pixel rounded to an integer DN.
const QUANTISED_TOL_PX: f64 = 1.5e-5;

#[test]
fn cos4_lens_centroid_is_the_projected_centre() {
    let cam = lens_camera([0.0, 0.0], false);
    for sphere in spheres() {
        let sig =
            sphere_signals(&cam.camera, &cam.optics, &[sphere], 4, cam.lens.as_ref()).unwrap();
        let c = sig[0].as_ref().unwrap().centroid().unwrap();
        let proj = cam.camera.project_pinhole(&sphere.centre).unwrap();
        let ellipse = ellipse_centre_px(&cam.camera, &sphere).unwrap();
        let err = (c - proj.coords).norm();
        eprintln!(
            "r = {} mm: centroid − projected centre {err:.2e} px (the ellipse centre is {:.3} px away)",
            sphere.radius,
            (ellipse - proj).norm()
        );
        assert!(
            err < LENS_TOL_PX,
            "centroid {c:?} vs projected centre {proj:?}"
        );
        assert!((ellipse - proj).norm() > 0.1, "no bias to tell apart");
    }
}

#[test]
fn lens_that_cancels_cos4_gives_the_ellipse_centre() {
    // cos⁴θ·(1 + tan²θ)² = 1: a radiance image.
    let cam = lens_camera([2.0, 1.0], false);
    for sphere in spheres() {
        let sig =
            sphere_signals(&cam.camera, &cam.optics, &[sphere], 4, cam.lens.as_ref()).unwrap();
        let c = sig[0].as_ref().unwrap().centroid().unwrap();
        let e = ellipse_centre_px(&cam.camera, &sphere).unwrap();
        let err = (c - e.coords).norm();
        eprintln!(
            "r = {} mm: centroid − ellipse centre {err:.2e} px",
            sphere.radius
        );
        assert!(err < LENS_TOL_PX, "centroid {c:?} vs ellipse centre {e:?}");
    }
}

#[test]
fn vignetted_lens_with_distortion_matches_the_cone_integral() {
    for v in [[1.2, 0.0], [-0.8, 2.0]] {
        let cam = lens_camera(v, true);
        assert!(!cam.camera.distortion.is_none());
        for sphere in spheres() {
            let sig =
                sphere_signals(&cam.camera, &cam.optics, &[sphere], 4, cam.lens.as_ref()).unwrap();
            let c = ideal_centroid(&cam.camera, sig[0].as_ref().unwrap());
            let want = cone_centroid(&cam.camera, &sphere, v);
            let err = (c - want.coords).norm();
            eprintln!(
                "V {v:?}, r = {} mm: centroid − cone integral {err:.2e} px",
                sphere.radius
            );
            assert!(err < DISTORTED_TOL_PX, "centroid {c:?} vs {want:?}");
        }
    }
}

/// The rule of thumb: V = 1 + v₁·tan²θ moves the centroid (v₁/2)·Δ outward
/// from the projected centre, Δ = ellipse centre − projected centre. It is a
/// first-order rule (V is expanded across the image); within 3 % here.
#[test]
fn vignetting_moves_the_centroid_by_half_v1_of_the_bias() {
    let v1 = 1.2;
    let cam = lens_camera([v1, 0.0], false);
    for sphere in spheres() {
        let c = cone_centroid(&cam.camera, &sphere, [v1, 0.0]);
        let proj = cam.camera.project_pinhole(&sphere.centre).unwrap();
        let e = ellipse_centre_px(&cam.camera, &sphere).unwrap();
        let delta = e - proj;
        let shift = (c - proj).dot(&delta) / delta.norm_squared();
        eprintln!(
            "r = {} mm: shift {shift:.4} of Δ (rule: {})",
            sphere.radius,
            v1 / 2.0
        );
        assert!((shift / (v1 / 2.0) - 1.0).abs() < 0.03, "{shift}");
    }
}

/// Through the whole frame path (blur, sensor, 16-bit quantisation), noise off:
/// the centroid of the frame (offset removed) is the projected centre under
/// pure cos⁴θ, to the rounding of each pixel to an integer DN.
#[test]
fn quantised_lens_frame_centroid_is_the_projected_centre() {
    let mut cam = lens_camera([0.0, 0.0], false);
    let s = spheres();
    let centroids = common::quantised_centroids(&mut cam, &s, true);
    for (sphere, c) in s.iter().zip(centroids) {
        let proj = cam.camera.project_pinhole(&sphere.centre).unwrap();
        let err = (c - proj.coords).norm();
        eprintln!(
            "r = {} mm: quantised centroid − projected centre {err:.2e} px",
            sphere.radius
        );
        assert!(
            err < QUANTISED_TOL_PX,
            "centroid {c:?} vs projected centre {proj:?}"
        );
    }
}

/// Flat field: mean DN = offset + gain·L·RI over a patch at the centre and at
/// a corner (L at ¾ of full scale where RI is largest); dark: the offset.
/// Patches of 64 × 64 px: the mean's standard error is ≈ σ/64 ≈ 4 DN at the
/// flat's level; the limit is 6 of them. The corner/centre ratio is the lens's RI.
#[test]
fn flat_and_dark_frames_follow_the_lens() {
    let config = Config {
        sensor: synth::config::SensorConfig {
            width: 1024,
            height: 768,
            pixel_mm: 0.022,
            ..Config::default().sensor
        },
        ..Config::default()
    };
    let rig = SynthRig::from_config(&config).unwrap();
    let cam = rig.camera(2).unwrap();
    let lens = cam.lens.as_ref().unwrap();
    let flat = cam.flat_field(config.seed);
    let dark = cam.dark_frame(config.seed);
    let mean = |img: &synth::Image16, u0: u32, v0: u32| {
        let mut s = 0.0;
        for v in v0..v0 + 64 {
            for u in u0..u0 + 64 {
                s += f64::from(img.get_pixel(u, v).0[0]);
            }
        }
        s / 4096.0
    };
    let s = &cam.sensor;
    let l = cam.flat_field_radiance_e();
    for (u0, v0) in [(480, 352), (0, 0), (960, 704)] {
        let ri = lens.at(f64::from(u0) + 31.5, f64::from(v0) + 31.5);
        let want = s.offset_dn + s.gain_dn_per_e * l * ri;
        let sd = s.variance_dn2(l * ri).sqrt();
        let got = mean(&flat, u0, v0);
        eprintln!("flat at ({u0}, {v0}): {got:.1} DN, expected {want:.1} (RI {ri:.4})");
        assert!((got - want).abs() < 6.0 * sd / 64.0, "{got} vs {want}");
        let d = mean(&dark, u0, v0);
        assert!(
            (d - s.offset_dn).abs() < 6.0 * s.variance_dn2(0.0).sqrt() / 64.0 + 0.1,
            "dark {d}"
        );
    }
    let peak = f64::from(*flat.iter().max().unwrap());
    assert!(
        peak > 0.7 * s.max_dn() && peak < 0.85 * s.max_dn(),
        "flat peaks at {peak} DN"
    );
    assert!(
        lens.at(0.0, 0.0) < 0.9 * lens.at(511.5, 383.5),
        "no fall-off to the corner"
    );
}
