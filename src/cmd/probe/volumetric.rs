//! `trinocular probe volumetric`: the 21-error volumetric model (docs/methods.md
//! §5) from error curves (`--errors E.csv`) or from a vision campaign
//! evaluated by `trinocular evaluate` (`--from-report DIR`); writes
//! `fits.csv`, `volumetric.csv` (with `--at`), `circle.csv` (with
//! `--circle`), `comp_<axis>.txt` (LinuxCNC), `report.json`, `report.html`.
//!
//! `trinocular synth probe volumetric`: error curves of a machine with known
//! error motions, `setup.json`, `at.csv`, `truth.json`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use formats::Axis;
use formats::probe::volumetric::report::FIGURES;
use formats::probe::volumetric::{
    self as files, AtRow, CircleRow, ErrorRow, FitRow, VolumetricRow,
};
use probe::volumetric::{
    Chain, CircleSpec, MeasuredAxis, Model, Order, ReadingsU, Setup, Squareness, UncertaintyInputs,
    analyse, campaign, html, measured_axes, uncertainty,
};

use crate::cmd::OrUsage;

/// Arguments of `trinocular probe volumetric`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("curves").required(true).multiple(true).args(["errors", "from_report"])))]
pub struct Args {
    /// Error curves `axis,position,ex,ey,ez,ea,eb,ec` (mm, rad; optional
    /// `positioning_up,positioning_down` for the compensation tables).
    #[arg(long, value_name = "E.csv")]
    errors: Option<PathBuf>,
    /// Take the curves of the swept axes from `trinocular evaluate`'s output
    /// folder (report.json); `--errors` may add the other axes (e.g. Z).
    #[arg(long, value_name = "DIR")]
    from_report: Option<PathBuf>,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Squareness EC0Y,EB0Z,EA0Z (rad). Default 0,0,0; with --from-report, EC0Y
    /// as the campaign measured it and 0 for the others.
    #[arg(long, value_name = "EC0Y,EB0Z,EA0Z", allow_hyphen_values = true, value_parser = three_numbers)]
    squareness: Option<[f64; 3]>,
    /// Kinematic chain `W a1 … ak F b1 … bl T`: the workpiece rides on a1, …,
    /// ak on the frame; the tool rides on bl, …, b1 on the frame. Default
    /// WXYFZT; with --from-report, WXYFZT keeping the axes that have curves
    /// (WXYFT for a campaign of X and Y).
    #[arg(long, value_name = "CHAIN")]
    chain: Option<String>,
    /// Tool offset t (mm) in the tool frame.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = three_numbers, default_value = "0,0,0")]
    tool: [f64; 3],
    /// Curves used for the predictions: raw (linear between measured
    /// positions), fourier or polynomial.
    #[arg(long, value_enum, default_value_t = ModelArg::Raw)]
    model: ModelArg,
    /// Order N of the series (Fourier order N, polynomial degree 2N), or
    /// `auto` (leave-one-out cross-validation per curve). Default 3, or for
    /// an axis with too few points the highest order they allow (said in a note).
    #[arg(long, value_parser = order)]
    order: Option<Order>,
    /// Carriage positions `x,y,z` (mm): writes volumetric.csv.
    #[arg(long, value_name = "A.csv")]
    at: Option<PathBuf>,
    /// Circular test in the workpiece frame, plane XY, 1° steps: centre and
    /// radius (mm). Writes circle.csv.
    #[arg(long, value_name = "CX,CY,CZ,R", allow_hyphen_values = true, value_parser = circle)]
    circle: Option<[f64; 4]>,
    /// Standard uncertainty of a translation value of the curves (µm; the instrument's, Type B):
    /// with --curve-u-urad, the figures get their U (k = 2) by Monte Carlo.
    #[arg(long, value_name = "UM", requires = "curve_u_urad", value_parser = crate::cmd::values::positive)]
    curve_u_um: Option<f64>,
    /// Standard uncertainty of a rotation value of the curves (µrad; the instrument's, Type B).
    #[arg(long, value_name = "URAD", requires = "curve_u_um", value_parser = crate::cmd::values::positive)]
    curve_u_urad: Option<f64>,
    /// Standard uncertainty of each squareness error (µrad, Type B); without it the squareness
    /// is taken as exact.
    #[arg(long, value_name = "URAD", value_parser = crate::cmd::values::positive)]
    squareness_u_urad: Option<f64>,
    #[command(flatten)]
    method: super::MethodArgs,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum ModelArg {
    Raw,
    Fourier,
    Polynomial,
}

/// `a,b,c` → three finite numbers.
fn numbers<const N: usize>(text: &str, what: &str) -> std::result::Result<[f64; N], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!(
            "expected {what}, got {} value(s) in '{text}'",
            parts.len()
        ));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("expected {what}: '{p}' is not a finite number"))?;
    }
    Ok(out)
}

