//! Files of `trinocular probe tracer` (laser-tracer multilateration of a CMM,
//! docs/probe-tracer.md): the nominal grid `grid.csv` (`point,x,y,z`), the
//! interferometric readings `readings.csv` (`station,point,l`), query points
//! `x,y,z`; the outputs `corrections.csv`, `stations.csv`, `residuals.csv`,
//! `corrected.csv`; and the generator's `truth.json`.
//!
//! The readers check what spans rows, with the file, line (header = line 1)
//! and column of the row at fault: duplicate point names and positions,
//! duplicate (station, point) readings, readings of points not in the grid,
//! and units — a station's readings cannot differ by more than the distance
//! between the two points they were taken at (triangle inequality), so
//! readings in µm instead of mm are caught; a grid spanning more than
//! [`MAX_GRID_EXTENT_MM`] is taken for one in µm.

pub mod report;

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{finite_fields, name, row_error};
use crate::table::{Invalid, Record, Row, finite, read_csv};
use crate::{FormatError, Result};

/// Slack on the triangle-inequality check of readings (mm): room for the
/// machine's own errors and the interferometer's noise, far below the factor
/// 1000 of readings written in µm.
pub const UNIT_SLACK_MM: f64 = 1.0;

/// Largest span of a grid in any axis (mm) taken as millimetres: 50 m is
/// beyond any CMM or machine tool; a grid written in µm exceeds it.
pub const MAX_GRID_EXTENT_MM: f64 = 50_000.0;

/// One nominal grid point of `grid.csv`: its name and nominal CMM coordinates (mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridRow {
    /// Point name (unique).
    pub point: String,
    /// Nominal x (mm).
    pub x: f64,
    /// Nominal y (mm).
    pub y: f64,
    /// Nominal z (mm).
    pub z: f64,
}

impl Record for GridRow {
    const COLUMNS: &'static [&'static str] = &["point", "x", "y", "z"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        name("point", &self.point)?;
        finite("x", self.x)?;
        finite("y", self.y)?;
        finite("z", self.z)
    }
}

impl GridRow {
    /// Nominal coordinates (mm).
    pub fn position(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

/// One interferometric reading of `readings.csv`: station, point and the
/// length `l` relative to the station's first point (mm), `|A − P| = d + l`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReadingRow {
    /// Station name.
    pub station: String,
    /// Point name (a `point` of the grid).
    pub point: String,
    /// Interferometric length relative to the station's first point (mm).
    pub l: f64,
}

impl Record for ReadingRow {
    const COLUMNS: &'static [&'static str] = &["station", "point", "l"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        name("station", &self.station)?;
        name("point", &self.point)?;
        finite("l", self.l)
    }
}

/// One query point (`x,y,z`, mm, nominal CMM coordinates) for `--query`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QueryRow {
    /// x (mm).
    pub x: f64,
    /// y (mm).
    pub y: f64,
    /// z (mm).
    pub z: f64,
}

impl Record for QueryRow {
    const COLUMNS: &'static [&'static str] = &["x", "y", "z"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("x", self.x)?;
        finite("y", self.y)?;
        finite("z", self.z)
    }
}

impl QueryRow {
    /// Coordinates (mm).
    pub fn position(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

/// One row of `corrections.csv`: nominal point, correction (true − nominal,
/// no rigid motion) and its standard uncertainties (mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CorrectionRow {
    /// Point name.
    pub point: String,
    /// Nominal x (mm).
    pub x: f64,
    /// Nominal y (mm).
    pub y: f64,
    /// Nominal z (mm).
    pub z: f64,
    /// Correction in x (mm).
    pub dx: f64,
    /// Correction in y (mm).
    pub dy: f64,
    /// Correction in z (mm).
    pub dz: f64,
    /// Standard uncertainty of `dx` (mm).
    pub u_dx: f64,
    /// Standard uncertainty of `dy` (mm).
    pub u_dy: f64,
    /// Standard uncertainty of `dz` (mm).
    pub u_dz: f64,
}

impl Record for CorrectionRow {
    const COLUMNS: &'static [&'static str] = &[
        "point", "x", "y", "z", "dx", "dy", "dz", "u_dx", "u_dy", "u_dz",
    ];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        name("point", &self.point)?;
        finite_fields!(self, x, y, z, dx, dy, dz, u_dx, u_dy, u_dz)
    }
}

