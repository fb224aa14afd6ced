//! One vessel link of the load client: the agent's handshake, then poses at
//! the rate and commands in, each timed, until the window ends.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use tokio::sync::Semaphore;
use tokio_tungstenite::tungstenite::Message;
use tokio_util::sync::CancellationToken;

use crate::agent::link::handshake;
use crate::geometry::{Point, Region};
use crate::protocol::{PoseDocument, VesselMessage};

/// State shared by the link tasks.
pub(super) struct Shared {
    pub(super) ws_url: String,
    pub(super) token: Option<String>,
    pub(super) region: Region,
    /// Poses per second (wall).
    pub(super) rate_hz: f64,
    pub(super) time_warp: f64,
    /// Tick rate of the coordinator in wall time.
    pub(super) tick_rate: f64,
    pub(super) origin: Instant,
    /// `origin` on the wall clock (Unix seconds), to compare receive times
    /// with the coordinator's published tick origin.
    pub(super) origin_unix: f64,
    pub(super) window_start: OnceLock<Instant>,
    pub(super) window_end: OnceLock<Instant>,
    /// Links that have finished their handshake, welcomed or not.
    pub(super) settled: AtomicUsize,
    /// Links that were welcomed.
    pub(super) welcomed: AtomicUsize,
    /// Links that have received at least one command.
    pub(super) commanded: AtomicUsize,
    pub(super) connecting: Semaphore,
}

impl Shared {
    fn in_window(&self, at: Instant) -> bool {
        self.window_start.get().is_some_and(|s| at >= *s)
            && self.window_end.get().is_none_or(|e| at < *e)
    }
}

/// What one link saw.
#[derive(Debug, Default)]
pub(super) struct LinkOutcome {
    /// Welcomed.
    pub(super) connected: bool,
    /// Why the handshake failed, or why the link ended early, and when.
    pub(super) problem: Option<String>,
    pub(super) ended_at: Option<Instant>,
    pub(super) poses: u64,
    pub(super) commands: u64,
    /// Pose sent → next command, seconds.
    pub(super) pose_latency: Vec<f64>,
    /// (tick, receive time since `origin` in seconds).
    pub(super) tick_offsets: Vec<(u64, f64)>,
}
/// What the client reads of a coordinator frame. Unused fields (the
/// centroid, the rates, …) are skipped without being built, and a plain
/// struct avoids the tagged enum's buffering of the whole object: the client
/// shares the machine with the coordinator, so its cost per frame counts.
#[derive(serde::Deserialize)]
pub(super) struct Incoming<'a> {
    #[serde(rename = "type", borrow)]
    pub(super) kind: std::borrow::Cow<'a, str>,
    #[serde(default)]
    pub(super) tick: u64,
    #[serde(default)]
    pub(super) u_d: f64,
    #[serde(default)]
    pub(super) r_d: f64,
    #[serde(default)]
    pub(super) code: Option<String>,
    #[serde(default)]
    pub(super) message: Option<String>,
}

/// How long a link may take to connect and be welcomed.
pub(super) const HANDSHAKE: Duration = Duration::from_secs(10);

/// The load client's hello: a vessel that declares nothing.
pub(super) fn hello(id: &str) -> VesselMessage {
    VesselMessage::Hello {
        vessel: id.to_string(),
        protocol: 1,
        actuator: None,
        astern: None,
        agility: None,
        mission: None,
        station_radius: None,
    }
}

/// One vessel link: handshake, then poses at the rate and commands in,
/// until `stop`.
pub(super) async fn run_link(
    id: String,
    phase: f64,
    start: (f64, f64, f64),
    shared: Arc<Shared>,
    stop: CancellationToken,
) -> LinkOutcome {
    let mut out = LinkOutcome::default();
    let socket = match connect(&id, &shared, &stop).await {
        Ok(socket) => socket,
        Err(e) => {
            out.problem = Some(e);
            return out;
        }
    };
    out.connected = true;
    if let Some(problem) = drive(socket, phase, start, &shared, &stop, &mut out).await {
        out.problem = Some(problem);
        out.ended_at = Some(Instant::now());
    }
    out
}

