//! Serde types of everything that crosses the wire or the command line
//! (docs/api.md), and nothing else: no validation, no behaviour. Validation lives
//! in the mission layer above (`mission::scenario`), so the same document is
//! checked the same way by the CLI and by the server.
//!
//! The types also derive their schemas: `utoipa::ToSchema` for the OpenAPI
//! document (`api/openapi.json`) and `schemars::JsonSchema` for the vessel
//! link's JSON Schema (`api/vessel-link.schema.json`); both read the serde
//! attributes, so the schemas follow the JSON that serde accepts and emits.
//! Schemas describe shapes only: value rules (ids matching
//! `[A-Za-z0-9_.-]{1,64}`, σ > 0, simple polygons, …) are checked by
//! `mission::scenario` and answered with `invalid`.

mod cell;
mod error_code;
mod fault;
mod json_error;
mod link;
pub mod peer;
mod sample;
mod schema;

pub use cell::{CellDocument, EdgeDocument, EvaluationDocument};
pub use error_code::ErrorCode;
pub use fault::{FixDocument, QuarantineDocument};
pub use json_error::json_error;
pub use link::{
    AgilityDocument, CommandDocument, CoordinatorMessage, LinkSampleDocument, PoseDocument,
    VesselMessage,
};
pub use sample::{
    BeliefDocument, SampleDocument, SampleRefusalDocument, SamplesAnswerDocument, SamplesDocument,
    UncertaintyDocument,
};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// `[x, y]` in metres.
pub type XY = [f64; 2];

/// A scenario document (`examples/*.json`), as `seacover evaluate` and
/// `POST /api/v1/coverage/evaluate` read it. With an origin, its region may
/// be GeoJSON and its risk objects and vessels may be placed by `lat` and
/// `lon` instead of `x` and `y`, which are placed in the local plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ScenarioDocument {
    /// A label; ignored by the engine.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The WGS84 origin of the document's local plane (East-North-Up: x
    /// east, y north). Omitted: the server's mission origin, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<OriginDocument>,
    /// Omitted: taken from the current mission (server) or rejected (CLI).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<RegionInput>,
    /// Omitted: taken from the current mission (server) or rejected (CLI).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub risk: Option<RiskInput>,
    /// The field simulated vessels measure, in the shape of `risk`: read
    /// only by `seacover sim`, which never gives it to the fleet, only its
    /// samples (docs/learning.md). `risk` is then the fleet's prior.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<RiskInput>,
    pub vessels: Vec<VesselInput>,
}

/// A geographic origin, WGS84 degrees: the mission's local plane is the
/// East-North-Up plane tangent to the ellipsoid there (x east, y north, m).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OriginDocument {
    /// Latitude [deg], |lat| < 90.
    pub lat: f64,
    /// Longitude [deg], |lon| ≤ 180.
    pub lon: f64,
}

/// The task region: a simple polygon with optional holes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
// No `deny_unknown_fields`: a region object with both `polygon` and a
// GeoJSON `type` must match both forms of `RegionInput`'s schema, so that
// its `oneOf` refuses it as serde does (`choose::geojson`).
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
#[serde(deny_unknown_fields)]
pub struct RiskDocument {
    /// φ0 ≥ 0, the density everywhere in the region.
    pub base: f64,
    #[serde(default)]
    pub objects: Vec<RiskObjectDocument>,
}

/// One Gaussian risk object: α exp(−‖q − (x, y)‖² / 2σ²).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(deny_unknown_fields)]
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
#[serde(deny_unknown_fields)]
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
    /// Actuator decay [1/m²]; default 0.001. Vessels with different β
    /// have cells with curved edges (`edges` in the evaluation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta: Option<f64>,
}

/// A region as a client may give it: in the local plane, or as GeoJSON
/// when there is an origin to place it.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema, JsonSchema)]
#[serde(untagged)]
pub enum RegionInput {
    Local(RegionDocument),
    GeoJson(GeoJsonRegion),
}

/// GeoJSON (RFC 7946) for a region: a `Polygon`, or a `MultiPolygon` of
/// one polygon, as a geometry, a `Feature` or a `FeatureCollection` of one
/// `Feature`. Positions are `[lon, lat]` in WGS84 degrees (a third number,
/// an altitude, is ignored); rings are closed; the first ring is the
/// region's outline and the others are islands; either orientation.
/// Needs an origin. Parsed by the `geojson` crate; which geometry it is,
/// and its rings, are checked when it is placed (`invalid`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct GeoJsonRegion(pub geojson::GeoJson);

