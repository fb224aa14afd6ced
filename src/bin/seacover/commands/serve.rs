//! `seacover serve`: the coordinator (HTTP API, vessel links, coverage
//! tick), its mission in a data directory, recorded as MCAP by default.

use std::path::PathBuf;

use crate::shell;

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    bind: shell::Bind,
    #[command(flatten)]
    time_warp: shell::Warp,
    #[command(flatten)]
    token: shell::Token,
    /// Where the mission is stored (created when missing).
    #[arg(long, value_name = "DIR", default_value = "seacover-data")]
    data_dir: PathBuf,
    /// TOML file with the mission (region, risk, actuator, guidance,
    /// tick rate) and server settings; it seeds a new data directory only
    /// (see examples/seacover.toml).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Record the run as MCAP files in this directory (one file per start
    /// and rotation, named by its UTC start); default DATA_DIR/recordings.
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
    /// Record nothing.
    #[arg(long, conflicts_with = "record")]
    no_record: bool,
    /// Start a new recording file after this many MiB.
    #[arg(long, value_name = "MIB", default_value_t = 256)]
    record_max_mb: u64,
    /// Start a new recording file after this many minutes of mission time
    /// (fractions allowed: 0.5 is thirty seconds).
    #[arg(long, value_name = "MINUTES", default_value_t = 60.0, value_parser = positive_minutes)]
    record_max_minutes: f64,
    /// Keep this much of the recordings, deleting the oldest files first:
    /// mission time recorded (48h, 90m, 3d) or bytes on disk (5GB, 500MB,
    /// 2GiB). Give it twice for both limits; either deletes. Only files
    /// named as the recorder names them are deleted (docs/recording.md).
    #[arg(
        long,
        value_name = "TIME|SIZE",
        default_values = seacover::recorder::retention::DEFAULT_KEEP,
        action = clap::ArgAction::Append
    )]
    record_keep: Vec<seacover::recorder::retention::Limit>,
    /// Join a peer fleet as a member (docs/peer.md): publish the mission
    /// to it (each accepted write a new revision) and show its vessels
    /// from their beacons; no commands are sent.
    #[arg(long)]
    peer: bool,
    #[command(flatten)]
    fleet: shell::Fleet,
    /// With --peer: `peer`, or `router` to route for members that reach
    /// this one over a routed network (LTE, VPN).
    #[arg(long, value_enum, default_value = "peer", requires = "peer")]
    zenoh_mode: ZenohMode,
    /// With --peer: publish this coordinator's mission over the one the
    /// fleet is working on. Without it a coordinator joining a fleet that
    /// has a mission takes the fleet's (stored as its own), so that a
    /// fresh shore cannot re-task a running fleet by accident.
    #[arg(long, requires = "peer")]
    replace_fleet_mission: bool,
    #[command(flatten)]
    zenoh: shell::ZenohArgs,
}

/// `--zenoh-mode`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum ZenohMode {
    Peer,
    Router,
}

/// `--record-max-minutes`: a positive, finite number of minutes.
fn positive_minutes(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(m) if m.is_finite() && m > 0.0 => Ok(m),
        _ => Err(format!("{s:?} is not a positive number of minutes")),
    }
}

pub(crate) async fn run(args: Args) -> anyhow::Result<()> {
    let record = (!args.no_record).then(|| seacover::recorder::RecorderConfig {
        target: seacover::recorder::Target::Directory {
            dir: args
                .record
                .clone()
                .unwrap_or_else(|| args.data_dir.join("recordings")),
            max_bytes: args.record_max_mb.saturating_mul(1024 * 1024),
            max_duration: std::time::Duration::try_from_secs_f64(args.record_max_minutes * 60.0)
                .unwrap_or(std::time::Duration::MAX),
            keep: seacover::recorder::retention::Keep::new(&args.record_keep),
        },
        wall_clock: true,
    });
    shell::check_warp(args.time_warp.factor)?;
    let settings = match &args.config {
        Some(path) => seacover::server::config::Settings::load(path)?,
        None => Default::default(),
    };
    let mission_source = match &args.config {
        Some(path) => format!("from {}", path.display()),
        None => "the built-in paper scenario (no --config)".to_string(),
    };
    let (listener, stop) = shell::listen(&args.bind.addr).await?;
    let config = seacover::server::ServeConfig {
        mission: settings.mission,
        time_warp: args.time_warp.factor,
        token: args.token.value,
        liveness: settings.liveness,
        data_dir: Some(args.data_dir),
        write_rate: settings.write_rate,
        write_burst: settings.write_burst,
        learning: settings.learning,
        record,
        mission_source,
        peer: args.peer.then(|| {
            let mut zenoh = args.zenoh.options();
            if let ZenohMode::Router = args.zenoh_mode {
                zenoh.mode = seacover::agent::peer::session::Mode::Router;
            }
            seacover::server::peer::PeerMember {
                fleet: args.fleet.name.clone(),
                zenoh,
                replace: args.replace_fleet_mission,
            }
        }),
    };
    let server = seacover::server::prepare(listener, config, stop).await?;
    // The first line of output is the address, so scripts and tests can
    // bind port 0 and find the server; it is printed only once every check
    // of the start has passed.
    println!("seacover: serving on http://{}", server.local_addr()?);
    server.run().await?;
    Ok(())
}
