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

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::Utf8Bytes;
use tokio::sync::{mpsc, oneshot, watch};
use tokio_util::sync::CancellationToken;

use super::error::ApiError;
use super::store::Store;
use crate::control::barrier::Scratch;
use crate::control::guidance::{Agility, Guidance, GuidanceGains, GuidanceMode};
use crate::control::model::State;
use crate::control::safety::{SafetyLayer, SafetyParams};
use crate::coverage::evaluate::cell_figures;
use crate::coverage::partition::power_cells_with;
use crate::coverage::{CellResult, Evaluation, Fleet, Options, RiskField, Vessel, evaluate};
use crate::geometry::geodesy::LocalFrame;
use crate::geometry::{Point, Region};
use crate::protocol::{
    ActuatorDocument, AgilityDocument, CommandDocument, CoordinatorMessage, CoverageDocument,
    GuidanceDocument, MissionDocument, OriginDocument, PoseDocument, RegionDocument, RegionInput,
    RiskDocument, RiskObjectDocument, RiskObjectInput, SafetyDocument, SnapshotDocument,
    VesselStatusDocument,
};
use crate::recorder::messages::{EventKind, EventRecord};
use crate::recorder::{Entry as RecorderEntry, MissionClock, Recorder};
use crate::scenario::{Scenario, ScenarioError, evaluation_document};

/// The mission: what to cover and how.
#[derive(Debug, Clone)]
pub struct Mission {
    /// The WGS84 origin of the local plane, when geo-referenced; validated
    /// ([`crate::geometry::geodesy::LocalFrame::new`]).
    pub origin: Option<OriginDocument>,
    pub region_doc: RegionDocument,
    pub risk_doc: RiskDocument,
    pub region: Region,
    pub risk: RiskField,
    pub actuator: ActuatorDocument,
    pub guidance: GuidanceGains,
    pub tick_hz: f64,
    pub safety: SafetyParams,
    /// The region's shore and route map with `safety`: rebuilt whenever
    /// either changes, shared by the mission's clones.
    pub layer: Arc<SafetyLayer>,
}

impl Mission {
    /// The paper's scenario (region, risk, actuator), default guidance, 10 Hz.
    pub fn paper() -> Mission {
        let doc = crate::scenario::parse_document(crate::sim::PAPER_SCENARIO)
            .expect("built-in scenario parses");
        let scenario = Scenario::from_document(&doc).expect("built-in scenario is valid");
        let v = scenario.fleet.vessels()[0];
        let mut risk_doc = doc.risk.clone().expect("paper has risk");
        for (i, o) in risk_doc.objects.iter_mut().enumerate() {
            o.id.get_or_insert_with(|| format!("object-{}", i + 1));
        }
        let layer = Arc::new(
            SafetyLayer::new(&scenario.region, SafetyParams::default())
                .expect("default safety parameters are valid"),
        );
        Mission {
            origin: None,
            region_doc: doc.region.clone().expect("paper has a region"),
            risk_doc,
            region: scenario.region,
            risk: scenario.risk,
            actuator: ActuatorDocument {
                k: v.k,
                beta: v.beta,
            },
            guidance: GuidanceGains::default(),
            tick_hz: 10.0,
            safety: SafetyParams::default(),
            layer,
        }
    }

    /// A mission from its document (a stored mission, a `--config` file),
    /// validated as `evaluate` validates a scenario, plus the guidance gains
    /// and the tick rate.
    pub fn from_document(doc: &MissionDocument) -> Result<Mission, ApiError> {
        let region = crate::scenario::region_from_document(&doc.region)?;
        let risk = risk_field(&doc.risk)?;
        // The actuator is checked as a scenario's vessel would be.
        Fleet::new(vec![Vessel {
            position: Point { x: 0.0, y: 0.0 },
            k: doc.actuator.k,
            beta: doc.actuator.beta,
        }])
        .map_err(|e| ApiError::from(crate::scenario::ScenarioError::from(e)))
        .map_err(|e| ApiError::Invalid(format!("actuator: {e}")))?;
        if !(doc.tick_hz.is_finite() && doc.tick_hz > 0.0 && doc.tick_hz <= 100.0) {
            return Err(ApiError::Invalid("tick_hz: must be in (0, 100]".into()));
        }
        let mut risk_doc = doc.risk.clone();
        let mut seen = std::collections::HashSet::new();
        for (i, o) in risk_doc.objects.iter_mut().enumerate() {
            let id = o.id.get_or_insert_with(|| format!("object-{}", i + 1));
            if !crate::scenario::valid_id(id) {
                return Err(ApiError::Invalid(format!(
                    "risk.objects[{i}].id: must match [A-Za-z0-9_.-]{{1,64}}"
                )));
            }
            if !seen.insert(id.clone()) {
                return Err(ApiError::Invalid(format!(
                    "risk.objects[{i}].id: duplicate id {id:?}"
                )));
            }
        }
        let safety = safety_params(&doc.safety);
        let layer = Arc::new(
            SafetyLayer::new(&region, safety)
                .map_err(|e| ApiError::from(crate::scenario::ScenarioError::from(e)))?,
        );
        if let Some(o) = doc.origin {
            origin_frame(o)?;
        }
        Ok(Mission {
            origin: doc.origin,
            region_doc: doc.region.clone(),
            risk_doc,
            region,
            risk,
            actuator: doc.actuator,
            guidance: guidance_gains(&doc.guidance)?,
            tick_hz: doc.tick_hz,
            safety,
            layer,
        })
    }

