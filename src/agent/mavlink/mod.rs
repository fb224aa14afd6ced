//! `seacover agent --mavlink ENDPOINT …`: puts real autopilots (ArduPilot
//! Rover boats) on the coordinator's vessel links (docs/ardupilot.md).
//!
//! Tasks:
//! - one per endpoint ([`endpoint`]): keeps the MAVLink connection open
//!   (the `mavlink` crate's tokio transports and framing), reconnecting when
//!   it drops, and hands every message to the router;
//! - the router ([`run`]'s loop): learns vehicles from their HEARTBEATs
//!   (system id → vessel `mav-<sysid>`, or `--id`), binds each to the
//!   endpoint it was first heard on, refuses what does not fit (a second
//!   vehicle with the same system id, ground stations), forgets a vehicle
//!   silent for [`LOST_AFTER`] and takes it back when it returns;
//! - one per vehicle: the [`vehicle::Vehicle`] rules, its coordinator
//!   [`link`](super::link), and its setpoints;
//! - the bridge's own HEARTBEAT (a ground station's) on every endpoint at
//!   1 Hz; the mission's origin, read from the coordinator at start and
//!   followed while the bridge runs.
//!
//! Invariants: nothing read from a link can stop the bridge: every refusal
//! is counted ([`Tally`]) and logged; a vehicle's messages reach only its
//! own task; the bridge moves a vehicle only through [`vehicle::Vehicle`].

pub mod vehicle;

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::{
    HEARTBEAT_DATA, MavAutopilot, MavMessage, MavModeFlag, MavState, MavType,
};
use mavlink::{AsyncMavConnection, MavHeader};
use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use super::link::{self, LinkConfig};
use crate::geometry::geodesy::{LatLon, LocalFrame};
use crate::protocol::{MissionDocument, OriginDocument};
pub use vehicle::SampleSource;
use vehicle::{Refusal, Vehicle};

/// A vehicle whose HEARTBEAT has not been heard for this long is lost: the
/// bridge stops reporting it, so the coordinator's liveness timeout hands
/// its cell to the others.
pub const LOST_AFTER: Duration = Duration::from_secs(3);

/// The bridge's settings.
#[derive(Debug, Clone)]
pub struct BridgeConfig {
    /// The coordinator's base URL (`http://host:port`).
    pub server: String,
    /// MAVLink endpoints in the `mavlink` crate's forms.
    pub endpoints: Vec<String>,
    /// Switch each vehicle to GUIDED and arm it, once, at start.
    pub arm: bool,
    /// Each vehicle keeps station on arrival by itself (ArduPilot's
    /// loiter) once within this of its goal [m]; `None`: the coordinator
    /// steers it to the end.
    pub station_radius: Option<f64>,
    /// NAMED_VALUE_FLOATs of this name are samples of the risk field
    /// (docs/learning.md), sent over each boat's link.
    pub sample: Option<vehicle::SampleSource>,
    pub token: Option<String>,
    /// The vessel id of the only vehicle (instead of `mav-<sysid>`).
    pub id: Option<String>,
    /// The bridge's own MAVLink system id (a ground station's; ArduPilot's
    /// `SYSID_MYGCS` is 255 by default).
    pub sysid: u8,
    /// How often the mission's origin is read again.
    pub origin_poll: Duration,
    /// Be each boat's peer node instead of linking it to a coordinator
    /// (`agent --mavlink … --peer`): the mission, its origin and the
    /// commands come from the boat's own loop on board.
    pub peer: Option<Arc<crate::agent::peer::node::Member>>,
}

