//! Photon transfer (EMVA 1288 §6) on simulated stacks of the METHODS §6
//! pixel model: a 12-bit ADC left-shifted into 16-bit files, K = 4 file
//! DN/e⁻, σ_d = 5 e⁻, a flat at ≈ 60 % of the full scale with a smooth
//! fall-off, PRNU 1 %, DSNU, column offsets and hot pixels.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod sim;

use sensor::{AdcDepth, adc_depth, master, photon_transfer};
use sim::{Pattern, Sensor, frames};

/// K, σ_d (e⁻) and the ADC depth recovered from `n` flats and `n` darks.
fn recovered(sensor: &Sensor, n: usize, seed: u64) -> (f64, f64, AdcDepth) {
    let flats = sensor.stack(&sensor.flat_signal(0.6), n, seed);
    let darks = sensor.stack(&|_, _| 0.0, n, seed + 1000);
    let (flats, darks) = (frames(&flats, sensor, None), frames(&darks, sensor, None));
    let all: Vec<_> = flats.iter().chain(&darks).copied().collect();
    let adc = adc_depth(&all);
    let flat = master(&flats, adc.saturation_dn()).unwrap();
    let dark = master(&darks, adc.saturation_dn()).unwrap();
    let t = photon_transfer(&flat, &dark, adc).unwrap();
    (t.gain_dn_per_e, t.read_noise_e, adc)
}

fn relative_error(measured: f64, truth: f64) -> f64 {
    (measured - truth).abs() / truth
}

#[test]
fn photon_transfer_recovers_gain_and_read_noise_from_16_flats_and_16_darks() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 24);
    let (k, sigma_d, adc) = recovered(&sensor, 16, 1);
    assert_eq!(adc.adc_bits, 12, "12-bit ADC left-shifted by 4");
    // The requirement: within 5 %. The statistical error is far
    // smaller: 15 pairs × 49 152 px give σ²_y to √(2/(15·49152)) = 0.16 %,
    // so K to ≈ 0.2 % and σ_d to ≈ 0.2 %; the hot pixels' dark-current shot
    // noise adds < 1 % to σ²_y.dark.
    let (ek, ed) = (
        relative_error(k, sensor.gain),
        relative_error(sigma_d, sensor.read_noise_e),
    );
    eprintln!(
        "16+16: K = {k:.4} DN/e⁻ ({:.2} %), σ_d = {sigma_d:.4} e⁻ ({:.2} %)",
        ek * 100.0,
        ed * 100.0
    );
    assert!(ek < 0.05 && ed < 0.05, "K {k} σ_d {sigma_d}");
}

#[test]
fn photon_transfer_from_2_flats_and_2_darks() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 25);
    // One pair each: σ²_y to √(2/49152) = 0.64 % (1σ), so K to
    // ≈ √(0.64² + (0.64·σ²_dark/σ²_flat)²) ≈ 0.65 % and σ_d to ≈ 0.7 % (the
    // dark's half of its own variance error plus K's). A tolerance of 5 %
    // for both is ≥ 7σ: it holds for any seed, and is still the 5 %.
    let mut worst = (0.0f64, 0.0f64);
    for seed in [3, 5, 7] {
        let (k, sigma_d, _) = recovered(&sensor, 2, seed);
        worst.0 = worst.0.max(relative_error(k, sensor.gain));
        worst.1 = worst.1.max(relative_error(sigma_d, sensor.read_noise_e));
    }
    eprintln!(
        "2+2 (3 seeds): worst K error {:.2} %, σ_d {:.2} %",
        worst.0 * 100.0,
        worst.1 * 100.0
    );
    assert!(worst.0 < 0.05 && worst.1 < 0.05, "{worst:?}");
}

#[test]
fn quantisation_noise_is_removed_from_the_read_noise() {
    // σ_d = 2 e⁻ = 8 DN against an ADC step of 16 DN (σ_q = 4.6 DN): without
    // the step²/12 term σ_d would read √(8² + 4.6²)/4 = 2.31 e⁻, 15 % high.
    let sensor = Sensor::new(
        sim::WIDTH,
        sim::HEIGHT,
        12,
        4.0,
        2.0,
        1600.0,
        &Pattern::realistic(),
        26,
    );
    let (k, sigma_d, _) = recovered(&sensor, 16, 11);
    eprintln!("σ_d 2 e⁻: K = {k:.4}, σ_d = {sigma_d:.4} e⁻");
    assert!(relative_error(k, 4.0) < 0.05, "K {k}");
    // Gaussian read noise of 0.5 ADC steps is quantised almost like a
    // uniform error (Sheppard's correction holds to < 1 % there): 5 %.
    assert!(relative_error(sigma_d, 2.0) < 0.05, "σ_d {sigma_d}");
}

#[test]
fn a_stack_of_one_gives_no_photon_transfer() {
    let sensor = Sensor::twelve_bit(&Pattern::ideal(), 27);
    let flats = sensor.stack(&sensor.flat_signal(0.6), 1, 1);
    let darks = sensor.stack(&|_, _| 0.0, 2, 2);
    let flat = master(&frames(&flats, &sensor, None), 65520).unwrap();
    let dark = master(&frames(&darks, &sensor, None), 65520).unwrap();
    assert_eq!(flat.temporal_var_dn2, None);
    let e = photon_transfer(&flat, &dark, AdcDepth::container(16)).unwrap_err();
    assert!(
        matches!(
            e,
            sensor::SensorError::StackTooSmall {
                frames: 1,
                needed: 2,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("flat stack has 1 frame"), "{e}");
}
