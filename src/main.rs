//! The `seacover` command: argument parsing and logging set-up over the library.

use std::io::Read;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use seacover::coverage::Options;
use seacover::coverage::integrate::Tolerance;
use seacover::protocol::{ErrorDetail, ErrorDocument};

#[derive(Parser)]
#[command(
    name = "seacover",
    version,
    about = "Coverage control for fleets of unmanned surface vessels"
)]
struct Cli {
    /// Log lines as text or as JSON objects (one per line); the level comes
    /// from RUST_LOG (default `info` for serve, agent and demo, `warn`
    /// otherwise).
    #[arg(long, global = true, value_enum, default_value = "text")]
    log_format: LogFormat,
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LogFormat {
    Text,
    Json,
}

#[derive(Subcommand)]
enum Command {
    /// Evaluate a scenario document (file or stdin): cells, centroids, H(P).
    Evaluate {
        /// Scenario JSON file; standard input when omitted or "-".
        file: Option<PathBuf>,
        /// Use adaptive quadrature to this estimated relative error (mass;
        /// centroid relative to the cell's size) instead of the default fixed
        /// resolution: slower, for reference results.
        #[arg(long)]
        tolerance: Option<f64>,
    },
    /// Run the coordinator: HTTP API, vessel links, coverage tick.
    Serve {
        /// Address to listen on (loopback only until tokens exist).
        #[arg(long, default_value = "127.0.0.1:8080")]
        bind: String,
        /// Run the tick clock this many times faster than real time.
        #[arg(long, default_value_t = 1.0)]
        time_warp: f64,
        /// Bearer token required for writes and vessel links.
        #[arg(long, env = "SEACOVER_TOKEN", hide_env_values = true)]
        token: Option<String>,
        /// Where the mission is stored (created when missing).
        #[arg(long, default_value = "seacover-data")]
        data_dir: PathBuf,
        /// TOML file with the mission (region, risk, actuator, guidance,
        /// tick rate) and server settings; it seeds a new data directory only
        /// (see examples/seacover.toml).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Record the run as MCAP in DATA_DIR/recordings/ (`on`) or not
        /// (`off`).
        #[arg(long, value_enum, default_value = "on")]
        record: OnOff,
        /// Start a new recording file after this many MiB.
        #[arg(long, default_value_t = 256)]
        record_max_mb: u64,
        /// Start a new recording file after this many minutes (fractions
        /// allowed: 0.5 is thirty seconds).
        #[arg(long, default_value_t = 60.0, value_parser = positive_minutes)]
        record_max_minutes: f64,
    },
    /// Run simulated vessels, each on its own link to a coordinator; or,
    /// with --mavlink, bridge real autopilots (ArduPilot boats) onto it.
    Agent {
        /// Coordinator base URL, e.g. http://127.0.0.1:8080.
        #[arg(long)]
        server: String,
        /// How many vessels (named usv-1 …); the first eight start where the
        /// paper's do, further ones at random in the paper's region.
        #[arg(long, default_value_t = 8)]
        vessels: usize,
        /// Run one vessel with this id instead.
        #[arg(long)]
        id: Option<String>,
        /// Vessel preset: `paper` or `otter`.
        #[arg(long, default_value = "paper")]
        preset: String,
        #[arg(long, default_value_t = 1.0)]
        time_warp: f64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Bearer token of the coordinator.
        #[arg(long, env = "SEACOVER_TOKEN", hide_env_values = true)]
        token: Option<String>,
        /// Bridge the autopilots on this MAVLink endpoint instead of
        /// simulating vessels (repeatable): `tcpout:HOST:PORT`,
        /// `udpin:ADDR:PORT`, `udpout:HOST:PORT`, `serial:DEVICE:BAUD`.
        /// Each autopilot becomes the vessel `mav-<sysid>` (or --id when
        /// there is exactly one). The mission must have an origin.
        #[arg(long, value_name = "ENDPOINT", conflicts_with_all = ["vessels", "preset", "time_warp", "seed"])]
        mavlink: Vec<String>,
        /// With --mavlink: switch each vehicle to GUIDED and arm it, once,
        /// at start (simulators and tests; otherwise the operator does).
        #[arg(long, requires = "mavlink")]
        arm: bool,
        /// With --mavlink: the bridge's own MAVLink system id (a ground
        /// station's; ArduPilot's SYSID_MYGCS is 255 by default).
        #[arg(long, default_value_t = 255, requires = "mavlink")]
        mavlink_sysid: u8,
    },
    /// Coordinator and eight simulated vessels on loopback, paper scenario.
    Demo {
        #[arg(long, default_value = "127.0.0.1:8080")]
        bind: String,
        #[arg(long, default_value_t = 1.0)]
        time_warp: f64,
        /// Bearer token (the demo's own vessels use it too).
        #[arg(long, env = "SEACOVER_TOKEN", hide_env_values = true)]
        token: Option<String>,
        /// Record the run as MCAP files in this directory.
        #[arg(long, value_name = "DIR")]
        record: Option<PathBuf>,
    },
    /// Serve the dashboard over a recording, read-only: play, pause, speed
    /// and seek from its replay bar or `PUT /api/v1/replay`.
    Replay {
        /// An MCAP recording (of `serve`, `demo --record` or `sim --record`).
        file: PathBuf,
        #[arg(long, default_value = "127.0.0.1:8080")]
        bind: String,
        /// Recording seconds per wall-clock second.
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
    },
    /// Inspect recordings.
    Record {
        #[command(subcommand)]
        what: RecordCommand,
    },
    /// Benchmarks against a running coordinator.
    Bench {
        #[command(subcommand)]
        kind: BenchKind,
    },
    /// Simulate the closed loop (dynamics, observer, controller, guidance,
    /// coverage) in one process and write CSV, JSON and figures.
    #[command(args_conflicts_with_subcommands = true)]
    Sim {
        #[command(subcommand)]
        study: Option<SimStudy>,
        /// `paper`, `harbour-8`, `harbour-30` (built in) or a scenario JSON
        /// file.
        #[arg(long, default_value = "paper")]
        scenario: String,
        /// Start where the scenario says (`scenario`) or at random legal
        /// starts drawn with --seed (`random`; the harbour's fleets leave
        /// from its staging area west of the pier).
        #[arg(long, default_value = "scenario")]
        starts: String,
        /// `on`: reachable goals, routes round islands and the safety filter
        /// (collision and shore avoidance); `off`: goals and routes without
        /// the filter; `none`: straight at the centroids, no filter (the
        /// paper's pipeline, for reproducing it).
        #[arg(long, default_value = "on")]
        safety: String,
        /// Least distance between two vessels' centres [m].
        #[arg(long, default_value_t = seacover::control::safety::SafetyParams::default().safety_distance)]
        safety_distance: f64,
        /// Least distance from a vessel's centre to the shore [m].
        #[arg(long, default_value_t = seacover::control::safety::SafetyParams::default().shore_distance)]
        shore_distance: f64,
        /// Simulated seconds.
        #[arg(long, default_value_t = 200.0)]
        duration: f64,
        /// Output directory.
        #[arg(long, default_value = "sim-out")]
        out: PathBuf,
        /// Guidance law: `course` (converges) or `paper` (the literal law).
        #[arg(long, default_value = "course")]
        guidance: String,
        /// Vessel preset: `paper` or `otter`.
        #[arg(long, default_value = "paper")]
        preset: String,
        /// Seed of the random disturbances and of random starts.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Disturbances: `paper`, `gusts`, `current` or `none`.
        #[arg(long, default_value = "paper")]
        disturbance: String,
        /// Skip the figures (CSV and JSON only).
        #[arg(long)]
        no_figures: bool,
        /// Also record the run as MCAP: the coordinator's channels plus each
        /// vessel's truth, disturbance and observer estimate.
        #[arg(long, value_name = "FILE.mcap")]
        record: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum OnOff {
    On,
    Off,
}

#[derive(Subcommand)]
enum RecordCommand {
    /// Duration, vessels, channels with message counts, H at start and end,
    /// gaps in the data.
    Info {
        file: PathBuf,
        /// As JSON.
        #[arg(long)]
        json: bool,
    },
    /// One channel's messages as CSV (coverage: H and each vessel's E over
    /// time; pose; command; sim/vessel) or JSON lines (any channel), on
    /// standard output.
    Export {
        file: PathBuf,
        #[arg(long, default_value = "/seacover/coverage")]
        channel: String,
        #[arg(long, value_enum, default_value = "csv")]
        format: ExportFormat,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ExportFormat {
    Csv,
    Jsonl,
}

#[derive(Subcommand)]
enum SimStudy {
    /// The harbour with 8 and 30 vessels from random starts, each seed with
    /// the safety filter on and off: collisions, incursions, closest
    /// approaches, H and interventions (docs/safety.md).
    SafetyStudy {
        /// Seeds 1..=N.
        #[arg(long, default_value_t = 50)]
        seeds: u64,
        /// Simulated seconds per run.
        #[arg(long, default_value_t = 400.0)]
        duration: f64,
        /// Where to write study.json, table.md and the trails figure.
        #[arg(long, default_value = "target/safety-study")]
        out: PathBuf,
        /// Runs at once (threads).
        #[arg(long, default_value_t = 1)]
        jobs: usize,
    },
}

#[derive(Subcommand)]
enum BenchKind {
    /// Open N vessel links to a coordinator, report poses at a rate, and
    /// measure links held, commands, latency and the coordinator's CPU and
    /// memory (SPEC §4 targets).
    Load {
        /// Coordinator base URL, e.g. http://127.0.0.1:8090.
        #[arg(long)]
        server: String,
        #[arg(long, default_value_t = 1000)]
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
        /// The coordinator's --time-warp.
        #[arg(long, default_value_t = 1.0)]
        time_warp: f64,
        /// Seed of the start positions.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Bearer token of the coordinator.
        #[arg(long, env = "SEACOVER_TOKEN", hide_env_values = true)]
        token: Option<String>,
        /// Print the report as JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let quiet = matches!(cli.command, Command::Evaluate { .. } | Command::Sim { .. });
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new(if quiet { "warn" } else { "info" })
    });
    let logs = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    match cli.log_format {
        LogFormat::Text => logs.init(),
        LogFormat::Json => logs.json().init(),
    }
    match cli.command {
        Command::Evaluate { file, tolerance } => evaluate(file, tolerance),
        Command::Serve {
            bind,
            time_warp,
            token,
            data_dir,
            config,
            record,
            record_max_mb,
            record_max_minutes,
        } => {
            let record = (record == OnOff::On).then(|| seacover::recorder::RecorderConfig {
                target: seacover::recorder::Target::Directory {
                    dir: data_dir.join("recordings"),
                    max_bytes: record_max_mb.saturating_mul(1024 * 1024),
                    max_duration: std::time::Duration::try_from_secs_f64(record_max_minutes * 60.0)
                        .unwrap_or(std::time::Duration::MAX),
                },
                wall_clock: true,
            });
            report(runtime().block_on(serve(&bind, time_warp, token, data_dir, config, record)))
        }
        Command::Agent {
            server,
            mavlink,
            arm,
            mavlink_sysid,
            id,
            token,
            ..
        } if !mavlink.is_empty() => report(runtime().block_on(bridge(
            seacover::agent::mavlink::BridgeConfig {
                server,
                endpoints: mavlink,
                arm,
                token,
                id,
                sysid: mavlink_sysid,
                origin_poll: std::time::Duration::from_secs(2),
            },
        ))),
        Command::Agent {
            server,
            vessels,
            id,
            preset,
            time_warp,
            seed,
            token,
            ..
        } => {
            report(runtime().block_on(agent(&server, vessels, id, &preset, time_warp, seed, token)))
        }
        Command::Demo {
            bind,
            time_warp,
            token,
            record,
        } => report(runtime().block_on(demo(&bind, time_warp, token, record))),
        Command::Replay { file, bind, speed } => {
            report(runtime().block_on(replay(&bind, file, speed)))
        }
        Command::Record {
            what: RecordCommand::Info { file, json },
        } => report(record_info(&file, json)),
        Command::Record {
            what:
                RecordCommand::Export {
                    file,
                    channel,
                    format,
                },
        } => report(record_export(&file, &channel, format)),
        Command::Bench {
            kind:
                BenchKind::Load {
                    server,
                    vessels,
                    rate,
                    duration,
                    warmup,
                    time_warp,
                    seed,
                    token,
                    json,
                },
        } => {
            let run = bench_load(
                server, vessels, rate, duration, warmup, time_warp, seed, token, json,
            );
            report(runtime().block_on(run))
        }
        Command::Sim {
            study:
                Some(SimStudy::SafetyStudy {
                    seeds,
                    duration,
                    out,
                    jobs,
                }),
            ..
        } => match safety_study(seeds, duration, &out, jobs) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("seacover sim safety-study: {e:#}");
                ExitCode::from(2)
            }
        },
        Command::Sim {
            study: None,
            scenario,
            starts,
            safety,
            safety_distance,
            shore_distance,
            duration,
            out,
            guidance,
            preset,
            seed,
            disturbance,
            no_figures,
            record,
        } => match sim(
            SimArgs {
                scenario: &scenario,
                starts: &starts,
                safety: &safety,
                safety_distance,
                shore_distance,
                duration,
                guidance: &guidance,
                preset: &preset,
                seed,
                disturbance: &disturbance,
            },
            &out,
            !no_figures,
            record.as_deref(),
        ) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("seacover sim: {e:#}");
                ExitCode::from(2)
            }
        },
    }
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("a tokio runtime")
}