/// One row of `stations.csv`: estimated station position and dead path (mm)
/// in the frame of the nominal grid, their standard uncertainties, the number
/// of readings and their residual RMS (µm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StationRow {
    /// Station name.
    pub station: String,
    /// x (mm).
    pub x: f64,
    /// y (mm).
    pub y: f64,
    /// z (mm).
    pub z: f64,
    /// Dead path `d`: distance from the station to the point where its readings are zero (mm).
    pub dead_path: f64,
    /// Standard uncertainty of x (mm).
    pub u_x: f64,
    /// Standard uncertainty of y (mm).
    pub u_y: f64,
    /// Standard uncertainty of z (mm).
    pub u_z: f64,
    /// Standard uncertainty of the dead path (mm).
    pub u_dead_path: f64,
    /// Number of readings of the station.
    pub readings: usize,
    /// RMS of the station's residuals (µm).
    pub residual_rms_um: f64,
}

impl Record for StationRow {
    const COLUMNS: &'static [&'static str] = &[
        "station",
        "x",
        "y",
        "z",
        "dead_path",
        "u_x",
        "u_y",
        "u_z",
        "u_dead_path",
        "readings",
        "residual_rms_um",
    ];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        name("station", &self.station)?;
        finite_fields!(
            self,
            x,
            y,
            z,
            dead_path,
            u_x,
            u_y,
            u_z,
            u_dead_path,
            residual_rms_um
        )
    }
}

/// One row of `residuals.csv`: a reading, its residual `|A − P| − d − l` (µm),
/// the residual normalised by its own standard deviation, and whether it is
/// flagged as an outlier.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResidualRow {
    /// Station name.
    pub station: String,
    /// Point name.
    pub point: String,
    /// The reading (mm).
    pub l: f64,
    /// Residual (µm).
    pub residual_um: f64,
    /// Normalised residual `v / (σ·√r)` (r: the reading's redundancy number).
    pub normalized: f64,
    /// Flagged: `|normalized| > k`.
    pub outlier: bool,
}

impl Record for ResidualRow {
    const COLUMNS: &'static [&'static str] = &[
        "station",
        "point",
        "l",
        "residual_um",
        "normalized",
        "outlier",
    ];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        name("station", &self.station)?;
        name("point", &self.point)?;
        finite("l", self.l)?;
        finite("residual_um", self.residual_um)?;
        finite("normalized", self.normalized)
    }
}

/// One row of `corrected.csv`: a query point and its correction (dx, dy, dz)
/// by trilinear interpolation in the grid cell that holds it (mm).
pub use super::PointDisplacementRow as CorrectedRow;

/// `truth.json` of `trinocular synth probe tracer`: the true corrections
/// (true − nominal, rigid part removed by the least-squares rigid alignment
/// of the true points to the nominal grid), the true stations and dead paths
/// in that same frame, and the generator's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TracerTruth {
    /// True corrections per grid point, in grid order (mm).
    pub corrections_rigid_removed_mm: Vec<[f64; 3]>,
    /// True station positions, in order of first appearance in `readings.csv` (mm).
    pub stations_mm: Vec<[f64; 3]>,
    /// True dead paths (mm), same order.
    #[serde(default)]
    pub dead_paths_mm: Vec<f64>,
    /// Standard deviation of the reading noise (µm).
    #[serde(default)]
    pub noise_um: Option<f64>,
    /// Anything else the generator records (its configuration).
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// `grid.csv` read and checked: rows in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// The rows with their lines.
    pub rows: Vec<Row<GridRow>>,
    index: HashMap<String, usize>,
}

impl Grid {
    /// Position in [`Grid::rows`] of the point named `point`.
    pub fn index_of(&self, point: &str) -> Option<usize> {
        self.index.get(point).copied()
    }

    /// Distance between the nominal positions of rows `a` and `b` (mm).
    fn distance(&self, a: usize, b: usize) -> f64 {
        let (p, q) = (
            self.rows[a].record.position(),
            self.rows[b].record.position(),
        );
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    }
}

/// Read `grid.csv`: every row checked, then no data rows, duplicate point
/// names, two points at the same position, and a span beyond
/// [`MAX_GRID_EXTENT_MM`] (coordinates in µm) are errors.
pub fn read_grid(path: &Path) -> Result<Grid> {
    check_grid(read_csv::<GridRow>(path)?, path)
}