/// A risk object as a client may give it: at `x`, `y`, or at `lat`, `lon`
/// when there is an origin; stored and answered with `x`, `y`.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema, JsonSchema)]
#[serde(untagged)]
pub enum RiskObjectInput {
    Local(RiskObjectDocument),
    Geo(GeoRiskObjectDocument),
}

/// A risk object placed in WGS84 degrees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GeoRiskObjectDocument {
    /// `[A-Za-z0-9_.-]{1,64}`; the server assigns one when it is omitted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    /// Latitude [deg].
    pub lat: f64,
    /// Longitude [deg].
    pub lon: f64,
    pub alpha: f64,
    /// Width σ > 0 [m].
    pub sigma: f64,
}

/// A scenario's risk density, its objects placed either way.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RiskInput {
    /// φ0 ≥ 0, the density everywhere in the region.
    pub base: f64,
    #[serde(default)]
    pub objects: Vec<RiskObjectInput>,
}

/// A scenario's vessel at `x`, `y`, or at `lat`, `lon` when there is an
/// origin.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema, JsonSchema)]
#[serde(untagged)]
pub enum VesselInput {
    Local(VesselDocument),
    Geo(GeoVesselDocument),
}

/// A scenario's vessel placed in WGS84 degrees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GeoVesselDocument {
    /// `[A-Za-z0-9_.-]{1,64}`, unique in the document.
    pub id: String,
    /// Latitude [deg].
    pub lat: f64,
    /// Longitude [deg].
    pub lon: f64,
    /// Heading [rad], counter-clockwise from east like every heading of
    /// the local plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub psi: Option<f64>,
    /// Actuator strength; default 0.5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k: Option<f64>,
    /// Actuator decay [1/m²]; default 0.001. Vessels with different β
    /// have cells with curved edges (`edges` in the evaluation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta: Option<f64>,
}

impl From<RegionDocument> for RegionInput {
    fn from(doc: RegionDocument) -> Self {
        RegionInput::Local(doc)
    }
}

impl From<RiskObjectDocument> for RiskObjectInput {
    fn from(doc: RiskObjectDocument) -> Self {
        RiskObjectInput::Local(doc)
    }
}

impl From<RiskDocument> for RiskInput {
    fn from(doc: RiskDocument) -> Self {
        RiskInput {
            base: doc.base,
            objects: doc.objects.into_iter().map(Into::into).collect(),
        }
    }
}

/// Which form an input object takes is decided by its keys, so that a
/// mistake is reported against the form the client meant (`missing field
/// `lon``) rather than as "no variant matched", and so that what serde
/// accepts is what the schemas' `oneOf` accepts: an object with both
/// complete positions, or both a region's `polygon` and a GeoJSON `type`,
/// is refused; one complete position decides; an incomplete one is read
/// as the form whose keys it has.
mod choose {
    use serde::de::{DeserializeOwned, Error};
    use serde_json::{Map, Value};

    fn has(map: &Map<String, Value>, key: &str) -> bool {
        map.contains_key(key)
    }

    fn parse<T: DeserializeOwned, E: Error>(value: Value) -> Result<T, E> {
        serde_json::from_value(value).map_err(E::custom)
    }

    /// `Ok(true)` for the geographic form (`lat`, `lon`), `Ok(false)` for
    /// the local one (`x`, `y`).
    pub(crate) fn geographic<E: Error>(value: &Value) -> Result<bool, E> {
        let Value::Object(map) = value else {
            return Ok(false);
        };
        let local = has(map, "x") && has(map, "y");
        let geo = has(map, "lat") && has(map, "lon");
        if local && geo {
            return Err(E::custom(
                "give the position as x and y or as lat and lon, not both",
            ));
        }
        Ok(geo || (!local && (has(map, "lat") || has(map, "lon"))))
    }

