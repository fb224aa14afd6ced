//! The on-board reference: from the commands a vessel receives, one per
//! tick, to the signal its controller tracks at every dynamics step.
//!
//! A command (u_d, r_d, u̇_d, ṙ_d) arrives every tick (100 ms by default).
//! Between ticks it defines a line, c(t) = (u_d + u̇_d (t − t_k),
//! r_d + ṙ_d (t − t_k)); at the next tick the line moves to wherever the
//! guidance says the hull should be now. Handing those lines to the
//! controller as they are gives it a step at every tick, which the
//! finite-time law answers with a moment the actuators may not have
//! (the paper's vessel has 1 rad/s² of yaw authority; a step in r_d asks for
//! an infinite one). The error it leaves is not the controller's failing
//! but the command's.
//!
//! [`Governor`] is the reference the controller is given instead: a
//! first-order follower of the line with the line's own slope fed forward,
//!
//! ```text
//! ẏ = clamp(ċ + ω (c − y), a_lo, a_hi)
//! ```
//!
//! per channel (y = u_ref or r_ref), where [a_lo, a_hi] is the acceleration
//! the actuators can still give at this instant, after damping, Coriolis
//! and the observer's disturbance estimate have taken their share and a
//! quarter of the limit is kept back for the controller's own error
//! feedback (`MARGIN`). So:
//! - y is continuous and ẏ bounded: the reference never asks for more than
//!   the hull can do, and with an exact estimate the controller tracks it
//!   exactly (paper eq. 37);
//! - a line followed along its slope is tracked with no lag (the slope is
//!   fed forward; only its jumps at ticks are smoothed, with time constant
//!   1/ω);
//! - what the governor holds back, |y − c|, is measured beside the tracking
//!   error (`command_lag` in a simulation's summary): a guidance that asks
//!   for what the hull cannot do shows there, not as a tracking error.
//!
//! Invariants: pure, deterministic, no clocks (the caller passes the step);
//! starts at the hull's own velocity, so a vessel at rest is given no step
//! when its first command arrives.

use super::Vec3;
use super::controller::Reference;
use super::guidance::Agility;
use super::model::VesselParams;

/// Share of each actuator limit the reference may use; the rest is left to
/// the controller's error feedback ∇.
const MARGIN: f64 = 0.75;

/// Bandwidth ω of the follower [1/s]: a jump at a tick is taken up with a
/// time constant of 50 ms, half a tick.
const BANDWIDTH: f64 = 20.0;

/// The command in force: its value at the instant it was computed and its
/// rates, i.e. the line c(t) from that instant on.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Line {
    /// Desired surge speed u_d at the line's instant [m/s].
    pub u_d: f64,
    /// Desired yaw rate r_d at the line's instant [rad/s].
    pub r_d: f64,
    /// The line's surge slope u̇_d [m/s²].
    pub u_d_dot: f64,
    /// The line's yaw slope ṙ_d [rad/s²].
    pub r_d_dot: f64,
}

impl Line {
    /// The line `since` seconds after its instant.
    pub fn at(&self, since: f64) -> Reference {
        Reference {
            u_d: self.u_d + self.u_d_dot * since,
            r_d: self.r_d + self.r_d_dot * since,
            u_d_dot: self.u_d_dot,
            r_d_dot: self.r_d_dot,
        }
    }

    /// Station keeping: u_d = r_d = 0.
    pub const HOLD: Line = Line {
        u_d: 0.0,
        r_d: 0.0,
        u_d_dot: 0.0,
        r_d_dot: 0.0,
    };
}

/// The command rates `params`' governor can follow without holding them
/// back: its share ([`MARGIN`]) of the actuators' acceleration at rest, the
/// weaker direction for surge. The simulated vessel declares it in its hello
/// so that the coordinator asks it only for that
/// ([`Agility`](super::guidance::Agility)); damping and the disturbance take
/// a little of it under way, which shows as a small `command_lag`.
pub fn agility(params: &VesselParams) -> Agility {
    Agility {
        yaw_accel: MARGIN * params.tau_r_max / params.m33,
        surge_accel: MARGIN * params.tau_u_max.min(params.tau_u_reverse) / params.m11,
    }
}

