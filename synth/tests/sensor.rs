//! The sensor's readout beyond the ideal model (docs/renderer.md): fixed
//! pattern statistics against the configuration, defects where truth.json
//! puts them, left-shifted ADC values, thread-count independence and
//! calibration stacks that share the pattern. 512 × 384 frames: N = 196 608
//! pixels, so a σ estimated over the frame has a relative standard error of
//! 1/√(2N) = 0.16 %; over 512 columns 3.1 %, over 384 rows 3.6 %. Every
//! limit is 4 standard errors.

#![allow(clippy::unwrap_used)]

use std::collections::BTreeSet;

use formats::{OutputPlan, Truth, read_json};
use synth::config::SensorConfig;
use synth::{
    Config, IlluminationModel, Image16, NoProgress, NoiseKey, Sphere, SynthCamera, SynthRig,
    write_target_scene,
};

mod common;

/// The seed's rig at 512 × 384 with radiance images (a flat field is then
/// uniform) and the sensor as `edit` leaves it.
fn config(edit: impl FnOnce(&mut SensorConfig)) -> Config {
    let mut c = common::small_config();
    c.optics.illumination = IlluminationModel::Radiance;
    edit(&mut c.sensor);
    c.validate().unwrap();
    c
}

fn camera(c: &Config) -> SynthCamera {
    SynthRig::from_config(c).unwrap().camera(2).unwrap().clone()
}

/// Without temporal noise: what is left is the pattern (and rounding).
fn noise_free(mut cam: SynthCamera) -> SynthCamera {
    cam.sensor.read_noise_e = 0.0;
    cam.sensor.shot_noise = false;
    cam
}

/// Mean and (n − 1) variance.
fn stats(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let v: Vec<f64> = values.collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var)
}

fn dn(img: &Image16) -> impl Iterator<Item = f64> + '_ {
    img.iter().map(|&x| f64::from(x))
}

/// |σ̂/σ − 1| within 4 standard errors of a σ estimated from `n` values.
fn assert_sigma(what: &str, var: f64, sigma: f64, n: usize) {
    let tol = 4.0 / (2.0 * n as f64).sqrt();
    let got = var.sqrt();
    eprintln!(
        "{what}: σ {got:.5} vs {sigma:.5} (tolerance {:.2} %)",
        100.0 * tol
    );
    assert!(
        (got / sigma - 1.0).abs() < tol,
        "{what}: σ {got} vs {sigma}"
    );
}

/// PRNU: a noise-free flat's relative spread is the configured σ of the gain.
#[test]
fn prnu_is_the_flat_fields_relative_spread() {
    let c = config(|s| s.prnu = 0.01);
    let cam = noise_free(camera(&c));
    let flat = cam.flat_field(c.seed);
    let (s, l) = (&cam.sensor, cam.flat_field_radiance_e());
    let (mean, var) = stats(dn(&flat).map(|x| (x - s.offset_dn) / (s.gain_dn_per_e * l)));
    assert!(
        (mean - 1.0).abs() < 4.0 * 0.01 / (flat.len() as f64).sqrt(),
        "mean gain {mean}"
    );
    // Rounding adds (1/12)/(K·L)² ≈ 3e-11 of variance: negligible.
    assert_sigma("PRNU", var, 0.01, flat.len());
}

/// DSNU: a noise-free dark frame spreads by the configured σ (plus rounding, 1/12 DN²).
#[test]
fn dsnu_is_the_dark_frames_spread() {
    let c = config(|s| s.dsnu_dn = 3.0);
    let dark = noise_free(camera(&c)).dark_frame(c.seed);
    let (mean, var) = stats(dn(&dark));
    assert!((mean - c.sensor.offset_dn).abs() < 4.0 * 3.0 / (dark.len() as f64).sqrt() + 0.05);
    assert_sigma("DSNU", var, (9.0_f64 + 1.0 / 12.0).sqrt(), dark.len());
}

