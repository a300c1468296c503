//! `trinocular probe <method>`: the probe-based methods (the `probe` crate),
//! and `trinocular synth probe <method>`: their check-data generators (the
//! `synth` crate). One module per method: the arguments and `run` of the
//! method, the arguments and `synth` of its generator.

pub mod indexing;
pub mod rotary;
pub mod tracer;
pub mod volumetric;

use std::path::{Path, PathBuf};

use anyhow::Result;
use formats::OutputPlan;

/// Arguments of `trinocular probe`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    method: Method,
}

#[derive(Debug, clap::Subcommand)]
enum Method {
    /// Rotary-table errors (ISO 230-7 EXC…ECC, location errors) from a standard ball at three positions.
    Rotary(rotary::Args),
    /// Probe-head indexing errors ΔθA, ΔθB from the reference-sphere centre per (A, B) position.
    Indexing(indexing::Args),
    /// CMM volumetric corrections by laser-tracer multilateration.
    Tracer(tracer::Args),
    /// 21-error volumetric model: error-curve fits, volumetric errors, circular-test prediction.
    Volumetric(volumetric::Args),
}

/// Run the method.
pub fn run(args: &Args) -> Result<()> {
    match &args.method {
        Method::Rotary(a) => rotary::run(a),
        Method::Indexing(a) => indexing::run(a),
        Method::Tracer(a) => tracer::run(a),
        Method::Volumetric(a) => volumetric::run(a),
    }
}

/// The Monte Carlo options of a probe method (docs/methods.md §7),
/// flattened into each method's arguments.
#[derive(Debug, Clone, Copy, clap::Args)]
struct PropagationArgs {
    /// Monte Carlo trials of the expanded uncertainties U (k = 2) of every figure; 0 turns the
    /// propagation off (the report says so).
    #[arg(long, value_name = "N", default_value_t = probe::uncertainty::DEFAULT_TRIALS)]
    trials: usize,
    /// Seed of the Monte Carlo draws (the same seed, the same U).
    #[arg(long, value_name = "S", default_value_t = 1)]
    seed: u64,
}

impl PropagationArgs {
    /// As the library's settings.
    fn options(self) -> probe::uncertainty::Propagation {
        probe::uncertainty::Propagation {
            trials: self.trials,
            seed: self.seed,
        }
    }
}

/// The uncertainty of a report's figures on stdout: how U was found and the
/// headline figures as value ± U, or why there is none.
fn print_uncertainty(u: &formats::uncertainty::Uncertainty) {
    for line in probe::uncertainty::summary(u) {
        println!("{line}");
    }
}

/// The checked output plan of a method or generator writing `names` into
/// `dir` (created if missing), and their paths: no output over an input, an
/// existing one only with `force`.
fn outputs<P: AsRef<Path>>(
    dir: &Path,
    names: &[&str],
    inputs: impl IntoIterator<Item = P>,
    force: bool,
) -> Result<(OutputPlan, Vec<PathBuf>)> {
    let paths: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
    let mut plan = OutputPlan::new(force);
    plan.inputs(inputs).folder(dir);
    for p in &paths {
        plan.file(p);
    }
    plan.check()?;
    Ok((plan, paths))
}

/// [`outputs`] of a fixed set of names.
fn outputs_n<const N: usize, P: AsRef<Path>>(
    dir: &Path,
    names: [&str; N],
    inputs: impl IntoIterator<Item = P>,
    force: bool,
) -> Result<(OutputPlan, [PathBuf; N])> {
    let (plan, paths) = outputs(dir, &names, inputs, force)?;
    let paths = <[PathBuf; N]>::try_from(paths)
        .map_err(|p| anyhow::anyhow!("{} output paths for {N} names", p.len()))?;
    Ok((plan, paths))
}

/// Arguments of `trinocular synth probe`.
#[derive(Debug, clap::Args)]
pub struct SynthArgs {
    #[command(subcommand)]
    method: SynthMethod,
}

#[derive(Debug, clap::Subcommand)]
enum SynthMethod {
    /// Ball centres (or probed points) of a rotary table with known errors, and truth.json.
    Rotary(rotary::SynthArgs),
    /// Reference-sphere centres of a probe head with known indexing errors, and truth.json.
    Indexing(indexing::SynthArgs),
    /// Grid and tracer readings of a CMM with a known error field, and truth.json.
    Tracer(tracer::SynthArgs),
    /// Error curves of a machine with known error motions, and truth.json.
    Volumetric(volumetric::SynthArgs),
}

/// Run the generator.
pub fn synth(args: &SynthArgs) -> Result<()> {
    match &args.method {
        SynthMethod::Rotary(a) => rotary::synth(a),
        SynthMethod::Indexing(a) => indexing::synth(a),
        SynthMethod::Tracer(a) => tracer::synth(a),
        SynthMethod::Volumetric(a) => volumetric::synth(a),
    }
}

/// The start of a `synth probe …` run: `None` when `--print-config` printed
/// the default configuration `default_toml`; else the output folder and the
/// configuration, `--config`'s (read by `read`) or the default.
fn synth_start<'a, C: Default>(
    print_config: bool,
    default_toml: &str,
    out: &'a Option<PathBuf>,
    config: &Option<PathBuf>,
    read: impl FnOnce(&Path) -> Result<C>,
) -> Result<Option<(&'a Path, C)>> {
    if print_config {
        print!("{default_toml}");
        return Ok(None);
    }
    let Some(out) = out else {
        return Err(crate::cmd::Usage::error("--out DIR is required"));
    };
    let config = match config {
        Some(path) => read(path)?,
        None => C::default(),
    };
    Ok(Some((out, config)))
}
