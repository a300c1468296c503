//! Helpers shared by calib's tests.

/// A deterministic stream of numbers uniform in [0, 1) from `seed` (Knuth's
/// MMIX linear congruential generator, top 53 bits): the same spurious blobs
/// and noise on every machine.
pub fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut x = seed;
    move || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }
}