/// Why the bridge could not start.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    #[error("--server must be an http:// URL, got {0:?}")]
    Server(String),
    #[error(
        "--mavlink {endpoint:?}: {source}; an endpoint is one of tcpout:HOST:PORT, \
         tcpin:ADDR:PORT, udpin:ADDR:PORT, udpout:HOST:PORT, serial:DEVICE:BAUD"
    )]
    Endpoint {
        endpoint: String,
        source: std::io::Error,
    },
    #[error("reading the mission from {url}: {message}")]
    Mission { url: String, message: String },
    #[error(
        "the coordinator's mission has no origin: a MAVLink vehicle reports latitude and \
         longitude, which need one (PUT /api/v1/mission/origin {{\"lat\": …, \"lon\": …}})"
    )]
    NoOrigin,
    #[error("the mission's origin is not valid")]
    Origin(#[source] crate::geometry::geodesy::GeoError),
    /// A vehicle's link gave up (its token refused): the bridge stops.
    #[error(transparent)]
    Link(#[from] link::LinkError),
}

/// What the bridge refused, by kind; logged when it changes and at exit.
#[derive(Debug, Default)]
pub struct Tally {
    /// Frames the `mavlink` crate could not decode (unknown message ids,
    /// invalid enum values, oversized payloads). Bytes that are not a
    /// frame at all, or frames whose CRC fails, are skipped inside the
    /// crate's decoder; they show as `frames_lost` when they hit a
    /// vehicle's own stream.
    pub undecodable: AtomicU64,
    /// Frames missing from a vehicle's sequence numbers.
    pub frames_lost: AtomicU64,
    /// The first vehicle link that gave up (a refused token), which stops
    /// the bridge.
    pub given_up: std::sync::Mutex<Option<link::LinkError>>,
    /// Messages claiming the system id of a vehicle heard elsewhere first.
    pub duplicate_sysid: AtomicU64,
    /// Positions that are not finite or out of WGS84's range.
    pub invalid_position: AtomicU64,
    /// Positions farther than [`LocalFrame::RANGE`] from the origin.
    pub far_from_origin: AtomicU64,
    /// Attitudes with a non-finite yaw or yaw rate.
    pub invalid_attitude: AtomicU64,
    /// Samples with a non-finite value or before any position.
    pub invalid_sample: AtomicU64,
    /// Vehicles beyond the first when `--id` names one.
    pub extra_vehicles: AtomicU64,
}

impl Tally {
    fn refused(&self, r: Refusal) {
        let counter = match r {
            Refusal::InvalidPosition => &self.invalid_position,
            Refusal::FarFromOrigin => &self.far_from_origin,
            Refusal::InvalidAttitude => &self.invalid_attitude,
            Refusal::InvalidSample => &self.invalid_sample,
        };
        counter.fetch_add(1, Ordering::Relaxed);
    }

    fn counts(&self) -> [(&'static str, u64); 8] {
        let get = |c: &AtomicU64| c.load(Ordering::Relaxed);
        [
            ("undecodable", get(&self.undecodable)),
            ("frames_lost", get(&self.frames_lost)),
            ("duplicate_sysid", get(&self.duplicate_sysid)),
            ("invalid_position", get(&self.invalid_position)),
            ("far_from_origin", get(&self.far_from_origin)),
            ("invalid_attitude", get(&self.invalid_attitude)),
            ("invalid_sample", get(&self.invalid_sample)),
            ("extra_vehicles", get(&self.extra_vehicles)),
        ]
    }

    /// One log line with every count.
    pub fn log(&self, what: &str) {
        let c = self.counts();
        tracing::info!(
            undecodable = c[0].1,
            frames_lost = c[1].1,
            duplicate_sysid = c[2].1,
            invalid_position = c[3].1,
            far_from_origin = c[4].1,
            invalid_attitude = c[5].1,
            extra_vehicles = c[6].1,
            "{what}"
        );
    }
}

type Connection = mavlink::AsyncConnection<MavMessage>;

/// One endpoint's current connection (none while it reconnects).
type Current = watch::Receiver<Option<Arc<Connection>>>;

/// A message as the router gets it.
struct Incoming {
    endpoint: usize,
    header: MavHeader,
    message: MavMessage,
}

/// Reads the mission's origin from the coordinator.
async fn fetch_origin(
    http: &reqwest::Client,
    config: &BridgeConfig,
) -> Result<Option<OriginDocument>, BridgeError> {
    let url = format!("{}/api/v1/mission", config.server.trim_end_matches('/'));
    let err = |message: String| BridgeError::Mission {
        url: url.clone(),
        message,
    };
    let mut request = http.get(&url);
    if let Some(token) = &config.token {
        request = request.bearer_auth(token);
    }
    let response = request.send().await.map_err(|e| err(e.to_string()))?;
    if !response.status().is_success() {
        return Err(err(format!("HTTP {}", response.status())));
    }
    let mission: MissionDocument = response.json().await.map_err(|e| err(e.to_string()))?;
    Ok(mission.origin)
}

fn frame_of(origin: OriginDocument) -> Result<LocalFrame, BridgeError> {
    LocalFrame::new(LatLon {
        lat: origin.lat,
        lon: origin.lon,
    })
    .map_err(BridgeError::Origin)
}

/// Where the boats are placed: the coordinator's link URL (none in a peer
/// fleet) and the mission's local frame, which a task started here keeps
/// following (the coordinator's origin, or the fleet's mission). `None`
/// when shut down while waiting for the fleet's mission.
async fn placed(
    config: &BridgeConfig,
    tasks: &TaskTracker,
    shutdown: &CancellationToken,
) -> Result<Option<(String, watch::Receiver<LocalFrame>)>, BridgeError> {
    let (url, frames, frame) = match &config.peer {
        None => {
            let url = link::link_url(&config.server)
                .filter(|_| config.server.starts_with("http"))
                .ok_or_else(|| BridgeError::Server(config.server.clone()))?;
            let http = reqwest::Client::builder()
                .timeout(Duration::from_secs(5))
                .build()
                .expect("a plain HTTP client builds");
            let origin = fetch_origin(&http, config)
                .await?
                .ok_or(BridgeError::NoOrigin)?;
            let (frames, frame) = watch::channel(frame_of(origin)?);
            tracing::info!(lat = origin.lat, lon = origin.lon, "mission origin");
            tasks.spawn(follow_origin(
                http,
                config.clone(),
                frames,
                shutdown.clone(),
            ));
            (url, None, frame)
        }
        Some(member) => {
            // The fleet's mission gives the origin; the boats wait for it.
            let mut missions = member.missions();
            let origin = loop {
                let origin = missions
                    .borrow_and_update()
                    .as_ref()
                    .map(|r| r.mission.origin());
                match origin {
                    Some(Some(o)) => break o,
                    Some(None) => return Err(BridgeError::NoOrigin),
                    None => {
                        tracing::info!(
                            "waiting for the fleet's mission (its origin places the boats)"
                        );
                        tokio::select! {
                            _ = shutdown.cancelled() => return Ok(None),
                            changed = missions.changed() => if changed.is_err() { return Ok(None) },
                        }
                    }
                }
            };
            let (frames, frame) = watch::channel(frame_of(origin)?);
            tracing::info!(
                lat = origin.lat,
                lon = origin.lon,
                "mission origin, from the fleet"
            );
            (String::new(), Some((frames, missions)), frame)
        }
    };
    if let Some((frames, missions)) = frames {
        tasks.spawn(follow_fleet_origin(missions, frames, shutdown.clone()));
    }
    Ok(Some((url, frame)))
}

/// Runs the bridge until `shutdown`. Fails only at start: a coordinator
/// that cannot be read, a mission without an origin, a malformed endpoint.
pub async fn run(config: BridgeConfig, shutdown: CancellationToken) -> Result<(), BridgeError> {
    for e in &config.endpoints {
        mavlink::ConnectionAddress::parse_address(e).map_err(|source| BridgeError::Endpoint {
            endpoint: e.clone(),
            source,
        })?;
    }
    let tasks = TaskTracker::new();
    let Some((url, frame)) = placed(&config, &tasks, &shutdown).await? else {
        return Ok(());
    };

    let tally = Arc::new(Tally::default());
    let (incoming_tx, mut incoming) = mpsc::channel::<Incoming>(1024);
    let mut connections: Vec<Current> = Vec::new();
    for (i, address) in config.endpoints.iter().enumerate() {
        let (current_tx, current) = watch::channel(None);
        connections.push(current);
        tasks.spawn(endpoint(
            i,
            address.clone(),
            current_tx,
            incoming_tx.clone(),
            tally.clone(),
            shutdown.clone(),
        ));
    }
    drop(incoming_tx);
    tasks.spawn(heartbeats(
        connections.clone(),
        config.sysid,
        shutdown.clone(),
    ));

    let mut vehicles: HashMap<u8, Entry> = HashMap::new();
    let mut check = tokio::time::interval(Duration::from_millis(200));
    let mut logged = tally.counts();
    let mut last_log = Instant::now();
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            message = incoming.recv() => {
                let Some(m) = message else { break };
                route(m, &mut vehicles, &config, &url, &connections, &frame, &tally, &tasks, &shutdown);
            }
            _ = check.tick() => {
                vehicles.retain(|sysid, e| {
                    let alive = e.heard.elapsed() < LOST_AFTER;
                    if !alive {
                        tracing::warn!(sysid, vessel = %e.vessel, "vehicle lost: no HEARTBEAT for 3 s; no longer reported");
                    }
                    alive
                });
                let counts = tally.counts();
                if counts != logged && last_log.elapsed() >= Duration::from_secs(1) {
                    tally.log("refused MAVLink input so far");
                    logged = counts;
                    last_log = Instant::now();
                }
            }
        }
    }
    // Dropping every vehicle's sender ends its task, which closes its link.
    vehicles.clear();
    tasks.close();
    let _ = tokio::time::timeout(Duration::from_secs(2), tasks.wait()).await;
    tally.log("bridge stopped; refused MAVLink input");
    match tally.given_up.lock().expect("tally lock").take() {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

/// A known vehicle.
struct Entry {
    endpoint: usize,
    compid: u8,
    mavtype: MavType,
    autopilot: MavAutopilot,
    vessel: String,
    heard: Instant,
    /// The next sequence number expected from the autopilot.
    next_seq: u8,
    tx: mpsc::Sender<MavMessage>,
}

#[allow(clippy::too_many_arguments)]
fn route(
    m: Incoming,
    vehicles: &mut HashMap<u8, Entry>,
    config: &BridgeConfig,
    url: &str,
    connections: &[Current],
    frame: &watch::Receiver<LocalFrame>,
    tally: &Arc<Tally>,
    tasks: &TaskTracker,
    shutdown: &CancellationToken,
) {
    // MAVLink's 32-bit system ids are no ArduPilot's: ignore them.
    let Ok(sysid) = u8::try_from(m.header.system_id) else {
        return;
    };
    if sysid == config.sysid {
        return; // our own heartbeat echoed by a shared link
    }
    if let Some(e) = vehicles.get_mut(&sysid) {
        let same = e.endpoint == m.endpoint
            && e.compid == m.header.component_id
            && match &m.message {
                MavMessage::HEARTBEAT(hb) => hb.mavtype == e.mavtype && hb.autopilot == e.autopilot,
                _ => true,
            };
        if !same {
            if m.header.component_id == e.compid || matches!(m.message, MavMessage::HEARTBEAT(_)) {
                tally.duplicate_sysid.fetch_add(1, Ordering::Relaxed);
            }
            return;
        }
        let lost = m.header.sequence.wrapping_sub(e.next_seq);
        // A jump of more than half the sequence space is a reordering or
        // a reboot, not a loss.
        if lost < 128 {
            tally
                .frames_lost
                .fetch_add(u64::from(lost), Ordering::Relaxed);
        }
        e.next_seq = m.header.sequence.wrapping_add(1);
        if matches!(m.message, MavMessage::HEARTBEAT(_)) {
            e.heard = Instant::now();
        }
        // A vehicle task that is behind loses a message rather than
        // holding up every other vehicle's.
        let _ = e.tx.try_send(m.message);
        return;
    }
    let MavMessage::HEARTBEAT(hb) = &m.message else {
        return; // not known yet: wait for its heartbeat
    };
    if !vehicle::is_vehicle(hb) {
        return;
    }
    let vessel = match &config.id {
        Some(id) if vehicles.is_empty() => id.clone(),
        Some(_) => {
            tally.extra_vehicles.fetch_add(1, Ordering::Relaxed);
            return;
        }
        None => format!("mav-{sysid}"),
    };
    tracing::info!(sysid, %vessel, endpoint = %config.endpoints[m.endpoint], "vehicle found");
    let (tx, rx) = mpsc::channel(256);
    let _ = tx.try_send(m.message.clone());
    tasks.spawn(run_vehicle(
        Vehicle::new(sysid, m.header.component_id, *frame.borrow(), config.arm)
            .holding_station(config.station_radius)
            .sampling(config.sample.clone()),
        LinkConfig {
            url: url.to_string(),
            token: config.token.clone(),
            vessel: vessel.clone(),
            seed: u64::from(sysid),
            // SET_POSITION_TARGET gives Rover a speed, never a direction
            // of thrust: it cannot be told to go astern.
            astern: Some(false),
            // The autopilot bounds its own targets (ATC_STR_ACC_MAX,
            // ATC_ACCEL_MAX); the mission's yaw_accel is the former's
            // default, so there is nothing tighter to declare.
            agility: None,
            station_radius: config.station_radius,
        },
        rx,
        frame.clone(),
        connections[m.endpoint].clone(),
        config.sysid,
        tally.clone(),
        config.peer.clone(),
        shutdown.clone(),
    ));
    vehicles.insert(
        sysid,
        Entry {
            endpoint: m.endpoint,
            compid: m.header.component_id,
            mavtype: hb.mavtype,
            autopilot: hb.autopilot,
            vessel,
            heard: Instant::now(),
            next_seq: m.header.sequence.wrapping_add(1),
            tx,
        },
    );
}

/// The bridge's header: a ground station's system id, the onboard
/// computer's component id.
fn header(sysid: u8) -> MavHeader {
    MavHeader {
        system_id: u32::from(sysid),
        component_id: 191, // MAV_COMP_ID_ONBOARD_COMPUTER
        sequence: 0,
    }
}

async fn send(connection: &Current, sysid: u8, messages: &[MavMessage]) {
    let Some(c) = connection.borrow().clone() else {
        return;
    };
    for m in messages {
        if let Err(e) = c.send(&header(sysid), m).await {
            tracing::debug!(error = %e, "sending to a vehicle");
        }
    }
}

#[allow(clippy::too_many_arguments)]
async fn run_vehicle(
    mut v: Vehicle,
    link_config: LinkConfig,
    mut messages: mpsc::Receiver<MavMessage>,
    mut frame: watch::Receiver<LocalFrame>,
    connection: Current,
    sysid: u8,
    tally: Arc<Tally>,
    peer: Option<Arc<crate::agent::peer::node::Member>>,
    shutdown: CancellationToken,
) {
    let vessel = link_config.vessel.clone();
    let stop = shutdown.child_token();
    let (poses, pose_slot) = watch::channel(None);
    let (commands_tx, mut commands) = mpsc::channel(4);
    // Samples wait for the link in a short queue; a full one drops them
    // (the coordinator's learner wants many, not every one).
    let (samples, sample_queue) = mpsc::channel(64);
    let mut sample_queue = Some(sample_queue);
    // The link opens with the first valid pose: a "vehicle" that never
    // gives one (a spoofed heartbeat, a boat without a position) never
    // appears at the coordinator.
    let mut link = Some((link_config, pose_slot, commands_tx));
    let mut link_task = None;
    send(&connection, sysid, &v.stream_requests()).await;
    let mut asked = Instant::now();
    let mut was_controlled = None;
    loop {
        let out = tokio::select! {
            _ = stop.cancelled() => break,
            m = messages.recv() => {
                let Some(m) = m else { break };
                match m {
                    MavMessage::HEARTBEAT(hb) => v.on_heartbeat(&hb),
                    MavMessage::ATTITUDE(a) => {
                        if let Err(r) = v.on_attitude(&a) { tally.refused(r) }
                        Vec::new()
                    }
                    MavMessage::GLOBAL_POSITION_INT(p) => match v.on_position(&p) {
                        Ok((pose, out)) => {
                            if pose.is_some() {
                                poses.send_replace(pose);
                                if let Some((config, slot, tx)) = link.take() {
                                    let sample_queue = sample_queue.take();
                                    link_task = Some(match &peer {
                                        None => {
                                            let (tally, shutdown, stop) = (tally.clone(), shutdown.clone(), stop.clone());
                                            tokio::spawn(async move {
                                                if let Err(e) = link::run(config, slot, sample_queue, tx, stop).await {
                                                    tally.given_up.lock().expect("tally lock").get_or_insert(e);
                                                    shutdown.cancel();
                                                }
                                            })
                                        }
                                        // A peer node: the boat's own loop on board.
                                        Some(m) => tokio::spawn(m.clone().link(config.vessel.clone(), slot, tx, sample_queue, config.astern.unwrap_or(true), stop.clone())),
                                    });
                                }
                            }
                            out
                        }
                        Err(r) => { tally.refused(r); Vec::new() }
                    },
                    MavMessage::GPS_RAW_INT(g) => { v.on_gps(&g); Vec::new() }
                    MavMessage::EKF_STATUS_REPORT(e) => { v.on_ekf_status(&e); Vec::new() }
                    MavMessage::SYS_STATUS(s) => { v.on_sys_status(&s); Vec::new() }
                    MavMessage::NAMED_VALUE_FLOAT(d) => {
                        match v.on_named_value(&d) {
                            Ok(Some(s)) => { let _ = samples.try_send(s); }
                            Ok(None) => {}
                            Err(r) => tally.refused(r),
                        }
                        Vec::new()
                    }
                    _ => Vec::new(),
                }
            }
            c = commands.recv() => match c {
                Some(link::Inbound::Command(c)) => v.on_command(c),
                // ArduPilot takes each target as it comes.
                Some(link::Inbound::Welcome { .. }) => Vec::new(),
                Some(link::Inbound::Lost) => {
                    tracing::warn!(%vessel, "coordinator link lost: stopping the boat");
                    v.on_link_lost()
                }
                None => break,
            },
            changed = frame.changed() => {
                if changed.is_err() { break }
                v.set_frame(*frame.borrow_and_update());
                Vec::new()
            }
        };
        if was_controlled != Some(v.controlled()) {
            if v.controlled() {
                tracing::info!(%vessel, "under control: armed and in GUIDED");
            } else {
                tracing::warn!(%vessel, mode = v.mode(), "not under control: commands stop until the operator puts it back in GUIDED, armed");
            }
            was_controlled = Some(v.controlled());
        }
        send(&connection, sysid, &out).await;
        // Telemetry rates are per link and forgotten by a rebooted
        // autopilot: ask again now and then.
        if asked.elapsed() > Duration::from_secs(10) {
            send(&connection, sysid, &v.stream_requests()).await;
            asked = Instant::now();
        }
    }
    stop.cancel();
    if let Some(task) = link_task {
        let _ = task.await;
    }
}

/// Keeps one endpoint connected and its messages flowing to the router.
async fn endpoint(
    index: usize,
    address: String,
    current: watch::Sender<Option<Arc<Connection>>>,
    incoming: mpsc::Sender<Incoming>,
    tally: Arc<Tally>,
    shutdown: CancellationToken,
) {
    let mut backoff = Duration::from_millis(200);
    while !shutdown.is_cancelled() {
        tracing::info!(%address, "connecting to the MAVLink endpoint");
        let connected = tokio::select! {
            _ = shutdown.cancelled() => return,
            c = mavlink::connect_async::<MavMessage>(&address) => c,
        };
        let mut connection = match connected {
            Ok(c) => c,
            Err(e) => {
                tracing::info!(
                    %address,
                    error = %e,
                    retry_in_ms = backoff.as_millis() as u64,
                    "MAVLink endpoint not reachable; retrying"
                );
                tokio::select! {
                    _ = shutdown.cancelled() => return,
                    _ = tokio::time::sleep(backoff) => {}
                }
                backoff = (backoff * 2).min(Duration::from_secs(5));
                continue;
            }
        };
        backoff = Duration::from_millis(200);
        connection.set_allow_recv_any_version(true);
        let connection = Arc::new(connection);
        current.send_replace(Some(connection.clone()));
        tracing::info!(%address, "MAVLink endpoint connected");
        loop {
            let received = tokio::select! {
                _ = shutdown.cancelled() => return,
                r = connection.recv() => r,
            };
            match received {
                Ok((header, message)) => {
                    let m = Incoming {
                        endpoint: index,
                        header,
                        message,
                    };
                    if incoming.send(m).await.is_err() {
                        return;
                    }
                }
                Err(mavlink::error::MessageReadError::Parse(e)) => {
                    tally.undecodable.fetch_add(1, Ordering::Relaxed);
                    tracing::debug!(%address, error = %e, "undecodable MAVLink frame");
                }
                Err(mavlink::error::MessageReadError::Io(e)) => {
                    tracing::warn!(%address, error = %e, "MAVLink endpoint closed; reconnecting");
                    break;
                }
            }
        }
        current.send_replace(None);
    }
}

/// The bridge's HEARTBEAT, a ground station's, on every endpoint at 1 Hz.
async fn heartbeats(connections: Vec<Current>, sysid: u8, shutdown: CancellationToken) {
    let beat = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    });
    let mut ticker = tokio::time::interval(Duration::from_secs(1));
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = ticker.tick() => {
                for c in &connections {
                    send(c, sysid, std::slice::from_ref(&beat)).await;
                }
            }
        }
    }
}

