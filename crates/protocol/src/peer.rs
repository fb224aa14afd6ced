//! The wire of a fleet without a coordinator (docs/peer.md): what the vessels of
//! a peer fleet, and a coordinator that joins it, put on Eclipse Zenoh.
//! Shapes only; the CBOR encoding and every value rule live in
//! `agent::peer::wire`.
//!
//! Keys, `<fleet>` the fleet's name:
//! - `seacover/<fleet>/beacon/<id>`: a [`BeaconDocument`] as a CBOR map;
//! - `seacover/<fleet>/alive/<id>`: a liveliness token per running vessel;
//! - `seacover/<fleet>/mission`: a [`PeerMissionDocument`] as JSON;
//! - `seacover/<fleet>/status/<id>`: a [`PeerStatusDocument`] as JSON,
//!   answered to queries (what a vessel hears and what it refused).

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::MissionDocument;

/// One vessel's beacon, 5 times a second: a CBOR map (RFC 8949) with
/// exactly these keys, in this order. Floats are sent in the shortest
/// CBOR float that holds them to the precision given per field, so a
/// beacon is at most 96 bytes for an id of up to 7 characters and a
/// revision up to 255, or up to 6 characters and revisions up to 65 535
/// (a peer node refuses longer ids).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BeaconDocument {
    /// The vessel's id (`[A-Za-z0-9_.-]{1,7}` in a peer fleet, so that the
    /// beacon stays within 96 bytes).
    pub id: String,
    /// Counts the vessel's beacons, modulo 256 (at most 2 bytes): a
    /// listener can count lost beacons over any gap shorter than 51 s.
    pub seq: u8,
    /// The sender's UTC time when it sent the beacon [s since 1970].
    pub t: f64,
    /// Position in the mission's local plane [m] (to ~4 mm at 50 km: a
    /// 32-bit float).
    pub x: f64,
    pub y: f64,
    /// Heading [rad] (to ~2 mrad: a 16-bit float).
    pub psi: f64,
    /// Surge, sway [m/s] and yaw rate [rad/s] (16-bit floats: ~1 mm/s at
    /// 1 m/s).
    pub u: f64,
    pub v: f64,
    pub r: f64,
    /// The vessel's actuator: f(q) = k exp(−β ‖q − p‖²) (within 0.1 %).
    pub k: f64,
    pub beta: f64,
    /// The mission revision the vessel works on.
    pub rev: u32,
    /// Whether seacover steers the vessel (false: its operator has it, or
    /// it holds station for want of its mission or its autopilot).
    pub controlled: bool,
}

impl BeaconDocument {
    /// The pose the beacon tells, as a linked vessel reports one (`t` the
    /// sender's clock; no telemetry or fix travels in a beacon).
    pub fn pose(&self) -> crate::PoseDocument {
        crate::PoseDocument {
            t: self.t,
            x: self.x,
            y: self.y,
            psi: self.psi,
            u: self.u,
            v: self.v,
            r: self.r,
            controlled: Some(self.controlled),
            telemetry: None,
            fix: None,
        }
    }
}

/// `seacover/<fleet>/mission`: the mission document (as `GET
/// /api/v1/mission`) with its revision. Every member keeps the highest
/// valid revision it has seen, answers queries with it, and refuses (and
/// counts) an invalid one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PeerMissionDocument {
    /// Higher replaces lower; `--mission FILE` seeds revision 0.
    pub revision: u32,
    #[serde(flatten)]
    pub mission: MissionDocument,
    /// Who made this revision: the program, how, and on which host
    /// (`seacover serve --peer on HOST: PUT /api/v1/mission/region`).
    /// Absent from members that predate it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by: Option<String>,
    /// When it was made, UTC (RFC 3339).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at: Option<String>,
}