fn three_numbers(text: &str) -> std::result::Result<[f64; 3], String> {
    numbers::<3>(text, "three numbers separated by commas")
}

fn circle(text: &str) -> std::result::Result<[f64; 4], String> {
    let c = numbers::<4>(text, "four numbers CX,CY,CZ,R")?;
    if c[3] <= 0.0 {
        return Err(format!("the radius {} must be positive", c[3]));
    }
    Ok(c)
}

fn order(text: &str) -> std::result::Result<Order, String> {
    if text.eq_ignore_ascii_case("auto") {
        return Ok(Order::Auto);
    }
    match text.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(Order::Fixed(n)),
        _ => Err(format!(
            "expected a whole number N ≥ 1 or 'auto', got '{text}'"
        )),
    }
}

/// Curves of `E.csv` per axis, with the first and last file line of each axis.
fn curves_from_file(path: &Path) -> Result<Vec<(MeasuredAxis, (u64, u64))>> {
    let rows = files::read_errors(path)?;
    let records: Vec<ErrorRow> = rows.iter().map(|r| r.record.clone()).collect();
    Ok(measured_axes(&records)
        .into_iter()
        .map(|m| {
            let lines: Vec<u64> = rows
                .iter()
                .filter(|r| r.record.axis() == m.axis)
                .map(|r| r.line)
                .collect();
            let first = lines.first().copied().unwrap_or(0);
            (m, (first, lines.last().copied().unwrap_or(first)))
        })
        .collect())
}

/// The measured curves and where they came from.
#[derive(Default)]
struct Curves {
    /// Per axis, in the order given.
    axes: Vec<MeasuredAxis>,
    /// The files the command reads (never overwritten by an output).
    inputs: Vec<PathBuf>,
    /// How the report names each source.
    sources: Vec<String>,
    /// A vision campaign's curves (`--from-report`), with its squareness.
    campaign: Option<campaign::CampaignCurves>,
}

/// Run the method: gather the curves, set up the model, analyse, write the
/// outputs (refusing before anything is written), print the summary.
pub fn run(args: &Args) -> Result<()> {
    let mut signing = super::Signing::start(&args.method)?;
    let given = args
        .chain
        .as_deref()
        .map(Chain::parse)
        .transpose()
        .or_usage()?;
    let report = match &args.from_report {
        Some(dir) => Some((dir, files::read_evaluate_report(dir)?)),
        None => None,
    };
    let errors = match &args.errors {
        Some(path) => Some((path, curves_from_file(path)?)),
        None => None,
    };
    let (chain, note) = match (given, &report) {
        (Some(chain), _) => (chain, None),
        (None, Some((dir, report))) => {
            let others: Vec<Axis> = errors
                .iter()
                .flat_map(|(_, e)| e.iter().map(|(m, _)| m.axis))
                .collect();
            campaign::default_chain(report, &others, &report_source(dir))?
        }
        (None, None) => (Chain::parse(probe::volumetric::DEFAULT_CHAIN)?, None),
    };
    if let Some(n) = &note {
        eprintln!("trinocular: note: {n}");
    }
    let mut curves = Curves::default();
    if let Some((dir, report)) = &report {
        curves_from_report(dir, report, &chain, note, &mut curves)?;
    }
    if let Some((path, errors)) = errors {
        curves_from_errors(path, errors, args.order, &mut curves)?;
    }
    curves.inputs.extend(args.at.clone());
    let readings = readings_u(args, &curves);
    let setup = setup(args, chain, &curves, readings.map(|(u, _)| u))?;
    let analysis = analyse(curves.axes.clone(), &setup, curves.campaign.as_ref())
        .with_context(|| format!("volumetric model from {}", setup.source))?;
    signing.read_limits(&analysis.report, &FIGURES)?;
    let inputs = UncertaintyInputs {
        translation_mm: readings.map(|(u, _)| u.translation_mm),
        rotation_rad: readings.map(|(u, _)| u.rotation_rad),
        squareness_rad: args.squareness_u_urad.map(|u| u * 1e-6),
        from_report: readings.is_some_and(|(_, from_report)| from_report),
    };
    let u = uncertainty(
        &curves.axes,
        &setup,
        curves.campaign.as_ref(),
        &analysis,
        &inputs,
        signing.propagation(),
    );
    if inputs.from_report
        && let Some(r) = curves.campaign.as_ref().and_then(|c| c.readings_u.as_ref())
    {
        eprintln!("trinocular: note: {}", r.note());
    }
    for n in &analysis.report.notes {
        eprintln!("trinocular: note: {n}");
    }
    let json = signing.judge(&analysis.report, Some(&u), &FIGURES)?;
    let page = html(&analysis, &u, &signing.signoff)?;
    let written = write_outputs(args, &analysis, &json, &page, &curves.inputs, &signing)?;
    signing.print(&args.out)?;
    print_summary(&analysis, &setup);
    super::print_uncertainty(&u);
    for w in &analysis.report.warnings {
        eprintln!("trinocular: warning: {w}");
    }
    println!("wrote {written} files into {}", args.out.display());
    signing.finish(&args.out)
}