fn report(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A reader that stops early (`seacover record export … | head`)
        // closes the pipe: that is the reader's choice, not a failure.
        Err(e)
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("seacover: {}", error_chain(&e));
            ExitCode::from(2)
        }
    }
}

/// An error and its causes, `: `-separated, leaving out a cause whose text
/// the message before it already quotes (library errors say their source
/// in their own message, for logs that print only that).
fn error_chain(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let part = cause.to_string();
        if text.is_empty() {
            text = part;
        } else if !text.contains(&part) {
            text = format!("{text}: {part}");
        }
    }
    text
}

/// Cancels `token` on ctrl-c or SIGTERM.
fn cancel_on_signal(token: tokio_util::sync::CancellationToken) {
    tokio::spawn(async move {
        let ctrl_c = tokio::signal::ctrl_c();
        #[cfg(unix)]
        {
            let mut term =
                tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
                    .expect("a SIGTERM handler");
            tokio::select! {
                _ = ctrl_c => {}
                _ = term.recv() => {}
            }
        }
        #[cfg(not(unix))]
        let _ = ctrl_c.await;
        token.cancel();
    });
}

fn check_warp(w: f64) -> anyhow::Result<()> {
    anyhow::ensure!(
        w.is_finite() && (0.01..=1000.0).contains(&w),
        "--time-warp must be in [0.01, 1000]"
    );
    Ok(())
}

