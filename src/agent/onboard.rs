//! The on-board simulation of one vessel: the dynamics (RK4, 1 ms), the
//! disturbance, the observer and the controller in simulated time, tracking
//! the newest command through the governor. Both kinds of simulated agent
//! run it: the linked one (commands from the coordinator) and the peer node
//! (commands from its own loop on board).
//!
//! Without a command younger than 1 s, or told to hold, the vessel keeps
//! station with its own guidance ([`Keeper`]): it brakes its velocity over
//! ground (sway included, which zero surge and yaw commands leave to drift
//! for a minute on the paper's hull), then holds the point where it stopped,
//! quietly once there (the guidance's station keeping), as ArduPilot's HOLD
//! does for a real boat.

use crate::control::Vec3;
use crate::control::controller::{ControllerGains, control};
use crate::control::disturbance::Disturbance;
use crate::control::guidance::{Agility, Guidance, GuidanceGains};
use crate::control::model::{State, VesselParams, step};
use crate::control::observer::{Observer, ObserverGains};
use crate::control::reference::{Governor, Line, Peaks, agility};
use crate::protocol::{CommandDocument, PoseDocument};

/// One simulated vessel's settings.
#[derive(Debug, Clone)]
pub struct VesselConfig {
    pub id: String,
    /// Index used by the paper's disturbance model (1-based).
    pub index: usize,
    pub start: State,
    pub params: VesselParams,
}

/// The on-board simulation of one vessel.
pub(crate) struct Onboard {
    pub(crate) params: VesselParams,
    pub(crate) state: State,
    observer: Observer,
    controller: ControllerGains,
    disturbance: Disturbance,
    pub(crate) t: f64,
    /// The newest command and the on-board time it arrived.
    pub(crate) command: Option<(CommandDocument, f64)>,
    governor: Governor,
    /// Largest tracking error and command lag since the previous pose.
    peaks: Peaks,
    /// Station keeping while there is no command to follow; `None` for a
    /// peer fleet's vessel, whose commands come from its own loop on board
    /// and which holds with zero speeds as before (its loop's safety filter
    /// keeps it clear of the others; the keeper's guidance would not).
    keeper: Option<Keeper>,
}

/// How often the station keeper steers, like a coordinator's tick [s].
const KEEPER_PERIOD: f64 = 0.1;
/// Braking is over below this speed over ground [m/s] or after
/// [`BRAKE_TIME`]; the vessel then holds where it is.
const SETTLED: f64 = 0.1;
const BRAKE_TIME: f64 = 10.0;

/// The vessel's own station keeping: brake, then hold the point where it
/// stopped, steered every [`KEEPER_PERIOD`] by the same guidance a
/// coordinator uses.
struct Keeper {
    guidance: Guidance,
    /// When holding began, and the point held once braking is over.
    since: Option<f64>,
    point: Option<(f64, f64)>,
    /// The newest line and when it was computed.
    line: Option<(Line, f64)>,
}

impl Keeper {
    fn new(params: &VesselParams) -> Keeper {
        let mut guidance = Guidance::new(GuidanceGains::default());
        let a = agility(params);
        guidance.agility = Agility {
            yaw_accel: a.yaw_accel,
            surge_accel: a.surge_accel,
        };
        Keeper {
            guidance,
            since: None,
            point: None,
            line: None,
        }
    }

    /// Commands are being followed again: the next hold starts afresh.
    fn release(&mut self, params: &VesselParams) {
        if self.since.is_some() {
            *self = Keeper::new(params);
        }
    }

    /// The line to follow at `t` for a vessel in `state`.
    fn line(&mut self, t: f64, state: &State) -> crate::control::controller::Reference {
        if let Some((line, at)) = self.line
            && t - at < KEEPER_PERIOD
        {
            return line.at(t - at);
        }
        let since = *self.since.get_or_insert(t);
        let (gx, gy) = state.ground_velocity();
        if self.point.is_none() && (gx.hypot(gy) < SETTLED || t - since >= BRAKE_TIME) {
            self.point = Some((state.x, state.y));
        }
        let c = match self.point {
            Some(point) => self.guidance.update(t, state, point),
            // Braking: a desired velocity over ground of zero, which the
            // `course` law reaches with the bow along the velocity error.
            None => self.guidance.track(
                t,
                state,
                (state.x, state.y),
                0.0,
                (0.0, 0.0),
                crate::control::guidance::UNBOUNDED,
            ),
        };
        let line = Line {
            u_d: c.u_d,
            r_d: c.r_d,
            u_d_dot: c.u_d_dot,
            r_d_dot: c.r_d_dot,
        };
        self.line = Some((line, t));
        line.at(0.0)
    }
}

impl Onboard {
    pub(crate) fn new(v: &VesselConfig) -> Self {
        Onboard {
            params: v.params,
            state: v.start,
            observer: Observer::new(v.params, ObserverGains::default()),
            controller: ControllerGains::default(),
            disturbance: Disturbance::Paper { index: v.index },
            t: 0.0,
            command: None,
            governor: Governor::new(v.params, v.start.vel),
            peaks: Peaks::default(),
            keeper: Some(Keeper::new(&v.params)),
        }
    }

    /// Without a command, holds with zero speeds instead of keeping
    /// station with its own guidance (a peer fleet's vessel).
    pub(crate) fn without_keeper(mut self) -> Self {
        self.keeper = None;
        self
    }

