//! `trinocular probe rotary` and `trinocular synth probe rotary` (to be written).

use anyhow::{Result, bail};

/// Arguments of `trinocular probe rotary`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Arguments of `trinocular synth probe rotary`.
#[derive(Debug, clap::Args)]
pub struct SynthArgs {}

/// Run the method.
pub fn run(_args: &Args) -> Result<()> {
    bail!("probe rotary is not written yet")
}

/// Run the generator.
pub fn synth(_args: &SynthArgs) -> Result<()> {
    bail!("synth probe rotary is not written yet")
}
