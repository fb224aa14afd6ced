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
//! Parts: [`wire`] (encoding and value rules), [`credentials`] (a fleet's
//! certificate authority and members, for Zenoh's mutual TLS), [`table`]
//! (neighbours, ages,
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

use crate::protocol::ActuatorDocument;
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
    /// Each vessel's own actuator.
    pub actuators: OwnActuators,
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
            actuators: OwnActuators::default(),
        })
    }
}

impl PeerConfig {
    /// Takes revision 0 of the mission from `path` (a mission as `GET
    /// /api/v1/mission` gives it, or a scenario document, whose region,
    /// risk and first vessel's actuator make the mission) and, from a
    /// scenario, each vessel's own actuator ([`OwnActuators`]).
    pub fn load_mission(&mut self, path: &std::path::Path) -> Result<(), PeerError> {
        let text = std::fs::read_to_string(path).map_err(|source| PeerError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        let text = crate::raster::resolve(&text, dir).map_err(|source| PeerError::Raster {
            path: path.to_path_buf(),
            source,
        })?;
        let refused = |source| PeerError::Mission {
            path: path.to_path_buf(),
            source,
        };
        let mission = crate::mission::Mission::from_text(&text).map_err(refused)?;
        self.actuators.scenario =
            crate::mission::Mission::vessel_actuators(&text).map_err(refused)?;
        self.mission = Some(PeerMissionDocument {
            revision: 0,
            mission: mission.document(),
            by: Some(wire::author(&format!(
                "seacover agent --mission {}",
                path.display()
            ))),
            at: Some(wire::now_utc()),
        });
        Ok(())
    }
}

/// Which actuator each of this process's vessels computes its cell with
/// and announces in its beacons: `given` (`--actuator`) for every one;
/// else the vessel of the same id in the `--mission` scenario; else the
/// mission's (its first vessel's).
#[derive(Debug, Clone, Default)]
pub struct OwnActuators {
    pub given: Option<ActuatorDocument>,
    pub scenario: std::collections::BTreeMap<String, ActuatorDocument>,
}

impl OwnActuators {
    /// The actuator vessel `id` declares; `None`: the mission's.
    pub fn of(&self, id: &str) -> Option<ActuatorDocument> {
        self.given.or_else(|| self.scenario.get(id).copied())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vessel_takes_its_own_actuator_from_the_scenario_unless_given_one() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paper-mixed.json");
        let mut config = PeerConfig::new("f".into(), session::ZenohOptions::default()).unwrap();
        config.load_mission(&path).unwrap();
        let wide = ActuatorDocument {
            k: 0.5,
            beta: 0.004,
        };
        let paper = ActuatorDocument {
            k: 0.5,
            beta: 0.001,
        };
        assert_eq!(config.actuators.of("usv-2"), Some(wide));
        assert_eq!(config.actuators.of("usv-3"), Some(paper));
        // Not in the scenario: the mission's, which is its first vessel's.
        assert_eq!(config.actuators.of("mav-1"), None);
        assert_eq!(config.mission.as_ref().unwrap().mission.actuator, paper);
        config.actuators.given = Some(wide);
        assert_eq!(config.actuators.of("usv-3"), Some(wide));
        assert_eq!(config.actuators.of("mav-1"), Some(wide));
    }
}
