//! The coordinator's state and the tick task that owns it.
//!
//! Invariants:
//! - one task ([`Coordinator::run`]) owns the mission and the fleet; links and
//!   HTTP handlers talk to it through a bounded channel of [`Request`]s and
//!   read the newest [`Snapshot`] from a `watch`; no lock is ever held across
//!   an `.await`;
//! - a tick that overruns makes the next ones be skipped
//!   (`MissedTickBehavior::Skip`), never queued; skipped ticks keep their
//!   numbers, so tick N is always mission time N / tick_hz and is due at
//!   wall time origin + N / (tick_hz × time warp);
//! - mission time is in mission seconds whatever the time warp, so guidance
//!   filters and liveness are in mission seconds;
//! - a tick is pipelined: once the partition is known, each vessel's cell,
//!   goal, filter and command are computed on their own (on every core for
//!   64 vessels or more) and the command is handed to its link as soon as it
//!   is ready; cells, H and commands are bit for bit those of
//!   [`evaluate`] and [`SafetyLayer::commands`](crate::control::safety::SafetyLayer::commands)
//!   (the functions `seacover sim` calls);
//! - the snapshot for readers is built after the tick's commands are
//!   written (or half a period later at most), never while the links are
//!   writing them.

mod error;
pub(super) mod history;
mod judging;
mod learning;
mod requests;
#[cfg(test)]
mod tests;
mod tick;

use std::collections::{BTreeMap, BTreeSet};
use std::ops::Deref;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::Utf8Bytes;
use tokio::sync::{mpsc, oneshot, watch};
use tokio_util::sync::CancellationToken;

use super::error::ApiError;
use super::store::Store;
use crate::control::barrier::Scratch;
use crate::control::guidance::Guidance;
use crate::control::model::State;
use crate::control::plausibility::Limits;
use crate::coverage::cells::cells_with;
use crate::coverage::evaluate::cell_figures;
use crate::coverage::{CellResult, Evaluation, Fleet, Options, Vessel, evaluate};
use crate::geometry::Point;
use crate::mission::scenario::evaluation_document;
use crate::mission::{ChangeResult, Mission, MissionChange, MissionClock};
use crate::protocol::{
    ActuatorDocument, AgilityDocument, CommandDocument, CoordinatorMessage, CoverageDocument,
    CoverageHistoryDocument, MissionDocument, PoseDocument, SnapshotDocument, VesselStatusDocument,
};
use crate::recorder::messages::{EventKind, EventRecord};
use crate::recorder::{Entry as RecorderEntry, Recorder};
pub(super) use error::CoordinatorError;
pub use learning::LearnSettings;

/// What links and handlers ask of the tick task.
#[derive(Debug)]
pub enum Request {
    /// A link said hello. The reply carries the tick rate.
    Register {
        id: String,
        link: u64,
        actuator: Option<ActuatorDocument>,
        /// The vessel can thrust astern (its hello's `astern`, default
        /// true); without, its guidance is ahead only.
        astern: bool,
        /// The command rates it can follow (its hello's `agility`).
        agility: Option<AgilityDocument>,
        /// The mission it says it follows (its hello's `mission`).
        mission: Option<String>,
        /// Within this of its goal it holds a position by itself (its
        /// hello's `station_radius`).
        station_radius: Option<f64>,
        tx: mpsc::Sender<Outgoing>,
        /// The link's newest pose. A slot rather than a request per pose:
        /// the tick only ever wants the newest, and 1000 vessels at 20 Hz
        /// would otherwise wake this task 20,000 times a second.
        poses: watch::Receiver<Option<PoseDocument>>,
        reply: oneshot::Sender<Result<Welcomed, CoordinatorError>>,
    },
    /// A link closed.
    Gone { id: String, link: u64 },
    /// `DELETE /api/v1/vessels/{id}`: forget the vessel; its link, if any, is
    /// told `removed` and closed.
    Forget {
        id: String,
        reply: oneshot::Sender<Result<(), CoordinatorError>>,
    },
    /// A peer fleet's vessels' own neighbour counts (`serve --peer`).
    PeerNeighbours(BTreeMap<String, u32>),
    /// `POST /api/v1/samples`: each sample judged on its own.
    Samples {
        samples: Vec<crate::protocol::SampleDocument>,
        reply: oneshot::Sender<Result<crate::protocol::SamplesAnswerDocument, CoordinatorError>>,
    },
    /// A sample on vessel `vessel`'s link; a refusal is answered there.
    LinkSample {
        vessel: String,
        sample: crate::protocol::LinkSampleDocument,
    },
    /// `GET /api/v1/samples`: the newest samples taken.
    RecentSamples {
        reply: oneshot::Sender<Result<crate::protocol::SamplesDocument, CoordinatorError>>,
    },
    /// `GET /api/v1/risk`: the density the fleet covers.
    Belief {
        reply: oneshot::Sender<crate::protocol::BeliefDocument>,
    },
    /// An operator's change to the mission; the reply is the changed
    /// document's new state.
    Change {
        change: MissionChange,
        reply: oneshot::Sender<Result<ChangeResult, CoordinatorError>>,
    },
}

