//! `seacover fleet`: what a peer fleet needs before it sails (its
//! credentials).

use std::path::PathBuf;

use crate::shell;

#[derive(clap::Subcommand)]
pub(crate) enum Command {
    /// Make a fleet's credentials (Zenoh user/password authentication) in
    /// DIR: copy DIR to every member and start each with `--zenoh-config
    /// DIR/zenoh.json5`; a program without them neither hears the fleet
    /// nor is heard by it.
    Credentials {
        /// Where to write them (created; existing credentials are kept).
        #[arg(value_name = "DIR")]
        dir: PathBuf,
        #[command(flatten)]
        fleet: shell::Fleet,
    },
}

pub(crate) fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Credentials { dir, fleet } => {
            anyhow::ensure!(
                seacover::agent::peer::wire::valid_fleet(&fleet.name),
                "--fleet must match [A-Za-z0-9_.-]{{1,64}}"
            );
            let config = seacover::agent::peer::credentials::write(&dir, &fleet.name)?;
            println!("{}", config.display());
            Ok(())
        }
    }
}
