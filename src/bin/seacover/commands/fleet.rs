//! `seacover fleet`: what a peer fleet needs before it sails (its
//! credentials).

use std::path::PathBuf;

use crate::shell;
use seacover::agent::peer::credentials;

#[derive(clap::Subcommand)]
pub(crate) enum Command {
    /// Make or change a fleet's credentials in DIR (docs/peer.md,
    /// "Credentials"): the fleet's certificate authority (DIR/ca.key stays
    /// ashore) and, for each member, DIR/members/ID to copy to it; start
    /// the member with `--zenoh-config DIR/members/ID/zenoh.json5`. Its
    /// links are then mutual TLS over QUIC datagrams: a program without a
    /// certificate from the fleet's authority neither hears the fleet nor
    /// is heard by it. Prints each member's configuration.
    Credentials {
        /// Where they are (created by --members).
        #[arg(value_name = "DIR")]
        dir: PathBuf,
        #[command(flatten)]
        fleet: shell::Fleet,
        /// A new fleet: its authority, and these members (vessel ids, and
        /// the shore's or an observer's names).
        #[arg(long, value_name = "ID,…", value_delimiter = ',', required_unless_present_any = ["add", "renew", "revoke"])]
        members: Vec<String>,
        /// Issue these new members a certificate from the fleet's
        /// authority.
        #[arg(long, value_name = "ID,…", value_delimiter = ',', conflicts_with_all = ["members", "renew", "revoke"])]
        add: Vec<String>,
        /// Issue every member a new certificate, before the old ones expire.
        #[arg(long, conflicts_with_all = ["members", "revoke"])]
        renew: bool,
        /// Shut member ID out: a new authority, and new certificates for
        /// every other member (copy their directories to them again).
        #[arg(long, value_name = "ID", conflicts_with = "members")]
        revoke: Option<String>,
        /// How long members' certificates are valid [days].
        #[arg(long, value_name = "DAYS", default_value_t = credentials::DEFAULT_DAYS, value_parser = clap::value_parser!(u32).range(1..=3650))]
        days: u32,
    },
}

pub(crate) fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Credentials {
            dir,
            fleet,
            members,
            add,
            renew,
            revoke,
            days,
        } => {
            anyhow::ensure!(
                seacover::agent::peer::wire::valid_fleet(&fleet.name),
                "--fleet must match [A-Za-z0-9_.-]{{1,64}}"
            );
            let configs = if let Some(id) = revoke {
                credentials::revoke(&dir, &id, days)?
            } else if renew {
                credentials::renew(&dir, days)?
            } else if !add.is_empty() {
                credentials::add(&dir, &add, days)?
            } else {
                credentials::create(&dir, &fleet.name, &members, days)?
            };
            for config in configs {
                println!("{}", config.display());
            }
            Ok(())
        }
    }
}
