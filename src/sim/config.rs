//! What a simulation runs: the scenario, the vessel model, gains, the
//! disturbance and the safety layer's settings ([`Config`]), loaded from a
//! built-in scenario or a file, and why a run fails ([`SimError`]).

use crate::control::Vec3;
use crate::control::controller::ControllerGains;
use crate::control::disturbance::{Disturbance, Gusts};
use crate::control::guidance::GuidanceGains;
use crate::control::model::VesselParams;
use crate::control::observer::ObserverGains;
use crate::control::safety::SafetyParams;
use crate::coverage::{Fleet, Vessel};
use crate::geometry::Point;
use crate::mission::scenario::Scenario;

/// Which disturbance acts on the fleet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DisturbanceKind {
    /// The paper's sinusoids, τ_d = (sin(t+i), 1.5 cos(t+i), 2 sin(t+i)).
    Paper,
    /// Seeded random gusts (|τ_d| ≤ (20, 10, 5), |τ̇_d| ≤ 2.5 per channel).
    Gusts,
    /// A steady 15 N push towards +x (a current), plus the paper's sinusoids.
    Current,
    None,
}

impl DisturbanceKind {
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "paper" => Some(Self::Paper),
            "gusts" => Some(Self::Gusts),
            "current" => Some(Self::Current),
            "none" => Some(Self::None),
            _ => None,
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Gusts => "gusts",
            Self::Current => "current",
            Self::None => "none",
        }
    }

    /// The model for vessel `i` (0-based).
    pub(super) fn model(&self, i: usize, seed: u64) -> Disturbance {
        match self {
            Self::Paper => Disturbance::Paper { index: i + 1 },
            Self::Gusts => Disturbance::Gusts(Gusts::random(
                seed.wrapping_mul(1000).wrapping_add(i as u64),
                Vec3::new(20.0, 10.0, 5.0),
                Vec3::new(2.5, 2.5, 2.5),
            )),
            Self::Current => Disturbance::Sum(vec![
                Disturbance::Current { fx: 15.0, fy: 0.0 },
                Disturbance::Paper { index: i + 1 },
            ]),
            Self::None => Disturbance::None,
        }
    }
}

