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
//! Keeping starts only once the goal has settled (it moves slower than
//! [`SETTLED`]) and ends when it moves again (faster than [`UNSETTLED`]):
//! while the fleet is still spreading, the `course` law follows the goal
//! and Lloyd's iteration goes on at its own pace. When keeping ends, the
//! `course` law's turn comes back over [`RETURN`] seconds rather than at
//! once (a hull at rest cannot take its full yaw rate in a step); the
//! safety filter's turn is never faded. On by default (`hold_radius`
//! 0.2 m, a mission setting); measured in docs/reproducing-the-paper.md
//! ("Quiet arrival").
//!
//! A vessel that holds a position by itself (an ArduPilot boat's loiter,
//! [`Look::holds_itself`]) is handed its goal instead of the keeper's
//! commands, and handed it again when the goal has moved far: for it
//! keeping starts below [`SETTLED_HELD`] and only distance ends it.
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
/// A goal moving slower than this [m/s] has settled: keeping may start.
pub const SETTLED: f64 = 0.01;
/// The same for a vessel that holds a position by itself (an autopilot's
/// loiter, handed its goal again once it has moved farther than the
/// vessel's station radius): its
/// neighbours' boats, which turn only under way, circle their goals
/// until they hold too, and move the goals by centimetres a second
/// meanwhile (measured on SITL: 0.05–0.2 m/s), so the threshold that
/// waits for a simulated fleet to settle would never be met.
pub const SETTLED_HELD: f64 = 0.1;
/// A goal moving faster than this [m/s] is left to the `course` law: the
/// fleet is moving again, and the keeper's slow turns would lag it.
pub const UNSETTLED: f64 = 0.03;
/// Over this many seconds after keeping ends the `course` law's turn comes
/// in from nothing (its authority grows linearly): a hull at rest asked at
/// once for the law's full yaw rate cannot follow it.
pub const RETURN: f64 = 4.0;

/// What the keeper looks at on a tick.
#[derive(Debug, Clone, Copy)]
pub struct Look<'a> {
    /// 0: never keep station.
    pub hold_radius: f64,
    /// The vessel's pose and velocity now.
    pub state: &'a State,
    /// The goal (x, y) [m].
    pub goal: (f64, f64),
    /// Distance to the goal [m].
    pub e: f64,
    /// How fast the goal moves [m/s].
    pub goal_speed: f64,
    /// Mission time [s].
    pub t: f64,
    /// The safety filter changed the vessel's desired velocity.
    pub yielding: bool,
    /// The hull cannot go astern.
    pub ahead_only: bool,
    /// The vessel holds a position by itself, handed its goal: keeping
    /// starts below [`SETTLED_HELD`], and a moving goal does not end it
    /// (handed again once it has moved farther than the radius; measured
    /// on SITL, ending it when goals moved faster than 0.3 m/s set boats
    /// circling again as their neighbours settled).
    pub holds_itself: bool,
}

/// Where a vessel is in keeping station.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Phase {
    /// The `course` law steers.
    #[default]
    Free,
    /// The `course` law steers, its turn coming in since `since` (keeping
    /// ended then).
    Returning {
        /// Mission time keeping ended [s].
        since: f64,
    },
    /// Shedding its velocity.
    Braking,
    /// Holding station, the bow aimed at `heading`; `shedding`: along the
    /// velocity, to take a sway out.
    Keeping {
        /// The heading the bow is aimed at [rad].
        heading: f64,
        /// Whether it is aimed along the velocity, to take a sway out.
        shedding: bool,
    },
}

/// What the guidance does this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Order {
    /// The `course` law towards the desired velocity, its yaw rate (and
    /// the surge rate that comes of it) scaled by this authority in [0, 1].
    Steer(f64),
    /// The `course` law towards rest (w_d = 0).
    Brake,
    /// This raw command: (u_d, r_d, the heading error acted on).
    Hold {
        /// Desired surge speed u_d [m/s].
        u: f64,
        /// Desired yaw rate r_d [rad/s].
        r: f64,
        /// The rate u̇_d [m/s²].
        u_dot: f64,
        /// The heading error acted on [rad].
        psi_e: f64,
    },
}

