//! The mission model: what a fleet covers and how, between the wire types
//! ([`seacover_protocol`]) and the processes that run it (server, agents,
//! simulator, recorder).
//!
//! Everything here is documents in, core types out (and back): no I/O, no
//! HTTP, no async. Its parts:
//! - [`Mission`] and its changes ([`MissionChange`], [`Mission::changed`]):
//!   the one model the coordinator owns, validated exactly as
//!   `seacover evaluate` validates a scenario;
//! - [`convert`]: the conversions between documents and core types (origin
//!   frame, guidance gains, safety parameters, risk field);
//! - [`scenario`]: scenario documents → validated core types → evaluation
//!   documents; [`georef`]: WGS84 documents in, GeoJSON out;
//! - [`builtin`]: the built-in scenarios (paper, harbour);
//! - [`belief`]: a learned belief and its uncertainty as documents;
//! - [`clock`]: the mission clock (mission seconds under a time warp).
//!
//! Invariants:
//! - a [`Mission`] is always valid: every constructor and every change
//!   validates, and a rejected change leaves the mission untouched;
//! - every rejection is a [`MissionError`] whose message starts with the
//!   path of the offending field and whose code is stable (`malformed`,
//!   `invalid`, `unsupported`, `not_found`, `conflict`); the HTTP edge
//!   converts it with one `From`.

pub mod belief;
pub mod builtin;
mod change;
pub mod clock;
pub mod convert;
mod error;
pub mod georef;
pub mod scenario;

use std::sync::Arc;

use seacover_engine::control::guidance::{GuidanceGains, GuidanceMode};
use seacover_engine::control::safety::{SafetyLayer, SafetyParams};
use seacover_engine::coverage::{Fleet, RiskField, Vessel};
use seacover_engine::geometry::geodesy::LocalFrame;
use seacover_engine::geometry::{Point, Region};
use seacover_protocol::{
    ActuatorDocument, MissionDocument, OriginDocument, RegionDocument, RiskDocument,
    RiskObjectDocument,
};

pub use builtin::PAPER_SCENARIO;
pub use change::{ChangeResult, MissionChange};
pub use clock::MissionClock;
pub use convert::{
    guidance_document, guidance_gains, origin_frame, risk_field, safety_document, safety_params,
};
pub use error::MissionError;
use scenario::{Scenario, ScenarioError};

/// The mission: what to cover and how. Always valid: it is made only by
/// [`Mission::paper`], [`Mission::from_document`] and
/// [`Mission::from_text`], which validate, and changed only through
/// [`MissionChange`]s, which validate again; its parts are read through
/// the accessors below.
#[derive(Debug, Clone)]
pub struct Mission {
    origin: Option<OriginDocument>,
    region_doc: RegionDocument,
    risk_doc: RiskDocument,
    region: Region,
    risk: RiskField,
    actuator: ActuatorDocument,
    guidance: GuidanceGains,
    tick_hz: f64,
    safety: SafetyParams,
    layer: Arc<SafetyLayer>,
}

impl Mission {
    /// The WGS84 origin of the local plane, when geo-referenced; validated
    /// ([`seacover_engine::geometry::geodesy::LocalFrame::new`]).
    pub fn origin(&self) -> Option<OriginDocument> {
        self.origin
    }

    /// The region as its document gave it.
    pub fn region_doc(&self) -> &RegionDocument {
        &self.region_doc
    }

    /// The risk as its document gave it, every object with an id.
    pub fn risk_doc(&self) -> &RiskDocument {
        &self.risk_doc
    }

    /// The task region Q.
    pub fn region(&self) -> &Region {
        &self.region
    }

    /// The risk density Φ (paper eq. 5).
    pub fn risk(&self) -> &RiskField {
        &self.risk
    }

    /// The actuator of vessels that do not declare their own.
    pub fn actuator(&self) -> ActuatorDocument {
        self.actuator
    }

    /// The guidance gains.
    pub fn guidance(&self) -> GuidanceGains {
        self.guidance
    }

    /// The coverage tick rate [Hz of mission time].
    pub fn tick_hz(&self) -> f64 {
        self.tick_hz
    }

    /// The safety parameters.
    pub fn safety(&self) -> SafetyParams {
        self.safety
    }

