//! The mission layer's one error: a scenario document's rejection, or a
//! change that cannot apply. Messages start with the path of the field at
//! fault; codes are stable and shared with the CLI's and the HTTP API's
//! `{"error": {"code", "message"}}`.

use super::scenario::ScenarioError;
use seacover_protocol::ErrorCode;

/// Why a mission, or a change to it, was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MissionError {
    /// A document that is malformed, invalid or unsupported, as `evaluate`
    /// would reject it.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// A value out of range or inconsistent with the rest of the mission.
    #[error("{0}")]
    Invalid(String),
    /// The change names something the mission does not have.
    #[error("{0}")]
    NotFound(String),
    /// The change would make two things of one name.
    #[error("{0}")]
    Conflict(String),
}

impl MissionError {
    /// Stable machine-readable code.
    pub fn code(&self) -> ErrorCode {
        match self {
            MissionError::Scenario(e) => e.code(),
            MissionError::Invalid(_) => ErrorCode::Invalid,
            MissionError::NotFound(_) => ErrorCode::NotFound,
            MissionError::Conflict(_) => ErrorCode::Conflict,
        }
    }
}