/// The readings' standard uncertainty and whether it came from the
/// campaign report: `--curve-u-um`/`--curve-u-urad` when given, else the
/// evaluate report's (`--from-report` without `--errors`, whose curves it
/// does not cover), else none.
fn readings_u(args: &Args, curves: &Curves) -> Option<(ReadingsU, bool)> {
    if let (Some(um), Some(urad)) = (args.curve_u_um, args.curve_u_urad) {
        return Some((
            ReadingsU {
                translation_mm: um * 1e-3,
                rotation_rad: urad * 1e-6,
            },
            false,
        ));
    }
    if args.errors.is_some() {
        return None;
    }
    let r = curves.campaign.as_ref()?.readings_u.as_ref()?;
    Some((r.u, true))
}

/// How errors name the report of `--from-report DIR`.
fn report_source(dir: &Path) -> String {
    dir.join("report.json").display().to_string()
}

/// The swept axes' curves of a vision campaign (`--from-report DIR`), with
/// the note on how the chain was chosen first among its notes.
fn curves_from_report(
    dir: &Path,
    report: &files::EvaluateReport,
    chain: &Chain,
    chain_note: Option<String>,
    curves: &mut Curves,
) -> Result<()> {
    let mut c = campaign::from_evaluate(report, chain, &report_source(dir))?;
    c.notes.splice(0..0, chain_note);
    curves.inputs.push(dir.join("report.json"));
    curves.axes.extend(c.axes.iter().cloned());
    curves
        .sources
        .push(format!("{} (vision campaign)", dir.display()));
    curves.campaign = Some(c);
    Ok(())
}

/// The curves of `E.csv`: each axis once over both sources, and with at
/// least as many points as the series of an explicit `--order N` has
/// coefficients (without `--order`, or with `auto`, a short axis takes the
/// highest order its points allow).
fn curves_from_errors(
    path: &Path,
    errors: Vec<(MeasuredAxis, (u64, u64))>,
    order: Option<Order>,
    curves: &mut Curves,
) -> Result<()> {
    let order_n = match order {
        Some(Order::Fixed(n)) => Some(n),
        _ => None,
    };
    for (m, (first, last)) in errors {
        if curves.axes.iter().any(|c| c.axis == m.axis) {
            bail!(
                "{}: lines {first}–{last}, column 'axis': axis {} comes from --from-report too; give each axis once",
                path.display(),
                m.axis
            );
        }
        if let Some(n) = order_n
            && m.positions.len() < 2 * n + 1
        {
            bail!(
                "{}: lines {first}–{last}, axis {}: {} points, fewer than the {} coefficients of a \
                 series of order {n} (--order {n}; without --order the highest order the points \
                 allow is taken)",
                path.display(),
                m.axis,
                m.positions.len(),
                2 * n + 1
            );
        }
        curves.axes.push(m);
    }
    curves.inputs.push(path.to_path_buf());
    curves.sources.push(path.display().to_string());
    Ok(())
}

