//! `seacover agent`: simulated vessels on real links (docs/api.md).
//!
//! Each vessel is one task with its own WebSocket link. On board it runs the
//! dynamics (RK4, 1 ms), the disturbance, the observer and the controller in
//! simulated time locked to the (warped) wall clock, reports its pose at
//! 20 Hz, and tracks the newest command: a line along its rates from the
//! instant it arrived, given to the controller through the on-board
//! governor ([`reference`](crate::control::reference)), exactly as in
//! `seacover sim`; when that command is more than 1 s old it holds station
//! (u_d = r_d = 0). Each pose's telemetry reports the largest tracking
//! error |u − u_ref|, |r − r_ref| and command lag |c − ref| at any 1 ms step
//! since the previous pose (`tracking_error`, `command_lag`, each `{u, r}`),
//! so a recording shows how well the hull followed its commands.
//! A lost link is retried with exponential backoff and jitter ([`link`]);
//! the vessel keeps moving meanwhile, as a real one would.
//!
//! [`mavlink`] is the other kind of agent: a bridge that puts real
//! autopilots (ArduPilot boats) on the same links.

pub mod link;
pub mod mavlink;
mod onboard;
pub mod peer;
pub mod sensor;

use std::time::Duration;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;

use link::LinkConfig;

use crate::control::Vec3;
use crate::control::model::{State, VesselParams};
use crate::control::reference::agility;
use crate::protocol::AgilityDocument;
use onboard::Onboard;
pub use onboard::VesselConfig;

/// Settings shared by a fleet of agents.
#[derive(Debug, Clone)]
pub struct AgentConfig {
    /// `ws://host:port/api/v1/vessels/link`.
    pub url: String,
    pub time_warp: f64,
    pub pose_hz: f64,
    pub seed: u64,
    /// Sent as `Authorization: Bearer TOKEN`.
    pub token: Option<String>,
}

/// Starts from the built-in paper scenario (ids usv-1 … usv-8).
pub fn paper_vessels(params: VesselParams) -> Vec<VesselConfig> {
    let doc = crate::mission::scenario::parse_document(crate::mission::PAPER_SCENARIO)
        .expect("built-in scenario");
    starts_of(&doc, params)
}

/// The vessels of a scenario document (its ids, and its starts in its own
/// plane); `None` for a mission document, or a scenario without vessels.
pub fn scenario_vessels(text: &str, params: VesselParams) -> Option<Vec<VesselConfig>> {
    let doc = crate::mission::scenario::parse_document(text).ok()?;
    (!doc.vessels.is_empty()).then(|| starts_of(&doc, params))
}

fn starts_of(
    doc: &crate::mission::scenario::LocalScenario,
    params: VesselParams,
) -> Vec<VesselConfig> {
    doc.vessels
        .iter()
        .enumerate()
        .map(|(i, v)| VesselConfig {
            id: v.id.clone(),
            index: i + 1,
            start: State {
                x: v.x,
                y: v.y,
                psi: v.psi.unwrap_or(0.0),
                vel: Vec3::zeros(),
            },
            params,
        })
        .collect()
}

/// `n` vessels named `{prefix}-1` …, started uniformly in [min, max].
pub fn random_vessels(
    prefix: &str,
    n: usize,
    min: (f64, f64),
    max: (f64, f64),
    seed: u64,
    params: VesselParams,
) -> Vec<VesselConfig> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|i| VesselConfig {
            id: format!("{prefix}-{}", i + 1),
            index: i + 1,
            start: State {
                x: rng.random_range(min.0..max.0),
                y: rng.random_range(min.1..max.1),
                psi: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
                vel: Vec3::zeros(),
            },
            params,
        })
        .collect()
}

/// Why a fleet of simulated vessels could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FleetError {
    #[error("--vessels must be in [1, 10000]")]
    Count,
    #[error("--id must match [A-Za-z0-9_.-]{{1,64}}")]
    Id,
}

/// The fleet a peer node runs: with a scenario document as its mission
/// (`scenario`, its text) and no count asked, the scenario's own vessels
/// where it starts them, or with `id` the one of that id (else its first,
/// renamed); otherwise [`fleet`] of `n` (8 when not asked).
pub fn peer_fleet(
    scenario: Option<&str>,
    n: Option<usize>,
    id: Option<String>,
    params: VesselParams,
    seed: u64,
) -> Result<Vec<VesselConfig>, FleetError> {
    let Some(mut vessels) = scenario
        .filter(|_| n.is_none())
        .and_then(|text| scenario_vessels(text, params))
    else {
        return fleet(n.unwrap_or(DEFAULT_VESSELS), id, params, seed);
    };
    if let Some(id) = id {
        if !crate::mission::scenario::valid_id(&id) {
            return Err(FleetError::Id);
        }
        let at = vessels.iter().position(|v| v.id == id).unwrap_or(0);
        vessels.swap(0, at);
        vessels.truncate(1);
        vessels[0].id = id;
    }
    Ok(vessels)
}

/// How many vessels `seacover agent` simulates unless told.
pub const DEFAULT_VESSELS: usize = 8;

