//! `calibrate` and `SensorMaps::correct` on simulated stacks of the
//! METHODS §6 pixel model (see `sim`): defects, DSNU and PRNU, the use
//! decisions, the correction of a frame, and determinism across threads.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod sim;

use sensor::{DarkModel, DefectKind, Options, SensorCalibration, calibrate};
use sim::{Pattern, Sensor, frames, sample_sigma};

/// Calibrate `sensor` from `n_flats` flats (≈ 60 % of full scale at the
/// centre, with the lens fall-off) and `n_darks` darks.
fn calibrated(
    sensor: &Sensor,
    n_flats: usize,
    n_darks: usize,
    options: &Options,
    seed: u64,
) -> SensorCalibration {
    let flats = sensor.stack(&sensor.flat_signal(0.6), n_flats, seed);
    let darks = sensor.stack(&|_, _| 0.0, n_darks, seed + 1000);
    let smooth = |u: f64, v: f64| sensor.falloff(u, v);
    calibrate(
        &frames(&flats, sensor, Some(0.004)),
        &frames(&darks, sensor, Some(0.004)),
        &smooth,
        options,
    )
    .unwrap()
}

/// (found, false positives) of the injected defects of one kind.
fn found(sensor: &Sensor, cal: &SensorCalibration, kind: DefectKind) -> (usize, usize, usize) {
    let injected: Vec<(u32, u32)> = sensor
        .defects
        .iter()
        .filter(|d| d.2 == kind.code())
        .map(|d| (d.0 as u32, d.1 as u32))
        .collect();
    let map = &cal.maps.defects;
    let hits = injected
        .iter()
        .filter(|&&(x, y)| map.kind(x, y) == Some(kind))
        .count();
    let false_positives = map
        .defects
        .iter()
        .filter(|d| d.kind == kind && !injected.contains(&(d.x, d.y)))
        .count();
    (injected.len(), hits, false_positives)
}

#[test]
fn every_hot_pixel_is_found_with_few_false_positives_beside_a_bright_column() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 31);
    // 16 darks (the stacks) and 2 (the least a map takes): the
    // weakest hot pixel, 200 DN, is 25σ of the residual pattern (6 DN
    // DSNU, 20 DN/√N noise: σ ≈ 8 DN) with 16 darks and 13σ with 2
    // (σ ≈ 15 DN), far above the 6σ threshold.
    for n in [16, 2] {
        let cal = calibrated(&sensor, n, n, &Options::default(), 40 + n as u64);
        let (injected, hits, false_positives) = found(&sensor, &cal, DefectKind::Hot);
        let bright_column_hot = cal
            .maps
            .defects
            .defects
            .iter()
            .filter(|d| d.x == 77)
            .count();
        eprintln!(
            "{n} darks: {hits}/{injected} hot pixels found, {false_positives} false, \
             {bright_column_hot} in the +400 DN column"
        );
        assert_eq!(hits, injected, "every injected hot pixel, from 200 DN up");
        // The issue: ≤ 1 % false positives. At 6σ a Gaussian pattern gives
        // 10⁻⁹ per pixel: none expected among 49 152.
        assert!(
            false_positives * 100 <= hits,
            "{false_positives} false of {hits}"
        );
        assert_eq!(
            bright_column_hot, 0,
            "a bright column is a column offset, not hot pixels"
        );
    }
}

#[test]
fn dead_weak_and_strong_pixels_and_their_clusters_are_found() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 32);
    let cal = calibrated(&sensor, 16, 16, &Options::default(), 50);
    for kind in [DefectKind::Dead, DefectKind::Weak, DefectKind::Strong] {
        let (injected, hits, false_positives) = found(&sensor, &cal, kind);
        eprintln!("{kind}: {hits}/{injected} found, {false_positives} false");
        // Gains 0, 0.5 and 1.5 are ≥ 20σ of PRNU 1 % from the ±30 % limits.
        assert_eq!((hits, false_positives), (injected, 0), "{kind}");
    }
    // The 2×2 dead cluster is the only cluster (the simulator places every
    // other defect ≥ 2 px from the rest).
    let clusters = &cal.maps.defects.clusters;
    assert_eq!(clusters.len(), 1, "{clusters:?}");
    assert_eq!(
        (
            clusters[0].pixels,
            clusters[0].x1 - clusters[0].x0,
            clusters[0].y1 - clusters[0].y0
        ),
        (4, 1, 1)
    );
}

