//! Serde types of everything that crosses the wire or the command line
//! (SPEC §3), and nothing else: no validation, no behaviour. Validation lives in
//! [`crate::scenario`], so the same document is checked the same way by the CLI
//! and by the server.

use serde::{Deserialize, Serialize};

/// `[x, y]` in metres.
pub type XY = [f64; 2];

/// A scenario document (`examples/*.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioDocument {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Omitted: taken from the current mission (server) or rejected (CLI).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<RegionDocument>,
    /// Omitted: taken from the current mission (server) or rejected (CLI).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub risk: Option<RiskDocument>,
    pub vessels: Vec<VesselDocument>,
}

/// The task region: a simple polygon with optional holes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegionDocument {
    pub polygon: Vec<XY>,
    #[serde(default)]
    pub holes: Vec<Vec<XY>>,
}

/// Risk density: base φ0 plus Gaussian objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RiskDocument {
    pub base: f64,
    #[serde(default)]
    pub objects: Vec<RiskObjectDocument>,
}

/// One Gaussian risk object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RiskObjectDocument {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    pub x: f64,
    pub y: f64,
    pub alpha: f64,
    pub sigma: f64,
}

/// One vessel of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VesselDocument {
    pub id: String,
    pub x: f64,
    pub y: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub psi: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta: Option<f64>,
}

/// Result of `evaluate`: cells in the order of the request's vessels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvaluationDocument {
    #[serde(rename = "H")]
    pub h: f64,
    pub cells: Vec<CellDocument>,
}

/// Figures of one cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellDocument {
    pub id: String,
    pub mass: f64,
    pub centroid: XY,
    pub area: f64,
    /// Outer ring of the cell (of its largest piece when it has several),
    /// counter-clockwise, without the closing vertex; `null` when empty.
    pub polygon: Option<Vec<XY>>,
    /// Every piece with its holes, present only when the cell is not one
    /// simple polygon (several pieces, or a hole of Q inside it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pieces: Vec<RegionDocument>,
    pub gradient: XY,
}

/// `{"error": {"code", "message"}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorDocument {
    pub error: ErrorDetail,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorDetail {
    pub code: String,
    pub message: String,
}

/// Actuator of a vessel (f_i = k exp(−β‖q − p_i‖²)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ActuatorDocument {
    pub k: f64,
    pub beta: f64,
}

/// Vessel → coordinator on `/api/v1/vessels/link`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum VesselMessage {
    Hello {
        vessel: String,
        protocol: u32,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        actuator: Option<ActuatorDocument>,
    },
    Pose(PoseDocument),
}

/// A pose report: the vessel's own clock, pose and body velocities.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseDocument {
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub psi: f64,
    pub u: f64,
    pub v: f64,
    pub r: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub telemetry: Option<serde_json::Value>,
}

/// Coordinator → vessel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum CoordinatorMessage {
    Welcome { vessel: String, tick_hz: f64 },
    Command(CommandDocument),
    Error { code: String, message: String },
}

/// One command, computed from the newest pose of every live vessel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CommandDocument {
    pub tick: u64,
    pub u_d: f64,
    pub r_d: f64,
    pub u_d_dot: f64,
    pub r_d_dot: f64,
    pub centroid: XY,
    #[serde(rename = "E")]
    pub e: f64,
    pub psi_e: f64,
}

/// `GET /api/v1/mission`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionDocument {
    pub region: RegionDocument,
    pub risk: RiskDocument,
    pub actuator: ActuatorDocument,
    pub guidance: GuidanceDocument,
    pub tick_hz: f64,
}

/// Guidance mode and gains of a mission.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GuidanceDocument {
    pub mode: String,
    pub k_r1: f64,
    pub k_r2: f64,
    pub b1: f64,
    pub k_u1: f64,
    pub k_u2: f64,
    pub b2: f64,
    pub arrival_radius: f64,
    pub max_speed: f64,
    pub max_yaw_rate: f64,
    pub filter_time: f64,
}

/// One vessel as the coordinator sees it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VesselStatusDocument {
    pub id: String,
    pub connected: bool,
    /// Within the liveness timeout, hence in the partition.
    pub live: bool,
    pub pose: Option<PoseDocument>,
    pub actuator: ActuatorDocument,
    pub polygon: Option<Vec<XY>>,
    pub mass: f64,
    pub centroid: Option<XY>,
    pub last_command: Option<CommandDocument>,
    /// Mission time of the newest pose [s].
    pub last_seen: Option<f64>,
}

/// `GET /api/v1/coverage`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoverageDocument {
    pub tick: u64,
    /// Mission time [s].
    pub time: f64,
    #[serde(rename = "H")]
    pub h: f64,
    pub cells: Vec<CellDocument>,
}

/// What the dashboard stream sends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SnapshotDocument {
    pub tick: u64,
    pub time: f64,
    #[serde(rename = "H")]
    pub h: f64,
    pub mission: MissionDocument,
    pub vessels: Vec<VesselStatusDocument>,
}