/// What a vessel declared in its hello.
struct Hello {
    actuator: Option<ActuatorDocument>,
    astern: bool,
    agility: Option<AgilityDocument>,
    mission: Option<String>,
    station_radius: Option<f64>,
}

/// What a registered link says in its welcome.
#[derive(Debug, Clone, PartialEq)]
pub struct Welcomed {
    pub tick_hz: f64,
    /// The mission's name ([`mission_name`]); `None` for a vessel held for
    /// following another, which keeps that one's name.
    pub mission: Option<String>,
}

/// A mission's name on the vessel link: the first 64 bits of the SHA-1 of
/// its document's JSON, in hex. The same mission has the same name on any
/// coordinator (a restarted one given the same `--config`), so only a
/// different mission makes a vessel's hello disagree.
pub(super) fn mission_name(document: &MissionDocument) -> String {
    use sha1::Digest;
    let json = serde_json::to_vec(document).expect("a mission document serializes");
    sha1::Sha1::digest(&json)[..8]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// What readers get from the tick task's `watch`: the newest state (the
/// protocol's [`Snapshot`](crate::protocol::Snapshot), which the recorder
/// is handed too) and the H(P) history up to it ([`history`]). It derefs
/// to the state, so readers write `snapshot.document` and
/// `snapshot.coverage`.
#[derive(Debug, Clone)]
pub struct Snapshot {
    pub state: Arc<crate::protocol::Snapshot>,
    pub history: Arc<CoverageHistoryDocument>,
}

impl Deref for Snapshot {
    type Target = crate::protocol::Snapshot;

    fn deref(&self) -> &crate::protocol::Snapshot {
        &self.state
    }
}

/// Settings of the tick task.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct TickSettings {
    /// Wall-clock speed-up (MOOS-IvP's time warp).
    pub time_warp: f64,
    /// A vessel silent longer than this (mission seconds) leaves the partition.
    pub liveness: f64,
    /// What a vessel's poses must keep to (per vessel; a refusal
    /// quarantines that vessel alone).
    pub limits: Limits,
    /// Learn the risk map from samples (`[learning]`); `None`: samples are
    /// refused and the mission's risk is covered.
    pub learning: Option<LearnSettings>,
}

struct Link {
    id: u64,
    tx: mpsc::Sender<Outgoing>,
    poses: watch::Receiver<Option<PoseDocument>>,
}

/// What the tick task hands a link to send.
#[derive(Debug)]
pub enum Outgoing {
    /// A welcome or an error; an error closes the link.
    Message(CoordinatorMessage),
    /// An error that leaves the link open (a refused pose).
    Notice(CoordinatorMessage),
    /// A tick's command, serialized on the thread that computed it (the
    /// link only frames and writes it).
    Command {
        text: Utf8Bytes,
        /// When its tick was due, for `seacover_command_delay_seconds`.
        due: std::time::Instant,
        /// Dropped once the command is written or dropped: when the last of
        /// a tick's is gone, the tick's fan-out is over and the tick task
        /// publishes its snapshot (see [`Fanout`]).
        written: mpsc::Sender<()>,
    },
}

