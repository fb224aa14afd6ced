//! `seacover sim`: the whole closed loop in one process, no network,
//! deterministic for a seed (SPEC §1, issue 3).
//!
//! Dynamics, observer and controller run at the dynamics step (1 kHz by
//! default); the coverage engine and guidance run at the coordinator's tick
//! (10 Hz), exactly as the networked system splits them: between ticks each
//! vessel follows its command's line (the command and its rates) through
//! the on-board governor ([`reference`](crate::control::reference)), as
//! `seacover agent` does. Lloyd's single-integrator fleet (paper Fig. 3b) runs from
//! the same start on the same ticks.
//!
//! Guidance goes through the same [`SafetyLayer`] as the coordinator's tick
//! (reachable goals, routes round islands, the barrier filter when it is on),
//! and [`monitor`] watches the true states at every dynamics step for
//! collisions and incursions.
//!
//! This module is the shell around the pure core: it owns files (CSV, JSON,
//! figures) and the progress bar; the loop itself is [`run`], which is pure.

pub mod figures;
pub mod monitor;
pub mod output;
pub mod record;
pub mod starts;
pub mod study;

use crate::control::controller::{ControllerGains, control};
use crate::control::disturbance::{Disturbance, Gusts};
use crate::control::guidance::{Command, Guidance, GuidanceGains};
use crate::control::model::{State, VesselParams, step};
use crate::control::observer::{Observer, ObserverGains};
use crate::control::reference::{Governor, Line, Peaks, agility};
use crate::control::safety::{SafetyLayer, SafetyParams};
use crate::control::{Vec3, lloyd};
use crate::coverage::{CellGeometry, Fleet, Options, Vessel, evaluate};
use crate::geometry::Point;
use crate::scenario::Scenario;
use monitor::{Monitor, SafetyRecord};

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
    fn model(&self, i: usize, seed: u64) -> Disturbance {
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
}

/// One vessel at one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VesselSample {
    pub state: State,
    pub command: Command,
    pub centroid: Point,
    /// The reachable goal the vessel steers for (the centroid, projected).
    pub goal: Point,
    /// Whether the safety filter changed this tick's command.
    pub intervened: bool,
    pub tau_d: Vec3,
    pub estimate: Vec3,
    /// The reference the controller tracks at this instant (the on-board
    /// governor's output; see `control::reference`).
    pub reference: (f64, f64),
    /// The largest tracking errors (u − u_ref, r − r_ref, signed) at any
    /// dynamics step since the previous tick: what Fig. 2 plots, so that
    /// nothing between ticks is hidden.
    pub peak_error: (f64, f64),
}

/// The fleet at one tick.
#[derive(Debug, Clone, PartialEq)]
pub struct Tick {
    pub t: f64,
    pub h: f64,
    pub lloyd_h: f64,
    pub vessels: Vec<VesselSample>,
    pub lloyd_positions: Vec<Point>,
}

/// The partition kept at a snapshot time.
#[derive(Debug, Clone)]
pub struct Snapshot {
    pub t: f64,
    pub cells: Vec<CellGeometry>,
}

/// Figures measured over the whole run at the dynamics step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Measures {
    pub observer_error_max_after_10s: f64,
    pub u_error_max_after_20s: f64,
    pub r_error_max_after_20s: f64,
    /// Largest gap after 20 s between the command line and the reference
    /// the on-board governor gave the controller (what it held back as
    /// more than the hull could do; see `control::reference`).
    pub u_lag_max_after_20s: f64,
    pub r_lag_max_after_20s: f64,
    /// Last time any observer error exceeded 0.05.
    pub t1_observer: f64,
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct Run {
    pub ticks: Vec<Tick>,
    pub snapshots: Vec<Snapshot>,
    pub measures: Measures,
    /// Collisions, incursions, closest approaches and interventions.
    pub safety: SafetyRecord,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("vessel {vessel} left the representable range at t = {t:.1} s")]
    Diverged { vessel: usize, t: f64 },
    #[error(transparent)]
    Scenario(#[from] crate::scenario::ScenarioError),
    #[error("{0}")]
    Io(String),
    #[error("drawing {0}")]
    Figure(String),
}

