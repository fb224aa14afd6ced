//! WebSocket endpoints: the vessel link (hello / welcome / pose / command /
//! error) and the read-only dashboard stream.
//!
//! A link task never touches the fleet: it validates frames, puts the newest
//! pose in the link's pose slot (a `watch` the tick task reads each tick),
//! and writes whatever the tick task sends it. Fatal
//! protocol errors (a pose before hello, a frame over 64 KiB, repeated
//! garbage) close that link only.

use std::net::SocketAddr;
use std::sync::atomic::Ordering;
use std::time::Duration;

use axum::extract::State;
use axum::extract::ws::{Message, Utf8Bytes, WebSocket, WebSocketUpgrade};
use axum::response::Response;
use futures_util::{SinkExt, StreamExt};
use tokio::sync::{mpsc, oneshot, watch};

use super::AppState;
use super::coordinator::{Outgoing, Request};
use super::events::Peer;
use crate::mission::scenario::valid_id;
use crate::protocol::{CoordinatorMessage, PoseDocument, VesselMessage};
use crate::recorder::messages::{EventKind, EventRecord};

/// Largest frame accepted on either socket.
pub(super) const MAX_FRAME: usize = 64 * 1024;
/// Malformed frames tolerated on one link before it is closed.
const MAX_GARBAGE: u32 = 5;
/// Poses a link may send per mission second, on average (five times the
/// 20 Hz a vessel reports at); a burst of as many is allowed. Beyond it
/// poses are dropped, counted and answered at most once a mission second:
/// a flooding link cannot take the coordinator's cores from the others.
pub(super) const MAX_POSE_RATE: f64 = 100.0;

/// A link's pose budget: a token bucket refilled on the mission clock, so
/// that the limit is per mission second whatever the time warp.
struct Budget {
    tokens: f64,
    at: f64,
    /// Mission time of the last refusal answered.
    answered: f64,
}

impl Budget {
    fn new(now: f64) -> Budget {
        Budget {
            tokens: MAX_POSE_RATE,
            at: now,
            answered: f64::NEG_INFINITY,
        }
    }

    /// Takes one pose's token at mission time `now`; `false` when spent.
    fn take(&mut self, now: f64) -> bool {
        self.tokens = (self.tokens + (now - self.at).max(0.0) * MAX_POSE_RATE).min(MAX_POSE_RATE);
        self.at = now;
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }

    /// Whether a refusal at `now` is to be answered (once a mission second).
    fn answer(&mut self, now: f64) -> bool {
        let due = now - self.answered >= 1.0;
        if due {
            self.answered = now;
        }
        due
    }
}
/// Initial read buffer of a socket. tungstenite zero-fills its whole read
/// buffer (128 KiB by default) before the first read, which made every link
/// cost 128 KiB of resident memory for frames of a few hundred bytes; the
/// buffer still grows to any frame up to [`MAX_FRAME`].
const READ_BUFFER: usize = 4 * 1024;

fn text(msg: &CoordinatorMessage) -> Message {
    let kind = match msg {
        CoordinatorMessage::Welcome { .. } => "welcome",
        CoordinatorMessage::Mission { .. } => "mission",
        CoordinatorMessage::Command(_) => "command",
        CoordinatorMessage::Error { .. } => "error",
    };
    metrics::counter!(super::metrics::MESSAGES_OUT, "kind" => kind).increment(1);
    Message::Text(Utf8Bytes::from(
        serde_json::to_string(msg).expect("messages serialize"),
    ))
}

fn error(code: &str, message: impl Into<String>) -> CoordinatorMessage {
    metrics::counter!(super::metrics::MESSAGES_REJECTED, "reason" => code.to_string()).increment(1);
    CoordinatorMessage::Error {
        code: code.to_string(),
        message: message.into(),
    }
}

pub(super) async fn link(
    ws: WebSocketUpgrade,
    Peer(peer): Peer,
    State(app): State<AppState>,
) -> Response {
    let tracker = app.tracker.clone();
    ws.max_message_size(MAX_FRAME)
        .max_frame_size(MAX_FRAME)
        .read_buffer_size(READ_BUFFER)
        .on_upgrade(move |socket| tracker.track_future(run_link(socket, app, peer)))
}