#[test]
fn dsnu_and_prnu_are_recovered_with_the_stack_noise_removed() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 33);
    let good: Vec<usize> = (0..sensor.dark_dn.len())
        .filter(|&i| !sensor.defects.iter().any(|d| d.1 * sensor.width + d.0 == i))
        .collect();
    let dsnu_truth = sample_sigma(good.iter().map(|&i| sensor.dark_dn[i]));
    let column_truth = sample_sigma((0..sensor.width).map(|x| {
        (0..sensor.height)
            .map(|y| sensor.dark_dn[y * sensor.width + x])
            .sum::<f64>()
            / sensor.height as f64
    }));
    for n in [16, 4] {
        let cal = calibrated(&sensor, n, n, &Options::default(), 60 + n as u64);
        eprintln!(
            "{n}+{n}: PRNU {:.4} % (truth {:.4} %), DSNU {:.2} DN (truth {dsnu_truth:.2}), \
             columns {:.2} DN (truth {column_truth:.2}), gain noise {:.3} %",
            cal.prnu * 100.0,
            sensor.prnu * 100.0,
            cal.dsnu_dn,
            cal.column_dsnu_dn,
            cal.gain_noise.unwrap() * 100.0
        );
        // PRNU: the gain map's spread is √(PRNU² + noise²) with the noise
        // 0.28 % (16 flats) to 0.55 % (4 flats) of a 1 % PRNU; removing it in
        // quadrature must land within 3 % (the spread's own sampling error
        // over 49 152 px is 0.3 %; a noise share misjudged by 10 % moves the
        // PRNU by ≤ 1.3 %). Without the removal, 4 flats would read 14 % high.
        assert!(
            (cal.prnu / sensor.prnu - 1.0).abs() < 0.03,
            "PRNU {}",
            cal.prnu
        );
        // DSNU (27 DN, most of it the +400 DN column): within 3 %, its
        // sampling error being < 1 %. The column σ is over only 256
        // columns, and the column means keep the pixel DSNU/√192: 5 %.
        assert!(
            (cal.dsnu_dn / dsnu_truth - 1.0).abs() < 0.03,
            "DSNU {}",
            cal.dsnu_dn
        );
        assert!(
            (cal.column_dsnu_dn / column_truth - 1.0).abs() < 0.05,
            "columns {}",
            cal.column_dsnu_dn
        );
    }
}

#[test]
fn maps_are_used_only_where_their_noise_is_well_below_the_pattern() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 34);
    // 16 flats at 33 000–37 700 DN above the dark: gain-map noise 0.28 % ≤ 0.5 ×
    // PRNU 1 %: used. The master dark's noise 20.5/√16 = 5.1 DN is not ≤
    // 0.5 × the 6 DN pixel DSNU: the column/row pattern only.
    let cal = calibrated(&sensor, 16, 16, &Options::default(), 70);
    eprintln!(
        "16+16:\n  dark: {}\n  gain: {}",
        cal.dark_note, cal.gain_note
    );
    assert!(cal.maps.gain.is_some() && cal.gain_note.starts_with("per-pixel gain map used"));
    assert_eq!(cal.dark_model, DarkModel::Lines);
    assert!(cal.maps.dark.is_some());
    // 2 flats: noise 0.78 % > 0.5 %: the smooth model is kept, and the note
    // says so with the numbers.
    let cal = calibrated(&sensor, 2, 2, &Options::default(), 71);
    eprintln!("2+2:\n  dark: {}\n  gain: {}", cal.dark_note, cal.gain_note);
    assert!(cal.maps.gain.is_none());
    assert!(
        cal.gain_note.contains("not ≤ 0.5 × the PRNU"),
        "{}",
        cal.gain_note
    );
    // One flat and one dark (accepted only when asked): no photon transfer,
    // no per-pixel maps, and the notes say why.
    let single = Options {
        min_stack_frames: 1,
        ..Options::default()
    };
    let cal = calibrated(&sensor, 1, 1, &single, 72);
    eprintln!(
        "1+1:\n  transfer: {:?}\n  dark: {}\n  gain: {}",
        cal.transfer_note, cal.dark_note, cal.gain_note
    );
    assert!(cal.transfer.is_none() && cal.transfer_note.is_some());
    assert!(cal.maps.gain.is_none() && cal.gain_note.contains("single flat"));
    assert_ne!(cal.dark_model, DarkModel::PerPixel);
    // A large pixel DSNU (20 DN) against 5 DN of noise: the per-pixel dark.
    let strong = Pattern {
        pixel_dsnu_dn: 20.0,
        ..Pattern::realistic()
    };
    let cal = calibrated(
        &Sensor::twelve_bit(&strong, 35),
        16,
        16,
        &Options::default(),
        73,
    );
    assert_eq!(cal.dark_model, DarkModel::PerPixel, "{}", cal.dark_note);
    // No fixed pattern at all: nothing but the black level.
    let cal = calibrated(
        &Sensor::twelve_bit(&Pattern::ideal(), 36),
        16,
        16,
        &Options::default(),
        74,
    );
    assert_eq!(cal.dark_model, DarkModel::Scalar, "{}", cal.dark_note);
    assert!(
        cal.maps.is_identity(),
        "{} / {}",
        cal.dark_note,
        cal.gain_note
    );
}

/// Spatial σ of a frame over the pixels `keep`.
fn spatial_sigma(frame: &[u16], keep: &[usize]) -> f64 {
    sample_sigma(keep.iter().map(|&i| f64::from(frame[i])))
}