    /// A vessel's members of either form, read in one pass: a fleet's
    /// vessels are most of a large document, and going through a `Value`
    /// (a map and a string per member) took most of its parsing time. The
    /// form is then chosen as [`geographic`] chooses it, and what the
    /// chosen form lacks or forbids is refused with serde's own messages.
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    pub(crate) struct VesselKeys {
        id: Option<String>,
        x: Option<f64>,
        y: Option<f64>,
        lat: Option<f64>,
        lon: Option<f64>,
        psi: Option<f64>,
        k: Option<f64>,
        beta: Option<f64>,
    }

    const LOCAL: &[&str] = &["id", "x", "y", "psi", "k", "beta"];
    const GEO: &[&str] = &["id", "lat", "lon", "psi", "k", "beta"];

    impl VesselKeys {
        pub(crate) fn into_input<E: Error>(self) -> Result<super::VesselInput, E> {
            let local = self.x.is_some() && self.y.is_some();
            let geo = self.lat.is_some() && self.lon.is_some();
            if local && geo {
                return Err(E::custom(
                    "give the position as x and y or as lat and lon, not both",
                ));
            }
            let geo = geo || (!local && (self.lat.is_some() || self.lon.is_some()));
            let (first, second, other, names) = if geo {
                (
                    self.lat,
                    self.lon,
                    [("x", self.x), ("y", self.y)],
                    ["lat", "lon"],
                )
            } else {
                (
                    self.x,
                    self.y,
                    [("lat", self.lat), ("lon", self.lon)],
                    ["x", "y"],
                )
            };
            if let Some((key, _)) = other.iter().find(|(_, v)| v.is_some()) {
                return Err(E::unknown_field(key, if geo { GEO } else { LOCAL }));
            }
            let id = self.id.ok_or_else(|| E::missing_field("id"))?;
            let first = first.ok_or_else(|| E::missing_field(names[0]))?;
            let second = second.ok_or_else(|| E::missing_field(names[1]))?;
            let (psi, k, beta) = (self.psi, self.k, self.beta);
            Ok(if geo {
                super::VesselInput::Geo(super::GeoVesselDocument {
                    id,
                    lat: first,
                    lon: second,
                    psi,
                    k,
                    beta,
                })
            } else {
                super::VesselInput::Local(super::VesselDocument {
                    id,
                    x: first,
                    y: second,
                    psi,
                    k,
                    beta,
                })
            })
        }
    }

    /// `Ok(true)` for GeoJSON (a `type` member).
    pub(crate) fn geojson<E: Error>(value: &Value) -> Result<bool, E> {
        let Value::Object(map) = value else {
            return Ok(false);
        };
        if has(map, "type") && has(map, "polygon") {
            return Err(E::custom(
                "give the region as {polygon, holes} or as GeoJSON (with a type), not both",
            ));
        }
        Ok(has(map, "type"))
    }

    pub(crate) fn either<L: DeserializeOwned, G: DeserializeOwned, T, E: Error>(
        value: Value,
        second: bool,
        local: impl FnOnce(L) -> T,
        geo: impl FnOnce(G) -> T,
    ) -> Result<T, E> {
        if second {
            parse(value).map(geo)
        } else {
            parse(value).map(local)
        }
    }
}

impl<'de> Deserialize<'de> for RegionInput {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let value = serde_json::Value::deserialize(d)?;
        let geojson = choose::geojson(&value)?;
        choose::either(value, geojson, RegionInput::Local, RegionInput::GeoJson)
    }
}

impl<'de> Deserialize<'de> for RiskObjectInput {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let value = serde_json::Value::deserialize(d)?;
        let geo = choose::geographic(&value)?;
        choose::either(value, geo, RiskObjectInput::Local, RiskObjectInput::Geo)
    }
}

impl<'de> Deserialize<'de> for VesselInput {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        choose::VesselKeys::deserialize(d)?.into_input()
    }
}

/// The GeoJSON objects the `geojson` crate reads, by their members: the
/// schema lets through what serde lets through, and which of them makes a
/// region is checked when it is placed.
const GEOJSON_GEOMETRIES: [&str; 6] = [
    "Point",
    "MultiPoint",
    "LineString",
    "MultiLineString",
    "Polygon",
    "MultiPolygon",
];

const GEOJSON_REGION: &str = "GeoJSON (RFC 7946) for a region: a `Polygon`, or a \
`MultiPolygon` of one polygon, as a geometry, a `Feature` or a `FeatureCollection` of one \
`Feature`. Positions are `[lon, lat]` in WGS84 degrees; rings are closed; the first ring is \
the outline and the others are islands; either orientation. Needs an origin (the \
mission's, or the scenario's `origin`). Other GeoJSON parses, and is refused as `invalid`.";