impl Phase {
    /// Moves through the phases and says what to command (see the module
    /// doc).
    pub fn advance(&mut self, look: &Look<'_>) -> Order {
        let Look {
            hold_radius,
            state,
            goal,
            e,
            goal_speed,
            t,
            yielding,
            ahead_only,
            holds_itself,
        } = *look;
        let (wx, wy) = state.ground_velocity();
        let speed = wx.hypot(wy);
        let (ex, ey) = (goal.0 - state.x, goal.1 - state.y);
        let keeps = matches!(self, Phase::Braking | Phase::Keeping { .. });
        let (settled, unsettled) = if holds_itself {
            (SETTLED_HELD, f64::INFINITY)
        } else {
            (SETTLED, UNSETTLED)
        };
        if yielding || hold_radius <= 0.0 {
            // Keeping clear is never faded in.
            *self = Phase::Free;
        } else if keeps && (e > 2.0 * hold_radius || goal_speed > unsettled) {
            *self = Phase::Returning { since: t };
        }
        loop {
            match *self {
                Phase::Free | Phase::Returning { .. }
                    if e < hold_radius
                        && goal_speed < settled
                        && !yielding
                        && hold_radius > 0.0 =>
                {
                    *self = Phase::Braking;
                }
                Phase::Free => return Order::Steer(1.0),
                Phase::Returning { since } if t - since >= RETURN || t < since => {
                    *self = Phase::Free;
                }
                Phase::Returning { since } => return Order::Steer((t - since) / RETURN),
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

    /// A settled goal at time 0.
    fn look<'a>(
        hold_radius: f64,
        state: &'a State,
        goal: (f64, f64),
        e: f64,
        yielding: bool,
        ahead_only: bool,
    ) -> Look<'a> {
        Look {
            hold_radius,
            state,
            goal,
            e,
            goal_speed: 0.0,
            t: 0.0,
            yielding,
            ahead_only,
            holds_itself: false,
        }
    }

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
        assert_eq!(
            p.advance(&look(0.25, &s, goal, 1.0, false, false)),
            Order::Steer(1.0)
        );
        // Inside, still moving: brake.
        let s = at(0.0, -0.2, 0.0, (0.05, 0.0, 0.0));
        assert_eq!(
            p.advance(&look(0.25, &s, goal, 0.2, false, false)),
            Order::Brake
        );
        // At rest, goal on the beam: turn towards it, slowly, coasting.
        let s = at(0.0, -0.2, 0.0, (0.0, 0.0, 0.0));
        let Order::Hold { u, r, .. } = p.advance(&look(0.25, &s, goal, 0.2, false, false)) else {
            panic!("{p:?}");
        };
        assert!(u.abs() < 1e-12, "{u}");
        assert!((r - AIM_RATE).abs() < 1e-12, "{r}");
        // Bow on the goal: thrust towards it without turning.
        let s = at(0.0, -0.1, FRAC_PI_2, (0.0, 0.0, 0.0));
        let Order::Hold { u, r, .. } = p.advance(&look(0.25, &s, goal, 0.1, false, false)) else {
            panic!("{p:?}");
        };
        assert!((u - GAIN * 0.1).abs() < 1e-12, "{u}");
        assert!(r.abs() < 1e-12, "{r}");
        // Nearly there, a change too small for a turn: the bow is held
        // wherever the goal lies.
        let s = at(0.03, 0.0, FRAC_PI_2, (0.0, 0.0, 0.0));
        let Order::Hold { r, .. } = p.advance(&look(0.25, &s, goal, 0.03, false, false)) else {
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
        let Order::Hold { u, r, .. } = p.advance(&look(0.25, &s, (0.0, 0.0), 0.0, false, false))
        else {
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
        let Order::Hold { u, r, .. } = p.advance(&look(0.25, &s, goal, 0.2, false, false)) else {
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
        assert_eq!(
            p.advance(&look(0.25, &s, goal, 0.2, false, false)),
            Order::Brake
        );
        // Hysteresis: between the radius and twice it, braking goes on;
        // beyond, the course law, its turn fading in.
        let s = at(0.4, 0.0, 0.0, (0.0, 0.2, 0.0));
        assert_eq!(
            p.advance(&look(0.25, &s, goal, 0.4, false, false)),
            Order::Brake
        );
        let s = at(0.6, 0.0, 0.0, (0.0, 0.2, 0.0));
        assert_eq!(
            p.advance(&look(0.25, &s, goal, 0.6, false, false)),
            Order::Steer(0.0)
        );
        // The safety filter's say ends keeping at once.
        let mut p = Phase::Keeping {
            heading: 0.0,
            shedding: false,
        };
        let s = at(0.1, 0.0, 0.0, (0.0, 0.0, 0.0));
        assert_eq!(
            p.advance(&look(0.25, &s, goal, 0.1, true, false)),
            Order::Steer(1.0)
        );
        // And a radius of 0 never keeps station.
        let mut p = Phase::Free;
        assert_eq!(
            p.advance(&look(0.0, &s, goal, 0.0, false, false)),
            Order::Steer(1.0)
        );
    }

    #[test]
    fn a_vessel_that_cannot_go_astern_keeps_its_heading() {
        let mut p = Phase::Keeping {
            heading: 0.3,
            shedding: false,
        };
        let s = at(0.0, -0.2, 0.3, (0.0, 0.0, 0.0));
        let Order::Hold { u, r, .. } = p.advance(&look(0.25, &s, (0.0, 0.0), 0.2, false, true))
        else {
            panic!("{p:?}");
        };
        assert!(r.abs() < 1e-12, "{r}");
        assert!(u > 0.0, "{u}");
    }

    #[test]
    fn keeping_waits_for_a_settled_goal_and_hands_back_gradually() {
        let goal = (0.0, 0.0);
        let s = at(0.1, 0.0, 0.0, (0.0, 0.0, 0.0));
        // Inside the radius, but the goal still moves: the course law.
        let mut p = Phase::Free;
        let moving = Look {
            goal_speed: 2.0 * SETTLED,
            ..look(0.25, &s, goal, 0.1, false, false)
        };
        assert_eq!(p.advance(&moving), Order::Steer(1.0));
        // Settled: keep station.
        assert!(matches!(
            p.advance(&look(0.25, &s, goal, 0.1, false, false)),
            Order::Hold { .. }
        ));
        // The fleet moves again: the course law's turn comes in over RETURN.
        let away = Look {
            goal_speed: 2.0 * UNSETTLED,
            t: 10.0,
            ..look(0.25, &s, goal, 0.1, false, false)
        };
        assert_eq!(p.advance(&away), Order::Steer(0.0));
        let later = Look {
            t: 10.0 + RETURN / 2.0,
            ..away
        };
        assert_eq!(p.advance(&later), Order::Steer(0.5));
        let done = Look {
            t: 10.0 + RETURN,
            ..away
        };
        assert_eq!(p.advance(&done), Order::Steer(1.0));
        assert_eq!(p, Phase::Free);
        // Beyond twice the radius likewise; the safety filter at once.
        let mut p = Phase::Keeping {
            heading: 0.0,
            shedding: false,
        };
        let far = at(0.6, 0.0, 0.0, (0.0, 0.0, 0.0));
        assert_eq!(
            p.advance(&look(0.25, &far, goal, 0.6, false, false)),
            Order::Steer(0.0)
        );
        let mut p = Phase::Keeping {
            heading: 0.0,
            shedding: false,
        };
        assert_eq!(
            p.advance(&look(0.25, &far, goal, 0.6, true, false)),
            Order::Steer(1.0)
        );
    }
}