    pub fn document(&self) -> MissionDocument {
        MissionDocument {
            origin: self.origin,
            region: self.region_doc.clone(),
            risk: self.risk_doc.clone(),
            actuator: self.actuator,
            guidance: guidance_document(&self.guidance),
            tick_hz: self.tick_hz,
            safety: safety_document(&self.safety),
        }
    }

    /// The mission's risk objects, with ids.
    pub fn objects(&self) -> &[RiskObjectDocument] {
        &self.risk_doc.objects
    }

    pub fn mode(&self) -> GuidanceMode {
        self.guidance.mode
    }

    /// The local plane of the mission's origin, when it has one.
    pub fn frame(&self) -> Option<LocalFrame> {
        // Validated when it was set (`from_document`, `changed`).
        self.origin.and_then(|o| origin_frame(o).ok())
    }
}

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
        tx: mpsc::Sender<Outgoing>,
        /// The link's newest pose. A slot rather than a request per pose:
        /// the tick only ever wants the newest, and 1000 vessels at 20 Hz
        /// would otherwise wake this task 20,000 times a second.
        poses: watch::Receiver<Option<PoseDocument>>,
        reply: oneshot::Sender<Result<f64, ApiError>>,
    },
    /// A link closed.
    Gone { id: String, link: u64 },
    /// `DELETE /api/v1/vessels/{id}`: forget the vessel; its link, if any, is
    /// told `removed` and closed.
    Forget {
        id: String,
        reply: oneshot::Sender<Result<(), ApiError>>,
    },
    /// An operator's change to the mission; the reply is the changed
    /// document's new state.
    Change {
        change: MissionChange,
        reply: oneshot::Sender<Result<ChangeResult, ApiError>>,
    },
}

/// One write of the REST API. Geographic inputs are placed in the plane by
/// [`Mission::changed`], with the origin of the mission they change: the
/// tick task applies changes in order, so a region written just after an
/// origin is placed with that origin.
#[derive(Debug, Clone)]
pub enum MissionChange {
    Origin(OriginDocument),
    Region(RegionInput),
    Base(f64),
    AddObject(RiskObjectInput),
    PutObject(String, RiskObjectInput),
    DeleteObject(String),
}

/// What a change answers with.
#[derive(Debug, Clone)]
pub enum ChangeResult {
    // Boxed: the mission document is far larger than the other answers.
    Mission(Box<MissionDocument>),
    Object(RiskObjectDocument),
    Deleted,
}

impl Mission {
    /// The mission with `change` applied, validated as `evaluate` validates;
    /// `self` is left untouched when it is rejected.
    pub fn changed(&self, change: &MissionChange) -> Result<(Mission, ChangeResult), ApiError> {
        let mut next = self.clone();
        let frame = self.frame();
        let placed = |e: crate::coverage::InputError| ApiError::from(ScenarioError::from(e));
        let result = match change {
            MissionChange::Origin(origin) => {
                // The region and the objects keep their local coordinates:
                // moving the origin moves the mission on the globe.
                origin_frame(*origin)?;
                next.origin = Some(*origin);
                None
            }
            MissionChange::Region(input) => {
                let doc = crate::georef::input::region(input, frame.as_ref()).map_err(placed)?;
                next.region = crate::scenario::region_from_document(&doc)?;
                next.region_doc = doc;
                next.layer = Arc::new(
                    SafetyLayer::new(&next.region, next.safety)
                        .map_err(|e| ApiError::from(crate::scenario::ScenarioError::from(e)))?,
                );
                None
            }
            MissionChange::Base(value) => {
                next.risk_doc.base = *value;
                None
            }
            MissionChange::AddObject(object) => {
                let mut object = crate::georef::input::risk_object(object, frame.as_ref(), "")
                    .map_err(placed)?;
                let id = match &object.id {
                    Some(id) => {
                        if !crate::scenario::valid_id(id) {
                            return Err(ApiError::Invalid(
                                "id: must match [A-Za-z0-9_.-]{1,64}".into(),
                            ));
                        }
                        if next
                            .risk_doc
                            .objects
                            .iter()
                            .any(|o| o.id.as_deref() == Some(id))
                        {
                            return Err(ApiError::Conflict(format!(
                                "a risk object {id:?} exists already"
                            )));
                        }
                        id.clone()
                    }
                    None => (1..)
                        .map(|n| format!("object-{n}"))
                        .find(|c| {
                            !next
                                .risk_doc
                                .objects
                                .iter()
                                .any(|o| o.id.as_deref() == Some(c))
                        })
                        .expect("an unused id exists"),
                };
                object.id = Some(id);
                next.risk_doc.objects.push(object.clone());
                Some(object)
            }
            MissionChange::PutObject(id, object) => {
                let object = crate::georef::input::risk_object(object, frame.as_ref(), "")
                    .map_err(placed)?;
                let slot = next
                    .risk_doc
                    .objects
                    .iter_mut()
                    .find(|o| o.id.as_deref() == Some(id.as_str()))
                    .ok_or_else(|| ApiError::NotFound(format!("no risk object {id:?}")))?;
                *slot = RiskObjectDocument {
                    id: Some(id.clone()),
                    ..object
                };
                Some(slot.clone())
            }
            MissionChange::DeleteObject(id) => {
                let before = next.risk_doc.objects.len();
                next.risk_doc
                    .objects
                    .retain(|o| o.id.as_deref() != Some(id.as_str()));
                if next.risk_doc.objects.len() == before {
                    return Err(ApiError::NotFound(format!("no risk object {id:?}")));
                }
                None
            }
        };
        next.risk = risk_field(&next.risk_doc)?;
        let answer = match (change, result) {
            (MissionChange::DeleteObject(_), _) => ChangeResult::Deleted,
            (_, Some(object)) => ChangeResult::Object(object),
            (_, None) => ChangeResult::Mission(Box::new(next.document())),
        };
        Ok((next, answer))
    }
}

