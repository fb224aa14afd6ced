//! REST handlers. Reads come from the newest snapshot; evaluation is a
//! stateless what-if that fills in the mission's region and risk.

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use tokio::sync::oneshot;

use super::AppState;
use super::coordinator::Request;
use super::error::ApiError;
use crate::coverage::Options;
use crate::mission::scenario::{Scenario, evaluation_document, localize, parse_input};
use crate::mission::{ChangeResult, MissionChange};
use crate::protocol::{
    CoverageDocument, EvaluationDocument, MissionDocument, OriginDocument, RegionInput,
    RiskObjectDocument, RiskObjectInput, VesselStatusDocument,
};

/// Liveness: `ok` while the server answers.
#[utoipa::path(
    get,
    path = "/healthz",
    tag = "system",
    responses((status = 200, description = "The server is up.", body = String, content_type = "text/plain", example = "ok")),
)]
pub(super) async fn healthz() -> &'static str {
    "ok"
}

/// The mission: region, risk density, actuator, guidance and tick rate.
#[utoipa::path(
    get,
    path = "/api/v1/mission",
    tag = "mission",
    responses((status = 200, description = "The current mission.", body = MissionDocument)),
)]
pub(super) async fn mission(State(app): State<AppState>) -> Json<MissionDocument> {
    Json(app.snapshot.borrow().document.mission.clone())
}

/// Every risk object of the mission, with its id.
#[utoipa::path(
    get,
    path = "/api/v1/risk-objects",
    tag = "mission",
    responses((status = 200, description = "The risk objects.", body = Vec<RiskObjectDocument>)),
)]
pub(super) async fn risk_objects(State(app): State<AppState>) -> Json<Vec<RiskObjectDocument>> {
    Json(app.snapshot.borrow().document.mission.risk.objects.clone())
}

/// Every vessel the coordinator knows, connected or not.
#[utoipa::path(
    get,
    path = "/api/v1/vessels",
    tag = "vessels",
    responses((status = 200, description = "Pose, link state, cell and last command of each vessel.", body = Vec<VesselStatusDocument>)),
)]
pub(super) async fn vessels(State(app): State<AppState>) -> Json<Vec<VesselStatusDocument>> {
    Json(app.snapshot.borrow().document.vessels.clone())
}

/// One vessel.
#[utoipa::path(
    get,
    path = "/api/v1/vessels/{id}",
    tag = "vessels",
    params(("id" = String, Path, description = "The vessel's id.")),
    responses(
        (status = 200, description = "The vessel.", body = VesselStatusDocument),
        (status = 404, response = super::responses::NotFound),
    ),
)]
pub(super) async fn vessel(
    State(app): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<VesselStatusDocument>, ApiError> {
    let snap = app.snapshot.borrow().clone();
    snap.document
        .vessels
        .iter()
        .find(|v| v.id == id)
        .cloned()
        .map(Json)
        .ok_or_else(|| ApiError::NotFound(format!("no vessel {id:?}")))
}

/// Forgets a vessel; a connected one is told `removed` and may come back by
/// saying hello again.
#[utoipa::path(
    delete,
    path = "/api/v1/vessels/{id}",
    tag = "vessels",
    params(("id" = String, Path, description = "The vessel's id.")),
    responses(
        (status = 204, description = "Forgotten; its link, if any, got an `error` frame with code `removed` and was closed."),
        (status = 401, response = super::responses::Unauthorized),
        (status = 404, response = super::responses::NotFound),
        (status = 429, response = super::responses::RateLimited),
        (status = 503, response = super::responses::ShuttingDown),
    ),
    security(("bearer" = [])),
)]
pub(super) async fn delete_vessel(
    State(app): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    let (reply, answer) = oneshot::channel();
    app.requests
        .send(Request::Forget { id, reply })
        .await
        .map_err(|_| ApiError::ShuttingDown)?;
    answer.await.map_err(|_| ApiError::ShuttingDown)??;
    Ok(StatusCode::NO_CONTENT)
}

/// The partition of the newest tick: H and every live vessel's cell.
#[utoipa::path(
    get,
    path = "/api/v1/coverage",
    tag = "coverage",
    responses((status = 200, description = "Tick, mission time, H and cells.", body = CoverageDocument)),
)]
pub(super) async fn coverage(State(app): State<AppState>) -> Json<CoverageDocument> {
    Json(app.snapshot.borrow().coverage.clone())
}

