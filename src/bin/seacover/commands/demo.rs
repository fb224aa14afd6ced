//! `seacover demo`: the coordinator and eight simulated vessels on
//! loopback, the paper's scenario, in one process.

use std::path::PathBuf;

use crate::shell;

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Address and port of the coordinator (its dashboard and API); any
    /// address but loopback needs a token.
    #[arg(long, value_name = "ADDR:PORT", default_value = "127.0.0.1:8080")]
    bind: String,
    /// Run the mission clock this many times faster than real time
    /// (MOOS-IvP's time warp), in [0.01, 1000].
    #[arg(long, value_name = "W", default_value_t = 1.0)]
    time_warp: f64,
    /// Bearer token (the demo's own vessels use it too).
    #[arg(long, env = "SEACOVER_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// Record the run as MCAP files in this directory (named by their UTC
    /// start); nothing is recorded without it.
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
}

pub(crate) async fn run(args: Args) -> anyhow::Result<()> {
    shell::check_warp(args.time_warp)?;
    let (listener, stop) = shell::listen(&args.bind).await?;
    let addr = listener.local_addr()?;
    // Before the banner: a demo that cannot serve says so at once.
    seacover::server::check_bind(addr, args.token.as_deref())?;
    let recording = args.record.as_ref().map(|dir| dir.display().to_string());
    let run = tokio::spawn(seacover::demo::run(
        listener,
        args.time_warp,
        args.token,
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
