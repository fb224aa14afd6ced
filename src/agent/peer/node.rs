//! The peer process: one Zenoh session, the fleet-wide declarations (every
//! beacon, the mission key and its queryable), and one task per simulated
//! vessel (its liveliness token, beacon publisher, status queryable, hull
//! and loop on board).
//!
//! The subscribers' callbacks only decode and file what they receive
//! (under a short `std` lock, never held across an await); the vessels
//! read the table at their own ticks, so a burst of beacons never delays a
//! hull's step.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::watch;
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;
use zenoh::Wait;
use zenoh::qos::CongestionControl;

use super::board::{Board, Revision};
use super::table::Table;
use super::wire::{self, Keys};
use super::{PeerConfig, PeerError};
use crate::agent::VesselConfig;
use crate::agent::onboard::Onboard;
use crate::control::barrier::Scratch;
use crate::control::guidance::Guidance;
use crate::protocol::peer::{BeaconDocument, PeerStatusDocument};

/// Seconds since 1970 by this machine's (disciplined) clock.
pub fn utc_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// What the fleet-wide declarations share with the vessels.
struct Shared {
    keys: Keys,
    table: Mutex<Table>,
    board: Mutex<Board>,
    mission: watch::Sender<Option<Arc<Revision>>>,
    /// The last beacon each of this process's vessels sent: a sample with
    /// an own id but other bytes is somebody else claiming it.
    sent: Mutex<BTreeMap<String, Vec<u8>>>,
    config: PeerConfig,
}

impl Shared {
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
                let rev = self.mission.borrow().as_ref().map(|r| r.revision);
                tracing::info!(fleet = %self.keys.fleet, revision = ?rev, "took a new mission revision");
            }
            Ok(false) => {}
            Err(why) => {
                tracing::warn!(fleet = %self.keys.fleet, reason = why.name(), "refused a mission document");
                self.table.lock().expect("table lock").refuse(why);
            }
        }
    }
}

/// Runs `vessels` as members of the peer fleet until `shutdown`.
pub async fn run(
    config: PeerConfig,
    vessels: Vec<VesselConfig>,
    shutdown: CancellationToken,
) -> Result<(), PeerError> {
    let zconfig = config.zenoh.config()?;
    let session = zenoh::open(zconfig)
        .await
        .map_err(|e| PeerError::Zenoh(e.to_string()))?;
    let keys = Keys {
        fleet: config.fleet.clone(),
    };
    let (mission_tx, _) = watch::channel(None);
    let shared = Arc::new(Shared {
        keys: keys.clone(),
        table: Mutex::new(Table::new(
            &config.fleet,
            vessels.iter().map(|v| v.id.clone()),
        )),
        board: Mutex::new(Board::default()),
        mission: mission_tx,
        sent: Mutex::new(BTreeMap::new()),
        config: config.clone(),
    });
    if let Some(doc) = &config.mission {
        let bytes = serde_json::to_vec(doc).expect("documents serialize");
        shared.offer_mission(&bytes);
    }
    tracing::info!(
        fleet = %config.fleet,
        zid = %session.zid(),
        vessels = vessels.len(),
        "peer node up"
    );
    let zerr = |e: zenoh::Error| PeerError::Zenoh(e.to_string());

    let s = shared.clone();
    let _beacons = session
        .declare_subscriber(Keys::all_beacons())
        .callback(move |sample| {
            let key = sample.key_expr().as_str();
            let bytes = sample.payload().to_bytes();
            let local = wire::Keys::parse_beacon(key).is_some_and(|(_, id)| {
                s.sent.lock().expect("sent lock").get(id).map(|b| b.as_slice()) == Some(&bytes[..])
            });
            let ageing = s.config.ageing;
            s.table.lock().expect("table lock").offer(
                key,
                &bytes,
                local,
                Instant::now(),
                utc_now(),
                &ageing,
            );
        })
        .await
        .map_err(zerr)?;
    let s = shared.clone();
    let _missions = session
        .declare_subscriber(keys.mission())
        .callback(move |sample| s.offer_mission(&sample.payload().to_bytes()))
        .await
        .map_err(zerr)?;
    let s = shared.clone();
    let mission_key = keys.mission();
    let _mission_queryable = session
        .declare_queryable(keys.mission())
        .callback(move |query| {
            let current = s.board.lock().expect("board lock").current();
            if let Some(rev) = current {
                let _ = query.reply(&mission_key, rev.json.as_slice()).wait();
            }
        })
        .await
        .map_err(zerr)?;

    let tasks = TaskTracker::new();
    // Until a mission is held, ask the fleet for it every second.
    {
        let (s, session, stop) = (shared.clone(), session.clone(), shutdown.clone());
        tasks.spawn(async move {
            while s.mission.borrow().is_none() && !stop.is_cancelled() {
                if let Ok(replies) = session
                    .get(s.keys.mission())
                    .timeout(Duration::from_secs(1))
                    .await
                {
                    while let Ok(reply) = replies.recv_async().await {
                        if let Ok(sample) = reply.result() {
                            s.offer_mission(&sample.payload().to_bytes());
                        }
                    }
                }
                tokio::select! {
                    _ = stop.cancelled() => break,
                    _ = tokio::time::sleep(Duration::from_secs(1)) => {}
                }
            }
        });
    }
    for vessel in vessels {
        let (s, session, stop) = (shared.clone(), session.clone(), shutdown.clone());
        tasks.spawn(async move {
            if let Err(e) = run_vessel(s, session, vessel.clone(), stop).await {
                tracing::error!(vessel = %vessel.id, error = %e, "peer vessel stopped");
            }
        });
    }
    tasks.close();
    tasks.wait().await;
    let _ = session.close().await;
    Ok(())
}