/// The partition of the newest tick as GeoJSON (RFC 7946), for GIS tools.
///
/// Every cell (a `Polygon`, or a `MultiPolygon` of its pieces;
/// properties `kind` = `cell`, `id`, `mass`, `area`, `centroid` as
/// `[lon, lat]`, `E` the vessel's distance to it in metres) and every
/// vessel (a `Point`; `kind` = `vessel`, `id`, `heading_deg` clockwise from
/// north, `connected`, `live`, `controlled`). Needs the mission's origin.
#[utoipa::path(
    get,
    path = "/api/v1/coverage.geojson",
    tag = "coverage",
    responses(
        (status = 200, description = "A GeoJSON FeatureCollection: [lon, lat] positions, closed rings, exteriors counter-clockwise and holes clockwise, no `crs`.", body = Object, content_type = "application/geo+json"),
        (status = 404, description = "`not_found`: the mission has no origin to place the partition on the globe.", body = crate::protocol::ErrorDocument),
    ),
)]
pub(super) async fn coverage_geojson(State(app): State<AppState>) -> Result<Response, ApiError> {
    let snap = app.snapshot.borrow().clone();
    let frame = match snap.document.mission.origin {
        Some(origin) => crate::mission::origin_frame(origin)?,
        None => {
            return Err(ApiError::NotFound(
                "the mission has no origin, so its partition has no place on the globe: \
                 set one with PUT /api/v1/mission/origin"
                    .into(),
            ));
        }
    };
    let collection = crate::mission::georef::output::coverage(
        &frame,
        &snap.coverage.cells,
        &snap.document.vessels,
    );
    let body = serde_json::to_string(&collection).expect("GeoJSON serializes");
    Ok((
        [(axum::http::header::CONTENT_TYPE, "application/geo+json")],
        body,
    )
        .into_response())
}

/// A stateless what-if: evaluates a scenario document, taking the region
/// and the risk it omits from the current mission. Validated exactly as
/// `seacover evaluate` validates; changes nothing.
///
/// Geographic parts are placed with the document's `origin`, or else the
/// mission's; a document with an origin other than the mission's must give
/// its own region and risk, since the mission's are in the mission's plane.
#[utoipa::path(
    post,
    path = "/api/v1/coverage/evaluate",
    tag = "coverage",
    request_body = crate::protocol::ScenarioDocument,
    responses(
        (status = 200, description = "The evaluation, cells in the order of the request's vessels.", body = EvaluationDocument),
        (status = 400, response = super::responses::Malformed),
        (status = 413, response = super::responses::TooLarge),
        (status = 422, response = super::responses::Invalid),
        (status = 503, response = super::responses::ShuttingDown),
    ),
)]
pub(super) async fn evaluate(
    State(app): State<AppState>,
    body: Bytes,
) -> Result<Json<EvaluationDocument>, ApiError> {
    let text = std::str::from_utf8(&body)
        .map_err(|e| ApiError::Malformed(format!("body is not UTF-8: {e}")))?;
    let input = parse_input(text)?;
    let mission = app.snapshot.borrow().document.mission.clone();
    let elsewhere = input.origin.is_some() && input.origin != mission.origin;
    if elsewhere && (input.region.is_none() || input.risk.is_none()) {
        return Err(ApiError::Invalid(
            "origin: differs from the mission's; a document with its own origin gives its own \
             region and risk (the mission's are in the mission's plane)"
                .into(),
        ));
    }
    let mut doc = localize(&input, mission.origin).map_err(ApiError::from)?;
    doc.region.get_or_insert(mission.region);
    doc.risk.get_or_insert(mission.risk);
    // Up to 10 000 vessels: CPU work, off the async workers.
    let result = tokio::task::spawn_blocking(move || {
        let scenario = Scenario::from_document(&doc)?;
        let eval = scenario.evaluate(&Options::default());
        Ok::<_, ApiError>(evaluation_document(&scenario.region, &scenario.ids, &eval))
    })
    .await
    .map_err(|_| ApiError::ShuttingDown)??;
    Ok(Json(result))
}

fn parse<T: serde::de::DeserializeOwned>(body: &Bytes) -> Result<T, ApiError> {
    serde_json::from_slice(body).map_err(|e| ApiError::Malformed(crate::protocol::json_error(&e)))
}

/// Hands a change to the tick task and waits for its verdict.
async fn change(app: &AppState, change: MissionChange) -> Result<ChangeResult, ApiError> {
    let (reply, answer) = oneshot::channel();
    app.requests
        .send(Request::Change { change, reply })
        .await
        .map_err(|_| ApiError::ShuttingDown)?;
    Ok(answer.await.map_err(|_| ApiError::ShuttingDown)??)
}

