//! Stacks: the refusals of issue 24 item 8 (`check_stack`, `calibrate`),
//! and the outlier-robust master.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod sim;

use sensor::{Frame, Options, SensorError, StackKind, calibrate, check_stack, master};
use sim::{Pattern, Sensor, frames};

fn frame(values: &[u16], width: u32, height: u32, bits: u8, exposure_s: Option<f64>) -> Frame<'_> {
    Frame {
        values,
        width,
        height,
        container_bits: bits,
        exposure_s,
    }
}

#[test]
fn check_stack_refuses_mixed_sizes_bit_depths_exposures_and_an_empty_stack() {
    let (a, b) = (vec![0u16; 12], vec![0u16; 12]);
    let ok = frame(&a, 4, 3, 16, Some(0.004));
    assert!(check_stack(&[ok, ok, ok], StackKind::Flat).is_ok());

    let e = check_stack(&[], StackKind::Dark).unwrap_err();
    assert_eq!(
        e,
        SensorError::EmptyStack {
            kind: StackKind::Dark
        }
    );
    assert_eq!(
        e.to_string(),
        "the dark stack is empty: at least one frame is needed"
    );

    let e = check_stack(&[ok, ok, frame(&b, 3, 4, 16, Some(0.004))], StackKind::Flat).unwrap_err();
    assert!(
        matches!(
            e,
            SensorError::SizeDiffers {
                frame: 2,
                width: 3,
                height: 4,
                ..
            }
        ),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("flat frame 2 is 3×4 px where frame 0 of the flat stack is 4×3 px"),
        "{e}"
    );

    let e = check_stack(&[ok, frame(&b, 4, 3, 8, Some(0.004))], StackKind::Flat).unwrap_err();
    assert!(
        e.to_string()
            .contains("flat frame 1 is a 8-bit file where frame 0 of the flat stack is 16-bit"),
        "{e}"
    );

    let e = check_stack(
        &[ok, ok, ok, frame(&b, 4, 3, 16, Some(0.005))],
        StackKind::Dark,
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .contains("dark frame 3 has exposure time 1/200 s where frame 0 has 1/250 s"),
        "{e}"
    );
    let e = check_stack(&[ok, frame(&b, 4, 3, 16, None)], StackKind::Dark).unwrap_err();
    assert!(
        e.to_string()
            .contains("exposure time absent where frame 0 has 1/250 s"),
        "{e}"
    );

    let short = vec![0u16; 11];
    let e = check_stack(&[ok, frame(&short, 4, 3, 16, Some(0.004))], StackKind::Flat).unwrap_err();
    assert!(
        e.to_string()
            .contains("flat frame 1: 11 values for a 4×3 frame"),
        "{e}"
    );
    let e = check_stack(&[frame(&[], 0, 3, 16, None)], StackKind::Flat).unwrap_err();
    assert!(e.to_string().contains("no pixels"), "{e}");
}

/// A realistic sensor, its flats at `flat_fraction` of the full scale and
/// its darks, calibrated with `options`; the stacks may be altered first.
fn refusal(
    flat_fraction: f64,
    n: usize,
    alter: impl Fn(&Sensor, &mut Vec<Vec<u16>>, &mut Vec<Vec<u16>>),
    options: &Options,
) -> SensorError {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 41);
    let mut flats = sensor.stack(&sensor.flat_signal(flat_fraction), n, 1);
    let mut darks = sensor.stack(&|_, _| 0.0, n, 100);
    alter(&sensor, &mut flats, &mut darks);
    let smooth = |u: f64, v: f64| sensor.falloff(u, v);
    calibrate(
        &frames(&flats, &sensor, None),
        &frames(&darks, &sensor, None),
        &smooth,
        options,
    )
    .expect_err("the stacks must be refused")
}

