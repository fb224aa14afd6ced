//! The generated API documents: the OpenAPI document of the HTTP API
//! (`api/openapi.json`, served at `GET /api/v1/openapi.json`) and the JSON
//! Schema of the vessel link's messages (`api/vessel-link.schema.json`).
//!
//! Both come from the serde types in [`crate::protocol`] (`utoipa::ToSchema`,
//! `schemars::JsonSchema`) and the `#[utoipa::path]` annotations of the
//! handlers in [`super::api`], so they cannot drift from the code unnoticed:
//! `tests/it/api_docs.rs` regenerates them and fails when the committed files
//! differ (`SEACOVER_BLESS=1 cargo test --test it api_docs::` rewrites them).
//! Endpoints whose handlers live elsewhere (`/metrics`, the WebSockets) are
//! described here by documentation-only functions.

use std::sync::OnceLock;

use axum::http::header::CONTENT_TYPE;
use axum::response::IntoResponse;
use schemars::generate::SchemaSettings;
use utoipa::openapi::security::{ApiKey, ApiKeyValue, HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::{Modify, OpenApi};

use super::api;
use super::responses::{
    Conflict, Invalid, Malformed, NotFound, NotStored, RateLimited, ShuttingDown, TooLarge,
    Unauthorized,
};
use crate::protocol::{CoordinatorMessage, ErrorDocument, SnapshotDocument, VesselMessage};

/// The OpenAPI document of the coordinator.
#[derive(OpenApi)]
#[openapi(
    info(
        title = "seacover coordinator",
        description = "Coverage control for a fleet of unmanned surface vessels: the mission \
(region, risk density), the vessels, the coverage partition and the stateless what-if \
evaluation. Errors are `{\"error\": {\"code\", \"message\"}}`; a rejected request changes \
nothing. With `--token`, every write and the vessel link need `Authorization: Bearer TOKEN`; \
reads are public. The vessel link's messages are also in `api/vessel-link.schema.json`.",
        license(name = "see the repository"),
    ),
    paths(
        api::healthz,
        metrics,
        serve,
        api::mission,
        api::put_origin,
        api::put_region,
        api::put_base,
        api::put_raster,
        api::risk_objects,
        api::post_object,
        api::get_object,
        api::put_object,
        api::delete_object,
        api::vessels,
        api::vessel,
        api::delete_vessel,
        api::coverage,
        api::coverage_geojson,
        api::evaluate,
        vessel_link,
        stream,
        api::coverage_history,
        api::post_samples,
        api::get_samples,
        api::risk,
    ),
    components(
        schemas(ErrorDocument, VesselMessage, CoordinatorMessage, SnapshotDocument),
        responses(Malformed, Unauthorized, NotFound, Conflict, TooLarge, Invalid, RateLimited, NotStored, ShuttingDown),
    ),
    modifiers(&Security),
    tags(
        (name = "system", description = "Health, metrics and this document."),
        (name = "mission", description = "The task region, the risk density and the WGS84 origin of the local plane."),
        (name = "vessels", description = "The fleet as the coordinator sees it, and the vessel link."),
        (name = "coverage", description = "The current partition and the what-if evaluation."),
        (name = "learning", description = "Samples of the risk field and the density learned from them."),
    ),
)]
pub struct ApiDoc;

/// The bearer token, and `?token=` for WebSocket clients that cannot set
/// headers (browsers).
struct Security;

impl Modify for Security {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        let components = openapi.components.get_or_insert_with(Default::default);
        components.add_security_scheme(
            "bearer",
            SecurityScheme::Http(
                HttpBuilder::new()
                    .scheme(HttpAuthScheme::Bearer)
                    .description(Some(
                        "`Authorization: Bearer TOKEN`; required only when the coordinator runs \
                         with `--token` (or `SEACOVER_TOKEN`). Compared in constant time.",
                    ))
                    .build(),
            ),
        );
        components.add_security_scheme(
            "token_query",
            SecurityScheme::ApiKey(ApiKey::Query(ApiKeyValue::with_description(
                "token",
                "The same token as a query parameter, for WebSocket clients that cannot set \
                 headers.",
            ))),
        );
    }
}

