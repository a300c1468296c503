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
use formats::conformance::{Limit, SignOff, read_tolerances_by_path};
use formats::uncertainty::{FigureKeys, Uncertainty};
use serde::Serialize;
use serde_json::Value;

use super::{OrUsage, signoff};

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

/// The options every probe method shares, flattened into each method's
/// arguments: the Monte Carlo propagation, the sign-off and `--force`.
#[derive(Debug, clap::Args)]
struct MethodArgs {
    #[command(flatten)]
    propagation: PropagationArgs,
    #[command(flatten)]
    signoff: signoff::SignoffArgs,
    /// Replace output files that already exist.
    #[arg(long)]
    force: bool,
}

/// The Monte Carlo options of a probe method (docs/methods.md §7).
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

/// A probe report's sign-off through its run (`--conditions`,
/// `--tolerances`, `--pdf`; docs/formats.md): the tolerance file's keys are
/// the report's figures by their paths (`[location] X0C_um`).
struct Signing<'a> {
    method: &'a MethodArgs,
    args: &'a signoff::SignoffArgs,
    browser: Option<PathBuf>,
    limits: Option<Vec<Limit>>,
    signoff: SignOff,
}

impl<'a> Signing<'a> {
    /// Find the browser and read the conditions, before anything is
    /// computed.
    fn start(method: &'a MethodArgs) -> Result<Self> {
        let args = &method.signoff;
        Ok(Signing {
            method,
            args,
            browser: args.browser()?,
            limits: None,
            signoff: SignOff {
                conditions: args.read_conditions()?,
                ..SignOff::default()
            },
        })
    }

    /// The Monte Carlo settings of `--trials` and `--seed`.
    fn propagation(&self) -> probe::uncertainty::Propagation {
        self.method.propagation.options()
    }

    /// The checked output plan of the method writing `names` into `dir`,
    /// and their paths, with what the sign-off adds ([`outputs`]: the
    /// sign-off's files are inputs too, `--force` replaces).
    fn outputs<P: AsRef<Path>>(
        &self,
        dir: &Path,
        names: &[&str],
        inputs: impl IntoIterator<Item = P>,
    ) -> Result<(OutputPlan, Vec<PathBuf>)> {
        let mut names = names.to_vec();
        names.extend(self.browser.iter().map(|_| "report.pdf"));
        let inputs: Vec<PathBuf> = inputs
            .into_iter()
            .map(|p| p.as_ref().to_path_buf())
            .chain(self.args.inputs().cloned())
            .collect();
        outputs(dir, &names, inputs, self.method.force)
    }

    /// Read the tolerance file against `report`'s figures (`keys`, by
    /// path), before their uncertainty is propagated.
    fn read_limits<R: Serialize>(&mut self, report: &R, keys: &FigureKeys) -> Result<()> {
        if let Some(path) = &self.args.tolerances {
            let figures = probe::uncertainty::report_figures(report, keys);
            self.limits = Some(read_tolerances_by_path(path, &figures)?);
        }
        Ok(())
    }

    /// Judge the limits on `report`'s figures (`keys`) with their U, and
    /// return `report.json`: the report with each figure's U beside it
    /// (`probe::uncertainty::report_json`) and the sign-off's keys
    /// (`conditions`, `conformance`, `verdict`, `decision_rule`) added at
    /// the top level.
    fn judge<R: Serialize>(
        &mut self,
        report: &R,
        uncertainty: Option<&Uncertainty>,
        keys: &FigureKeys,
    ) -> Result<Value> {
        let figures = probe::uncertainty::report_figures(report, keys);
        let expanded = uncertainty.and_then(Uncertainty::expanded);
        self.args.judge(
            &mut self.signoff,
            self.limits.as_deref(),
            &figures,
            expanded,
        )?;
        let mut json = probe::uncertainty::report_json(report, uncertainty, keys)?;
        if let (Value::Object(report), Value::Object(signed)) =
            (&mut json, serde_json::to_value(&self.signoff)?)
        {
            report.extend(signed);
        }
        Ok(json)
    }

    /// With `--pdf`, print the `report.html` written into `out` beside it.
    fn print(&self, out: &Path) -> Result<()> {
        match &self.browser {
            Some(browser) => {
                signoff::print_pdf(browser, &out.join("report.html"), &out.join("report.pdf"))
            }
            None => Ok(()),
        }
    }

    /// The last word of a run: the verdict line and the exit status
    /// ([`signoff::SignoffArgs::finish`]).
    fn finish(&self, out: &Path) -> Result<()> {
        self.args.finish(&self.signoff, out)
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

/// The configuration file of a `synth probe …` generator.
trait GeneratorConfig: Default {
    /// The documented default configuration (`--print-config`).
    const DEFAULT_TOML: &'static str;
    /// Read and check a configuration file.
    fn read(path: &Path) -> Result<Self>;
    /// Check the configuration after the command line's overrides.
    fn check(&self) -> Result<()>;
}

impl GeneratorConfig for synth::probe::rotary::RotaryConfig {
    const DEFAULT_TOML: &'static str = synth::probe::rotary::DEFAULT_TOML;
    fn read(path: &Path) -> Result<Self> {
        Ok(Self::from_file(path)?)
    }
    fn check(&self) -> Result<()> {
        Ok(self.validate()?)
    }
}

impl GeneratorConfig for synth::probe::indexing::IndexingConfig {
    const DEFAULT_TOML: &'static str = synth::probe::indexing::DEFAULT_TOML;
    fn read(path: &Path) -> Result<Self> {
        Ok(Self::from_file(path)?)
    }
    fn check(&self) -> Result<()> {
        Ok(self.validate()?)
    }
}

/// The start of a `synth probe …` run: `None` when `--print-config` printed
/// the default configuration; else the output folder and the configuration,
/// `--config`'s or the default.
fn synth_start<'a, C: GeneratorConfig>(
    print_config: bool,
    out: &'a Option<PathBuf>,
    config: &Option<PathBuf>,
) -> Result<Option<(&'a Path, C)>> {
    if print_config {
        print!("{}", C::DEFAULT_TOML);
        return Ok(None);
    }
    let Some(out) = out else {
        return Err(crate::cmd::Usage::error("--out DIR is required"));
    };
    let config = match config {
        Some(path) => C::read(path)?,
        None => C::default(),
    };
    Ok(Some((out, config)))
}

/// The configuration once the command line's options are applied: the
/// file's is valid (its reader checks it), so what the options break is a
/// usage error.
fn overridden<C: GeneratorConfig>(config: C) -> Result<C> {
    config.check().or_usage()?;
    Ok(config)
}