#[test]
fn calibrate_refuses_each_bad_stack_with_its_numbers() {
    let defaults = Options::default();
    let keep = |_: &Sensor, _: &mut Vec<Vec<u16>>, _: &mut Vec<Vec<u16>>| {};

    // A stack of one where a per-pixel map needs a pair.
    let e = refusal(0.6, 1, keep, &defaults);
    assert!(
        matches!(
            e,
            SensorError::StackTooSmall {
                kind: StackKind::Flat,
                frames: 1,
                needed: 2,
                ..
            }
        ),
        "{e}"
    );

    // Flats and darks of different sizes.
    let e = refusal(
        0.6,
        3,
        |_, _, d| d.iter_mut().for_each(|f| f.truncate(f.len() - 256)),
        &defaults,
    );
    assert!(
        e.to_string()
            .contains("dark frame 0: 48896 values for a 256×192 frame"),
        "{e}"
    );

    // Flats and darks of different cameras: 256×192 flats, 128×96 darks.
    let (big, small) = (
        Sensor::twelve_bit(&Pattern::ideal(), 41),
        Sensor::new(128, 96, 12, 4.0, 5.0, 1600.0, &Pattern::ideal(), 1),
    );
    let (flats, darks) = (
        big.stack(&big.flat_signal(0.6), 3, 1),
        small.stack(&|_, _| 0.0, 3, 9),
    );
    let e = calibrate(
        &frames(&flats, &big, None),
        &frames(&darks, &small, None),
        &|_, _| 1.0,
        &defaults,
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .contains("dark frame 0 is 128×96 px where frame 0 of the flat stack is 256×192 px"),
        "{e}"
    );

    // A saturated flat: 110 % of the full scale at the centre.
    let e = refusal(1.1, 3, keep, &defaults);
    assert!(
        matches!(
            e,
            SensorError::SaturatedFlat {
                saturation_dn: 65520,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("reach 65520 DN"), "{e}");

    // An under-exposed flat: 4 % of the full scale at the centre, ≈ 1000 DN
    // above the dark, below 5 % of 65 520 DN.
    let e = refusal(0.04, 3, keep, &defaults);
    let SensorError::UnderexposedFlat {
        signal_dn,
        needed_dn,
        ..
    } = e
    else {
        panic!("{e}")
    };
    assert!(
        signal_dn > 500.0 && signal_dn < 1100.0 && (needed_dn - 3276.0).abs() < 1.0,
        "{signal_dn} {needed_dn}"
    );

    // A dark with light: uniform at 30 % of the full scale …
    let lit = |s: &Sensor, _: &mut Vec<Vec<u16>>, d: &mut Vec<Vec<u16>>| {
        *d = s.stack(&s.flat_signal(0.3), 3, 200)
    };
    let e = refusal(0.6, 3, lit, &defaults);
    assert!(matches!(e, SensorError::DarkWithLight { .. }), "{e}");
    assert!(e.to_string().contains("has light in it"), "{e}");
    // … or uneven: a ramp to 25 % across the frame, its mean (12.5 %) below
    // the 20 % limit but far above its darkest pixels.
    let ramp = |s: &Sensor, _: &mut Vec<Vec<u16>>, d: &mut Vec<Vec<u16>>| {
        let top = 0.25 * 65520.0 / s.gain;
        *d = s.stack(&|x, _| top * x as f64 / s.width as f64, 3, 300);
    };
    let e = refusal(0.6, 3, ramp, &defaults);
    let SensorError::DarkWithLight {
        above_dn,
        above_limit_dn,
        level_dn,
        bright_limit_dn,
        ..
    } = e
    else {
        panic!("{e}")
    };
    assert!(
        above_dn > above_limit_dn && level_dn < bright_limit_dn,
        "{above_dn} {level_dn}"
    );

    // A flat darker than its dark (the lens cap left on for the flats, and
    // a dark a step brighter).
    let capped = |_: &Sensor, f: &mut Vec<Vec<u16>>, d: &mut Vec<Vec<u16>>| {
        *f = d
            .iter()
            .map(|frame| frame.iter().map(|v| v.saturating_sub(16)).collect())
            .collect();
    };
    let e = refusal(0.6, 3, capped, &defaults);
    let SensorError::FlatDarkerThanDark { flat_dn, dark_dn } = e else {
        panic!("{e}")
    };
    assert!(flat_dn < dark_dn, "{flat_dn} {dark_dn}");

    // Flats without shot noise: one frame copied.
    let copies = |_: &Sensor, f: &mut Vec<Vec<u16>>, _: &mut Vec<Vec<u16>>| {
        let first = f[0].clone();
        f.iter_mut().for_each(|frame| frame.clone_from(&first));
    };
    let e = refusal(0.6, 3, copies, &defaults);
    assert!(
        matches!(e, SensorError::NoShotNoise { flat_var_dn2, .. } if flat_var_dn2 == 0.0),
        "{e}"
    );
}

#[test]
fn a_smooth_model_that_is_not_positive_is_refused() {
    let sensor = Sensor::twelve_bit(&Pattern::ideal(), 42);
    let flats = sensor.stack(&sensor.flat_signal(0.6), 2, 1);
    let darks = sensor.stack(&|_, _| 0.0, 2, 2);
    let smooth = |u: f64, v: f64| if (u, v) == (5.0, 7.0) { 0.0 } else { 1.0 };
    let e = calibrate(
        &frames(&flats, &sensor, None),
        &frames(&darks, &sensor, None),
        &smooth,
        &Options::default(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "the smooth model of the flat is 0 at pixel (5, 7): it must be positive"
    );
}

#[test]
fn a_spike_in_one_frame_is_rejected_from_the_master() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 43);
    let clean = sensor.stack(&sensor.flat_signal(0.6), 16, 1);
    let mut spiked = clean.clone();
    // A cosmic event of 3 000 DN (≈ 8σ of the flat's noise) and a stray
    // flash saturating one pixel, each in one frame.
    let (p, q) = (100 * sensor.width + 50, 20 * sensor.width + 200);
    spiked[5][p] += 3000;
    spiked[9][q] = 65520;
    let saturation = sensor.saturation();
    let m_clean = master(&frames(&clean, &sensor, None), saturation).unwrap();
    let m = master(&frames(&spiked, &sensor, None), saturation).unwrap();
    // The outliers are left out: the master there is the mean of the other
    // 15 samples (up to f32 rounding), and differs from the plain mean of
    // 16 by 3000/16 = 188 DN at p.
    for (i, k) in [(p, 5), (q, 9)] {
        let others: f64 = clean
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != k)
            .map(|(_, f)| f64::from(f[i]))
            .sum::<f64>()
            / 15.0;
        assert!(
            (f64::from(m.mean[i]) - others).abs() < 0.01,
            "pixel {i}: {} vs {others}",
            m.mean[i]
        );
    }
    // Rejected: the two events, and at most a few normal samples (a 5σ
    // two-sided tail is 6·10⁻⁷ of 786 432 samples: 0.5 expected).
    eprintln!(
        "rejected: {} clean, {} spiked",
        m_clean.rejected, m.rejected
    );
    assert!(
        m.rejected >= 2 && m.rejected <= m_clean.rejected + 2 && m_clean.rejected <= 3,
        "{} {}",
        m.rejected,
        m_clean.rejected
    );
    // The temporal variance is hardly moved: the saturated pixel is left
    // out, and the 3000 DN event is 5.8σ of a difference of two frames, just
    // inside the 6σ clip there, adding ½·2·3000²/(15·49152) = 12 DN² of
    // 133 000 (≤ 10⁻⁴; 5·10⁻⁴ allows for the pixel that left the sums).
    let (a, b) = (
        m.temporal_var_dn2.unwrap(),
        m_clean.temporal_var_dn2.unwrap(),
    );
    assert!((a / b - 1.0).abs() < 5e-4, "{a} {b}");
    // The saturated event counts as saturation (the caller refuses > 10⁻⁴).
    assert_eq!(
        m.saturated_fraction,
        1.0 / (sensor.width * sensor.height) as f64
    );
}

