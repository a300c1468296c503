//! `trinocular probe volumetric` and `trinocular synth probe volumetric` (to be written).

use anyhow::{Result, bail};

/// Arguments of `trinocular probe volumetric`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Arguments of `trinocular synth probe volumetric`.
#[derive(Debug, clap::Args)]
pub struct SynthArgs {}

/// Run the method.
pub fn run(_args: &Args) -> Result<()> {
    bail!("probe volumetric is not written yet")
}

/// Run the generator.
pub fn synth(_args: &SynthArgs) -> Result<()> {
    bail!("synth probe volumetric is not written yet")
}
