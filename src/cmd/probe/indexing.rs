//! `trinocular probe indexing` and `trinocular synth probe indexing` (to be written).

use anyhow::{Result, bail};

/// Arguments of `trinocular probe indexing`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Arguments of `trinocular synth probe indexing`.
#[derive(Debug, clap::Args)]
pub struct SynthArgs {}

/// Run the method.
pub fn run(_args: &Args) -> Result<()> {
    bail!("probe indexing is not written yet")
}

/// Run the generator.
pub fn synth(_args: &SynthArgs) -> Result<()> {
    bail!("synth probe indexing is not written yet")
}