/// Reads the mission's origin again every `origin_poll`; a change reaches
/// every vehicle's task.
async fn follow_origin(
    http: reqwest::Client,
    config: BridgeConfig,
    frames: watch::Sender<LocalFrame>,
    shutdown: CancellationToken,
) {
    let mut ticker = tokio::time::interval(config.origin_poll);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = ticker.tick() => {}
        }
        match fetch_origin(&http, &config).await {
            Ok(Some(origin)) => match frame_of(origin) {
                Ok(f) if f != *frames.borrow() => {
                    tracing::info!(
                        lat = origin.lat,
                        lon = origin.lon,
                        "the mission's origin moved"
                    );
                    frames.send_replace(f);
                }
                Ok(_) => {}
                Err(e) => {
                    tracing::warn!(error = %crate::chain::Chain(&e), "keeping the previous origin")
                }
            },
            Ok(None) => {
                tracing::warn!("the mission no longer has an origin; keeping the previous one")
            }
            Err(e) => {
                tracing::debug!(error = %crate::chain::Chain(&e), "origin not read this time")
            }
        }
    }
}

/// In a peer fleet: the origin of each new mission revision reaches every
/// vehicle's task.
async fn follow_fleet_origin(
    mut missions: watch::Receiver<Option<Arc<crate::agent::peer::board::Revision>>>,
    frames: watch::Sender<LocalFrame>,
    shutdown: CancellationToken,
) {
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => return,
            changed = missions.changed() => if changed.is_err() { return },
        }
        let origin = missions
            .borrow_and_update()
            .as_ref()
            .and_then(|r| r.mission.origin());
        match origin.map(frame_of) {
            Some(Ok(f)) if f != *frames.borrow() => {
                tracing::info!("the mission's origin moved");
                frames.send_replace(f);
            }
            Some(Ok(_)) => {}
            Some(Err(e)) => {
                tracing::warn!(error = %crate::chain::Chain(&e), "keeping the previous origin")
            }
            None => tracing::warn!("the mission no longer has an origin; keeping the previous one"),
        }
    }
}