/// The model's set-up from the options: squareness (given, else the
/// campaign's, else 0), tool, model, order, the positions of `--at` (read
/// here, named by file line) and the circle.
fn setup(
    args: &Args,
    chain: Chain,
    curves: &Curves,
    readings_u: Option<ReadingsU>,
) -> Result<Setup> {
    let measured_square = curves.campaign.as_ref().map(|c| c.squareness);
    let squareness = match (args.squareness, measured_square) {
        (Some(s), _) => Squareness {
            ec0y: s[0],
            eb0z: s[1],
            ea0z: s[2],
        },
        (None, Some(m)) => Squareness {
            ec0y: m.ec0y.unwrap_or(0.0),
            eb0z: m.eb0z.unwrap_or(0.0),
            ea0z: m.ea0z.unwrap_or(0.0),
        },
        (None, None) => Squareness::default(),
    };
    let at_rows = match &args.at {
        Some(p) => files::read_at(p)?,
        None => Vec::new(),
    };
    let at_label = |line: u64| {
        format!(
            "{}: line {line}",
            args.at
                .as_deref()
                .map(Path::display)
                .map(|d| d.to_string())
                .unwrap_or_default()
        )
    };
    Ok(Setup {
        chain,
        squareness,
        tool: args.tool,
        model: match args.model {
            ModelArg::Raw => Model::Raw,
            ModelArg::Fourier => Model::Fourier,
            ModelArg::Polynomial => Model::Polynomial,
        },
        order: args
            .order
            .unwrap_or(Order::Highest(probe::volumetric::DEFAULT_ORDER)),
        at: at_rows
            .iter()
            .map(|r| (at_label(r.line), [r.record.x, r.record.y, r.record.z]))
            .collect(),
        circle: args.circle.map(|c| CircleSpec {
            centre: [c[0], c[1], c[2]],
            radius: c[3],
        }),
        source: curves.sources.join(" + "),
        readings_u,
    })
}

/// Write every output into `--out` (refused as a whole before anything is
/// written when one exists without `--force` or is an input); the number of
/// files written.
fn write_outputs(
    args: &Args,
    analysis: &probe::volumetric::Analysis,
    json: &serde_json::Value,
    page: &str,
    inputs: &[PathBuf],
    signing: &super::Signing<'_>,
) -> Result<usize> {
    let out = &args.out;
    let mut names: Vec<String> = vec![
        "report.json".into(),
        "report.html".into(),
        "fits.csv".into(),
    ];
    if args.at.is_some() {
        names.push("volumetric.csv".into());
    }
    if args.circle.is_some() {
        names.push("circle.csv".into());
    }
    for (axis, _) in &analysis.compensation {
        names.push(comp_name(*axis));
    }
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let (output, files) = signing.outputs(out, &names, inputs)?;

    let fits: Vec<FitRow> = analysis
        .report
        .fits
        .iter()
        .map(|f| FitRow {
            axis: f.axis,
            error: f.error.name().into(),
            model: f.model.name().into(),
            r2: f.r2,
            sse: f.sse,
            rmse: f.rmse,
            emax: f.emax,
            order: f.order,
            coefficients: 2 * f.order + 1,
        })
        .collect();
    output.write_records(&out.join("fits.csv"), &fits)?;
    if args.at.is_some() {
        let rows: Vec<VolumetricRow> = analysis
            .volumetric
            .iter()
            .map(|(q, d)| VolumetricRow {
                x: q[0],
                y: q[1],
                z: q[2],
                dx: d.x,
                dy: d.y,
                dz: d.z,
            })
            .collect();
        output.write_records(&out.join("volumetric.csv"), &rows)?;
    }
    if let Some(c) = &analysis.circles {
        let rows: Vec<CircleRow> = c
            .predicted
            .points
            .iter()
            .zip(&c.compensated_fourier.points)
            .zip(&c.compensated_polynomial.points)
            .map(|((p, f), q)| CircleRow {
                angle_deg: p.angle_deg,
                dx: p.delta[0],
                dy: p.delta[1],
                dz: p.delta[2],
                radial: p.radial,
                radial_compensated_fourier: f.radial,
                radial_compensated_polynomial: q.radial,
            })
            .collect();
        output.write_records(&out.join("circle.csv"), &rows)?;
    }
    for (axis, table) in &analysis.compensation {
        files::write_comp_file(&output, &out.join(comp_name(*axis)), table)?;
    }
    output.write_json(&out.join("report.json"), json)?;
    output.write_bytes(&out.join("report.html"), page.as_bytes())?;
    Ok(files.len())
}

/// The compensation file of an axis.
fn comp_name(axis: Axis) -> String {
    format!("comp_{}.txt", axis.name())
}

