//! The closed loop itself, pure and deterministic for a seed: dynamics,
//! observer and controller at the dynamics step, coverage and guidance at
//! the tick, and what it records ([`Run`]).

use super::config::{Config, SimError};
use super::learn::Learning;
use super::monitor::{Monitor, SafetyRecord};
use crate::control::controller::control;
use crate::control::disturbance::Disturbance;
use crate::control::guidance::{Command, Guidance};
use crate::control::model::{State, step};
use crate::control::observer::{Observer, ObserverGains};
use crate::control::reference::{Governor, Line, Peaks, agility};
use crate::control::safety::SafetyLayer;
use crate::control::{Vec3, lloyd};
use crate::coverage::{CellGeometry, Fleet, Options, Vessel, evaluate};
use crate::geometry::Point;

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
    /// H of the density the fleet covers.
    pub h: f64,
    /// H judged on the scenario's truth (NaN without one).
    pub h_true: f64,
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
    /// Samples taken and fits made, when the scenario has a truth.
    pub learned: Option<Learned>,
    /// Every sample and belief, when the learning config asked to log.
    pub learn_log: Option<super::learn::LearnLog>,
}

/// What a run with a truth sampled and fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Learned {
    pub samples: usize,
    pub fits: usize,
}

pub(super) fn fleet_at(config: &Config, positions: impl Iterator<Item = Point>) -> Option<Fleet> {
    let vessels = positions
        .zip(config.scenario.fleet.vessels())
        .map(|(position, v)| Vessel { position, ..*v })
        .collect();
    Fleet::new(vessels).ok()
}

/// Runs the closed loop. `progress` is called with the fraction done.
pub fn run(config: &Config, mut progress: impl FnMut(f64)) -> Result<Run, SimError> {
    let n = config.scenario.fleet.len();
    let layer = SafetyLayer::new(&config.scenario.region, config.safety)
        .map_err(|e| SimError::Scenario(crate::mission::scenario::ScenarioError::Input(e)))?;
    let mut monitor = Monitor::new(
        n,
        config.hull_radius,
        config.safety.safety_distance,
        config.safety.shore_distance,
        1.0 / config.tick_hz,
    );
    let mut hulls = Hulls::new(config);
    let mut learning = match &config.learning {
        Some(l) => Some(
            Learning::new(
                l,
                &config.scenario.region,
                &config.scenario.risk,
                config.seed,
            )
            .map_err(|e| SimError::Scenario(e.into()))?,
        ),
        None => None,
    };
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
            let period = per_tick as f64 * h;
            let (tick, eval) =
                hulls.tick(config, t, &layer, &mut monitor, period, learning.as_mut())?;
            if let Some(pos) = pending_snapshots.iter().position(|&ts| ts <= t + 1e-9) {
                pending_snapshots.remove(pos);
                snapshots.push(Snapshot {
                    t,
                    cells: eval.cells.iter().map(|c| c.geometry.clone()).collect(),
                });
            }
            ticks.push(tick);
            progress(t / config.duration);
        }
        if k == steps {
            break;
        }
        let since = (k % per_tick) as f64 * h;
        hulls.step(config, t, since, &mut measures, &mut late);
        monitor.step(&hulls.states, layer.shore());
    }
    measures.u_error_max_after_20s = late.error.0.abs();
    measures.r_error_max_after_20s = late.error.1.abs();
    measures.u_lag_max_after_20s = late.lag.0.abs();
    measures.r_lag_max_after_20s = late.lag.1.abs();
    let learn_log = learning.as_mut().and_then(|l| l.log.take());
    Ok(Run {
        ticks,
        snapshots,
        measures,
        safety: monitor.record,
        learn_log,
        learned: learning.map(|l| Learned {
            samples: l.samples,
            fits: l.fits,
        }),
    })
}

/// Every vessel's hull, observer, guidance and governor between steps,
/// and Lloyd's fleet beside them.
struct Hulls {
    states: Vec<State>,
    disturbances: Vec<Disturbance>,
    observers: Vec<Observer>,
    guidance: Vec<Guidance>,
    governors: Vec<Governor>,
    /// Each vessel's command line since the last tick.
    lines: Vec<Line>,
    /// Each vessel's tracking peaks since the last tick.
    peaks: Vec<Peaks>,
    lloyd_positions: Vec<Point>,
}

impl Hulls {
    fn new(config: &Config) -> Hulls {
        let n = config.scenario.fleet.len();
        let disturbances: Vec<Disturbance> = (0..n)
            .map(|i| config.disturbance.model(i, config.seed))
            .collect();
        // Paper Assumption 2: b₂ must exceed |τ̇_d|, which for a force fixed
        // in the earth frame grows with the turn rate the guidance may ask
        // for.
        let rate = disturbances
            .iter()
            .map(|d| d.rate_bound(config.guidance.max_yaw_rate).amax())
            .fold(0.0, f64::max);
        let observer_gains = if ObserverGains::for_rate(rate).b2 > config.observer.b2 {
            ObserverGains::for_rate(rate)
        } else {
            config.observer
        };
        let vessels = config.scenario.fleet.vessels();
        let states: Vec<State> = vessels
            .iter()
            .zip(&config.headings)
            .map(|(v, &psi)| State {
                x: v.position.x,
                y: v.position.y,
                psi,
                vel: Vec3::zeros(),
            })
            .collect();
        Hulls {
            observers: (0..n)
                .map(|_| Observer::new(config.vessel, observer_gains))
                .collect(),
            // Each simulated vessel declares what its governor can follow,
            // as the networked one does in its hello.
            guidance: (0..n)
                .map(|_| {
                    let mut g = Guidance::new(config.guidance);
                    g.agility = agility(&config.vessel);
                    g
                })
                .collect(),
            governors: states
                .iter()
                .map(|s| Governor::new(config.vessel, s.vel))
                .collect(),
            lines: vec![Line::HOLD; n],
            peaks: vec![Peaks::default(); n],
            lloyd_positions: vessels.iter().map(|v| v.position).collect(),
            states,
            disturbances,
        }
    }