/// The checks of [`read_grid`] on rows already read (or made in memory);
/// `path` names their source in errors.
pub fn check_grid(rows: Vec<Row<GridRow>>, path: &Path) -> Result<Grid> {
    if rows.is_empty() {
        return Err(FormatError::file(path, "no grid points after the header"));
    }
    let mut index = HashMap::with_capacity(rows.len());
    let mut positions: HashMap<[u64; 3], usize> = HashMap::with_capacity(rows.len());
    for (k, row) in rows.iter().enumerate() {
        match index.entry(row.record.point.clone()) {
            Entry::Occupied(first) => {
                let first: usize = *first.get();
                return Err(row_error(
                    path,
                    row.line,
                    "point",
                    format!(
                        "point '{}' is already defined on line {}",
                        row.record.point, rows[first].line
                    ),
                ));
            }
            Entry::Vacant(v) => {
                v.insert(k);
            }
        }
        // +0.0 folds -0.0 into 0.0, so that the bit patterns compare positions.
        let key = row.record.position().map(|v| (v + 0.0).to_bits());
        if let Some(&first) = positions.get(&key) {
            return Err(row_error(
                path,
                row.line,
                "x",
                format!(
                    "point '{}' has the same coordinates as point '{}' on line {}",
                    row.record.point, rows[first].record.point, rows[first].line
                ),
            ));
        }
        positions.insert(key, k);
    }
    for (a, column) in ["x", "y", "z"].into_iter().enumerate() {
        let (lo, hi) = rows
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                let v = r.record.position()[a];
                (lo.min(v), hi.max(v))
            });
        if hi - lo > MAX_GRID_EXTENT_MM {
            let far = rows
                .iter()
                .find(|r| r.record.position()[a] == hi)
                .map_or(1, |r| r.line);
            return Err(row_error(
                path,
                far,
                column,
                format!(
                    "the grid spans {:.0} in {column}, more than {MAX_GRID_EXTENT_MM:.0} mm: \
                     coordinates must be in mm (are they in µm?)",
                    hi - lo
                ),
            ));
        }
    }
    Ok(Grid { rows, index })
}

/// `readings.csv` read and checked against its grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Readings {
    /// The rows with their lines, in file order.
    pub rows: Vec<Row<ReadingRow>>,
    /// Station names in order of first appearance.
    pub stations: Vec<String>,
    /// Per row: position of its station in [`Readings::stations`].
    pub station_of: Vec<usize>,
    /// Per row: position of its point in the grid's rows.
    pub point_of: Vec<usize>,
}

/// Read `readings.csv` against `grid` (read from `grid_path`): every row
/// checked, then no data rows, a point not in the grid, a (station, point)
/// read twice, and readings whose spread within a station exceeds the
/// distance between their points by more than [`UNIT_SLACK_MM`] (readings
/// not in mm) are errors naming the line and column.
pub fn read_readings(path: &Path, grid: &Grid, grid_path: &Path) -> Result<Readings> {
    check_readings(read_csv::<ReadingRow>(path)?, path, grid, grid_path)
}

/// The checks of [`read_readings`] on rows already read (or made in
/// memory); `path` names their source in errors.
pub fn check_readings(
    rows: Vec<Row<ReadingRow>>,
    path: &Path,
    grid: &Grid,
    grid_path: &Path,
) -> Result<Readings> {
    if rows.is_empty() {
        return Err(FormatError::file(path, "no readings after the header"));
    }
    let mut stations: Vec<String> = Vec::new();
    let mut station_index: HashMap<String, usize> = HashMap::new();
    let mut seen: HashMap<(usize, usize), u64> = HashMap::with_capacity(rows.len());
    let mut station_of = Vec::with_capacity(rows.len());
    let mut point_of = Vec::with_capacity(rows.len());
    for row in &rows {
        let r = &row.record;
        let point = grid.index_of(&r.point).ok_or_else(|| {
            row_error(
                path,
                row.line,
                "point",
                format!("point '{}' is not in {}", r.point, grid_path.display()),
            )
        })?;
        let next = stations.len();
        let station = *station_index.entry(r.station.clone()).or_insert(next);
        if station == next {
            stations.push(r.station.clone());
        }
        if let Some(first) = seen.insert((station, point), row.line) {
            return Err(row_error(
                path,
                row.line,
                "point",
                format!(
                    "station '{}' already has a reading of point '{}' on line {first}",
                    r.station, r.point
                ),
            ));
        }
        station_of.push(station);
        point_of.push(point);
    }
    // Triangle inequality: | |A_a − P| − |A_b − P| | ≤ |A_a − A_b| for the
    // extreme readings of each station.
    let mut extremes: Vec<Option<(usize, usize)>> = vec![None; stations.len()];
    for (k, row) in rows.iter().enumerate() {
        let e = &mut extremes[station_of[k]];
        let l = row.record.l;
        *e = Some(match *e {
            None => (k, k),
            Some((lo, hi)) => (
                if l < rows[lo].record.l { k } else { lo },
                if l > rows[hi].record.l { k } else { hi },
            ),
        });
    }
    for (s, e) in extremes.iter().enumerate() {
        let Some((lo, hi)) = *e else { continue };
        let spread = rows[hi].record.l - rows[lo].record.l;
        let apart = grid.distance(point_of[lo], point_of[hi]);
        if spread > apart + UNIT_SLACK_MM {
            return Err(row_error(
                path,
                rows[hi].line,
                "l",
                format!(
                    "station '{}' reads {} here and {} on line {}, {spread:.3} apart, but points '{}' \
                     and '{}' are only {apart:.3} mm apart: readings must be in mm (are they in µm?), \
                     and the grid's nominal points within {UNIT_SLACK_MM} mm of the true ones",
                    stations[s],
                    rows[hi].record.l,
                    rows[lo].record.l,
                    rows[lo].line,
                    rows[hi].record.point,
                    rows[lo].record.point
                ),
            ));
        }
    }
    Ok(Readings {
        rows,
        stations,
        station_of,
        point_of,
    })
}