    /// The region's shore and route map with [`Mission::safety`]: rebuilt
    /// whenever either changes, shared by the mission's clones.
    pub fn layer(&self) -> &Arc<SafetyLayer> {
        &self.layer
    }

    /// The paper's scenario (region, risk, actuator), default guidance, 10 Hz.
    pub fn paper() -> Mission {
        let doc =
            crate::scenario::parse_document(PAPER_SCENARIO).expect("built-in scenario parses");
        let scenario = Scenario::from_document(&doc).expect("built-in scenario is valid");
        let v = scenario.fleet.vessels()[0];
        let mut risk_doc = doc.risk.clone().expect("paper has risk");
        for (i, o) in risk_doc.objects.iter_mut().enumerate() {
            o.id.get_or_insert_with(|| format!("object-{}", i + 1));
        }
        let layer = Arc::new(
            SafetyLayer::new(&scenario.region, SafetyParams::default())
                .expect("default safety parameters are valid"),
        );
        Mission {
            origin: None,
            region_doc: doc.region.clone().expect("paper has a region"),
            risk_doc,
            region: scenario.region,
            risk: scenario.risk,
            actuator: ActuatorDocument {
                k: v.k,
                beta: v.beta,
            },
            guidance: GuidanceGains::default(),
            tick_hz: 10.0,
            safety: SafetyParams::default(),
            layer,
        }
    }

    /// A mission from its document (a stored mission, a `--config` file),
    /// validated as `evaluate` validates a scenario, plus the guidance gains
    /// and the tick rate.
    pub fn from_document(doc: &MissionDocument) -> Result<Mission, MissionError> {
        let region = crate::scenario::region_from_document(&doc.region)?;
        let risk = risk_field(&doc.risk)?;
        check_actuator(doc.actuator, "actuator")?;
        if !(doc.tick_hz.is_finite() && doc.tick_hz > 0.0 && doc.tick_hz <= 100.0) {
            return Err(MissionError::Invalid("tick_hz: must be in (0, 100]".into()));
        }
        let mut risk_doc = doc.risk.clone();
        let mut seen = std::collections::HashSet::new();
        for (i, o) in risk_doc.objects.iter_mut().enumerate() {
            let id = o.id.get_or_insert_with(|| format!("object-{}", i + 1));
            if !crate::scenario::valid_id(id) {
                return Err(MissionError::Invalid(format!(
                    "risk.objects[{i}].id: must match [A-Za-z0-9_.-]{{1,64}}"
                )));
            }
            if !seen.insert(id.clone()) {
                return Err(MissionError::Invalid(format!(
                    "risk.objects[{i}].id: duplicate id {id:?}"
                )));
            }
        }
        let safety = safety_params(&doc.safety);
        let layer = Arc::new(
            SafetyLayer::new(&region, safety)
                .map_err(|e| MissionError::from(ScenarioError::from(e)))?,
        );
        if let Some(o) = doc.origin {
            origin_frame(o)?;
        }
        Ok(Mission {
            origin: doc.origin,
            region_doc: doc.region.clone(),
            risk_doc,
            region,
            risk,
            actuator: doc.actuator,
            guidance: guidance_gains(&doc.guidance)?,
            tick_hz: doc.tick_hz,
            safety,
            layer,
        })
    }

    /// A mission from a file's text: a mission document (as `GET
    /// /api/v1/mission` gives it, extra fields such as a peer fleet's
    /// `revision` ignored) or a scenario document, whose origin, region,
    /// risk and first vessel's actuator replace the paper mission's, with
    /// the default guidance, safety and tick rate.
    pub fn from_text(text: &str) -> Result<Mission, MissionError> {
        if let Ok(doc) = serde_json::from_str::<MissionDocument>(text) {
            return Mission::from_document(&doc);
        }
        let local = scenario::parse_document(text)?;
        let mut doc = Mission::paper().document();
        doc.origin = local.origin;
        if let Some(region) = local.region {
            doc.region = region;
        }
        if let Some(risk) = local.risk {
            doc.risk = risk;
        }
        if let Some(v) = local.vessels.first() {
            doc.actuator.k = v.k.unwrap_or(doc.actuator.k);
            doc.actuator.beta = v.beta.unwrap_or(doc.actuator.beta);
        }
        Mission::from_document(&doc)
    }

