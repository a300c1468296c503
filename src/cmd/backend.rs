//! Choosing the extraction backend (`--backend auto|cpu|gpu`).

use anyhow::{Result, bail};
use clap::ValueEnum;
use extract::{Backend, CpuBackend};

/// Which compute backend extracts blobs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BackendChoice {
    /// The GPU where a suitable one exists, else the CPU (with the reason logged).
    Auto,
    /// The CPU (the reference).
    Cpu,
    /// The GPU; fails with the reason when there is none.
    Gpu,
}

/// The backend for a choice.
pub fn select_backend(choice: BackendChoice) -> Result<Box<dyn Backend>> {
    match choice {
        BackendChoice::Auto | BackendChoice::Cpu => Ok(Box::new(CpuBackend)),
        BackendChoice::Gpu => bail!("this build has no GPU backend"),
    }
}
