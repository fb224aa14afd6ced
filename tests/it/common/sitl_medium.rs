//! ArduPilot SITL boats and their peer bridges on a radio medium
//! ([`Medium`], [`super::netns`]): boat i's autopilot (SITL) and its bridge
//! (`seacover agent --mavlink … --peer`) run together in host i's network
//! namespace, as on a boat whose companion computer reaches its autopilot
//! on board and the other boats only by radio. The bridges' Zenoh links
//! cross the medium, where a test cuts and heals them; the test process
//! reads each boat's second MAVLink port from inside that boat's namespace
//! ([`connect_in`]), as an operator's ground station on board would.
//!
//! Invariants:
//! - Every boat is SITL instance 0 (ports 5760 and 5762) in its own
//!   namespace: each namespace has its own loopback and ports, so the
//!   boats cannot collide with each other or with anything of the
//!   machine's, and nothing listens in the machine's namespace.
//! - The bridges find each other as the peer fleet tests' vessels do
//!   (tests/it/common/fleet.rs): Zenoh's defaults, multicast scouting on
//!   the medium and UDP links (docs/peer.md, "Networks"), under a fleet
//!   name the caller makes unique, so that nothing but the medium's hosts
//!   can join.
//! - Only a short-lived thread of the test process ever enters a
//!   namespace: setns(2) moves the calling thread only, and that thread
//!   opens its socket and exits. A socket keeps the namespace it was made
//!   in, so the test's own threads read it from the machine's namespace.

use std::net::TcpStream;
use std::os::fd::AsRawFd;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use mavlink::AsyncConnectable;
use mavlink::dialects::ardupilotmega::MavMessage;

use super::netns::Medium;
use super::sitl::{Ardupilot, Boat, Bridge, Station, boat_by, peer_bridge_args, scattered_start};

/// Where `ip netns add` mounts the namespaces it names (its
/// NETNS_RUN_DIR; [`Medium`] removes them from there).
const NETNS_DIR: &str = "/var/run/netns";

/// A TCP connection to 127.0.0.1:`port` inside the network namespace
/// `ns` (one that `ip netns add` made), opened by a thread of its own
/// that enters the namespace and then ends: the caller's threads stay
/// where they are.
pub(crate) fn connect_in(ns: &str, port: u16) -> std::io::Result<TcpStream> {
    let file = std::fs::File::open(Path::new(NETNS_DIR).join(ns))?;
    std::thread::scope(|s| {
        s.spawn(|| {
            // SAFETY: setns(2) with a descriptor this thread holds open, of
            // a network namespace; it changes only the calling thread,
            // which ends once the socket is made.
            if unsafe { libc::setns(file.as_raw_fd(), libc::CLONE_NEWNET) } != 0 {
                return Err(std::io::Error::last_os_error());
            }
            TcpStream::connect(("127.0.0.1", port))
        })
        .join()
        .expect("the thread that connects inside the namespace")
    })
}

/// The four boats of [`super::sitl::scattered_boats`], boat i + 1 in host
/// i of `medium`, each SITL instance 0 in its namespace.
pub(crate) fn scattered_boats_in(ap: &Ardupilot, medium: &Medium) -> Vec<Boat> {
    (0..4u8)
        .map(|i| {
            let command = medium.command(usize::from(i), &ap.binary);
            boat_by(command, 0, ap, i + 1, scattered_start(i), None)
        })
        .collect()
}

/// Each of `boats` (boat i in host i) its own `agent --mavlink … --id
/// boat-<i + 1> --peer --arm --fleet <fleet> --mission <mission>` in the
/// same host, with Zenoh's defaults (the module doc); their ids.
pub(crate) fn peer_bridges_in(
    medium: &Medium,
    boats: &[Boat],
    mission: &Path,
    fleet: &str,
) -> (Vec<Bridge>, Vec<String>) {
    let ids: Vec<String> = (1..=boats.len()).map(|i| format!("boat-{i}")).collect();
    let bridges = boats
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let args = peer_bridge_args(b, &ids[i], fleet, mission);
            Bridge::agent_by(medium.command(i, env!("CARGO_BIN_EXE_seacover")), &args)
        })
        .collect();
    (bridges, ids)
}

impl Station {
    /// [`Station::open`] on `boat`, which runs in host `host` of
    /// `medium`: its second port is reached from inside that namespace
    /// ([`connect_in`]), retried for 20 s while SITL starts.
    pub(crate) async fn open_in(medium: &Medium, host: usize, boat: &Boat) -> Station {
        let (ns, port) = (medium.host_ns(host).to_string(), boat.second);
        let began = Instant::now();
        let stream = loop {
            let inside = ns.clone();
            let tried = tokio::task::spawn_blocking(move || connect_in(&inside, port))
                .await
                .expect("the connecting task");
            match tried {
                Ok(stream) => break stream,
                Err(_) if began.elapsed() < Duration::from_secs(20) => {
                    tokio::time::sleep(Duration::from_millis(200)).await;
                }
                Err(e) => panic!("127.0.0.1:{port} in {ns}: {e}"),
            }
        };
        // The stream becomes tokio's here: non-blocking, on this runtime.
        let connection = match mavlink::TcpConfig::from_stream(stream) {
            Ok(c) => c.connect_async::<MavMessage>().await,
            Err(e) => Err(e),
        }
        .unwrap_or_else(|e| panic!("127.0.0.1:{port} in {ns}: {e}"));
        Station::watch(Arc::new(connection), boat.sysid).await
    }

    /// [`Station::open_in`] on each of `boats`, boat i in host i.
    pub(crate) async fn open_all_in(medium: &Medium, boats: &[Boat]) -> Vec<Station> {
        let mut stations = Vec::new();
        for (host, b) in boats.iter().enumerate() {
            stations.push(Station::open_in(medium, host, b).await);
        }
        stations
    }
}
