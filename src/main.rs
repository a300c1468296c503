//! `trinocular`: the command-line front end. Thin by design: it parses flags,
//! reads and writes files, shows progress and maps errors to exit codes; the
//! work is done by the library crates.

mod cmd;
mod interrupt;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Trinocular vision measurement of machine-tool and CMM geometric errors.
#[derive(Debug, Parser)]
#[command(name = "trinocular", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Throughput figures for this machine.
    Bench(cmd::bench::Args),
    /// Calibrate each camera from a 3-D target: DLT, Levenberg–Marquardt with distortion, commissioning report.
    Calibrate(cmd::calibrate::Args),
    /// The whole job on built-in data: render, calibrate, measure, evaluate; measured vs true figures.
    Demo(cmd::demo::Args),
    /// ISO 230-2 positioning, straightness, flatness and angular errors from points.csv.
    Evaluate(cmd::evaluate::Args),
    /// Sub-pixel blob centres of images into blobs.csv (thresholded gray centroid).
    Extract(cmd::extract::Args),
    /// Fit a geometric element (least squares and minimum zone) to a point file.
    Fit(cmd::fit::Args),
    /// manifest.csv from captured camera folders and the motion program (<stem>.problems.csv beside it).
    Manifest(cmd::manifest::Args),
    /// Sphere centres of every instant of a campaign into points.csv (<stem>.problems.csv, <stem>.poses.csv beside it).
    Measure(cmd::measure::Args),
    /// Probe-based methods: rotary table, probe-head indexing, laser-tracer multilateration, volumetric model.
    Probe(cmd::probe::Args),
    /// Synthetic images of the rig with ground truth: campaign, calibration target, default config.
    Synth(cmd::synth::Args),
}

/// Exit status for command-line usage errors (as clap uses).
const USAGE_ERROR: u8 = cmd::Usage::EXIT_STATUS;

/// Every flag and argument that takes a value accepts a negative number as
/// that value (`--width -512` is then reported as an invalid width, not as an
/// unknown flag `-5`), in every subcommand.
fn negative_numbers(command: clap::Command) -> clap::Command {
    command
        .mut_args(|arg| {
            if arg.get_action().takes_values() {
                arg.allow_negative_numbers(true)
            } else {
                arg
            }
        })
        .mut_subcommands(negative_numbers)
}

fn parse() -> Result<Cli, clap::Error> {
    use clap::{CommandFactory, FromArgMatches};
    let mut command = negative_numbers(Cli::command());
    let matches = command.try_get_matches_from_mut(std::env::args_os())?;
    Cli::from_arg_matches(&matches).map_err(|e| e.format(&mut command))
}

/// The subcommand the command line names, as its help is asked for
/// (`trinocular probe volumetric`): the leading arguments that name
/// subcommands, each of the one before; `trinocular` when none does.
fn subcommand_named() -> String {
    use clap::CommandFactory;
    let mut command = Cli::command();
    let mut path = vec!["trinocular".to_string()];
    for arg in std::env::args_os().skip(1) {
        let Some(sub) = command.find_subcommand(&arg).cloned() else {
            break;
        };
        path.push(sub.get_name().to_string());
        command = sub;
    }
    path.join(" ")
}

/// A usage error on stderr, one line, pointing to the subcommand's help.
fn usage_error(reason: &str) -> ExitCode {
    eprintln!(
        "trinocular: error: {reason} (see '{} --help')",
        subcommand_named()
    );
    ExitCode::from(USAGE_ERROR)
}