/// One vessel: token, publisher, status queryable, hull and loop.
async fn run_vessel(
    shared: Arc<Shared>,
    session: zenoh::Session,
    vessel: VesselConfig,
    shutdown: CancellationToken,
) -> Result<(), PeerError> {
    let zerr = |e: zenoh::Error| PeerError::Zenoh(e.to_string());
    let keys = &shared.keys;
    let config = &shared.config;
    let id = vessel.id.clone();
    let _token = session
        .liveliness()
        .declare_token(keys.alive(&id))
        .await
        .map_err(zerr)?;
    let publisher = session
        .declare_publisher(keys.beacon(&id))
        .congestion_control(CongestionControl::Drop)
        .express(true)
        .await
        .map_err(zerr)?;
    let status = session
        .declare_queryable(keys.status(&id))
        .await
        .map_err(zerr)?;
    let mut onboard = Onboard::new(&vessel);
    let mut missions = shared.mission.subscribe();
    let mut current: Option<Arc<Revision>> = missions.borrow_and_update().clone();
    let mut guidance = current.as_ref().map(|r| Guidance::new(r.mission.guidance));
    let mut scratch = Scratch::default();
    let mut seq: u16 = 0;
    let mut partition = 0usize;
    let mut ticks: u64 = 0;
    let period = 0.05; // the hull's step between looks at the world [s]
    let beacon_every = 1.0 / config.beacon_hz;
    let (mut next_beacon, mut next_control) = (0.0, 0.0);
    let mut ticker =
        tokio::time::interval(Duration::from_secs_f64(period / config.time_warp));
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    tracing::info!(vessel = %id, fleet = %keys.fleet, "peer vessel joined");
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            Ok(()) = missions.changed() => {
                current = missions.borrow_and_update().clone();
                guidance = current.as_ref().map(|r| Guidance::new(r.mission.guidance));
            }
            Ok(query) = status.recv_async() => {
                let doc = status_document(&shared, &id, &current, onboard.command.is_some() && current.is_some(), partition);
                let json = serde_json::to_vec(&doc).expect("documents serialize");
                let _ = query.reply(keys.status(&id), json).await;
            }
            _ = ticker.tick() => {
                onboard.advance(period);
                let t = onboard.t;
                let actuator = current.as_ref().map(|r| wire::wire_actuator(r.mission.actuator.k, r.mission.actuator.beta));
                if t + 1e-9 >= next_control {
                    if let (Some(rev), Some(g), Some(act)) = (&current, guidance.as_mut(), actuator) {
                        next_control = t + 1.0 / rev.mission.tick_hz;
                        let neighbours = {
                            let mut table = shared.table.lock().expect("table lock");
                            table.neighbours(&id, Instant::now(), &config.ageing)
                        };
                        let step = super::step::step(&rev.mission, &onboard.state, act, &neighbours, g, t, ticks, &mut scratch);
                        ticks += 1;
                        partition = step.partition;
                        onboard.command = Some((step.command, t));
                    } else {
                        next_control = t + 0.1;
                    }
                }
                if t + 1e-9 >= next_beacon {
                    next_beacon = t + beacon_every;
                    // Before it has a mission a vessel announces the
                    // default actuator (the paper's), and that it holds.
                    let (k, beta) = actuator.unwrap_or_else(|| {
                        wire::wire_actuator(crate::coverage::fleet::DEFAULT_K, crate::coverage::fleet::DEFAULT_BETA)
                    });
                    let s = &onboard.state;
                    let controlled = current.is_some();
                    let doc = BeaconDocument {
                        id: id.clone(),
                        seq,
                        t: utc_now(),
                        x: s.x,
                        y: s.y,
                        psi: s.psi,
                        u: s.vel.x,
                        v: s.vel.y,
                        r: s.vel.z,
                        k,
                        beta,
                        rev: current.as_ref().map_or(0, |r| r.revision),
                        controlled,
                    };
                    seq = seq.wrapping_add(1);
                    let bytes = wire::encode(&doc);
                    shared.sent.lock().expect("sent lock").insert(id.clone(), bytes.clone());
                    // Express and dropped on congestion: never waits on a slow link.
                    if let Err(e) = publisher.put(bytes).await {
                        tracing::debug!(vessel = %id, error = %e, "beacon not sent");
                    }
                }
            }
        }
    }
    tracing::info!(vessel = %id, "peer vessel left");
    Ok(())
}

fn status_document(
    shared: &Shared,
    id: &str,
    current: &Option<Arc<Revision>>,
    controlled: bool,
    partition: usize,
) -> PeerStatusDocument {
    let table = shared.table.lock().expect("table lock");
    let mut heard = table.ages(Instant::now(), &shared.config.ageing);
    heard.remove(id);
    PeerStatusDocument {
        id: id.to_string(),
        revision: current.as_ref().map(|r| r.revision),
        controlled,
        neighbours: partition,
        heard,
        refused: table.refused(),
        received: table.received(),
    }
}
