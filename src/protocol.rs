//! Serde types of everything that crosses the wire or the command line
//! (SPEC §3), and nothing else: no validation, no behaviour. Validation lives in
//! [`crate::scenario`], so the same document is checked the same way by the CLI
//! and by the server.
//!
//! The types also derive their schemas: `utoipa::ToSchema` for the OpenAPI
//! document (`api/openapi.json`) and `schemars::JsonSchema` for the vessel
//! link's JSON Schema (`api/vessel-link.schema.json`); both read the serde
//! attributes, so the schemas follow the JSON that serde accepts and emits.
//! Schemas describe shapes only: value rules (ids matching
//! `[A-Za-z0-9_.-]{1,64}`, σ > 0, simple polygons, …) are checked by
//! [`crate::scenario`] and answered with `invalid`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// `[x, y]` in metres.
pub type XY = [f64; 2];

/// A scenario document (`examples/*.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct ScenarioDocument {
    /// A label; ignored by the engine.
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct RegionDocument {
    /// Outer ring `[[x, y], …]` in metres, without the closing vertex.
    #[schema(schema_with = schema::region_polygon)]
    pub polygon: Vec<XY>,
    /// Islands: rings strictly inside the polygon and disjoint.
    #[serde(default)]
    #[schema(schema_with = schema::region_holes)]
    pub holes: Vec<Vec<XY>>,
}

/// Risk density: base φ0 plus Gaussian objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct RiskDocument {
    /// φ0 ≥ 0, the density everywhere in the region.
    pub base: f64,
    #[serde(default)]
    pub objects: Vec<RiskObjectDocument>,
}

/// One Gaussian risk object: α exp(−‖q − (x, y)‖² / 2σ²).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct RiskObjectDocument {
    /// `[A-Za-z0-9_.-]{1,64}`; the server assigns one when it is omitted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    pub x: f64,
    pub y: f64,
    pub alpha: f64,
    /// Width σ > 0 [m].
    pub sigma: f64,
}

/// One vessel of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct VesselDocument {
    /// `[A-Za-z0-9_.-]{1,64}`, unique in the document.
    pub id: String,
    pub x: f64,
    pub y: f64,
    /// Heading [rad].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub psi: Option<f64>,
    /// Actuator strength; default 0.5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k: Option<f64>,
    /// Actuator decay [1/m²]; default 0.001, shared by every vessel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta: Option<f64>,
}

/// Result of `evaluate`: cells in the order of the request's vessels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct EvaluationDocument {
    /// The coverage metric H(P) = Σ M_i.
    #[serde(rename = "H")]
    pub h: f64,
    pub cells: Vec<CellDocument>,
}

/// Figures of one cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct CellDocument {
    pub id: String,
    /// M_i = ∫_{V_i} f_i Φ.
    pub mass: f64,
    /// C_i; the nearest point of the region for an empty cell.
    #[schema(value_type = Vec<f64>, min_items = 2, max_items = 2)]
    pub centroid: XY,
    /// [m²].
    pub area: f64,
    /// Outer ring of the cell (of its largest piece when it has several),
    /// counter-clockwise, without the closing vertex; `null` when empty.
    #[schema(schema_with = schema::cell_polygon, required = true)]
    pub polygon: Option<Vec<XY>>,
    /// Every piece with its holes, present only when the cell is not one
    /// simple polygon (several pieces, or a hole of Q inside it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pieces: Vec<RegionDocument>,
    /// ∂H/∂p_i = 2β M_i (C_i − p_i).
    #[schema(value_type = Vec<f64>, min_items = 2, max_items = 2)]
    pub gradient: XY,
}

/// `{"error": {"code", "message"}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct ErrorDocument {
    pub error: ErrorDetail,
}

/// What went wrong.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct ErrorDetail {
    /// Stable machine code: `malformed`, `invalid`, `unsupported`,
    /// `not_found`, `conflict`, `unauthorized`, `shutting_down`, ….
    pub code: String,
    /// For people; starts with the offending field when there is one.
    pub message: String,
}

/// Actuator of a vessel (f_i = k exp(−β‖q − p_i‖²)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct ActuatorDocument {
    pub k: f64,
    pub beta: f64,
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
    },
    /// A pose report.
    Pose(PoseDocument),
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
    /// Free-form; the coordinator does not interpret it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub telemetry: Option<serde_json::Value>,
}

/// Coordinator → vessel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum CoordinatorMessage {
    /// The answer to a valid hello.
    Welcome { vessel: String, tick_hz: f64 },
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
}