/// Column and row offsets: a noise-free dark frame's column (row) means
/// spread by the configured σ (plus rounding, the same in a whole column
/// or row), and a column pattern leaves every row the same, and vice versa.
#[test]
fn column_and_row_offsets_are_lines() {
    let means = |img: &Image16, columns: bool| -> Vec<f64> {
        let (w, h) = img.dimensions();
        let (outer, inner) = if columns { (w, h) } else { (h, w) };
        (0..outer)
            .map(|i| {
                (0..inner)
                    .map(|j| {
                        let (u, v) = if columns { (i, j) } else { (j, i) };
                        f64::from(img.get_pixel(u, v).0[0])
                    })
                    .sum::<f64>()
                    / f64::from(inner)
            })
            .collect()
    };
    for columns in [true, false] {
        let c = config(|s| {
            if columns {
                s.column_offset_dn = 2.0;
            } else {
                s.row_offset_dn = 2.0;
            }
        });
        let dark = noise_free(camera(&c)).dark_frame(c.seed);
        let lines = means(&dark, columns);
        let (_, var) = stats(lines.iter().copied());
        let what = if columns {
            "column offset"
        } else {
            "row offset"
        };
        assert_sigma(what, var, (4.0_f64 + 1.0 / 12.0).sqrt(), lines.len());
        // The other direction carries no pattern: all its means are equal.
        let (_, across) = stats(means(&dark, !columns).into_iter());
        assert!(across < 1e-20, "{what}: the other lines vary ({across})");
    }
}

/// Hot pixels are where truth.json and `SynthCamera::defects` put them: in
/// a dark frame exactly those pixels stand out, each at offset + K·dark
/// electrons within 6 σ of its noise; dead pixels are exactly the flat's
/// pixels at the offset. Every position is distinct.
#[test]
fn defects_are_at_truths_positions() {
    let c = config(|s| {
        s.hot_pixels = 50;
        s.hot_pixel_e = [2000.0, 8000.0];
        s.dead_pixels = 30;
    });
    let cam = camera(&c);
    let defects = cam.defects();
    assert_eq!((defects.hot.len(), defects.dead.len()), (50, 30));
    let s = &cam.sensor;
    let dark = cam.dark_frame(c.seed);
    let bright: BTreeSet<(u32, u32)> = dark
        .enumerate_pixels()
        .filter(|(_, _, p)| f64::from(p.0[0]) > s.offset_dn + 1000.0)
        .map(|(x, y, _)| (x, y))
        .collect();
    let hot: BTreeSet<(u32, u32)> = defects.hot.iter().map(|h| (h.x, h.y)).collect();
    assert_eq!(bright, hot);
    for h in &defects.hot {
        let want = s.expected_dn(h.dark_e);
        let got = f64::from(dark.get_pixel(h.x, h.y).0[0]);
        assert!(
            (got - want).abs() < 6.0 * s.variance_dn2(h.dark_e).sqrt(),
            "hot {h:?}: {got}"
        );
    }
    let flat = cam.flat_field(c.seed);
    let dim: BTreeSet<(u32, u32)> = flat
        .enumerate_pixels()
        .filter(|(_, _, p)| f64::from(p.0[0]) < s.offset_dn + 1000.0)
        .map(|(x, y, _)| (x, y))
        .collect();
    let dead: BTreeSet<(u32, u32)> = defects.dead.iter().map(|d| (d[0], d[1])).collect();
    assert_eq!(dim, dead);
    assert!(hot.is_disjoint(&dead));

    // truth.json lists the same pixels per camera.
    let dir = tempfile::tempdir().unwrap();
    write_target_scene(&c, dir.path(), &mut OutputPlan::new(false), &NoProgress).unwrap();
    let truth: Truth = read_json(&dir.path().join("truth.json")).unwrap();
    let rig = SynthRig::from_config(&c).unwrap();
    for t in &truth.cameras {
        let sensor = &t.extra["sensor"];
        let listed = |key: &str| -> BTreeSet<(u64, u64)> {
            sensor[key]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| (p["x"].as_u64().unwrap(), p["y"].as_u64().unwrap()))
                .collect()
        };
        let d = rig.camera(t.model.id).unwrap().defects();
        let own = |v: Vec<(u32, u32)>| -> BTreeSet<(u64, u64)> {
            v.into_iter()
                .map(|(x, y)| (u64::from(x), u64::from(y)))
                .collect()
        };
        assert_eq!(
            listed("hot_pixels"),
            own(d.hot.iter().map(|h| (h.x, h.y)).collect())
        );
        assert_eq!(
            listed("dead_pixels"),
            own(d.dead.iter().map(|p| (p[0], p[1])).collect())
        );
        assert_eq!(sensor["calibration_frames"], 1);
    }
    // Each camera has its own pattern (keyed by serial).
    assert_ne!(
        rig.camera(1).unwrap().defects(),
        rig.camera(2).unwrap().defects()
    );
}

