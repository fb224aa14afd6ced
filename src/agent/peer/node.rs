//! The peer process: one Zenoh session, the fleet-wide declarations (every
//! beacon, the mission key and its queryable), and one task per simulated
//! vessel (its liveliness token, beacon publisher, status queryable, hull
//! and loop on board).
//!
//! The subscribers' callbacks only decode and file what they receive
//! (under a short `std` lock, never held across an await); the vessels
//! read the table at their own ticks, so a burst of beacons never delays a
//! hull's step.

mod listen;
mod off_tick;
mod status;
mod step_times;

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::watch;
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;
use zenoh::qos::CongestionControl;
use zenoh::query::ConsolidationMode;

use super::board::{Board, Revision};
use super::joining::Joining;
use super::learn::{Learning, Outbox};
use super::split::{Split, Tick};
use super::table::Table;
use super::wire::{self, Keys, utc_now};
use super::{PeerConfig, PeerError};
use crate::agent::VesselConfig;
use crate::agent::onboard::Onboard;
use crate::control::barrier::Scratch;
use crate::control::guidance::Guidance;
use off_tick::OffTick;
use status::status_document;
use step_times::StepTimes;

/// What the fleet-wide declarations share with the vessels.
struct Shared {
    keys: Keys,
    table: Mutex<Table>,
    board: Mutex<Board>,
    mission: watch::Sender<Option<Arc<Revision>>>,
    /// The last beacon each of this process's vessels sent: a sample with
    /// an own id but other bytes is somebody else claiming it.
    sent: Mutex<BTreeMap<String, Vec<u8>>>,
    /// Woken when a beacon carries a newer revision than the one held: a
    /// revision this member missed (a lost put over UDP) is asked for at
    /// once, not at the next one-second poll.
    behind: tokio::sync::Notify,
    config: PeerConfig,
    /// The learner, when the fleet learns.
    learning: Option<Arc<Learning>>,
}

impl Shared {
    /// A beacon heard on `key`: filed in the table (marked local when it
    /// is this member's own, as sent), and the asker woken when it shows a
    /// newer mission revision than the one held.
    fn on_beacon(&self, key: &str, bytes: &[u8]) {
        let local = wire::Keys::parse_beacon(key).is_some_and(|(_, id)| {
            self.sent
                .lock()
                .expect("sent lock")
                .get(id)
                .map(|b| b.as_slice())
                == Some(bytes)
        });
        let ageing = self.config.ageing;
        let rev = self.table.lock().expect("table lock").offer(
            key,
            bytes,
            local,
            Instant::now(),
            utc_now(),
            &ageing,
        );
        let held = self.mission.borrow().as_ref().map(|r| r.revision);
        if rev.is_some_and(|rev| held.is_none_or(|h| rev > h)) {
            self.behind.notify_one();
        }
    }

    /// An answer to this member's own query: the fleet's members answer
    /// with whatever revision they hold, most of them the one this member
    /// already has or an older one; only a newer one is news (the rest are
    /// not refusals, nobody sent them unasked).
    fn offer_answer(&self, bytes: &[u8]) {
        let held = self.mission.borrow().as_ref().map(|r| r.revision);
        if let (Ok(doc), Some(h)) = (wire::decode_mission(bytes), held)
            && doc.revision <= h
        {
            return;
        }
        self.offer_mission(bytes);
    }

    fn offer_mission(&self, bytes: &[u8]) {
        let result = wire::decode_mission(bytes).and_then(|doc| {
            let mut board = self.board.lock().expect("board lock");
            let changed = board.offer(doc)?;
            if changed {
                self.mission.send_replace(board.current());
            }
            Ok(changed)
        });
        match result {
            Ok(true) => {
                let region = self
                    .mission
                    .borrow()
                    .as_ref()
                    .map(|r| r.mission.region().clone());
                self.table.lock().expect("table lock").set_region(region);
                let rev = self.mission.borrow().as_ref().map(|r| r.revision);
                if let Some(rev) = rev {
                    tracing::info!(fleet = %self.keys.fleet, revision = rev, "took a new mission revision");
                }
            }
            Ok(false) => {}
            Err(why) => {
                tracing::warn!(fleet = %self.keys.fleet, reason = why.name(), "refused a mission document");
                self.table.lock().expect("table lock").refuse(why);
            }
        }
    }
}