/// The reference one vessel's controller tracks (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Governor {
    params: VesselParams,
    u: f64,
    r: f64,
}

impl Governor {
    /// A governor for a hull with `params` moving at `vel` (u, v, r).
    pub fn new(params: VesselParams, vel: Vec3) -> Governor {
        Governor {
            params,
            u: vel.x,
            r: vel.z,
        }
    }

    /// The reference (u_ref, r_ref) now.
    pub fn current(&self) -> (f64, f64) {
        (self.u, self.r)
    }

    /// The reference for the step from now to `h` later, given the command
    /// line's value `line` now, the measured velocity `vel` and the
    /// observer's estimate of the disturbance `estimate`; advances by `h`.
    pub fn step(&mut self, line: &Reference, vel: Vec3, estimate: Vec3, h: f64) -> Reference {
        let p = &self.params;
        let (u, v, r) = (vel.x, vel.y, vel.z);
        // What the controller spends besides m (ẏ + ∇): eq. 33–34 without
        // the reference's share.
        let rest_u = p.d11 * u - p.m22 * v * r - estimate.x;
        let rest_r = p.d33 * r + (p.m22 - p.m11) * u * v - estimate.z;
        let band = |lo: f64, hi: f64, rest: f64, m: f64| {
            let (lo, hi) = ((MARGIN * lo - rest) / m, (MARGIN * hi - rest) / m);
            // Actuators already overwhelmed: ask for no change either way.
            if lo <= hi { (lo, hi) } else { (0.0, 0.0) }
        };
        let (ulo, uhi) = band(-p.tau_u_reverse, p.tau_u_max, rest_u, p.m11);
        let (rlo, rhi) = band(-p.tau_r_max, p.tau_r_max, rest_r, p.m33);
        let du = (line.u_d_dot + BANDWIDTH * (line.u_d - self.u)).clamp(ulo.min(0.0), uhi.max(0.0));
        let dr = (line.r_d_dot + BANDWIDTH * (line.r_d - self.r)).clamp(rlo.min(0.0), rhi.max(0.0));
        let reference = Reference {
            u_d: self.u,
            r_d: self.r,
            u_d_dot: du,
            r_d_dot: dr,
        };
        self.u += du * h;
        self.r += dr * h;
        reference
    }
}

/// The largest tracking error (u − u_ref, r − r_ref) and command lag
/// (c − ref) per channel over an interval, by magnitude with the sign kept:
/// what the simulator plots per tick and a networked vessel reports per
/// pose, so that nothing between two samples is hidden.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Peaks {
    /// Tracking error (u − u_ref [m/s], r − r_ref [rad/s]).
    pub error: (f64, f64),
    /// Command lag (u_d − u_ref [m/s], r_d − r_ref [rad/s]).
    pub lag: (f64, f64),
}

