//! `seacover agent --peer`: a fleet that needs no coordinator (docs/peer.md).
//!
//! Every vessel runs the coverage loop on board with its neighbours only,
//! over Eclipse Zenoh in peer mode: it publishes its beacon 5 times a
//! second, holds a liveliness token while it runs, hears the others'
//! beacons, computes its own range-limited cell ([`step`]) and drives its
//! hull's controller as the linked agent does. The mission travels on the
//! fleet's mission key with a revision; every member keeps the newest valid
//! revision and answers queries for it ([`board`]), so a vessel that joins
//! late gets it from any peer.
//!
//! Parts: [`wire`] (encoding and value rules), [`credentials`] (Zenoh's
//! user/password authentication for a fleet), [`table`] (neighbours, ages,
//! refusals), [`board`] (mission revisions), [`step`] (the loop on board),
//! [`split`] (the plan both sides of a partition follow),
//! [`session`] (Zenoh's configuration from the command line), [`node`]
//! (the Zenoh declarations and the tasks).
//!
//! Invariants: no transport, discovery or membership of our own (Zenoh's
//! scouting, routing, liveliness and authentication do it); a slow link
//! never blocks a vessel (beacons are express and dropped on congestion);
//! a vessel without a mission holds station and says so (`controlled`
//! false); nothing received can change a vessel's mission but a valid,
//! higher revision.

pub mod board;
pub mod credentials;
mod error;
mod index;
mod joining;
pub mod learn;
pub mod node;
pub mod samples;
pub mod session;
pub mod split;
pub mod step;
pub mod table;
pub mod wire;

use crate::protocol::peer::PeerMissionDocument;
pub use error::PeerError;

/// A peer process's settings.
#[derive(Debug, Clone)]
pub struct PeerConfig {
    pub fleet: String,
    pub zenoh: session::ZenohOptions,
    /// Revision 0 of the mission, from `--mission FILE`; without it the
    /// vessels hold station until a peer gives them one.
    pub mission: Option<PeerMissionDocument>,
    pub time_warp: f64,
    /// Beacons per second of mission time.
    pub beacon_hz: f64,
    pub ageing: table::Ageing,
    /// Cover even while hearing no other vessel (`--alone`, single-boat
    /// work). Without it a vessel that hears nobody (the only one left, or
    /// one whose credentials the fleet refuses) holds station: covering the
    /// whole region by itself would take it onto water a fleet it cannot
    /// hear is working.
    pub alone: bool,
    /// Learn the risk map from the fleet's samples (`--learn`; every member
    /// the same settings).
    pub learning: Option<learn::LearnSettings>,
    /// What the simulated vessels' sensors measure (`--truth`).
    pub sensor: Option<crate::agent::sensor::SensorConfig>,
    /// Seeds the simulated sensors' noise.
    pub seed: u64,
}

impl PeerConfig {
    pub fn new(fleet: String, zenoh: session::ZenohOptions) -> Result<PeerConfig, PeerError> {
        if !wire::valid_fleet(&fleet) {
            return Err(PeerError::Fleet);
        }
        Ok(PeerConfig {
            fleet,
            zenoh,
            mission: None,
            time_warp: 1.0,
            beacon_hz: 5.0,
            ageing: table::Ageing::default(),
            alone: false,
            learning: None,
            sensor: None,
            seed: 1,
        })
    }
}

/// The mission document in `path` (a mission as `GET /api/v1/mission`
/// gives it, or a scenario document, whose region, risk and first
/// vessel's actuator make the mission), as revision 0.
pub fn mission_file(path: &std::path::Path) -> Result<PeerMissionDocument, PeerError> {
    let text = std::fs::read_to_string(path).map_err(|source| PeerError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let dir = path.parent().unwrap_or(std::path::Path::new("."));
    let text = crate::raster::resolve(&text, dir).map_err(|source| PeerError::Raster {
        path: path.to_path_buf(),
        source,
    })?;
    let mission =
        crate::mission::Mission::from_text(&text).map_err(|source| PeerError::Mission {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(PeerMissionDocument {
        revision: 0,
        mission: mission.document(),
        by: Some(wire::author(&format!(
            "seacover agent --mission {}",
            path.display()
        ))),
        at: Some(wire::now_utc()),
    })
}
