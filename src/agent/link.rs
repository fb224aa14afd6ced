//! One vessel's link to the coordinator (docs/api.md, `/api/v1/vessels/link`),
//! shared by the simulated vessels and the MAVLink bridge.
//!
//! The vessel side publishes its newest pose in a `watch` and reads
//! [`Inbound`] messages (commands, and word that the link is lost) from a
//! channel; this task does the rest: connect (with the bearer token),
//! say hello, send every new pose, hand over every command, and reconnect
//! with exponential backoff and jitter when the link drops. A pose that
//! arrives while the link is down is not queued: only the newest matters.
//!
//! Invariants: the vessel never waits on the link (poses are a `watch`,
//! commands are dropped rather than queued when the vessel is behind); the
//! task ends only on `shutdown` (saying goodbye with a close frame), when
//! the URL is unusable, or after [`MAX_UNAUTHORIZED`] refusals of its token
//! in a row (no retry can mend a wrong token; the process should say so and
//! stop rather than retry for ever).

use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tokio::sync::{mpsc, watch};
use tokio_tungstenite::tungstenite::Message;
use tokio_util::sync::CancellationToken;

use crate::protocol::{
    AgilityDocument, CommandDocument, CoordinatorMessage, LinkSampleDocument, PoseDocument,
    VesselMessage,
};

/// What the link hands the vessel.
#[derive(Debug, Clone)]
pub enum Inbound {
    /// The coordinator welcomed the vessel (on every connection): its tick
    /// rate [Hz of mission time]. Tick N of a coordinator is at mission
    /// time N / tick_hz, so a vessel can place each command's line where
    /// the coordinator computed it, whatever the link's delay did to it.
    Welcome { tick_hz: f64 },
    /// A command from the coordinator.
    Command(CommandDocument),
    /// The connection to the coordinator closed or failed: no command will
    /// come until it is back. A vessel that must not wait out its command's
    /// age (a real boat) acts on this at once.
    Lost,
}

/// Where and as whom a link connects.
#[derive(Debug, Clone)]
pub struct LinkConfig {
    /// `ws://host:port/api/v1/vessels/link`.
    pub url: String,
    /// Sent as `Authorization: Bearer TOKEN`.
    pub token: Option<String>,
    /// The vessel's id, said in the hello.
    pub vessel: String,
    /// Seeds the reconnection jitter.
    pub seed: u64,
    /// Said in the hello: `Some(false)` for a vessel that cannot thrust
    /// astern.
    pub astern: Option<bool>,
    /// Said in the hello: the command rates the vessel can follow.
    pub agility: Option<AgilityDocument>,
    /// Said in the hello: the vessel keeps station by itself within this
    /// of its goal [m].
    pub station_radius: Option<f64>,
}

/// The WebSocket URL of a coordinator's vessel link from its base URL
/// (`http://host:port` or `ws://host:port` → `ws://host:port/api/v1/vessels/link`);
/// `None` for any other scheme.
pub fn link_url(server: &str) -> Option<String> {
    let base = server.trim_end_matches('/');
    let ws = if let Some(rest) = base.strip_prefix("http://") {
        format!("ws://{rest}")
    } else if let Some(rest) = base.strip_prefix("https://") {
        format!("wss://{rest}")
    } else if base.starts_with("ws://") || base.starts_with("wss://") {
        base.to_string()
    } else {
        return None;
    };
    Some(format!("{ws}/api/v1/vessels/link"))
}

/// A coordinator link's WebSocket.
pub type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// The upgrade request of a link to `url`, with the bearer token when there
/// is one.
fn request(
    url: &str,
    token: Option<&str>,
) -> Result<
    tokio_tungstenite::tungstenite::handshake::client::Request,
    tokio_tungstenite::tungstenite::Error,
> {
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;
    let mut request = url.into_client_request()?;
    if let Some(token) = token
        && let Ok(value) = format!("Bearer {token}").parse()
    {
        request.headers_mut().insert("authorization", value);
    }
    Ok(request)
}

