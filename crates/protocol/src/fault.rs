//! A vessel in trouble on the wire: the quality of its position fix, and
//! the quarantine its refused poses put it in.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// A pose's position fix (`PoseDocument::fix`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FixDocument {
    /// A 3-D GNSS fix or better, and a healthy estimator.
    Good,
    /// No 3-D GNSS fix.
    NoFix,
    /// The estimator reports its horizontal position unusable.
    Estimator,
}

/// Why a vessel is out of the partition and held
/// (`VesselStatusDocument::quarantine`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct QuarantineDocument {
    /// `not_finite`, `out_of_range`, `time_backwards`, `outside_region`,
    /// `too_fast`, `jump` or `fix`: the latest refusal's; or
    /// `unknown_mission`, a vessel following a mission this coordinator
    /// does not hold (held until an operator changes the mission).
    pub code: String,
    /// The latest refusal, in words.
    pub reason: String,
    /// Mission time it began [s].
    pub since: f64,
    /// Poses refused since.
    pub refused: u64,
}