/// Read a query file (`x,y,z`, mm): every row checked, no data rows is an error.
pub fn read_query(path: &Path) -> Result<Vec<Row<QueryRow>>> {
    let rows = read_csv::<QueryRow>(path)?;
    if rows.is_empty() {
        return Err(FormatError::file(path, "no query points after the header"));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::probe::assert_mentions;

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    const GRID: &str = "point,x,y,z\n1,0,0,0\n2,100,0,0\n3,0,100,0\n4,0,0,100\n";

    #[test]
    fn good_files_read() {
        let dir = tempfile::tempdir().unwrap();
        let g = write(dir.path(), "grid.csv", GRID);
        let r = write(
            dir.path(),
            "readings.csv",
            "station,point,l\nA,1,0\nA,2,50.5\nB,3,0\nB,4,-20\n",
        );
        let grid = read_grid(&g).unwrap();
        assert_eq!(grid.index_of("3"), Some(2));
        let readings = read_readings(&r, &grid, &g).unwrap();
        assert_eq!(readings.stations, ["A", "B"]);
        assert_eq!(readings.station_of, [0, 0, 1, 1]);
        assert_eq!(readings.point_of, [0, 1, 2, 3]);
    }

    fn grid_error(text: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let g = write(dir.path(), "grid.csv", text);
        read_grid(&g).unwrap_err().to_string()
    }

    fn readings_error(text: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let g = write(dir.path(), "grid.csv", GRID);
        let r = write(dir.path(), "readings.csv", text);
        let grid = read_grid(&g).unwrap();
        read_readings(&r, &grid, &g).unwrap_err().to_string()
    }

    #[test]
    fn grid_errors_name_line_and_column() {
        let e = grid_error("point,x,y,z\n1,0,0,0\n1,1,0,0\n");
        assert_mentions(&e, &["line 3, column 'point'", "line 2"]);
        let e = grid_error("point,x,y,z\n1,0,0,0\n2,0,-0,0\n");
        assert_mentions(&e, &["line 3, column 'x'", "same coordinates"]);
        let e = grid_error("point,x,y,z\n1,0,0,0\n2,0,NaN,0\n");
        assert!(e.contains("line 3, column 'y'"), "{e}");
        let e = grid_error("point,x,y,z\n1,0,0,0\n2,0,0,400000\n");
        assert_mentions(&e, &["line 3, column 'z'", "µm"]);
        let e = grid_error("point,x,y,z\n");
        assert!(e.contains("no grid points"), "{e}");
    }

    #[test]
    fn reading_errors_name_line_and_column() {
        let e = readings_error("station,point,l\nA,1,0\nA,1,0.5\n");
        assert_mentions(&e, &["line 3, column 'point'", "line 2"]);
        let e = readings_error("station,point,l\nA,1,0\nA,9,0.5\n");
        assert_mentions(&e, &["line 3, column 'point'", "'9'"]);
        let e = readings_error("station,point,l\nA,1,0\nA,2,nan\n");
        assert!(e.contains("line 3, column 'l'"), "{e}");
        // 100 mm apart, read as 50000 (µm): the spread breaks the triangle inequality.
        let e = readings_error("station,point,l\nA,1,0\nA,2,50000\nB,1,0\n");
        assert_mentions(&e, &["line 3, column 'l'", "µm"]);
        let e = readings_error("station,point,l\n");
        assert!(e.contains("no readings"), "{e}");
    }

    #[test]
    fn query_rows_are_checked() {
        let dir = tempfile::tempdir().unwrap();
        let q = write(dir.path(), "q.csv", "x,y,z\n1,2,3\n1,inf,3\n");
        let e = read_query(&q).unwrap_err().to_string();
        assert!(e.contains("line 3, column 'y'"), "{e}");
    }
}
