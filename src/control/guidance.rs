//! Guidance: from a vessel's pose and its cell's centroid to the desired surge
//! speed u_d and yaw rate r_d that the on-board controller tracks.
//!
//! ## `paper`: the literal law (eq. 10–13, `atan2` argument order fixed)
//! e = C − p, E = ‖e‖, ψ_r = atan2(e_y, e_x), ψ_e = wrap(ψ_r − ψ),
//! r_d = k_r1 (σ(b₁ ψ_e) − ½) + k_r2 ψ_e + ψ̇_r,
//! u_d = k_u1 (σ(b₂ E) − ½) + k_u2 E + ‖Ċ‖.
//! ψ̇_r and Ċ are differences of successive ticks through a first-order
//! low-pass filter (time constant `filter_time`), never raw differences.
//! Inside `arrival_radius` the vessel holds station (u_d = r_d = 0), the
//! singularity of Remark 1.
//!
//! ## `course`: steering the velocity over ground (the default)
//! The literal law steers the bow. With the paper's vessel (m11 = m22, sway
//! time constant m22/d22 ≈ 67 s) turning the bow barely turns the velocity:
//! the hull behaves like a puck whose only thrust is along the bow, and the
//! fleet drifts out of the region (SPEC §2; `docs/reproducing-the-paper.md`
//! measures it). This mode treats the velocity over ground w as the thing to
//! control:
//! - desired ground velocity w_d = S(E) ê with the paper's speed profile
//!   S(E) = k_u1 (σ(b₂ E) − ½) + k_u2 E, capped at `max_speed`, and 0 inside
//!   `arrival_radius`;
//! - the bow is steered along Δw + ¼ w_d, i.e. mostly along the velocity
//!   error Δw = w_d − w and along w_d once that error is small (or against
//!   it, with hysteresis, so braking may use astern thrust), with the paper's
//!   r_d law on that heading error, faded out below a needed velocity change
//!   of 0.1 m/s so that at rest at the goal it holds its heading, and capped
//!   at `max_yaw_rate`;
//! - u_d = w_d · b, the desired velocity's component along the current bow
//!   b (braking through zero when w_d is behind), with u̇_d = r_d (w_d · l),
//!   l the beam direction — how that component changes while the bow turns;
//!   vessels extrapolate u_d with it between ticks;
//! - but only as far as the bow points the right way: with
//!   α = max(cos ψ_e, 0)², u_d = α w_d·b + (1 − α) u and u̇_d blends to the
//!   natural rate v r_d, i.e. the surge coasts while the bow comes round.
//!   Holding u at a set value while the hull yaws takes a force m r (w·l);
//!   with the paper's vessel that is all its thrust, spent as the centripetal
//!   force of an orbit around the goal that keeps the heading error fixed.
//!
//! Once the bow lies along Δw, changing u changes w exactly along Δw, so the
//! error shrinks without ever needing the weakly damped sway to die out.
//! Same vessel, same disturbances, same observer and controller.

use super::model::State;
use super::{sigmoid, wrap};

/// Which guidance law.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GuidanceMode {
    Paper,
    Course,
}

impl GuidanceMode {
    pub fn name(&self) -> &'static str {
        match self {
            GuidanceMode::Paper => "paper",
            GuidanceMode::Course => "course",
        }
    }

    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(GuidanceMode::Paper),
            "course" => Some(GuidanceMode::Course),
            _ => None,
        }
    }
}

/// Guidance gains; the paper gives none, these are SPEC §2's defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidanceGains {
    pub mode: GuidanceMode,
    pub k_r1: f64,
    pub k_r2: f64,
    pub b1: f64,
    pub k_u1: f64,
    pub k_u2: f64,
    pub b2: f64,
    /// Inside this distance of the centroid the vessel holds station [m].
    pub arrival_radius: f64,
    /// Speed cap of the `course` mode [m/s].
    pub max_speed: f64,
    /// Yaw-rate cap of the `course` mode [rad/s]: the outer loop must ask
    /// only for turns the actuator can follow (the paper's vessel reaches
    /// 1 rad/s² at most), or the yaw loop lags, overshoots and spins.
    pub max_yaw_rate: f64,
    /// Time constant of the filters on ψ̇_r, Ċ, u̇_d, ṙ_d [s].
    pub filter_time: f64,
}