/// Why a link's handshake failed.
#[derive(Debug, thiserror::Error)]
pub enum HandshakeError {
    #[error("bad link URL")]
    Url(#[source] tokio_tungstenite::tungstenite::Error),
    #[error("connecting")]
    Connect(#[source] tokio_tungstenite::tungstenite::Error),
    /// The coordinator answered the upgrade with an HTTP error (a wrong
    /// token's 401, a 429), with its JSON error's message when it has one.
    #[error("refused with HTTP {status}: {message}")]
    Rejected { status: u16, message: String },
    #[error("sending hello")]
    Hello(#[source] tokio_tungstenite::tungstenite::Error),
    #[error("refused: {code}: {message}")]
    Refused { code: String, message: String },
    #[error("a command or mission before the welcome")]
    EarlyCommand,
    #[error("unreadable frame: {0}")]
    Unreadable(String),
    #[error("closed before the welcome")]
    Closed,
    #[error("before the welcome")]
    Transport(#[source] tokio_tungstenite::tungstenite::Error),
}

/// The message of an HTTP error's body: docs/api.md's `{"error": {"message"}}`,
/// or the body as text.
fn http_message(body: Option<&[u8]>) -> String {
    let body = body.unwrap_or_default();
    serde_json::from_slice::<crate::protocol::ErrorDocument>(body)
        .map(|d| d.error.message)
        .unwrap_or_else(|_| String::from_utf8_lossy(body).trim().to_string())
}

/// A link the coordinator welcomed.
pub struct Welcomed {
    pub socket: Socket,
    /// The mission's name, to say in the next hello.
    pub mission: Option<String>,
    /// The coordinator's tick rate [Hz of mission time].
    pub tick_hz: f64,
}

/// Connects to `url` (with the bearer token), says `hello` and waits for the
/// coordinator's welcome: the handshake of every vessel link, simulated,
/// bridged or the load client's.
pub async fn handshake(
    url: &str,
    token: Option<&str>,
    hello: &VesselMessage,
) -> Result<Welcomed, HandshakeError> {
    let request = request(url, token).map_err(HandshakeError::Url)?;
    // Small frames both ways: send each at once rather than waiting for
    // the previous one's acknowledgement (no Nagle), and a small read
    // buffer (tungstenite zero-fills all of it, 128 KiB by default; 1000
    // links of the load client would hold 128 MiB).
    let config = tokio_tungstenite::tungstenite::protocol::WebSocketConfig::default()
        .read_buffer_size(4 * 1024);
    let (mut socket, _) = tokio_tungstenite::connect_async_with_config(request, Some(config), true)
        .await
        .map_err(|e| match e {
            tokio_tungstenite::tungstenite::Error::Http(response) => HandshakeError::Rejected {
                status: response.status().as_u16(),
                message: http_message(response.body().as_deref()),
            },
            e => HandshakeError::Connect(e),
        })?;
    socket
        .send(text(hello))
        .await
        .map_err(HandshakeError::Hello)?;
    loop {
        match socket.next().await {
            Some(Ok(Message::Text(t))) => match serde_json::from_str::<CoordinatorMessage>(&t) {
                Ok(CoordinatorMessage::Welcome {
                    mission, tick_hz, ..
                }) => {
                    return Ok(Welcomed {
                        socket,
                        mission,
                        tick_hz,
                    });
                }
                Ok(CoordinatorMessage::Error { code, message }) => {
                    return Err(HandshakeError::Refused { code, message });
                }
                Ok(CoordinatorMessage::Command(_) | CoordinatorMessage::Mission { .. }) => {
                    return Err(HandshakeError::EarlyCommand);
                }
                Err(e) => return Err(HandshakeError::Unreadable(e.to_string())),
            },
            Some(Ok(Message::Close(_))) | None => return Err(HandshakeError::Closed),
            Some(Err(e)) => return Err(HandshakeError::Transport(e)),
            Some(Ok(_)) => {}
        }
    }
}

fn text<T: serde::Serialize>(value: &T) -> Message {
    Message::text(serde_json::to_string(value).expect("protocol messages serialize"))
}

/// Refusals of the token (HTTP 401) in a row after which a link gives up.
pub const MAX_UNAUTHORIZED: u32 = 3;

/// Why a link gave up.
#[derive(Debug, Clone, thiserror::Error)]
pub enum LinkError {
    #[error("bad coordinator URL {url}: {message}")]
    Url { url: String, message: String },
    #[error(
        "the coordinator refused {vessel}'s token {count} times (HTTP 401: {message}); \
         give the coordinator's token with --token or the SEACOVER_TOKEN variable"
    )]
    Unauthorized {
        vessel: String,
        count: u32,
        message: String,
    },
}

/// Keeps the link up until `shutdown`; an error when it gave up.
pub async fn run(
    config: LinkConfig,
    mut poses: watch::Receiver<Option<PoseDocument>>,
    mut samples: Option<mpsc::Receiver<LinkSampleDocument>>,
    commands: mpsc::Sender<Inbound>,
    shutdown: CancellationToken,
) -> Result<(), LinkError> {
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let mut backoff = Duration::from_millis(100);
    let mut unauthorized = 0;
    // The mission this vessel follows, as the coordinator names it: said
    // in each hello, so that a coordinator restarted without the mission
    // holds the vessel rather than re-tasking it (docs/api.md).
    let mut following: Option<String> = None;
    while !shutdown.is_cancelled() {
        if let Err(e) = request(&config.url, config.token.as_deref()) {
            tracing::error!(url = %config.url, error = %e, "bad coordinator URL");
            return Err(LinkError::Url {
                url: config.url.clone(),
                message: e.to_string(),
            });
        }
        let hello = VesselMessage::Hello {
            vessel: config.vessel.clone(),
            protocol: 1,
            actuator: None,
            astern: config.astern,
            agility: config.agility,
            mission: following.clone(),
            station_radius: config.station_radius,
        };
        tracing::info!(vessel = %config.vessel, url = %config.url, "connecting to the coordinator");
        let connected = tokio::select! {
            _ = shutdown.cancelled() => return Ok(()),
            c = handshake(&config.url, config.token.as_deref(), &hello) => c,
        };
        let socket = match connected {
            Ok(welcomed) => {
                // No name: held for following another mission; keep it.
                if welcomed.mission.is_some() {
                    following = welcomed.mission;
                }
                let _ = commands.try_send(Inbound::Welcome {
                    tick_hz: welcomed.tick_hz,
                });
                welcomed.socket
            }
            Err(e) => {
                let wait = backoff.mul_f64(rng.random_range(0.5..1.5));
                refused(&config, &e, wait, &mut unauthorized)?;
                tokio::select! {
                    _ = shutdown.cancelled() => return Ok(()),
                    _ = tokio::time::sleep(wait) => {}
                }
                backoff = (backoff * 2).min(Duration::from_secs(5));
                continue;
            }
        };
        unauthorized = 0;
        tracing::info!(vessel = %config.vessel, url = %config.url, "connected to the coordinator");
        backoff = Duration::from_millis(100);
        let link = Connected {
            config: &config,
            poses: &mut poses,
            samples: &mut samples,
            commands: &commands,
            shutdown: &shutdown,
            following: &mut following,
        };
        if let Ended::Stopped = link.serve(socket).await {
            return Ok(());
        }
        if !shutdown.is_cancelled() {
            tracing::warn!(vessel = %config.vessel, "link to the coordinator lost; reconnecting");
        }
        // Unlike a command, the loss is not dropped when the vessel is
        // behind: it is the one message that must arrive (and the vessel
        // drains its channel within a step). An error means the vessel is
        // gone, which ends nothing here: shutdown does.
        tokio::select! {
            _ = shutdown.cancelled() => return Ok(()),
            _ = commands.send(Inbound::Lost) => {}
        }
    }
    Ok(())
}

/// The next sample, or never when the vessel takes none.
async fn next_sample(
    samples: &mut Option<mpsc::Receiver<LinkSampleDocument>>,
) -> Option<LinkSampleDocument> {
    match samples {
        Some(r) => r.recv().await,
        None => std::future::pending().await,
    }
}

/// Says why a handshake failed; an error once the token has been refused
/// [`MAX_UNAUTHORIZED`] times in a row.
fn refused(
    config: &LinkConfig,
    e: &HandshakeError,
    wait: Duration,
    unauthorized: &mut u32,
) -> Result<(), LinkError> {
    let retry_in_ms = wait.as_millis() as u64;
    match e {
        HandshakeError::Rejected {
            status: 401,
            message,
        } => {
            *unauthorized += 1;
            let given = if config.token.is_some() {
                "the token given"
            } else {
                "no token"
            };
            tracing::error!(vessel = %config.vessel, %message, attempt = *unauthorized, "the coordinator refused the link (HTTP 401, {given}): give its token with --token or the SEACOVER_TOKEN variable");
            if *unauthorized >= MAX_UNAUTHORIZED {
                return Err(LinkError::Unauthorized {
                    vessel: config.vessel.clone(),
                    count: *unauthorized,
                    message: message.clone(),
                });
            }
        }
        HandshakeError::Refused { .. } | HandshakeError::Rejected { .. } => {
            tracing::warn!(vessel = %config.vessel, error = %crate::chain::Chain(e), retry_in_ms, "the coordinator refused the link; retrying");
        }
        _ => {
            tracing::info!(vessel = %config.vessel, error = %crate::chain::Chain(e), retry_in_ms, "cannot reach the coordinator; retrying");
        }
    }
    Ok(())
}

/// How a connection ended.
enum Ended {
    /// Shutdown, or the vessel is gone: the link ends.
    Stopped,
    /// The connection was lost: the link reconnects.
    Lost,
}

/// A welcomed connection's loop: poses out, commands in.
struct Connected<'a> {
    config: &'a LinkConfig,
    poses: &'a mut watch::Receiver<Option<PoseDocument>>,
    /// The vessel's samples of the risk field, if it takes any.
    samples: &'a mut Option<mpsc::Receiver<LinkSampleDocument>>,
    commands: &'a mpsc::Sender<Inbound>,
    shutdown: &'a CancellationToken,
    following: &'a mut Option<String>,
}

impl Connected<'_> {
    async fn serve(self, socket: Socket) -> Ended {
        let vessel = &self.config.vessel;
        let (mut sink, mut stream) = socket.split();
        // The pose current at connection goes out at once, not only the
        // next one.
        self.poses.mark_changed();
        loop {
            tokio::select! {
                _ = self.shutdown.cancelled() => {
                    let _ = sink.send(Message::Close(None)).await;
                    return Ended::Stopped;
                }
                changed = self.poses.changed() => {
                    if changed.is_err() {
                        // The vessel is gone: nothing more to report.
                        let _ = sink.send(Message::Close(None)).await;
                        return Ended::Stopped;
                    }
                    let pose = self.poses.borrow_and_update().clone();
                    if let Some(pose) = pose
                        && sink.send(text(&VesselMessage::Pose(pose))).await.is_err()
                    {
                        return Ended::Lost;
                    }
                }
                sample = next_sample(self.samples) => match sample {
                    Some(s) => if sink.send(text(&VesselMessage::Sample(s))).await.is_err() {
                        return Ended::Lost;
                    },
                    // The vessel takes no more samples.
                    None => *self.samples = None,
                },
                frame = stream.next() => match frame {
                    Some(Ok(Message::Text(t))) => match serde_json::from_str::<CoordinatorMessage>(&t) {
                        Ok(CoordinatorMessage::Command(c)) => {
                            // A vessel behind on its commands wants the
                            // next one, not a backlog.
                            let _ = self.commands.try_send(Inbound::Command(c));
                        }
                        Ok(CoordinatorMessage::Welcome { .. }) => {}
                        Ok(CoordinatorMessage::Mission { mission }) => {
                            tracing::info!(%vessel, %mission, "the coordinator's mission changed");
                            *self.following = Some(mission);
                        }
                        Ok(CoordinatorMessage::Error { code, message }) if code == "shutting_down" => {
                            tracing::info!(%vessel, %message, "coordinator stopping");
                        }
                        Ok(CoordinatorMessage::Error { code, message }) => {
                            tracing::warn!(%vessel, %code, %message, "coordinator error");
                        }
                        Err(e) => tracing::warn!(%vessel, error = %e, "unreadable frame"),
                    },
                    Some(Ok(Message::Close(_))) | None | Some(Err(_)) => return Ended::Lost,
                    Some(Ok(_)) => {}
                },
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_urls() {
        assert_eq!(
            link_url("http://127.0.0.1:8090/").unwrap(),
            "ws://127.0.0.1:8090/api/v1/vessels/link"
        );
        assert_eq!(
            link_url("https://fleet.example").unwrap(),
            "wss://fleet.example/api/v1/vessels/link"
        );
        assert_eq!(
            link_url("ws://[::1]:80").unwrap(),
            "ws://[::1]:80/api/v1/vessels/link"
        );
        assert!(link_url("127.0.0.1:8090").is_none());
    }
}
