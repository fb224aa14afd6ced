//! `seacover demo`: the coordinator and eight simulated vessels on
//! loopback, the paper's scenario, in one process.

use std::path::PathBuf;

use crate::shell;

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    bind: shell::Bind,
    #[command(flatten)]
    time_warp: shell::Warp,
    // The demo's own vessels use the token too.
    #[command(flatten)]
    token: shell::Token,
    /// Record the run as MCAP files in this directory (named by their UTC
    /// start); nothing is recorded without it.
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
}

pub(crate) async fn run(args: Args) -> anyhow::Result<()> {
    shell::check_warp(args.time_warp.factor)?;
    let (listener, stop) = shell::listen(&args.bind.addr).await?;
    let addr = listener.local_addr()?;
    // Before the banner: a demo that cannot serve says so at once.
    seacover::server::check_bind(addr, args.token.value.as_deref())?;
    let recording = args.record.as_ref().map(|dir| dir.display().to_string());
    let run = tokio::spawn(seacover::demo::run(
        listener,
        args.time_warp.factor,
        args.token.value,
        args.record,
        stop,
    ));
    println!("seacover demo: coordinator with 8 vessels (usv-1 … usv-8), mission in memory");
    println!("  dashboard: http://{addr}/");
    println!("  coverage: http://{addr}/api/v1/coverage   vessels: http://{addr}/api/v1/vessels");
    if let Some(dir) = recording {
        println!("  recording: {dir}/ (MCAP; `seacover replay FILE` plays it back)");
    }
    println!("  stop with ctrl-c");
    run.await??;
    Ok(())
}
