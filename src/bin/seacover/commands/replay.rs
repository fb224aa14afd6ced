//! `seacover replay`: the dashboard over a recording, read-only.

use std::path::PathBuf;

use crate::shell;

#[derive(clap::Args)]
pub(crate) struct Args {
    /// An MCAP recording (of `serve`, `demo --record` or `sim --record`).
    #[arg(value_name = "FILE")]
    file: PathBuf,
    #[command(flatten)]
    bind: shell::Bind,
    /// Recording seconds per wall-clock second.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    speed: f64,
}

pub(crate) async fn run(Args { file, bind, speed }: Args) -> anyhow::Result<()> {
    let (listener, stop) = shell::listen(&bind.addr).await?;
    println!(
        "seacover: replaying {} on http://{}",
        file.display(),
        listener.local_addr()?
    );
    seacover::server::replay::serve(listener, file, speed, stop).await?;
    Ok(())
}