/// A refused frame: counted, recorded, and the error to send.
fn rejected(
    app: &AppState,
    peer: Option<SocketAddr>,
    vessel: Option<&str>,
    code: &str,
    message: impl Into<String>,
) -> CoordinatorMessage {
    let message = message.into();
    if app.recorder.is_on() {
        let mut event = EventRecord::new(app.clock.now(), EventKind::RejectedFrame)
            .code(code)
            .peer(peer)
            .detail(message.clone());
        event.vessel = vessel.map(str::to_string);
        app.recorder.event(event);
    }
    error(code, message)
}

fn finite(p: &PoseDocument) -> bool {
    [p.t, p.x, p.y, p.psi, p.u, p.v, p.r]
        .iter()
        .all(|v| v.is_finite())
}

/// A pose frame, read without the tagged enum's buffering of the whole
/// object into an intermediate tree (a link reads 20 of them a second). It
/// accepts exactly the frames that [`VesselMessage`] reads as a pose; any
/// other frame, good or bad, falls back to [`VesselMessage`] and its errors.
/// Its fields are [`PoseDocument`]'s (the struct literal in [`parse`]
/// fails to compile when one is added there and not here).
#[derive(serde::Deserialize)]
struct PoseFrame {
    #[serde(rename = "type")]
    _kind: PoseTag,
    t: f64,
    x: f64,
    y: f64,
    psi: f64,
    u: f64,
    v: f64,
    r: f64,
    #[serde(default)]
    controlled: Option<bool>,
    #[serde(default)]
    telemetry: Option<serde_json::Value>,
    #[serde(default)]
    fix: Option<crate::protocol::FixDocument>,
}

#[derive(serde::Deserialize)]
#[serde(rename_all = "snake_case")]
enum PoseTag {
    Pose,
}

fn parse(text: &str) -> Result<VesselMessage, serde_json::Error> {
    match serde_json::from_str::<PoseFrame>(text) {
        Ok(PoseFrame {
            _kind: PoseTag::Pose,
            t,
            x,
            y,
            psi,
            u,
            v,
            r,
            controlled,
            telemetry,
            fix,
        }) => Ok(VesselMessage::Pose(PoseDocument {
            t,
            x,
            y,
            psi,
            u,
            v,
            r,
            controlled,
            telemetry,
            fix,
        })),
        Err(_) => serde_json::from_str(text),
    }
}

async fn run_link(socket: WebSocket, app: AppState, peer: Option<SocketAddr>) {
    let Some((socket, hello)) = read_hello(socket, &app, peer).await else {
        return;
    };
    let Some((socket, link)) = join(socket, &app, peer, hello).await else {
        return;
    };
    serve(socket, &app, peer, link).await;
}

/// A hello the coordinator can register.
struct Hello {
    id: String,
    actuator: Option<crate::protocol::ActuatorDocument>,
    astern: Option<bool>,
    agility: Option<crate::protocol::AgilityDocument>,
    mission: Option<String>,
    station_radius: Option<f64>,
}

/// The first frame, which must be a valid hello; a link that sends
/// anything else is refused (and `None` returned).
async fn read_hello(
    mut socket: WebSocket,
    app: &AppState,
    peer: Option<SocketAddr>,
) -> Option<(WebSocket, Hello)> {
    let first = tokio::select! {
        _ = app.shutdown.cancelled() => return None,
        first = tokio::time::timeout(Duration::from_secs(10), socket.recv()) => first,
    };
    let Ok(Some(Ok(Message::Text(t)))) = first else {
        return None;
    };
    let (vessel, code, why) = match parse(&t) {
        Ok(VesselMessage::Hello {
            vessel,
            protocol,
            actuator,
            astern,
            agility,
            mission,
            station_radius,
        }) => {
            if protocol != 1 {
                (
                    Some(vessel),
                    "unsupported",
                    format!("protocol {protocol}: only 1 is spoken"),
                )
            } else if !valid_id(&vessel) {
                (
                    None,
                    "invalid",
                    "vessel: must match [A-Za-z0-9_.-]{1,64}".into(),
                )
            } else {
                let hello = Hello {
                    id: vessel,
                    actuator,
                    astern,
                    agility,
                    mission,
                    station_radius,
                };
                return Some((socket, hello));
            }
        }
        Ok(VesselMessage::Pose(_)) => (None, "protocol", "a pose before hello".into()),
        Ok(VesselMessage::Sample(_)) => (None, "protocol", "a sample before hello".into()),
        Err(e) => (
            None,
            "malformed",
            format!("expected hello: {}", crate::protocol::json_error(&e)),
        ),
    };
    refuse_hello(socket, app, peer, vessel.as_deref(), code, why).await;
    None
}