fn respond(status: StatusCode, result: ChangeResult) -> Response {
    match result {
        ChangeResult::Mission(m) => (status, Json(m)).into_response(),
        ChangeResult::Object(o) => (status, Json(o)).into_response(),
        ChangeResult::Deleted => StatusCode::NO_CONTENT.into_response(),
    }
}

/// Sets the mission's WGS84 origin.
///
/// The mission's plane is the East-North-Up plane tangent to the WGS84
/// ellipsoid at the origin (x east, y north). The region and the risk
/// objects keep their local coordinates: moving the origin moves them on
/// the globe.
#[utoipa::path(
    put,
    path = "/api/v1/mission/origin",
    tag = "mission",
    request_body = OriginDocument,
    responses(
        (status = 200, description = "The mission with the new origin, once durable.", body = MissionDocument),
        super::responses::DocumentWrite,
    ),
    security(("bearer" = [])),
)]
pub(super) async fn put_origin(
    State(app): State<AppState>,
    body: Bytes,
) -> Result<Response, ApiError> {
    let origin: OriginDocument = parse(&body)?;
    Ok(respond(
        StatusCode::OK,
        change(&app, MissionChange::Origin(origin)).await?,
    ))
}

/// Replaces the task region.
///
/// In the local plane, or as GeoJSON (a Polygon, its islands as interior
/// rings) placed with the mission's origin.
#[utoipa::path(
    put,
    path = "/api/v1/mission/region",
    tag = "mission",
    request_body = RegionInput,
    responses(
        (status = 200, description = "The mission with the new region, once durable.", body = MissionDocument),
        super::responses::DocumentWrite,
    ),
    security(("bearer" = [])),
)]
pub(super) async fn put_region(
    State(app): State<AppState>,
    body: Bytes,
) -> Result<Response, ApiError> {
    let region: RegionInput = parse(&body)?;
    Ok(respond(
        StatusCode::OK,
        change(&app, MissionChange::Region(region)).await?,
    ))
}

/// Sets the base risk density φ0.
#[utoipa::path(
    put,
    path = "/api/v1/mission/risk/base",
    tag = "mission",
    request_body = crate::protocol::RiskBaseDocument,
    responses(
        (status = 200, description = "The mission with the new base density, once durable.", body = MissionDocument),
        super::responses::DocumentWrite,
    ),
    security(("bearer" = [])),
)]
pub(super) async fn put_base(
    State(app): State<AppState>,
    body: Bytes,
) -> Result<Response, ApiError> {
    let v: crate::protocol::RiskBaseDocument = parse(&body)?;
    Ok(respond(
        StatusCode::OK,
        change(&app, MissionChange::Base(v.value)).await?,
    ))
}

/// Adds a risk object; without an id the server assigns `object-N`.
///
/// It may be placed at `lat`, `lon` instead of `x`, `y` when the mission
/// has an origin; it is stored, and answered, at `x`, `y`.
#[utoipa::path(
    post,
    path = "/api/v1/risk-objects",
    tag = "mission",
    request_body = RiskObjectInput,
    responses(
        (status = 201, description = "The stored object with its id, once durable.", body = RiskObjectDocument),
        (status = 409, response = super::responses::Conflict),
        super::responses::DocumentWrite,
    ),
    security(("bearer" = [])),
)]
pub(super) async fn post_object(
    State(app): State<AppState>,
    body: Bytes,
) -> Result<Response, ApiError> {
    let object: RiskObjectInput = parse(&body)?;
    Ok(respond(
        StatusCode::CREATED,
        change(&app, MissionChange::AddObject(object)).await?,
    ))
}