impl From<CoordinatorMessage> for Outgoing {
    fn from(message: CoordinatorMessage) -> Self {
        Outgoing::Message(message)
    }
}

struct Entry {
    actuator: ActuatorDocument,
    link: Option<Link>,
    pose: Option<PoseDocument>,
    last_seen_tick: Option<u64>,
    guidance: Guidance,
    last_command: Option<CommandDocument>,
    /// Its own neighbour count, when it is a peer fleet's vessel.
    neighbours: Option<u32>,
    /// Its poses judged on their own, and its quarantine.
    standing: judging::Standing,
    /// When its link was last told of a refused sample [mission s].
    sample_notice: Option<f64>,
}

/// Takes a link's pose into `entry` (vessel `id`) when the link has sent a
/// new one since the last look, judged ([`judging`]): a believed pose
/// becomes the vessel's, any pose at all means it was heard at `tick`, and
/// a refusal is answered on the link's `tx`.
fn take_pose(id: &str, entry: &mut Entry, link: &mut Link, tick: u64, bench: &judging::Bench<'_>) {
    let newest = link.poses.borrow_and_update();
    if !newest.has_changed() {
        return;
    }
    let Some(pose) = newest.as_ref() else {
        return;
    };
    entry.last_seen_tick = Some(tick);
    let judged = entry.standing.judge(id, pose, bench);
    if judged.believed {
        entry.pose = Some(pose.clone());
    }
    if let Some(notice) = judged.notice {
        let _ = link.tx.try_send(Outgoing::Notice(notice));
    }
}

/// What a tick computed, for [`Coordinator::finish_tick`].
struct Published {
    time: f64,
    live: Vec<String>,
    evaluation: Option<Evaluation>,
}

/// A tick whose commands are on their way. Its snapshot for dashboards is
/// built once they are all written (or dropped), or at the deadline for a
/// link that cannot keep up: building it takes milliseconds of a core that
/// the links need while they write the tick's commands.
struct Fanout {
    published: Published,
    /// Closed when the last command's `written` sender is dropped.
    written: mpsc::Receiver<()>,
    deadline: tokio::time::Instant,
}

/// The tick task.
pub(super) struct Coordinator {
    mission: Mission,
    settings: TickSettings,
    vessels: BTreeMap<String, Entry>,
    tick: u64,
    snapshot: watch::Sender<Arc<Snapshot>>,
    /// Where accepted changes are made durable before they are answered;
    /// `None` keeps the mission in memory only (the demo).
    store: Option<Store>,
    /// Where ticks, mission changes and fleet events are recorded.
    recorder: Recorder,
    /// When tick 1 is due (its origin plus one period).
    clock: Option<MissionClock>,
    /// The previous tick's partition, to see who leaves it and who returns.
    live_before: BTreeSet<String>,
    /// Vessels that left the partition by falling silent, until heard again.
    lapsed: BTreeSet<String>,
    /// H(P) since the first tick, bounded; published with each snapshot.
    history: history::History,
    /// [`mission_name`] of the mission.
    name: String,
    /// The mission is only what this coordinator started with, into an
    /// empty store (or none): not the fleet's. Until an operator changes
    /// it, a vessel that names another mission in its hello is held
    /// rather than re-tasked ([`judging::Standing::hold_stray`]).
    provisional: bool,
    /// The learner, when the risk map is learned from samples.
    learning: Option<learning::Learning>,
}

