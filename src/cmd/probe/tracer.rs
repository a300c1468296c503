//! `trinocular probe tracer` (CMM volumetric correction by laser-tracer
//! multilateration, docs/probe-tracer.md) and `trinocular synth probe tracer` (its
//! check data with truth). Thin: flags, files through `formats`, the work in
//! `probe::tracer` and `synth::probe::tracer`.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use formats::FormatError;
use formats::probe::tracer::report::FIGURES;
use formats::probe::tracer::{
    CorrectedRow, CorrectionRow, Grid, QueryRow, ResidualRow, StationRow, read_grid, read_query,
    read_readings,
};
use formats::{Row, write_records};
use geom::Point3;
use probe::ProbeError;
use probe::tracer::{self, CorrectionGrid, Network, Options};
use synth::probe::tracer::{TracerConfig, generate};

use crate::cmd::OrUsage;

const UM: f64 = 1e3;
const AXES: [&str; 3] = ["x", "y", "z"];

/// Arguments of `trinocular probe tracer`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Nominal grid `point,x,y,z` (CMM coordinates, mm).
    #[arg(long, value_name = "GRID.csv")]
    nominal: PathBuf,
    /// Interferometric readings `station,point,l` (mm, relative to each station's first point).
    #[arg(long, value_name = "READINGS.csv")]
    readings: PathBuf,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Points `x,y,z` (mm) to correct by trilinear interpolation in the grid's cells (the grid
    /// must be a lattice): writes DIR/corrected.csv.
    #[arg(long, value_name = "Q.csv")]
    query: Option<PathBuf>,
    /// Flag a reading when its normalised residual exceeds k.
    #[arg(long, default_value_t = tracer::OUTLIER_K, value_parser = crate::cmd::values::positive)]
    k: f64,
    /// Standard deviation of a reading (µm) to use for the uncertainties, instead of the one
    /// estimated from the residuals.
    #[arg(long, value_name = "UM", value_parser = crate::cmd::values::positive)]
    sigma_um: Option<f64>,
    #[command(flatten)]
    method: super::MethodArgs,
}

/// Arguments of `trinocular synth probe tracer`. Defaults are those of
/// `synth::probe::tracer::TracerConfig` (the check data's layout).
#[derive(Debug, clap::Args)]
pub struct SynthArgs {
    /// Output directory (created if missing): grid.csv, readings.csv, truth.json.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Grid points along x, y, z [default: 5,5,4].
    #[arg(long, value_parser = triple::<usize>, value_name = "NX,NY,NZ")]
    counts: Option<[usize; 3]>,
    /// Size of the grid along x, y, z (mm) [default: 400,400,300].
    #[arg(long, value_parser = triple::<f64>, value_name = "X,Y,Z")]
    size: Option<[f64; 3]>,
    /// Corner of the grid with the smallest coordinates (mm) [default: 0,0,0].
    #[arg(long, value_parser = triple::<f64>, value_name = "X,Y,Z", allow_hyphen_values = true)]
    origin: Option<[f64; 3]>,
    /// Number of tracer stations.
    #[arg(long, default_value_t = TracerConfig::default().stations)]
    stations: usize,
    /// Distance of the stations from the grid centre, in half-diagonals of the grid.
    #[arg(long, default_value_t = TracerConfig::default().station_distance, value_parser = crate::cmd::values::finite)]
    station_distance: f64,
    /// RMS of the CMM's error field (µm).
    #[arg(long, default_value_t = TracerConfig::default().error_um, value_parser = crate::cmd::values::finite)]
    error_um: f64,
    /// Standard deviation of a reading (µm).
    #[arg(long, default_value_t = TracerConfig::default().noise_um, value_parser = crate::cmd::values::finite)]
    noise_um: f64,
    /// Resolution the readings are rounded to (µm; 0: none).
    #[arg(long, default_value_t = TracerConfig::default().resolution_um, value_parser = crate::cmd::values::finite)]
    resolution_um: f64,
    /// Share of readings left out at random.
    #[arg(long, default_value_t = TracerConfig::default().missing, value_parser = crate::cmd::values::finite)]
    missing: f64,
    /// Seed of the error field and the station layout.
    #[arg(long, default_value_t = TracerConfig::default().seed)]
    seed: u64,
    /// Seed of the reading noise.
    #[arg(long, default_value_t = TracerConfig::default().noise_seed)]
    noise_seed: u64,
    /// Replace output files that already exist.
    #[arg(long)]
    force: bool,
}