/// `seacover/<fleet>/status/<id>`: what one member hears and what it
/// refused, for dashboards and tests.
/// What a group covers while it follows a split's plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SplitWater {
    Region,
    Own,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PeerStatusDocument {
    pub id: String,
    /// The mission revision it works on (`null` before it has one).
    pub revision: Option<u32>,
    /// Whether it steers its vessel now.
    pub controlled: bool,
    /// Neighbours in its partition now (heard within `stale_after`).
    pub neighbours: usize,
    /// When `neighbours` last changed: UTC, s since 1970 (`null` before it
    /// ever did).
    #[serde(default)]
    pub partition_since: Option<f64>,
    /// Each vessel it has heard: the age of its newest beacon [s].
    pub heard: BTreeMap<String, f64>,
    /// Inputs it refused, by reason (`undecodable`, `oversized`,
    /// `out_of_range`, `id_conflict`, `other_fleet`, `mission_invalid`,
    /// `mission_older`), and beacons it judged implausible, by the judge's
    /// reason (`outside_region`, `too_fast`, `jump`, `time_backwards`).
    pub refused: BTreeMap<String, u64>,
    /// Vessels it keeps clear of as traffic but does not believe (their
    /// beacons failed the plausibility rules), and why.
    #[serde(default)]
    pub quarantined: BTreeMap<String, String>,
    /// Beacons it received in all.
    pub received: u64,
    /// While it follows a split's plan (the fleet cut in two, docs/peer.md
    /// "What each loss does"): the other group's ids; `null` otherwise.
    #[serde(default)]
    pub split: Option<Vec<String>>,
    /// What its group covers while it follows a split's plan: `region`
    /// (the whole region, the other group's water traded by the plan's
    /// ways) or `own` (only its own water, the other group held where it
    /// fell silent: the ways to cover the region were not clear); `null`
    /// otherwise.
    #[serde(default)]
    pub split_water: Option<SplitWater>,
    /// It hears no other vessel of the fleet and holds station (without
    /// `--alone`).
    #[serde(default)]
    pub alone: bool,
    /// What it learned of the risk field, when its fleet learns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub learning: Option<PeerLearningDocument>,
    /// How long its loop's recent steps took (`null` before its first
    /// step with a mission).
    #[serde(default)]
    pub step_time: Option<StepTimeDocument>,
}

/// The wall time of a vessel's recent steps on board (its cell, centroid,
/// safety filter and controller; docs/peer.md, "A hundred vessels").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StepTimeDocument {
    /// Steps measured: the newest, at most 100.
    pub steps: u32,
    /// Their median [ms].
    pub median_ms: f64,
    /// The longest of them [ms].
    pub max_ms: f64,
}

/// A peer vessel's learner (docs/learning.md, "In a peer fleet").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PeerLearningDocument {
    /// Samples it holds, from every source.
    pub samples: u64,
    /// Sources (vessels) it holds samples of.
    pub sources: u64,
    /// Fits made so far.
    pub fits: u64,
    /// A digest of the sample set the newest fit saw (hex): two vessels
    /// that show the same digest hold the same belief, bit for bit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub digest: Option<String>,
    /// How many samples the newest fit saw.
    pub fitted: u64,
    /// The newest fit saw the samples taken up to this time (UTC, s since
    /// 1970): the end of its epoch, the same for every member.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until: Option<f64>,
    /// The belief it covers; only when the status query asks for it
    /// (`status/<id>?belief`), as it can be tens of kilobytes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub belief: Option<crate::RiskDocument>,
}

/// `seacover/<fleet>/sample/<id>`: one measurement of the risk field by
/// vessel `id`, as a CBOR map; its `n` counts that vessel's samples from 0,
/// so a listener sees what it missed and asks `seacover/<fleet>/samples/<id>?from=N`
/// (answered, by any member that holds them, with a CBOR array of these).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PeerSampleDocument {
    pub id: String,
    /// The vessel's sample number, from 0.
    pub n: u32,
    /// When it was taken: the sender's UTC time [s since 1970].
    pub t: f64,
    /// Where, in the mission's local plane [m] (32-bit floats on the wire).
    pub x: f64,
    pub y: f64,
    /// The value measured, and its standard deviation σ > 0 (32-bit).
    pub value: f64,
    pub sd: f64,
}
