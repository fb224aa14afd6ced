//! One module per subcommand: its arguments (clap derive) and its `run`.

pub(crate) mod agent;
pub(crate) mod bench;
pub(crate) mod demo;
pub(crate) mod evaluate;
pub(crate) mod fleet;
pub(crate) mod record;
pub(crate) mod replay;
pub(crate) mod risk;
pub(crate) mod serve;
pub(crate) mod sim;
