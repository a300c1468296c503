//! What the renderer's tests share: the seed's camera 3 and three spheres
//! far off its axis; the seed's configuration at 512 × 384. Each test crate
//! uses a part of it.

#![allow(dead_code)]

use geom::Distortion;
use geom::nalgebra::{Point3, Vector2};
use synth::{
    Config, Image16, NoiseKey, Overrides, Signal, Sphere, SynthCamera, SynthRig, sphere_signals,
};

/// The seed's configuration at 512 × 384 px (the same field of view).
pub fn small_config() -> Config {
    let mut c = Config::default();
    c.apply(&Overrides {
        width: Some(512),
        height: Some(384),
        ..Overrides::default()
    })
    .unwrap();
    c
}

/// The seed camera 3 (true model of the default config), optionally without
/// distortion; its relative illumination as the default config gives it.
pub fn seed_camera(distortion: bool) -> SynthCamera {
    let rig = SynthRig::from_config(&Config::default()).unwrap();
    let mut cam = rig.camera(3).unwrap().clone();
    if !distortion {
        cam.camera.distortion = Distortion::NONE;
    }
    cam
}

/// Spheres far off-axis (large perspective bias), at arbitrary sub-pixel
/// positions, defocused (camera 3 is focused at z = 30), none hiding another.
pub fn spheres() -> Vec<Sphere> {
    vec![
        Sphere {
            centre: Point3::new(75.0, 50.123, 30.0),
            radius: 10.0,
            radiance_e: 12_000.0,
        },
        Sphere {
            centre: Point3::new(-83.37, -40.71, 45.0),
            radius: 7.5,
            radiance_e: 12_000.0,
        },
        Sphere {
            centre: Point3::new(-20.2, 62.9, 0.0),
            radius: 5.0,
            radiance_e: 12_000.0,
        },
    ]
}

/// The whole frame path of `cam` (blur, sensor, 16-bit quantisation) over
/// `spheres` with every noise and the background off, 4× supersampled.
pub fn noise_free_frame(cam: &mut SynthCamera, spheres: &[Sphere]) -> Image16 {
    cam.sensor.read_noise_e = 0.0;
    cam.sensor.shot_noise = false;
    cam.sensor.background_e = 0.0;
    let key = NoiseKey {
        seed: 1,
        frame: 0,
        camera: 3,
    };
    cam.render(spheres, key, 4).unwrap()
}

/// The gray centroid (px) of `img` over a sphere's signal window, the
/// sensor offset `offset_dn` removed.
pub fn window_centroid(img: &Image16, sig: &Signal, offset_dn: f64) -> Vector2<f64> {
    let (mut sum, mut total) = (Vector2::zeros(), 0.0);
    for r in 0..sig.height as i64 {
        for c in 0..sig.width as i64 {
            let (u, v) = (sig.x0 + c, sig.y0 + r);
            let f = f64::from(img.get_pixel(u as u32, v as u32).0[0]) - offset_dn;
            sum += Vector2::new(u as f64, v as f64) * f;
            total += f;
        }
    }
    sum / total
}

/// The centroid (px) of each sphere in `cam`'s noise-free frame
/// ([`noise_free_frame`]), over its signal window (computed through the
/// camera's lens illumination when `with_lens`).
pub fn quantised_centroids(
    cam: &mut SynthCamera,
    spheres: &[Sphere],
    with_lens: bool,
) -> Vec<Vector2<f64>> {
    let img = noise_free_frame(cam, spheres);
    let lens = if with_lens { cam.lens.as_ref() } else { None };
    let signals = sphere_signals(&cam.camera, &cam.optics, spheres, 4, lens).unwrap();
    signals
        .iter()
        .map(|s| window_centroid(&img, s.as_ref().unwrap(), cam.sensor.offset_dn))
        .collect()
}