/// The lattice of the grid and the query points inside it, checked before
/// solving so that a refused query leaves nothing written.
fn check_query(
    net: &Network,
    grid: &Grid,
    grid_path: &Path,
    query: &[Row<QueryRow>],
    query_path: &Path,
) -> Result<()> {
    let zeros = vec![geom::Vector3::zeros(); net.points.len()];
    let lattice =
        CorrectionGrid::new(&net.points, &net.point_names, &zeros).map_err(|e| match e {
            ProbeError::NotLattice(ref fault) if let Some(i) = fault.point() => {
                anyhow::Error::new(FormatError::Row {
                    path: grid_path.to_path_buf(),
                    line: grid.rows[i].line,
                    column: fault.axis().map(|a| AXES[a].to_string()),
                    message: format!("--query needs a lattice grid: {fault}"),
                })
            }
            other => anyhow::anyhow!(
                "{}: --query needs a lattice grid: {other}",
                grid_path.display()
            ),
        })?;
    for row in query {
        let p = Point3::from(row.record.position());
        if let Some(a) = lattice.outside(&p) {
            let (lo, hi) = lattice.range(a);
            return Err(FormatError::Row {
                path: query_path.to_path_buf(),
                line: row.line,
                column: Some(AXES[a].to_string()),
                message: format!(
                    "{} = {} is outside the grid ({} from {lo} to {hi} mm in {})",
                    AXES[a],
                    p[a],
                    AXES[a],
                    grid_path.display()
                ),
            }
            .into());
        }
    }
    Ok(())
}

/// The tables of a solution.
struct Tables {
    corrections: Vec<CorrectionRow>,
    stations: Vec<StationRow>,
    residuals: Vec<ResidualRow>,
    /// The query points corrected (with `--query`).
    corrected: Option<Vec<CorrectedRow>>,
}

/// Run the method: read and check the inputs (a query outside the grid is
/// refused before solving), refuse outputs that exist, solve, tabulate,
/// write, print the summary.
pub fn run(args: &Args) -> Result<()> {
    let mut signing = super::Signing::start(&args.method)?;
    let grid = read_grid(&args.nominal)?;
    let readings = read_readings(&args.readings, &grid, &args.nominal)?;
    let query = args.query.as_deref().map(read_query).transpose()?;
    let net = Network::from_records(&grid, &readings);
    if let (Some(q), Some(path)) = (&query, &args.query) {
        check_query(&net, &grid, &args.nominal, q, path)?;
    }
    let mut names = vec![
        "report.json",
        "report.html",
        "corrections.csv",
        "stations.csv",
        "residuals.csv",
    ];
    if query.is_some() {
        names.push("corrected.csv");
    }
    let mut inputs = vec![args.nominal.as_path(), args.readings.as_path()];
    inputs.extend(args.query.as_deref());
    let (output, files) = signing.outputs(&args.out, &names, inputs)?;

    let options = Options {
        outlier_k: args.k,
        sigma_mm: args.sigma_um.map(|s| s / UM),
        ..Options::default()
    };
    let solution = tracer::solve(&net, &options).with_context(|| {
        format!(
            "{} with {}",
            args.readings.display(),
            args.nominal.display()
        )
    })?;
    let report = tracer::report(&net, &solution);
    signing.read_limits(&report, &FIGURES)?;
    let uncertainty = tracer::uncertainty(&net, &solution, &options, signing.propagation())?;
    let json = signing.judge(&report, Some(&uncertainty), &FIGURES)?;
    let page = tracer::html(&net, &solution, &report, &uncertainty, &signing.signoff)?;
    let tables = tables(&net, &solution, &readings, query.as_deref())?;

    let out = &args.out;
    output.write_records(&out.join("corrections.csv"), &tables.corrections)?;
    output.write_records(&out.join("stations.csv"), &tables.stations)?;
    output.write_records(&out.join("residuals.csv"), &tables.residuals)?;
    if let Some(c) = &tables.corrected {
        output.write_records(&out.join("corrected.csv"), c)?;
    }
    output.write_json(&out.join("report.json"), &json)?;
    output.write_bytes(&out.join("report.html"), page.as_bytes())?;
    signing.print(out)?;

    print_summary(&report, tables.corrected.as_ref().map(Vec::len));
    super::print_uncertainty(&uncertainty);
    println!("wrote {} files into {}", files.len(), out.display());
    signing.finish(out)
}