/// The paper's scenario (paper section 5), built in.
pub const PAPER_SCENARIO: &str = include_str!("../../examples/paper.json");

/// A harbour with three islands and a pier, 30 vessels, built in
/// (`harbour-8` takes its first eight vessels).
pub const HARBOUR_SCENARIO: &str = include_str!("../../examples/harbour.json");

/// Names of the built-in scenarios.
pub const BUILT_IN: [&str; 3] = ["paper", "harbour-8", "harbour-30"];

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
pub fn load_scenario_document(spec: &str) -> Result<crate::scenario::LocalScenario, SimError> {
    let (text, keep) = match spec {
        "paper" => (PAPER_SCENARIO.to_string(), usize::MAX),
        "harbour-8" => (HARBOUR_SCENARIO.to_string(), 8),
        "harbour-30" => (HARBOUR_SCENARIO.to_string(), 30),
        _ => (
            std::fs::read_to_string(spec)
                .map_err(|e| SimError::Io(format!("cannot read {spec}: {e}")))?,
            usize::MAX,
        ),
    };
    let mut doc = crate::scenario::parse_document(&text)?;
    doc.vessels.truncate(keep);
    Ok(doc)
}

impl Config {
    /// A run of `duration` seconds with the defaults: 1 kHz dynamics, 10 Hz
    /// ticks, the paper's disturbances, snapshots at 0, T/8, T/3 and T.
    pub fn new(scenario: Scenario, headings: Vec<f64>, duration: f64) -> Config {
        Config {
            scenario,
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
            lloyd: true,
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
        let drawn = starts::random_starts(
            &shore,
            n,
            seed,
            self.safety.safety_distance,
            self.safety.goal_clearance(),
            zone,
        )
        .ok_or_else(|| SimError::Io(format!("no room for {n} random starts in the region")))?;
        let beta = self.scenario.fleet.beta();
        let vessels = drawn
            .iter()
            .zip(self.scenario.fleet.vessels())
            .map(|((q, _), v)| Vessel {
                position: *q,
                k: v.k,
                beta,
            })
            .collect();
        self.scenario.fleet = Fleet::new(vessels)
            .map_err(|e| SimError::Scenario(crate::scenario::ScenarioError::Input(e)))?;
        self.headings = drawn.iter().map(|(_, psi)| *psi).collect();
        Ok(self)
    }
}

/// The hull radius of the paper's vessel as the safety watch sees it [m]:
/// a 2-tonne workboat of about 4 m by 2 m, inside a disc of radius 2 m.
pub const DEFAULT_HULL_RADIUS: f64 = 2.0;

/// Runs `config` and writes `timeseries.csv`, `summary.json`, `safety.json`
/// and (with `figures`) the five figures into `out`.
pub fn run_to_dir(
    config: &Config,
    out: &std::path::Path,
    figures: bool,
    record: Option<(&std::path::Path, &crate::scenario::LocalScenario)>,
    progress: impl FnMut(f64),
) -> Result<(output::Summary, output::SafetySummary), SimError> {
    let io = |e: std::io::Error| SimError::Io(format!("{}: {e}", out.display()));
    std::fs::create_dir_all(out).map_err(io)?;
    let started = std::time::Instant::now();
    let result = run(config, progress)?;
    if let Some((path, doc)) = record {
        record::record(path, config, doc, &result)?;
    }
    let wall = started.elapsed().as_secs_f64();
    let summary = output::Summary::new(config, &result, wall);
    let safety = output::SafetySummary::new(config, &result);
    output::write_timeseries(&out.join("timeseries.csv"), config, &result).map_err(io)?;
    output::write_summary(&out.join("summary.json"), &summary).map_err(io)?;
    output::write_safety(&out.join("safety.json"), &safety).map_err(io)?;
    if figures {
        figures::draw_all(out, config, &result).map_err(SimError::Figure)?;
    }
    Ok((summary, safety))
}

fn fleet_at(config: &Config, positions: impl Iterator<Item = Point>) -> Option<Fleet> {
    let beta = config.scenario.fleet.beta();
    let vessels = positions
        .zip(config.scenario.fleet.vessels())
        .map(|(position, v)| Vessel {
            position,
            k: v.k,
            beta,
        })
        .collect();
    Fleet::new(vessels).ok()
}

/// Runs the closed loop. `progress` is called with the fraction done.
pub fn run(config: &Config, mut progress: impl FnMut(f64)) -> Result<Run, SimError> {
    let n = config.scenario.fleet.len();
    let region = &config.scenario.region;
    let risk = &config.scenario.risk;
    let options = Options::default();
    let disturbances: Vec<Disturbance> = (0..n)
        .map(|i| config.disturbance.model(i, config.seed))
        .collect();
    // Paper Assumption 2: b₂ must exceed |τ̇_d|, which for a force fixed in
    // the earth frame grows with the turn rate the guidance may ask for.
    let rate = disturbances
        .iter()
        .map(|d| d.rate_bound(config.guidance.max_yaw_rate).amax())
        .fold(0.0, f64::max);
    let observer_gains = if ObserverGains::for_rate(rate).b2 > config.observer.b2 {
        ObserverGains::for_rate(rate)
    } else {
        config.observer
    };
    let mut states: Vec<State> = config
        .scenario
        .fleet
        .vessels()
        .iter()
        .zip(&config.headings)
        .map(|(v, &psi)| State {
            x: v.position.x,
            y: v.position.y,
            psi,
            vel: Vec3::zeros(),
        })
        .collect();
    let mut observers: Vec<Observer> = (0..n)
        .map(|_| Observer::new(config.vessel, observer_gains))
        .collect();
    // Each simulated vessel declares what its governor can follow, as the
    // networked one does in its hello.
    let mut guidance: Vec<Guidance> = (0..n)
        .map(|_| {
            let mut g = Guidance::new(config.guidance);
            g.agility = agility(&config.vessel);
            g
        })
        .collect();
    let layer = SafetyLayer::new(region, config.safety)
        .map_err(|e| SimError::Scenario(crate::scenario::ScenarioError::Input(e)))?;
    let mut monitor = Monitor::new(
        n,
        config.hull_radius,
        config.safety.safety_distance,
        config.safety.shore_distance,
        1.0 / config.tick_hz,
    );
    let mut lines = vec![Line::HOLD; n];
    let mut peaks = vec![Peaks::default(); n];
    let mut governors: Vec<Governor> = states
        .iter()
        .map(|s| Governor::new(config.vessel, s.vel))
        .collect();
    let mut commands = vec![Command::default(); n];
    let mut lloyd_positions: Vec<Point> = config
        .scenario
        .fleet
        .vessels()
        .iter()
        .map(|v| v.position)
        .collect();

    let h = config.step;
    let steps = (config.duration / h).round() as usize;
    let per_tick = ((1.0 / config.tick_hz) / h).round().max(1.0) as usize;
    let mut ticks = Vec::with_capacity(steps / per_tick + 1);
    let mut snapshots = Vec::new();
    let mut pending_snapshots: Vec<f64> = config.snapshots.clone();
    let mut measures = Measures::default();
    // Every vessel's tracking after 20 s.
    let mut late = Peaks::default();

    for k in 0..=steps {
        let t = k as f64 * h;
        // Every tick, and the final state even when the duration is not a
        // whole number of ticks.
        if k % per_tick == 0 || k == steps {
            let diverged = states.iter().position(|s| {
                !(s.x.is_finite() && s.y.is_finite()) || s.x.abs() > 1e6 || s.y.abs() > 1e6
            });
            if let Some(vessel) = diverged {
                return Err(SimError::Diverged { vessel, t });
            }
            let fleet = fleet_at(config, states.iter().map(|s| Point { x: s.x, y: s.y }))
                .ok_or(SimError::Diverged { vessel: 0, t })?;
            let eval = evaluate(region, risk, &fleet, &options);
            let lloyd_eval = if config.lloyd {
                let lloyd_fleet = fleet_at(config, lloyd_positions.iter().copied())
                    .ok_or(SimError::Diverged { vessel: 0, t })?;
                Some(evaluate(region, risk, &lloyd_fleet, &options))
            } else {
                None
            };

            let safe = layer.commands(t, &states, &eval.cells, &mut guidance);
            monitor.tick(&states, layer.shore(), safe.iter().map(|c| c.intervened));
            let mut samples = Vec::with_capacity(n);
            for i in 0..n {
                let c = eval.cells[i].centroid;
                commands[i] = safe[i].command;
                lines[i] = Line {
                    u_d: commands[i].u_d,
                    r_d: commands[i].r_d,
                    u_d_dot: commands[i].u_d_dot,
                    r_d_dot: commands[i].r_d_dot,
                };
                samples.push(VesselSample {
                    state: states[i],
                    command: commands[i],
                    centroid: c,
                    goal: safe[i].goal,
                    intervened: safe[i].intervened,
                    tau_d: disturbances[i].value(t, states[i].psi),
                    estimate: observers[i].estimate(),
                    reference: governors[i].current(),
                    peak_error: std::mem::take(&mut peaks[i]).error,
                });
            }
            if let Some(pos) = pending_snapshots.iter().position(|&ts| ts <= t + 1e-9) {
                pending_snapshots.remove(pos);
                snapshots.push(Snapshot {
                    t,
                    cells: eval.cells.iter().map(|c| c.geometry.clone()).collect(),
                });
            }
            ticks.push(Tick {
                t,
                h: eval.h,
                lloyd_h: lloyd_eval.as_ref().map_or(f64::NAN, |e| e.h),
                vessels: samples,
                lloyd_positions: lloyd_positions.clone(),
            });
            if let Some(lloyd_eval) = lloyd_eval {
                let centroids: Vec<Point> = lloyd_eval.cells.iter().map(|c| c.centroid).collect();
                lloyd::step(
                    &mut lloyd_positions,
                    &centroids,
                    config.lloyd_gain,
                    per_tick as f64 * h,
                );
            }
            progress(t / config.duration);
        }
        if k == steps {
            break;
        }
        for i in 0..n {
            let s = states[i];
            observers[i].measure(s.vel, h);
            let est = observers[i].estimate();
            let truth = disturbances[i].value(t, s.psi);
            if t >= 10.0 {
                measures.observer_error_max_after_10s = measures
                    .observer_error_max_after_10s
                    .max((est - truth).amax());
            }
            if (est - truth).amax() > 0.05 {
                measures.t1_observer = t;
            }
            // Between ticks the command is a line along its rates; the
            // governor gives the controller what of it the hull can follow.
            let since = (k % per_tick) as f64 * h;
            let line = lines[i].at(since);
            let reference = governors[i].step(&line, s.vel, est, h);
            peaks[i].record(s.vel, &line, &reference);
            if t >= 20.0 {
                late.record(s.vel, &line, &reference);
            }
            let (tu, tr) = control(&config.vessel, &config.controller, s.vel, &reference, est);
            let dist = &disturbances[i];
            let (next, applied) = step(&config.vessel, &s, tu, tr, t, h, |t, st| {
                dist.value(t, st.psi)
            });
            observers[i].actuate(Vec3::new(applied.0, 0.0, applied.1));
            states[i] = next;
        }
        monitor.step(&states, layer.shore());
    }
    measures.u_error_max_after_20s = late.error.0.abs();
    measures.r_error_max_after_20s = late.error.1.abs();
    measures.u_lag_max_after_20s = late.lag.0.abs();
    measures.r_lag_max_after_20s = late.lag.1.abs();
    Ok(Run {
        ticks,
        snapshots,
        measures,
        safety: monitor.record,
    })
}
