//! `seacover serve`: the coordinator (SPEC §3). Router and start-up here; the
//! tick task and its state in [`state`], WebSocket endpoints in [`ws`], REST
//! in [`api`], the HTTP error type in [`error`].
//!
//! Shutdown: cancelling the token stops accepting connections, makes the tick
//! task send every vessel `shutting_down`, and waits (bounded) for every
//! tracked WebSocket task.

pub mod api;
pub mod auth;
pub mod error;
pub mod metrics;
pub mod state;
pub mod ws;

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::AtomicU64;
use std::time::Duration;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::routing::{get, post, put};
use tokio::net::TcpListener;
use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use state::{Coordinator, Mission, Request, Snapshot, TickSettings};

/// Shared by every handler; cheap to clone.
#[derive(Clone)]
pub struct AppState {
    /// Required for writes and vessel links when set.
    pub token: Option<Arc<str>>,
    pub requests: mpsc::Sender<Request>,
    pub snapshot: watch::Receiver<Arc<Snapshot>>,
    pub tracker: TaskTracker,
    pub shutdown: CancellationToken,
    pub next_link: Arc<AtomicU64>,
}

/// Server settings.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    pub mission: Mission,
    /// Bearer token for writes and vessel links; without one only loopback
    /// addresses are served.
    pub token: Option<String>,
    pub time_warp: f64,
    /// Mission seconds of silence after which a vessel leaves the partition.
    pub liveness: f64,
}

impl Default for ServeConfig {
    fn default() -> Self {
        ServeConfig {
            mission: Mission::paper(),
            token: None,
            time_warp: 1.0,
            liveness: 3.0,
        }
    }
}

/// Why the server stopped abnormally.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    #[error(
        "refusing to bind {0} without a token: only loopback addresses may be served unauthenticated"
    )]
    PublicWithoutToken(SocketAddr),
    #[error("serving: {0}")]
    Io(#[from] std::io::Error),
}

/// Every route of SPEC §3 implemented so far.
pub fn router(app: AppState) -> Router {
    let writes = Router::new()
        .route("/api/v1/mission/region", put(api::put_region))
        .route("/api/v1/mission/risk/base", put(api::put_base))
        .route("/api/v1/risk-objects", post(api::post_object))
        .route(
            "/api/v1/risk-objects/{id}",
            put(api::put_object).delete(api::delete_object),
        )
        .route("/api/v1/vessels/link", get(ws::link))
        .route_layer(axum::middleware::from_fn_with_state(
            app.clone(),
            auth::require_token,
        ));
    Router::new()
        .merge(writes)
        .route("/healthz", get(api::healthz))
        .route("/metrics", get(metrics::render))
        .route("/api/v1/mission", get(api::mission))
        .route("/api/v1/risk-objects", get(api::risk_objects))
        .route("/api/v1/risk-objects/{id}", get(api::get_object))
        .route("/api/v1/vessels", get(api::vessels))
        .route("/api/v1/vessels/{id}", get(api::vessel))
        .route("/api/v1/coverage", get(api::coverage))
        .route("/api/v1/coverage/evaluate", post(api::evaluate))
        .route("/api/v1/stream", get(ws::stream))
        .layer(DefaultBodyLimit::max(1024 * 1024))
        .with_state(app)
}

/// Serves on `listener` until `shutdown` is cancelled.
pub async fn serve(
    listener: TcpListener,
    config: ServeConfig,
    shutdown: CancellationToken,
) -> Result<(), ServeError> {
    let addr = listener.local_addr()?;
    if !addr.ip().is_loopback() && config.token.is_none() {
        return Err(ServeError::PublicWithoutToken(addr));
    }
    metrics::handle();
    let (coordinator, snapshot) = Coordinator::new(
        config.mission,
        TickSettings {
            time_warp: config.time_warp,
            liveness: config.liveness,
        },
    );
    let (requests, rx) = mpsc::channel(1024);
    let tracker = TaskTracker::new();
    let tick = tokio::spawn(coordinator.run(rx, shutdown.clone()));
    let app = AppState {
        token: config.token.map(Arc::from),
        requests,
        snapshot,
        tracker: tracker.clone(),
        shutdown: shutdown.clone(),
        next_link: Arc::new(AtomicU64::new(1)),
    };
    let signal = shutdown.clone();
    axum::serve(listener, router(app))
        .with_graceful_shutdown(async move { signal.cancelled().await })
        .await?;
    tracker.close();
    let _ = tokio::time::timeout(Duration::from_millis(1500), tracker.wait()).await;
    let _ = tick.await;
    Ok(())
}