/// Prometheus metrics: vessels connected and live, the tick duration
/// histogram, skipped ticks, H, messages in, out and rejected by reason.
#[utoipa::path(
    get,
    path = "/metrics",
    tag = "system",
    responses(
        (status = 200, description = "Prometheus text exposition format 0.0.4.", body = String, content_type = "text/plain; version=0.0.4"),
    ),
)]
#[allow(dead_code)] // documentation only: the handler is `super::metrics::render`
fn metrics() {}

/// This document (the same bytes as `api/openapi.json` in the repository).
#[utoipa::path(
    get,
    path = "/api/v1/openapi.json",
    tag = "system",
    responses(
        (status = 200, description = "The OpenAPI 3.1 document.", body = Object, content_type = "application/json"),
    ),
)]
pub async fn serve() -> impl IntoResponse {
    ([(CONTENT_TYPE, "application/json")], json())
}

/// The vessel link (WebSocket). Text frames, one JSON object each: the
/// vessel sends `hello` first, then `pose` reports (`VesselMessage`); the
/// coordinator answers `welcome`, then one `command` per tick while the
/// vessel is live, and `error` for a rejected frame — fatal ones close the
/// link (`CoordinatorMessage`). Frames are at most 64 KiB; the first must
/// come within 10 s; five malformed frames close the link. A second link for
/// the same id replaces the first. JSON Schema of both directions:
/// `api/vessel-link.schema.json`.
#[utoipa::path(
    get,
    path = "/api/v1/vessels/link",
    tag = "vessels",
    params(
        ("token" = Option<String>, Query, description = "The bearer token, for clients that cannot set headers."),
    ),
    responses(
        (status = 101, description = "Switching Protocols: the link is open."),
        (status = 400, description = "Not a WebSocket upgrade request.", body = String, content_type = "text/plain"),
        (status = 401, response = Unauthorized),
        (status = 426, description = "The connection cannot be upgraded.", body = String, content_type = "text/plain"),
        (status = 429, response = RateLimited),
    ),
    security(("bearer" = []), ("token_query" = [])),
)]
#[allow(dead_code)] // documentation only: the handler is `super::ws::link`
fn vessel_link() {}

/// The dashboard stream (WebSocket, read-only): a `SnapshotDocument` per
/// text frame — the newest on connect, then every change, at most 10 per
/// second; a slow client skips to the newest.
#[utoipa::path(
    get,
    path = "/api/v1/stream",
    tag = "coverage",
    responses(
        (status = 101, description = "Switching Protocols: snapshots follow."),
        (status = 400, description = "Not a WebSocket upgrade request.", body = String, content_type = "text/plain"),
        (status = 426, description = "The connection cannot be upgraded.", body = String, content_type = "text/plain"),
    ),
)]
#[allow(dead_code)] // documentation only: the handler is `super::ws::stream`
fn stream() {}

/// `api/openapi.json`: the OpenAPI document as pretty JSON with a final
/// newline.
pub fn json() -> &'static str {
    static DOCUMENT: OnceLock<String> = OnceLock::new();
    DOCUMENT.get_or_init(|| {
        let mut text = ApiDoc::openapi()
            .to_pretty_json()
            .expect("the OpenAPI document serializes");
        text.push('\n');
        text
    })
}

/// `api/vessel-link.schema.json`: one JSON Schema (draft 2020-12) for every
/// frame of the vessel link, either direction, as pretty JSON with a final
/// newline.
pub fn vessel_link_schema() -> String {
    let mut generator = SchemaSettings::draft2020_12().into_generator();
    let from_vessel = generator.subschema_for::<VesselMessage>();
    let from_coordinator = generator.subschema_for::<CoordinatorMessage>();
    let definitions = generator.take_definitions(true);
    let schema = serde_json::json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "seacover vessel link",
        "description": "One text frame of the WebSocket `/api/v1/vessels/link`: a JSON object \
            that is either a `VesselMessage` (vessel → coordinator: `hello` first, then `pose` \
            reports) or a `CoordinatorMessage` (coordinator → vessel: `welcome`, one `command` \
            per tick, `error`). Frames are at most 64 KiB. Shapes only: value rules (ids \
            `[A-Za-z0-9_.-]{1,64}`, protocol 1, finite numbers) are answered with an `error` \
            frame.",
        "oneOf": [from_vessel, from_coordinator],
        "$defs": definitions,
    });
    let mut text = serde_json::to_string_pretty(&schema).expect("the schema serializes");
    text.push('\n');
    text
}
