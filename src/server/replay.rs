//! `seacover replay FILE`: the dashboard and the REST reads over a
//! recording, read-only.
//!
//! The replay serves the coordinator's own router: every read handler reads
//! the newest snapshot from the same `watch`, and here a player task, not a
//! tick task, publishes it — the state the recording held at the replay's
//! current time. What would change the mission or the fleet (REST writes,
//! vessel links, removals) reaches a task that answers 409. The player is
//! steered through `GET`/`PUT /api/v1/replay` (play, pause, speed, seek),
//! which the dashboard's replay bar uses.
//!
//! A seek reads only what the moment needs through the recording's chunk
//! index: the newest coverage and mission messages at or before it and the
//! poses, commands and peer beacons of the [`LOOKBACK`] before it.
//!
//! The H(P) history (`GET /api/v1/coverage/history`) is the coordinator's
//! bounded [`History`] over the recording's coverage channel up to the
//! replay's time: playing on reads only the coverage since the last
//! publication; a seek back reads it again from the start.
//!
//! The page is served marked as a replay's ([`PageMode::Replay`]), so the
//! dashboard shows "replay", hides its editing controls and steers the
//! player without asking first whether it is one.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicU64;
use std::time::Duration;

use axum::Json;
use axum::extract::State;
use axum::routing::get;
use serde::{Deserialize, Serialize};
use tokio::net::TcpListener;
use tokio::sync::{mpsc, oneshot, watch};
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use super::coordinator::history::History;
use super::coordinator::{CoordinatorError, Request, Snapshot as Published};
use super::error::ApiError;
use super::web::PageMode;
use super::{AppState, ServeError, router};
use crate::mission::MissionClock;
use crate::protocol::{
    CommandDocument, CoverageDocument, CoverageSampleDocument, MissionDocument, PoseDocument,
    Snapshot, SnapshotDocument, VesselStatusDocument,
};
use crate::recorder::Recorder;
use crate::recorder::messages::{
    self, BeaconRecord, CommandRecord, CoverageRecord, MissionRecord, PoseRecord,
};
use crate::recorder::reader::{ReadError, Recording};

/// How far back a moment's poses and commands are looked for [ns]: longer
/// than the liveness timeout, so every live vessel has one.
pub const LOOKBACK: u64 = 3_500_000_000;
/// How often a playing replay publishes.
const FRAME: Duration = Duration::from_millis(100);

/// `GET /api/v1/replay`, and what `PUT` answers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReplayStatus {
    pub file: String,
    /// Mission time of the recording's first and last message [s].
    pub start: f64,
    pub end: f64,
    /// The replay's current mission time [s].
    pub time: f64,
    pub playing: bool,
    /// Recording seconds per wall second.
    pub speed: f64,
}

/// `PUT /api/v1/replay`: any of these.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReplayControl {
    pub playing: Option<bool>,
    pub speed: Option<f64>,
    /// Seek to this mission time [s] (clamped to the recording).
    pub time: Option<f64>,
}

/// Why a replay could not start.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{0}: the recording holds no coverage (no tick was recorded)")]
    Empty(PathBuf),
    #[error("--speed must be a finite number > 0")]
    Speed,
    #[error(transparent)]
    Serve(#[from] ServeError),
}

enum Control {
    Get(oneshot::Sender<ReplayStatus>),
    Set(
        ReplayControl,
        oneshot::Sender<Result<ReplayStatus, ApiError>>,
    ),
}

#[derive(Clone)]
struct ReplayState {
    control: mpsc::Sender<Control>,
}

