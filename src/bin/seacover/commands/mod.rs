//! One module per subcommand: its arguments (clap derive) and its `run`.

pub mod agent;
pub mod bench;
pub mod demo;
pub mod evaluate;
pub mod fleet;
pub mod record;
pub mod replay;
pub mod serve;
pub mod sim;
