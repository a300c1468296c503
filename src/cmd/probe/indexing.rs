//! `trinocular probe indexing --centres C.csv --out DIR`: probe-head indexing
//! errors ΔθA, ΔθB by the construction of docs/probe-indexing.md (the `probe` crate),
//! writing `DIR/indexing.csv`, `DIR/report.json` and `DIR/report.html`; and
//! `trinocular synth probe indexing --out DIR`: centres of a head with known
//! indexing errors (the `synth` crate), `DIR/centres.csv` and `DIR/truth.json`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use formats::FormatError;
use formats::probe::indexing::report::FIGURES;
use formats::probe::indexing::{CentreRow, IndexingRow, read_centres};
use probe::indexing::{self as method, Position, layout};
use synth::probe::indexing::{IndexingConfig, generate};

/// Arguments of `trinocular probe indexing`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Measured reference-sphere centre per head position: `a_deg,b_deg,x,y,z` (degrees, mm).
    #[arg(long, value_name = "FILE")]
    centres: PathBuf,
    /// Output directory (created if missing): indexing.csv, report.json, report.html.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Nominal head-centre-to-stylus-ball length, to compare the fitted radius with.
    #[arg(long, value_name = "MM", value_parser = crate::cmd::values::positive)]
    nominal_radius: Option<f64>,
    /// List the positions whose |ΔθA| or |ΔθB| exceed this many arc-seconds.
    #[arg(long, value_name = "ARCSEC", value_parser = crate::cmd::values::non_negative)]
    tolerance: Option<f64>,
    #[command(flatten)]
    method: super::MethodArgs,
}

/// Arguments of `trinocular synth probe indexing`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("what").required(true).multiple(true).args(["out", "print_config"])))]
pub struct SynthArgs {
    /// Output directory (created if missing): centres.csv, truth.json.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Configuration (TOML; see --print-config). Default: a PH10 with a 117 mm stylus, 720 positions.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Random seed (detent errors, noise); same seed, same files.
    #[arg(long)]
    seed: Option<u64>,
    /// Largest A (degrees).
    #[arg(long, value_name = "DEG", value_parser = crate::cmd::values::finite)]
    a_max: Option<f64>,
    /// A step (degrees).
    #[arg(long, value_name = "DEG", value_parser = crate::cmd::values::finite)]
    a_step: Option<f64>,
    /// B step (degrees; must divide 360).
    #[arg(long, value_name = "DEG", value_parser = crate::cmd::values::finite)]
    b_step: Option<f64>,
    /// Head-centre-to-stylus-ball length (mm).
    #[arg(long, value_name = "MM", value_parser = crate::cmd::values::finite)]
    stylus: Option<f64>,
    /// Noise of every reported coordinate (µm, standard deviation).
    #[arg(long, value_name = "UM", value_parser = crate::cmd::values::finite)]
    noise_um: Option<f64>,
    /// Print the documented default configuration and exit.
    #[arg(long)]
    print_config: bool,
    /// Replace output files that already exist.
    #[arg(long)]
    force: bool,
}

/// The positions of `centres.csv`, checked for the construction; a fault
/// names the file, the line and the column.
fn positions(path: &Path) -> Result<Vec<Position>> {
    let rows = read_centres(path)?;
    let angles: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.record.a_deg, r.record.b_deg))
        .collect();
    let xyz: Vec<[f64; 3]> = rows
        .iter()
        .map(|r| [r.record.x, r.record.y, r.record.z])
        .collect();
    if let Err(fault) = layout::check(&angles, &xyz) {
        let (row, column, message) = fault.describe(|k| format!("line {}", rows[k].line));
        return Err(match row {
            Some(k) => FormatError::Row {
                path: path.to_path_buf(),
                line: rows[k].line,
                column: Some(column.into()),
                message,
            },
            None => FormatError::file(path, format!("column '{column}': {message}")),
        }
        .into());
    }
    Ok(angles
        .iter()
        .zip(&xyz)
        .map(|(&(a, b), p)| Position::new(a, b, *p))
        .collect())
}