/// This process's membership of a peer fleet: its Zenoh session and what
/// the fleet-wide declarations (running in the background until the
/// session closes) share with its vessels.
pub struct Member {
    session: zenoh::Session,
    shared: Arc<Shared>,
}

impl listen::Listener for Shared {
    fn on_beacon(&self, key: &str, bytes: &[u8]) {
        Shared::on_beacon(self, key, bytes);
    }
    fn offer_mission(&self, bytes: &[u8]) {
        Shared::offer_mission(self, bytes);
    }
    fn current_mission(&self) -> Option<Arc<Revision>> {
        self.board.lock().expect("board lock").current()
    }
}

impl std::fmt::Debug for Member {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Member")
            .field("fleet", &self.shared.keys.fleet)
            .field("zid", &self.session.zid())
            .finish()
    }
}

impl Member {
    /// Opens the session and declares what every vessel of this process
    /// shares: every fleet's beacons, the mission key and its queryable;
    /// until a mission is held it asks the fleet for one every second.
    /// `own` are the ids this process's vessels use (more may be claimed).
    pub async fn join(
        config: PeerConfig,
        own: impl IntoIterator<Item = String>,
        tasks: &TaskTracker,
        shutdown: &CancellationToken,
    ) -> Result<Arc<Member>, PeerError> {
        let zerr = |e: zenoh::Error| PeerError::Zenoh(e.to_string());
        let session = zenoh::open(config.zenoh.config()?).await.map_err(zerr)?;
        let keys = Keys {
            fleet: config.fleet.clone(),
        };
        let (mission_tx, _) = watch::channel(None);
        let shared = Arc::new(Shared {
            keys: keys.clone(),
            table: Mutex::new(Table::new(&config.fleet, own)),
            board: Mutex::new(Board::default()),
            mission: mission_tx,
            sent: Mutex::new(BTreeMap::new()),
            behind: tokio::sync::Notify::new(),
            config: config.clone(),
            learning: config.learning.map(|s| Arc::new(Learning::new(s))),
        });
        if let Some(doc) = &config.mission {
            let bytes = serde_json::to_vec(doc).expect("documents serialize");
            shared.offer_mission(&bytes);
        }
        tracing::info!(fleet = %config.fleet, zid = %session.zid(), "joined the peer fleet");
        listen::declare(&session, &shared, &keys)
            .await
            .map_err(zerr)?;
        tasks.spawn(ask_while_behind(
            shared.clone(),
            session.clone(),
            shutdown.clone(),
        ));
        if let Some(l) = &shared.learning {
            let missions = shared.mission.subscribe();
            let warp = config.time_warp;
            super::learn::declare(l.clone(), &session, &keys, missions, warp, tasks, shutdown)
                .await
                .map_err(zerr)?;
        }
        Ok(Arc::new(Member { session, shared }))
    }

    /// The mission revisions as this member takes them.
    pub fn missions(&self) -> watch::Receiver<Option<Arc<Revision>>> {
        self.shared.mission.subscribe()
    }

    /// Claims `id` for a vessel of this process: a beacon of that id from
    /// anywhere else is then an id conflict.
    pub fn claim(&self, id: &str) {
        self.shared.table.lock().expect("table lock").claim(id);
    }

    /// Leaves the fleet.
    pub async fn close(&self) {
        let _ = self.session.close().await;
    }

