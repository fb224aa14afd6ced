//! Zenoh's configuration from seacover's command line: a JSON5 file
//! (`--zenoh-config`, Zenoh's own format, for credentials and anything
//! else), then the mode and the endpoints given as flags, which win.
//!
//! Without endpoints a member finds the others by Zenoh's multicast
//! scouting (a LAN); `--zenoh-listen`/`--zenoh-connect` (`tcp/ADDR:PORT`,
//! `udp/…`, `quic/…`, `tls/…`) cover networks where multicast does not
//! pass. With a fleet's credentials ([`credentials`](super::credentials))
//! only the encrypted ones (`quic/`, `tls/`) are taken.

use std::path::PathBuf;

use super::error::PeerError;

/// Which Zenoh role a process takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    #[default]
    Peer,
    /// Routes for members that reach it over a routed network (LTE, VPN).
    Router,
}

/// The Zenoh flags of `agent --peer` and `serve --peer`.
#[derive(Debug, Clone, Default)]
pub struct ZenohOptions {
    pub mode: Mode,
    pub listen: Vec<String>,
    pub connect: Vec<String>,
    pub config: Option<PathBuf>,
}

impl ZenohOptions {
    /// The Zenoh configuration these options make.
    pub fn config(&self) -> Result<zenoh::Config, PeerError> {
        let mut config = match &self.config {
            Some(path) => zenoh::Config::from_file(path.clone())
                .map_err(|e| PeerError::Config(format!("{}: {e}", path.display())))?,
            None => zenoh::Config::default(),
        };
        if let Some(path) = &self.config {
            resolve_files(&mut config, path)?;
        }
        check_encrypted(&config, &[&self.listen[..], &self.connect[..]].concat())?;
        let mode = match self.mode {
            Mode::Peer => "\"peer\"",
            Mode::Router => "\"router\"",
        };
        config.insert_json5("mode", mode).map_err(bad)?;
        let list = |v: &[String]| serde_json::to_string(v).expect("strings serialize");
        if !self.listen.is_empty() {
            config
                .insert_json5("listen/endpoints", &list(&self.listen))
                .map_err(bad)?;
        } else if self.mode == Mode::Peer && !chose(&config, LISTEN) {
            config
                .insert_json5(LISTEN, &list(&[PEER_LISTEN.to_string()]))
                .map_err(bad)?;
        }
        if !chose(&config, LEASE) {
            config
                .insert_json5(LEASE, &PEER_LEASE_MS.to_string())
                .map_err(bad)?;
        }
        if !self.connect.is_empty() {
            config
                .insert_json5("connect/endpoints", &list(&self.connect))
                .map_err(bad)?;
        }
        let scouted_only = !chose(&config, CONNECT);
        if self.mode == Mode::Peer && scouted_only && !chose(&config, GOSSIP) {
            config.insert_json5(GOSSIP, "false").map_err(bad)?;
        }
        Ok(config)
    }
}

/// A peer's endpoint when neither the flags nor the file give one: UDP,
/// because a beacon is worthless once the next is due. Over TCP a lost
/// segment holds up everything behind it, a link cut by range backs off
/// its retransmissions for seconds after the pair is back in range, and
/// the acknowledgements alone cost more than the 1 kB/s per neighbour a
/// radio budget allows (measured: docs/peer.md, "Radio budgets"). What
/// needs to arrive whole (a mission revision) is asked for again until it
/// does, so nothing relies on retransmission.
pub const PEER_LISTEN: &str = "udp/0.0.0.0:0";

const LISTEN: &str = "listen/endpoints";
const LEASE: &str = "transport/link/tx/lease";
const CONNECT: &str = "connect/endpoints";

/// Zenoh's gossip, off for a peer that finds the others by multicast
/// scouting alone (no `connect` endpoints, and the file does not set it).
/// On a radio, scouting reaches exactly the members in range, and those
/// are the ones to link with; gossip tells each member of every other, and
/// it tries to link with each, out of range too, so its attempts grow with
/// the fleet: with a hundred vessels over a 300 m radio, 87 failed
/// attempts per vessel in the first minutes and 4 MB more memory per
/// process (docs/peer.md, "A hundred vessels"). Given endpoints (multicast
/// does not pass), gossip stays on: it introduces the members the
/// endpoints do not name.
const GOSSIP: &str = "scouting/gossip/enabled";

/// How long a member keeps a link to another that it no longer hears
/// [ms]: as long as a silent neighbour is kept as an obstacle
/// ([`Ageing::forget_after`](super::table::Ageing)), not Zenoh's 10 s. A
/// boat that leaves radio range and comes back finds its link still open
/// and is heard again with its next beacon; a link that closed would wait
/// for multicast scouting, which backs off to one attempt every 8 s.
/// Staleness is judged by beacon age, never by the link.
pub const PEER_LEASE_MS: u64 = 120_000;

/// Whether a configuration file chose `key`: Zenoh's defaults fill in
/// whatever a file leaves out, so a file chose it when it differs from
/// the default.
fn chose(config: &zenoh::Config, key: &str) -> bool {
    config.get_json(key).ok() != zenoh::Config::default().get_json(key).ok()
}

fn bad(e: impl std::fmt::Display) -> PeerError {
    PeerError::Config(e.to_string())
}