/// Binds `bind` and returns the listener with a token that ctrl-c or SIGTERM
/// cancels.
async fn listen(
    bind: &str,
) -> anyhow::Result<(tokio::net::TcpListener, tokio_util::sync::CancellationToken)> {
    use anyhow::Context;
    let listener = tokio::net::TcpListener::bind(bind)
        .await
        .with_context(|| format!("binding {bind}"))?;
    let stop = tokio_util::sync::CancellationToken::new();
    cancel_on_signal(stop.clone());
    Ok((listener, stop))
}

async fn serve(
    bind: &str,
    time_warp: f64,
    token: Option<String>,
    data_dir: PathBuf,
    config: Option<PathBuf>,
    record: Option<seacover::recorder::RecorderConfig>,
) -> anyhow::Result<()> {
    check_warp(time_warp)?;
    let settings = match &config {
        Some(path) => seacover::server::config::Settings::load(path)?,
        None => Default::default(),
    };
    let (listener, stop) = listen(bind).await?;
    // The first line of output is the address, so scripts and tests can
    // bind port 0 and find the server.
    println!("seacover: serving on http://{}", listener.local_addr()?);
    let config = seacover::server::ServeConfig {
        mission: settings.mission,
        time_warp,
        token,
        liveness: settings.liveness,
        data_dir: Some(data_dir),
        write_rate: settings.write_rate,
        write_burst: settings.write_burst,
        record,
    };
    seacover::server::serve(listener, config, stop).await?;
    Ok(())
}