    /// A tick at `t`: the partition, every vessel's command through the
    /// safety layer, what the tick records, and Lloyd's step over `period`.
    fn tick(
        &mut self,
        config: &Config,
        t: f64,
        layer: &SafetyLayer,
        monitor: &mut Monitor,
        period: f64,
        learning: Option<&mut Learning>,
    ) -> Result<(Tick, crate::coverage::Evaluation), SimError> {
        let region = &config.scenario.region;
        let options = Options::default();
        let diverged = self.states.iter().position(|s| {
            !(s.x.is_finite() && s.y.is_finite()) || s.x.abs() > 1e6 || s.y.abs() > 1e6
        });
        if let Some(vessel) = diverged {
            return Err(SimError::Diverged { vessel, t });
        }
        let at: Vec<Point> = self
            .states
            .iter()
            .map(|s| Point { x: s.x, y: s.y })
            .collect();
        let fleet =
            fleet_at(config, at.iter().copied()).ok_or(SimError::Diverged { vessel: 0, t })?;
        let (eval, h_true) = match learning {
            Some(l) => {
                let velocities: Vec<Point> = self
                    .states
                    .iter()
                    .map(|s| {
                        let (x, y) = s.ground_velocity();
                        Point { x, y }
                    })
                    .collect();
                l.tick(t, &at, &velocities, &fleet);
                let mut eval = evaluate(region, &l.cover, &fleet, &options);
                if let Some(centroids) = l.centroids(&fleet) {
                    for (cell, c) in eval.cells.iter_mut().zip(centroids) {
                        cell.centroid = c;
                    }
                }
                let h_true = if l.covers_truth() {
                    eval.h
                } else {
                    evaluate(region, l.truth(), &fleet, &options).h
                };
                (eval, h_true)
            }
            None => (
                evaluate(region, &config.scenario.risk, &fleet, &options),
                f64::NAN,
            ),
        };
        let risk = &config.scenario.risk;
        let lloyd_eval = if config.lloyd {
            let lloyd_fleet = fleet_at(config, self.lloyd_positions.iter().copied())
                .ok_or(SimError::Diverged { vessel: 0, t })?;
            Some(evaluate(region, risk, &lloyd_fleet, &options))
        } else {
            None
        };

        let safe = layer.commands(t, &self.states, &eval.cells, &mut self.guidance);
        monitor.tick(
            &self.states,
            layer.shore(),
            safe.iter().map(|c| c.intervened),
        );
        let mut samples = Vec::with_capacity(self.states.len());
        for (i, safe) in safe.iter().enumerate() {
            let command = safe.command;
            self.lines[i] = Line {
                u_d: command.u_d,
                r_d: command.r_d,
                u_d_dot: command.u_d_dot,
                r_d_dot: command.r_d_dot,
            };
            samples.push(VesselSample {
                state: self.states[i],
                command,
                centroid: eval.cells[i].centroid,
                goal: safe.goal,
                intervened: safe.intervened,
                tau_d: self.disturbances[i].value(t, self.states[i].psi),
                estimate: self.observers[i].estimate(),
                reference: self.governors[i].current(),
                peak_error: std::mem::take(&mut self.peaks[i]).error,
            });
        }
        let tick = Tick {
            t,
            h: eval.h,
            h_true,
            lloyd_h: lloyd_eval.as_ref().map_or(f64::NAN, |e| e.h),
            vessels: samples,
            lloyd_positions: self.lloyd_positions.clone(),
        };
        if let Some(lloyd_eval) = lloyd_eval {
            let centroids: Vec<Point> = lloyd_eval.cells.iter().map(|c| c.centroid).collect();
            lloyd::step(
                &mut self.lloyd_positions,
                &centroids,
                config.lloyd_gain,
                period,
            );
        }
        Ok((tick, eval))
    }

    /// One dynamics step from `t`, `since` the last tick: each vessel's
    /// observer, governor, controller and hull.
    fn step(
        &mut self,
        config: &Config,
        t: f64,
        since: f64,
        measures: &mut Measures,
        late: &mut Peaks,
    ) {
        let h = config.step;
        for i in 0..self.states.len() {
            let s = self.states[i];
            self.observers[i].measure(s.vel, h);
            let est = self.observers[i].estimate();
            let truth = self.disturbances[i].value(t, s.psi);
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
            let line = self.lines[i].at(since);
            let reference = self.governors[i].step(&line, s.vel, est, h);
            self.peaks[i].record(s.vel, &line, &reference);
            if t >= 20.0 {
                late.record(s.vel, &line, &reference);
            }
            let (tu, tr) = control(&config.vessel, &config.controller, s.vel, &reference, est);
            let dist = &self.disturbances[i];
            let (next, applied) = step(&config.vessel, &s, tu, tr, t, h, |t, st| {
                dist.value(t, st.psi)
            });
            self.observers[i].actuate(Vec3::new(applied.0, 0.0, applied.1));
            self.states[i] = next;
        }
    }
}
