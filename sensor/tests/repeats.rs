//! The system gain from pairs of repeated captures of one scene (the
//! measurement images, no stacks): bright flat discs on a background, the
//! METHODS §6 pixel model with PRNU, DSNU, column offsets and hot pixels
//! (12-bit ADC, K = 4 DN/e⁻, σ_d = 5 e⁻), the discs moved between the two
//! captures of a pair as a machine's repeatability would.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod sim;

use sensor::{Frame, RepeatGainEstimate, SensorError, gain_from_repeats};
use sim::{Pattern, Sensor, frames};

/// Background electrons.
const BACKGROUND_E: f64 = 200.0;

/// A scene of discs (radius 14 px, sharp edges, area-sampled 4×4) of
/// 2000…9000 e⁻ over the background, every disc moved by `shift` px.
fn scene(shift: [f64; 2]) -> impl Fn(usize, usize) -> f64 {
    let discs: Vec<([f64; 2], f64)> = (0..6)
        .map(|i| {
            let (col, row) = (f64::from(i % 3), f64::from(i / 3));
            (
                [45.0 + 80.0 * col, 50.0 + 90.0 * row],
                2000.0 + 1400.0 * f64::from(i),
            )
        })
        .collect();
    move |x, y| {
        let mut e = BACKGROUND_E;
        for &(c, level) in &discs {
            let mut covered = 0.0;
            for i in 0..4 {
                for j in 0..4 {
                    let u = x as f64 - 0.375 + 0.25 * f64::from(i) - c[0] - shift[0];
                    let v = y as f64 - 0.375 + 0.25 * f64::from(j) - c[1] - shift[1];
                    if u.hypot(v) <= 14.0 {
                        covered += 1.0 / 16.0;
                    }
                }
            }
            e += level * covered;
        }
        e
    }
}

/// `pairs` pairs of captures; the second of each moved by `shift`.
fn captures(sensor: &Sensor, pairs: u64, shift: [f64; 2]) -> Vec<Vec<u16>> {
    let (a, b) = (scene([0.0, 0.0]), scene(shift));
    (0..pairs)
        .flat_map(|k| {
            [
                sensor.frame(&a, 100 + 2 * k, true),
                sensor.frame(&b, 101 + 2 * k, true),
            ]
        })
        .collect()
}

fn as_pairs<'a>(frames: &[Frame<'a>]) -> Vec<(Frame<'a>, Frame<'a>)> {
    frames.chunks(2).map(|p| (p[0], p[1])).collect()
}

/// ½·var(A − B) over the pixels of each level band, plainly (every pixel):
/// what a photon transfer without the flatness test would see.
fn plain_half_variance(stack: &[Vec<u16>], band: (f64, f64)) -> f64 {
    let (mut n, mut s2) = (0.0, 0.0);
    for pair in stack.chunks(2) {
        for (&a, &b) in pair[0].iter().zip(&pair[1]) {
            let level = (f64::from(a) + f64::from(b)) / 2.0;
            if level >= band.0 && level < band.1 {
                n += 1.0;
                s2 += (f64::from(a) - f64::from(b)).powi(2);
            }
        }
    }
    0.5 * s2 / n
}

/// K within 5 % from 8 pairs, still (no motion) and with the discs moved
/// by 0.3 px between captures — where the plain photon transfer of the
/// disc-edge levels is inflated several times by the motion. The
/// statistical error: the brightest disc's ≈ 8 × 500 flat pixels give its
/// variance to √(2/4000) ≈ 2.2 %, the slope over all six discs to ≈ 1.5 %;
/// 5 % is > 3σ.
#[test]
fn the_gain_is_recovered_from_repeated_captures_despite_motion() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 31);
    for shift in [[0.0, 0.0], [0.3, -0.2]] {
        let stack = captures(&sensor, 8, shift);
        let all = frames(&stack, &sensor, None);
        let g = gain_from_repeats(&as_pairs(&all), sensor.saturation()).unwrap();
        let error = (g.gain_dn_per_e / sensor.gain - 1.0).abs();
        // Background: K²·(200 + 25) + step²/12 DN².
        let bg =
            (sensor.gain.powi(2) * (BACKGROUND_E + 25.0) + sensor.step().powi(2) / 12.0).sqrt();
        eprintln!(
            "shift {shift:?}: K = {:.4} DN/e⁻ ({:.2} %), σ at the background {:.1} DN \
             (truth {bg:.1}), levels {:.0}…{:.0} DN, {} differences of {} pairs",
            g.gain_dn_per_e,
            100.0 * error,
            g.background_temporal_dn,
            g.background_level_dn,
            g.top_level_dn,
            g.pixels,
            g.pairs
        );
        assert!(error < 0.05, "{g:?}");
        assert!((g.background_temporal_dn / bg - 1.0).abs() < 0.05, "{g:?}");
        assert!(
            g.top_level_dn > 30_000.0,
            "the bright discs take part: {g:?}"
        );
        if shift != [0.0, 0.0] {
            // Edge levels (between background and the faintest disc): the
            // motion dominates the plain difference there.
            let edge = plain_half_variance(&stack, (3000.0, 8000.0));
            let shot = sensor.gain * (5500.0 - 1600.0);
            eprintln!(
                "plain ½·var(A − B) at the edges {edge:.0} DN² against {shot:.0} DN² of noise"
            );
            assert!(
                edge > 3.0 * shot,
                "the test's motion matters: {edge} {shot}"
            );
        }
    }
}

/// Frames without any bright flat region give no gain, and say so.
#[test]
fn a_scene_without_bright_flat_regions_is_refused() {
    let sensor = Sensor::twelve_bit(&Pattern::ideal(), 32);
    let background = |_: usize, _: usize| BACKGROUND_E;
    let stack: Vec<Vec<u16>> = (0..2).map(|k| sensor.frame(&background, k, true)).collect();
    let all = frames(&stack, &sensor, None);
    let e = gain_from_repeats(&as_pairs(&all), sensor.saturation()).unwrap_err();
    assert!(matches!(e, SensorError::NoGainFromRepeats { .. }), "{e}");
    assert!(e.to_string().contains("no system gain"), "{e}");
    let e = gain_from_repeats(&[], sensor.saturation()).unwrap_err();
    assert!(e.to_string().contains("repeated-capture"), "{e}");
}

/// Pairs given one at a time (`RepeatGainEstimate`, as `measure` reads
/// them): a pair of another size than the first is refused, naming its
/// frame, and leaves the estimate as it was.
#[test]
fn pairs_given_one_at_a_time_refuse_another_size() {
    let sensor = Sensor::twelve_bit(&Pattern::realistic(), 33);
    let stack = captures(&sensor, 2, [0.0, 0.0]);
    let all = frames(&stack, &sensor, None);
    let mut estimate = RepeatGainEstimate::new(sensor.saturation());
    for (a, b) in as_pairs(&all) {
        estimate.add_pair(&a, &b).unwrap();
    }
    let short = Frame {
        height: all[0].height - 1,
        values: &all[0].values[..all[0].values.len() - all[0].width as usize],
        ..all[0]
    };
    let e = estimate.add_pair(&all[0], &short).unwrap_err();
    assert!(
        matches!(e, SensorError::SizeDiffers { frame: 5, .. }),
        "{e}"
    );
    let one_at_a_time = estimate.finish().unwrap();
    let g = gain_from_repeats(&as_pairs(&all), sensor.saturation()).unwrap();
    assert_eq!(one_at_a_time, g);
    assert!((g.gain_dn_per_e / sensor.gain - 1.0).abs() < 0.1, "{g:?}");
}