/// A registered link: its number, its commands and where its poses go.
struct Link {
    id: String,
    number: u64,
    commands: mpsc::Receiver<Outgoing>,
    poses: watch::Sender<Option<PoseDocument>>,
}

/// Registers the vessel with the tick task and welcomes it; a refusal is
/// answered and the link closed (`None`).
async fn join(
    mut socket: WebSocket,
    app: &AppState,
    peer: Option<SocketAddr>,
    hello: Hello,
) -> Option<(WebSocket, Link)> {
    let number = app.next_link.fetch_add(1, Ordering::Relaxed);
    let (tx, commands) = mpsc::channel::<Outgoing>(16);
    let (poses, slot) = watch::channel(None);
    let (reply_tx, reply_rx) = oneshot::channel();
    let registered = app
        .requests
        .send(Request::Register {
            id: hello.id.clone(),
            link: number,
            actuator: hello.actuator,
            astern: hello.astern.unwrap_or(true),
            agility: hello.agility,
            mission: hello.mission,
            station_radius: hello.station_radius,
            tx,
            poses: slot,
            reply: reply_tx,
        })
        .await
        .is_ok();
    let id = hello.id;
    let welcomed = match (registered, reply_rx.await) {
        (true, Ok(Ok(welcomed))) => welcomed,
        (_, Ok(Err(e))) => {
            refuse_hello(
                socket,
                app,
                peer,
                Some(&id),
                e.code().as_str(),
                e.to_string(),
            )
            .await;
            return None;
        }
        _ => {
            refuse(
                socket,
                error("shutting_down", "the coordinator is shutting down"),
            )
            .await;
            return None;
        }
    };
    let welcome = CoordinatorMessage::Welcome {
        vessel: id.clone(),
        tick_hz: welcomed.tick_hz,
        mission: welcomed.mission,
    };
    socket.send(text(&welcome)).await.ok()?;
    Some((
        socket,
        Link {
            id,
            number,
            commands,
            poses,
        },
    ))
}

/// What the link does after a frame.
enum Flow {
    Go,
    Close,
}

/// A welcomed link: forwards its poses and writes its commands until it
/// closes, the coordinator stops or too much garbage arrives.
async fn serve(mut socket: WebSocket, app: &AppState, peer: Option<SocketAddr>, mut link: Link) {
    let id = link.id.clone();
    let peer_text = peer.map_or_else(|| "?".to_string(), |p| p.to_string());
    tracing::info!(vessel = %id, peer = %peer_text, "vessel link up");
    app.recorder.event(
        EventRecord::new(app.clock.now(), EventKind::LinkUp)
            .vessel(id.clone())
            .peer(peer),
    );
    let mut reader = Reader {
        app,
        peer,
        peer_text: peer_text.clone(),
        vessel: id.as_str().into(),
        garbage: 0,
        budget: Budget::new(app.clock.now()),
        flooded: metrics::counter!(super::metrics::MESSAGES_REJECTED, "reason" => "rate_limited"),
        poses_in: metrics::counter!(super::metrics::MESSAGES_IN, "kind" => "pose"),
    };
    // Handles looked up once: a lookup hashes the name and labels.
    let commands_out = metrics::counter!(super::metrics::MESSAGES_OUT, "kind" => "command");
    let command_delay = metrics::histogram!(super::metrics::COMMAND_DELAY);
    // Registered once: a fresh `cancelled()` per frame would lock the
    // token's shared waiter list twice per pose, from every link at once.
    let shutdown = app.shutdown.cancelled();
    tokio::pin!(shutdown);
    loop {
        // One socket, not split: the branches' futures are dropped before a
        // handler runs, so a handler may write while the read is idle, and
        // nothing pays for the lock a split socket shares between halves.
        let flow = tokio::select! {
            // In this order: a command waiting behind a pose that is being
            // read and forwarded only arrives later. Commands come once a
            // tick, so they cannot starve the poses.
            biased;
            _ = &mut shutdown => {
                let _ = socket.send(text(&error("shutting_down", "the coordinator is shutting down"))).await;
                Flow::Close
            }
            out = link.commands.recv() => match out {
                Some(Outgoing::Command { text, due, written }) => {
                    let sent = socket.send(Message::Text(text)).await.is_ok();
                    drop(written);
                    commands_out.increment(1);
                    command_delay.record(due.elapsed().as_secs_f64());
                    if sent { Flow::Go } else { Flow::Close }
                }
                Some(Outgoing::Notice(message)) => match socket.send(text(&message)).await {
                    Ok(()) => Flow::Go,
                    Err(_) => Flow::Close,
                },
                Some(Outgoing::Message(message)) => {
                    let fatal = matches!(&message, CoordinatorMessage::Error { .. });
                    if socket.send(text(&message)).await.is_err() || fatal { Flow::Close } else { Flow::Go }
                }
                None => Flow::Close,
            },
            frame = socket.recv() => match frame {
                Some(Ok(Message::Text(t))) => reader.frame(&mut socket, &t, &link.poses).await,
                Some(Ok(Message::Close(_))) | None | Some(Err(_)) => Flow::Close,
                Some(Ok(_)) => Flow::Go,
            },
        };
        if let Flow::Close = flow {
            break;
        }
    }
    let _ = socket.close().await;
    tracing::info!(vessel = %id, peer = %peer_text, "vessel link down");
    app.recorder.event(
        EventRecord::new(app.clock.now(), EventKind::LinkDown)
            .vessel(id.clone())
            .peer(peer),
    );
    let _ = app
        .requests
        .send(Request::Gone {
            id,
            link: link.number,
        })
        .await;
}