    /// The actuator of each vessel a scenario document names: its own k
    /// and β, or the defaults, each checked as a mission's actuator is
    /// (`vessels[i]` in the message); empty for a mission document or a
    /// scenario without vessels. A vessel of a peer fleet computes with
    /// its own (docs/peer.md, "Every actuator on board").
    pub fn vessel_actuators(
        text: &str,
    ) -> Result<std::collections::BTreeMap<String, ActuatorDocument>, MissionError> {
        if serde_json::from_str::<MissionDocument>(text).is_ok() {
            return Ok(Default::default());
        }
        let local = scenario::parse_document(text)?;
        let mut out = std::collections::BTreeMap::new();
        for (i, v) in local.vessels.iter().enumerate() {
            let a = ActuatorDocument {
                k: v.k.unwrap_or(seacover_engine::coverage::fleet::DEFAULT_K),
                beta: v
                    .beta
                    .unwrap_or(seacover_engine::coverage::fleet::DEFAULT_BETA),
            };
            check_actuator(a, &format!("vessels[{i}]"))?;
            out.insert(v.id.clone(), a);
        }
        Ok(out)
    }

    pub fn document(&self) -> MissionDocument {
        MissionDocument {
            origin: self.origin,
            region: self.region_doc.clone(),
            risk: self.risk_doc.clone(),
            actuator: self.actuator,
            guidance: guidance_document(&self.guidance),
            tick_hz: self.tick_hz,
            safety: safety_document(&self.safety),
        }
    }

    /// The mission's risk objects, with ids.
    pub fn objects(&self) -> &[RiskObjectDocument] {
        &self.risk_doc.objects
    }

    pub fn mode(&self) -> GuidanceMode {
        self.guidance.mode
    }

    /// The local plane of the mission's origin, when it has one.
    pub fn frame(&self) -> Option<LocalFrame> {
        // Validated when it was set (`from_document`, `changed`).
        self.origin.and_then(|o| origin_frame(o).ok())
    }
}

/// Checks an actuator as a scenario's vessel would be; `at` names it in
/// the message.
pub fn check_actuator(a: ActuatorDocument, at: &str) -> Result<(), MissionError> {
    Fleet::new(vec![Vessel {
        position: Point { x: 0.0, y: 0.0 },
        k: a.k,
        beta: a.beta,
    }])
    .map(|_| ())
    .map_err(|e| match e {
        // The engine names it as the first vessel of a fleet.
        seacover_engine::coverage::InputError::Invalid { field, reason } => MissionError::from(
            ScenarioError::from(seacover_engine::coverage::InputError::Invalid {
                field: field.replacen("vessels[0]", at, 1),
                reason,
            }),
        ),
        e => MissionError::from(ScenarioError::from(e)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_vessel_of_a_scenario_has_its_own_actuator() {
        let text = r#"{"vessels": [
            {"id": "a", "x": 1, "y": 2, "k": 0.7, "beta": 0.004},
            {"id": "b", "x": 3, "y": 4}
        ]}"#;
        let a = Mission::vessel_actuators(text).unwrap();
        assert_eq!(
            a["a"],
            ActuatorDocument {
                k: 0.7,
                beta: 0.004
            }
        );
        let defaults = ActuatorDocument {
            k: seacover_engine::coverage::fleet::DEFAULT_K,
            beta: seacover_engine::coverage::fleet::DEFAULT_BETA,
        };
        assert_eq!(a["b"], defaults);
        assert_eq!(a.len(), 2);
    }

    #[test]
    fn a_mission_document_names_no_vessel() {
        let text = serde_json::to_string(&Mission::paper().document()).unwrap();
        assert!(Mission::vessel_actuators(&text).unwrap().is_empty());
    }

    #[test]
    fn a_vessel_actuator_out_of_range_is_refused_by_its_place() {
        let text = r#"{"vessels": [
            {"id": "a", "x": 1, "y": 2},
            {"id": "b", "x": 3, "y": 4, "beta": -1}
        ]}"#;
        let e = Mission::vessel_actuators(text).unwrap_err().to_string();
        assert!(e.starts_with("vessels[1].beta: "), "{e}");
        let mut doc = Mission::paper().document();
        doc.actuator.k = 0.0;
        let e = Mission::from_document(&doc).unwrap_err().to_string();
        assert!(e.starts_with("actuator.k: "), "{e}");
    }
}