/// The solution as tables: corrections and stations with their
/// uncertainties, every reading's residual, and the query points corrected
/// by trilinear interpolation in the grid.
fn tables(
    net: &Network,
    solution: &tracer::Solution,
    readings: &formats::probe::tracer::Readings,
    query: Option<&[Row<QueryRow>]>,
) -> Result<Tables> {
    let corrections: Vec<CorrectionRow> = net
        .points
        .iter()
        .zip(&net.point_names)
        .zip(&solution.corrections)
        .map(|((p, name), c)| CorrectionRow {
            point: name.clone(),
            x: p.x,
            y: p.y,
            z: p.z,
            dx: c.vector.x,
            dy: c.vector.y,
            dz: c.vector.z,
            u_dx: c.u.x,
            u_dy: c.u.y,
            u_dz: c.u.z,
        })
        .collect();
    let stations: Vec<StationRow> = solution
        .stations
        .iter()
        .zip(&net.station_names)
        .map(|(s, name)| StationRow {
            station: name.clone(),
            x: s.position.x,
            y: s.position.y,
            z: s.position.z,
            dead_path: s.dead_path,
            u_x: s.u_position.x,
            u_y: s.u_position.y,
            u_z: s.u_position.z,
            u_dead_path: s.u_dead_path,
            readings: s.readings,
            residual_rms_um: s.residual_rms * UM,
        })
        .collect();
    let residuals: Vec<ResidualRow> = readings
        .rows
        .iter()
        .zip(&solution.residuals)
        .map(|(r, v)| ResidualRow {
            station: r.record.station.clone(),
            point: r.record.point.clone(),
            l: r.record.l,
            residual_um: v.value * UM,
            normalized: v.normalized,
            outlier: v.outlier,
        })
        .collect();
    let corrected: Option<Vec<CorrectedRow>> = match query {
        Some(q) => {
            let vectors: Vec<_> = solution.corrections.iter().map(|c| c.vector).collect();
            let lattice = CorrectionGrid::new(&net.points, &net.point_names, &vectors)?;
            Some(
                q.iter()
                    .map(|row| {
                        let p = Point3::from(row.record.position());
                        let c = lattice.at(&p)?;
                        Ok(CorrectedRow {
                            x: p.x,
                            y: p.y,
                            z: p.z,
                            dx: c.x,
                            dy: c.y,
                            dz: c.z,
                        })
                    })
                    .collect::<Result<_>>()?,
            )
        }
        None => None,
    };
    Ok(Tables {
        corrections,
        stations,
        residuals,
        corrected,
    })
}

/// What the solution found, on stdout; weakly determined stations and points
/// as warnings on stderr.
fn print_summary(report: &tracer::TracerReport, corrected: Option<usize>) {
    println!(
        "tracer: {} points, {} stations, {} readings, {} unknowns (redundancy {})",
        report.points, report.stations, report.equations, report.unknowns, report.redundancy
    );
    println!(
        "converged in {} iterations; residual RMS {:.4} µm, σ of a reading {:.4} µm{}; condition {:.3e}",
        report.iterations,
        report.residual_rms_um,
        report.sigma_um,
        if report.sigma_a_priori {
            " (a priori)"
        } else {
            ""
        },
        report.condition
    );
    println!(
        "corrections: largest {:.3} µm at point {}, RMS {:.3} µm; standard uncertainty median {:.4} µm, largest {:.4} µm",
        report.max_correction_um,
        report.max_correction_point,
        report.rms_correction_um,
        report.median_u_um,
        report.max_u_um
    );
    println!(
        "outliers: {} readings with |w| > {} (≈ {:.1} expected by chance; flagged in residuals.csv, \
         kept in the solution)",
        report.outliers.count, report.outliers.k, report.outliers.expected_by_chance
    );
    for w in &report.weak.stations {
        eprintln!(
            "trinocular: warning: station {} weakly determined: {}",
            w.name, w.reason
        );
    }
    for w in &report.weak.points {
        eprintln!(
            "trinocular: warning: point {} weakly determined: {}",
            w.name, w.reason
        );
    }
    if let Some(n) = corrected {
        println!("corrected {n} query points by trilinear interpolation");
    }
}

/// Parse `a,b,c` (x, y, z) for a flag.
fn triple<T: std::str::FromStr>(text: &str) -> std::result::Result<[T; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [a, b, c] = parts.as_slice() else {
        return Err(format!("{} values where x, y, z take 3", parts.len()));
    };
    let parse = |v: &str| v.parse::<T>().map_err(|_| format!("'{v}' is not a number"));
    Ok([parse(a)?, parse(b)?, parse(c)?])
}