    /// A vessel whose hull is elsewhere (an autopilot behind the MAVLink
    /// bridge): its newest pose in `poses` (local plane), its commands out
    /// on `commands`, the same beacons, loop and rules as a simulated one.
    /// The loop runs on the hull's own clock (the poses' `t`, the
    /// autopilot's boot time), once per mission tick of it, so its rate
    /// limits hold in the boat's time whatever the simulator's speed-up;
    /// `astern` false keeps the guidance ahead only (a Rover boat is given
    /// a speed, never a direction of thrust), as the coordinator does for
    /// a link that declares it. Without a mission, or without a pose newer
    /// than [`POSE_STALE`], it commands nothing, so the autopilot's own
    /// timeout stops the boat. Its sensor's readings (`samples`, where the
    /// boat was) go to the fleet's learner when the fleet learns.
    #[allow(clippy::too_many_arguments)]
    pub async fn link(
        self: Arc<Self>,
        id: String,
        mut poses: watch::Receiver<Option<crate::protocol::PoseDocument>>,
        commands: tokio::sync::mpsc::Sender<crate::agent::link::Inbound>,
        mut samples: Option<tokio::sync::mpsc::Receiver<crate::protocol::LinkSampleDocument>>,
        astern: bool,
        stop: CancellationToken,
    ) {
        self.claim(&id);
        let Ok(mut v) = Declared::new(&self, &id).await else {
            tracing::error!(vessel = %id, "could not declare the vessel on the fleet");
            return;
        };
        v.set_ahead_only(!astern);
        let mut last_step: Option<f64> = None;
        let mut pose: Option<(crate::protocol::PoseDocument, Instant)> = None;
        let mut beacons =
            tokio::time::interval(Duration::from_secs_f64(1.0 / self.shared.config.beacon_hz));
        beacons.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tokio::select! {
                _ = stop.cancelled() => break,
                changed = poses.changed() => {
                    if changed.is_err() { break }
                    let Some(p) = poses.borrow_and_update().clone() else { continue };
                    // One step per mission tick of the hull's own clock (a
                    // clock that went back, a rebooted autopilot, restarts it).
                    let period = v.current.as_ref().map_or(0.1, |r| 1.0 / r.mission.tick_hz());
                    let due = last_step.is_none_or(|l| p.t - l >= period - 1e-6 || p.t < l);
                    if due
                        && let Some(command) = v.step(&self.shared, &super::step::state_of_pose(&p), p.t)
                    {
                        last_step = Some(p.t);
                        let _ = commands.try_send(crate::agent::link::Inbound::Command(command));
                    }
                    pose = Some((p, Instant::now()));
                }
                Ok(()) = v.missions.changed() => v.take_mission(),
                Ok(query) = v.status.recv_async() => v.answer(&self.shared, query).await,
                Some(s) = async { match samples.as_mut() {
                    Some(r) => r.recv().await,
                    None => std::future::pending().await,
                } } => v.measured(&self.shared, s.x, s.y, s.value, s.sd).await,
                _ = beacons.tick() => {
                    if let Some((p, at)) = &pose && at.elapsed() < POSE_STALE {
                        let controlled = p.controlled.unwrap_or(true) && v.current.is_some();
                        v.beacon(&self.shared, &super::step::state_of_pose(p), controlled).await;
                    }
                }
            }
        }
    }

    /// A simulated vessel: its hull on board, driven by its own loop.
    pub async fn simulate(self: Arc<Self>, vessel: VesselConfig, stop: CancellationToken) {
        if let Err(e) = run_vessel(
            self.shared.clone(),
            self.session.clone(),
            vessel.clone(),
            stop,
        )
        .await
        {
            tracing::error!(vessel = %vessel.id, error = %crate::chain::Chain(&e), "peer vessel stopped");
        }
    }
}

/// A pose older than this is not announced nor steered by.
pub const POSE_STALE: Duration = Duration::from_secs(2);