async fn replay(bind: &str, file: PathBuf, speed: f64) -> anyhow::Result<()> {
    let (listener, stop) = listen(bind).await?;
    println!(
        "seacover: replaying {} on http://{}",
        file.display(),
        listener.local_addr()?
    );
    seacover::server::replay::serve(listener, file, speed, stop).await?;
    Ok(())
}

fn record_info(file: &std::path::Path, json: bool) -> anyhow::Result<()> {
    use seacover::recorder::{inspect, reader::Recording};
    let info = inspect::info(&Recording::open(file)?)?;
    let mut out = std::io::stdout().lock();
    if json {
        serde_json::to_writer_pretty(&mut out, &info)?;
        println!();
    } else {
        inspect::print_info(&info, &mut out)?;
    }
    Ok(())
}

fn record_export(
    file: &std::path::Path,
    channel: &str,
    format: ExportFormat,
) -> anyhow::Result<()> {
    use seacover::recorder::{inspect, reader::Recording};
    let format = match format {
        ExportFormat::Csv => inspect::Format::Csv,
        ExportFormat::Jsonl => inspect::Format::Jsonl,
    };
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    inspect::export(&Recording::open(file)?, channel, format, &mut out)?;
    use std::io::Write;
    out.flush()?;
    Ok(())
}

