//! Solve time of laser-tracer multilateration at the scale: 10⁴ grid
//! points × 8 stations (80 000 readings, 30 032 unknowns), from the
//! generator's data; the seed's station start, Gauss–Newton with the Schur
//! complement and the covariance of every correction. Smaller layouts show
//! how the time grows (linearly in n).
//!
//! `cargo bench -p probe --bench tracer`

#![allow(clippy::unwrap_used, clippy::expect_used)]

use geom::nalgebra::Point3;
use probe::tracer::{self, Network, Options, Reading};
use synth::probe::tracer::{TracerConfig, generate};

fn main() {
    divan::main();
}

fn network(counts: [usize; 3], stations: usize) -> Network {
    let d = generate(&TracerConfig {
        counts,
        stations,
        ..TracerConfig::default()
    })
    .unwrap();
    Network {
        points: d.grid.iter().map(|g| Point3::from(g.position())).collect(),
        point_names: d.grid.iter().map(|g| g.point.clone()).collect(),
        station_names: (1..=stations).map(|j| j.to_string()).collect(),
        // The generator writes station j's readings as "j", points as "i" (1-based).
        readings: d
            .readings
            .iter()
            .map(|r| Reading {
                station: r.station.parse::<usize>().unwrap() - 1,
                point: r.point.parse::<usize>().unwrap() - 1,
                l: r.l,
            })
            .collect(),
    }
}

/// n points × 8 stations, n = 10³ … 10⁴.
#[divan::bench(args = [[10, 10, 10], [20, 10, 10], [25, 20, 20]], sample_count = 10, sample_size = 1)]
fn solve(bencher: divan::Bencher, counts: [usize; 3]) {
    let net = network(counts, 8);
    bencher
        .counter(divan::counter::ItemsCount::new(net.points.len()))
        .bench(|| tracer::solve(divan::black_box(&net), &Options::default()).unwrap());
}
