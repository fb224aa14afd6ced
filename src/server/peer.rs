//! `seacover serve --peer`: the coordinator as a member of a peer fleet
//! (docs/peer.md). It publishes the mission (each accepted REST write becomes a
//! new revision), answers the fleet's queries for it, and shows the fleet
//! from its beacons: every vessel it hears is registered with the tick task
//! as a vessel whose link is this member, so the dashboard, `GET
//! /api/v1/vessels`, `/api/v1/coverage`, the stream and the recording show
//! it as they show a linked one. It sends no commands: what the tick would
//! command is computed for display and dropped here.
//!
//! Invariants: joining a fleet that has a mission, it takes the fleet's
//! newest revision (stored as its own) and publishes nothing new, unless
//! told to replace it (`--replace-fleet-mission`): a fresh or stale shore
//! never re-tasks a running fleet; the same when a vessel shows a newer
//! revision than it holds. Only an operator's write, or that flag, makes a
//! new revision, and every revision says who made it and when. The
//! revision it publishes only grows, and starts above the highest the
//! fleet holds when it replaces it (a restarted coordinator does not
//! publish an old revision number); a beacon that fails the wire's checks
//! changes nothing and is counted (`seacover_peer_refused_total`); a vessel
//! whose liveliness token goes leaves the tick task's links as a closed
//! link does.

use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::{mpsc, oneshot, watch};
use tokio_util::sync::CancellationToken;
use zenoh::Wait;
use zenoh::sample::SampleKind;

use super::app::AppState;
use super::coordinator::Request;
use crate::agent::peer::PeerError;
use crate::agent::peer::session::ZenohOptions;
use crate::agent::peer::wire::{self, Keys};
use crate::mission::MissionChange;
use crate::protocol::peer::PeerMissionDocument;
use crate::protocol::{ActuatorDocument, MissionDocument, PoseDocument};

/// Counter of refused peer inputs, by `reason`.
pub const PEER_REFUSED: &str = "seacover_peer_refused_total";
/// Gauge of the mission revision the coordinator publishes.
pub const PEER_REVISION: &str = "seacover_peer_mission_revision";

/// `serve --peer`'s settings.
#[derive(Debug, Clone)]
pub struct PeerMember {
    pub fleet: String,
    pub zenoh: ZenohOptions,
    /// Publish this coordinator's mission over the fleet's
    /// (`--replace-fleet-mission`).
    pub replace: bool,
}

/// The fleet's newest mission revision: every other member's answer (Zenoh's
/// default consolidation would keep only the last to arrive; this member's
/// own queryable is not asked).
async fn fleet_mission(session: &zenoh::Session, keys: &Keys) -> Option<PeerMissionDocument> {
    let replies = session
        .get(keys.mission())
        .consolidation(zenoh::query::ConsolidationMode::None)
        .allowed_destination(zenoh::sample::Locality::Remote)
        .timeout(Duration::from_secs(1))
        .await
        .ok()?;
    let mut newest: Option<PeerMissionDocument> = None;
    while let Ok(reply) = replies.recv_async().await {
        if let Ok(sample) = reply.result()
            && let Ok(doc) = wire::decode_mission(&sample.payload().to_bytes())
            && newest.as_ref().is_none_or(|n| doc.revision > n.revision)
        {
            newest = Some(doc);
        }
    }
    newest
}

/// Makes `doc` the coordinator's mission (validated and stored as any
/// write is).
async fn adopt(app: &AppState, doc: &PeerMissionDocument) -> Result<(), PeerError> {
    let (reply, answer) = oneshot::channel();
    let failed = |message: String| PeerError::Adopt {
        revision: doc.revision,
        message,
    };
    app.requests
        .send(Request::Change {
            change: MissionChange::Adopt(Box::new(doc.mission.clone())),
            reply,
        })
        .await
        .map_err(|_| failed("the coordinator is stopping".into()))?;
    match answer.await {
        Ok(Ok(_)) => {
            tracing::info!(
                revision = doc.revision,
                by = doc.by.as_deref().unwrap_or("?"),
                at = doc.at.as_deref().unwrap_or("?"),
                "took the fleet's mission"
            );
            Ok(())
        }
        Ok(Err(e)) => Err(failed(crate::chain::Chain(&e).to_string())),
        Err(_) => Err(failed("the coordinator is stopping".into())),
    }
}