/// One risk object.
#[utoipa::path(
    get,
    path = "/api/v1/risk-objects/{id}",
    tag = "mission",
    params(("id" = String, Path, description = "The risk object's id.")),
    responses(
        (status = 200, description = "The risk object.", body = RiskObjectDocument),
        (status = 404, response = super::responses::NotFound),
    ),
)]
pub(super) async fn get_object(
    State(app): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<RiskObjectDocument>, ApiError> {
    let snap = app.snapshot.borrow().clone();
    snap.document
        .mission
        .risk
        .objects
        .iter()
        .find(|o| o.id.as_deref() == Some(id.as_str()))
        .cloned()
        .map(Json)
        .ok_or_else(|| ApiError::NotFound(format!("no risk object {id:?}")))
}

/// Replaces a risk object; the path's id wins over one in the body.
///
/// Like a new one, it may be placed at `lat`, `lon`.
#[utoipa::path(
    put,
    path = "/api/v1/risk-objects/{id}",
    tag = "mission",
    params(("id" = String, Path, description = "The risk object's id.")),
    request_body = RiskObjectInput,
    responses(
        (status = 200, description = "The stored object, once durable.", body = RiskObjectDocument),
        (status = 404, response = super::responses::NotFound),
        super::responses::DocumentWrite,
    ),
    security(("bearer" = [])),
)]
pub(super) async fn put_object(
    State(app): State<AppState>,
    Path(id): Path<String>,
    body: Bytes,
) -> Result<Response, ApiError> {
    let object: RiskObjectInput = parse(&body)?;
    Ok(respond(
        StatusCode::OK,
        change(&app, MissionChange::PutObject(id, object)).await?,
    ))
}

/// Removes a risk object.
#[utoipa::path(
    delete,
    path = "/api/v1/risk-objects/{id}",
    tag = "mission",
    params(("id" = String, Path, description = "The risk object's id.")),
    responses(
        (status = 204, description = "Removed, durably."),
        (status = 401, response = super::responses::Unauthorized),
        (status = 404, response = super::responses::NotFound),
        (status = 429, response = super::responses::RateLimited),
        (status = 500, response = super::responses::NotStored),
        (status = 503, response = super::responses::ShuttingDown),
    ),
    security(("bearer" = [])),
)]
pub(super) async fn delete_object(
    State(app): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    Ok(respond(
        StatusCode::NO_CONTENT,
        change(&app, MissionChange::DeleteObject(id)).await?,
    ))
}

/// H(P) from the mission's first tick to about the newest, bounded: every
/// tick at first; once 1000 samples are held, every other one is dropped
/// and the stride doubles, so the history spans the whole mission. A
/// replay answers it from its recording up to the replay's time.
#[utoipa::path(
    get,
    path = "/api/v1/coverage/history",
    tag = "coverage",
    responses((status = 200, description = "The stride and the samples (tick, mission time, H), oldest first.", body = crate::protocol::CoverageHistoryDocument)),
)]
pub(super) async fn coverage_history(
    State(app): State<AppState>,
) -> Json<crate::protocol::CoverageHistoryDocument> {
    let history = app.snapshot.borrow().history.clone();
    Json(history.as_ref().clone())
}

/// Samples of the risk field from any sensor (docs/learning.md), a batch of
/// at most 1000. Each is judged on its own: taken into the learner, or
/// refused by its index with a code (`invalid`, `outside_region`, `stale`,
/// `future`, `flood`) and counted in `seacover_samples_total`. A
/// coordinator that does not learn refuses the batch (409).
#[utoipa::path(
    post,
    path = "/api/v1/samples",
    tag = "learning",
    request_body = crate::protocol::SamplesDocument,
    responses(
        (status = 200, description = "How many were taken, and each refusal.", body = crate::protocol::SamplesAnswerDocument),
        (status = 409, response = super::responses::Conflict),
        super::responses::DocumentWrite,
    ),
    security(("bearer" = [])),
)]
pub(super) async fn post_samples(
    State(app): State<AppState>,
    body: Bytes,
) -> Result<Json<crate::protocol::SamplesAnswerDocument>, ApiError> {
    let batch: crate::protocol::SamplesDocument = parse(&body)?;
    if batch.samples.len() > MAX_SAMPLES {
        return Err(ApiError::Invalid(format!(
            "samples: at most {MAX_SAMPLES} in a batch, got {}",
            batch.samples.len()
        )));
    }
    let (reply, answer) = oneshot::channel();
    app.requests
        .send(Request::Samples {
            samples: batch.samples,
            reply,
        })
        .await
        .map_err(|_| ApiError::ShuttingDown)?;
    Ok(Json(answer.await.map_err(|_| ApiError::ShuttingDown)??))
}

/// The newest samples the learner has taken (at most 500), oldest first:
/// what the dashboard draws over the belief.
#[utoipa::path(
    get,
    path = "/api/v1/samples",
    tag = "learning",
    responses(
        (status = 200, description = "The newest samples taken.", body = crate::protocol::SamplesDocument),
        (status = 409, response = super::responses::Conflict),
    ),
)]
pub(super) async fn get_samples(
    State(app): State<AppState>,
) -> Result<Json<crate::protocol::SamplesDocument>, ApiError> {
    let (reply, answer) = oneshot::channel();
    app.requests
        .send(Request::RecentSamples { reply })
        .await
        .map_err(|_| ApiError::ShuttingDown)?;
    Ok(Json(answer.await.map_err(|_| ApiError::ShuttingDown)??))
}

