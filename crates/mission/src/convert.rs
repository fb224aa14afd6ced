//! Conversions between the mission's documents and the core's types: the
//! origin's local plane, the risk field, guidance gains and safety
//! parameters. Each reading conversion validates and names the field at
//! fault; each writing one is its exact inverse.

use super::MissionError;
use super::scenario::ScenarioError;
use seacover_engine::control::guidance::{GuidanceGains, GuidanceMode};
use seacover_engine::control::safety::SafetyParams;
use seacover_engine::coverage::RiskField;
use seacover_engine::geometry::Point;
use seacover_protocol::{GuidanceDocument, OriginDocument, RiskDocument, SafetyDocument};

/// The local plane of an origin, or `invalid` naming `origin.lat` or
/// `origin.lon`.
pub fn origin_frame(
    origin: OriginDocument,
) -> Result<seacover_engine::geometry::geodesy::LocalFrame, MissionError> {
    use seacover_engine::geometry::geodesy::{LatLon, LocalFrame};
    LocalFrame::new(LatLon {
        lat: origin.lat,
        lon: origin.lon,
    })
    .map_err(|e| MissionError::Invalid(format!("origin.{e}")))
}

/// The risk field of its document, validated as a scenario's.
pub fn risk_field(doc: &RiskDocument) -> Result<RiskField, MissionError> {
    RiskField::new(
        doc.base,
        doc.objects
            .iter()
            .map(|o| seacover_engine::coverage::RiskObject {
                center: Point { x: o.x, y: o.y },
                alpha: o.alpha,
                sigma: o.sigma,
            })
            .collect(),
    )
    .map_err(|e| MissionError::from(ScenarioError::from(e)))
}

/// The mission's safety parameters: the document's three, the rest at their
/// defaults (validated by [`SafetyLayer::new`]).
pub fn safety_params(doc: &SafetyDocument) -> SafetyParams {
    SafetyParams {
        filter: doc.filter,
        safety_distance: doc.safety_distance,
        shore_distance: doc.shore_distance,
        ..SafetyParams::default()
    }
}

/// The document of guidance gains ([`guidance_gains`] reads it back).
pub fn guidance_document(g: &GuidanceGains) -> GuidanceDocument {
    GuidanceDocument {
        mode: g.mode.name().to_string(),
        k_r1: g.k_r1,
        k_r2: g.k_r2,
        b1: g.b1,
        k_u1: g.k_u1,
        k_u2: g.k_u2,
        b2: g.b2,
        arrival_radius: g.arrival_radius,
        max_speed: g.max_speed,
        max_yaw_rate: g.max_yaw_rate,
        filter_time: g.filter_time,
        yaw_accel: g.yaw_accel,
        surge_accel: g.surge_accel,
        hold_radius: g.hold_radius,
    }
}

/// The document of safety parameters ([`safety_params`] reads it back).
pub fn safety_document(p: &SafetyParams) -> SafetyDocument {
    SafetyDocument {
        filter: p.filter,
        safety_distance: p.safety_distance,
        shore_distance: p.shore_distance,
    }
}

/// Guidance gains from their document: a known mode, every gain finite and
/// positive (the arrival and hold radii may be zero).
pub fn guidance_gains(doc: &GuidanceDocument) -> Result<GuidanceGains, MissionError> {
    let mode = GuidanceMode::parse(&doc.mode).ok_or_else(|| {
        MissionError::Invalid(format!(
            "guidance.mode: unknown mode {:?} (paper, course)",
            doc.mode
        ))
    })?;
    let gains = [
        ("k_r1", doc.k_r1),
        ("k_r2", doc.k_r2),
        ("b1", doc.b1),
        ("k_u1", doc.k_u1),
        ("k_u2", doc.k_u2),
        ("b2", doc.b2),
        ("max_speed", doc.max_speed),
        ("max_yaw_rate", doc.max_yaw_rate),
        ("filter_time", doc.filter_time),
        ("yaw_accel", doc.yaw_accel),
        ("surge_accel", doc.surge_accel),
    ];
    for (name, value) in gains {
        if !(value.is_finite() && value > 0.0) {
            return Err(MissionError::Invalid(format!(
                "guidance.{name}: must be a finite number > 0"
            )));
        }
    }
    for (name, value) in [
        ("arrival_radius", doc.arrival_radius),
        ("hold_radius", doc.hold_radius),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(MissionError::Invalid(format!(
                "guidance.{name}: must be a finite number >= 0"
            )));
        }
    }
    Ok(GuidanceGains {
        mode,
        k_r1: doc.k_r1,
        k_r2: doc.k_r2,
        b1: doc.b1,
        k_u1: doc.k_u1,
        k_u2: doc.k_u2,
        b2: doc.b2,
        arrival_radius: doc.arrival_radius,
        hold_radius: doc.hold_radius,
        max_speed: doc.max_speed,
        max_yaw_rate: doc.max_yaw_rate,
        filter_time: doc.filter_time,
        yaw_accel: doc.yaw_accel,
        surge_accel: doc.surge_accel,
    })
}