/// The handshake, at most [`CONNECTING`](super::CONNECTING) at once;
/// counted as settled either way, and as welcomed when it was.
async fn connect(
    id: &str,
    shared: &Shared,
    stop: &CancellationToken,
) -> Result<crate::agent::link::Socket, String> {
    let hello = hello(id);
    let welcomed = {
        let _permit = shared.connecting.acquire().await;
        tokio::select! {
            _ = stop.cancelled() => Err("stopped while connecting".to_string()),
            r = tokio::time::timeout(HANDSHAKE, handshake(&shared.ws_url, shared.token.as_deref(), &hello)) => match r {
                Ok(handshake) => handshake.map_err(|e| e.to_string()),
                Err(_) => Err(format!("no welcome within {} s", HANDSHAKE.as_secs())),
            }
        }
    };
    shared.settled.fetch_add(1, Ordering::Relaxed);
    let welcomed = welcomed?;
    shared.welcomed.fetch_add(1, Ordering::Relaxed);
    Ok(welcomed.socket)
}

/// Poses out at the rate and commands in, until `stop` (`None`) or the
/// link ends (why).
async fn drive(
    socket: crate::agent::link::Socket,
    phase: f64,
    start: (f64, f64, f64),
    shared: &Shared,
    stop: &CancellationToken,
    out: &mut LinkOutcome,
) -> Option<String> {
    let (mut sink, mut stream) = socket.split();

    let period = Duration::from_secs_f64(1.0 / shared.rate_hz);
    // Mission seconds per pose.
    let dt = period.as_secs_f64() * shared.time_warp;
    let began = Instant::now();
    // Spread the links' poses over the period rather than sending them in
    // bursts.
    let mut ticker =
        tokio::time::interval_at(tokio::time::Instant::now() + period.mul_f64(phase), period);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let (mut x, mut y, mut psi) = start;
    let (mut u, mut r) = (0.0, 0.0);
    let mut commanded = false;
    // Send times of the poses (in the window) awaiting their next command.
    let mut pending: Vec<Instant> = Vec::with_capacity(4);
    loop {
        tokio::select! {
            // Frames before poses, so that a command's receive time is not
            // delayed by sending a pose that fell due at the same moment.
            biased;
            _ = stop.cancelled() => {
                let _ = sink.send(Message::Close(None)).await;
                return None;
            }
            frame = stream.next() => match frame {
                Some(Ok(Message::Text(t))) => {
                    let at = Instant::now();
                    match serde_json::from_str::<Incoming>(&t) {
                        Ok(c) if c.kind == "command" => {
                            out.pose_latency.extend(pending.drain(..).map(|s| (at - s).as_secs_f64()));
                            if shared.in_window(at) {
                                out.commands += 1;
                                out.tick_offsets.push((
                                    c.tick,
                                    (at - shared.origin).as_secs_f64(),
                                ));
                            }
                            (u, r) = (c.u_d, c.r_d);
                            if !commanded {
                                commanded = true;
                                shared.commanded.fetch_add(1, Ordering::Relaxed);
                            }
                        }
                        Ok(c) if c.kind == "error" => {
                            let (code, message) = (c.code.unwrap_or_default(), c.message.unwrap_or_default());
                            return Some(format!("error frame: {code}: {message}"));
                        }
                        Ok(c) if c.kind == "welcome" => {}
                        Ok(c) => return Some(format!("unknown frame type {:?}", c.kind)),
                        Err(e) => return Some(format!("unreadable frame: {e}")),
                    }
                }
                Some(Ok(Message::Close(frame))) => {
                    return Some(format!("closed by the coordinator ({frame:?})"));
                }
                None => return Some("closed by the coordinator".into()),
                Some(Err(e)) => return Some(format!("link error: {e}")),
                Some(Ok(_)) => {}
            },
            _ = ticker.tick() => {
                psi = (psi + r * dt).rem_euclid(std::f64::consts::TAU);
                let next = Point { x: x + u * psi.cos() * dt, y: y + u * psi.sin() * dt };
                if shared.region.contains(next) {
                    (x, y) = (next.x, next.y);
                }
                let pose = VesselMessage::Pose(PoseDocument {
                    t: began.elapsed().as_secs_f64() * shared.time_warp,
                    x,
                    y,
                    psi,
                    u,
                    v: 0.0,
                    r,
                    controlled: None,
                    telemetry: None,
                    fix: None,
                });
                let text = serde_json::to_string(&pose).expect("serializes");
                let sent = Instant::now();
                if let Err(e) = sink.send(Message::text(text)).await {
                    return Some(format!("sending a pose: {e}"));
                }
                if shared.in_window(sent) {
                    out.poses += 1;
                    pending.push(sent);
                }
            }
        }
    }
}