/// Reads a welcomed link's frames: judges each and forwards its poses.
struct Reader<'a> {
    app: &'a AppState,
    peer: Option<SocketAddr>,
    peer_text: String,
    vessel: std::sync::Arc<str>,
    garbage: u32,
    budget: Budget,
    flooded: metrics::Counter,
    poses_in: metrics::Counter,
}

impl Reader<'_> {
    async fn frame(
        &mut self,
        socket: &mut WebSocket,
        t: &str,
        poses: &watch::Sender<Option<PoseDocument>>,
    ) -> Flow {
        let (app, peer, id) = (self.app, self.peer, &*self.vessel);
        let refusal = match parse(t) {
            Ok(VesselMessage::Pose(_)) if !self.budget.take(app.clock.now()) => {
                // Counted once each: by `error` when answered.
                if !self.budget.answer(app.clock.now()) {
                    self.flooded.increment(1);
                    return Flow::Go;
                }
                tracing::warn!(vessel = %id, peer = %self.peer_text, "vessel link over {MAX_POSE_RATE} poses a mission second: poses dropped");
                rejected(
                    app,
                    peer,
                    Some(id),
                    "rate_limited",
                    format!("more than {MAX_POSE_RATE} poses a mission second: poses dropped"),
                )
            }
            Ok(VesselMessage::Pose(pose)) if finite(&pose) => {
                self.poses_in.increment(1);
                // The clock is read only when recording: this runs for
                // every pose of every link.
                if app.recorder.is_on() {
                    app.recorder.pose(&self.vessel, app.clock.now(), &pose);
                }
                poses.send_replace(Some(pose));
                return Flow::Go;
            }
            Ok(VesselMessage::Pose(_)) => rejected(
                app,
                peer,
                Some(id),
                "invalid",
                "pose: every number must be finite",
            ),
            Ok(VesselMessage::Hello { .. }) => {
                rejected(app, peer, Some(id), "protocol", "hello twice on one link")
            }
            Ok(VesselMessage::Sample(s)) => {
                // Judged by the tick task, which answers a refusal on this
                // link; a full queue drops it, counted.
                let request = Request::LinkSample {
                    vessel: self.vessel.to_string(),
                    sample: s,
                };
                if app.requests.try_send(request).is_err() {
                    metrics::counter!(crate::server::metrics::SAMPLES, "outcome" => "dropped")
                        .increment(1);
                }
                return Flow::Go;
            }
            Err(e) => {
                self.garbage += 1;
                let refusal = rejected(
                    app,
                    peer,
                    Some(id),
                    "malformed",
                    crate::protocol::json_error(&e),
                );
                let _ = socket.send(text(&refusal)).await;
                return if self.garbage >= MAX_GARBAGE {
                    Flow::Close
                } else {
                    Flow::Go
                };
            }
        };
        let _ = socket.send(text(&refusal)).await;
        Flow::Go
    }
}