/// A relative file of a fleet's credentials
/// ([`credentials::FILES`](super::credentials::FILES)) is read next to
/// the configuration file, not in the working directory, and so is an
/// absolute one that does not exist but has a namesake there: a member's
/// directory works wherever it is copied.
fn resolve_files(config: &mut zenoh::Config, path: &std::path::Path) -> Result<(), PeerError> {
    for (key, _) in super::credentials::FILES {
        let key = format!("transport/link/tls/{key}");
        let Ok(json) = config.get_json(&key) else {
            continue;
        };
        let Ok(Some(file)) = serde_json::from_str::<Option<String>>(&json) else {
            continue;
        };
        let file = std::path::Path::new(&file);
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        let beside = file.file_name().map(|name| dir.join(name));
        let moved =
            file.is_absolute() && !file.exists() && beside.as_ref().is_some_and(|b| b.exists());
        if file.is_relative() || moved {
            let full = if moved {
                beside.expect("checked")
            } else {
                dir.join(file)
            };
            let value = serde_json::to_string(&full.to_string_lossy()).expect("strings serialize");
            config.insert_json5(&key, &value).map_err(bad)?;
        }
    }
    Ok(())
}

/// With a fleet's credentials (mutual TLS) every endpoint must be an
/// encrypted one: a `udp/` or `tcp/` endpoint given beside them would
/// carry the fleet's beacons in the clear, to anyone.
fn check_encrypted(config: &zenoh::Config, endpoints: &[String]) -> Result<(), PeerError> {
    let mtls = config.get_json("transport/link/tls/enable_mtls").ok();
    if mtls.as_deref() != Some("true") {
        return Ok(());
    }
    match endpoints
        .iter()
        .find(|e| !(e.starts_with("quic/") || e.starts_with("tls/")))
    {
        Some(e) => Err(PeerError::Config(format!(
            "{e}: with the fleet's credentials every endpoint is quic/ or tls/ (encrypted)"
        ))),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn endpoints(config: &zenoh::Config) -> serde_json::Value {
        serde_json::from_str(&config.get_json("listen/endpoints").unwrap()).unwrap()
    }

    #[test]
    fn a_peer_listens_on_udp_unless_told_otherwise() {
        let peer = ZenohOptions::default().config().unwrap();
        assert_eq!(endpoints(&peer), serde_json::json!([PEER_LISTEN]));

        let tcp = ZenohOptions {
            listen: vec!["tcp/0.0.0.0:7447".into()],
            ..Default::default()
        };
        assert_eq!(
            endpoints(&tcp.config().unwrap()),
            serde_json::json!(["tcp/0.0.0.0:7447"])
        );

        // A router keeps Zenoh's own default (TCP), for members on routed networks.
        let router = ZenohOptions {
            mode: Mode::Router,
            ..Default::default()
        };
        assert!(
            !endpoints(&router.config().unwrap())
                .to_string()
                .contains("udp")
        );
    }

    #[test]
    fn a_member_directory_works_where_it_is_copied_and_only_encrypted() {
        let dir = tempfile::tempdir().unwrap();
        let creds = dir.path().join("creds");
        let configs =
            super::super::credentials::create(&creds, "bay", &["usv-1".into()], 30).unwrap();
        let moved = dir.path().join("boat");
        std::fs::rename(configs[0].parent().unwrap(), &moved).unwrap();
        let options = ZenohOptions {
            config: Some(moved.join("zenoh.json5")),
            ..Default::default()
        };
        let config = options.config().unwrap();
        let ca = config
            .get_json("transport/link/tls/root_ca_certificate")
            .unwrap();
        let expected = moved.join("ca.pem");
        assert_eq!(ca, serde_json::to_string(&expected).unwrap());
        let clear = ZenohOptions {
            listen: vec!["udp/0.0.0.0:7447".into()],
            ..options
        };
        let refused = clear.config().unwrap_err().to_string();
        assert!(refused.contains("udp/0.0.0.0:7447"), "{refused}");
    }

    /// Unset (`null`) is Zenoh's default: on.
    fn gossip(config: &zenoh::Config) -> bool {
        config.get_json(GOSSIP).unwrap() != "false"
    }

    #[test]
    fn a_peer_found_by_scouting_alone_does_not_gossip() {
        assert!(!gossip(&ZenohOptions::default().config().unwrap()));
        let connect = ZenohOptions {
            connect: vec!["tcp/10.0.0.1:7447".into()],
            ..Default::default()
        };
        assert!(gossip(&connect.config().unwrap()));
        let router = ZenohOptions {
            mode: Mode::Router,
            ..Default::default()
        };
        assert!(gossip(&router.config().unwrap()));
        let dir = tempfile::tempdir().unwrap();
        for (file, expected) in [
            (r#"{ connect: { endpoints: ["udp/10.0.0.1:7447"] } }"#, true),
            (r#"{ scouting: { gossip: { enabled: true } } }"#, true),
        ] {
            let path = dir.path().join("zenoh.json5");
            std::fs::write(&path, file).unwrap();
            let options = ZenohOptions {
                config: Some(path),
                ..Default::default()
            };
            assert_eq!(gossip(&options.config().unwrap()), expected, "{file}");
        }
    }

    #[test]
    fn a_file_that_lists_endpoints_keeps_them() {
        let dir = std::env::temp_dir().join(format!("seacover-zenoh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("zenoh.json5");
        std::fs::write(&file, r#"{ listen: { endpoints: ["tcp/127.0.0.1:0"] } }"#).unwrap();
        let options = ZenohOptions {
            config: Some(file),
            ..Default::default()
        };
        let config = options.config().unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(endpoints(&config), serde_json::json!(["tcp/127.0.0.1:0"]));
    }
}
