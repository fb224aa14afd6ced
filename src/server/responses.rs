//! The error responses of the OpenAPI document, one component each, shared
//! by the handlers' `#[utoipa::path]` annotations ([`super::api`]) and the
//! document itself ([`super::openapi`]): every one is docs/api.md's
//! `{"error": {"code", "message"}}` ([`crate::protocol::ErrorDocument`]).

use utoipa::ToResponse;
use utoipa::openapi::{ContentBuilder, Ref, RefOr, Response, ResponseBuilder};

/// An error answer: `{"error": {"code", "message"}}`.
fn error_response(description: &str) -> RefOr<Response> {
    ResponseBuilder::new()
        .description(description)
        .content(
            "application/json",
            ContentBuilder::new()
                .schema(Some(Ref::from_schema_name("ErrorDocument")))
                .build(),
        )
        .build()
        .into()
}

/// The error responses shared by the operations; each is a component the
/// `#[utoipa::path]` annotations refer to with `response = ...`.
macro_rules! error_responses {
    ($($name:ident => $description:literal,)*) => {$(
        #[doc = $description]
        pub(super) struct $name;

        impl<'a> ToResponse<'a> for $name {
            fn response() -> (&'a str, RefOr<Response>) {
                (stringify!($name), error_response($description))
            }
        }
    )*};
}

error_responses! {
    Malformed => "`malformed`: not UTF-8, not JSON, or not the document's shape.",
    Unauthorized => "`unauthorized`: the coordinator runs with a token and the request has no valid `Authorization: Bearer TOKEN`.",
    NotFound => "`not_found`: no such id.",
    Conflict => "`conflict`: the id is taken.",
    TooLarge => "`too_large`: the body is over 1 MiB.",
    Invalid => "`invalid` (out-of-range or non-finite values, bad polygons, bad or duplicate ids, positions in WGS84 without an origin (`origin`) or beyond 50 km of it, …). The message starts with the offending field.",
    RateLimited => "`rate_limited`: too many writes; `Retry-After` says when to try again.",
    NotStored => "`storage`: the change could not be made durable and was not applied.",
    ShuttingDown => "`shutting_down`: the coordinator is stopping.",
}

/// The answers a write of the mission's documents may get besides its
/// success, declared once for every such handler's `responses(...)` (each
/// a reference to the component above).
pub(super) struct DocumentWrite;

impl utoipa::IntoResponses for DocumentWrite {
    fn responses() -> std::collections::BTreeMap<String, RefOr<Response>> {
        [
            ("400", "Malformed"),
            ("401", "Unauthorized"),
            ("413", "TooLarge"),
            ("422", "Invalid"),
            ("429", "RateLimited"),
            ("500", "NotStored"),
            ("503", "ShuttingDown"),
        ]
        .into_iter()
        .map(|(status, name)| {
            (
                status.to_string(),
                RefOr::Ref(Ref::from_response_name(name)),
            )
        })
        .collect()
    }
}
