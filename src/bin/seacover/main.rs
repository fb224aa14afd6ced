//! The `seacover` command: parses the command line, sets up logging and
//! runs one subcommand. Each subcommand is one file in `commands/` (its clap
//! `Args` and its `run`), as cargo's own are; what they share (the runtime,
//! signals, exit codes) is in `shell.rs`. Everything else is the library's.

mod commands;
mod shell;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use commands::{agent, bench, demo, evaluate, fleet, record, replay, risk, serve, sim};

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
    Evaluate(evaluate::Args),
    /// Run the coordinator: HTTP API, vessel links, coverage tick.
    Serve(serve::Args),
    /// Run simulated vessels, each on its own link to a coordinator; or,
    /// with --mavlink, bridge real autopilots (ArduPilot boats) onto it.
    Agent(agent::Args),
    /// Coordinator and eight simulated vessels on loopback, paper scenario.
    Demo(demo::Args),
    /// Serve the dashboard over a recording, read-only: play, pause, speed
    /// and seek from its replay bar or `PUT /api/v1/replay`.
    Replay(replay::Args),
    /// Inspect recordings.
    Record {
        #[command(subcommand)]
        what: record::Command,
    },
    /// Risk maps from GIS: `risk fit FILE.tif --mission M` fits a GeoTIFF
    /// as the mission's risk.
    Risk {
        #[command(subcommand)]
        what: risk::Command,
    },
    /// What a peer fleet needs before it sails: `fleet credentials DIR`.
    Fleet {
        #[command(subcommand)]
        what: fleet::Command,
    },
    /// Benchmarks against a running coordinator.
    Bench {
        #[command(subcommand)]
        kind: bench::Command,
    },
    /// Simulate the closed loop (dynamics, observer, controller, guidance,
    /// coverage) in one process and write CSV, JSON and figures.
    #[command(args_conflicts_with_subcommands = true)]
    Sim(sim::Args),
}

fn main() -> ExitCode {
    shell::zenoh_runtime();
    let cli = Cli::parse();
    let quiet = matches!(
        cli.command,
        Command::Evaluate(_) | Command::Sim(_) | Command::Risk { .. }
    );
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        // Zenoh's own info lines (its id, every endpoint, scouting) are
        // for debugging Zenoh; ours say what a member does. Its warning
        // that it skips the server's name on every QUIC link is the
        // credentials' design (a member is known by its fleet's
        // authority, not by an address's name: docs/peer.md).
        tracing_subscriber::EnvFilter::new(if quiet {
            "warn"
        } else {
            "info,zenoh=warn,zenoh_link_commons::quic::utils=error"
        })
    });
    // Colour only for a person at a terminal, never into a file or a pipe.
    let logs = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_writer(std::io::stderr);
    match cli.log_format {
        LogFormat::Text => logs.init(),
        LogFormat::Json => logs.json().init(),
    }
    match cli.command {
        Command::Evaluate(args) => evaluate::run(args),
        Command::Serve(args) => shell::report(shell::block_on(serve::run(args))),
        Command::Agent(args) => shell::report(shell::block_on(agent::run(args))),
        Command::Demo(args) => shell::report(shell::block_on(demo::run(args))),
        Command::Replay(args) => shell::report(shell::block_on(replay::run(args))),
        Command::Record { what } => shell::report(record::run(what)),
        Command::Risk { what } => shell::report(risk::run(what)),
        Command::Fleet { what } => shell::report(fleet::run(what)),
        Command::Bench { kind } => shell::report(shell::block_on(bench::run(kind))),
        Command::Sim(args) => sim::run(args),
    }
}