impl Default for GuidanceGains {
    fn default() -> Self {
        GuidanceGains {
            mode: GuidanceMode::Course,
            k_r1: 1.0,
            k_r2: 1.0,
            b1: 1.0,
            k_u1: 1.0,
            k_u2: 0.1,
            b2: 1.0,
            arrival_radius: 0.05,
            max_speed: 2.0,
            max_yaw_rate: 1.0,
            filter_time: 0.5,
        }
    }
}

/// One guidance output.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Command {
    pub u_d: f64,
    pub r_d: f64,
    pub u_d_dot: f64,
    pub r_d_dot: f64,
    /// Distance to the centroid E.
    pub e: f64,
    /// The heading error the yaw law acts on.
    pub psi_e: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Last {
    t: f64,
    psi_r: f64,
    centroid: (f64, f64),
    u_d: f64,
    r_d: f64,
}

/// Guidance state of one vessel (the filters need history).
#[derive(Debug, Clone, PartialEq)]
pub struct Guidance {
    pub gains: GuidanceGains,
    last: Option<Last>,
    psi_r_dot: f64,
    c_dot: (f64, f64),
    u_d_dot: f64,
    r_d_dot: f64,
    /// Whether the `course` mode is thrusting astern.
    astern: bool,
    /// The vessel cannot thrust astern: the `course` mode turns it round
    /// instead and never asks for a negative surge (the `paper` law never
    /// does).
    pub ahead_only: bool,
}

/// The `course` mode switches between ahead and astern when the heading
/// error of the current choice exceeds this (a right angle plus hysteresis).
const ASTERN_SWITCH: f64 = 1.9;

impl Guidance {
    pub fn new(gains: GuidanceGains) -> Self {
        Guidance {
            gains,
            last: None,
            psi_r_dot: 0.0,
            c_dot: (0.0, 0.0),
            u_d_dot: 0.0,
            r_d_dot: 0.0,
            astern: false,
            ahead_only: false,
        }
    }

    /// The command at time `t` for a vessel in `state` whose cell's centroid
    /// is `centroid`.
    pub fn update(&mut self, t: f64, state: &State, centroid: (f64, f64)) -> Command {
        let e = (centroid.0 - state.x).hypot(centroid.1 - state.y);
        self.steer(t, state, centroid, e, None)
    }

    /// The `course` mode's desired ground velocity towards `towards` with
    /// `remaining` metres still to go (a route may bend, so that can exceed
    /// the straight distance): w_d = S(remaining) along the line of sight,
    /// 0 inside the arrival radius. The safety filter starts from this.
    pub fn desired_velocity(
        &self,
        state: &State,
        towards: (f64, f64),
        remaining: f64,
    ) -> (f64, f64) {
        let g = self.gains;
        let (ex, ey) = (towards.0 - state.x, towards.1 - state.y);
        let sight = ex.hypot(ey);
        let s = if remaining < g.arrival_radius {
            0.0
        } else {
            (g.k_u1 * (sigmoid(g.b2 * remaining) - 0.5) + g.k_u2 * remaining).min(g.max_speed)
        };
        if sight > 0.0 {
            (s * ex / sight, s * ey / sight)
        } else {
            (0.0, 0.0)
        }
    }

    /// The command for a vessel steering towards `towards` with `remaining`
    /// metres to go, and, in the `course` mode, tracking the ground velocity
    /// `w_d` instead of its own desired one (the safety filter's output).
    /// With `towards` the centroid, `remaining` its distance and `w_d` from
    /// [`desired_velocity`](Self::desired_velocity), this is exactly
    /// [`update`](Self::update). The `paper` mode ignores `w_d`: the literal
    /// law steers the bow, not a ground velocity.
    pub fn track(
        &mut self,
        t: f64,
        state: &State,
        towards: (f64, f64),
        remaining: f64,
        w_d: (f64, f64),
    ) -> Command {
        self.steer(t, state, towards, remaining, Some(w_d))
    }