/// Runs `vessels` as members of the peer fleet until `shutdown`.
pub async fn run(
    config: PeerConfig,
    vessels: Vec<VesselConfig>,
    shutdown: CancellationToken,
) -> Result<(), PeerError> {
    let tasks = TaskTracker::new();
    let member = Member::join(
        config,
        vessels.iter().map(|v| v.id.clone()),
        &tasks,
        &shutdown,
    )
    .await?;
    tracing::info!(vessels = vessels.len(), "peer vessels starting");
    for vessel in vessels {
        tasks.spawn(member.clone().simulate(vessel, shutdown.clone()));
    }
    tasks.close();
    tasks.wait().await;
    member.close().await;
    Ok(())
}

/// One vessel's declarations on the fleet and its loop's state: what a
/// simulated hull and an autopilot's link share.
struct Declared {
    id: String,
    /// Its own actuator, when it declares one.
    own_actuator: Option<crate::protocol::ActuatorDocument>,
    _token: zenoh::liveliness::LivelinessToken,
    publisher: zenoh::pubsub::Publisher<'static>,
    status: zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<zenoh::query::Query>>,
    missions: watch::Receiver<Option<Arc<Revision>>>,
    current: Option<Arc<Revision>>,
    guidance: Option<Guidance>,
    scratch: Scratch,
    seq: u8,
    ticks: u64,
    partition: usize,
    /// When `partition` last changed (UTC, s; 0 before it ever did).
    partition_since: f64,
    controlled: bool,
    /// The hull cannot go astern: its guidance is ahead only.
    ahead_only: bool,
    /// The plan it follows while the fleet is split.
    split: Split,
    /// The split plan being computed off the loop.
    planning: OffTick,
    /// Since when (mission time) it has heard no other vessel and holds,
    /// while it does.
    alone: Option<f64>,
    /// While it (re)joins the fleet: it holds until its neighbourhood is
    /// heard whole (see [`Joining`]).
    joining: Option<Joining>,
    /// Its samples' publisher, when the fleet learns.
    outbox: Option<Outbox>,
    /// How long its newest steps with a mission took.
    step_times: StepTimes,
}

impl Declared {
    async fn new(member: &Member, id: &str) -> Result<Declared, PeerError> {
        if !wire::valid_peer_id(id) {
            return Err(PeerError::Id(id.to_string()));
        }
        let zerr = |e: zenoh::Error| PeerError::Zenoh(e.to_string());
        let (session, keys) = (&member.session, &member.shared.keys);
        let token = session
            .liveliness()
            .declare_token(keys.alive(id))
            .await
            .map_err(zerr)?;
        let publisher = session
            .declare_publisher(keys.beacon(id))
            .congestion_control(CongestionControl::Drop)
            .express(true)
            .await
            .map_err(zerr)?;
        let status = session
            .declare_queryable(keys.status(id))
            .await
            .map_err(zerr)?;
        let outbox = match &member.shared.learning {
            Some(_) => Some(Outbox::declare(session, keys, id).await.map_err(zerr)?),
            None => None,
        };
        let mut missions = member.shared.mission.subscribe();
        let current = missions.borrow_and_update().clone();
        let guidance = current
            .as_ref()
            .map(|r| Guidance::new(r.mission.guidance()));
        let own_actuator = member.shared.config.actuators.of(id);
        match own_actuator {
            Some(a) => {
                tracing::info!(vessel = %id, fleet = %keys.fleet, k = a.k, beta = a.beta, "peer vessel joined")
            }
            None => {
                tracing::info!(vessel = %id, fleet = %keys.fleet, "peer vessel joined with the mission's actuator")
            }
        }
        Ok(Declared {
            id: id.to_string(),
            own_actuator,
            _token: token,
            publisher,
            status,
            missions,
            current,
            guidance,
            scratch: Scratch::default(),
            seq: 0,
            ticks: 0,
            partition: 0,
            partition_since: 0.0,
            controlled: false,
            ahead_only: false,
            split: Split::default(),
            planning: OffTick::default(),
            alone: None,
            joining: Some(Joining::START),
            outbox,
            step_times: StepTimes::default(),
        })
    }