/// Refuses a link's hello: logged (who and why), counted, recorded,
/// answered with the error, and closed.
async fn refuse_hello(
    socket: WebSocket,
    app: &AppState,
    peer: Option<SocketAddr>,
    vessel: Option<&str>,
    code: &str,
    message: impl Into<String>,
) {
    let message = message.into();
    tracing::warn!(
        peer = %peer.map_or_else(|| "?".to_string(), |p| p.to_string()),
        vessel = vessel.unwrap_or("?"),
        %code,
        %message,
        "vessel link refused"
    );
    refuse(socket, rejected(app, peer, vessel, code, message)).await
}

/// Sends a fatal error, then closes the socket properly.
async fn refuse(mut sink: impl SinkExt<Message> + Unpin, message: CoordinatorMessage) {
    let _ = sink.send(text(&message)).await;
    let _ = sink.close().await;
}

/// `GET /api/v1/stream`: the newest snapshot on connect, then every change,
/// at most 10 per second. A slow client skips to the newest one (a `watch`
/// keeps only the latest), so nothing queues up.
pub(super) async fn stream(ws: WebSocketUpgrade, State(app): State<AppState>) -> Response {
    let tracker = app.tracker.clone();
    ws.max_message_size(MAX_FRAME)
        .read_buffer_size(READ_BUFFER)
        .on_upgrade(move |socket| tracker.track_future(run_stream(socket, app)))
}

async fn run_stream(socket: WebSocket, app: AppState) {
    let (mut sink, mut incoming) = socket.split();
    let mut snapshots = app.snapshot.clone();
    loop {
        let snap = snapshots.borrow_and_update().clone();
        let json = serde_json::to_string(&snap.document).expect("snapshots serialize");
        if sink
            .send(Message::Text(Utf8Bytes::from(json)))
            .await
            .is_err()
        {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
        tokio::select! {
            _ = app.shutdown.cancelled() => break,
            changed = snapshots.changed() => if changed.is_err() { break },
            frame = incoming.next() => match frame {
                Some(Ok(Message::Close(_))) | None | Some(Err(_)) => break,
                _ => {}
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pose fast path reads every frame exactly as the protocol's
    /// tagged enum does: the same pose, or an error where it errs.
    #[test]
    fn the_pose_fast_path_agrees_with_the_protocol_type() {
        let frames = [
            r#"{"type":"pose","t":1,"x":2.5,"y":-3,"psi":0.1,"u":1,"v":0,"r":0}"#,
            r#"{"x":2.5,"type":"pose","t":1,"y":-3,"psi":0.1,"u":1,"v":0,"r":0,"extra":[1,2]}"#,
            r#"{"type":"pose","t":1,"x":2,"y":3,"psi":0,"u":0,"v":0,"r":0,"telemetry":{"d":[1,2,3]}}"#,
            r#"{"type":"pose","t":1,"x":2,"y":3,"psi":0,"u":0,"v":0,"r":0,"telemetry":null}"#,
            r#"{"type":"pose","t":1,"x":2,"y":3,"psi":0,"u":0,"v":0}"#,
            r#"{"type":"pose","t":1,"x":"2","y":3,"psi":0,"u":0,"v":0,"r":0}"#,
            r#"{"type":"pose","type":"pose","t":1,"x":2,"y":3,"psi":0,"u":0,"v":0,"r":0}"#,
            r#"{"type":"Pose","t":1,"x":2,"y":3,"psi":0,"u":0,"v":0,"r":0}"#,
            r#"{"t":1,"x":2,"y":3,"psi":0,"u":0,"v":0,"r":0}"#,
            r#"{"type":"hello","vessel":"usv-1","protocol":1}"#,
            r#"{"type":"pose","t":1,"x":2,"y":3,"psi":0,"u":0,"v":0,"r":0"#,
            "[]",
            "",
        ];
        for frame in frames {
            let fast = parse(frame).map_err(|e| e.to_string());
            let full = serde_json::from_str::<VesselMessage>(frame).map_err(|e| e.to_string());
            assert_eq!(fast, full, "{frame}");
        }
    }
}
