//! Solve time of a calibration over views at the scale: 3 cameras ×
//! 20 views × 50 points (a 10 × 5 board at 20 poses, each seen by every
//! camera, 0.1 px noise): Zhang's start, the bundle (≈ 160 unknowns, 6000
//! residuals) with the k·σ rejection and the covariance.
//!
//! `cargo bench -p calib --bench views`

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;

use calib::{Observation, Options, View, calibrate_views};
use geom::nalgebra::Isometry3;
use geom::{Camera, Distortion, Intrinsics, Point2, Point3, Vector3};

fn main() {
    divan::main();
}

/// The views: cameras side by side 100 mm apart, turned towards the board
/// 500 mm away; the board tilted up to ±0.35 rad between poses.
fn views() -> Vec<View> {
    let cameras: Vec<Camera> = (0..3)
        .map(|c| {
            let x = 100.0 * f64::from(c) - 100.0;
            Camera {
                intrinsics: Intrinsics {
                    fx: 1400.0,
                    fy: 1398.0,
                    cx: 640.0,
                    cy: 480.0,
                    skew: 0.0,
                },
                distortion: Distortion {
                    k1: -0.1,
                    k2: 0.04,
                    k3: 0.0,
                    p1: 3e-4,
                    p2: -2e-4,
                },
                pose: Isometry3::new(
                    Vector3::new(-x - 90.0, -40.0, 0.0),
                    Vector3::new(0.0, x / 500.0, 0.0),
                ),
                width: 1280,
                height: 960,
            }
        })
        .collect();
    let board: Vec<Point3<f64>> = (0..10)
        .flat_map(|i| {
            (0..5).map(move |j| Point3::new(20.0 * f64::from(i), 20.0 * f64::from(j), 0.0))
        })
        .collect();
    // Uniform noise of σ 0.1 px from a 64-bit LCG: reproducible.
    let mut seed = 7u64;
    let mut noise = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        0.1 * (((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5) * 12f64.sqrt()
    };
    let mut views = Vec::new();
    for p in 0..20u32 {
        let a = f64::from(p);
        let pose = Isometry3::new(
            Vector3::new(
                -5.0 * (a * 0.9).sin(),
                5.0 * (a * 1.7).cos(),
                480.0 + 2.0 * a,
            ),
            Vector3::new(
                0.35 * (a * 1.3).sin(),
                0.35 * (a * 0.7 + 1.0).cos(),
                0.05 * a,
            ),
        );
        for (c, camera) in cameras.iter().enumerate() {
            let observations = board
                .iter()
                .enumerate()
                .map(|(id, x)| {
                    let px = camera.project(&(pose * x)).unwrap();
                    Observation {
                        id: id as u32,
                        world: *x,
                        pixel: Point2::new(px.x + noise(), px.y + noise()),
                        sphere_diameter: None,
                    }
                })
                .collect();
            views.push(View {
                camera: c as u8 + 1,
                pose: p,
                observations,
            });
        }
    }
    views
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn three_cameras_twenty_views(bencher: divan::Bencher) {
    let views = views();
    let sizes: BTreeMap<u8, (u32, u32)> = (1..=3).map(|c| (c, (1280, 960))).collect();
    bencher.bench(|| {
        let rig = calibrate_views(divan::black_box(&views), &sizes, &Options::default()).unwrap();
        assert!(rig.cameras.iter().all(|c| c.rms_px < 0.2));
        rig
    });
}
