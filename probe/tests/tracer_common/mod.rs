//! Networks for the tracer tests and bench: the check data read through the
//! file readers, and the generator's data through the same checks.

#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use std::path::{Path, PathBuf};

use formats::Row;
use formats::probe::tracer::{check_grid, check_readings, read_grid, read_readings};
use probe::tracer::Network;
use synth::probe::tracer::TracerData;

/// A file of the check data (`testdata/probe/tracer/`).
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/probe/tracer")
        .join(name)
}

/// The check data as a network, through the file readers.
pub fn check_network() -> Network {
    let grid_path = data("grid.csv");
    let grid = read_grid(&grid_path).unwrap();
    let readings = read_readings(&data("readings.csv"), &grid, &grid_path).unwrap();
    Network::from_records(&grid, &readings)
}

/// Generated data as a network, through the readers' checks (rows numbered
/// as the files would number them).
pub fn network(d: &TracerData) -> Network {
    let rows = |n: usize| (0..n).map(|k| k as u64 + 2);
    let (grid_path, readings_path) = (Path::new("grid.csv"), Path::new("readings.csv"));
    let grid = check_grid(
        rows(d.grid.len())
            .zip(&d.grid)
            .map(|(line, r)| Row {
                line,
                record: r.clone(),
            })
            .collect(),
        grid_path,
    )
    .unwrap();
    let readings = check_readings(
        rows(d.readings.len())
            .zip(&d.readings)
            .map(|(line, r)| Row {
                line,
                record: r.clone(),
            })
            .collect(),
        readings_path,
        &grid,
        grid_path,
    )
    .unwrap();
    Network::from_records(&grid, &readings)
}
