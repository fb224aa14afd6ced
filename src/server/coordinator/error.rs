//! What the coordinator's actor answers a request it refuses. It is the
//! actor's own: the HTTP edge converts it (`From<CoordinatorError> for
//! ApiError`), and a vessel link sends its code and message as an `error`
//! frame.

use crate::mission::MissionError;
use crate::protocol::ErrorCode;

use super::super::store::StoreError;

/// Why the actor refused a request.
#[derive(Debug, thiserror::Error)]
pub enum CoordinatorError {
    /// A change the mission model refuses.
    #[error(transparent)]
    Mission(#[from] MissionError),
    /// A hello whose values are out of range (the message names the field).
    #[error("{0}")]
    Hello(String),
    /// The fleet is full.
    #[error("the mission already has {0} vessels, the most it takes")]
    Full(usize),
    /// A removal of a vessel the coordinator does not know.
    #[error("no vessel {0:?}")]
    NoVessel(String),
    /// The store could not make a change durable; it was not applied.
    #[error("the change could not be stored")]
    Storage(#[source] StoreError),
    /// A replay's read-only server takes no write and no link.
    #[error(
        "this server is a replay of a recording: it is read-only (writes and vessel links go \
         to a coordinator, `seacover serve`)"
    )]
    ReadOnly,
    /// Samples sent to a coordinator that does not learn.
    #[error(
        "this coordinator does not learn the risk map: start it with a [learning] section in \
         --config (docs/learning.md)"
    )]
    NotLearning,
}

impl CoordinatorError {
    /// The code its refusal carries on the wire.
    pub fn code(&self) -> ErrorCode {
        match self {
            CoordinatorError::Mission(e) => e.code(),
            CoordinatorError::Hello(_) => ErrorCode::Invalid,
            CoordinatorError::Full(_)
            | CoordinatorError::ReadOnly
            | CoordinatorError::NotLearning => ErrorCode::Conflict,
            CoordinatorError::NoVessel(_) => ErrorCode::NotFound,
            CoordinatorError::Storage(_) => ErrorCode::Storage,
        }
    }
}
