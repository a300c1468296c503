//! One module per subcommand: argument struct and `run`.

pub mod evaluate;
pub mod fit;
