//! Station keeping on arrival: the `course` mode's last metres.
//!
//! The `course` law steers the velocity over ground towards w_d = S(E) ê.
//! Centimetres from the goal that vector is tiny and its direction swings
//! with every centimetre the hull slides (the paper's Remark 1 for the
//! velocity), so a vessel that only follows it orbits its goal for ever,
//! turning at half a radian per second, a few centimetres off: on a real
//! boat, endless turns. Inside `hold_radius` the vessel keeps station
//! instead, in phases with hysteresis (docs/reproducing-the-paper.md,
//! "Quiet arrival"):
//!
//! 1. **Braking** (entered when E < `hold_radius`): the `course` law with
//!    w_d = 0: the bow comes along the velocity and the surge takes it out.
//!    A hull whose sway barely damps (the paper's: m₂₂/d₂₂ ≈ 67 s) must shed
//!    its velocity this way, along the bow, before anything else: a velocity
//!    left across the bow would carry it off sideways for a minute.
//! 2. **Keeping** (once the ground speed is below [`SLOW`]): the surge
//!    takes the share along the bow of the velocity wanted back to the goal,
//!    w★ = min([`GAIN`] E, [`KEEP_SPEED`]) ê, i.e. u_d = w★ · b. The bow is
//!    aimed, ahead or astern (the smaller turn), at [`AIM_RATE`] at most and
//!    no faster than holds the heading once aimed:
//!    - along the velocity once the sway exceeds [`QUIET`] and until it is
//!      below a third of that: thrust acts only along the bow, and this is
//!      how a hull whose sway barely damps sheds it;
//!    - else at the goal, when the aim's line misses it by more than
//!      [`DEAD`] and the last aim has been reached; the bearing of a point
//!      centimetres away, which swings with every centimetre, is never
//!      chased.
//!
//!    While the bow comes round the hull coasts (u̇_d = v r, the surge's own
//!    rate in a turn; aiming at the goal, the surge also dies away over
//!    [`COAST`]): a surge held at a set value would turn the velocity with
//!    the hull, sway and all.
//!
//!    A hull that cannot go astern keeps the heading it braked on and closes
//!    only what lies ahead (it cannot turn without way on).
//!
//! The heading is held, not turned into the disturbance: the coordinator
//! does not know the forces on a hull (its observer is on board), and the
//! paper's disturbances oscillate around zero, so the heading the vessel
//! arrived with costs no turn. A steady force across the bow shows as sway,
//! and the bow is brought along it. Keeping still tracks a goal that moves
//! while the fleet settles, so Lloyd's iteration is not frozen short of the
//! optimum. Past [`DRIFT`] the vessel brakes
//! again, and beyond 2 × `hold_radius` the `course` law takes over. Where
//! the safety filter changes the vessel's velocity the keeper yields at
//! once: keeping station never outranks keeping clear.
//!
//! **Status: experimental, off by default** (`hold_radius` 0; `seacover sim
//! --hold-radius`; not yet a mission setting). Measured in
//! docs/reproducing-the-paper.md ("Quiet arrival"): once the fleet has
//! settled both presets keep station without turning, but the fleet settles
//! more slowly than without it, and the hand-over back to the `course` law
//! asks for a step the Otter's governor cannot follow.
//!
//! Invariant: the keeper's commands are bounded by [`AIM_RATE`] and
//! [`KEEP_SPEED`] and go through the same command line (continuity, rate
//! bounds, the filter's surge bound) as the `course` law's.

use super::model::State;
use super::wrap;
use std::f64::consts::{FRAC_PI_2, PI};