/// The local plane of an origin, or `invalid` naming `origin.lat` or
/// `origin.lon`.
pub fn origin_frame(
    origin: OriginDocument,
) -> Result<crate::geometry::geodesy::LocalFrame, ApiError> {
    use crate::geometry::geodesy::{LatLon, LocalFrame};
    LocalFrame::new(LatLon {
        lat: origin.lat,
        lon: origin.lon,
    })
    .map_err(|e| ApiError::Invalid(format!("origin.{e}")))
}

fn risk_field(doc: &RiskDocument) -> Result<RiskField, ApiError> {
    RiskField::new(
        doc.base,
        doc.objects
            .iter()
            .map(|o| crate::coverage::RiskObject {
                center: Point { x: o.x, y: o.y },
                alpha: o.alpha,
                sigma: o.sigma,
            })
            .collect(),
    )
    .map_err(|e| ApiError::from(crate::scenario::ScenarioError::from(e)))
}

/// Guidance gains from their document: a known mode, every gain finite and
/// positive (the arrival radius may be zero).
/// The mission's safety parameters: the document's three, the rest at their
/// defaults (validated by [`SafetyLayer::new`]).
pub fn safety_params(doc: &SafetyDocument) -> SafetyParams {
    SafetyParams {
        filter: doc.filter,
        safety_distance: doc.safety_distance,
        shore_distance: doc.shore_distance,
        ..SafetyParams::default()
    }
}

/// The document of guidance gains ([`guidance_gains`] reads it back).
pub fn guidance_document(g: &GuidanceGains) -> GuidanceDocument {
    GuidanceDocument {
        mode: g.mode.name().to_string(),
        k_r1: g.k_r1,
        k_r2: g.k_r2,
        b1: g.b1,
        k_u1: g.k_u1,
        k_u2: g.k_u2,
        b2: g.b2,
        arrival_radius: g.arrival_radius,
        max_speed: g.max_speed,
        max_yaw_rate: g.max_yaw_rate,
        filter_time: g.filter_time,
        yaw_accel: g.yaw_accel,
        surge_accel: g.surge_accel,
    }
}

/// The document of safety parameters ([`safety_params`] reads it back).
pub fn safety_document(p: &SafetyParams) -> SafetyDocument {
    SafetyDocument {
        filter: p.filter,
        safety_distance: p.safety_distance,
        shore_distance: p.shore_distance,
    }
}

pub fn guidance_gains(doc: &GuidanceDocument) -> Result<GuidanceGains, ApiError> {
    let mode = GuidanceMode::parse(&doc.mode).ok_or_else(|| {
        ApiError::Invalid(format!(
            "guidance.mode: unknown mode {:?} (paper, course)",
            doc.mode
        ))
    })?;
    let gains = [
        ("k_r1", doc.k_r1),
        ("k_r2", doc.k_r2),
        ("b1", doc.b1),
        ("k_u1", doc.k_u1),
        ("k_u2", doc.k_u2),
        ("b2", doc.b2),
        ("max_speed", doc.max_speed),
        ("max_yaw_rate", doc.max_yaw_rate),
        ("filter_time", doc.filter_time),
        ("yaw_accel", doc.yaw_accel),
        ("surge_accel", doc.surge_accel),
    ];
    for (name, value) in gains {
        if !(value.is_finite() && value > 0.0) {
            return Err(ApiError::Invalid(format!(
                "guidance.{name}: must be a finite number > 0"
            )));
        }
    }
    if !(doc.arrival_radius.is_finite() && doc.arrival_radius >= 0.0) {
        return Err(ApiError::Invalid(
            "guidance.arrival_radius: must be a finite number >= 0".into(),
        ));
    }
    Ok(GuidanceGains {
        mode,
        k_r1: doc.k_r1,
        k_r2: doc.k_r2,
        b1: doc.b1,
        k_u1: doc.k_u1,
        k_u2: doc.k_u2,
        b2: doc.b2,
        arrival_radius: doc.arrival_radius,
        max_speed: doc.max_speed,
        max_yaw_rate: doc.max_yaw_rate,
        filter_time: doc.filter_time,
        yaw_accel: doc.yaw_accel,
        surge_accel: doc.surge_accel,
    })
}

