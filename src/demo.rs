//! `seacover demo`: the coordinator and the paper's eight simulated vessels
//! in one process, on real loopback sockets — what `main` runs and what the
//! networked tracking test (`tests/it/tracking.rs`) runs, so the two cannot
//! drift apart.
//!
//! Invariant: the vessels are ordinary agents ([`run_fleet`]) on WebSocket
//! links to the listener's address; nothing is shared in memory between
//! them and the coordinator.

use std::path::PathBuf;

use tokio::net::TcpListener;
use tokio_util::sync::CancellationToken;

use crate::agent::{AgentConfig, paper_vessels, run_fleet};
use crate::control::model::VesselParams;
use crate::recorder::{RecorderConfig, Target};
use crate::server::{ServeConfig, ServeError, serve};

/// Agents' pose rate [Hz] (docs/api.md).
const POSE_HZ: f64 = 20.0;

/// Runs the coordinator on `listener` and the eight vessels of the paper's
/// scenario, connected to it, until `stop`; with `record`, the run is
/// recorded as MCAP files in that directory.
pub async fn run(
    listener: TcpListener,
    time_warp: f64,
    token: Option<String>,
    record: Option<PathBuf>,
    stop: CancellationToken,
) -> Result<(), ServeError> {
    let addr = listener.local_addr()?;
    // Refused before anything starts: the vessels would retry for ever
    // against a coordinator that never came up.
    crate::server::check_bind(addr, token.as_deref())?;
    let config = ServeConfig {
        time_warp,
        token: token.clone(),
        record: record.map(|dir| RecorderConfig {
            target: Target::directory(dir),
            wall_clock: true,
        }),
        ..Default::default()
    };
    let server = tokio::spawn(serve(listener, config, stop.clone()));
    let agents = AgentConfig {
        url: format!("ws://{addr}/api/v1/vessels/link"),
        time_warp,
        pose_hz: POSE_HZ,
        seed: 1,
        token,
    };
    let fleet = tokio::spawn(run_fleet(
        agents,
        paper_vessels(VesselParams::PAPER),
        stop.clone(),
    ));
    // Both end on `stop`; a task that panicked is a bug worth its panic.
    // The demo's vessels carry the coordinator's own token: a refusal
    // would be a bug, said rather than hidden.
    if let Err(e) = fleet.await.expect("the demo fleet does not panic") {
        tracing::error!(error = %e, "the demo's vessels gave up");
    }
    server.await.expect("the coordinator does not panic")
}
