//! What the HTTP edge tells the recorder: refused requests (with the peer's
//! address and the error's code) and the peer of a vessel link.

use std::net::SocketAddr;

use axum::extract::connect_info::ConnectInfo;
use axum::extract::{Request, State};
use axum::http::request::Parts;
use axum::middleware::Next;
use axum::response::Response;

use super::AppState;
use super::error::AnsweredCode;
use crate::recorder::messages::{EventKind, EventRecord};

/// The remote address of a request, when the server knows it (it is served
/// with connect info; a router used without, as in some tests, has none).
#[derive(Debug, Clone, Copy)]
pub(super) struct Peer(pub Option<SocketAddr>);

impl<S: Send + Sync> axum::extract::FromRequestParts<S> for Peer {
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Self, Self::Rejection> {
        Ok(Peer(
            parts
                .extensions
                .get::<ConnectInfo<SocketAddr>>()
                .map(|c| c.0),
        ))
    }
}

/// Records every request answered with an error status as a
/// `rejected_request` event: its code, the peer, the method and path.
pub(super) async fn record_rejections(
    State(app): State<AppState>,
    request: Request,
    next: Next,
) -> Response {
    // A refused vessel link (a wrong token, too many writes) is logged as
    // well: an operator starting an agent wants to see why it is not there.
    let link = request.uri().path() == "/api/v1/vessels/link";
    if !app.recorder.is_on() && !link {
        return next.run(request).await;
    }
    let peer = request
        .extensions()
        .get::<ConnectInfo<SocketAddr>>()
        .map(|c| c.0);
    let detail = format!("{} {}", request.method(), request.uri().path());
    let response = next.run(request).await;
    let status = response.status();
    if status.is_client_error() || status.is_server_error() {
        let code = response
            .extensions()
            .get::<AnsweredCode>()
            .map_or_else(|| status.as_u16().to_string(), |c| c.0.to_string());
        if link {
            tracing::warn!(
                peer = %peer.map_or_else(|| "?".to_string(), |p| p.to_string()),
                status = status.as_u16(),
                %code,
                "vessel link refused"
            );
        }
        if app.recorder.is_on() {
            app.recorder.event(
                EventRecord::new(app.clock.now(), EventKind::RejectedRequest)
                    .code(code)
                    .peer(peer)
                    .detail(detail),
            );
        }
    }
    response
}
