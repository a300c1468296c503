//! One module per subcommand: argument struct and `run`.

pub mod backend;
pub mod bench;
pub mod evaluate;
pub mod extract;
pub mod fit;
pub mod progress;
pub mod synth;