    fn steer(
        &mut self,
        t: f64,
        state: &State,
        centroid: (f64, f64),
        e: f64,
        w_d: Option<(f64, f64)>,
    ) -> Command {
        let g = self.gains;
        let (ex, ey) = (centroid.0 - state.x, centroid.1 - state.y);
        let sight = ex.hypot(ey);
        let psi_r = if sight > 0.0 { ey.atan2(ex) } else { state.psi };

        // Filtered rates from the previous tick.
        if let Some(last) = self.last {
            let dt = t - last.t;
            if dt > 0.0 {
                let a = dt / (g.filter_time + dt);
                self.psi_r_dot += a * (wrap(psi_r - last.psi_r) / dt - self.psi_r_dot);
                let cd = (
                    (centroid.0 - last.centroid.0) / dt,
                    (centroid.1 - last.centroid.1) / dt,
                );
                self.c_dot.0 += a * (cd.0 - self.c_dot.0);
                self.c_dot.1 += a * (cd.1 - self.c_dot.1);
            }
        }

        let speed = |e: f64| g.k_u1 * (sigmoid(g.b2 * e) - 0.5) + g.k_u2 * e;
        let yaw = |err: f64| g.k_r1 * (sigmoid(g.b1 * err) - 0.5) + g.k_r2 * err;
        // (u_d, r_d, ψ_e, exact u̇_d when the law has one)
        let (u_d, r_d, psi_e, exact_u_d_dot) = match g.mode {
            GuidanceMode::Paper => {
                let psi_e = wrap(psi_r - state.psi);
                if e < g.arrival_radius {
                    (0.0, 0.0, psi_e, None)
                } else {
                    let c_dot = self.c_dot.0.hypot(self.c_dot.1);
                    (speed(e) + c_dot, yaw(psi_e) + self.psi_r_dot, psi_e, None)
                }
            }
            GuidanceMode::Course => {
                let wd = match w_d {
                    Some(wd) => wd,
                    None => self.desired_velocity(state, centroid, e),
                };
                let w = state.ground_velocity();
                let dw = (wd.0 - w.0, wd.1 - w.1);
                const FADE: f64 = 0.1; // m/s
                let (bow_x, bow_y) = (state.psi.cos(), state.psi.sin());
                let u_d = wd.0 * bow_x + wd.1 * bow_y;
                // Steer along Δw, blended with w_d so that the target turns
                // continuously as Δw vanishes.
                let target = (dw.0 + 0.25 * wd.0, dw.1 + 0.25 * wd.1);
                let need = target.0.hypot(target.1);
                let beam = wd.1 * bow_x - wd.0 * bow_y;
                if need == 0.0 {
                    (u_d, 0.0, 0.0, Some(0.0))
                } else {
                    let ahead = wrap(target.1.atan2(target.0) - state.psi);
                    // Thrust astern rather than turn more than a right angle,
                    // with hysteresis so the choice does not flicker.
                    let flip = |a: f64| wrap(a + std::f64::consts::PI);
                    let current = if self.astern { flip(ahead) } else { ahead };
                    if current.abs() > ASTERN_SWITCH && !self.ahead_only {
                        self.astern = !self.astern;
                    }
                    let psi_e = if self.astern { flip(ahead) } else { ahead };
                    // Turning matters as much as the velocity change it
                    // serves: fade the yaw command out as that change
                    // vanishes, rather than switching it off.
                    let r_d = (yaw(psi_e) * (need / FADE).min(1.0))
                        .clamp(-g.max_yaw_rate, g.max_yaw_rate);
                    // Track only as far as the bow points the right way; else
                    // coast (u_d = u at its natural rate v r), so no thrust
                    // turns the velocity along with the hull.
                    let alpha = psi_e.cos().max(0.0).powi(2);
                    let (u, v) = (state.vel.x, state.vel.y);
                    let u_d = alpha * u_d + (1.0 - alpha) * u;
                    (
                        if self.ahead_only { u_d.max(0.0) } else { u_d },
                        r_d,
                        psi_e,
                        Some(alpha * r_d * beam + (1.0 - alpha) * v * r_d),
                    )
                }
            }
        };

        if let Some(last) = self.last {
            let dt = t - last.t;
            if dt > 0.0 {
                let a = dt / (g.filter_time + dt);
                self.u_d_dot += a * ((u_d - last.u_d) / dt - self.u_d_dot);
                self.r_d_dot += a * ((r_d - last.r_d) / dt - self.r_d_dot);
            }
        }
        self.last = Some(Last {
            t,
            psi_r,
            centroid,
            u_d,
            r_d,
        });
        Command {
            u_d,
            r_d,
            u_d_dot: exact_u_d_dot.unwrap_or(self.u_d_dot),
            r_d_dot: if exact_u_d_dot.is_some() {
                0.0
            } else {
                self.r_d_dot
            },
            e,
            psi_e,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Vec3;

    #[test]
    fn paper_law_matches_its_formula_and_holds_station_on_arrival() {
        let gains = GuidanceGains {
            mode: GuidanceMode::Paper,
            ..GuidanceGains::default()
        };
        let mut g = Guidance::new(gains);
        let s = State {
            x: 0.0,
            y: 0.0,
            psi: 0.0,
            vel: Vec3::zeros(),
        };
        let c = g.update(0.0, &s, (3.0, 4.0));
        let psi_e = 4f64.atan2(3.0);
        assert!((c.e - 5.0).abs() < 1e-12 && (c.psi_e - psi_e).abs() < 1e-12);
        assert!((c.u_d - ((sigmoid(5.0) - 0.5) + 0.5)).abs() < 1e-12);
        assert!((c.r_d - ((sigmoid(psi_e) - 0.5) + psi_e)).abs() < 1e-12);
        let stop = g.update(0.1, &s, (0.01, 0.0));
        assert_eq!((stop.u_d, stop.r_d), (0.0, 0.0));
    }

    #[test]
    fn course_mode_turns_towards_the_velocity_error_and_brakes() {
        let mut g = Guidance::new(GuidanceGains::default());
        // Drifting north at 1 m/s with the bow east, goal due east.
        let s = State {
            x: 0.0,
            y: 0.0,
            psi: 0.0,
            vel: Vec3::new(0.0, 1.0, 0.0),
        };
        let c = g.update(0.0, &s, (10.0, 0.0));
        // w_d = (S, 0); Δw = (S, −1): the bow must turn to starboard (ψ_e < 0).
        assert!(c.psi_e < 0.0 && c.r_d < 0.0);
        assert!(c.u_d > 0.0);
        // Goal behind: surge is asked to go astern, not to turn round first.
        let back = g.update(
            0.1,
            &State {
                vel: Vec3::zeros(),
                ..s
            },
            (-10.0, 0.0),
        );
        assert!(back.u_d < 0.0);
        assert!(back.psi_e.abs() < 1e-12);
    }

    #[test]
    fn a_vessel_that_cannot_go_astern_turns_round_instead() {
        let mut g = Guidance::new(GuidanceGains::default());
        g.ahead_only = true;
        // At rest, bow east, goal due west and a little north: it must turn
        // to port (the shorter way round) and not ask for a negative surge.
        let s = State {
            x: 0.0,
            y: 0.0,
            psi: 0.0,
            vel: Vec3::zeros(),
        };
        for k in 0..20 {
            let c = g.update(0.1 * k as f64, &s, (-10.0, 1.0));
            assert!(c.u_d >= 0.0, "{c:?}");
            assert!(c.r_d > 0.0 && c.psi_e > 1.9, "{c:?}");
        }
        // Moving ahead at 1 m/s, goal behind: no astern thrust to brake.
        let moving = State {
            vel: Vec3::new(1.0, 0.0, 0.0),
            ..s
        };
        let c = g.update(3.0, &moving, (-10.0, 1.0));
        assert!(c.u_d >= 0.0 && c.r_d > 0.0, "{c:?}");
    }
}