fn link_url(server: &str) -> anyhow::Result<String> {
    seacover::agent::link::link_url(server)
        .ok_or_else(|| anyhow::anyhow!("--server must be an http:// or ws:// URL, got {server:?}"))
}

async fn bridge(config: seacover::agent::mavlink::BridgeConfig) -> anyhow::Result<()> {
    if let Some(id) = &config.id {
        anyhow::ensure!(
            seacover::scenario::valid_id(id),
            "--id must match [A-Za-z0-9_.-]{{1,64}}"
        );
    }
    let stop = tokio_util::sync::CancellationToken::new();
    cancel_on_signal(stop.clone());
    seacover::agent::mavlink::run(config, stop).await?;
    Ok(())
}

async fn agent(
    server: &str,
    n: usize,
    id: Option<String>,
    preset: &str,
    time_warp: f64,
    seed: u64,
    token: Option<String>,
) -> anyhow::Result<()> {
    use anyhow::Context;
    use seacover::agent::{AgentConfig, paper_vessels, random_vessels, run_fleet};
    use seacover::control::model::VesselParams;
    check_warp(time_warp)?;
    anyhow::ensure!((1..=10_000).contains(&n), "--vessels must be in [1, 10000]");
    let params = VesselParams::preset(preset).with_context(|| {
        format!(
            "--preset: unknown preset {preset:?} ({})",
            VesselParams::PRESETS.join(", ")
        )
    })?;
    let mut vessels = paper_vessels(params);
    if n > vessels.len() {
        let extra = random_vessels(
            "usv",
            n - vessels.len(),
            (0.0, 0.0),
            (100.0, 100.0),
            seed,
            params,
        );
        vessels.extend(extra.into_iter().enumerate().map(|(i, mut v)| {
            v.id = format!("usv-{}", 9 + i);
            v.index = 9 + i;
            v
        }));
    }
    vessels.truncate(n);
    if let Some(id) = id {
        anyhow::ensure!(
            seacover::scenario::valid_id(&id),
            "--id must match [A-Za-z0-9_.-]{{1,64}}"
        );
        vessels.truncate(1);
        vessels[0].id = id;
    }
    let config = AgentConfig {
        url: link_url(server)?,
        time_warp,
        pose_hz: 20.0,
        seed,
        token,
    };
    let stop = tokio_util::sync::CancellationToken::new();
    cancel_on_signal(stop.clone());
    run_fleet(config, vessels, stop).await;
    Ok(())
}