    /// The hold of a vessel that hears no other vessel, or is still
    /// joining the fleet it has begun to hear (see [`Joining`]); `None`
    /// once it covers.
    fn hold_while_joining(
        &mut self,
        shared: &Shared,
        own: &crate::control::model::State,
        t: f64,
    ) -> Option<crate::protocol::CommandDocument> {
        let ageing = &shared.config.ageing;
        let heard =
            shared
                .table
                .lock()
                .expect("table lock")
                .others_heard(&self.id, Instant::now(), ageing);
        if heard == 0 {
            if self.alone.is_none() {
                tracing::warn!(vessel = %self.id, fleet = %shared.keys.fleet, "hears no other vessel of the fleet (none there, or its credentials refused): holding station; --alone covers alone");
                self.alone = Some(t);
            }
            self.joining = None;
            self.set_partition(0);
            return Some(super::step::hold(
                self.ticks,
                own,
                "hears no other vessel of the fleet",
            ));
        }
        if let Some(since) = self.alone.take() {
            tracing::info!(vessel = %self.id, held = t - since, heard, "hears the fleet: joining");
            self.joining = Some(Joining {
                began: t,
                newest: t,
                heard,
            });
        }
        let joining = self.joining.as_mut()?;
        if !joining.settled(heard, t, ageing.stale_after) {
            self.set_partition(0);
            return Some(super::step::hold(self.ticks, own, "joining the fleet"));
        }
        tracing::info!(vessel = %self.id, joined_in = t - joining.began, heard, "heard the fleet whole: covering");
        self.joining = None;
        None
    }

    fn take_mission(&mut self) {
        self.current = self.missions.borrow_and_update().clone();
        self.guidance = self.current.as_ref().map(|r| {
            let mut g = Guidance::new(r.mission.guidance());
            g.ahead_only = self.ahead_only;
            g
        });
    }

    fn set_partition(&mut self, n: usize) {
        if n != self.partition {
            self.partition = n;
            self.partition_since = utc_now();
        }
    }

    /// Keeps the guidance ahead only (a hull that cannot go astern).
    fn set_ahead_only(&mut self, ahead_only: bool) {
        self.ahead_only = ahead_only;
        if let Some(g) = self.guidance.as_mut() {
            g.ahead_only = ahead_only;
        }
    }

    async fn answer(&self, shared: &Shared, query: zenoh::query::Query) {
        let with_belief = query.parameters().contains_key("belief");
        let mut doc = status_document(
            &shared.table.lock().expect("table lock"),
            &shared.config.ageing,
            &self.id,
            &self.current,
            self.controlled,
            self.partition,
            &self.split,
        );
        doc.alone = self.alone.is_some();
        doc.partition_since = (self.partition_since > 0.0).then_some(self.partition_since);
        doc.step_time = self.step_times.document();
        if let Some(l) = &shared.learning {
            doc.learning = Some(l.document(with_belief));
            for (why, n) in l.refused() {
                doc.refused.insert(why.to_string(), n);
            }
        }
        let json = serde_json::to_vec(&doc).expect("documents serialize");
        let _ = query.reply(shared.keys.status(&self.id), json).await;
    }

    /// The actuator it announces and computes with, as the wire carries
    /// it: its own ([`OwnActuators`](super::OwnActuators)), else the
    /// mission's; before it has either, the paper's default.
    fn actuator(&self) -> (f64, f64) {
        let a = self
            .own_actuator
            .or_else(|| self.current.as_ref().map(|r| r.mission.actuator()));
        match a {
            Some(a) => wire::wire_actuator(a.k, a.beta),
            None => wire::wire_actuator(
                crate::coverage::fleet::DEFAULT_K,
                crate::coverage::fleet::DEFAULT_BETA,
            ),
        }
    }