/// The state the recording held at `at` [ns]: the snapshot readers get.
pub fn snapshot_at(recording: &Recording, at: u64) -> Result<Option<Snapshot>, ReadError> {
    let Some(coverage) = recording.latest(messages::COVERAGE, at)? else {
        return Ok(None);
    };
    let Ok(coverage) = serde_json::from_slice::<CoverageRecord>(&coverage.data) else {
        return Ok(None);
    };
    let Some(mission) = recording
        .latest(messages::MISSION, at)?
        .and_then(|m| serde_json::from_slice::<MissionRecord>(&m.data).ok())
    else {
        return Ok(None);
    };
    let mission: MissionDocument = mission.mission;
    let mut poses: HashMap<String, PoseDocument> = HashMap::new();
    let mut commands: HashMap<String, CommandDocument> = HashMap::new();
    // A peer fleet's member (`serve --peer`) records its vessels' beacons,
    // not poses: each tells its vessel's pose.
    let wanted =
        |t: &str| t == messages::POSE || t == messages::COMMAND || t == messages::PEER_BEACON;
    for m in recording.window(at.saturating_sub(LOOKBACK), at, &wanted)? {
        match &*m.topic {
            messages::POSE => {
                if let Ok(p) = serde_json::from_slice::<PoseRecord>(&m.data) {
                    poses.insert(p.vessel, p.pose);
                }
            }
            messages::PEER_BEACON => {
                if let Ok(b) = serde_json::from_slice::<BeaconRecord>(&m.data) {
                    poses.insert(b.beacon.id.clone(), b.beacon.pose());
                }
            }
            _ => {
                if let Ok(c) = serde_json::from_slice::<CommandRecord>(&m.data) {
                    commands.insert(c.vessel, c.command);
                }
            }
        }
    }
    let cells: Vec<crate::protocol::CellDocument> =
        coverage.cells.iter().map(|c| c.document()).collect();
    let by_id: HashMap<&str, &crate::protocol::CellDocument> =
        cells.iter().map(|c| (c.id.as_str(), c)).collect();
    let vessels = coverage
        .vessels
        .iter()
        .map(|v| {
            let cell = by_id.get(v.id.as_str()).copied();
            VesselStatusDocument {
                id: v.id.clone(),
                connected: v.connected,
                live: v.live,
                controlled: v.controlled,
                pose: poses.get(&v.id).cloned(),
                actuator: v.actuator.unwrap_or(mission.actuator),
                polygon: cell.and_then(|c| c.polygon.clone()),
                edges: cell.map_or_else(Vec::new, |c| c.edges.clone()),
                mass: cell.map_or(0.0, |c| c.mass),
                centroid: cell.map(|c| c.centroid),
                last_command: commands.get(&v.id).cloned(),
                last_seen: v.last_seen,
                neighbours: None,
                quarantine: None,
            }
        })
        .collect();
    Ok(Some(Snapshot {
        document: SnapshotDocument {
            tick: coverage.tick,
            time: coverage.time,
            h: coverage.h,
            mission,
            vessels,
        },
        coverage: CoverageDocument {
            tick: coverage.tick,
            time: coverage.time,
            h: coverage.h,
            cells,
        },
    }))
}

/// Tick, time and H of the coverage messages logged in `[from, to]` [ns],
/// oldest first.
pub fn coverage_samples(
    recording: &Recording,
    from: u64,
    to: u64,
) -> Result<Vec<CoverageSampleDocument>, ReadError> {
    /// A coverage message's figures; its cells and vessels are skipped.
    #[derive(Deserialize)]
    struct Figures {
        tick: u64,
        time: f64,
        #[serde(rename = "H")]
        h: f64,
    }
    if from > to {
        return Ok(Vec::new());
    }
    Ok(recording
        .window(from, to, &|t| t == messages::COVERAGE)?
        .iter()
        .filter_map(|m| serde_json::from_slice::<Figures>(&m.data).ok())
        .map(|f| CoverageSampleDocument {
            tick: f.tick,
            time: f.time,
            h: f.h,
        })
        .collect())
}

/// Serves the replay of `file` on `listener` until `shutdown`.
pub async fn serve(
    listener: TcpListener,
    file: PathBuf,
    speed: f64,
    shutdown: CancellationToken,
) -> Result<(), ReplayError> {
    if !(speed.is_finite() && speed > 0.0) {
        return Err(ReplayError::Speed);
    }
    let addr = listener.local_addr().map_err(ServeError::from)?;
    if !addr.ip().is_loopback() {
        // Read-only, but a recording is an operator's data: loopback only,
        // as an unauthenticated coordinator.
        return Err(ServeError::PublicWithoutToken(addr).into());
    }
    let recording = {
        let file = file.clone();
        tokio::task::spawn_blocking(move || Recording::open(&file))
            .await
            .expect("opening does not panic")?
    };
    let (start, end) = recording.span().ok_or(ReplayError::Empty(file.clone()))?;
    // The first moment with a whole state: the first coverage message.
    let first = recording
        .messages(&|t| t == messages::COVERAGE)
        .next()
        .and_then(Result::ok)
        .map(|m| m.log_time)
        .ok_or(ReplayError::Empty(file.clone()))?;
    let initial = snapshot_at(&recording, first)?.ok_or(ReplayError::Empty(file.clone()))?;
    let mut history = History::new();
    for s in coverage_samples(&recording, 0, first)? {
        history.push(s.tick, s.time, s.h);
    }
    super::metrics::handle();
    let (snapshot_tx, snapshot) = watch::channel(Arc::new(Published {
        state: Arc::new(initial),
        history: history.document(),
    }));
    let (requests, refusals) = mpsc::channel(64);
    let tracker = TaskTracker::new();
    let app = AppState {
        token: None,
        requests,
        snapshot,
        tracker: tracker.clone(),
        shutdown: shutdown.clone(),
        next_link: Arc::new(AtomicU64::new(1)),
        writes: Arc::new(super::app::write_limiter(50, 100)),
        recorder: Recorder::off(),
        clock: MissionClock::first_tick_now(1.0, 10.0),
    };
    let (control, controls) = mpsc::channel(16);
    let player = Player {
        recording: Arc::new(recording),
        file: file.display().to_string(),
        start,
        end,
        at: first,
        playing: true,
        speed,
        out: snapshot_tx,
        history,
        read_to: first,
    };
    let tasks = [
        tokio::spawn(refuse_writes(refusals, shutdown.clone())),
        tokio::spawn(player.run(controls, shutdown.clone())),
    ];
    let replay = ReplayState { control };
    let routes = router(app)
        .merge(
            axum::Router::new()
                .route("/api/v1/replay", get(status).put(set))
                .with_state(replay),
        )
        .layer(axum::Extension(PageMode::Replay));
    let signal = shutdown.clone();
    axum::serve(
        listener,
        routes.into_make_service_with_connect_info::<SocketAddr>(),
    )
    .with_graceful_shutdown(async move { signal.cancelled().await })
    .await
    .map_err(ServeError::from)?;
    tracker.close();
    let _ = tokio::time::timeout(Duration::from_millis(1500), tracker.wait()).await;
    for t in tasks {
        let _ = t.await;
    }
    Ok(())
}