#[test]
fn hot_pixels_keep_their_samples_in_a_dark_master() {
    // A hot pixel's dark-current shot noise (8000 DN: √2000 e⁻·4 = 179 DN)
    // far exceeds the read noise (20 DN): its own MAD spread keeps its
    // samples, which the dark's noise model alone would cut at 5·20 DN.
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 44);
    let darks = sensor.stack(&|_, _| 0.0, 8, 5);
    let m = master(&frames(&darks, &sensor, None), sensor.saturation()).unwrap();
    eprintln!(
        "dark master: {} samples rejected of {}",
        m.rejected,
        8 * sensor.width * sensor.height
    );
    assert!(m.rejected <= 5, "{}", m.rejected);
}

#[test]
fn two_frames_give_the_plain_mean_and_one_frame_no_temporal_noise() {
    let (a, b) = (vec![10u16, 20, 30, 40], vec![12u16, 20, 1030, 44]);
    let m = master(
        &[frame(&a, 2, 2, 16, None), frame(&b, 2, 2, 16, None)],
        65535,
    )
    .unwrap();
    assert_eq!(m.mean, vec![11.0, 20.0, 530.0, 42.0]);
    assert_eq!(m.rejected, 0);
    assert!(m.temporal_var_dn2.is_some());
    let m = master(&[frame(&a, 2, 2, 16, None)], 65535).unwrap();
    assert_eq!((m.temporal_var_dn2, m.noise_dn()), (None, None));
    assert_eq!(m.level_dn, 25.0);
    let e = master(
        &[frame(&a, 2, 2, 16, None), frame(&b, 4, 1, 16, None)],
        65535,
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("frame 1 of the stack: 4×1 px"),
        "{e}"
    );
}

#[test]
fn a_spike_does_not_inflate_the_temporal_noise_of_a_dark() {
    // A 5000 DN event in one dark frame: in the two differences it enters
    // it would add ½·2·5000²/(15·49152) = 34 DN² to σ²_y.dark ≈ 420 DN²
    // (8 %, and 4 % on the read noise); it is 175σ of a difference, so the
    // 6σ clip leaves it out and σ²_y.dark stays within 0.1 % (a clean
    // sample clipped at 6σ: 2·10⁻⁹ of them).
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 45);
    let clean = sensor.stack(&|_, _| 0.0, 16, 7);
    let mut spiked = clean.clone();
    spiked[3][60 * sensor.width + 60] += 5000;
    let saturation = sensor.saturation();
    let a = master(&frames(&spiked, &sensor, None), saturation).unwrap();
    let b = master(&frames(&clean, &sensor, None), saturation).unwrap();
    let (a, b) = (a.temporal_var_dn2.unwrap(), b.temporal_var_dn2.unwrap());
    eprintln!("σ²_y.dark: {a:.2} DN² with the event, {b:.2} DN² without");
    assert!((a / b - 1.0).abs() < 1e-3, "{a} {b}");
}
