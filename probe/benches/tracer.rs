//! Solve time of laser-tracer multilateration at the scale: 10⁴ grid
//! points × 8 stations (80 000 readings, 30 032 unknowns), from the
//! generator's data; the seed's station start, Gauss–Newton with the Schur
//! complement and the covariance of every correction. Smaller layouts show
//! how the time grows (linearly in n).
//!
//! `cargo bench -p probe --bench tracer`

#![allow(clippy::unwrap_used, clippy::expect_used)]

#[path = "../tests/tracer_common/mod.rs"]
mod tracer_common;

use probe::tracer::{self, Network, Options};
use synth::probe::tracer::{TracerConfig, generate};

fn main() {
    divan::main();
}

fn network(counts: [usize; 3], stations: usize) -> Network {
    tracer_common::network(
        &generate(&TracerConfig {
            counts,
            stations,
            ..TracerConfig::default()
        })
        .unwrap(),
    )
}

/// n points × 8 stations, n = 10³ … 10⁴.
#[divan::bench(args = [[10, 10, 10], [20, 10, 10], [25, 20, 20]], sample_count = 10, sample_size = 1)]
fn solve(bencher: divan::Bencher, counts: [usize; 3]) {
    let net = network(counts, 8);
    bencher
        .counter(divan::counter::ItemsCount::new(net.points.len()))
        .bench(|| tracer::solve(divan::black_box(&net), &Options::default()).unwrap());
}
