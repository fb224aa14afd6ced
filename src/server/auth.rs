//! Bearer tokens: with `--token` every write and every vessel link needs
//! `Authorization: Bearer TOKEN` (browsers, which cannot set headers on
//! WebSockets, may pass `?token=`). Reads stay public. Tokens are compared in
//! constant time, so response timing reveals nothing about a wrong guess.
//!
//! Writes are also rate-limited: one token bucket (governor's GCRA) shared by
//! every client, since writes are an operator's and each costs an fsync.
//! Over the limit a write is answered 429 with `Retry-After` and changes
//! nothing. Reads and vessel links are not limited here (links are bounded by
//! the vessel count, reads by the body limit and the snapshot they share).

use axum::extract::{Request, State};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use subtle::ConstantTimeEq;

use super::app::AppState;
use super::error::ApiError;

fn presented(request: &Request) -> Option<String> {
    if let Some(value) = request.headers().get(axum::http::header::AUTHORIZATION)
        && let Ok(text) = value.to_str()
        && let Some(token) = text.strip_prefix("Bearer ")
    {
        return Some(token.to_string());
    }
    request
        .uri()
        .query()?
        .split('&')
        .find_map(|pair| pair.strip_prefix("token="))
        .map(str::to_string)
}

/// Whether `given` equals `expected`, in time independent of where they differ.
pub(super) fn token_matches(expected: &str, given: &str) -> bool {
    expected.as_bytes().ct_eq(given.as_bytes()).into()
}

pub(super) async fn require_token(
    State(app): State<AppState>,
    request: Request,
    next: Next,
) -> Response {
    if let Some(expected) = &app.token {
        let ok = presented(&request).is_some_and(|given| token_matches(expected, &given));
        if !ok {
            return ApiError::Unauthorized.into_response();
        }
    }
    next.run(request).await
}

/// Spends one write from the bucket for every request that is not a GET
/// (the vessel link's upgrade is a GET).
pub(super) async fn limit_writes(
    State(app): State<AppState>,
    request: Request,
    next: Next,
) -> Response {
    if request.method() != axum::http::Method::GET && app.writes.bucket.check().is_err() {
        metrics::counter!(super::metrics::MESSAGES_REJECTED, "reason" => "rate_limited")
            .increment(1);
        return ApiError::RateLimited(app.writes.per_second).into_response();
    }
    next.run(request).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_must_match_exactly() {
        assert!(token_matches("s3cret", "s3cret"));
        assert!(!token_matches("s3cret", "s3cre"));
        assert!(!token_matches("s3cret", "s3cret!"));
        assert!(!token_matches("s3cret", ""));
    }
}