/// A desired velocity the safety filter moved by more than this [m/s] is
/// the filter's, and station keeping yields to it.
pub const YIELD: f64 = 1e-3;
/// Below this ground speed [m/s] a braking vessel keeps station.
pub const SLOW: f64 = 0.02;
/// Above this ground speed [m/s] a keeping vessel brakes again: above
/// [`KEEP_SPEED`] and the sway the disturbances give a light hull
/// (≈ 0.01 m/s for the Otter) together.
pub const DRIFT: f64 = 0.15;
/// How fast the wanted velocity closes the error [1/s].
pub const GAIN: f64 = 0.35;
/// The wanted velocity's cap [m/s].
pub const KEEP_SPEED: f64 = 0.1;
/// A sway smaller than this [m/s] is not worth a turn: above what the
/// disturbances give a light hull, whose damping takes it out anyway.
pub const QUIET: f64 = 0.015;
/// The aim moves to the velocity's line only when it is off it by more
/// than this [rad].
pub const SLACK: f64 = 0.3;
/// The aim moves to the goal only when its line misses the goal by more
/// than this [m].
pub const DEAD: f64 = 0.1;
/// A keeping vessel turns at most this fast [rad/s].
pub const AIM_RATE: f64 = 0.1;
/// Aiming gain [1/s].
const AIM_GAIN: f64 = 0.5;
/// The bow is aimed within this [rad]: thrust may change the velocity.
const ALIGNED: f64 = 0.1;
/// Time constant of the surge dying away while the bow comes round [s].
pub const COAST: f64 = 5.0;
/// Turn rate allowed while thrusting [rad/s]: only to hold the heading.
const HOLD_RATE: f64 = 0.02;

/// Where a vessel is in keeping station.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Phase {
    /// The `course` law steers.
    #[default]
    Free,
    /// Shedding its velocity.
    Braking,
    /// Holding station, the bow aimed at `heading`; `shedding`: along the
    /// velocity, to take a sway out.
    Keeping { heading: f64, shedding: bool },
}

/// What the guidance does this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Order {
    /// The `course` law towards the desired velocity.
    Steer,
    /// The `course` law towards rest (w_d = 0).
    Brake,
    /// This raw command: (u_d, r_d, the heading error acted on).
    Hold {
        u: f64,
        r: f64,
        u_dot: f64,
        psi_e: f64,
    },
}

impl Phase {
    /// Moves through the phases for a vessel in `state`, `e` metres from
    /// `goal`, and says what to command. `yielding`: the safety filter
    /// changed the vessel's desired velocity. A `hold_radius` of 0 never
    /// keeps station.
    pub fn advance(
        &mut self,
        hold_radius: f64,
        state: &State,
        goal: (f64, f64),
        e: f64,
        yielding: bool,
        ahead_only: bool,
    ) -> Order {
        let (wx, wy) = state.ground_velocity();
        let speed = wx.hypot(wy);
        let (ex, ey) = (goal.0 - state.x, goal.1 - state.y);
        if yielding || hold_radius <= 0.0 || e > 2.0 * hold_radius {
            *self = Phase::Free;
        }
        loop {
            match *self {
                Phase::Free if e < hold_radius && !yielding && hold_radius > 0.0 => {
                    *self = Phase::Braking;
                }
                Phase::Free => return Order::Steer,
                Phase::Braking if speed < SLOW => {
                    *self = Phase::Keeping {
                        heading: state.psi,
                        shedding: false,
                    };
                }
                Phase::Braking => return Order::Brake,
                Phase::Keeping { .. } if speed > DRIFT => *self = Phase::Braking,
                Phase::Keeping { heading, shedding } => {
                    return self.keep(heading, shedding, state, (ex, ey), e, ahead_only);
                }
            }
        }
    }