impl Coordinator {
    pub(super) fn new(
        mission: Mission,
        settings: TickSettings,
        store: Option<Store>,
    ) -> (Coordinator, watch::Receiver<Arc<Snapshot>>) {
        let history = history::History::new();
        let empty = Arc::new(crate::protocol::Snapshot {
            document: SnapshotDocument {
                tick: 0,
                time: 0.0,
                h: 0.0,
                mission: mission.document(),
                vessels: Vec::new(),
            },
            coverage: CoverageDocument {
                tick: 0,
                time: 0.0,
                h: 0.0,
                cells: Vec::new(),
            },
        });
        let name = mission_name(&empty.document.mission);
        let (tx, rx) = watch::channel(Arc::new(Snapshot {
            state: empty,
            history: history.document(),
        }));
        (
            Coordinator {
                settings,
                vessels: BTreeMap::new(),
                tick: 0,
                snapshot: tx,
                store,
                recorder: Recorder::off(),
                clock: None,
                live_before: BTreeSet::new(),
                lapsed: BTreeSet::new(),
                history,
                name,
                mission,
                provisional: false,
                learning: settings.learning.map(learning::Learning::new),
            },
            rx,
        )
    }

    /// Records to `recorder`, with ticks due on `clock`; the mission as it
    /// starts is the recording's first message.
    pub(super) fn recording(mut self, recorder: Recorder, clock: MissionClock) -> Coordinator {
        recorder.mission(0.0, self.mission.document());
        self.recorder = recorder;
        self.clock = Some(clock);
        self
    }

    /// Marks the mission as only the start-up default ([`Coordinator`]'s
    /// `provisional`): the store was empty, or there is none.
    pub(super) fn provisional(mut self) -> Coordinator {
        self.provisional = true;
        self
    }

