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

/// How far from its arrival a command's line may start, in tick periods
/// ([`Onboard::receive`]): a command arriving just as the previous one's
/// line starts is a period early, and a reading off a clock that advances a
/// pose period at a time is late by up to that.
const LEEWAY: f64 = 1.5;

/// Commands at most waiting for their lines to start ([`Onboard::receive`]).
const PENDING: usize = 3;

/// A line due within this of now [s] starts now: the clock sums 1 ms steps,
/// so it reaches a tick's time only to within rounding.
const DUE_SLACK: f64 = 1e-6;

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
    /// The newest command and the on-board time its line starts at
    /// ([`Onboard::receive`]).
    pub(crate) command: Option<(CommandDocument, f64)>,
    /// Commands whose lines start later than now, and when, oldest first.
    pending: std::collections::VecDeque<(CommandDocument, f64)>,
    /// The coordinator's tick period [mission s], from its welcome.
    pub(crate) tick_period: Option<f64>,
    governor: Governor,
    /// Largest tracking error and command lag since the previous pose.
    peaks: Peaks,
    /// Station keeping while there is no command to follow; `None` for a
    /// peer fleet's vessel, whose commands come from its own loop on board
    /// and which holds with zero speeds as before (its loop's safety filter
    /// keeps it clear of the others; the keeper's guidance would not).
    keeper: Option<Keeper>,
    /// How long after its arrival a re-anchored line starts [s]
    /// ([`Onboard::paced`]).
    playout: f64,
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
            pending: std::collections::VecDeque::new(),
            tick_period: None,
            governor: Governor::new(v.params, v.start.vel),
            peaks: Peaks::default(),
            keeper: Some(Keeper::new(&v.params)),
            playout: 0.0,
        }
    }

    /// Without a command, holds with zero speeds instead of keeping
    /// station with its own guidance (a peer fleet's vessel).
    pub(crate) fn without_keeper(mut self) -> Self {
        self.keeper = None;
        self
    }

    /// Advanced `period` at a time by its caller ([`Onboard::advance`]),
    /// so that its clock reads arrivals up to that late: every command's
    /// line starts that much after the first's arrival (see
    /// [`Onboard::receive`]).
    pub(crate) fn paced(mut self, period: f64) -> Self {
        self.playout = period;
        self
    }

    /// Takes a command from the coordinator. Its line starts at its tick:
    /// the coordinator computes tick N's line to continue tick N − 1's
    /// from N / tick_hz on, so the vessel starts it one tick period after
    /// the previous one's start, not when it happens to arrive. (The
    /// vessel's clock advances a pose period at a time, so the arrival
    /// read off it jitters by that much: on the paper's hull turning at
    /// 0.75 rad/s², 50 ms is a 0.04 rad/s step in the command.) Until
    /// then the previous line goes on; a line that starts in the past is
    /// taken where it has got to, a step where the line turned at its tick.
    /// A first command, one after a restarted count, or one whose tick is
    /// more than [`LEEWAY`] periods off the arrival (the link stalled, or
    /// the two clocks drifted apart) anchors the timeline one clock period
    /// ([`Onboard::paced`]) after its arrival is read: a jitter buffer. The
    /// clock reads an arrival at the end of the period it falls in, so a
    /// later command that comes a little later in that phase than the
    /// first is read a whole period later; on a timeline anchored at the
    /// first's reading its line would start a period before it is read.
    /// The hull follows the coordinator's lines a period later instead.
    pub(crate) fn receive(&mut self, command: CommandDocument) {
        self.start_due();
        let newest = self.pending.back().or(self.command.as_ref());
        let at = match (newest, self.tick_period) {
            (Some((previous, started)), Some(period)) if command.tick > previous.tick => {
                let due = started + (command.tick - previous.tick) as f64 * period;
                if (due - self.t).abs() <= LEEWAY * period {
                    due
                } else {
                    self.t + self.playout
                }
            }
            _ => self.t + self.playout,
        };
        if at > self.t {
            // Never more than a few ahead (the link keeps one command in
            // flight): past that the oldest starts now.
            if self.pending.len() >= PENDING {
                self.command = self.pending.pop_front();
            }
            self.pending.push_back((command, at));
        } else {
            self.pending.clear();
            self.command = Some((command, at));
        }
    }

    /// Makes the newest pending command whose line has started the one
    /// followed. (A line that starts at the end of an advance is due
    /// before the next command arrives: checked on arrival too.)
    fn start_due(&mut self) {
        while let Some((_, at)) = self.pending.front()
            && *at <= self.t + DUE_SLACK
        {
            self.command = self.pending.pop_front();
        }
    }

    /// Advances `seconds` of simulated time in 1 ms steps.
    pub(crate) fn advance(&mut self, seconds: f64) {
        let h = 1e-3;
        let steps = (seconds / h).round() as usize;
        for _ in 0..steps {
            self.start_due();
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

    /// The paper's hull at rest at (50, 50), heading east.
    fn paper_vessel() -> Onboard {
        Onboard::new(&VesselConfig {
            id: "usv-1".into(),
            index: 1,
            start: State {
                x: 50.0,
                y: 50.0,
                psi: 0.0,
                vel: Vec3::zeros(),
            },
            params: VesselParams::PAPER,
        })
    }

    /// Tick k's line of a yaw-rate ramp at 0.75 rad/s² (the paper's hull
    /// turning as hard as it declared it can), 10 Hz.
    fn ramp(tick: u64) -> CommandDocument {
        CommandDocument {
            tick,
            u_d: 0.0,
            r_d: 0.075 * tick as f64,
            u_d_dot: 0.0,
            r_d_dot: 0.75,
            centroid: [0.0, 0.0],
            e: 0.0,
            psi_e: 0.0,
            hold: None,
            station: None,
        }
    }

    /// The yaw rate the vessel's command line asks for now.
    fn asked(vessel: &Onboard) -> f64 {
        let (c, at) = vessel.command.as_ref().expect("a command");
        c.r_d + c.r_d_dot * (vessel.t - at)
    }

    /// Advances in 1 ms steps for `seconds`, checking at every step that
    /// the line followed asks for `want(t)` (to within `within`).
    fn follows(vessel: &mut Onboard, seconds: f64, want: impl Fn(f64) -> f64, within: f64) {
        for _ in 0..(seconds / 1e-3).round() as usize {
            vessel.advance(1e-3);
            let want = want(vessel.t);
            assert!(
                (asked(vessel) - want).abs() < within,
                "at {}: {} against {want}, {:?}",
                vessel.t,
                asked(vessel),
                vessel.command.as_ref().map(|(c, at)| (c.tick, *at))
            );
        }
    }

    /// [`follows`] the ramp from `t0`.
    fn follows_the_ramp(vessel: &mut Onboard, seconds: f64, t0: f64) {
        follows(vessel, seconds, |t| 0.75 * (t - t0), 1e-9);
    }

    /// The networked demo's vessels advance a pose period (50 ms) at a
    /// time and took each command at that clock's reading: commands 0.1 s
    /// apart read as 0.05 or 0.15 s apart, and the line they follow stepped
    /// by 0.0375 rad/s at each (a yaw-rate command lag of 0.04–0.048 in the
    /// tracking test, against a bound of 0.05). On the tick's timeline the
    /// ramp is followed without a step.
    #[test]
    fn a_command_starts_at_its_tick_not_when_it_arrives() {
        let mut vessel = paper_vessel();
        vessel.tick_period = Some(0.1);
        let t0 = vessel.t;
        vessel.receive(ramp(0));
        for k in 1..20 {
            // Read at 0.05 s and 0.15 s after the previous one: early
            // (taken at its tick, the previous line going on till then)
            // and late (taken where it has got to).
            follows_the_ramp(&mut vessel, if k % 2 == 1 { 0.05 } else { 0.15 }, t0);
            vessel.receive(ramp(k));
        }
        follows_the_ramp(&mut vessel, 0.15, t0);
        // A zigzag (up on even ticks, down on odd ones, so that a line
        // followed past its tick leaves it), each command arriving just as
        // the previous one's line starts, at the end of an advance: none is
        // passed over.
        let zig = |k: u64| CommandDocument {
            r_d: if k.is_multiple_of(2) { 0.0 } else { 0.075 },
            r_d_dot: if k.is_multiple_of(2) { 0.75 } else { -0.75 },
            ..ramp(k)
        };
        let t1 = vessel.t;
        let zigzag = |t: f64| {
            let phase = ((t - t1) / 0.1).rem_euclid(2.0);
            0.075 * if phase < 1.0 { phase } else { 2.0 - phase }
        };
        vessel.receive(zig(20));
        follows(&mut vessel, 0.05, zigzag, 1e-6);
        vessel.receive(zig(21));
        follows(&mut vessel, 0.05, zigzag, 1e-6);
        for k in 22..30 {
            vessel.receive(zig(k));
            follows(&mut vessel, 0.1, zigzag, 1e-6);
        }
        // After a stall longer than a tick, the line starts on arrival.
        vessel.advance(0.4);
        vessel.receive(ramp(30));
        assert!((asked(&vessel) - 2.25).abs() < 1e-9);
        // So does a first command from a restarted coordinator.
        vessel.advance(0.05);
        vessel.receive(ramp(3));
        assert!((asked(&vessel) - 0.225).abs() < 1e-9);
        // And every one when the coordinator's tick rate is not known.
        vessel.tick_period = None;
        vessel.advance(0.05);
        vessel.receive(ramp(4));
        assert!((asked(&vessel) - 0.3).abs() < 1e-9);
    }

    /// The demo's vessels read their clock a pose period (50 ms) at a time
    /// and simulate that period when they read it, ahead of the wall
    /// clock: a command that arrives a few ms after its tick's period was
    /// simulated is read a whole period late. Where the guidance turned its
    /// line at that tick (a zigzag here; 0.62 to −0.37 rad/s² in the CI run
    /// that found it), the line followed stepped by the change of slope ×
    /// 50 ms: a yaw-rate lag of 0.0503 rad/s in the tracking test, over its
    /// bound. Every command here after the first is read a period later
    /// than the first one's phase; the line followed has no step.
    #[test]
    fn a_command_read_a_clock_period_late_leaves_no_step() {
        let period = 0.05;
        let mut vessel = paper_vessel().paced(period);
        vessel.tick_period = Some(0.1);
        let zig = |k: u64| CommandDocument {
            r_d: if k.is_multiple_of(2) { 0.0 } else { 0.075 },
            r_d_dot: if k.is_multiple_of(2) { 0.75 } else { -0.75 },
            ..ramp(k)
        };
        vessel.advance(period);
        vessel.receive(zig(0));
        let mut before: Option<f64> = None;
        let mut started = None;
        for k in 1..20 {
            let seconds = if k == 1 { 0.15 } else { 0.1 };
            for _ in 0..(seconds / 1e-3_f64).round() as usize {
                vessel.advance(1e-3);
                let Some((c, at)) = vessel.command.as_ref() else {
                    continue;
                };
                started.get_or_insert(*at);
                let now = c.r_d + c.r_d_dot * (vessel.t - at);
                if let Some(b) = before {
                    assert!(
                        (now - b).abs() <= 0.75e-3 + 1e-9,
                        "at {:.3} (tick {}): {b} then {now}",
                        vessel.t,
                        c.tick
                    );
                }
                before = Some(now);
            }
            vessel.receive(zig(k));
        }
        assert!(started.is_some(), "the first command started");
    }

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