    /// One tick of the loop on board at mission time `t`; `None` without a
    /// mission (the vessel then holds). Timed for its status.
    fn step(
        &mut self,
        shared: &Shared,
        own: &crate::control::model::State,
        t: f64,
    ) -> Option<crate::protocol::CommandDocument> {
        let started = Instant::now();
        let command = self.steer(shared, own, t);
        if self.current.is_some() {
            self.step_times.record(started.elapsed());
        }
        command
    }

    fn steer(
        &mut self,
        shared: &Shared,
        own: &crate::control::model::State,
        t: f64,
    ) -> Option<crate::protocol::CommandDocument> {
        let actuator = self.actuator();
        if self.current.is_none() || self.guidance.is_none() {
            self.controlled = false;
            return None;
        }
        if !shared.config.alone
            && let Some(held) = self.hold_while_joining(shared, own, t)
        {
            return Some(held);
        }
        let (Some(rev), Some(g)) = (&self.current, self.guidance.as_mut()) else {
            return None;
        };
        let ageing = &shared.config.ageing;
        let neighbours = shared.table.lock().expect("table lock").neighbours_near(
            &self.id,
            (own.x, own.y),
            super::step::relevance(&rev.mission, actuator),
            Instant::now(),
            ageing,
        );
        let tick = Tick {
            mission: &rev.mission,
            revision: rev.revision,
            me: &self.id,
            own,
            actuator,
            neighbours: &neighbours,
            ageing,
            t,
        };
        // A plan computed off the loop is taken on the first tick after it
        // comes (`Split` drops it if its situation has passed); until then
        // the vessel keeps clear of the silent ones as without a plan.
        if let Some(planned) = self.planning.arrived(&self.id) {
            self.split.accept(planned, &tick).log(&self.id, t);
        }
        let (orders, change, job) = self.split.look(&tick);
        change.log(&self.id, t);
        if let Some(job) = job {
            self.planning.spawn(job);
        }
        // The other group stays an obstacle where it fell silent too, not
        // only where the plan has it: two boats lost at once look like a
        // partition, and a wreck does not follow the plan.
        // The belief fitted under this revision, once there is one; the
        // mission's risk (its prior) until then.
        let belief = shared
            .learning
            .as_ref()
            .and_then(|l| l.belief(rev.revision));
        let risk = belief.as_ref().map_or(rev.mission.risk(), |b| &b.density);
        let step = super::step::step(
            &rev.mission,
            risk,
            own,
            actuator,
            &neighbours,
            orders.as_ref(),
            g,
            t,
            self.ticks,
            &mut self.scratch,
        );
        self.ticks += 1;
        self.set_partition(step.partition);
        Some(step.command)
    }

    /// A measurement of the risk field at (x, y), when the fleet learns.
    async fn measured(&mut self, shared: &Shared, x: f64, y: f64, value: f64, sd: f64) {
        if let (Some(outbox), Some(l)) = (self.outbox.as_mut(), &shared.learning) {
            outbox.measured(l, x, y, value, sd).await;
        }
    }

    /// Publishes the beacon of `s`: express and dropped on congestion, so
    /// it never waits on a slow link.
    async fn beacon(
        &mut self,
        shared: &Shared,
        s: &crate::control::model::State,
        controlled: bool,
    ) {
        self.controlled = controlled;
        let doc = wire::beacon_of(
            s,
            wire::Said {
                id: &self.id,
                seq: self.seq,
                t: utc_now(),
                actuator: self.actuator(),
                rev: self.current.as_ref().map_or(0, |r| r.revision),
                controlled,
            },
        );
        self.seq = self.seq.wrapping_add(1);
        if let Some(outbox) = self.outbox.as_mut() {
            outbox.flush_due(utc_now()).await;
        }
        let bytes = wire::encode(&doc);
        shared
            .sent
            .lock()
            .expect("sent lock")
            .insert(self.id.clone(), bytes.clone());
        if let Err(e) = self.publisher.put(bytes).await {
            tracing::debug!(vessel = %self.id, error = %e, "beacon not sent");
        }
    }
}