/// Run the generator.
pub fn synth(args: &SynthArgs) -> Result<()> {
    let d = TracerConfig::default();
    let config = TracerConfig {
        counts: args.counts.unwrap_or(d.counts),
        size: args.size.unwrap_or(d.size),
        origin: args.origin.unwrap_or(d.origin),
        stations: args.stations,
        station_distance: args.station_distance,
        error_um: args.error_um,
        noise_um: args.noise_um,
        resolution_um: args.resolution_um,
        missing: args.missing,
        seed: args.seed,
        noise_seed: args.noise_seed,
    };
    config.check().or_usage()?;
    let data = generate(&config)?;
    let names = ["grid.csv", "readings.csv", "truth.json"];
    let (output, [grid, readings, truth]) =
        super::outputs_n(&args.out, names, [] as [&Path; 0], args.force)?;
    output.write_records(&grid, &data.grid)?;
    output.write_records(&readings, &data.readings)?;
    output.write_json(&truth, &data.truth)?;
    println!(
        "tracer: {} grid points ({}×{}×{} over {}×{}×{} mm), {} stations, {} readings (noise {} µm), \
         error field {} µm RMS",
        data.grid.len(),
        config.counts[0],
        config.counts[1],
        config.counts[2],
        config.size[0],
        config.size[1],
        config.size[2],
        config.stations,
        data.readings.len(),
        config.noise_um,
        config.error_um
    );
    println!(
        "wrote grid.csv, readings.csv, truth.json into {}",
        args.out.display()
    );
    Ok(())
}

/// Arguments of `trinocular bench tracer`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Grid points along x, y, z (10⁴ by default).
    #[arg(long, value_parser = triple::<usize>, default_value = "25,20,20", value_name = "NX,NY,NZ")]
    counts: [usize; 3],
    /// Tracer stations.
    #[arg(long, default_value_t = 8)]
    stations: usize,
    /// Timed solves (the median is reported).
    #[arg(long, default_value_t = 5)]
    repeat: usize,
}

/// Median wall time of `repeat` calls of `f` (after one untimed call).
fn median_time<T>(repeat: usize, mut f: impl FnMut() -> Result<T>) -> Result<(Duration, T)> {
    let mut last = f()?;
    let mut times = Vec::with_capacity(repeat.max(1));
    for _ in 0..repeat.max(1) {
        let start = Instant::now();
        last = f()?;
        times.push(start.elapsed());
    }
    times.sort();
    Ok((times[times.len() / 2], last))
}

/// `trinocular bench tracer`: the generator's data written and read back
/// through the file readers, then the solve timed on all threads and on one,
/// and the Monte Carlo of the figures' U that `probe tracer` adds by default.
pub fn bench(args: &BenchArgs) -> Result<()> {
    let config = TracerConfig {
        counts: args.counts,
        stations: args.stations,
        ..TracerConfig::default()
    };
    let data = generate(&config)?;
    let dir = formats::interrupt::ScratchFolder::new()?;
    let (grid_path, readings_path) = (dir.path().join("grid.csv"), dir.path().join("readings.csv"));
    write_records(&grid_path, &data.grid)?;
    write_records(&readings_path, &data.readings)?;
    let start = Instant::now();
    let grid = read_grid(&grid_path)?;
    let readings = read_readings(&readings_path, &grid, &grid_path)?;
    let read = start.elapsed();
    let net = Network::from_records(&grid, &readings);
    let options = Options::default();
    let threads = rayon::current_num_threads();
    let (all, solution) = median_time(args.repeat, || Ok(tracer::solve(&net, &options)?))?;
    let one_pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let (one, _) = median_time(args.repeat, || {
        Ok(one_pool.install(|| tracer::solve(&net, &options))?)
    })?;
    // The figures' U as `probe tracer` computes it by default (200 trials
    // and the budget), against the solve: what `--trials 0` saves.
    let propagation = probe::uncertainty::Propagation::default();
    let (mc, uncertainty) = median_time(args.repeat, || {
        Ok(tracer::uncertainty(&net, &solution, &options, propagation)?)
    })?;
    let start = Instant::now();
    let report = tracer::report(&net, &solution);
    let page = tracer::html(&net, &solution, &report, &uncertainty, &Default::default())?;
    let html = start.elapsed();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!(
        "tracer: n = {} points, m = {} stations, {} readings, {} unknowns",
        net.points.len(),
        net.station_names.len(),
        net.readings.len(),
        3 * net.points.len() + 4 * net.station_names.len()
    );
    println!("read grid.csv + readings.csv:   {:8.1} ms", ms(read));
    println!(
        "solve, {threads} threads:              {:8.1} ms  (median of {}; {} iterations, residual RMS {:.3} µm)",
        ms(all),
        args.repeat.max(1),
        solution.iterations,
        solution.residual_rms * UM
    );
    println!("solve, 1 thread:                {:8.1} ms", ms(one));
    println!(
        "U of the figures, {threads} threads:   {:8.1} ms  ({} trials and the budget, as `probe tracer` \
         by default; none with --trials 0)",
        ms(mc),
        propagation.trials
    );
    println!(
        "report.json + report.html:      {:8.1} ms  ({:.1} MB of HTML)",
        ms(html),
        page.len() as f64 / 1e6
    );
    println!(
        "the solve includes the seed's station start, the Gauss–Newton iterations (Schur complement \
         onto the {} station unknowns) and the covariance of every correction",
        4 * net.station_names.len()
    );
    Ok(())
}