#[test]
fn correction_reduces_the_fixed_pattern_of_a_uniform_scene_to_the_stack_noise() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 37);
    let cal = calibrated(&sensor, 16, 16, &Options::default(), 80);
    // A uniform scene of 5 000 e⁻ (20 000 DN) without temporal noise: what
    // is left of its spatial spread is fixed pattern (and the ADC step).
    let scene = sensor.frame(&|_, _| 5000.0, 0, false);
    let (w, h) = (sensor.width as u32, sensor.height as u32);
    let mut corrected = Vec::new();
    cal.maps.correct(&scene, w, h, &mut corrected).unwrap();
    let good: Vec<usize> = (0..scene.len())
        .filter(|&i| !sensor.defects.iter().any(|d| d.1 * sensor.width + d.0 == i))
        .collect();
    let all: Vec<usize> = (0..scene.len()).collect();
    let before = spatial_sigma(&scene, &good);
    let after = spatial_sigma(&corrected, &all);
    // What the correction cannot remove: the gain map's own noise at the
    // scene's level, the pixel DSNU it leaves (dark model: lines), the
    // lines' estimate, and the ADC step of the scene (16/√12 DN).
    let signal = 20000.0;
    let pixel_dsnu2 = cal.dsnu_dn.powi(2) - cal.column_dsnu_dn.powi(2) - cal.row_dsnu_dn.powi(2);
    let predicted =
        ((signal * cal.gain_noise.unwrap()).powi(2) + pixel_dsnu2 + 16.0f64.powi(2) / 12.0).sqrt();
    eprintln!(
        "uniform scene at 20 000 DN: fixed pattern {before:.1} DN before, {after:.1} DN after \
         (predicted from the stacks' noise {predicted:.1} DN; PRNU alone {:.1} DN)",
        signal * sensor.prnu
    );
    // Before: PRNU 1 % of 20 000 DN (200 DN) and DSNU. After: the stack
    // noise, ≈ 56 DN, within 15 % (the residual is measured over 49 152 px to
    // 0.3 %; the prediction uses the mean relative noise over the fall-off).
    assert!(before > 190.0, "{before}");
    assert!(
        (after / predicted - 1.0).abs() < 0.15,
        "after {after} predicted {predicted}"
    );
    // Every hot pixel and dead pixel is gone: no corrected pixel stands out
    // by more than 6σ of the residual.
    let mean = all.iter().map(|&i| f64::from(corrected[i])).sum::<f64>() / all.len() as f64;
    let worst = corrected
        .iter()
        .map(|&v| (f64::from(v) - mean).abs())
        .fold(0.0, f64::max);
    assert!(worst < 6.0 * after, "worst {worst} σ {after}");
}

#[test]
fn calibration_and_correction_do_not_depend_on_the_thread_count() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 38);
    let flats = sensor.stack(&sensor.flat_signal(0.6), 5, 90);
    let darks = sensor.stack(&|_, _| 0.0, 5, 91);
    let scene = sensor.frame(&|x, _| 2000.0 + 10.0 * x as f64, 92, true);
    let smooth = |u: f64, v: f64| sensor.falloff(u, v);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let cal = calibrate(
                    &frames(&flats, &sensor, None),
                    &frames(&darks, &sensor, None),
                    &smooth,
                    &Options {
                        useful_noise_ratio: 1.0,
                        ..Options::default()
                    },
                )
                .unwrap();
                let master = sensor::master(&frames(&flats, &sensor, None), 65520).unwrap();
                let mut out = Vec::new();
                cal.maps
                    .correct(&scene, sensor.width as u32, sensor.height as u32, &mut out)
                    .unwrap();
                (cal, master, out)
            })
    };
    let (one, four) = (run(1), run(4));
    assert!(one.0.maps.gain.is_some(), "the gain map takes part");
    // Compared whole (every statistic bit for bit, every map value); the
    // message stays short, the maps being 49 152 values each.
    assert!(
        one.0 == four.0,
        "the calibration differs between 1 and 4 threads"
    );
    assert!(
        one.1 == four.1,
        "the master differs between 1 and 4 threads"
    );
    assert!(
        one.2 == four.2,
        "the corrected frame differs between 1 and 4 threads"
    );
}

#[test]
fn darks_of_another_exposure_are_noted_with_the_photon_transfer() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 39);
    let flats = sensor.stack(&sensor.flat_signal(0.6), 2, 93);
    let darks = sensor.stack(&|_, _| 0.0, 2, 94);
    let smooth = |u: f64, v: f64| sensor.falloff(u, v);
    let cal = calibrate(
        &frames(&flats, &sensor, Some(0.004)),
        &frames(&darks, &sensor, Some(0.01)),
        &smooth,
        &Options::default(),
    )
    .unwrap();
    assert!(cal.transfer.is_some());
    let note = cal.transfer_note.unwrap_or_default();
    assert!(
        note.contains("the darks were exposed 0.01 s and the flats 0.004 s"),
        "{note}"
    );
}