fn sphere_frame(cam: &SynthCamera, seed: u64) -> Image16 {
    let spheres = [Sphere {
        centre: geom::Point3::new(5.0, 0.0, 30.0),
        radius: 10.0,
        radiance_e: 12_000.0,
    }];
    let key = NoiseKey {
        seed,
        frame: 4,
        camera: cam.id,
    };
    cam.render(&spheres, key, 3).unwrap()
}

/// An ADC of n bits in a 16-bit file writes multiples of 2^(16 − n): flats,
/// darks and sphere frames. Noise-free, every pixel of a flat is the ADC code
/// of offset + K·L; a dark frame above the ADC's range sits at its largest code.
#[test]
fn adc_values_are_left_shifted() {
    for adc_bits in [10u8, 12, 14] {
        let step = 1u16 << (16 - adc_bits);
        let c = config(|s| {
            s.adc_bits = adc_bits;
            s.prnu = 0.01;
            s.hot_pixels = 5;
            s.hot_pixel_e = [100.0, 200.0];
        });
        let cam = camera(&c);
        for img in [
            cam.flat_field(c.seed),
            cam.dark_frame(c.seed),
            sphere_frame(&cam, c.seed),
        ] {
            assert!(img.iter().all(|&x| x % step == 0), "{adc_bits}-bit ADC");
            // Not a constant image (a dark frame's noise spans few codes).
            let distinct: BTreeSet<u16> = img.iter().copied().collect();
            assert!(
                distinct.len() > 2,
                "{adc_bits}-bit: only {} values",
                distinct.len()
            );
        }
        let mut plain = noise_free(camera(&config(|s| s.adc_bits = adc_bits)));
        let s = plain.sensor.clone();
        let l = plain.flat_field_radiance_e();
        let code = ((s.offset_dn + s.gain_dn_per_e * l) / f64::from(step) + 0.5).floor();
        let want = code as u16 * step;
        assert!(plain.flat_field(c.seed).iter().all(|&x| x == want));
        // Above the ADC's range: its largest code, shifted.
        plain.sensor.offset_dn = 70_000.0;
        let top = ((1u32 << adc_bits) - 1) as u16 * step;
        assert!(plain.dark_frame(c.seed).iter().all(|&x| x == top));
    }
    // An ADC of the file's own depth is the default readout, byte for byte.
    let c16 = config(|s| s.adc_bits = 16);
    let c0 = config(|_| {});
    assert_eq!(
        sphere_frame(&camera(&c16), 3).as_raw(),
        sphere_frame(&camera(&c0), 3).as_raw()
    );
}