impl Peaks {
    /// One dynamics step: the hull at `vel`, the command line at `line`,
    /// the controller given `reference`.
    pub fn record(&mut self, vel: Vec3, line: &Reference, reference: &Reference) {
        let larger = |peak: &mut f64, x: f64| {
            if x.abs() > peak.abs() {
                *peak = x;
            }
        };
        larger(&mut self.error.0, vel.x - reference.u_d);
        larger(&mut self.error.1, vel.z - reference.r_d);
        larger(&mut self.lag.0, line.u_d - reference.u_d);
        larger(&mut self.lag.1, line.r_d - reference.r_d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const H: f64 = 1e-3;

    #[test]
    fn peaks_keep_the_largest_magnitude_with_its_sign() {
        let mut p = Peaks::default();
        let at = |u_d: f64, r_d: f64| Reference {
            u_d,
            r_d,
            ..Reference::default()
        };
        p.record(Vec3::new(1.0, 0.0, 0.5), &at(1.5, 0.5), &at(1.2, 0.6));
        p.record(Vec3::new(1.0, 0.0, 0.5), &at(1.0, 0.0), &at(1.1, 0.3));
        // u error −0.2 then −0.1: the first stays; r error −0.1 then +0.2:
        // the larger replaces it with its own sign.
        assert!((p.error.0 + 0.2).abs() < 1e-12 && (p.error.1 - 0.2).abs() < 1e-12);
        assert!((p.lag.0 - 0.3).abs() < 1e-12 && (p.lag.1 + 0.3).abs() < 1e-12);
    }

    #[test]
    fn starts_at_the_hulls_velocity() {
        let g = Governor::new(VesselParams::PAPER, Vec3::new(0.7, 0.1, -0.3));
        assert_eq!(g.current(), (0.7, -0.3));
    }

    #[test]
    fn a_line_the_hull_can_follow_is_given_unchanged() {
        let p = VesselParams::PAPER;
        let mut g = Governor::new(p, Vec3::new(0.5, 0.0, 0.1));
        let line = Line {
            u_d: 0.5,
            r_d: 0.1,
            u_d_dot: 0.2,
            r_d_dot: -0.3,
        };
        for k in 0..2000 {
            let since = k as f64 * H;
            let c = line.at(since);
            // The hull tracking exactly, no disturbance.
            let vel = Vec3::new(g.current().0, 0.0, g.current().1);
            let y = g.step(&c, vel, Vec3::zeros(), H);
            assert!(
                (y.u_d - c.u_d).abs() < 1e-9 && (y.r_d - c.r_d).abs() < 1e-9,
                "{k}"
            );
            assert!((y.u_d_dot - 0.2).abs() < 1e-9 && (y.r_d_dot + 0.3).abs() < 1e-9);
        }
    }

    /// A reversal of the turn from +1 to −1 rad/s, ramped at the mission's
    /// 2 rad/s²: the paper's hull (1 rad/s² of authority) falls far behind.
    /// Ramped at the rate it declares, it keeps up but for what its damping
    /// takes.
    #[test]
    fn a_line_ramped_at_the_declared_agility_is_followed() {
        let p = VesselParams::PAPER;
        assert_eq!(
            agility(&p),
            Agility {
                yaw_accel: 0.75,
                surge_accel: 0.75
            }
        );
        let worst_lag = |accel: f64| {
            let mut g = Governor::new(p, Vec3::new(0.0, 0.0, 1.0));
            let mut lag = 0.0f64;
            for k in 0..6000 {
                let r_d = (1.0 - accel * k as f64 * H).max(-1.0);
                let c = Line {
                    r_d,
                    r_d_dot: if r_d > -1.0 { -accel } else { 0.0 },
                    ..Line::HOLD
                };
                let (u, r) = g.current();
                let y = g.step(&c.at(0.0), Vec3::new(u, 0.0, r), Vec3::zeros(), H);
                lag = lag.max((y.r_d - r_d).abs());
            }
            lag
        };
        let fast = worst_lag(2.0);
        let declared = worst_lag(agility(&p).yaw_accel);
        assert!(fast > 0.5, "{fast}");
        assert!(declared < 0.02, "{declared}");
    }

    #[test]
    fn a_step_is_taken_no_faster_than_the_actuators_allow() {
        let p = VesselParams::PAPER;
        let mut g = Governor::new(p, Vec3::zeros());
        let step = Line {
            u_d: 1.0,
            r_d: -1.0,
            ..Line::HOLD
        };
        let mut last = g.current();
        for _ in 0..3000 {
            let (u, r) = g.current();
            let y = g.step(&step.at(0.0), Vec3::new(u, 0.0, r), Vec3::zeros(), H);
            // The hull's own damping takes its share of the moment too.
            let room_u = (MARGIN * p.tau_u_max - p.d11 * u) / p.m11;
            let room_r = (MARGIN * p.tau_r_max + p.d33 * r) / p.m33;
            assert!(y.u_d_dot <= room_u + 1e-12 && y.u_d_dot >= 0.0, "{y:?}");
            assert!(-y.r_d_dot <= room_r + 1e-12 && y.r_d_dot <= 0.0, "{y:?}");
            last = g.current();
        }
        // It gets there, continuously.
        assert!(
            (last.0 - 1.0).abs() < 1e-6 && (last.1 + 1.0).abs() < 1e-6,
            "{last:?}"
        );
    }
}