/// A revision this coordinator makes, said to be made by `how`.
fn ours(revision: u32, mission: &MissionDocument, how: &str) -> Arc<Vec<u8>> {
    Arc::new(
        serde_json::to_vec(&PeerMissionDocument {
            revision,
            mission: mission.clone(),
            by: Some(wire::author(&format!("seacover serve --peer: {how}"))),
            at: Some(wire::now_utc()),
        })
        .expect("documents serialize"),
    )
}

/// What the member knows of one vessel it registered.
struct Heard {
    link: u64,
    poses: watch::Sender<Option<PoseDocument>>,
}

/// What the beacon callback hands the member's task.
enum Event {
    Beacon(String, Vec<u8>),
    Gone(String),
}

/// How long after a put a vessel may still beacon an older revision (the
/// put and its beacon in flight) before the revision is published again,
/// and the longest interval between such repeats.
const REPEAT_FIRST: Duration = Duration::from_millis(300);
const REPEAT_MAX: Duration = Duration::from_secs(8);

/// Joins the fleet and runs until `shutdown`.
pub async fn run(
    member: PeerMember,
    app: AppState,
    shutdown: CancellationToken,
) -> Result<(), PeerError> {
    if !wire::valid_fleet(&member.fleet) {
        return Err(PeerError::Fleet);
    }
    let session = zenoh::open(member.zenoh.config()?).await.map_err(zerr)?;
    let keys = Keys {
        fleet: member.fleet.clone(),
    };
    let joined = join(&app, &session, &keys, member.replace).await?;
    let published = Arc::new(Mutex::new(joined.first));
    let mission_key = keys.mission();
    let answer = published.clone();
    let _queryable = session
        .declare_queryable(keys.mission())
        .callback(move |query| {
            let json = answer.lock().expect("mission lock").clone();
            let _ = query.reply(&mission_key, json.as_slice()).wait();
        })
        .await
        .map_err(zerr)?;
    // A revision is rare and must not be dropped by a full queue (the
    // default for puts): block instead, and go ahead of the beacons.
    let publisher = session
        .declare_publisher(keys.mission())
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .priority(zenoh::qos::Priority::InteractiveHigh)
        .await
        .map_err(zerr)?;
    let revision = joined.revision;
    if joined.put_first {
        let first = published.lock().expect("mission lock").clone();
        publisher
            .put(first.as_slice().to_vec())
            .await
            .map_err(zerr)?;
        tracing::info!(fleet = %member.fleet, revision, "joined the peer fleet; mission published");
    } else {
        tracing::info!(fleet = %member.fleet, revision, "joined the peer fleet; working on its mission");
    }
    metrics::gauge!(PEER_REVISION).set(revision as f64);

    let (events, mut incoming) = mpsc::channel::<Event>(4096);
    let _subscribers = subscribe(&session, &keys, events).await?;
    let mut state = Member {
        app: &app,
        session: &session,
        keys: &keys,
        replace: member.replace,
        publisher,
        published,
        revision,
        settled: joined.settled,
        put_at: tokio::time::Instant::now(),
        repeat: REPEAT_FIRST,
        last: joined.own,
        asked: None,
        heard: BTreeMap::new(),
        refused: BTreeMap::new(),
        snapshots: app.snapshot.clone(),
    };
    // Each vessel's own neighbour count, asked of the fleet every second.
    let mut ask = tokio::time::interval(Duration::from_secs(1));
    ask.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let (counts_tx, mut counts) = mpsc::channel::<BTreeMap<String, u32>>(2);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = ask.tick() => ask_neighbours(&app, &session, &keys, counts_tx.clone()),
            Some(found) = counts.recv() => {
                if !found.is_empty() {
                    let _ = app.requests.send(Request::PeerNeighbours(found)).await;
                }
            }
            Ok(()) = state.snapshots.changed() => state.on_snapshot().await,
            Some(event) = incoming.recv() => match event {
                Event::Beacon(id, bytes) => state.on_beacon(id, &bytes).await,
                Event::Gone(id) => state.on_gone(id).await,
            },
        }
    }
    for (id, h) in std::mem::take(&mut state.heard) {
        let _ = app.requests.send(Request::Gone { id, link: h.link }).await;
    }
    drop(state);
    let _ = session.close().await;
    Ok(())
}

