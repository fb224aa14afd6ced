//! `seacover bench load`: the load benchmark of a running coordinator.

use crate::shell;

#[derive(clap::Subcommand)]
pub(crate) enum Command {
    /// Open N vessel links to a coordinator, report poses at a rate, and
    /// measure links held, commands, latency and the coordinator's CPU and
    /// memory (the targets of docs/performance.md).
    Load(LoadArgs),
}

#[derive(clap::Args)]
pub(crate) struct LoadArgs {
    /// Coordinator base URL, e.g. http://127.0.0.1:8090.
    #[arg(long, value_name = "URL")]
    server: String,
    /// How many vessel links to open (named load-00001 …).
    #[arg(long, value_name = "N", default_value_t = 1000)]
    vessels: usize,
    /// Poses per second per vessel.
    #[arg(long, default_value_t = 20.0)]
    rate: f64,
    /// Measured seconds.
    #[arg(long, default_value_t = 30.0)]
    duration: f64,
    /// Seconds of settling after every link has its first command.
    #[arg(long, default_value_t = 2.0)]
    warmup: f64,
    #[command(flatten)]
    time_warp: shell::Warp,
    /// Seed of the start positions.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    token: shell::Token,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    json: bool,
}

pub(crate) async fn run(Command::Load(args): Command) -> anyhow::Result<()> {
    let seconds = |name: &str, s: f64| {
        anyhow::ensure!(
            s.is_finite() && (0.0..=86_400.0).contains(&s),
            "--{name} must be in [0, 86400] s"
        );
        Ok(std::time::Duration::from_secs_f64(s))
    };
    let mut config = seacover::load::LoadConfig::new(
        args.server,
        args.vessels,
        args.rate,
        seconds("duration", args.duration)?,
    );
    config.warmup = seconds("warmup", args.warmup)?;
    config.time_warp = args.time_warp.factor;
    config.seed = args.seed;
    config.token = args.token.value;
    let report = seacover::load::run(config, shell::stop_on_signal()).await?;
    if args.json {
        println!("{}", report.to_json());
    } else {
        print!("{report}");
    }
    Ok(())
}