/// What would change the mission or the fleet: 409.
async fn refuse_writes(mut requests: mpsc::Receiver<Request>, shutdown: CancellationToken) {
    let refusal = || CoordinatorError::ReadOnly;
    loop {
        let request = tokio::select! {
            _ = shutdown.cancelled() => return,
            r = requests.recv() => match r { Some(r) => r, None => return },
        };
        match request {
            Request::Register { reply, .. } => {
                let _ = reply.send(Err(refusal()));
            }
            Request::Change { reply, .. } => {
                let _ = reply.send(Err(refusal()));
            }
            Request::Forget { reply, .. } => {
                let _ = reply.send(Err(refusal()));
            }
            Request::Samples { reply, .. } => {
                let _ = reply.send(Err(refusal()));
            }
            Request::RecentSamples { reply } => {
                let _ = reply.send(Err(refusal()));
            }
            // Unanswered: the handler then answers the recorded mission's
            // risk.
            Request::Belief { .. }
            | Request::LinkSample { .. }
            | Request::Gone { .. }
            | Request::PeerNeighbours(_) => {}
        }
    }
}

struct Player {
    recording: Arc<Recording>,
    file: String,
    start: u64,
    end: u64,
    at: u64,
    playing: bool,
    speed: f64,
    out: watch::Sender<Arc<Published>>,
    /// H(P) of the coverage messages logged up to `read_to` [ns].
    history: History,
    read_to: u64,
}

impl Player {
    fn status(&self) -> ReplayStatus {
        ReplayStatus {
            file: self.file.clone(),
            start: self.start as f64 * 1e-9,
            end: self.end as f64 * 1e-9,
            time: self.at as f64 * 1e-9,
            playing: self.playing,
            speed: self.speed,
        }
    }

    /// Publishes the state at the current time and the history up to it
    /// (decoding off the runtime's worker threads).
    async fn publish(&mut self) {
        let (recording, at) = (self.recording.clone(), self.at);
        // Forwards, the coverage since the last publication; backwards,
        // all of it again.
        let back = at < self.read_to;
        let from = if back { 0 } else { self.read_to + 1 };
        let built = tokio::task::spawn_blocking(move || {
            Ok::<_, ReadError>((
                snapshot_at(&recording, at)?,
                coverage_samples(&recording, from, at)?,
            ))
        })
        .await;
        match built {
            Ok(Ok((snapshot, samples))) => {
                if back {
                    self.history = History::new();
                }
                for s in samples {
                    self.history.push(s.tick, s.time, s.h);
                }
                self.read_to = at;
                if let Some(snapshot) = snapshot {
                    self.out.send_replace(Arc::new(Published {
                        state: Arc::new(snapshot),
                        history: self.history.document(),
                    }));
                }
            }
            Ok(Err(e)) => tracing::warn!(error = %crate::chain::Chain(&e), "reading the recording"),
            Err(e) => tracing::warn!(error = %e, "reading the recording"),
        }
    }