/// Every part of the fixed pattern, as the stacks test counts it: PRNU 1 %,
/// DSNU 2 DN, column offsets 1.5 DN, 10 hot pixels of 3000–6000 e⁻, 5 dead.
fn full_pattern(s: &mut SensorConfig) {
    s.prnu = 0.01;
    s.dsnu_dn = 2.0;
    s.column_offset_dn = 1.5;
    s.hot_pixels = 10;
    s.hot_pixel_e = [3000.0, 6000.0];
    s.dead_pixels = 5;
}

/// Same bytes for 1 and 4 threads, pattern maps drawn in either pool.
#[test]
fn pattern_frames_do_not_depend_on_threads() {
    let c = config(|s| {
        full_pattern(s);
        s.adc_bits = 12;
        s.row_offset_dn = 0.5;
    });
    let frames = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let cam = camera(&c);
            [
                cam.flat_field_at(c.seed, 2),
                cam.dark_frame(c.seed),
                sphere_frame(&cam, c.seed),
            ]
        })
    };
    let (one, four) = (frames(1), frames(4));
    for (a, b) in one.iter().zip(&four) {
        assert_eq!(a.as_raw(), b.as_raw());
    }
}

/// A stack of 4 flats and 4 darks per camera: folders of 4 frames, no
/// single files; frames differ (temporal noise) but share the pattern: the
/// variance of the difference of two flats is twice the temporal variance
/// K²·(L + σ_read²) + 1/12, while one flat's variance adds the PRNU's
/// (K·L·prnu)², DSNU and column offsets; hot and dead pixels are the same in
/// every frame. Defects are left out of the flat's statistics.
#[test]
fn calibration_stacks_share_the_pattern() {
    let c = config(|s| {
        full_pattern(s);
        s.calibration_frames = 4;
    });
    let dir = tempfile::tempdir().unwrap();
    let summary =
        write_target_scene(&c, dir.path(), &mut OutputPlan::new(false), &NoProgress).unwrap();
    assert_eq!(summary.images.len(), 3 * (1 + 4 + 4));
    let calib = dir.path().join("calib");
    assert!(!calib.join("flat_cam2.tif").exists() && !calib.join("dark_cam2.tif").exists());
    let read = |kind: &str, i: u32| {
        let p = calib.join(format!("{kind}_cam2/{kind}_{i:03}.tif"));
        image::open(&p).unwrap().to_luma16()
    };
    let flats: Vec<Image16> = (1..=4).map(|i| read("flat", i)).collect();
    let darks: Vec<Image16> = (1..=4).map(|i| read("dark", i)).collect();
    let cam = camera(&c);
    assert_eq!(flats[0].as_raw(), cam.flat_field(c.seed).as_raw());
    assert_eq!(flats[3].as_raw(), cam.flat_field_at(c.seed, 3).as_raw());
    assert_eq!(darks[1].as_raw(), cam.dark_frame_at(c.seed, 1).as_raw());
    let d = cam.defects();
    let defective: BTreeSet<(u32, u32)> = d
        .hot
        .iter()
        .map(|h| (h.x, h.y))
        .chain(d.dead.iter().map(|p| (p[0], p[1])))
        .collect();
    let good = |img: &Image16| -> Vec<f64> {
        img.enumerate_pixels()
            .filter(|(x, y, _)| !defective.contains(&(*x, *y)))
            .map(|(_, _, p)| f64::from(p.0[0]))
            .collect()
    };
    let (s, l) = (&cam.sensor, cam.flat_field_radiance_e());
    let k = s.gain_dn_per_e;
    let temporal = k * k * (l + s.read_noise_e.powi(2)) + 1.0 / 12.0;
    for pair in flats.windows(2) {
        assert_ne!(pair[0].as_raw(), pair[1].as_raw());
        let (a, b) = (good(&pair[0]), good(&pair[1]));
        let n = a.len();
        let (_, var_diff) = stats(a.iter().zip(&b).map(|(x, y)| x - y));
        let tol = 4.0 * (2.0 / n as f64).sqrt();
        assert!(
            (var_diff / 2.0 / temporal - 1.0).abs() < tol,
            "temporal {var_diff} vs 2·{temporal}"
        );
        // One flat: temporal + PRNU + DSNU + columns (+ rounding, counted once).
        let (_, var_one) = stats(a.into_iter());
        let pattern = (k * l * 0.01).powi(2) + 4.0 + 1.5 * 1.5;
        let fixed = var_one - var_diff / 2.0;
        eprintln!(
            "flat: temporal {:.0} DN², fixed {fixed:.0} DN² (expected {pattern:.0})",
            var_diff / 2.0
        );
        assert!(
            (fixed / pattern - 1.0).abs() < 0.05,
            "fixed pattern {fixed} vs {pattern}"
        );
    }
    // The defects are the same in every frame of both stacks.
    for img in flats.iter() {
        assert!(
            d.dead
                .iter()
                .all(|p| f64::from(img.get_pixel(p[0], p[1]).0[0]) < s.offset_dn + 200.0)
        );
        assert!(d.hot.iter().all(
            |h| f64::from(img.get_pixel(h.x, h.y).0[0]) > s.expected_dn(l) + 0.5 * k * h.dark_e
        ));
    }
    for img in darks.iter() {
        assert!(d.hot.iter().all(|h| f64::from(img.get_pixel(h.x, h.y).0[0]) > s.offset_dn + 0.5 * k * h.dark_e));
    }
    let truth: Truth = read_json(&dir.path().join("truth.json")).unwrap();
    assert!(
        truth
            .cameras
            .iter()
            .all(|t| t.extra["sensor"]["calibration_frames"] == 4)
    );
}

