//! The HTTP edge's one error type and its single `IntoResponse`:
//! `{"error": {"code", "message"}}` with the status docs/api.md assigns.

use axum::Json;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};

use super::coordinator::CoordinatorError;
use crate::coverage::InputError;
use crate::mission::MissionError;
use crate::mission::scenario::ScenarioError;
use crate::protocol::{ErrorCode, ErrorDetail, ErrorDocument};

/// Largest request body accepted; a larger one is answered `too_large`.
pub const MAX_BODY: usize = 1024 * 1024;

/// The code of an [`ApiError`](ApiError) response, left in
/// its extensions for the rejection events
/// ([`record_rejections`](super::events::record_rejections)).
#[derive(Debug, Clone, Copy)]
pub(super) struct AnsweredCode(pub ErrorCode);

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ApiError {
    #[error("{0}")]
    Malformed(String),
    #[error("{0}")]
    NotFound(String),
    #[error("{0}")]
    Invalid(String),
    #[error("{0}")]
    Unsupported(String),
    #[error("{0}")]
    Conflict(String),
    /// The route exists, but not with this method (`Allow` lists those it
    /// has).
    #[error("{0}")]
    MethodNotAllowed(String),
    #[error("a valid `Authorization: Bearer TOKEN` is required")]
    Unauthorized,
    #[error("the coordinator is shutting down")]
    ShuttingDown,
    #[error("the request body is larger than {0} bytes")]
    TooLarge(usize),
    #[error("too many writes: at most {0} per second, try again shortly")]
    RateLimited(u32),
    /// The store could not make a change durable; the change was not applied.
    #[error("the change could not be stored: {0}")]
    Storage(String),
}

impl ApiError {
    pub fn code(&self) -> ErrorCode {
        match self {
            ApiError::Malformed(_) => ErrorCode::Malformed,
            ApiError::NotFound(_) => ErrorCode::NotFound,
            ApiError::Invalid(_) => ErrorCode::Invalid,
            ApiError::Unsupported(_) => ErrorCode::Unsupported,
            ApiError::Conflict(_) => ErrorCode::Conflict,
            ApiError::MethodNotAllowed(_) => ErrorCode::MethodNotAllowed,
            ApiError::Unauthorized => ErrorCode::Unauthorized,
            ApiError::ShuttingDown => ErrorCode::ShuttingDown,
            ApiError::TooLarge(_) => ErrorCode::TooLarge,
            ApiError::RateLimited(_) => ErrorCode::RateLimited,
            ApiError::Storage(_) => ErrorCode::Storage,
        }
    }

    pub fn status(&self) -> StatusCode {
        match self {
            ApiError::Malformed(_) => StatusCode::BAD_REQUEST,
            ApiError::NotFound(_) => StatusCode::NOT_FOUND,
            ApiError::Invalid(_) | ApiError::Unsupported(_) => StatusCode::UNPROCESSABLE_ENTITY,
            ApiError::Conflict(_) => StatusCode::CONFLICT,
            ApiError::MethodNotAllowed(_) => StatusCode::METHOD_NOT_ALLOWED,
            ApiError::Unauthorized => StatusCode::UNAUTHORIZED,
            ApiError::ShuttingDown => StatusCode::SERVICE_UNAVAILABLE,
            ApiError::TooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            ApiError::RateLimited(_) => StatusCode::TOO_MANY_REQUESTS,
            ApiError::Storage(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    pub fn document(&self) -> ErrorDocument {
        ErrorDocument {
            error: ErrorDetail {
                code: self.code().as_str().to_string(),
                message: self.to_string(),
            },
        }
    }
}

impl From<ScenarioError> for ApiError {
    fn from(e: ScenarioError) -> Self {
        let message = e.to_string();
        match e {
            ScenarioError::Malformed(_) => ApiError::Malformed(message),
            ScenarioError::Input(InputError::Unsupported { .. }) => ApiError::Unsupported(message),
            ScenarioError::Input(_) => ApiError::Invalid(message),
        }
    }
}

impl From<MissionError> for ApiError {
    fn from(e: MissionError) -> Self {
        match e {
            MissionError::Scenario(e) => ApiError::from(e),
            MissionError::Invalid(m) => ApiError::Invalid(m),
            MissionError::NotFound(m) => ApiError::NotFound(m),
            MissionError::Conflict(m) => ApiError::Conflict(m),
        }
    }
}

impl From<crate::raster::RasterError> for ApiError {
    fn from(e: crate::raster::RasterError) -> Self {
        use crate::raster::RasterError as R;
        let message = crate::chain::Chain(&e).to_string();
        match e {
            // Not a GeoTIFF at all: the body is not what the route takes.
            R::Tiff { .. } | R::Io { .. } | R::NoData { .. } | R::NotGeoreferenced { .. } => {
                ApiError::Malformed(message)
            }
            R::Bands { .. } | R::Crs { .. } | R::NotNorthUp { .. } => {
                ApiError::Unsupported(message)
            }
            // The file is fine; the mission cannot place it.
            R::NoOrigin => ApiError::Conflict(message),
            R::Value { .. }
            | R::Outside { .. }
            | R::Projection { .. }
            | R::Mission { .. }
            | R::Spacing { .. } => ApiError::Invalid(message),
        }
    }
}

impl From<CoordinatorError> for ApiError {
    fn from(e: CoordinatorError) -> Self {
        let message = e.to_string();
        match e {
            CoordinatorError::Mission(e) => ApiError::from(e),
            CoordinatorError::Hello(_) => ApiError::Invalid(message),
            CoordinatorError::Full(_)
            | CoordinatorError::ReadOnly
            | CoordinatorError::NotLearning => ApiError::Conflict(message),
            CoordinatorError::NoVessel(_) => ApiError::NotFound(message),
            // The store's own words: the client learns why.
            CoordinatorError::Storage(e) => ApiError::Storage(crate::chain::Chain(&e).to_string()),
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let mut response = (self.status(), Json(self.document())).into_response();
        response.extensions_mut().insert(AnsweredCode(self.code()));
        if let ApiError::Unauthorized = self {
            // RFC 6750: the scheme a client must use.
            response.headers_mut().insert(
                axum::http::header::WWW_AUTHENTICATE,
                axum::http::HeaderValue::from_static("Bearer"),
            );
        }
        if let ApiError::RateLimited(_) = self {
            // The bucket refills one write per 1/rate s; one second is a
            // safe, simple hint.
            response.headers_mut().insert(
                axum::http::header::RETRY_AFTER,
                axum::http::HeaderValue::from_static("1"),
            );
        }
        response
    }
}

/// The answer to a path no route has: the JSON error of docs/api.md, not an empty
/// body.
pub(super) async fn not_found(uri: axum::http::Uri) -> ApiError {
    ApiError::NotFound(format!("no such path: {}", uri.path()))
}

/// The answer to a method a route does not have; the router adds `Allow`.
pub(super) async fn method_not_allowed(
    method: axum::http::Method,
    uri: axum::http::Uri,
) -> ApiError {
    ApiError::MethodNotAllowed(format!("{method} is not allowed on {}", uri.path()))
}

/// Gives the 413 that the body limit answers (plain text, from axum) the
/// JSON error shape of every other error.
pub(super) async fn json_too_large(response: Response) -> Response {
    let is_json = response
        .headers()
        .get(axum::http::header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/json"));
    if response.status() == StatusCode::PAYLOAD_TOO_LARGE && !is_json {
        return ApiError::TooLarge(MAX_BODY).into_response();
    }
    response
}
