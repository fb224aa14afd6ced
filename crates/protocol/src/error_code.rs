//! The stable codes of `{"error": {"code", "message"}}` (docs/api.md), one
//! enum for every layer that refuses something: a scenario or mission
//! document (the CLI's `evaluate`, the mission model) and the HTTP API.
//! Each layer says which code its errors carry by matching on its own
//! variants; the code's text is the wire's.

use std::fmt;

/// A refusal's machine-readable code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorCode {
    /// Not UTF-8, not JSON, or not the document's shape.
    Malformed,
    /// Out-of-range or inconsistent values, bad polygons, bad ids.
    Invalid,
    /// Valid JSON the coordinator does not take (a GeoJSON geometry that is
    /// not a polygon, a CRS other than WGS84).
    Unsupported,
    /// No such id.
    NotFound,
    /// The id is taken.
    Conflict,
    /// The route does not answer the method.
    MethodNotAllowed,
    /// No valid bearer token.
    Unauthorized,
    /// The coordinator is stopping.
    ShuttingDown,
    /// The body is over the limit.
    TooLarge,
    /// Too many writes.
    RateLimited,
    /// The change could not be made durable.
    Storage,
}

impl ErrorCode {
    /// The code as the wire carries it (`not_found`, …).
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorCode::Malformed => "malformed",
            ErrorCode::Invalid => "invalid",
            ErrorCode::Unsupported => "unsupported",
            ErrorCode::NotFound => "not_found",
            ErrorCode::Conflict => "conflict",
            ErrorCode::MethodNotAllowed => "method_not_allowed",
            ErrorCode::Unauthorized => "unauthorized",
            ErrorCode::ShuttingDown => "shutting_down",
            ErrorCode::TooLarge => "too_large",
            ErrorCode::RateLimited => "rate_limited",
            ErrorCode::Storage => "storage",
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}