fn main() -> ExitCode {
    let cli = match parse() {
        Ok(cli) => cli,
        Err(err) if !err.use_stderr() => {
            // --help and --version: print as clap formats them.
            let _ = err.print();
            return ExitCode::SUCCESS;
        }
        Err(err) => {
            // One line: clap's first paragraph, without its "error: " prefix,
            // and its tips ("a similar subcommand exists: 'evaluate'").
            let text = err.to_string();
            let reason: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .chain(text.lines().filter(|l| l.trim_start().starts_with("tip:")))
                .map(str::trim)
                .collect();
            return usage_error(reason.join("; ").trim_start_matches("error: "));
        }
    };
    interrupt::install(match cli.command {
        Command::Measure(_) => Some(cmd::measure::RERUN),
        _ => None,
    });
    let result = match cli.command {
        Command::Bench(args) => cmd::bench::run(&args),
        Command::Calibrate(args) => cmd::calibrate::run(&args),
        Command::Demo(args) => cmd::demo::run(&args),
        Command::Evaluate(args) => cmd::evaluate::run(&args),
        Command::Extract(args) => cmd::extract::run(&args),
        Command::Fit(args) => cmd::fit::run(&args),
        Command::Manifest(args) => cmd::manifest::run(&args),
        Command::Measure(args) => cmd::measure::run(&args),
        Command::Probe(args) => cmd::probe::run(&args),
        Command::Synth(args) => cmd::synth::run(&args),
    };
    cmd::bench_measure::record_peak();
    let written = |e: &anyhow::Error| {
        e.downcast_ref::<cmd::Finished>().is_some()
            || e.downcast_ref::<cmd::signoff::DoesNotConform>().is_some()
    };
    if result.as_ref().is_err_and(|e| !written(e)) {
        discard_created();
    }
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) if err.downcast_ref::<cmd::signoff::DoesNotConform>().is_some() => {
            eprintln!("trinocular: {err}");
            ExitCode::from(cmd::signoff::NONCONFORMANCE_EXIT_STATUS)
        }
        Err(err) if err.downcast_ref::<cmd::Finished>().is_some() => {
            eprintln!("trinocular: finished with problems: {err}");
            ExitCode::from(cmd::Finished::EXIT_STATUS)
        }
        Err(err) if cmd::Usage::is(&err) => usage_error(&one_line(&err)),
        Err(err) => {
            eprintln!("trinocular: error: {}", one_line(&err));
            ExitCode::FAILURE
        }
    }
}

/// A failed run leaves the output location as it was: remove what it
/// created (`formats::created`); say what could not be removed.
fn discard_created() {
    for (path, e) in formats::created::discard() {
        eprintln!(
            "trinocular: warning: {}: written by this failed run, but not removed: {e}",
            path.display()
        );
    }
}

/// The error and its causes on one line, outermost first, skipping a cause
/// whose text the line already holds (many errors repeat their source).
fn one_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string().replace('\n', " ");
        if !line.contains(&text) {
            if !line.is_empty() {
                line.push_str(": ");
            }
            line.push_str(&text);
        }
    }
    line
}

#[cfg(test)]
#[path = "../tests/common/readme_blocks.rs"]
mod readme_blocks;

#[cfg(test)]
mod tests {
    use super::readme_blocks;
    use clap::{CommandFactory, FromArgMatches};

    /// Every `trinocular` command line the README and its guides in `docs/`
    /// show (`readme_blocks::PAGES`) parses as written, those their test
    /// cannot run included (full-size renders, the reader's own files, a
    /// GPU).
    #[test]
    fn every_readme_command_parses() {
        let mut failures = Vec::new();
        let mut count = 0;
        for page in readme_blocks::PAGES {
            for block in readme_blocks::sh_blocks(&readme_blocks::read_page(page)) {
                for args in readme_blocks::trinocular_commands(&block.text) {
                    count += 1;
                    let mut command = super::negative_numbers(super::Cli::command());
                    let parsed = command
                        .try_get_matches_from_mut(
                            std::iter::once("trinocular".to_string()).chain(args.clone()),
                        )
                        .and_then(|m| super::Cli::from_arg_matches(&m));
                    if let Err(e) = parsed {
                        failures.push(format!(
                            "{page} line {}: trinocular {}: {e}",
                            block.line,
                            args.join(" ")
                        ));
                    }
                }
            }
        }
        assert!(count >= 20, "only {count} commands found in the pages");
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }
}