fn zerr(e: zenoh::Error) -> PeerError {
    PeerError::Zenoh(e.to_string())
}

/// What joining decided.
struct Joined {
    revision: u32,
    /// The coordinator's own mission as it stands after joining.
    own: MissionDocument,
    /// The revision's document as published.
    first: Arc<Vec<u8>>,
    /// Whether this member puts it (its own or a replacing revision).
    put_first: bool,
    /// Whether another member has answered: until then a mission published
    /// as "the fleet's first" is provisional, since on a busy or slow link
    /// the first query can miss a fleet that is there.
    settled: bool,
}

/// Asks the fleet for its mission and decides which one this member works
/// on (see the module doc's invariants).
async fn join(
    app: &AppState,
    session: &zenoh::Session,
    keys: &Keys,
    replace: bool,
) -> Result<Joined, PeerError> {
    let own = app.snapshot.borrow().document.mission.clone();
    let found = fleet_mission(session, keys).await;
    let settled = found.is_some();
    Ok(match found {
        Some(doc) if doc.mission == own || !replace => {
            if doc.mission != own {
                adopt(app, &doc).await?;
            }
            Joined {
                revision: doc.revision,
                // The coordinator's own view of it, which later writes change.
                own: app.snapshot.borrow().document.mission.clone(),
                first: Arc::new(serde_json::to_vec(&doc).expect("documents serialize")),
                put_first: false,
                settled,
            }
        }
        Some(doc) => {
            tracing::warn!(
                replaced = doc.revision,
                by = doc.by.as_deref().unwrap_or("?"),
                "replacing the fleet's mission (--replace-fleet-mission)"
            );
            let revision = doc.revision + 1;
            Joined {
                revision,
                first: ours(revision, &own, "--replace-fleet-mission"),
                own,
                put_first: true,
                settled,
            }
        }
        None => Joined {
            revision: 0,
            first: ours(0, &own, "the fleet's first mission"),
            own,
            put_first: true,
            settled,
        },
    })
}

/// The fleet's beacons and liveliness, handed to the member's task as
/// [`Event`]s (a full channel drops a beacon: the vessel's next one
/// supersedes it).
async fn subscribe(
    session: &zenoh::Session,
    keys: &Keys,
    events: mpsc::Sender<Event>,
) -> Result<(zenoh::pubsub::Subscriber<()>, zenoh::pubsub::Subscriber<()>), PeerError> {
    let tx = events.clone();
    let fleet = keys.fleet.clone();
    let beacons = session
        .declare_subscriber(Keys::all_beacons())
        .callback(move |sample| {
            let key = sample.key_expr().as_str();
            match Keys::parse_beacon(key) {
                Some((f, _)) if f != fleet => {
                    metrics::counter!(PEER_REFUSED, "reason" => "other_fleet").increment(1);
                }
                Some((_, id)) => {
                    let _ = tx.try_send(Event::Beacon(
                        id.to_string(),
                        sample.payload().to_bytes().to_vec(),
                    ));
                }
                None => {}
            }
        })
        .await
        .map_err(zerr)?;
    let alive = session
        .liveliness()
        .declare_subscriber(keys.alive_all())
        .history(true)
        .callback(move |sample| {
            if sample.kind() == SampleKind::Delete
                && let Some(id) = sample.key_expr().as_str().rsplit('/').next()
            {
                let _ = events.try_send(Event::Gone(id.to_string()));
            }
        })
        .await
        .map_err(zerr)?;
    Ok((beacons, alive))
}

/// Asks every vessel for its own neighbour count, off the member's loop (a
/// query waits for its replies); the answers come back on `tx`.
fn ask_neighbours(
    app: &AppState,
    session: &zenoh::Session,
    keys: &Keys,
    tx: mpsc::Sender<BTreeMap<String, u32>>,
) {
    let (session, selector) = (session.clone(), keys.status_all());
    app.tracker.spawn(async move {
        let Ok(replies) = session
            .get(selector)
            .timeout(Duration::from_millis(800))
            .await
        else {
            return;
        };
        let mut found = BTreeMap::new();
        while let Ok(reply) = replies.recv_async().await {
            if let Ok(sample) = reply.result()
                && let Ok(doc) = serde_json::from_slice::<
                    crate::protocol::peer::PeerStatusDocument,
                >(&sample.payload().to_bytes())
            {
                found.insert(doc.id, doc.neighbours as u32);
            }
        }
        let _ = tx.try_send(found);
    });
}

