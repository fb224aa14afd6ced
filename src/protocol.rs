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