/// Run the method.
pub fn run(args: &Args) -> Result<()> {
    let mut signing = super::Signing::start(&args.method)?;
    let names = ["indexing.csv", "report.json", "report.html"];
    let (output, files) = signing.outputs(&args.out, &names, [&args.centres])?;
    let [csv, json_path, html] = [&files[0], &files[1], &files[2]];
    let positions = positions(&args.centres)?;
    let solved = method::solve(&positions)
        .with_context(|| format!("{}: the construction failed", args.centres.display()))?;
    let options = method::Options {
        nominal_radius_mm: args.nominal_radius,
        tolerance_arcsec: args.tolerance,
        source: args.centres.display().to_string(),
    };
    let mut report = method::report(&solved, &options)?;
    signing.read_limits(&report, &FIGURES)?;
    report.uncertainty = Some(method::uncertainty::propagate(
        &positions,
        &solved,
        &report,
        &options,
        signing.propagation(),
    ));
    let json = signing.judge(&report, report.uncertainty.as_ref(), &FIGURES)?;
    let page = method::html(&report, &solved.angles, &signing.signoff)?;
    let rows: Vec<IndexingRow> = solved
        .angles
        .iter()
        .map(|p| IndexingRow {
            a_deg: p.a_deg,
            b_deg: p.b_deg,
            theta_a_deg: p.theta_a_deg,
            theta_b_deg: p.theta_b_deg,
            d_a_arcsec: p.d_a_arcsec,
            d_b_arcsec: p.d_b_arcsec,
            u_d_a_arcsec: p.u_d_a_arcsec,
            u_d_b_arcsec: p.u_d_b_arcsec,
            residual_um: p.residual_um,
        })
        .collect();
    output.write_records(csv, &rows)?;
    output.write_json(json_path, &json)?;
    output.write_bytes(html, page.as_bytes())?;
    signing.print(&args.out)?;

    let c = report.rotation_centre;
    println!(
        "rotation centre O ({:.4}, {:.4}, {:.4}) mm, radius {:.4} mm (u {:.3} µm); sphere fit residual RMS {:.3} µm",
        c[0], c[1], c[2], report.radius_mm, report.u_radius_um, report.sphere_fit.residual_rms_um
    );
    if let (Some(n), Some(d)) = (report.nominal_radius_mm, report.radius_deviation_um) {
        println!("radius − nominal {n} mm: {d:+.1} µm");
    }
    println!(
        "ΔθA: max |ΔθA| {:.3}″ (A = {}°, B = {}°), RMS {:.3}″",
        report.max_d_a_arcsec,
        report.max_d_a_at.a_deg,
        report.max_d_a_at.b_deg,
        report.rms_d_a_arcsec
    );
    println!(
        "ΔθB: max |ΔθB| {:.3}″ (A = {}°, B = {}°), RMS {:.3}″",
        report.max_d_b_arcsec,
        report.max_d_b_at.a_deg,
        report.max_d_b_at.b_deg,
        report.rms_d_b_arcsec
    );
    println!(
        "per detent (noise averaged): max |mean ΔθA| {:.3}″ (A > 0°), max |mean ΔθB| {:.3}″",
        report.max_detent_d_a_arcsec, report.max_detent_d_b_arcsec
    );
    println!(
        "standard uncertainty of one ΔθA / ΔθB (median): {:.3}″ / {:.3}″",
        report.median_u_d_a_arcsec, report.median_u_d_b_arcsec
    );
    if let Some(t) = &report.tolerance {
        println!(
            "beyond ±{}″ by more than U: {} positions ({} in ΔθA, {} in ΔθB); within U of it, \
             undecided: {} in ΔθA, {} in ΔθB",
            t.tolerance_arcsec,
            t.exceeding.len(),
            t.count_d_a,
            t.count_d_b,
            t.inconclusive_d_a,
            t.inconclusive_d_b
        );
    }
    if let Some(u) = &report.uncertainty {
        super::print_uncertainty(u);
    }
    for w in &report.warnings {
        eprintln!("trinocular: warning: {w}");
    }
    println!(
        "wrote {} positions to {}, {} and {}",
        rows.len(),
        csv.display(),
        json_path.display(),
        html.display()
    );
    signing.finish(&args.out)
}

/// Run the generator.
pub fn synth(args: &SynthArgs) -> Result<()> {
    let Some((out, mut config)) =
        super::synth_start::<IndexingConfig>(args.print_config, &args.out, &args.config)?
    else {
        return Ok(());
    };
    config.seed = args.seed.unwrap_or(config.seed);
    config.a_max_deg = args.a_max.unwrap_or(config.a_max_deg);
    config.a_step_deg = args.a_step.unwrap_or(config.a_step_deg);
    config.b_step_deg = args.b_step.unwrap_or(config.b_step_deg);
    config.stylus_mm = args.stylus.unwrap_or(config.stylus_mm);
    config.noise_um = args.noise_um.unwrap_or(config.noise_um);
    let config = super::overridden(config)?;
    let (output, [centres, truth]) =
        super::outputs_n(out, ["centres.csv", "truth.json"], &args.config, args.force)?;
    let generated = generate(&config)?;
    output.write_records::<CentreRow>(&centres, &generated.centres)?;
    output.write_json(&truth, &generated.truth)?;
    let largest =
        |values: &mut dyn Iterator<Item = f64>| values.fold(0.0_f64, |m, v| m.max(v.abs()));
    let t = &generated.truth.truth;
    println!(
        "{} positions (A 0…{}° every {}°, B every {}°), stylus {} mm, noise {} µm, seed {}; \
         injected max |ΔθA| {:.3}″, max |ΔθB| {:.3}″",
        generated.centres.len(),
        config.a_detents().last().copied().unwrap_or(0.0),
        config.a_step_deg,
        config.b_step_deg,
        config.stylus_mm,
        config.noise_um,
        config.seed,
        largest(&mut t.iter().map(|r| r.2)),
        largest(&mut t.iter().filter_map(|r| r.3)),
    );
    println!("wrote {} and {}", centres.display(), truth.display());
    Ok(())
}
