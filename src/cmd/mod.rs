//! One module per subcommand: argument struct and `run`.

pub mod backend;
pub mod bench;
pub mod calibrate;
pub mod demo;
pub mod evaluate;
pub mod extract;
pub mod fit;
pub mod manifest;
pub mod measure;
pub mod probe;
pub mod progress;
pub mod synth;

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