/// Everything a run depends on.
#[derive(Debug, Clone)]
pub struct Config {
    pub scenario: Scenario,
    /// Initial headings (the scenario's ψ, 0 where absent).
    pub headings: Vec<f64>,
    pub duration: f64,
    /// Dynamics step [s].
    pub step: f64,
    /// Coverage and guidance rate [Hz].
    pub tick_hz: f64,
    pub guidance: GuidanceGains,
    pub preset: String,
    pub vessel: VesselParams,
    pub observer: ObserverGains,
    pub controller: ControllerGains,
    pub disturbance: DisturbanceKind,
    pub seed: u64,
    /// Gain k of Lloyd's ṗ = k (C − p) [1/s].
    pub lloyd_gain: f64,
    /// Times at which to keep the partition for the evolution figure.
    pub snapshots: Vec<f64>,
    /// Goals, routes and the barrier filter (`safety.filter`).
    pub safety: SafetyParams,
    /// Radius of the disc taken as a hull, for collisions and incursions [m].
    pub hull_radius: f64,
    /// Whether to run Lloyd's baseline beside the fleet.
    pub lloyd: bool,
    /// Sampling and learning, when the scenario has a truth.
    pub learning: Option<super::learn::LearningConfig>,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("vessel {vessel} left the representable range at t = {t:.1} s")]
    Diverged { vessel: usize, t: f64 },
    #[error(transparent)]
    Scenario(#[from] crate::mission::scenario::ScenarioError),
    #[error("{0}")]
    Io(String),
    #[error("drawing {0}")]
    Figure(String),
    #[error("the scenario's raster")]
    Raster(#[from] crate::raster::RasterError),
}

/// Where random starts of a built-in scenario are drawn: the harbour's fleet
/// leaves from the basin west of the pier and south of the octagonal island
/// (x ≤ 85 m, y ≤ 75 m), so it must spread past the pier, the islands and
/// each other; other scenarios use the whole region.
pub fn staging_zone(spec: &str) -> Option<(Point, Point)> {
    spec.starts_with("harbour-")
        .then_some((Point { x: 0.0, y: 0.0 }, Point { x: 85.0, y: 75.0 }))
}

/// Loads a built-in scenario (`paper`, `harbour-8`, `harbour-30`) or a
/// scenario file; returns it with the vessels' initial headings.
pub fn load_scenario(spec: &str) -> Result<(Scenario, Vec<f64>), SimError> {
    let doc = load_scenario_document(spec)?;
    let scenario = Scenario::from_document(&doc)?;
    let headings = doc.vessels.iter().map(|v| v.psi.unwrap_or(0.0)).collect();
    Ok((scenario, headings))
}

/// The document of a built-in scenario or a scenario file, placed in its
/// own plane (what [`load_scenario`] builds the scenario from).
pub fn load_scenario_document(
    spec: &str,
) -> Result<crate::mission::scenario::LocalScenario, SimError> {
    let (text, keep) = match crate::mission::builtin::scenario(spec) {
        Some((text, keep)) => (text.to_string(), keep),
        None => {
            let text = std::fs::read_to_string(spec)
                .map_err(|e| SimError::Io(format!("cannot read {spec}: {e}")))?;
            // A risk or truth that names a raster is fitted from it.
            let dir = std::path::Path::new(spec)
                .parent()
                .unwrap_or(std::path::Path::new("."));
            (crate::raster::resolve(&text, dir)?, usize::MAX)
        }
    };
    let mut doc = crate::mission::scenario::parse_document(&text)?;
    doc.vessels.truncate(keep);
    Ok(doc)
}

impl Config {
    /// A run of `duration` seconds with the defaults: 1 kHz dynamics, 10 Hz
    /// ticks, the paper's disturbances, snapshots at 0, T/8, T/3 and T.
    pub fn new(scenario: Scenario, headings: Vec<f64>, duration: f64) -> Config {
        Config {
            headings,
            duration,
            step: 1e-3,
            tick_hz: 10.0,
            guidance: GuidanceGains::default(),
            preset: "paper".to_string(),
            vessel: VesselParams::PAPER,
            observer: ObserverGains::default(),
            controller: ControllerGains::default(),
            disturbance: DisturbanceKind::Paper,
            seed: 1,
            lloyd_gain: 0.5,
            snapshots: vec![0.0, duration / 8.0, duration / 3.0, duration],
            safety: SafetyParams::default(),
            hull_radius: DEFAULT_HULL_RADIUS,
            // Lloyd's baseline covers the scenario's risk, which is only a
            // prior when there is a truth.
            lloyd: scenario.truth.is_none(),
            learning: scenario
                .truth
                .clone()
                .map(super::learn::LearningConfig::new),
            scenario,
        }
    }

    /// The same run from random starts drawn with `seed` inside `zone` (the
    /// whole region when `None`; see [`starts`]): legal for the safety
    /// parameters, headings uniform.
    pub fn with_random_starts(
        mut self,
        seed: u64,
        zone: Option<(Point, Point)>,
    ) -> Result<Config, SimError> {
        let shore = crate::geometry::shore::Shore::new(&self.scenario.region);
        let n = self.scenario.fleet.len();
        let drawn = super::starts::random_starts(
            &shore,
            n,
            seed,
            self.safety.safety_distance,
            self.safety.goal_clearance(),
            zone,
        )
        .ok_or_else(|| SimError::Io(format!("no room for {n} random starts in the region")))?;
        let vessels = drawn
            .iter()
            .zip(self.scenario.fleet.vessels())
            .map(|((q, _), v)| Vessel { position: *q, ..*v })
            .collect();
        self.scenario.fleet = Fleet::new(vessels)
            .map_err(|e| SimError::Scenario(crate::mission::scenario::ScenarioError::Input(e)))?;
        self.headings = drawn.iter().map(|(_, psi)| *psi).collect();
        Ok(self)
    }
}

/// The hull radius of the paper's vessel as the safety watch sees it [m]:
/// a 2-tonne workboat of about 4 m by 2 m, inside a disc of radius 2 m.
pub const DEFAULT_HULL_RADIUS: f64 = 2.0;