    async fn run(mut self, mut controls: mpsc::Receiver<Control>, shutdown: CancellationToken) {
        let mut frame = tokio::time::interval(FRAME);
        frame.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        loop {
            tokio::select! {
                _ = shutdown.cancelled() => return,
                _ = frame.tick() => {
                    if self.playing {
                        let step = (FRAME.as_secs_f64() * self.speed * 1e9) as u64;
                        self.at = (self.at + step).min(self.end);
                        if self.at >= self.end {
                            self.playing = false;
                        }
                        self.publish().await;
                    }
                }
                control = controls.recv() => match control {
                    None => return,
                    Some(Control::Get(reply)) => { let _ = reply.send(self.status()); }
                    Some(Control::Set(c, reply)) => {
                        if let Some(s) = c.speed && !(s.is_finite() && s > 0.0 && s <= 1000.0) {
                            let _ = reply.send(Err(ApiError::Invalid("speed: must be a number in (0, 1000]".into())));
                            continue;
                        }
                        if let Some(t) = c.time && !t.is_finite() {
                            let _ = reply.send(Err(ApiError::Invalid("time: must be a finite number".into())));
                            continue;
                        }
                        if let Some(s) = c.speed { self.speed = s; }
                        if let Some(p) = c.playing { self.playing = p; }
                        if let Some(t) = c.time {
                            self.at = ((t.max(0.0) * 1e9) as u64).clamp(self.start, self.end);
                        }
                        // Answered once the state at the new time is out,
                        // so a reader after the answer sees it.
                        self.publish().await;
                        let _ = reply.send(Ok(self.status()));
                    }
                },
            }
        }
    }
}

/// `GET /api/v1/replay`.
async fn status(State(replay): State<ReplayState>) -> Result<Json<ReplayStatus>, ApiError> {
    let (tx, rx) = oneshot::channel();
    replay
        .control
        .send(Control::Get(tx))
        .await
        .map_err(|_| ApiError::ShuttingDown)?;
    rx.await.map(Json).map_err(|_| ApiError::ShuttingDown)
}

/// `PUT /api/v1/replay`.
async fn set(
    State(replay): State<ReplayState>,
    body: axum::body::Bytes,
) -> Result<Json<ReplayStatus>, ApiError> {
    let control: ReplayControl = serde_json::from_slice(&body).map_err(|e| {
        let why = crate::protocol::json_error(&e);
        ApiError::Malformed(format!("expected {{playing, speed, time}}: {why}"))
    })?;
    let (tx, rx) = oneshot::channel();
    replay
        .control
        .send(Control::Set(control, tx))
        .await
        .map_err(|_| ApiError::ShuttingDown)?;
    rx.await.map_err(|_| ApiError::ShuttingDown)?.map(Json)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::peer::BeaconDocument;
    use crate::recorder::{Entry, Recorder, RecorderConfig, Target};

    /// A `serve --peer` recording holds beacons, not poses: the replay
    /// shows each vessel where its last beacon put it.
    #[test]
    fn a_peer_members_recording_shows_its_boats() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("peer.mcap");
        let (recorder, thread) = Recorder::start(
            RecorderConfig {
                target: Target::File(file.clone()),
                wall_clock: false,
            },
            true,
        );
        let mission = crate::mission::Mission::from_text(crate::mission::PAPER_SCENARIO)
            .unwrap()
            .document();
        recorder.mission(0.0, mission.clone());
        let beacon = |id: &str, x: f64| BeaconDocument {
            id: id.into(),
            seq: 1,
            t: 1.0,
            x,
            y: 20.0,
            psi: 0.5,
            u: 0.3,
            v: 0.0,
            r: 0.01,
            k: 0.5,
            beta: 0.001,
            rev: 0,
            controlled: true,
        };
        recorder.beacon(0.9, &beacon("usv-1", 10.0));
        recorder.beacon(0.95, &beacon("usv-2", 30.0));
        let status = |id: &str| VesselStatusDocument {
            id: id.into(),
            connected: true,
            live: true,
            controlled: true,
            pose: None,
            actuator: mission.actuator,
            polygon: None,
            edges: Vec::new(),
            mass: 0.0,
            centroid: None,
            last_command: None,
            last_seen: Some(0.95),
            neighbours: None,
            quarantine: None,
        };
        recorder.record(Entry::Tick(std::sync::Arc::new(Snapshot {
            document: SnapshotDocument {
                tick: 10,
                time: 1.0,
                h: 1.0,
                mission: mission.clone(),
                vessels: vec![status("usv-1"), status("usv-2")],
            },
            coverage: CoverageDocument {
                tick: 10,
                time: 1.0,
                h: 1.0,
                cells: Vec::new(),
            },
        })));
        recorder.finish();
        thread.join();

        let recording = Recording::open(&file).unwrap();
        let snapshot = snapshot_at(&recording, 1_000_000_000).unwrap().unwrap();
        let poses: Vec<_> = snapshot
            .document
            .vessels
            .iter()
            .map(|v| (v.id.as_str(), v.pose.as_ref().map(|p| (p.x, p.y))))
            .collect();
        assert_eq!(
            poses,
            [("usv-1", Some((10.0, 20.0))), ("usv-2", Some((30.0, 20.0)))]
        );
    }
}