/// `GET /api/v1/mission`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct MissionDocument {
    pub region: RegionDocument,
    pub risk: RiskDocument,
    pub actuator: ActuatorDocument,
    pub guidance: GuidanceDocument,
    pub tick_hz: f64,
    /// Collision and shore avoidance; missions stored before it existed get
    /// the defaults.
    #[serde(default)]
    pub safety: SafetyDocument,
}

/// The safety filter of a mission (routes round islands are always used).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct SafetyDocument {
    /// Whether the barrier filter changes commands to keep the distances.
    pub filter: bool,
    /// Least distance between two vessels' centres [m].
    pub safety_distance: f64,
    /// Least distance from a vessel's centre to the region's boundary and
    /// islands [m].
    pub shore_distance: f64,
}

impl Default for SafetyDocument {
    fn default() -> Self {
        let d = crate::control::safety::SafetyParams::default();
        SafetyDocument {
            filter: d.filter,
            safety_distance: d.safety_distance,
            shore_distance: d.shore_distance,
        }
    }
}

/// Guidance mode and gains of a mission.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct GuidanceDocument {
    /// `course` or `paper`.
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct VesselStatusDocument {
    pub id: String,
    /// A link is open.
    pub connected: bool,
    /// Within the liveness timeout, hence in the partition.
    pub live: bool,
    /// The newest pose; `null` before the first.
    #[schema(required = true)]
    pub pose: Option<PoseDocument>,
    pub actuator: ActuatorDocument,
    /// The cell's outer ring; `null` when the vessel has no cell.
    #[schema(schema_with = schema::status_polygon, required = true)]
    pub polygon: Option<Vec<XY>>,
    pub mass: f64,
    /// The cell's centroid, the vessel's goal; `null` without a cell.
    #[schema(value_type = Option<Vec<f64>>, min_items = 2, max_items = 2, required = true)]
    pub centroid: Option<XY>,
    #[schema(required = true)]
    pub last_command: Option<CommandDocument>,
    /// Mission time of the newest pose [s].
    #[schema(required = true)]
    pub last_seen: Option<f64>,
}

/// `GET /api/v1/coverage`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct CoverageDocument {
    pub tick: u64,
    /// Mission time [s].
    pub time: f64,
    #[serde(rename = "H")]
    pub h: f64,
    pub cells: Vec<CellDocument>,
}

/// What the dashboard stream sends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct SnapshotDocument {
    pub tick: u64,
    /// Mission time [s].
    pub time: f64,
    #[serde(rename = "H")]
    pub h: f64,
    pub mission: MissionDocument,
    pub vessels: Vec<VesselStatusDocument>,
}

/// OpenAPI schemas of the rings. utoipa reads field types by name and cannot
/// see through the [`XY`] alias (schemars can): a lone `XY` field says
/// `value_type = Vec<f64>, min_items = 2, max_items = 2`, and lists of them
/// come from here, with their descriptions (utoipa drops a field's doc
/// comment when `schema_with` builds its schema).
mod schema {
    use utoipa::openapi::schema::{ArrayBuilder, ObjectBuilder, SchemaType, Type};
    use utoipa::openapi::{KnownFormat, SchemaFormat};

    /// `[x, y]`: exactly two numbers, as serde reads `[f64; 2]`.
    fn xy() -> ArrayBuilder {
        ArrayBuilder::new()
            .items(
                ObjectBuilder::new()
                    .schema_type(Type::Number)
                    .format(Some(SchemaFormat::KnownFormat(KnownFormat::Double))),
            )
            .min_items(Some(2))
            .max_items(Some(2))
    }

    /// `[[x, y], …]`.
    fn points() -> ArrayBuilder {
        ArrayBuilder::new().items(xy())
    }

    fn ring(description: &str) -> ArrayBuilder {
        points().description(Some(description))
    }

    fn or_null(array: ArrayBuilder) -> ArrayBuilder {
        array.schema_type(
            [Type::Array, Type::Null]
                .into_iter()
                .collect::<SchemaType>(),
        )
    }

    pub fn region_polygon() -> ArrayBuilder {
        ring("Outer ring `[[x, y], …]` in metres, without the closing vertex.")
    }

    pub fn region_holes() -> ArrayBuilder {
        ArrayBuilder::new().items(points()).description(Some(
            "Islands: rings strictly inside the polygon and disjoint.",
        ))
    }

    pub fn cell_polygon() -> ArrayBuilder {
        or_null(ring(
            "Outer ring of the cell (of its largest piece when it has several), \
             counter-clockwise, without the closing vertex; `null` when empty.",
        ))
    }

    pub fn status_polygon() -> ArrayBuilder {
        or_null(ring(
            "The cell's outer ring; `null` when the vessel has no cell.",
        ))
    }
}
