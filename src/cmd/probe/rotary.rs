//! `trinocular probe rotary (--centres C.csv | --points P.csv) --out DIR
//! [--at DEG …] [--force]`: rotary-table errors from a standard ball
//! (docs/probe-rotary.md); writes `DIR/rotary.csv`, `DIR/report.json`,
//! `DIR/report.html`, with `--at` `DIR/rotary_at.csv`, with `--points`
//! `DIR/spheres.csv`, and prints the sign-off figures.
//!
//! `trinocular synth probe rotary --out DIR [--config FILE] [--seed S]
//! [--step-deg D] [--noise-um N] [--force]`: check data with known truth
//! (`centres.csv`, `points.csv`, `truth.json`, `config.toml`);
//! `--print-config` prints the documented default configuration.

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use formats::probe::rotary::report::FIGURES;
use formats::probe::rotary::{
    CentreRow, ErrorRow, RotaryInput, SphereFitRow, read_centres, read_points,
};
use probe::rotary::report::{Report, report};
use probe::rotary::uncertainty::Measured;
use probe::rotary::{Interpolated, Measurement, NAMES, Solution};
use probe::{CentreFault, ProbeError};
use synth::probe::rotary::RotaryConfig;

use crate::cmd::Usage;

/// Arguments of `trinocular probe rotary`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["centres", "points"])))]
pub struct Args {
    /// Ball centres `ball,angle_deg,x,y,z` (mm, table frame; angles in degrees, counter-clockwise
    /// seen from +Z): one row per ball and angle, every ball at the same angles, 0° among them.
    #[arg(long)]
    centres: Option<PathBuf>,
    /// Probed points, same columns: at least 4 rows per ball and angle (e.g. the north pole and
    /// four on the equator); a sphere is fitted to each.
    #[arg(long)]
    points: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Also write rotary_at.csv: the errors at these angles (degrees, any value; linear between
    /// the two nearest measured angles, wrapping at 360°).
    #[arg(long, num_args = 1.., allow_negative_numbers = true, value_name = "DEG", value_parser = crate::cmd::values::finite)]
    at: Vec<f64>,
    #[command(flatten)]
    method: super::MethodArgs,
}

/// Arguments of `trinocular synth probe rotary`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("what").required(true).multiple(true).args(["out", "print_config"])))]
pub struct SynthArgs {
    /// Output directory (created if missing).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Configuration (TOML; see --print-config). Default: a C axis with offset, tilt, wobble,
    /// run-out and angular errors, three balls, 30° steps, 0.3 µm noise.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Random seed of the noise.
    #[arg(long)]
    seed: Option<u64>,
    /// Angular step (degrees): angles 0, step, … below 360.
    #[arg(long, value_parser = crate::cmd::values::finite)]
    step_deg: Option<f64>,
    /// Noise of centres and probed points, per coordinate (µm, standard deviation).
    #[arg(long, value_parser = crate::cmd::values::finite)]
    noise_um: Option<f64>,
    /// Print the documented default configuration and exit.
    #[arg(long)]
    print_config: bool,
    /// Replace output files that already exist.
    #[arg(long)]
    force: bool,
}

/// mm → µm and rad → µrad, for printing.
const UM: f64 = 1e3;
const URAD: f64 = 1e6;

/// `12–16` or `12` for the lines of one ball and angle.
fn line_span(lines: &[u64]) -> String {
    match (lines.iter().min(), lines.iter().max()) {
        (Some(a), Some(b)) if a != b => format!("lines {a}–{b}"),
        (Some(a), _) => format!("line {a}"),
        _ => "line ?".into(),
    }
}

/// A method error with the file, and the line where it is about one centre.
fn located(e: ProbeError, input: &RotaryInput) -> anyhow::Error {
    let path = input.path.display();
    if let ProbeError::Centre {
        ball,
        angle_deg,
        fault,
    } = &e
    {
        let lines = input.lines(ball, *angle_deg);
        if !lines.is_empty() {
            // A sphere fit fails on the points' values; anything else on the angle.
            let column = if matches!(fault, CentreFault::SphereFit(_)) {
                "x"
            } else {
                "angle_deg"
            };
            return anyhow!("{path}: {}, column '{column}': {e}", line_span(&lines));
        }
    }
    anyhow!("{path}: {e}")
}

fn error_row(
    angle_deg: f64,
    errors: &probe::rotary::SixErrors,
    u: &probe::rotary::SixErrors,
) -> ErrorRow {
    ErrorRow::new(
        angle_deg,
        std::array::from_fn(|k| errors[k]),
        std::array::from_fn(|k| u[k]),
    )
}

/// The sign-off figures on stdout.
fn print_summary(solution: &Solution, report: &Report) {
    println!(
        "{} balls at {} angles; layout condition number {:.2}; residual RMS {:.3} µm",
        solution.balls.len(),
        solution.angles_deg.len(),
        report.condition,
        report.residual_rms_um
    );
    if let Some(l) = &report.location {
        println!(
            "location: X0C {:.3} µm, Y0C {:.3} µm, A0C {:.3} µrad, B0C {:.3} µrad (u {:.3} µm, {:.3} µrad)",
            l.errors.x0c_um,
            l.errors.y0c_um,
            l.errors.a0c_urad,
            l.errors.b0c_urad,
            l.u_x0c_um.max(l.u_y0c_um),
            l.u_a0c_urad.max(l.u_b0c_urad)
        );
    }
    let ranges = |label: &str, v: [f64; 6]| {
        let parts: Vec<String> = (0..6)
            .map(|k| {
                let unit = if k < 3 { "µm" } else { "µrad" };
                format!("{} {:.3} {unit}", NAMES[k], v[k])
            })
            .collect();
        println!("{label}: {}", parts.join(", "));
    };
    ranges("ranges of the errors", report.ranges.errors.values());
    if let Some(c) = &report.ranges.components {
        ranges("ranges of the component errors", c.values());
    }
    if let Some(u) = &report.uncertainty {
        super::print_uncertainty(u);
    }
    for w in &report.warnings {
        eprintln!("trinocular: warning: {w}");
    }
}

/// Run the method and write its outputs.
pub fn run(args: &Args) -> Result<()> {
    let (path, points) = match (&args.centres, &args.points) {
        (Some(c), None) => (c, false),
        (None, Some(p)) => (p, true),
        _ => return Err(Usage::error("give exactly one of --centres and --points")),
    };
    let mut signing = super::Signing::start(&args.method)?;
    let input = if points {
        read_points(path)?
    } else {
        read_centres(path)?
    };
    let m = if points {
        Measurement::from_points(input.angles_deg.clone(), input.points())
    } else {
        Ok(Measurement::from_centres(
            input.angles_deg.clone(),
            input.centres(),
        ))
    }
    .map_err(|e| located(e, &input))?;
    let solution = probe::rotary::solve(&m).map_err(|e| located(e, &input))?;
    let at: Vec<Interpolated> = args
        .at
        .iter()
        .map(|a| solution.at(*a))
        .collect::<probe::Result<_>>()
        .map_err(|e| Usage::error(format!("--at: {e}")))?;
    let source = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let mut report = report(&solution, &source, &at);
    signing.read_limits(&report, &FIGURES)?;
    let probed = if points { input.points() } else { Vec::new() };
    let measured = if points {
        Measured::Points {
            angles_deg: &input.angles_deg,
            balls: &probed,
        }
    } else {
        Measured::Centres(&m)
    };
    report.uncertainty = Some(probe::rotary::uncertainty::propagate(
        measured,
        &solution,
        &report,
        signing.propagation(),
    ));
    let json = signing.judge(&report, report.uncertainty.as_ref(), &FIGURES)?;
    let html = probe::rotary::html(&report, &signing.signoff)?;

    let mut names = vec!["rotary.csv", "report.json", "report.html"];
    if !at.is_empty() {
        names.push("rotary_at.csv");
    }
    if points {
        names.push("spheres.csv");
    }
    let (output, files) = signing.outputs(&args.out, &names, [path])?;
    let rows: Vec<ErrorRow> = solution
        .errors
        .iter()
        .map(|e| error_row(e.angle_deg, &e.errors, &e.uncertainty))
        .collect();
    output.write_records(&files[0], &rows)?;
    output.write_json(&files[1], &json)?;
    output.write_bytes(&files[2], html.as_bytes())?;
    let mut next = 3;
    if !at.is_empty() {
        let rows: Vec<ErrorRow> = at
            .iter()
            .map(|i| error_row(i.angle_deg, &i.errors, &i.uncertainty))
            .collect();
        output.write_records(&files[next], &rows)?;
        next += 1;
    }
    if points {
        let rows: Vec<SphereFitRow> = m
            .balls
            .iter()
            .flat_map(|b| {
                m.angles_deg.iter().zip(&b.fits).map(|(a, f)| SphereFitRow {
                    ball: b.name.clone(),
                    angle_deg: *a,
                    x: f.centre.x,
                    y: f.centre.y,
                    z: f.centre.z,
                    radius: f.radius,
                    rms_residual: f.rms_residual,
                    max_residual: f.max_residual,
                    points: f.points,
                })
            })
            .collect();
        output.write_records(&files[next], &rows)?;
    }
    signing.print(&args.out)?;
    print_summary(&solution, &report);
    for i in &at {
        let parts: Vec<String> = (0..6)
            .map(|k| {
                let (scale, unit) = if k < 3 { (UM, "µm") } else { (URAD, "µrad") };
                format!("{} {:.3} {unit}", NAMES[k], i.errors[k] * scale)
            })
            .collect();
        println!("at {}°: {}", i.angle_deg, parts.join(", "));
    }
    println!("wrote {} files into {}", files.len(), args.out.display());
    signing.finish(&args.out)
}

/// Run the generator and write its files.
pub fn synth(args: &SynthArgs) -> Result<()> {
    let Some((out, mut config)) =
        super::synth_start::<RotaryConfig>(args.print_config, &args.out, &args.config)?
    else {
        return Ok(());
    };
    if let Some(s) = args.seed {
        config.seed = s;
    }
    if let Some(s) = args.step_deg {
        config.step_deg = s;
    }
    if let Some(n) = args.noise_um {
        config.noise_um = n;
        config.probe_noise_um = n;
    }
    let config = super::overridden(config)?;
    let data = synth::probe::rotary::generate(&config)?;
    let (output, files) = super::outputs(
        out,
        &["centres.csv", "points.csv", "truth.json", "config.toml"],
        &args.config,
        args.force,
    )?;
    output.write_records::<CentreRow>(&files[0], &data.centres)?;
    output.write_records::<CentreRow>(&files[1], &data.points)?;
    output.write_json(&files[2], &data.truth)?;
    output.write_bytes(&files[3], config.to_toml()?.as_bytes())?;
    let l = config.location;
    println!(
        "{} balls at {} angles ({}° steps): {} centres, {} probed points; noise {} µm (centres), {} µm (points)",
        config.balls.len(),
        data.truth.angles_deg.len(),
        config.step_deg,
        data.centres.len(),
        data.points.len(),
        config.noise_um,
        config.probe_noise_um
    );
    println!(
        "true location: X0C {} µm, Y0C {} µm, A0C {} µrad, B0C {} µrad",
        l.x0c_um, l.y0c_um, l.a0c_urad, l.b0c_urad
    );
    println!("wrote {} files into {}", files.len(), out.display());
    Ok(())
}