/// The fleet `seacover agent` runs: `n` vessels, the first eight at the
/// paper's starts (usv-1 … usv-8), further ones (usv-9 …) at seeded random
/// starts in the paper's region; or, with `id`, one vessel of that id at the
/// paper's first start.
pub fn fleet(
    n: usize,
    id: Option<String>,
    params: VesselParams,
    seed: u64,
) -> Result<Vec<VesselConfig>, FleetError> {
    if !(1..=crate::coverage::fleet::MAX_VESSELS).contains(&n) {
        return Err(FleetError::Count);
    }
    let mut vessels = paper_vessels(params);
    if n > vessels.len() {
        let extra = random_vessels(
            "usv",
            n - vessels.len(),
            (0.0, 0.0),
            (100.0, 100.0),
            seed,
            params,
        );
        vessels.extend(extra.into_iter().enumerate().map(|(i, mut v)| {
            v.id = format!("usv-{}", 9 + i);
            v.index = 9 + i;
            v
        }));
    }
    vessels.truncate(n);
    if let Some(id) = id {
        if !crate::mission::scenario::valid_id(&id) {
            return Err(FleetError::Id);
        }
        vessels.truncate(1);
        vessels[0].id = id;
    }
    Ok(vessels)
}

/// Runs every vessel until `shutdown`, or until a vessel's link gives up
/// (its token refused): then every vessel stops and that is the error.
pub async fn run_fleet(
    config: AgentConfig,
    vessels: Vec<VesselConfig>,
    shutdown: CancellationToken,
) -> Result<(), link::LinkError> {
    let stop = shutdown.child_token();
    let tasks: Vec<_> = vessels
        .into_iter()
        .enumerate()
        .map(|(i, v)| {
            tokio::spawn(run_vessel(
                config.clone(),
                v,
                config.seed.wrapping_add(i as u64),
                stop.clone(),
            ))
        })
        .collect();
    let mut first = None;
    for t in tasks {
        if let Ok(Err(e)) = t.await {
            stop.cancel();
            first.get_or_insert(e);
        }
    }
    first.map_or(Ok(()), Err)
}

async fn run_vessel(
    config: AgentConfig,
    vessel: VesselConfig,
    seed: u64,
    shutdown: CancellationToken,
) -> Result<(), link::LinkError> {
    let period = 1.0 / config.pose_hz;
    let mut onboard = Onboard::new(&vessel).paced(period);
    let (poses, pose_slot) = watch::channel(None);
    let (commands, mut incoming) = mpsc::channel(4);
    let mut link = tokio::spawn(link::run(
        LinkConfig {
            url: config.url.clone(),
            token: config.token.clone(),
            vessel: vessel.id.clone(),
            seed,
            astern: None,
            agility: Some({
                let a = agility(&vessel.params);
                AgilityDocument {
                    yaw_accel: a.yaw_accel,
                    surge_accel: a.surge_accel,
                }
            }),
            // The simulated hull keeps station with the coordinator's
            // commands (the keeper's own surge and aim).
            station_radius: None,
        },
        pose_slot,
        None,
        commands,
        shutdown.clone(),
    ));
    let mut ticker = tokio::time::interval(Duration::from_secs_f64(period / config.time_warp));
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    // The vessel sails on whether or not its link is up, as a real one would.
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            // The link gave up (a refused token): the vessel's run is over.
            given_up = &mut link => return given_up.unwrap_or(Ok(())),
            _ = ticker.tick() => {
                onboard.advance(period);
                poses.send_replace(Some(onboard.pose()));
            }
            Some(m) = incoming.recv() => match m {
                link::Inbound::Welcome { tick_hz } => onboard.tick_period = Some(1.0 / tick_hz),
                link::Inbound::Command(c) => onboard.receive(c),
                // The simulated hull keeps its own rule for an aging
                // command (docs/api.md): it needs no word of the loss.
                link::Inbound::Lost => {}
            },
        }
    }
    match link.await {
        Ok(Err(e)) => Err(e),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HARBOUR: &str = include_str!("../../examples/harbour.json");

    /// A peer node given a scenario runs its vessels where it starts them,
    /// not the paper's eight.
    #[test]
    fn a_scenario_mission_brings_its_own_vessels() {
        let p = VesselParams::PAPER;
        let doc = crate::mission::scenario::parse_document(HARBOUR).unwrap();
        let all = peer_fleet(Some(HARBOUR), None, None, p, 1).unwrap();
        assert_eq!(all.len(), doc.vessels.len());
        for (v, d) in all.iter().zip(&doc.vessels) {
            assert_eq!(v.id, d.id);
            assert_eq!((v.start.x, v.start.y), (d.x, d.y));
        }
        let one = peer_fleet(Some(HARBOUR), None, Some("usv-12".into()), p, 1).unwrap();
        let twelfth = doc.vessels.iter().find(|v| v.id == "usv-12").unwrap();
        assert_eq!(one.len(), 1);
        assert_eq!((one[0].start.x, one[0].start.y), (twelfth.x, twelfth.y));
        // A count asked for wins; a mission document has no vessels.
        assert_eq!(
            peer_fleet(Some(HARBOUR), Some(3), None, p, 1)
                .unwrap()
                .len(),
            3
        );
        assert_eq!(
            peer_fleet(Some("{}"), None, None, p, 1).unwrap().len(),
            DEFAULT_VESSELS
        );
        assert_eq!(peer_fleet(None, None, None, p, 1).unwrap()[0].id, "usv-1");
    }
}
