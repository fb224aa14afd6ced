//! REST handlers. Reads come from the newest snapshot; evaluation is a
//! stateless what-if that fills in the mission's region and risk.

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use tokio::sync::oneshot;

use super::AppState;
use super::error::ApiError;
use super::state::{ChangeResult, MissionChange, Request};
use crate::coverage::Options;
use crate::protocol::{
    CoverageDocument, EvaluationDocument, MissionDocument, RegionDocument, RiskObjectDocument,
    VesselStatusDocument,
};
use crate::scenario::{Scenario, evaluation_document, parse_document};

pub async fn healthz() -> &'static str {
    "ok"
}

pub async fn mission(State(app): State<AppState>) -> Json<MissionDocument> {
    Json(app.snapshot.borrow().document.mission.clone())
}

pub async fn risk_objects(State(app): State<AppState>) -> Json<Vec<RiskObjectDocument>> {
    Json(app.snapshot.borrow().document.mission.risk.objects.clone())
}

pub async fn vessels(State(app): State<AppState>) -> Json<Vec<VesselStatusDocument>> {
    Json(app.snapshot.borrow().document.vessels.clone())
}

pub async fn vessel(
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
pub async fn delete_vessel(
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

pub async fn coverage(State(app): State<AppState>) -> Json<CoverageDocument> {
    Json(app.snapshot.borrow().coverage.clone())
}

pub async fn evaluate(
    State(app): State<AppState>,
    body: Bytes,
) -> Result<Json<EvaluationDocument>, ApiError> {
    let text = std::str::from_utf8(&body)
        .map_err(|e| ApiError::Malformed(format!("body is not UTF-8: {e}")))?;
    let mut doc = parse_document(text)?;
    {
        let snap = app.snapshot.borrow();
        let mission = &snap.document.mission;
        doc.region.get_or_insert_with(|| mission.region.clone());
        doc.risk.get_or_insert_with(|| mission.risk.clone());
    }
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
    serde_json::from_slice(body).map_err(|e| ApiError::Malformed(e.to_string()))
}

/// Hands a change to the tick task and waits for its verdict.
async fn change(app: &AppState, change: MissionChange) -> Result<ChangeResult, ApiError> {
    let (reply, answer) = oneshot::channel();
    app.requests
        .send(Request::Change { change, reply })
        .await
        .map_err(|_| ApiError::ShuttingDown)?;
    answer.await.map_err(|_| ApiError::ShuttingDown)?
}

fn respond(status: StatusCode, result: ChangeResult) -> Response {
    match result {
        ChangeResult::Mission(m) => (status, Json(m)).into_response(),
        ChangeResult::Object(o) => (status, Json(o)).into_response(),
        ChangeResult::Deleted => StatusCode::NO_CONTENT.into_response(),
    }
}

pub async fn put_region(State(app): State<AppState>, body: Bytes) -> Result<Response, ApiError> {
    let region: RegionDocument = parse(&body)?;
    Ok(respond(
        StatusCode::OK,
        change(&app, MissionChange::Region(region)).await?,
    ))
}

#[derive(Deserialize)]
struct Value {
    value: f64,
}

pub async fn put_base(State(app): State<AppState>, body: Bytes) -> Result<Response, ApiError> {
    let v: Value = parse(&body)?;
    Ok(respond(
        StatusCode::OK,
        change(&app, MissionChange::Base(v.value)).await?,
    ))
}

pub async fn post_object(State(app): State<AppState>, body: Bytes) -> Result<Response, ApiError> {
    let object: RiskObjectDocument = parse(&body)?;
    Ok(respond(
        StatusCode::CREATED,
        change(&app, MissionChange::AddObject(object)).await?,
    ))
}

pub async fn get_object(
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

pub async fn put_object(
    State(app): State<AppState>,
    Path(id): Path<String>,
    body: Bytes,
) -> Result<Response, ApiError> {
    let object: RiskObjectDocument = parse(&body)?;
    Ok(respond(
        StatusCode::OK,
        change(&app, MissionChange::PutObject(id, object)).await?,
    ))
}

pub async fn delete_object(
    State(app): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    Ok(respond(
        StatusCode::NO_CONTENT,
        change(&app, MissionChange::DeleteObject(id)).await?,
    ))
}
