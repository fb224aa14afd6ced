//! `seacover replay`: the dashboard over a recording, read-only.

use std::path::PathBuf;

use crate::shell;

#[derive(clap::Args)]
pub(crate) struct Args {
    /// An MCAP recording (of `serve`, `demo --record` or `sim --record`).
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// Address and port of the read-only dashboard and API.
    #[arg(long, value_name = "ADDR:PORT", default_value = "127.0.0.1:8080")]
    bind: String,
    /// Recording seconds per wall-clock second.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    speed: f64,
}

pub(crate) async fn run(Args { file, bind, speed }: Args) -> anyhow::Result<()> {
    let (listener, stop) = shell::listen(&bind).await?;
    println!(
        "seacover: replaying {} on http://{}",
        file.display(),
        listener.local_addr()?
    );
    seacover::server::replay::serve(listener, file, speed, stop).await?;
    Ok(())
}