/// One simulated vessel: its declarations, hull and loop.
async fn run_vessel(
    shared: Arc<Shared>,
    session: zenoh::Session,
    vessel: VesselConfig,
    shutdown: CancellationToken,
) -> Result<(), PeerError> {
    let member = Member {
        session,
        shared: shared.clone(),
    };
    let mut v = Declared::new(&member, &vessel.id).await?;
    let config = &shared.config;
    let mut onboard = Onboard::new(&vessel).without_keeper();
    let mut sensor = config
        .sensor
        .as_ref()
        .map(|s| crate::agent::sensor::Sensor::new(s, config.seed, &vessel.id));
    let period = 0.05; // the hull's step between looks at the world [s]
    let beacon_every = 1.0 / config.beacon_hz;
    let (mut next_beacon, mut next_control) = (0.0, 0.0);
    let mut ticker = tokio::time::interval(Duration::from_secs_f64(period / config.time_warp));
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            Ok(()) = v.missions.changed() => v.take_mission(),
            Ok(query) = v.status.recv_async() => v.answer(&shared, query).await,
            _ = ticker.tick() => {
                onboard.advance(period);
                let t = onboard.t;
                let (x, y) = (onboard.state.x, onboard.state.y);
                if let Some((value, sd)) = sensor.as_mut().and_then(|s| s.read(t, crate::geometry::Point { x, y })) {
                    v.measured(&shared, x, y, value, sd).await;
                }
                // Each schedule keeps its own phase: counted from the
                // step that fired it, a rate that does not divide the
                // hull's 20 Hz would be rounded down to one that does (3
                // Hz beaconed at 2.86). A faster one (a mission may tick
                // at 100 Hz) fires at every step, without a backlog.
                if t + 1e-9 >= next_control {
                    let hz = v.current.as_ref().map_or(10.0, |r| r.mission.tick_hz());
                    next_control = (next_control + 1.0 / hz).max(t);
                    if let Some(command) = v.step(&shared, &onboard.state, t) {
                        onboard.command = Some((command, t));
                    }
                }
                if t + 1e-9 >= next_beacon {
                    next_beacon = (next_beacon + beacon_every).max(t);
                    let controlled = v.current.is_some();
                    let state = onboard.state;
                    v.beacon(&shared, &state, controlled).await;
                }
            }
        }
    }
    tracing::info!(vessel = %vessel.id, "peer vessel left");
    Ok(())
}

/// Until a mission is held, and whenever a neighbour's beacon shows a
/// newer revision than the one held (one published while this member was
/// cut off, or a put lost on UDP), asks the fleet for it: at once when such
/// a beacon arrives, then again every second while behind, but never more
/// often than every 200 ms.
async fn ask_while_behind(s: Arc<Shared>, z: zenoh::Session, stop: CancellationToken) {
    while !stop.is_cancelled() {
        let held = s.mission.borrow().as_ref().map(|r| r.revision);
        let newest = s.table.lock().expect("table lock").newest_revision();
        let behind = match held {
            None => true,
            Some(h) => newest.is_some_and(|n| n > h),
        };
        // No consolidation: Zenoh's default for a get (`Latest`)
        // holds every reply back until the last member has
        // answered, then keeps one per key, without timestamps the
        // last to arrive, often a neighbour's older revision. Each
        // answer is taken as it comes; the board keeps the newest.
        if behind
            && let Ok(replies) = z
                .get(s.keys.mission())
                .consolidation(ConsolidationMode::None)
                .timeout(Duration::from_secs(1))
                .await
        {
            while let Ok(reply) = replies.recv_async().await {
                if let Ok(sample) = reply.result() {
                    s.offer_answer(&sample.payload().to_bytes());
                }
            }
        }
        let woken = async {
            tokio::time::sleep(Duration::from_millis(200)).await;
            s.behind.notified().await;
        };
        tokio::select! {
            _ = stop.cancelled() => break,
            _ = tokio::time::sleep(Duration::from_secs(1)) => {}
            _ = woken => {}
        }
    }
}
