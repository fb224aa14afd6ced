//! Measurements of the risk field and the belief learned from them
//! (docs/learning.md): what a sensor posts, what the coordinator answers,
//! and the density the fleet covers.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::RiskDocument;

/// One measurement of the risk field.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SampleDocument {
    /// The vessel (or sensor) that measured it: its samples are judged,
    /// rate-limited and counted together.
    pub vessel: String,
    /// Mission time it was taken [s].
    pub t: f64,
    /// Where, in the mission's plane [m].
    pub x: f64,
    pub y: f64,
    /// The value measured, in the risk density's units.
    pub value: f64,
    /// Its standard deviation σ > 0, in the same units.
    pub sd: f64,
}

/// A batch of samples (`POST /api/v1/samples`), at most 1000.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SamplesDocument {
    pub samples: Vec<SampleDocument>,
}

/// What became of a batch: each sample is taken or refused on its own.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct SamplesAnswerDocument {
    /// Samples taken into the learner.
    pub accepted: u64,
    /// The refused ones, by their index in the batch.
    pub refused: Vec<SampleRefusalDocument>,
}

/// A refused sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct SampleRefusalDocument {
    /// Its index in the batch.
    pub index: u64,
    /// `invalid` (not finite, out of range, a bad id), `outside_region`,
    /// `stale`, `future` or `flood` (its vessel over its rate).
    pub code: String,
    /// In words.
    pub reason: String,
}

/// The density the fleet covers (`GET /api/v1/risk`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct BeliefDocument {
    /// `mission`: the mission's own risk (learning off, or nothing fitted
    /// yet); `learned`: the belief fitted to the samples.
    pub source: String,
    /// The density: a base plus Gaussians, as a mission's risk.
    pub risk: RiskDocument,
    /// Samples held by the learner.
    pub samples: u64,
    /// Fits made so far.
    pub fits: u64,
    /// Mission time of the samples the newest fit saw [s].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fitted_at: Option<f64>,
    /// The optimism this density was fitted with: posterior standard
    /// deviations added (0: the mean), fading as the samples age.
    pub kappa: f64,
    /// Whether the coordinator learns at all (`[learning]`).
    #[serde(default)]
    pub learning: bool,
    /// The newest fit's uncertainty, when there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<UncertaintyDocument>,
}

/// The posterior standard deviation of the mean belief's Φ, on a grid of
/// square cells over the region's bounding box (docs/learning.md): where
/// the fleet has measured, small; where it has not, the prior's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema, JsonSchema)]
pub struct UncertaintyDocument {
    /// The south-west corner of the grid [m].
    pub x0: f64,
    pub y0: f64,
    /// A cell's side [m].
    pub step: f64,
    /// Cells east and north.
    pub nx: u32,
    pub ny: u32,
    /// σ at each cell's centre, row by row from the south, each row from
    /// the west, in the density's units (`nx · ny` values).
    pub sd: Vec<f64>,
}
