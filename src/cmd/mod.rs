//! The subcommands, one module each (argument struct and `run`), and the
//! parts they share, each in one module of its own. A command uses the
//! shared modules and never another command's helpers; `demo` runs the
//! commands themselves (their `Args` and `run`), `bench` and `synth`
//! only dispatch to the `bench` and `synth` entry points of the commands
//! they time or render for (`bench_measure` is `bench measure`'s own).

// The subcommands.
pub mod bench;
pub mod bench_measure;
pub mod calibrate;
pub mod demo;
pub mod evaluate;
pub mod extract;
pub mod fit;
pub mod manifest;
pub mod measure;
pub mod probe;
pub mod synth;

// What they share: the backend choice, the extraction options, the images
// given, outputs and problems files, progress bars, flat and dark stacks,
// the sign-off options, the option value parsers.
pub mod backend;
pub mod extraction;
pub mod images;
pub mod output;
pub mod progress;
pub mod sensor;
pub mod signoff;
pub mod values;

/// A batch that finished but left items unprocessed (listed in a problems
/// file): reported on stderr with exit status [`Finished::EXIT_STATUS`], so
/// that scripts can tell it from a run that failed outright.
#[derive(Debug)]
pub struct Finished {
    message: String,
}

impl Finished {
    /// Exit status of a batch that finished with problems.
    pub const EXIT_STATUS: u8 = 3;

    /// The error to return from `run`.
    pub fn with_problems(message: String) -> anyhow::Error {
        anyhow::Error::new(Finished { message })
    }
}

impl std::fmt::Display for Finished {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Finished {}

/// "none of the 3 images could be used; the first: REASON", or with one
/// item "the only image could not be used: REASON".
pub fn none_could(count: usize, noun: &str, verb: &str, first: Option<&str>) -> String {
    let reason = first.unwrap_or("no reason given");
    if count == 1 {
        format!("the only {noun} could not {verb}: {reason}")
    } else {
        format!("none of the {count} {noun}s could {verb}; the first: {reason}")
    }
}

/// A command-line usage error found after parsing — an option's value out of
/// its domain, options that do not fit together or do not fit the inputs
/// they describe (three images for a two-camera rig): reported like clap's
/// own usage errors, with exit status [`Usage::EXIT_STATUS`].
#[derive(Debug)]
pub struct Usage {
    message: String,
}

impl Usage {
    /// Exit status of a usage error (as clap uses).
    pub const EXIT_STATUS: u8 = 2;

    /// The error to return from `run`.
    pub fn error(message: impl std::fmt::Display) -> anyhow::Error {
        anyhow::Error::new(Usage {
            message: message.to_string(),
        })
    }

    /// Whether an error (or one of its causes) is a usage error.
    pub fn is(err: &anyhow::Error) -> bool {
        err.chain().any(|c| c.is::<Usage>())
    }
}

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Usage {}

/// Errors of a step that checks only what the command line says, as usage errors.
pub trait OrUsage<T> {
    /// The error, with its causes on one line, as a [`Usage`] error.
    fn or_usage(self) -> anyhow::Result<T>;
}

impl<T, E: Into<anyhow::Error>> OrUsage<T> for std::result::Result<T, E> {
    fn or_usage(self) -> anyhow::Result<T> {
        self.map_err(|e| Usage::error(format!("{:#}", e.into())))
    }
}