/// The pattern is the same in every frame of a campaign: with hot pixels
/// bright enough to saturate, each of camera 2's frames — the continuous
/// stream with motion blur, its target image, flat field and dark frame —
/// holds the ADC's largest code at exactly its hot pixels' positions (and
/// its dead pixels stay dark in the flat).
#[test]
fn every_frame_of_a_campaign_has_the_pattern() {
    let mut c = config(|s| {
        s.adc_bits = 12;
        s.hot_pixels = 12;
        s.hot_pixel_e = [20_000.0, 30_000.0];
        s.dead_pixels = 4;
    });
    c.procedure.runs = 1;
    c.procedure.fps = 5.0;
    c.procedure.feed_mm_per_s = 40.0;
    c.procedure.settle_s = 0.5;
    for a in &mut c.procedure.axes {
        a.segments = 1;
        a.start_mm = -10.0;
        a.length_mm = 20.0;
        a.lines_mm = vec![0.0];
    }
    c.capture.mode = synth::config::CaptureMode::Continuous;
    c.capture.blur_steps = 2;
    c.validate().unwrap();
    let dir = tempfile::tempdir().unwrap();
    synth::write_campaign(&c, dir.path(), &mut OutputPlan::new(false), &NoProgress).unwrap();
    let cam = camera(&c);
    let defects = cam.defects();
    let hot: BTreeSet<(u32, u32)> = defects.hot.iter().map(|h| (h.x, h.y)).collect();
    let top = 4095 << 4;
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir.path().join(&cam.serial))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(files.len() > 10, "{} frames", files.len());
    for name in ["cam2.tif", "flat_cam2.tif", "dark_cam2.tif"] {
        files.push(dir.path().join("calib").join(name));
    }
    for f in &files {
        let img = image::open(f).unwrap().to_luma16();
        let saturated: BTreeSet<(u32, u32)> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0[0] == top)
            .map(|(x, y, _)| (x, y))
            .collect();
        assert_eq!(saturated, hot, "{}", f.display());
    }
    let flat = image::open(dir.path().join("calib/flat_cam2.tif"))
        .unwrap()
        .to_luma16();
    assert!(
        defects
            .dead
            .iter()
            .all(|p| flat.get_pixel(p[0], p[1]).0[0] < 1000)
    );
}