    /// Runs until `shutdown`; then tells every vessel and returns.
    pub(super) async fn run(
        mut self,
        mut requests: mpsc::Receiver<Request>,
        shutdown: CancellationToken,
    ) {
        let period =
            Duration::from_secs_f64(1.0 / (self.mission.tick_hz() * self.settings.time_warp));
        // Tick 1 is due one period after the clock's origin (at once when
        // there is no clock), so what links record on the clock and what
        // ticks record agree.
        let first = self
            .clock
            .map_or_else(tokio::time::Instant::now, |c| (c.origin + period).into());
        let mut ticker = tokio::time::interval_at(first, period);
        ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        // Tick N is due at origin + N × period (the interval's first tick,
        // tick 1, fires at once). Published so that a client on the same
        // host can measure a command's delay from the moment its tick was
        // due, exactly, rather than estimate it (`seacover bench load`).
        let origin = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64())
            - period.as_secs_f64();
        metrics::gauge!(super::metrics::TICK_ORIGIN).set(origin);
        metrics::gauge!(super::metrics::TICK_PERIOD).set(period.as_secs_f64());
        let mut last: Option<tokio::time::Instant> = None;
        let mut fanout: Option<Fanout> = None;
        loop {
            tokio::select! {
                _ = shutdown.cancelled() => break,
                due = ticker.tick() => {
                    if let Some(previous) = fanout.take() {
                        self.finish_tick(previous.published);
                    }
                    // Ticks the interval skipped because one overran keep
                    // their numbers: tick N always means mission time
                    // N / tick_hz, whatever the load.
                    let advance = match last {
                        Some(prev) => ((due - prev).as_secs_f64() / period.as_secs_f64()).round().max(1.0) as u64,
                        None => 1,
                    };
                    if advance > 1 {
                        metrics::counter!(super::metrics::TICKS_SKIPPED).increment(advance - 1);
                    }
                    last = Some(due);
                    let started = std::time::Instant::now();
                    let (written_tx, written) = mpsc::channel(1);
                    let published = self.on_tick(advance, due.into_std(), written_tx);
                    metrics::histogram!(super::metrics::TICK_SECONDS).record(started.elapsed().as_secs_f64());
                    fanout = Some(Fanout { published, written, deadline: due + period / 2 });
                }
                () = async {
                    match fanout.as_mut() {
                        Some(f) => {
                            tokio::select! {
                                _ = f.written.recv() => {}
                                _ = tokio::time::sleep_until(f.deadline) => {}
                            }
                        }
                        None => std::future::pending().await,
                    }
                } => {
                    if let Some(done) = fanout.take() {
                        self.finish_tick(done.published);
                    }
                }
                request = requests.recv() => match request {
                    Some(r) => self.serve(r, &mut fanout),
                    None => break,
                },
            }
        }
        for entry in self.vessels.values() {
            if let Some(link) = &entry.link {
                let _ = link.tx.try_send(
                    CoordinatorMessage::Error {
                        code: ApiError::ShuttingDown.code().to_string(),
                        message: ApiError::ShuttingDown.to_string(),
                    }
                    .into(),
                );
            }
        }
        self.recorder
            .event(EventRecord::new(self.time(), EventKind::Shutdown));
    }

    /// Mission time of the current tick [s].
    fn time(&self) -> f64 {
        self.tick as f64 / self.mission.tick_hz()
    }

    /// Serves one request, after publishing the tick whose commands are
    /// still on their way, if any. That tick's snapshot shows the fleet as
    /// it was when the commands were handed out: a link that goes down
    /// after writing its command and before the fan-out ends is still
    /// connected in it, so the recording holds every command written.
    fn serve(&mut self, request: Request, pending: &mut Option<Fanout>) {
        if let Some(tick) = pending.take() {
            self.finish_tick(tick.published);
        }
        self.on_request(request);
    }

    /// Serves one request.
    fn on_request(&mut self, request: Request) {
        match request {
            Request::Register {
                id,
                link,
                actuator,
                astern,
                agility,
                mission,
                station_radius,
                tx,
                poses,
                reply,
            } => {
                let hello = Hello {
                    actuator,
                    astern,
                    agility,
                    mission,
                    station_radius,
                };
                let name = self.name.clone();
                let welcomed = self.register(id, hello).map(|entry| {
                    entry.link = Some(Link {
                        id: link,
                        tx,
                        poses,
                    });
                    // A held stray keeps the name of what it followed.
                    (!entry.standing.is_stray()).then_some(name)
                });
                let welcomed = welcomed.map(|mission| Welcomed {
                    tick_hz: self.mission.tick_hz(),
                    mission,
                });
                let _ = reply.send(welcomed);
            }
            Request::Change { change, reply } => {
                let outcome = self.change(&change);
                let _ = reply.send(outcome);
            }
            Request::LinkSample { vessel, sample } => self.link_sample(vessel, sample),
            learning @ (Request::Samples { .. }
            | Request::RecentSamples { .. }
            | Request::Belief { .. }) => self.on_learning_request(learning),
            Request::PeerNeighbours(counts) => {
                for (id, n) in counts {
                    if let Some(entry) = self.vessels.get_mut(&id) {
                        entry.neighbours = Some(n);
                    }
                }
            }
            Request::Forget { id, reply } => {
                let outcome = match self.vessels.remove(&id) {
                    Some(entry) => {
                        self.recorder.event(
                            EventRecord::new(self.time(), EventKind::VesselRemoved)
                                .vessel(id.clone()),
                        );
                        self.live_before.remove(&id);
                        self.lapsed.remove(&id);
                        if let Some(link) = entry.link {
                            let _ = link.tx.try_send(
                                CoordinatorMessage::Error {
                                    code: "removed".into(),
                                    message: "an operator removed this vessel from the mission"
                                        .into(),
                                }
                                .into(),
                            );
                        }
                        let time = self.tick as f64 / self.mission.tick_hz();
                        let live = self.live_ids();
                        let evaluation = self.evaluate_live(&live);
                        self.publish(time, &live, evaluation.as_ref());
                        Ok(())
                    }
                    None => Err(CoordinatorError::NoVessel(id.clone())),
                };
                let _ = reply.send(outcome);
            }
            Request::Gone { id, link } => {
                let (tick, bench) = (
                    self.tick,
                    judging::Bench {
                        limits: &self.settings.limits,
                        region: self.mission.region(),
                        time: self.time(),
                        recorder: &self.recorder,
                    },
                );
                if let Some(entry) = self.vessels.get_mut(&id)
                    && entry.link.as_ref().is_some_and(|l| l.id == link)
                {
                    // A pose sent just before the link closed still counts.
                    if let Some(mut link) = entry.link.take() {
                        take_pose(&id, entry, &mut link, tick, &bench);
                    }
                }
            }
        }
    }
}