async fn demo(
    bind: &str,
    time_warp: f64,
    token: Option<String>,
    record: Option<PathBuf>,
) -> anyhow::Result<()> {
    check_warp(time_warp)?;
    let (listener, stop) = listen(bind).await?;
    let addr = listener.local_addr()?;
    let recording = record.as_ref().map(|dir| dir.display().to_string());
    let run = tokio::spawn(seacover::demo::run(
        listener, time_warp, token, record, stop,
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

#[allow(clippy::too_many_arguments)]
async fn bench_load(
    server: String,
    vessels: usize,
    rate: f64,
    duration: f64,
    warmup: f64,
    time_warp: f64,
    seed: u64,
    token: Option<String>,
    json: bool,
) -> anyhow::Result<()> {
    let seconds = |name: &str, s: f64| {
        anyhow::ensure!(
            s.is_finite() && (0.0..=86_400.0).contains(&s),
            "--{name} must be in [0, 86400] s"
        );
        Ok(std::time::Duration::from_secs_f64(s))
    };
    let mut config =
        seacover::load::LoadConfig::new(server, vessels, rate, seconds("duration", duration)?);
    config.warmup = seconds("warmup", warmup)?;
    config.time_warp = time_warp;
    config.seed = seed;
    config.token = token;
    let stop = tokio_util::sync::CancellationToken::new();
    cancel_on_signal(stop.clone());
    let report = seacover::load::run(config, stop).await?;
    if json {
        println!("{}", report.to_json());
    } else {
        print!("{report}");
    }
    Ok(())
}

struct SimArgs<'a> {
    scenario: &'a str,
    starts: &'a str,
    safety: &'a str,
    safety_distance: f64,
    shore_distance: f64,
    duration: f64,
    guidance: &'a str,
    preset: &'a str,
    seed: u64,
    disturbance: &'a str,
}

fn sim(
    args: SimArgs,
    out: &std::path::Path,
    figures: bool,
    record: Option<&std::path::Path>,
) -> anyhow::Result<()> {
    use anyhow::{Context, bail};
    use seacover::control::guidance::GuidanceMode;
    use seacover::control::model::VesselParams;
    use seacover::sim::{Config, DisturbanceKind, load_scenario, run_to_dir};
    let SimArgs {
        scenario,
        starts,
        safety,
        safety_distance,
        shore_distance,
        duration,
        guidance,
        preset,
        seed,
        disturbance,
    } = args;

    if !(duration.is_finite() && duration > 0.0 && duration <= 86_400.0) {
        bail!("--duration must be in (0, 86400] s");
    }
    let mode = GuidanceMode::parse(guidance)
        .with_context(|| format!("--guidance: unknown mode {guidance:?} (paper, course)"))?;
    let vessel = VesselParams::preset(preset).with_context(|| {
        format!(
            "--preset: unknown preset {preset:?} ({})",
            VesselParams::PRESETS.join(", ")
        )
    })?;
    let disturbance = DisturbanceKind::parse(disturbance).with_context(|| {
        format!("--disturbance: unknown model {disturbance:?} (paper, gusts, current, none)")
    })?;
    let (filter, reachable_goals) = match safety {
        "on" => (true, true),
        "off" => (false, true),
        "none" => (false, false),
        _ => bail!("--safety: must be on, off or none, got {safety:?}"),
    };
    let (loaded, headings) = load_scenario(scenario)?;
    let mut config = Config::new(loaded, headings, duration);
    config.guidance.mode = mode;
    config.vessel = vessel;
    config.preset = preset.to_string();
    config.seed = seed;
    config.disturbance = disturbance;
    config.safety.filter = filter;
    config.safety.reachable_goals = reachable_goals;
    config.safety.safety_distance = safety_distance;
    config.safety.shore_distance = shore_distance;
    config.safety.validate()?;
    let config = match starts {
        "scenario" => config,
        "random" => config.with_random_starts(seed, seacover::sim::staging_zone(scenario))?,
        _ => bail!("--starts: must be scenario or random, got {starts:?}"),
    };

    let bar = std::io::IsTerminal::is_terminal(&std::io::stderr()).then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {percent:>3}% simulated, eta {eta}")
                .expect("a valid template"),
        );
        bar
    });
    let document = match record {
        Some(_) => Some(seacover::sim::load_scenario_document(scenario)?),
        None => None,
    };
    let record = record.zip(document.as_ref());
    let (summary, safety) = run_to_dir(&config, out, figures, record, |f| {
        if let Some(bar) = &bar {
            bar.set_position((f * 1000.0) as u64);
        }
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    println!("{}", serde_json::to_string_pretty(&summary)?);
    eprintln!(
        "safety (filter {}): {} collisions, {} incursions, closest pair {:.2} m, closest to shore {:.2} m, interventions {:.2} % of vessel-ticks (safety.json)",
        if safety.filter { "on" } else { "off" },
        safety.collisions,
        safety.incursions,
        safety.min_pair_distance.unwrap_or(f64::INFINITY),
        safety.min_shore_clearance,
        100.0 * safety.intervention_rate,
    );
    Ok(())
}

fn safety_study(
    seeds: u64,
    duration: f64,
    out: &std::path::Path,
    jobs: usize,
) -> anyhow::Result<()> {
    use anyhow::{Context, ensure};
    use seacover::sim::study;
    ensure!(
        (1..=10_000).contains(&seeds),
        "--seeds must be in [1, 10000]"
    );
    ensure!(
        duration.is_finite() && duration > 0.0 && duration <= 86_400.0,
        "--duration must be in (0, 86400] s"
    );
    ensure!((1..=64).contains(&jobs), "--jobs must be in [1, 64]");
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let started = std::time::Instant::now();
    let seed_list: Vec<u64> = (1..=seeds).collect();
    let runs = study::run_study(&[8, 30], &seed_list, duration, jobs, |r| {
        eprintln!(
            "  {:>2} vessels, seed {:>3}, filter {:<3}: {} collisions, {} incursions, H {:.1}",
            r.vessels,
            r.seed,
            if r.filter { "on" } else { "off" },
            r.collisions,
            r.incursions,
            r.h_end
        );
    })?;
    let summaries = study::summarize(&runs);
    let table = study::table(&summaries);
    let doc = serde_json::json!({"seeds": seeds, "duration": duration, "summaries": summaries, "runs": runs});
    std::fs::write(
        out.join("study.json"),
        serde_json::to_string_pretty(&doc)? + "\n",
    )?;
    std::fs::write(out.join("table.md"), &table)?;
    // The figure: the first seed of the bigger fleet, filter on.
    let config = study::study_config(30, 1, true, duration)?;
    let run = seacover::sim::run(&config, |_| {})?;
    seacover::sim::figures::draw_trails(&out.join("harbour-30-trails"), &config, &run)
        .map_err(anyhow::Error::msg)?;
    print!("{table}");
    eprintln!(
        "{} runs in {:.0} s; study.json, table.md and harbour-30-trails.{{png,svg}} in {}",
        runs.len(),
        started.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}

/// `--record-max-minutes`: a positive, finite number of minutes.
fn positive_minutes(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(m) if m.is_finite() && m > 0.0 => Ok(m),
        _ => Err(format!("{s:?} is not a positive number of minutes")),
    }
}

fn fail(code: &str, message: String) -> ExitCode {
    let doc = ErrorDocument {
        error: ErrorDetail {
            code: code.to_string(),
            message,
        },
    };
    eprintln!(
        "{}",
        serde_json::to_string(&doc).expect("error documents serialize")
    );
    ExitCode::from(2)
}

fn evaluate(file: Option<PathBuf>, tolerance: Option<f64>) -> ExitCode {
    let tolerance = match tolerance {
        None => Tolerance::default(),
        Some(t) if t.is_finite() && (1e-14..=1e-2).contains(&t) => Tolerance::adaptive(t),
        Some(t) => {
            return fail(
                "invalid",
                format!("--tolerance: must be in [1e-14, 1e-2], got {t}"),
            );
        }
    };
    let mut text = String::new();
    let read = match &file {
        Some(path) if path.as_os_str() != "-" => std::fs::read_to_string(path).map(|t| text = t),
        _ => std::io::stdin().read_to_string(&mut text).map(|_| ()),
    };
    if let Err(e) = read {
        return fail("io", format!("cannot read input: {e}"));
    }
    let options = Options {
        tolerance,
        ..Options::default()
    };
    match seacover::scenario::evaluate_text(&text, &options) {
        Ok(doc) => {
            println!(
                "{}",
                serde_json::to_string(&doc).expect("evaluations serialize")
            );
            ExitCode::SUCCESS
        }
        Err(e) => fail(e.code(), e.to_string()),
    }
}
