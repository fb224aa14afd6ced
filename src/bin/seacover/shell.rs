//! What the subcommands share: the tokio runtime, ctrl-c and SIGTERM,
//! listening, the time-warp check and how an outcome becomes an exit code
//! and a message.

use std::process::ExitCode;

use anyhow::Context;
use tokio_util::sync::CancellationToken;

/// Runs `future` to completion on a multi-threaded runtime.
pub(crate) fn block_on<F: std::future::Future>(future: F) -> F::Output {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("a tokio runtime")
        .block_on(future)
}

/// The exit code of a subcommand's outcome; a failure is printed as
/// `seacover: ` and its causes.
pub(crate) fn report(result: anyhow::Result<()>) -> ExitCode {
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

/// An error and its causes, `: `-separated: each layer's message says
/// only what failed there (see `seacover::chain`).
fn error_chain(e: &anyhow::Error) -> String {
    format!("{e:#}")
}

/// A token that ctrl-c or SIGTERM cancels.
pub(crate) fn stop_on_signal() -> CancellationToken {
    let token = CancellationToken::new();
    let cancel = token.clone();
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
        cancel.cancel();
    });
    token
}

pub(crate) fn check_warp(w: f64) -> anyhow::Result<()> {
    anyhow::ensure!(
        w.is_finite() && (0.01..=1000.0).contains(&w),
        "--time-warp must be in [0.01, 1000]"
    );
    Ok(())
}

/// Binds `bind` and returns the listener with a token that ctrl-c or SIGTERM
/// cancels.
pub(crate) async fn listen(
    bind: &str,
) -> anyhow::Result<(tokio::net::TcpListener, CancellationToken)> {
    let listener = tokio::net::TcpListener::bind(bind)
        .await
        .with_context(|| format!("binding {bind}"))?;
    Ok((listener, stop_on_signal()))
}

/// `--preset`: a vessel model the library knows.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Preset {
    /// The paper's hull (section 5).
    Paper,
    /// Maritime Robotics' Otter USV.
    Otter,
}

impl Preset {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Preset::Paper => "paper",
            Preset::Otter => "otter",
        }
    }

    pub(crate) fn params(self) -> seacover::control::model::VesselParams {
        use seacover::control::model::VesselParams;
        match self {
            Preset::Paper => VesselParams::PAPER,
            Preset::Otter => VesselParams::OTTER,
        }
    }
}

// The flags several subcommands share, each declared once (flattened into
// each subcommand's arguments) with one name and one help.

/// `--bind`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct Bind {
    /// Address and port to listen on for the dashboard and the API (a
    /// coordinator needs --token on any address but loopback).
    #[arg(
        id = "bind",
        long = "bind",
        value_name = "ADDR:PORT",
        default_value = "127.0.0.1:8080"
    )]
    pub(crate) addr: String,
}

/// `--token`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct Token {
    /// The coordinator's bearer token: a coordinator requires it for
    /// writes and vessel links, and its clients send it.
    #[arg(
        id = "token",
        long = "token",
        env = "SEACOVER_TOKEN",
        hide_env_values = true
    )]
    pub(crate) value: Option<String>,
}

/// `--time-warp`.
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct Warp {
    /// Run the mission clock this many times faster than real time
    /// (MOOS-IvP's time warp), in [0.01, 1000]; every program of a
    /// mission (coordinator, vessels, load client) uses the same.
    #[arg(
        id = "time_warp",
        long = "time-warp",
        value_name = "W",
        default_value_t = 1.0
    )]
    pub(crate) factor: f64,
}

/// `--fleet`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct Fleet {
    /// The peer fleet's name: the second segment of its Zenoh keys, and
    /// of its credentials' user name (seacover-NAME).
    #[arg(
        id = "fleet",
        long = "fleet",
        value_name = "NAME",
        default_value = "seacover"
    )]
    pub(crate) name: String,
}