    /// Advances `seconds` of simulated time in 1 ms steps.
    pub(crate) fn advance(&mut self, seconds: f64) {
        let h = 1e-3;
        let steps = (seconds / h).round() as usize;
        for _ in 0..steps {
            let line = match &self.command {
                Some((c, at)) if self.t - at <= 1.0 && c.hold.is_none() => {
                    if let Some(k) = self.keeper.as_mut() {
                        k.release(&self.params);
                    }
                    Line {
                        u_d: c.u_d,
                        r_d: c.r_d,
                        u_d_dot: c.u_d_dot,
                        r_d_dot: c.r_d_dot,
                    }
                    .at(self.t - at)
                }
                // No command, a stale one, or one to hold: keep station.
                _ => match self.keeper.as_mut() {
                    Some(k) => k.line(self.t, &self.state),
                    None => Line::HOLD.at(0.0),
                },
            };
            self.observer.measure(self.state.vel, h);
            let (vel, est) = (self.state.vel, self.observer.estimate());
            let reference = self.governor.step(&line, vel, est, h);
            self.peaks.record(vel, &line, &reference);
            let (tu, tr) = control(&self.params, &self.controller, vel, &reference, est);
            let d = &self.disturbance;
            let (next, applied) = step(&self.params, &self.state, tu, tr, self.t, h, |t, s| {
                d.value(t, s.psi)
            });
            self.observer.actuate(Vec3::new(applied.0, 0.0, applied.1));
            self.state = next;
            self.t += h;
        }
    }

    /// The pose as the vessel's sensors would give it: positions to the
    /// millimetre, angles to 10 µrad, speeds to 0.1 mm/s, its clock and
    /// forces to four decimals. Finer than any GNSS/INS, and it keeps the
    /// 17-digit noise of a double out of the wire and of every recording
    /// (it was most of an 8-vessel recording's size).
    /// Also starts the next interval of `tracking_error` and `command_lag`.
    pub(crate) fn pose(&mut self) -> PoseDocument {
        let Peaks { error, lag } = std::mem::take(&mut self.peaks);
        let pair = |(u, r): (f64, f64)| serde_json::json!({"u": decimals(u.abs(), 5), "r": decimals(r.abs(), 5)});
        let tau = self.disturbance.value(self.t, self.state.psi);
        let est = self.observer.estimate();
        let s = &self.state;
        let tau_d = [tau.x, tau.y, tau.z].map(|v| decimals(v, 4));
        let tau_d_hat = [est.x, est.y, est.z].map(|v| decimals(v, 4));
        PoseDocument {
            t: decimals(self.t, 4),
            x: decimals(s.x, 3),
            y: decimals(s.y, 3),
            psi: decimals(s.psi, 5),
            u: decimals(s.vel.x, 4),
            v: decimals(s.vel.y, 4),
            r: decimals(s.vel.z, 5),
            controlled: None,
            telemetry: Some(serde_json::json!({
                "tau_d": tau_d,
                "tau_d_hat": tau_d_hat,
                "tracking_error": pair(error),
                "command_lag": pair(lag),
            })),
            fix: None,
        }
    }
}

/// `v` rounded to `n` decimals, as the nearest double to that decimal (so
/// that it prints as the decimal).
fn decimals(v: f64, n: i32) -> f64 {
    let scale = 10f64.powi(n);
    (v * scale).round() / scale
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::model::VesselParams;

    /// A vessel under way that loses its commands keeps station: with
    /// zero surge and yaw commands alone the paper's hull slid on at
    /// its sway speed (its sway time constant is 67 s).
    fn drift_after_losing_commands(params: VesselParams, index: usize) -> (f64, f64) {
        let start = State {
            x: 50.0,
            y: 50.0,
            psi: 0.3,
            vel: Vec3::zeros(),
        };
        let mut vessel = Onboard::new(&VesselConfig {
            id: "usv-1".into(),
            index,
            start,
            params,
        });
        // Ten seconds at 1.5 m/s turning, so that it sways too, under
        // commands; then none.
        for i in 0..100 {
            let c = CommandDocument {
                tick: i,
                u_d: 1.5,
                r_d: 0.15,
                u_d_dot: 0.0,
                r_d_dot: 0.0,
                centroid: [0.0, 0.0],
                e: 0.0,
                psi_e: 0.0,
                hold: None,
                station: None,
            };
            vessel.command = Some((c, vessel.t));
            vessel.advance(0.1);
        }
        let (gx, gy) = vessel.state.ground_velocity();
        assert!(gx.hypot(gy) > 1.0, "under way before the loss");
        let lost = vessel.t;
        while vessel.keeper.as_ref().expect("a keeper").point.is_none() {
            vessel.advance(0.1);
            assert!(vessel.t - lost <= BRAKE_TIME + 1.0, "never settled");
        }
        let braking = vessel.t - lost;
        let (px, py) = vessel
            .keeper
            .as_ref()
            .and_then(|k| k.point)
            .expect("holding");
        let mut drift: f64 = 0.0;
        for _ in 0..600 {
            vessel.advance(0.1);
            drift = drift.max((vessel.state.x - px).hypot(vessel.state.y - py));
        }
        (braking, drift)
    }

    #[test]
    fn a_vessel_without_commands_holds_station_within_two_metres_for_a_minute() {
        for (name, params) in [
            ("paper", VesselParams::PAPER),
            ("otter", VesselParams::OTTER),
        ] {
            for index in [1, 4] {
                let (braking, drift) = drift_after_losing_commands(params, index);
                eprintln!("{name} #{index}: braked in {braking:.1} s, drift {drift:.3} m");
                assert!(
                    drift < 2.0,
                    "{name} #{index}: drifted {drift:.2} m in 60 s (braked in {braking:.1} s)"
                );
            }
        }
    }
}
