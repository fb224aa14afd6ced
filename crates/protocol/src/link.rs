//! The vessel link's messages, both directions (docs/api.md, "The vessel
//! link"; `api/vessel-link.schema.json` is generated from them).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::{ActuatorDocument, FixDocument, XY};

/// How fast a vessel's commands may change for it to follow them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct AgilityDocument {
    /// Largest |ṙ_d| [rad/s²], > 0.
    pub yaw_accel: f64,
    /// Largest |u̇_d − v r| [m/s²], > 0: what the vessel's actuators add
    /// to the rate its surge changes at unforced while it turns (v r, the
    /// rigid-body Coriolis term, from its own poses' sway and yaw rate).
    pub surge_accel: f64,
}

/// Vessel → coordinator on `/api/v1/vessels/link`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum VesselMessage {
    /// The first frame of every link.
    Hello {
        /// The vessel's id, `[A-Za-z0-9_.-]{1,64}`.
        vessel: String,
        /// Protocol version; only 1 is spoken.
        protocol: u32,
        /// Omitted: the mission's actuator.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        actuator: Option<ActuatorDocument>,
        /// Whether the vessel can thrust astern when a command asks for a
        /// negative surge. Omitted: `true`. A vessel that cannot (an
        /// ArduPilot boat driven by velocity setpoints takes only a speed)
        /// is guided ahead only: it turns round rather than backing up.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        astern: Option<bool>,
        /// The command rates the vessel can follow. Omitted: the mission's
        /// `yaw_accel` and `surge_accel` alone; declared: its commands also
        /// keep within these. The simulated vessel declares its reference
        /// governor's share of its actuators.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        agility: Option<AgilityDocument>,
        /// The mission the vessel was following, as a coordinator named it
        /// (its welcome's or its latest `mission` message's `mission`).
        /// Omitted by a vessel that has followed none since it started.
        /// A coordinator whose mission is only its start-up default (no
        /// stored mission, no operator's change) holds a vessel that names
        /// another: a fresh shore does not re-task a running fleet.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        mission: Option<String>,
        /// The vessel holds a position by itself (an autopilot's own
        /// loiter) and may be handed its goal to hold once it is within
        /// this many metres of it [m], > 0. Omitted: the coordinator steers
        /// it to the end. Declared: station keeping starts within the
        /// larger of this and the mission's `hold_radius` (unless that is
        /// 0), and its commands say `station` while it lasts.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        station_radius: Option<f64>,
    },
    /// A pose report.
    Pose(PoseDocument),
    /// A measurement of the risk field by this vessel, taken when sent
    /// (the coordinator stamps it with its mission time; docs/learning.md).
    Sample(LinkSampleDocument),
}

/// A sample on the vessel link: where and what, the vessel being the
/// link's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct LinkSampleDocument {
    /// Where, in the mission's plane [m].
    pub x: f64,
    pub y: f64,
    /// The value measured, in the risk density's units.
    pub value: f64,
    /// Its standard deviation σ > 0, in the same units.
    pub sd: f64,
}

/// A pose report: the vessel's own clock, pose and body velocities.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct PoseDocument {
    /// The vessel's clock [s].
    pub t: f64,
    pub x: f64,
    pub y: f64,
    /// Heading [rad].
    pub psi: f64,
    /// Surge velocity [m/s].
    pub u: f64,
    /// Sway velocity [m/s].
    pub v: f64,
    /// Yaw rate [rad/s].
    pub r: f64,
    /// Whether the vessel follows the coordinator's commands: `false` when
    /// an operator has taken it over (an autopilot out of GUIDED, or
    /// disarmed). Omitted: `true`. A vessel not under control keeps its
    /// place in the partition.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controlled: Option<bool>,
    /// Free-form; the coordinator does not interpret it. The simulated
    /// vessel (`seacover agent`) sends `tau_d` and `tau_d_hat` (the
    /// disturbance and its estimate) and, each `{u, r}`, `tracking_error`
    /// (largest |u − u_ref|, |r − r_ref| at any 1 ms step since its previous
    /// pose, against the reference its controller was given) and
    /// `command_lag` (largest gap between the command line and that
    /// reference); the MAVLink bridge sends the autopilot's state.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub telemetry: Option<serde_json::Value>,
    /// The quality of the position fix, where the source reports one (the
    /// MAVLink bridge: GPS_RAW_INT's fix type and the EKF's status). A
    /// pose with a poor fix is refused and its vessel held. Omitted:
    /// unreported.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fix: Option<FixDocument>,
}

/// Coordinator → vessel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum CoordinatorMessage {
    /// The answer to a valid hello.
    Welcome {
        vessel: String,
        tick_hz: f64,
        /// The mission's name: a digest of its document, the same for the
        /// same mission on any coordinator. The vessel says it in its next
        /// hello.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        mission: Option<String>,
    },
    /// The mission changed (an operator's act): its new name, to say in
    /// the next hello instead of the welcome's.
    Mission { mission: String },
    /// One per tick per live vessel.
    Command(CommandDocument),
    /// A rejected frame; fatal ones (protocol, shutting_down, …) close the link.
    Error { code: String, message: String },
}

/// One command, computed from the newest pose of every live vessel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct CommandDocument {
    pub tick: u64,
    /// Desired surge velocity [m/s].
    pub u_d: f64,
    /// Desired yaw rate [rad/s].
    pub r_d: f64,
    pub u_d_dot: f64,
    pub r_d_dot: f64,
    /// The vessel's cell centroid, its goal.
    #[schema(value_type = Vec<f64>, min_items = 2, max_items = 2)]
    pub centroid: XY,
    /// Distance to the centroid [m].
    #[serde(rename = "E")]
    pub e: f64,
    /// Heading error towards the centroid [rad].
    pub psi_e: f64,
    /// Present when the vessel is held out of the partition (its poses
    /// are refused, or it follows another mission): why, as its status's
    /// `quarantine` says. The vessel keeps
    /// station where it is (`centroid` is its last believed position, the
    /// speeds are 0) until commands come without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hold: Option<String>,
    /// Present while the vessel keeps station on arrival: its goal has
    /// settled, it is within its hold radius, and the safety filter leaves
    /// it alone (docs/api.md, "Quiet arrival"). The point it keeps (its
    /// goal: the centroid, or the nearest point to it that keeps the
    /// mission's margin from the shore). A vessel that holds a position by
    /// itself (it declared `station_radius`) may then hold this point
    /// instead of following `u_d` and `r_d`; any other follows them as
    /// always.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vec<f64>>, min_items = 2, max_items = 2)]
    pub station: Option<XY>,
}