impl utoipa::PartialSchema for GeoJsonRegion {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::schema::{ArrayBuilder, ObjectBuilder, OneOfBuilder, Type};
        // One GeoJSON object type: `type` among `types`, with `member`
        // (an array) required, when there is one.
        let object = |types: &[&'static str], member: Option<&str>| {
            let mut o = ObjectBuilder::new().schema_type(Type::Object).property(
                "type",
                ObjectBuilder::new()
                    .schema_type(Type::String)
                    .enum_values(Some(types.iter().copied())),
            );
            o = o.required("type");
            if let Some(member) = member {
                o = o.property(member, ArrayBuilder::new()).required(member);
            }
            o
        };
        OneOfBuilder::new()
            .description(Some(GEOJSON_REGION))
            .item(object(&GEOJSON_GEOMETRIES, Some("coordinates")))
            .item(object(&["GeometryCollection"], Some("geometries")))
            .item(
                object(&["Feature"], None).property(
                    "geometry",
                    ObjectBuilder::new().schema_type(
                        [Type::Object, Type::Null]
                            .into_iter()
                            .collect::<utoipa::openapi::schema::SchemaType>(),
                    ),
                ),
            )
            .item(object(&["FeatureCollection"], Some("features")))
            .into()
    }
}

impl ToSchema for GeoJsonRegion {}

impl JsonSchema for GeoJsonRegion {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "GeoJsonRegion".into()
    }

    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": GEOJSON_REGION,
            "oneOf": [
                {"type": "object", "required": ["type", "coordinates"], "properties": {
                    "type": {"type": "string", "enum": GEOJSON_GEOMETRIES},
                    "coordinates": {"type": "array"}}},
                {"type": "object", "required": ["type", "geometries"], "properties": {
                    "type": {"type": "string", "enum": ["GeometryCollection"]},
                    "geometries": {"type": "array"}}},
                {"type": "object", "required": ["type"], "properties": {
                    "type": {"type": "string", "enum": ["Feature"]},
                    "geometry": {"type": ["object", "null"]}}},
                {"type": "object", "required": ["type", "features"], "properties": {
                    "type": {"type": "string", "enum": ["FeatureCollection"]},
                    "features": {"type": "array"}}},
            ],
        })
    }
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

/// `GET /api/v1/mission`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct MissionDocument {
    /// The WGS84 origin of the local plane; `null` when the mission is not
    /// geo-referenced.
    #[serde(default)]
    #[schema(required = true)]
    pub origin: Option<OriginDocument>,
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
        let d = seacover_engine::control::safety::SafetyParams::default();
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
    /// Largest rate of change of the `course` mode's yaw-rate command
    /// [rad/s²]; 2.0 when absent.
    #[serde(default = "default_yaw_accel")]
    #[schema(default = default_yaw_accel)]
    pub yaw_accel: f64,
    /// Largest rate of change of the `course` mode's surge command beyond
    /// what the turning bow asks for [m/s²]; 0.75 when absent.
    #[serde(default = "default_surge_accel")]
    #[schema(default = default_surge_accel)]
    pub surge_accel: f64,
    /// Within this distance of its settled goal a `course` vessel stops
    /// turning and keeps station, until twice as far [m]; 0 never; 0.2
    /// when absent (docs/reproducing-the-paper.md, "Quiet arrival").
    #[serde(default = "default_hold_radius")]
    #[schema(default = default_hold_radius)]
    pub hold_radius: f64,
}

fn default_hold_radius() -> f64 {
    seacover_engine::control::guidance::GuidanceGains::default().hold_radius
}

fn default_yaw_accel() -> f64 {
    seacover_engine::control::guidance::GuidanceGains::default().yaw_accel
}

fn default_surge_accel() -> f64 {
    seacover_engine::control::guidance::GuidanceGains::default().surge_accel
}

