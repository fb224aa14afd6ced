//! The on-board simulation of one vessel: the dynamics (RK4, 1 ms), the
//! disturbance, the observer and the controller in simulated time, tracking
//! the newest command through the governor and holding station when it is
//! more than 1 s old. Both kinds of simulated agent run it: the linked one
//! (commands from the coordinator) and the peer node (commands from its own
//! loop on board).

use crate::control::Vec3;
use crate::control::controller::{ControllerGains, control};
use crate::control::disturbance::Disturbance;
use crate::control::model::{State, VesselParams, step};
use crate::control::observer::{Observer, ObserverGains};
use crate::control::reference::{Governor, Line, Peaks};
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
        }
    }

    /// Advances `seconds` of simulated time in 1 ms steps.
    pub(crate) fn advance(&mut self, seconds: f64) {
        let h = 1e-3;
        let steps = (seconds / h).round() as usize;
        for _ in 0..steps {
            let line = match &self.command {
                Some((c, at)) if self.t - at <= 1.0 => Line {
                    u_d: c.u_d,
                    r_d: c.r_d,
                    u_d_dot: c.u_d_dot,
                    r_d_dot: c.r_d_dot,
                }
                .at(self.t - at),
                // No command, or a stale one: hold station.
                _ => Line::HOLD.at(0.0),
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
        }
    }
}

/// `v` rounded to `n` decimals, as the nearest double to that decimal (so
/// that it prints as the decimal).
fn decimals(v: f64, n: i32) -> f64 {
    let scale = 10f64.powi(n);
    (v * scale).round() / scale
}
