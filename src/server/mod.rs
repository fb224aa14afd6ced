//! `seacover serve`: the coordinator (docs/api.md). Router and start-up here; the
//! tick task and its state in [`coordinator`], WebSocket endpoints in [`ws`], REST
//! in [`api`], the HTTP error type in [`error`].
//!
//! Shutdown: cancelling the token stops accepting connections, makes the tick
//! task send every vessel `shutting_down`, and waits (bounded) for every
//! tracked WebSocket task.

mod api;
mod app;
mod auth;
mod close;
pub mod config;
mod coordinator;
mod error;
mod events;
pub mod metrics;
pub mod openapi;
pub mod peer;
pub mod replay;
mod responses;
mod store;
mod web;
mod ws;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicU64;
use std::time::Duration;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::routing::{delete, get, post, put};
use axum::serve::ListenerExt as _;
use tokio::net::TcpListener;
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use crate::mission::Mission;
use crate::mission::MissionClock;
use crate::recorder::{Recorder, RecorderConfig};
pub use app::AppState;
pub use coordinator::LearnSettings;
use coordinator::{Coordinator, TickSettings};
pub use error::MAX_BODY;

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
    /// Where the mission is stored; `None` keeps it in memory only. When the
    /// store already holds a mission, that one is served and `mission` is
    /// ignored; otherwise `mission` seeds the store.
    pub data_dir: Option<PathBuf>,
    /// Writes per second allowed, and the burst.
    pub write_rate: u32,
    pub write_burst: u32,
    /// Where the run is recorded; `None`: not recorded.
    pub record: Option<RecorderConfig>,
    /// Where `mission` comes from, for the log line that says a new data
    /// directory was seeded with it.
    pub mission_source: String,
    /// Join this peer fleet as a member (`serve --peer`).
    pub peer: Option<peer::PeerMember>,
    /// Learn the risk map from samples (`[learning]` of `--config`).
    pub learning: Option<LearnSettings>,
}