/// One vessel as the coordinator sees it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct VesselStatusDocument {
    pub id: String,
    /// A link is open.
    pub connected: bool,
    /// Within the liveness timeout, hence in the partition.
    pub live: bool,
    /// Following the coordinator's commands (the newest pose's
    /// `controlled`, `true` when it has none); `false` while an operator
    /// has taken the vessel over.
    pub controlled: bool,
    /// The newest pose; `null` before the first.
    #[schema(required = true)]
    pub pose: Option<PoseDocument>,
    pub actuator: ActuatorDocument,
    /// The cell's outer ring; `null` when the vessel has no cell.
    #[schema(schema_with = schema::status_polygon, required = true)]
    pub polygon: Option<Vec<XY>>,
    /// The cell's exact boundary when it has an arc, as
    /// [`CellDocument::edges`]; absent otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub edges: Vec<Vec<EdgeDocument>>,
    pub mass: f64,
    /// The cell's centroid, the vessel's goal; `null` without a cell.
    #[schema(value_type = Option<Vec<f64>>, min_items = 2, max_items = 2, required = true)]
    pub centroid: Option<XY>,
    #[schema(required = true)]
    pub last_command: Option<CommandDocument>,
    /// Mission time of the newest pose [s] (in a peer fleet, of the
    /// newest beacon).
    #[schema(required = true)]
    pub last_seen: Option<f64>,
    /// In a peer fleet shown by `serve --peer`: the neighbours in the
    /// vessel's own partition, as it reports them; absent for a vessel on
    /// a link.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub neighbours: Option<u32>,
    /// Present while the vessel's poses are refused: it is out of the
    /// partition and commanded to hold.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quarantine: Option<QuarantineDocument>,
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

/// The coordinator's newest state as readers get it: what the dashboard
/// stream sends and what `GET /api/v1/coverage` answers (not itself a wire
/// document).
#[derive(Debug, Clone)]
pub struct Snapshot {
    pub document: SnapshotDocument,
    pub coverage: CoverageDocument,
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

/// `PUT /api/v1/mission/risk/base` body: the new base density φ0.
#[derive(Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RiskBaseDocument {
    /// φ0 ≥ 0.
    pub value: f64,
}

/// `PUT /api/v1/mission/risk/raster`: the mission with a GeoTIFF's fit as
/// its risk, and how well that fit matches the raster (docs/rasters.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct RasterFitDocument {
    pub mission: MissionDocument,
    pub fit: FitDocument,
}

/// A raster's fit as a base plus Gaussians, and its error against the
/// raster at every pixel inside the region.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct FitDocument {
    /// The raster's coordinate reference system (`EPSG:32755`).
    pub crs: String,
    /// Its columns and rows.
    pub width: usize,
    pub height: usize,
    /// The lattice's spacing, each Gaussian's σ [m].
    pub spacing: f64,
    /// Gaussians in the lattice; the risk keeps those not negligible.
    pub lattice: usize,
    /// Pixels with data in the region's bounding box.
    pub pixels: usize,
    /// Pixels inside the region, where the error is measured.
    pub measured: usize,
    /// The raster's smallest and largest value over the measured pixels.
    pub min: f64,
    pub max: f64,
    /// RMS of fit − raster over the measured pixels, over max − min.
    pub rms: f64,
    /// Largest |fit − raster| there, over max − min.
    pub worst: f64,
}

/// `PUT /api/v1/mission/risk/raster` query.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RasterQuery {
    /// Spacing and spread of the fit's Gaussians [m]; by default 30 across
    /// the region's longer side, and at least three pixels.
    pub spacing: Option<f64>,
}

/// `GET /api/v1/coverage/history`: H(P) from the mission's first tick to
/// (about) the newest, at most 1000 samples however long the mission.
/// Every tick is kept at first; when the history is full every other
/// sample is dropped and `stride` doubles, so the samples stay about
/// `stride` ticks apart and always reach back to the start.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct CoverageHistoryDocument {
    /// Ticks between two samples kept from now on (1, 2, 4, …).
    pub stride: u64,
    /// Oldest first, `stride` ticks apart (more where ticks were skipped);
    /// the newest tick is about `stride` ticks after the last one at most.
    pub samples: Vec<CoverageSampleDocument>,
}

/// H(P) at one tick.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct CoverageSampleDocument {
    pub tick: u64,
    /// Mission time [s].
    pub time: f64,
    #[serde(rename = "H")]
    pub h: f64,
}

#[cfg(test)]
mod tests;
