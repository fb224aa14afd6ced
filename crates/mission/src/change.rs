//! Changes to a mission: one REST write each, applied to a copy and
//! validated as a whole, so a rejected change leaves the mission as it was.

use std::sync::Arc;

use super::scenario::ScenarioError;
use super::{Mission, MissionError, origin_frame, risk_field};
use seacover_engine::control::safety::SafetyLayer;
use seacover_engine::coverage::InputError;
use seacover_engine::geometry::{Point, Region, norm2};
use seacover_protocol::{
    MissionDocument, OriginDocument, RegionInput, RiskDocument, RiskObjectDocument, RiskObjectInput,
};

/// One write of the REST API. Geographic inputs are placed in the plane by
/// [`Mission::changed`], with the origin of the mission they change: the
/// tick task applies changes in order, so a region written just after an
/// origin is placed with that origin.
#[derive(Debug, Clone)]
pub enum MissionChange {
    Origin(OriginDocument),
    Region(RegionInput),
    Base(f64),
    AddObject(RiskObjectInput),
    PutObject(String, RiskObjectInput),
    DeleteObject(String),
    /// The whole mission replaced by a peer fleet's (a coordinator joining
    /// a fleet takes the fleet's mission rather than re-task it).
    Adopt(Box<MissionDocument>),
    /// The whole risk replaced (a raster's fit): its objects without an id
    /// are numbered as a mission document's are.
    Risk(RiskDocument),
}

/// What a change answers with.
#[derive(Debug, Clone)]
pub enum ChangeResult {
    // Boxed: the mission document is far larger than the other answers.
    Mission(Box<MissionDocument>),
    Object(RiskObjectDocument),
    Deleted,
}

impl Mission {
    /// The mission with `change` applied, validated as `evaluate` validates;
    /// `self` is left untouched when it is rejected.
    pub fn changed(&self, change: &MissionChange) -> Result<(Mission, ChangeResult), MissionError> {
        let whole = match change {
            MissionChange::Adopt(doc) => Some(doc.as_ref().clone()),
            MissionChange::Risk(risk) => Some(MissionDocument {
                risk: risk.clone(),
                ..self.document()
            }),
            _ => None,
        };
        if let Some(doc) = whole {
            let next = Mission::from_document(&doc)?;
            let answer = ChangeResult::Mission(Box::new(next.document()));
            return Ok((next, answer));
        }
        let mut next = self.clone();
        let frame = self.frame();
        let placed =
            |e: seacover_engine::coverage::InputError| MissionError::from(ScenarioError::from(e));
        let result = match change {
            MissionChange::Origin(origin) => {
                // The region and the objects keep their local coordinates:
                // moving the origin moves the mission on the globe.
                origin_frame(*origin)?;
                next.origin = Some(*origin);
                None
            }
            MissionChange::Region(input) => {
                let doc = crate::georef::input::region(input, frame.as_ref()).map_err(placed)?;
                next.region = crate::scenario::region_from_document(&doc)?;
                next.region_doc = doc;
                next.layer = Arc::new(
                    SafetyLayer::new(&next.region, next.safety)
                        .map_err(|e| MissionError::from(ScenarioError::from(e)))?,
                );
                None
            }
            MissionChange::Base(value) => {
                next.risk_doc.base = *value;
                None
            }
            MissionChange::AddObject(object) => {
                let mut object = crate::georef::input::risk_object(object, frame.as_ref(), "")
                    .map_err(placed)?;
                check_object(&object, &next.region)?;
                let id = match &object.id {
                    Some(id) => {
                        if !crate::scenario::valid_id(id) {
                            return Err(MissionError::Invalid(
                                "id: must match [A-Za-z0-9_.-]{1,64}".into(),
                            ));
                        }
                        if next
                            .risk_doc
                            .objects
                            .iter()
                            .any(|o| o.id.as_deref() == Some(id))
                        {
                            return Err(MissionError::Conflict(format!(
                                "a risk object {id:?} exists already"
                            )));
                        }
                        id.clone()
                    }
                    None => (1..)
                        .map(|n| format!("object-{n}"))
                        .find(|c| {
                            !next
                                .risk_doc
                                .objects
                                .iter()
                                .any(|o| o.id.as_deref() == Some(c))
                        })
                        .expect("an unused id exists"),
                };
                object.id = Some(id);
                next.risk_doc.objects.push(object.clone());
                Some(object)
            }
            MissionChange::PutObject(id, object) => {
                let object = crate::georef::input::risk_object(object, frame.as_ref(), "")
                    .map_err(placed)?;
                check_object(&object, &next.region)?;
                let slot = next
                    .risk_doc
                    .objects
                    .iter_mut()
                    .find(|o| o.id.as_deref() == Some(id.as_str()))
                    .ok_or_else(|| MissionError::NotFound(format!("no risk object {id:?}")))?;
                *slot = RiskObjectDocument {
                    id: Some(id.clone()),
                    ..object
                };
                Some(slot.clone())
            }
            MissionChange::DeleteObject(id) => {
                let before = next.risk_doc.objects.len();
                next.risk_doc
                    .objects
                    .retain(|o| o.id.as_deref() != Some(id.as_str()));
                if next.risk_doc.objects.len() == before {
                    return Err(MissionError::NotFound(format!("no risk object {id:?}")));
                }
                None
            }
            MissionChange::Adopt(_) | MissionChange::Risk(_) => unreachable!("replaced above"),
        };
        next.risk = risk_field(&next.risk_doc)?;
        let answer = match (change, result) {
            (MissionChange::DeleteObject(_), _) => ChangeResult::Deleted,
            (_, Some(object)) => ChangeResult::Object(object),
            (_, None) => ChangeResult::Mission(Box::new(next.document())),
        };
        Ok((next, answer))
    }
}

/// How far a risk object reaches, in σ: beyond 5σ its density is below
/// exp(−12.5) ≈ 4e-6 of its peak.
const REACH_SIGMAS: f64 = 5.0;

/// Checks one risk object as the request wrote it, before it joins the
/// mission's list: errors name the request's own fields (`sigma`, not
/// `risk.objects[3].sigma`), and an object whose whole 5σ disc lies outside
/// the region is refused, since it cannot change the coverage.
fn check_object(object: &RiskObjectDocument, region: &Region) -> Result<(), MissionError> {
    let alone = RiskDocument {
        base: 0.0,
        objects: vec![object.clone()],
    };
    risk_field(&alone).map_err(|e| match e {
        MissionError::Scenario(ScenarioError::Input(InputError::Invalid { field, reason })) => {
            let field = field.strip_prefix("risk.objects[0].").unwrap_or(&field);
            MissionError::Invalid(format!("{field}: {reason}"))
        }
        other => other,
    })?;
    let centre = Point {
        x: object.x,
        y: object.y,
    };
    let reach = REACH_SIGMAS * object.sigma;
    let distance = norm2(region.closest_point(centre) - centre).sqrt();
    if !region.contains(centre) && distance > reach {
        return Err(MissionError::Invalid(format!(
            "x, y: the object lies {distance:.1} m outside the region, farther than its \
             5σ reach ({reach:.1} m), so it cannot change the coverage"
        )));
    }
    Ok(())
}
