//! `trinocular probe tracer` and `trinocular synth probe tracer` (to be written).

use anyhow::{Result, bail};

/// Arguments of `trinocular probe tracer`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Arguments of `trinocular synth probe tracer`.
#[derive(Debug, clap::Args)]
pub struct SynthArgs {}

/// Run the method.
pub fn run(_args: &Args) -> Result<()> {
    bail!("probe tracer is not written yet")
}

/// Run the generator.
pub fn synth(_args: &SynthArgs) -> Result<()> {
    bail!("synth probe tracer is not written yet")
}