    /// The keeping phase's command (see the module doc).
    fn keep(
        &mut self,
        heading: f64,
        shedding: bool,
        state: &State,
        (ex, ey): (f64, f64),
        e: f64,
        ahead_only: bool,
    ) -> Order {
        let (wx, wy) = state.ground_velocity();
        // The velocity wanted: back to the goal, slowly (w★ = k e).
        let k = if e > 0.0 {
            (GAIN * e).min(KEEP_SPEED) / e
        } else {
            0.0
        };
        let sway = state.vel.y;
        let aim = |along: f64| {
            // Along ±that line, whichever is the smaller turn.
            if wrap(along - state.psi).abs() <= FRAC_PI_2 {
                along
            } else {
                wrap(along + PI)
            }
        };
        // Shed a sway above QUIET until it is below a third of it.
        let shedding = !ahead_only && sway.abs() > if shedding { QUIET / 3.0 } else { QUIET };
        let heading = if shedding {
            // A velocity across the bow that thrust cannot touch: bring the
            // bow along the velocity, so that the surge takes it out.
            let along_w = aim(wy.atan2(wx));
            if wrap(along_w - heading).abs() > SLACK {
                along_w
            } else {
                heading
            }
        } else if !ahead_only
            && e > DEAD
            && (ey * heading.cos() - ex * heading.sin()).abs() > DEAD
            && wrap(heading - state.psi).abs() <= ALIGNED
        {
            // The aim's line misses the goal: aim at the goal (once the
            // last aim is reached: a bearing that moves while the bow comes
            // round is not chased).
            aim(ey.atan2(ex))
        } else {
            heading
        };
        *self = Phase::Keeping { heading, shedding };
        let err = wrap(heading - state.psi);
        let rate = if err.abs() > ALIGNED {
            AIM_RATE
        } else {
            HOLD_RATE
        };
        let r = (AIM_GAIN * err).clamp(-rate, rate);
        if err.abs() > ALIGNED {
            // Turn coasting (u̇ = v r, the surge's own rate in a turn): a
            // surge held at a set value would turn the velocity with the
            // hull, and the sway with it. Shedding, the sway must become
            // surge whole; aiming, the surge also dies away.
            let u = state.vel.x;
            let fade = if shedding { 0.0 } else { u / COAST };
            return Order::Hold {
                u,
                r,
                u_dot: sway * r - fade,
                psi_e: err,
            };
        }
        let (bx, by) = (state.psi.cos(), state.psi.sin());
        let lo = if ahead_only { 0.0 } else { -KEEP_SPEED };
        let u = (k * (ex * bx + ey * by)).clamp(lo, KEEP_SPEED);
        Order::Hold {
            u,
            r,
            u_dot: 0.0,
            psi_e: err,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Vec3;

    fn at(x: f64, y: f64, psi: f64, vel: (f64, f64, f64)) -> State {
        State {
            x,
            y,
            psi,
            vel: Vec3::new(vel.0, vel.1, vel.2),
        }
    }

    #[test]
    fn a_moving_vessel_brakes_then_keeps_aiming_at_its_goal() {
        let mut p = Phase::Free;
        let goal = (0.0, 0.0);
        // Outside the radius: the course law.
        let s = at(-1.0, 0.0, 0.0, (0.2, 0.0, 0.0));
        assert_eq!(p.advance(0.25, &s, goal, 1.0, false, false), Order::Steer);
        // Inside, still moving: brake.
        let s = at(0.0, -0.2, 0.0, (0.05, 0.0, 0.0));
        assert_eq!(p.advance(0.25, &s, goal, 0.2, false, false), Order::Brake);
        // At rest, goal on the beam: turn towards it, slowly, coasting.
        let s = at(0.0, -0.2, 0.0, (0.0, 0.0, 0.0));
        let Order::Hold { u, r, .. } = p.advance(0.25, &s, goal, 0.2, false, false) else {
            panic!("{p:?}");
        };
        assert!(u.abs() < 1e-12, "{u}");
        assert!((r - AIM_RATE).abs() < 1e-12, "{r}");
        // Bow on the goal: thrust towards it without turning.
        let s = at(0.0, -0.1, FRAC_PI_2, (0.0, 0.0, 0.0));
        let Order::Hold { u, r, .. } = p.advance(0.25, &s, goal, 0.1, false, false) else {
            panic!("{p:?}");
        };
        assert!((u - GAIN * 0.1).abs() < 1e-12, "{u}");
        assert!(r.abs() < 1e-12, "{r}");
        // Nearly there, a change too small for a turn: the bow is held
        // wherever the goal lies.
        let s = at(0.03, 0.0, FRAC_PI_2, (0.0, 0.0, 0.0));
        let Order::Hold { r, .. } = p.advance(0.25, &s, goal, 0.03, false, false) else {
            panic!("{p:?}");
        };
        assert!(r.abs() < 1e-12, "{r}");
    }

    #[test]
    fn sway_is_taken_out_by_aiming_along_it() {
        // At the goal, sliding to port at 0.018 m/s: the bow turns to lie
        // along the slide, coasting, so that the surge can take it out.
        let mut p = Phase::Keeping {
            heading: 0.0,
            shedding: false,
        };
        let s = at(0.0, 0.0, 0.0, (0.0, 0.018, 0.0));
        let Order::Hold { u, r, .. } = p.advance(0.25, &s, (0.0, 0.0), 0.0, false, false) else {
            panic!("{p:?}");
        };
        let Phase::Keeping { heading, .. } = p else {
            panic!("{p:?}");
        };
        assert!((heading.abs() - FRAC_PI_2).abs() < 1e-9, "{heading}");
        assert!(u.abs() < 1e-12 && r.abs() > 0.0, "{u} {r}");
    }

    #[test]
    fn the_goal_behind_is_kept_astern_and_drift_or_distance_end_keeping() {
        let mut p = Phase::Braking;
        let goal = (0.0, 0.0);
        // Goal behind: the bow stays, the surge goes astern.
        let s = at(0.2, 0.0, 0.0, (0.0, 0.0, 0.0));
        let Order::Hold { u, r, .. } = p.advance(0.25, &s, goal, 0.2, false, false) else {
            panic!("{p:?}");
        };
        assert!(
            matches!(p, Phase::Keeping { heading, .. } if heading.abs() < 1e-12),
            "{p:?}"
        );
        assert!((u + GAIN * 0.2).abs() < 1e-12, "{u}");
        assert!(r.abs() < 1e-12, "{r}");
        // Drifting: brake again.
        let s = at(0.2, 0.0, 0.0, (0.0, 0.2, 0.0));
        assert_eq!(p.advance(0.25, &s, goal, 0.2, false, false), Order::Brake);
        // Hysteresis: between the radius and twice it, braking goes on;
        // beyond, the course law.
        let s = at(0.4, 0.0, 0.0, (0.0, 0.2, 0.0));
        assert_eq!(p.advance(0.25, &s, goal, 0.4, false, false), Order::Brake);
        let s = at(0.6, 0.0, 0.0, (0.0, 0.2, 0.0));
        assert_eq!(p.advance(0.25, &s, goal, 0.6, false, false), Order::Steer);
        // The safety filter's say ends keeping at once.
        let mut p = Phase::Keeping {
            heading: 0.0,
            shedding: false,
        };
        let s = at(0.1, 0.0, 0.0, (0.0, 0.0, 0.0));
        assert_eq!(p.advance(0.25, &s, goal, 0.1, true, false), Order::Steer);
        // And a radius of 0 never keeps station.
        let mut p = Phase::Free;
        assert_eq!(p.advance(0.0, &s, goal, 0.0, false, false), Order::Steer);
    }

    #[test]
    fn a_vessel_that_cannot_go_astern_keeps_its_heading() {
        let mut p = Phase::Keeping {
            heading: 0.3,
            shedding: false,
        };
        let s = at(0.0, -0.2, 0.3, (0.0, 0.0, 0.0));
        let Order::Hold { u, r, .. } = p.advance(0.25, &s, (0.0, 0.0), 0.2, false, true) else {
            panic!("{p:?}");
        };
        assert!(r.abs() < 1e-12, "{r}");
        assert!(u > 0.0, "{u}");
    }
}