/// The member between events.
struct Member<'a> {
    app: &'a AppState,
    session: &'a zenoh::Session,
    keys: &'a Keys,
    replace: bool,
    publisher: zenoh::pubsub::Publisher<'static>,
    /// What the queryable answers: the revision last published or taken.
    published: Arc<Mutex<Arc<Vec<u8>>>>,
    revision: u32,
    settled: bool,
    /// When the revision last went out, and how long a vessel may beacon
    /// an older one before it goes out again (doubling while any lags).
    put_at: tokio::time::Instant,
    repeat: Duration,
    /// The mission of `revision`.
    last: MissionDocument,
    /// When the fleet was last asked for a newer revision than ours.
    asked: Option<tokio::time::Instant>,
    heard: BTreeMap<String, Heard>,
    /// Vessels the tick task refused (an actuator out of range, a full
    /// fleet), with the actuator they had: asked again only when it
    /// changes.
    refused: BTreeMap<String, (f64, f64)>,
    snapshots: watch::Receiver<Arc<super::coordinator::Snapshot>>,
}

impl Member<'_> {
    /// Publishes `json` as the revision now held.
    async fn publish(&mut self, json: Arc<Vec<u8>>) {
        *self.published.lock().expect("mission lock") = json.clone();
        if let Err(e) = self.publisher.put(json.as_slice().to_vec()).await {
            tracing::warn!(error = %e, "mission revision not published");
        }
        (self.put_at, self.repeat) = (tokio::time::Instant::now(), REPEAT_FIRST);
        metrics::gauge!(PEER_REVISION).set(self.revision as f64);
    }

    /// An operator's write becomes a new revision.
    async fn on_snapshot(&mut self) {
        let mission = self.snapshots.borrow_and_update().document.mission.clone();
        if mission != self.last {
            self.revision += 1;
            let json = ours(self.revision, &mission, "an operator's write");
            self.publish(json).await;
            tracing::info!(
                revision = self.revision,
                "published a new mission revision to the fleet"
            );
            self.last = mission;
        }
    }

    async fn on_beacon(&mut self, id: String, bytes: &[u8]) {
        let beacon = match wire::decode(bytes, &id) {
            Ok(b) => b,
            Err(why) => {
                metrics::counter!(PEER_REFUSED, "reason" => why.name()).increment(1);
                return;
            }
        };
        self.app.recorder.beacon(self.app.clock.now(), &beacon);
        let pose = beacon.pose();
        // A vessel works on a revision above ours (ours from before a
        // restart), or on any revision while ours is provisional (the same
        // number may be another mission): the fleet is asked, and what it
        // holds wins unless this coordinator was told to replace it. Asked
        // at most every 2 s: the query waits up to 1 s.
        let unsure = beacon.rev > self.revision || (!self.settled && beacon.rev == self.revision);
        if unsure
            && self
                .asked
                .is_none_or(|a| a.elapsed() >= Duration::from_secs(2))
            && !self.reconcile(beacon.rev).await
        {
            return;
        }
        // A vessel still on an older revision once the put had time to
        // arrive: the put was lost to it (UDP, a link down), and so perhaps
        // to its neighbours, whose beacons would otherwise tell it to ask.
        // Published again, at doubling intervals while any vessel lags, so
        // one that refuses the document costs little.
        if beacon.rev < self.revision && self.put_at.elapsed() >= self.repeat {
            let json = self.published.lock().expect("mission lock").clone();
            if let Err(e) = self.publisher.put(json.as_slice().to_vec()).await {
                tracing::warn!(error = %e, "mission revision not published");
            }
            self.put_at = tokio::time::Instant::now();
            self.repeat = (self.repeat * 2).min(REPEAT_MAX);
            tracing::debug!(vessel = %id, held = beacon.rev, revision = self.revision, "a vessel lags: the revision published again");
        }
        if let Some(h) = self.heard.get(&id) {
            h.poses.send_replace(Some(pose));
            return;
        }
        if self.refused.get(&id) == Some(&(beacon.k, beacon.beta)) {
            return;
        }
        // The vessel's actuator: the mission's when the beacon carries it
        // as the wire rounds it.
        let mission = &self.last.actuator;
        let actuator = if wire::wire_actuator(mission.k, mission.beta) == (beacon.k, beacon.beta) {
            *mission
        } else {
            ActuatorDocument {
                k: beacon.k,
                beta: beacon.beta,
            }
        };
        match register(self.app, &id, actuator, pose).await {
            Some(h) => {
                self.heard.insert(id, h);
            }
            None => {
                self.refused.insert(id, (beacon.k, beacon.beta));
            }
        }
    }

    /// Asks the fleet for its mission after a beacon on revision `held`
    /// made this member unsure of its own; `false` when the beacon should
    /// be dropped (the fleet's newer mission could not be taken).
    async fn reconcile(&mut self, held: u32) -> bool {
        self.asked = Some(tokio::time::Instant::now());
        let doc = fleet_mission(self.session, self.keys).await;
        self.settled |= doc.is_some();
        let (revision, last) = (self.revision, &self.last);
        // Another member made it, or the first query missed it: take it,
        // as on joining.
        let differs = |d: &PeerMissionDocument| {
            d.revision > revision || (d.revision == revision && d.mission != *last)
        };
        match doc {
            Some(doc) if differs(&doc) && !self.replace => {
                if let Err(e) = adopt(self.app, &doc).await {
                    tracing::warn!(error = %crate::chain::Chain(&e), "the fleet's newer mission was not taken");
                    return false;
                }
                self.revision = doc.revision;
                self.last = self.app.snapshot.borrow().document.mission.clone();
                *self.published.lock().expect("mission lock") =
                    Arc::new(serde_json::to_vec(&doc).expect("documents serialize"));
                metrics::gauge!(PEER_REVISION).set(self.revision as f64);
                // The adopted mission's snapshot is not a write.
                self.snapshots.borrow_and_update();
            }
            d if self.replace && (held > revision || d.as_ref().is_some_and(differs)) => {
                self.revision = held.max(d.map_or(0, |d| d.revision)) + 1;
                let json = ours(self.revision, &self.last, "--replace-fleet-mission");
                self.publish(json).await;
                tracing::info!(
                    revision = self.revision,
                    "the fleet had a newer revision: the mission published again above it \
                     (--replace-fleet-mission)"
                );
            }
            // Not found yet: asked again at the next beacon.
            _ => {}
        }
        true
    }

    /// A vessel's liveliness token went: it leaves as a closed link does.
    async fn on_gone(&mut self, id: String) {
        self.refused.remove(&id);
        if let Some(h) = self.heard.remove(&id) {
            let _ = self
                .app
                .requests
                .send(Request::Gone { id, link: h.link })
                .await;
        }
    }
}

/// Registers a vessel heard on the fleet with the tick task, its link
/// being this member: commands are received and dropped.
async fn register(
    app: &AppState,
    id: &str,
    actuator: ActuatorDocument,
    pose: PoseDocument,
) -> Option<Heard> {
    let link = app.next_link.fetch_add(1, Ordering::Relaxed);
    let (tx, mut drained) = mpsc::channel(16);
    let (poses, slot) = watch::channel(Some(pose));
    let (reply, answer) = oneshot::channel();
    app.requests
        .send(Request::Register {
            id: id.to_string(),
            link,
            actuator: Some(actuator),
            astern: true,
            agility: None,
            mission: None,
            station_radius: None,
            tx,
            poses: slot,
            reply,
        })
        .await
        .ok()?;
    match answer.await {
        Ok(Ok(_)) => {
            // The member sends no commands: the tick's are dropped here.
            app.tracker
                .spawn(async move { while drained.recv().await.is_some() {} });
            tracing::info!(vessel = id, "peer vessel heard");
            Some(Heard { link, poses })
        }
        Ok(Err(e)) => {
            tracing::warn!(vessel = id, error = %crate::chain::Chain(&e), "peer vessel not shown");
            None
        }
        Err(_) => None,
    }
}