/// How a peer fleet learns the risk map, and what its simulated vessels
/// measure (docs/learning.md, "In a peer fleet").
#[derive(clap::Args, Debug, Clone)]
#[command(next_help_heading = "Learning (with --peer)")]
pub(crate) struct PeerLearnArgs {
    /// Learn the risk map from the fleet's samples and cover the belief
    /// (the mission's risk is the prior). Every member needs the same
    /// learning flags: the belief is fitted with them.
    #[arg(long, requires = "peer", conflicts_with = "server")]
    learn: bool,
    /// Optimism: posterior standard deviations added (0: the mean).
    #[arg(long, value_name = "K", default_value_t = 0.0, requires = "learn")]
    kappa: f64,
    /// The optimism's time constant: κ fades as κ·exp(−age / SECONDS),
    /// age that of the oldest sample held.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = seacover::learning::FADE,
        requires = "learn"
    )]
    fade: f64,
    /// Mission seconds between fits.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 5.0,
        requires = "learn"
    )]
    refit: f64,
    /// Spacing of the belief's lattice of Gaussians (and their spread) [m].
    #[arg(long, value_name = "M", default_value_t = 10.0, requires = "learn")]
    lattice: f64,
    /// The prior's spread of each lattice weight (the density's units).
    #[arg(
        long,
        value_name = "SD",
        default_value_t = seacover::learning::WEIGHT_SD,
        requires = "learn"
    )]
    weight_sd: f64,
    /// The simulated vessels measure this scenario's `truth` (the world's,
    /// never given to the fleet) and share their samples.
    #[arg(long, value_name = "FILE", requires = "learn")]
    truth: Option<std::path::PathBuf>,
    /// With --truth: readings per second per vessel.
    #[arg(long, value_name = "HZ", default_value_t = 1.0, requires = "truth")]
    sample_rate: f64,
    /// With --truth: the readings' noise σ, as a share of the truth's range.
    #[arg(long, value_name = "SHARE", default_value_t = 0.05, requires = "truth")]
    sample_noise: f64,
}

impl PeerLearnArgs {
    /// Onto a peer process's settings.
    pub(crate) fn apply(
        &self,
        config: &mut seacover::agent::peer::PeerConfig,
    ) -> anyhow::Result<()> {
        if !self.learn {
            return Ok(());
        }
        let settings = seacover::agent::peer::learn::LearnSettings {
            kappa: self.kappa,
            fade: self.fade,
            refit: self.refit,
            lattice: self.lattice,
            weight_sd: self.weight_sd,
        };
        settings.validate(|f| format!("--{}", f.replace('_', "-")))?;
        config.learning = Some(settings);
        if let Some(path) = &self.truth {
            let text = std::fs::read_to_string(path)
                .map_err(|e| anyhow::anyhow!("--truth {}: {e}", path.display()))?;
            config.sensor = Some(
                seacover::agent::sensor::SensorConfig::of_scenario(
                    &text,
                    self.sample_rate,
                    self.sample_noise,
                )
                .map_err(|e| {
                    anyhow::anyhow!("--truth {}: {}", path.display(), seacover::chain::Chain(&e))
                })?,
            );
        }
        Ok(())
    }
}

/// The Zenoh flags of `agent --peer` and `serve --peer`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct ZenohArgs {
    /// Listen for other members on this Zenoh endpoint (repeatable), e.g.
    /// `tcp/0.0.0.0:7447`; for networks where multicast scouting does not
    /// pass.
    #[arg(long, value_name = "ENDPOINT")]
    zenoh_listen: Vec<String>,
    /// Connect to a member or router at this Zenoh endpoint (repeatable),
    /// e.g. `tcp/192.168.1.10:7447`.
    #[arg(long, value_name = "ENDPOINT")]
    zenoh_connect: Vec<String>,
    /// A Zenoh JSON5 configuration file (credentials, TLS, scouting);
    /// the flags above override its endpoints.
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<std::path::PathBuf>,
}

impl ZenohArgs {
    pub(crate) fn options(&self) -> seacover::agent::peer::session::ZenohOptions {
        seacover::agent::peer::session::ZenohOptions {
            mode: Default::default(),
            listen: self.zenoh_listen.clone(),
            connect: self.zenoh_connect.clone(),
            config: self.zenoh_config.clone(),
        }
    }
}

/// Zenoh's worker pools, unless `ZENOH_RUNTIME` says otherwise: its
/// defaults (2 receive workers, 1 transmit, 1 network) stop all receiving
/// for 10 s when TCP links to vanished peers are closed (Zenoh lingers on
/// each close for 10 s), which a peer fleet whose neighbours drop out of
/// radio range cannot afford. Set before any thread starts.
pub(crate) fn zenoh_runtime() {
    if std::env::var_os("ZENOH_RUNTIME").is_none() {
        // SAFETY: called first thing in `main`, before any other thread
        // exists that could read the environment.
        unsafe {
            std::env::set_var(
                "ZENOH_RUNTIME",
                "(rx: (worker_threads: 16), tx: (worker_threads: 16), net: (worker_threads: 16))",
            );
        }
    }
}