pub use crate::protocol::Snapshot;

/// Settings of the tick task.
#[derive(Debug, Clone, Copy)]
pub struct TickSettings {
    /// Wall-clock speed-up (MOOS-IvP's time warp).
    pub time_warp: f64,
    /// A vessel silent longer than this (mission seconds) leaves the partition.
    pub liveness: f64,
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
}

/// Takes a link's pose into its entry when the link has sent a new one since
/// the last look; the vessel was then seen at `tick`.
fn take_pose(entry: &mut Entry, poses: &mut watch::Receiver<Option<PoseDocument>>, tick: u64) {
    let newest = poses.borrow_and_update();
    if newest.has_changed()
        && let Some(pose) = newest.as_ref()
    {
        entry.pose = Some(pose.clone());
        entry.last_seen_tick = Some(tick);
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
pub struct Coordinator {
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
}

impl Coordinator {
    pub fn new(
        mission: Mission,
        settings: TickSettings,
        store: Option<Store>,
    ) -> (Coordinator, watch::Receiver<Arc<Snapshot>>) {
        let empty = Arc::new(Snapshot {
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
        let (tx, rx) = watch::channel(empty);
        (
            Coordinator {
                mission,
                settings,
                vessels: BTreeMap::new(),
                tick: 0,
                snapshot: tx,
                store,
                recorder: Recorder::off(),
                clock: None,
                live_before: BTreeSet::new(),
                lapsed: BTreeSet::new(),
            },
            rx,
        )
    }

    /// Records to `recorder`, with ticks due on `clock`; the mission as it
    /// starts is the recording's first message.
    pub fn recording(mut self, recorder: Recorder, clock: MissionClock) -> Coordinator {
        recorder.mission(0.0, self.mission.document());
        self.recorder = recorder;
        self.clock = Some(clock);
        self
    }

    /// Runs until `shutdown`; then tells every vessel and returns.
    pub async fn run(mut self, mut requests: mpsc::Receiver<Request>, shutdown: CancellationToken) {
        let period =
            Duration::from_secs_f64(1.0 / (self.mission.tick_hz * self.settings.time_warp));
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
                    Some(r) => {
                        if self.on_request(r) {
                            // A change published a newer snapshot.
                            fanout = None;
                        }
                    }
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
        self.tick as f64 / self.mission.tick_hz
    }

    /// Serves one request; `true` when it published a snapshot.
    fn on_request(&mut self, request: Request) -> bool {
        match request {
            Request::Register {
                id,
                link,
                actuator,
                astern,
                agility,
                tx,
                poses,
                reply,
            } => {
                let actuator = actuator.unwrap_or(self.mission.actuator);
                let agility = match agility {
                    None => Agility::UNDECLARED,
                    Some(a) => {
                        let ok = |x: f64| x.is_finite() && x > 0.0;
                        if !(ok(a.yaw_accel) && ok(a.surge_accel)) {
                            let _ = reply.send(Err(ApiError::Invalid(
                                "agility: yaw_accel and surge_accel must be finite numbers > 0"
                                    .into(),
                            )));
                            return false;
                        }
                        Agility {
                            yaw_accel: a.yaw_accel,
                            surge_accel: a.surge_accel,
                        }
                    }
                };
                if !(actuator.k.is_finite() && actuator.k > 0.0) {
                    let _ = reply.send(Err(ApiError::Invalid(
                        "actuator.k: must be a finite number > 0".into(),
                    )));
                    return false;
                }
                if actuator.beta != self.mission.actuator.beta {
                    let _ = reply.send(Err(ApiError::Unsupported(format!(
                        "actuator.beta: the mission's vessels share beta = {}; different beta give curved cell edges",
                        self.mission.actuator.beta
                    ))));
                    return false;
                }
                if !self.vessels.contains_key(&id)
                    && self.vessels.len() >= crate::coverage::fleet::MAX_VESSELS
                {
                    let _ = reply.send(Err(ApiError::Conflict(format!(
                        "the mission already has {} vessels, the most it takes",
                        crate::coverage::fleet::MAX_VESSELS
                    ))));
                    return false;
                }
                let gains = self.mission.guidance;
                let entry = self.vessels.entry(id).or_insert_with(|| Entry {
                    actuator,
                    link: None,
                    pose: None,
                    last_seen_tick: None,
                    guidance: Guidance::new(gains),
                    last_command: None,
                });
                if let Some(old) = entry.link.take() {
                    let _ = old.tx.try_send(
                        CoordinatorMessage::Error {
                            code: "replaced".into(),
                            message: "another link for this vessel connected".into(),
                        }
                        .into(),
                    );
                }
                entry.actuator = actuator;
                entry.guidance.ahead_only = !astern;
                entry.guidance.agility = agility;
                entry.link = Some(Link {
                    id: link,
                    tx,
                    poses,
                });
                let _ = reply.send(Ok(self.mission.tick_hz));
                false
            }
            Request::Change { change, reply } => {
                let outcome = self.mission.changed(&change).and_then(|(next, answer)| {
                    // Durable first, applied second: a change the store
                    // refuses is not applied, and one that is answered
                    // survives a crash. The commit blocks this task for one
                    // fsync (a few ms); writes are rate-limited, so the tick
                    // loses at most that, and changes stay in one order.
                    if let Some(store) = &self.store {
                        store.apply(&change, &answer).map_err(|e| {
                            tracing::error!(error = %e, "a mission change could not be stored");
                            ApiError::Storage(e.to_string())
                        })?;
                    }
                    self.mission = next;
                    Ok(answer)
                });
                if outcome.is_ok() {
                    self.recorder.mission(self.time(), self.mission.document());
                }
                let changed = outcome.is_ok();
                if changed {
                    // Readers see the write at once, not at the next tick.
                    let time = self.tick as f64 / self.mission.tick_hz;
                    let live = self.live_ids();
                    let evaluation = self.evaluate_live(&live);
                    self.publish(time, &live, evaluation.as_ref());
                }
                let _ = reply.send(outcome);
                changed
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
                        let time = self.tick as f64 / self.mission.tick_hz;
                        let live = self.live_ids();
                        let evaluation = self.evaluate_live(&live);
                        self.publish(time, &live, evaluation.as_ref());
                        Ok(())
                    }
                    None => Err(ApiError::NotFound(format!("no vessel {id:?}"))),
                };
                let forgotten = outcome.is_ok();
                let _ = reply.send(outcome);
                forgotten
            }
            Request::Gone { id, link } => {
                let tick = self.tick;
                if let Some(entry) = self.vessels.get_mut(&id)
                    && entry.link.as_ref().is_some_and(|l| l.id == link)
                {
                    // A pose sent just before the link closed still counts.
                    if let Some(mut link) = entry.link.take() {
                        take_pose(entry, &mut link.poses, tick);
                    }
                }
                false
            }
        }
    }

    /// Takes every link's newest pose, if it has a new one.
    fn collect_poses(&mut self) {
        let tick = self.tick;
        for entry in self.vessels.values_mut() {
            if let Some(mut link) = entry.link.take() {
                take_pose(entry, &mut link.poses, tick);
                entry.link = Some(link);
            }
        }
    }

    fn is_live(&self, entry: &Entry) -> bool {
        let window = (self.settings.liveness * self.mission.tick_hz).round() as u64;
        entry.pose.is_some()
            && entry
                .last_seen_tick
                .is_some_and(|t| self.tick - t <= window)
    }

    /// Ids of the vessels in the partition, in id order.
    fn live_ids(&self) -> Vec<String> {
        self.vessels
            .iter()
            .filter(|(_, e)| self.is_live(e))
            .map(|(id, _)| id.clone())
            .collect()
    }

    /// One tick, `advance` ticks after the previous one (more than one when
    /// the interval skipped some), due at `due`.
    ///
    /// Pipelined: after the partition (which needs every position), each
    /// vessel's cell figures, goal, filter and command are computed on their
    /// own (on every core for large fleets) and the command is serialized
    /// and handed to its link at once, so the first commands are on the
    /// wire while the last are still being computed. Each handed command
    /// holds a clone of `written`. The cells and H are those of
    /// [`evaluate`], and the commands those of
    /// [`SafetyLayer::commands`](crate::control::safety::SafetyLayer::commands),
    /// bit for bit.
    fn on_tick(
        &mut self,
        advance: u64,
        due: std::time::Instant,
        written: mpsc::Sender<()>,
    ) -> Published {
        self.tick += advance;
        self.collect_poses();
        let time = self.tick as f64 / self.mission.tick_hz;
        let live = self.live_ids();
        self.note_liveness(time, &live);
        let Some(fleet) = self.fleet(&live) else {
            return Published {
                time,
                live,
                evaluation: None,
            };
        };
        // The live entries, in `live`'s order (both are in id order).
        let mut wanted = live.iter().peekable();
        let mut entries: Vec<&mut Entry> = Vec::with_capacity(live.len());
        for (id, entry) in self.vessels.iter_mut() {
            if wanted.next_if(|w| *w == id).is_some() {
                entries.push(entry);
            }
        }
        let states: Vec<State> = entries
            .iter()
            .map(|entry| {
                let pose = entry.pose.as_ref().expect("live vessels have a pose");
                State {
                    x: pose.x,
                    y: pose.y,
                    psi: pose.psi,
                    vel: crate::control::Vec3::new(pose.u, pose.v, pose.r),
                }
            })
            .collect();
        let mission = &self.mission;
        let options = Options {
            parallel: true,
            ..Options::default()
        };
        let parallel = entries.len() >= crate::coverage::PARALLEL_MIN;
        let geometries = power_cells_with(&mission.region, &fleet, parallel);
        // Goals inside the vessel's own piece of water, routes round islands
        // and the collision filter: the same functions as `seacover sim`.
        let layer = &mission.layer;
        let safety = {
            let guidance: Vec<&Guidance> = entries.iter().map(|e| &e.guidance).collect();
            layer.prepare(time, &states, &guidance)
        };
        let tick = self.tick;
        let one = |i: usize,
                   entry: &mut Entry,
                   geometry,
                   (near, scratch): &mut (Vec<usize>, Scratch)|
         -> (CellResult, bool) {
            let vessel = &fleet.vessels()[i];
            let cell = cell_figures(
                &mission.region,
                &mission.risk,
                vessel,
                fleet.beta(),
                geometry,
                &options,
                near,
            );
            let sc = layer.command(&safety, i, &states[i], &cell, &mut entry.guidance, scratch);
            let (cmd, c) = (sc.command, cell.centroid);
            let doc = CommandDocument {
                tick,
                u_d: cmd.u_d,
                r_d: cmd.r_d,
                u_d_dot: cmd.u_d_dot,
                r_d_dot: cmd.r_d_dot,
                centroid: [c.x, c.y],
                e: cmd.e,
                psi_e: cmd.psi_e,
            };
            if let Some(link) = &entry.link {
                let text = serde_json::to_string(&CoordinatorMessage::Command(doc.clone()))
                    .expect("commands serialize");
                // A link that cannot keep up misses this command; the next
                // one supersedes it anyway.
                let sent = link.tx.try_send(Outgoing::Command {
                    text: Utf8Bytes::from(text),
                    due,
                    written: written.clone(),
                });
                if sent.is_err() {
                    metrics::counter!(super::metrics::MESSAGES_REJECTED, "reason" => "link_full")
                        .increment(1);
                }
            }
            entry.last_command = Some(doc);
            (cell, sc.intervened)
        };
        let done: Vec<(CellResult, bool)> = crate::coverage::map_each(
            entries.into_iter().zip(geometries).collect(),
            parallel,
            |i, (entry, geometry), scratch| one(i, entry, geometry, scratch),
        );
        let interventions = done.iter().filter(|(_, intervened)| *intervened).count();
        metrics::counter!(super::metrics::SAFETY_INTERVENTIONS).increment(interventions as u64);
        let cells: Vec<CellResult> = done.into_iter().map(|(cell, _)| cell).collect();
        let h = cells.iter().map(|c| c.mass).sum();
        Published {
            time,
            live,
            evaluation: Some(Evaluation { h, cells }),
        }
    }

    /// Records who left the partition by falling silent (the others take
    /// their water) and who came back.
    fn note_liveness(&mut self, time: f64, live: &[String]) {
        if !self.recorder.is_on() {
            return;
        }
        let now: BTreeSet<String> = live.iter().cloned().collect();
        for gone in self.live_before.difference(&now) {
            if self.vessels.contains_key(gone) {
                self.recorder.event(
                    EventRecord::new(time, EventKind::LivenessTakeover).vessel(gone.clone()),
                );
                self.lapsed.insert(gone.clone());
            }
        }
        for back in now.difference(&self.live_before) {
            if self.lapsed.remove(back) {
                self.recorder.event(
                    EventRecord::new(time, EventKind::LivenessRegained).vessel(back.clone()),
                );
            }
        }
        self.live_before = now;
    }

    /// The second half of a tick, once its commands are on their way: the
    /// snapshot for readers and the gauges.
    fn finish_tick(&mut self, tick: Published) {
        let Published {
            time,
            live,
            evaluation,
        } = tick;
        self.publish(time, &live, evaluation.as_ref());
        let connected = self.vessels.values().filter(|e| e.link.is_some()).count();
        metrics::gauge!(super::metrics::VESSELS_CONNECTED).set(connected as f64);
        metrics::gauge!(super::metrics::VESSELS_LIVE).set(live.len() as f64);
        metrics::gauge!(super::metrics::COVERAGE_H).set(evaluation.as_ref().map_or(0.0, |e| e.h));
    }

    /// The fleet of the `live` vessels, in that order; `None` when there
    /// are none.
    fn fleet(&self, live: &[String]) -> Option<Fleet> {
        if live.is_empty() {
            return None;
        }
        let vessels = live
            .iter()
            .map(|id| {
                let e = &self.vessels[id];
                let p = e.pose.as_ref().expect("live vessels have a pose");
                Vessel {
                    position: Point { x: p.x, y: p.y },
                    k: e.actuator.k,
                    beta: e.actuator.beta,
                }
            })
            .collect();
        Fleet::new(vessels).ok()
    }

    fn evaluate_live(&self, live: &[String]) -> Option<Evaluation> {
        let fleet = self.fleet(live)?;
        Some(evaluate(
            &self.mission.region,
            &self.mission.risk,
            &fleet,
            &Options {
                parallel: true,
                ..Options::default()
            },
        ))
    }

    fn publish(&self, time: f64, live: &[String], evaluation: Option<&Evaluation>) {
        let h = evaluation.map_or(0.0, |e| e.h);
        let coverage = match evaluation {
            Some(e) => {
                let doc = evaluation_document(&self.mission.region, live, e);
                CoverageDocument {
                    tick: self.tick,
                    time,
                    h,
                    cells: doc.cells,
                }
            }
            None => CoverageDocument {
                tick: self.tick,
                time,
                h,
                cells: Vec::new(),
            },
        };
        // An index rather than a search per vessel, which made publishing
        // quadratic: milliseconds of a 1000-vessel tick, holding a worker
        // thread while the links were sending that tick's commands.
        let cells: std::collections::HashMap<&str, &crate::protocol::CellDocument> =
            coverage.cells.iter().map(|c| (c.id.as_str(), c)).collect();
        let vessels = self
            .vessels
            .iter()
            .map(|(id, e)| {
                let cell = cells.get(id.as_str()).copied();
                VesselStatusDocument {
                    id: id.clone(),
                    connected: e.link.is_some(),
                    live: cell.is_some(),
                    controlled: e.pose.as_ref().and_then(|p| p.controlled).unwrap_or(true),
                    pose: e.pose.clone(),
                    actuator: e.actuator,
                    polygon: cell.and_then(|c| c.polygon.clone()),
                    mass: cell.map_or(0.0, |c| c.mass),
                    centroid: cell.map(|c| c.centroid),
                    last_command: e.last_command.clone(),
                    last_seen: e.last_seen_tick.map(|t| t as f64 / self.mission.tick_hz),
                }
            })
            .collect();
        let snapshot = Snapshot {
            document: SnapshotDocument {
                tick: self.tick,
                time,
                h,
                mission: self.mission.document(),
                vessels,
            },
            coverage,
        };
        let snapshot = Arc::new(snapshot);
        if self.recorder.is_on() {
            self.recorder.record(RecorderEntry::Tick(snapshot.clone()));
        }
        self.snapshot.send_replace(snapshot);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Vec3;

    /// A coordinator of `mission` in real time, with no store. (Its
    /// snapshots go to no reader: publishing needs none.)
    fn coordinator(mission: &Mission) -> Coordinator {
        let settings = TickSettings {
            time_warp: 1.0,
            liveness: 3.0,
        };
        Coordinator::new(mission.clone(), settings, None).0
    }

    /// Registers a vessel through the same request a link sends; returns
    /// its pose slot and command queue.
    fn register(
        c: &mut Coordinator,
        id: &str,
        link: u64,
    ) -> (
        watch::Sender<Option<PoseDocument>>,
        mpsc::Receiver<Outgoing>,
    ) {
        let (tx, rx) = mpsc::channel(16);
        let (pose_tx, poses) = watch::channel(None);
        let (reply, answer) = oneshot::channel();
        c.on_request(Request::Register {
            id: id.into(),
            link,
            actuator: None,
            astern: true,
            agility: None,
            tx,
            poses,
            reply,
        });
        assert!(answer.blocking_recv().unwrap().is_ok());
        (pose_tx, rx)
    }

    fn pose(x: f64, y: f64, psi: f64, u: f64) -> PoseDocument {
        serde_json::from_value(serde_json::json!({
            "t": 0.0, "x": x, "y": y, "psi": psi, "u": u, "v": 0.0, "r": 0.0
        }))
        .unwrap()
    }

    /// Asserts that a tick's cells and H are `evaluate`'s for the vessels
    /// at `states` with the mission's actuator.
    fn assert_is_the_evaluation(mission: &Mission, states: &[State], eval: &Evaluation) {
        let fleet = Fleet::new(
            states
                .iter()
                .map(|s| Vessel {
                    position: Point { x: s.x, y: s.y },
                    k: mission.actuator.k,
                    beta: mission.actuator.beta,
                })
                .collect(),
        )
        .unwrap();
        assert_eq!(
            eval,
            &evaluate(&mission.region, &mission.risk, &fleet, &Options::default())
        );
    }

    /// The command waiting on a link's queue (`what` names it in failures).
    fn command(rx: &mut mpsc::Receiver<Outgoing>, what: &str) -> CommandDocument {
        let Ok(Outgoing::Command { text, .. }) = rx.try_recv() else {
            panic!("{what}: no command");
        };
        let Ok(CoordinatorMessage::Command(got)) = serde_json::from_str(&text) else {
            panic!("{what}: not a command: {text}");
        };
        got
    }

    /// The tick's commands are exactly the safety layer's for the same poses
    /// and cells (the function `seacover sim` calls), over several ticks, and
    /// two vessels closing head on inside the safety distance make the
    /// filter act.
    #[test]
    fn tick_commands_are_the_safety_layers() {
        let mission = Mission::paper();
        let mut c = coordinator(&mission);
        let starts = [
            ("usv-1", 40.0, 50.0, 0.0, 1.2),
            ("usv-2", 45.0, 50.0, std::f64::consts::PI, 1.2),
            ("usv-3", 20.0, 80.0, 1.0, 0.3),
        ];
        let mut links: Vec<_> = starts
            .iter()
            .enumerate()
            .map(|(i, s)| register(&mut c, s.0, i as u64))
            .collect();
        let mut local: Vec<Guidance> = starts
            .iter()
            .map(|_| Guidance::new(mission.guidance))
            .collect();
        let mut intervened = 0;
        for tick in 0..3 {
            let states: Vec<State> = starts
                .iter()
                .map(|s| State {
                    x: s.1 + 0.1 * tick as f64,
                    y: s.2,
                    psi: s.3,
                    vel: Vec3::new(s.4, 0.0, 0.0),
                })
                .collect();
            for ((pose_tx, _), s) in links.iter().zip(&states) {
                pose_tx.send_replace(Some(pose(s.x, s.y, s.psi, s.vel.x)));
            }
            let (written_tx, mut written) = mpsc::channel(1);
            let published = c.on_tick(1, std::time::Instant::now(), written_tx);
            let eval = published.evaluation.as_ref().unwrap();
            // The pipelined tick's cells and H are the evaluation's.
            assert_is_the_evaluation(&mission, &states, eval);
            let expected = mission
                .layer
                .commands(published.time, &states, &eval.cells, &mut local);
            intervened += expected.iter().filter(|s| s.intervened).count();
            for ((_, rx), want) in links.iter_mut().zip(&expected) {
                let got = command(rx, &format!("tick {tick}"));
                assert_eq!(got.tick, tick + 1);
                assert_eq!(
                    (got.u_d, got.r_d, got.e),
                    (want.command.u_d, want.command.r_d, want.command.e),
                    "tick {tick}"
                );
            }
            // Every command was taken (and its guard dropped with it): the
            // fan-out is over.
            assert_eq!(
                written.try_recv(),
                Err(mpsc::error::TryRecvError::Disconnected)
            );
        }
        assert!(
            intervened >= 2,
            "the head-on pair never triggered the filter"
        );
    }

    /// A fleet large enough for the tick to run on every core: its cells, H
    /// and every command are still exactly those of `evaluate` and the
    /// safety layer, and each link gets its own vessel's command.
    #[test]
    fn a_large_fleets_parallel_tick_is_the_evaluation_and_the_safety_layer() {
        let mission = Mission::paper();
        let mut c = coordinator(&mission);
        let n = 2 * crate::coverage::PARALLEL_MIN;
        // Ids in the coordinator's (id) order.
        let ids: Vec<String> = (0..n).map(|i| format!("usv-{i:03}")).collect();
        let mut links: Vec<_> = ids
            .iter()
            .enumerate()
            .map(|(i, id)| register(&mut c, id, i as u64))
            .collect();
        let states: Vec<State> = (0..n)
            .map(|i| State {
                x: 5.0 + 90.0 * ((i * 37) % n) as f64 / n as f64,
                y: 5.0 + 90.0 * (i % 16) as f64 / 16.0,
                psi: 0.1 * i as f64,
                vel: Vec3::new(0.5, 0.0, 0.0),
            })
            .collect();
        for ((pose_tx, _), s) in links.iter().zip(&states) {
            pose_tx.send_replace(Some(pose(s.x, s.y, s.psi, s.vel.x)));
        }
        let (written_tx, _written) = mpsc::channel(1);
        let published = c.on_tick(1, std::time::Instant::now(), written_tx);
        let eval = published.evaluation.as_ref().unwrap();
        assert_is_the_evaluation(&mission, &states, eval);
        let mut local: Vec<Guidance> = (0..n).map(|_| Guidance::new(mission.guidance)).collect();
        let expected = mission
            .layer
            .commands(published.time, &states, &eval.cells, &mut local);
        for (i, ((_, rx), want)) in links.iter_mut().zip(&expected).enumerate() {
            let got = command(rx, &format!("vessel {i}"));
            assert_eq!(
                (got.u_d, got.r_d, got.e, got.centroid),
                (
                    want.command.u_d,
                    want.command.r_d,
                    want.command.e,
                    [eval.cells[i].centroid.x, eval.cells[i].centroid.y]
                ),
                "vessel {i}"
            );
        }
    }
}