/// The most samples one `POST /api/v1/samples` carries.
const MAX_SAMPLES: usize = 1000;

/// The risk density the fleet covers: the belief learned from samples once
/// fitted, else the mission's own risk; with the learner's state.
#[utoipa::path(
    get,
    path = "/api/v1/risk",
    tag = "learning",
    responses((status = 200, description = "The density covered and where it comes from.", body = crate::protocol::BeliefDocument)),
)]
pub(super) async fn risk(State(app): State<AppState>) -> Json<crate::protocol::BeliefDocument> {
    let (reply, answer) = oneshot::channel();
    if app.requests.send(Request::Belief { reply }).await.is_ok()
        && let Ok(doc) = answer.await
    {
        return Json(doc);
    }
    // A replay (or a coordinator stopping): the recorded mission's risk.
    let risk = app.snapshot.borrow().document.mission.risk.clone();
    Json(crate::protocol::BeliefDocument {
        source: "mission".into(),
        risk,
        samples: 0,
        fits: 0,
        fitted_at: None,
        kappa: 0.0,
        learning: false,
        uncertainty: None,
    })
}

/// The largest GeoTIFF `PUT /api/v1/mission/risk/raster` takes [bytes]: a
/// float band of 2000 × 2000 pixels, far finer than a fit of 30 × 30
/// Gaussians can use.
const MAX_RASTER: usize = 32 * 1024 * 1024;

/// Replaces the mission's risk by the fit of a GeoTIFF (docs/rasters.md):
/// the body is the file itself (single band, EPSG:4326 or a WGS84 UTM
/// zone, at most 32 MiB), placed by the mission's origin and fitted as
/// `seacover risk fit` fits it; `?spacing=M` sets the fit's lattice.
#[utoipa::path(
    put,
    path = "/api/v1/mission/risk/raster",
    tag = "mission",
    params(("spacing" = Option<f64>, Query, description = "Spacing and spread of the fit's Gaussians [m]; by default 30 across the region's longer side, and at least three pixels.")),
    request_body(content = Vec<u8>, content_type = "image/tiff", description = "A single-band GeoTIFF."),
    responses(
        (status = 200, description = "The mission with the fit as its risk, once durable, and the fit's error against the raster.", body = crate::protocol::RasterFitDocument),
        (status = 409, response = super::responses::Conflict),
        super::responses::DocumentWrite,
    ),
    security(("bearer" = [])),
)]
pub(super) async fn put_raster(
    State(app): State<AppState>,
    query: Result<
        axum::extract::Query<crate::protocol::RasterQuery>,
        axum::extract::rejection::QueryRejection,
    >,
    body: axum::body::Body,
) -> Result<Response, ApiError> {
    let axum::extract::Query(query) = query.map_err(|e| ApiError::Malformed(e.body_text()))?;
    let bytes = axum::body::to_bytes(body, MAX_RASTER)
        .await
        .map_err(|_| ApiError::TooLarge(MAX_RASTER))?;
    let doc = app.snapshot.borrow().document.mission.clone();
    let mission = crate::mission::Mission::from_document(&doc)?;
    // Decoding and fitting take up to seconds: off the server's threads.
    let fitted = tokio::task::spawn_blocking(move || {
        let raster = crate::raster::Raster::decode(std::path::Path::new("the upload"), &bytes)?;
        let fit = crate::raster::fit(&raster, &mission, query.spacing)?;
        let (width, height) = raster.size();
        let summary = crate::protocol::FitDocument {
            crs: raster.crs().name(),
            width,
            height,
            spacing: fit.spacing,
            lattice: fit.gaussians,
            pixels: fit.pixels,
            measured: fit.measured,
            min: fit.min,
            max: fit.max,
            rms: fit.rms,
            worst: fit.worst,
        };
        Ok::<_, crate::raster::RasterError>((
            crate::mission::belief::risk_document(&fit.risk),
            summary,
        ))
    })
    .await
    .map_err(|_| ApiError::ShuttingDown)?;
    let (risk, fit) = fitted?;
    match change(&app, MissionChange::Risk(risk)).await? {
        ChangeResult::Mission(mission) => Ok(Json(crate::protocol::RasterFitDocument {
            mission: *mission,
            fit,
        })
        .into_response()),
        other => unreachable!("a whole risk answers with the mission, not {other:?}"),
    }
}