impl Default for ServeConfig {
    fn default() -> Self {
        ServeConfig {
            mission: Mission::paper(),
            token: None,
            time_warp: 1.0,
            liveness: 3.0,
            data_dir: None,
            write_rate: 50,
            write_burst: 100,
            record: None,
            mission_source: "the built-in paper scenario".into(),
            peer: None,
            learning: None,
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
    #[error("serving")]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Store(#[from] store::StoreError),
    #[error("--peer")]
    Peer(#[from] crate::agent::peer::PeerError),
    #[error("the mission stored in {path} is not valid")]
    StoredMission {
        path: PathBuf,
        source: crate::mission::MissionError,
    },
}

/// Every route of docs/api.md.
pub fn router(app: AppState) -> Router {
    let writes = Router::new()
        .route("/api/v1/mission/origin", put(api::put_origin))
        .route("/api/v1/mission/region", put(api::put_region))
        .route("/api/v1/mission/risk/base", put(api::put_base))
        .route("/api/v1/mission/risk/raster", put(api::put_raster))
        .route("/api/v1/risk-objects", post(api::post_object))
        .route(
            "/api/v1/risk-objects/{id}",
            put(api::put_object).delete(api::delete_object),
        )
        .route("/api/v1/vessels/{id}", delete(api::delete_vessel))
        .route("/api/v1/vessels/link", get(ws::link))
        .route("/api/v1/samples", post(api::post_samples))
        // The token is checked first, so strangers cannot spend the budget.
        .route_layer(axum::middleware::from_fn_with_state(
            app.clone(),
            auth::limit_writes,
        ))
        .route_layer(axum::middleware::from_fn_with_state(
            app.clone(),
            auth::require_token,
        ));
    Router::new()
        .merge(writes)
        .route("/", get(web::index))
        .route("/{file}", get(web::asset))
        .route("/healthz", get(api::healthz))
        .route("/metrics", get(metrics::render))
        .route("/api/v1/openapi.json", get(openapi::serve))
        .route("/api/v1/mission", get(api::mission))
        .route("/api/v1/risk-objects", get(api::risk_objects))
        .route("/api/v1/risk", get(api::risk))
        .route("/api/v1/samples", get(api::get_samples))
        .route("/api/v1/risk-objects/{id}", get(api::get_object))
        .route("/api/v1/vessels", get(api::vessels))
        .route("/api/v1/vessels/{id}", get(api::vessel))
        .route("/api/v1/coverage", get(api::coverage))
        .route("/api/v1/coverage.geojson", get(api::coverage_geojson))
        .route("/api/v1/coverage/evaluate", post(api::evaluate))
        .route("/api/v1/coverage/history", get(api::coverage_history))
        .route("/api/v1/stream", get(ws::stream))
        .fallback(error::not_found)
        .method_not_allowed_fallback(error::method_not_allowed)
        .layer(axum::middleware::map_response(error::json_too_large))
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .layer(axum::middleware::from_fn_with_state(
            app.clone(),
            events::record_rejections,
        ))
        .layer(axum::middleware::from_fn(close::unread_bodies))
        .with_state(app)
}

/// Serves on `listener` until `shutdown` is cancelled: [`prepare`], then
/// [`Prepared::run`].
pub async fn serve(
    listener: TcpListener,
    config: ServeConfig,
    shutdown: CancellationToken,
) -> Result<(), ServeError> {
    prepare(listener, config, shutdown).await?.run().await
}

/// A coordinator that has passed every check of its start (the address
/// and token, the data directory and its lock, the stored mission) and
/// whose tick task runs, but that accepts no connection yet: what a process
/// says when it starts ("serving on …") is true only after this.
pub struct Prepared {
    listener: TcpListener,
    app: AppState,
    tracker: TaskTracker,
    tick: tokio::task::JoinHandle<()>,
    recorder: Recorder,
    recording: Option<crate::recorder::RecorderThread>,
    shutdown: CancellationToken,
    peer: Option<peer::PeerMember>,
}

/// Refuses to serve `addr` off loopback without a token.
pub fn check_bind(addr: SocketAddr, token: Option<&str>) -> Result<(), ServeError> {
    if !addr.ip().is_loopback() && token.is_none() {
        return Err(ServeError::PublicWithoutToken(addr));
    }
    Ok(())
}

/// Checks the start and starts the tick task; see [`Prepared`].
pub async fn prepare(
    listener: TcpListener,
    config: ServeConfig,
    shutdown: CancellationToken,
) -> Result<Prepared, ServeError> {
    let addr = listener.local_addr()?;
    check_bind(addr, config.token.as_deref())?;
    if let Some(member) = &config.peer {
        // A bad Zenoh configuration stops the start, not the member later.
        member.zenoh.config()?;
        if !crate::agent::peer::wire::valid_fleet(&member.fleet) {
            return Err(crate::agent::peer::PeerError::Fleet.into());
        }
    }
    metrics::handle();
    // Provisional: this coordinator's mission is only what it started with
    // (an empty store, or none), so it re-tasks no vessel that follows
    // another (docs/api.md, the vessel link).
    let mut provisional = true;
    let (mission, store) = match &config.data_dir {
        Some(dir) => {
            let store = store::Store::open(dir)?;
            let mission = match store.load()? {
                Some(doc) => {
                    let mission = Mission::from_document(&doc).map_err(|source| {
                        ServeError::StoredMission {
                            path: store.path().to_path_buf(),
                            source,
                        }
                    })?;
                    tracing::info!(
                        path = %store.path().display(),
                        objects = mission.objects().len(),
                        "serving the stored mission (a --config mission only seeds an empty data directory)"
                    );
                    provisional = false;
                    mission
                }
                None => {
                    store.save(&config.mission.document())?;
                    tracing::info!(
                        path = %store.path().display(),
                        mission = %config.mission_source,
                        "new store seeded"
                    );
                    config.mission
                }
            };
            (mission, Some(store))
        }
        None => (config.mission, None),
    };
    let (recorder, recording) = match config.record {
        Some(c) => {
            let (r, t) = Recorder::start(c, false);
            (r, Some(t))
        }
        None => (Recorder::off(), None),
    };
    let clock = MissionClock::first_tick_now(config.time_warp, mission.tick_hz());
    let (coordinator, snapshot) = Coordinator::new(
        mission,
        TickSettings {
            time_warp: config.time_warp,
            liveness: config.liveness,
            limits: crate::control::plausibility::Limits::default(),
            learning: config.learning,
        },
        store,
    );
    let mut coordinator = coordinator.recording(recorder.clone(), clock);
    if provisional {
        coordinator = coordinator.provisional();
    }
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
        writes: Arc::new(app::write_limiter(config.write_rate, config.write_burst)),
        recorder: recorder.clone(),
        clock,
    };
    Ok(Prepared {
        listener,
        app,
        tracker,
        tick,
        recorder,
        recording,
        shutdown,
        peer: config.peer,
    })
}

impl Prepared {
    /// Where it will serve.
    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Serves until the shutdown token is cancelled, then stops the links,
    /// the tick task and the recording in that order.
    pub async fn run(self) -> Result<(), ServeError> {
        let Prepared {
            listener,
            app,
            tracker,
            tick,
            recorder,
            recording,
            shutdown,
            peer,
        } = self;
        if let Some(member) = peer {
            let (app, stop) = (app.clone(), shutdown.clone());
            tracker.spawn(async move {
                if let Err(e) = self::peer::run(member, app, stop).await {
                    tracing::error!(error = %crate::chain::Chain(&e), "the peer fleet member stopped");
                }
            });
        }
        // Commands and poses are small frames that must leave at once:
        // without TCP_NODELAY a command written while the link's previous
        // frame is unacknowledged waits for the vessel's delayed ACK (up to
        // 40 ms).
        let listener = listener.tap_io(|tcp| {
            if let Err(e) = tcp.set_nodelay(true) {
                tracing::warn!(error = %e, "TCP_NODELAY could not be set on a connection");
            }
        });
        // With the peers' addresses, for the recording's events.
        let service = router(app).into_make_service_with_connect_info::<SocketAddr>();
        axum::serve(listener, service)
            .with_graceful_shutdown(async move { shutdown.cancelled().await })
            .await?;
        tracker.close();
        let _ = tokio::time::timeout(Duration::from_millis(1500), tracker.wait()).await;
        let _ = tick.await;
        // The tick task has recorded the shutdown: finish the file.
        if let Some(thread) = recording {
            recorder.finish();
            let _ = tokio::task::spawn_blocking(move || thread.join()).await;
        }
        Ok(())
    }
}