fn print_summary(a: &probe::volumetric::Analysis, setup: &Setup) {
    let r = &a.report;
    for ax in &r.axes {
        let better = ax
            .curves
            .iter()
            .filter(|c| c.fourier.rmse <= c.polynomial.rmse)
            .count();
        println!(
            "{}: {} positions {}–{} mm; Fourier beats the polynomial (RMSE) on {better} of 6 curves",
            ax.axis, ax.points, ax.travel_mm[0], ax.travel_mm[1]
        );
    }
    println!(
        "chain {}, tool ({}, {}, {}) mm, squareness EC0Y {:.2} µrad, EB0Z {:.2} µrad, EA0Z {:.2} µrad",
        r.chain,
        r.tool_mm[0],
        r.tool_mm[1],
        r.tool_mm[2],
        r.squareness_urad.ec0y,
        r.squareness_urad.eb0z,
        r.squareness_urad.ea0z
    );
    if let Some(v) = &r.volumetric {
        println!(
            "volumetric error at {} positions ({} curves): max {:.3} µm, RMS {:.3} µm",
            v.points,
            setup.model.name(),
            v.max_um,
            v.rms_um
        );
    }
    if let Some(c) = &r.circle {
        println!(
            "circle R {} mm at ({}, {}, {}): circular deviation {:.3} µm, radial range {:.3} µm ({} curves)",
            c.radius_mm,
            c.centre_mm[0],
            c.centre_mm[1],
            c.centre_mm[2],
            c.circular_deviation_um,
            c.radial_range_um,
            setup.model.name()
        );
        println!(
            "after compensation: Fourier {:.3} µm, polynomial {:.3} µm (circular deviation)",
            c.compensated.fourier.circular_deviation_um,
            c.compensated.polynomial.circular_deviation_um
        );
    }
    if r.order == "auto" {
        for ax in &r.axes {
            let orders = |f: fn(&probe::volumetric::report::CurveReport) -> usize| {
                ax.curves
                    .iter()
                    .map(|c| format!("{}={}", c.error.name(), f(c)))
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            println!(
                "{}: orders by leave-one-out: Fourier {}; polynomial {}",
                ax.axis,
                orders(|c| c.fourier.order),
                orders(|c| c.polynomial.order)
            );
        }
    }
    println!(
        "compensation tables comp_<axis>.txt for LinuxCNC: COMP_FILE_TYPE = {} (nominal, actual forward, actual reverse; mm)",
        files::COMP_FILE_TYPE
    );
    if let Some(c) = &r.campaign {
        for (k, v) in &c.measured_squareness_urad {
            println!("campaign: measured {k} {v:.2} µrad");
        }
        for n in &c.notes {
            println!("campaign: {n}");
        }
    }
}

/// Arguments of `trinocular synth probe volumetric`.
#[derive(Debug, clap::Args)]
pub struct SynthArgs {
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Random seed of the error motions and the noise.
    #[arg(long)]
    seed: Option<u64>,
    /// Kinematic chain.
    #[arg(long)]
    chain: Option<String>,
    /// Overwrite output files that exist.
    #[arg(long)]
    force: bool,
}

/// Run the generator.
pub fn synth(args: &SynthArgs) -> Result<()> {
    let mut config = synth::probe::volumetric::VolumetricConfig::default();
    if let Some(s) = args.seed {
        config.seed = s;
    }
    if let Some(c) = &args.chain {
        Chain::parse(c).or_usage()?;
        config.chain = c.clone();
    }
    let data = synth::probe::volumetric::generate(&config)?;
    let out = &args.out;
    let (output, [errors, at_path, setup, truth]) = super::outputs_n(
        out,
        ["errors.csv", "at.csv", "setup.json", "truth.json"],
        [] as [&Path; 0],
        args.force,
    )?;
    output.write_records(&errors, &data.errors)?;
    let at: Vec<AtRow> = data.at.clone();
    output.write_records(&at_path, &at)?;
    output.write_json(&setup, &data.setup)?;
    output.write_json(&truth, &data.truth)?;
    let s = &data.setup;
    println!(
        "error curves of X, Y, Z ({} rows), {} positions in at.csv, chain {}, tool ({}, {}, {}) mm",
        data.errors.len(),
        data.at.len(),
        s.chain,
        s.tool_mm[0],
        s.tool_mm[1],
        s.tool_mm[2]
    );
    println!(
        "next: trinocular probe volumetric --errors {e} --chain {} --squareness {},{},{} --tool {},{},{} \
         --at {a} --circle {},{},{},{} --curve-u-um {} --curve-u-urad {} --out <DIR>",
        s.chain,
        s.squareness_rad.ec0y,
        s.squareness_rad.eb0z,
        s.squareness_rad.ea0z,
        s.tool_mm[0],
        s.tool_mm[1],
        s.tool_mm[2],
        s.circle.centre_mm[0],
        s.circle.centre_mm[1],
        s.circle.centre_mm[2],
        s.circle.radius_mm,
        config.noise_um,
        config.noise_urad,
        e = out.join("errors.csv").display(),
        a = out.join("at.csv").display(),
    );
    println!("wrote 4 files into {}", out.display());
    Ok(())
}
