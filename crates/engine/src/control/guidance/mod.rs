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
//! fleet drifts out of the region (`docs/reproducing-the-paper.md`
//! measures it). This mode treats the velocity over ground w as the thing to
//! control:
//! - desired ground velocity w_d = S(E) ê with the paper's speed profile
//!   S(E) = k_u1 (σ(b₂ E) − ½) + k_u2 E, capped at `max_speed` and faded
//!   to 0 smoothly (C¹) inside `arrival_radius`, so arriving is no switch;
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
//!
//! ## Commands a hull can follow (`course`)
//! A command is a line in time: its value at the tick and its rates, which
//! the vessel follows until the next command arrives. The law's raw output
//! jumps (the heading error swings as Δw shrinks, the astern choice flips,
//! the yaw command fades out near the goal) and a held value is a step at
//! every tick; a step in r_d asks for an infinite yaw moment. So the
//! `course` mode sends, instead of the raw output, a line that
//! - starts where the previous command's line has got to (or, for a vessel
//!   without one, at its own velocity): the command is continuous in time;
//! - heads for the raw output by the next tick, with ṙ_d bounded by
//!   `yaw_accel` and u̇_d by `surge_accel` (the raw u̇_d of the turning bow
//!   fed forward), as ArduPilot bounds its steering and speed targets, and
//!   by the vessel's own [`Agility`] where it declared one (a hull with less
//!   authority than the mission's bounds is asked only for what it can do;
//!   its surge bound is taken around v r, the rate its surge changes at
//!   unforced, where the mission's is absolute);
//! - never leaves ±`max_yaw_rate`, and keeps inside the safety filter's
//!   surge interval: that bound is a constraint, and where it moves past
//!   the line (it jumps when the bow swings across a constraint's normal)
//!   the line heads for it at the rate the vessel declared it can follow,
//!   and jumps to it for a vessel that declared none. A step would reach
//!   the hull no sooner: its governor takes it at that rate
//!   ([`reference`](super::reference)).
//!
//! The cost is one tick of delay on the raw law, which the coverage figures
//! do not notice (`docs/reproducing-the-paper.md`).

use super::model::State;
use super::station::{Look, Order, Phase, YIELD};
use super::{sigmoid, wrap};

/// 3x² − 2x³ on [0, 1], 0 below and 1 above: a C¹ switch.
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// No bound on the surge command.
pub const UNBOUNDED: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);

/// Which guidance law.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GuidanceMode {
    /// The paper's law (eq. 10–13): the bow steered at the centroid.
    Paper,
    /// The velocity over ground steered towards the centroid (the default).
    Course,
}

impl GuidanceMode {
    /// The mode's name: `paper` or `course`.
    pub fn name(&self) -> &'static str {
        match self {
            GuidanceMode::Paper => "paper",
            GuidanceMode::Course => "course",
        }
    }

    /// The mode of that [`name`](Self::name); `None` for any other text.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(GuidanceMode::Paper),
            "course" => Some(GuidanceMode::Course),
            _ => None,
        }
    }
}

/// Guidance gains. The paper gives none; these defaults are the ones
/// `docs/reproducing-the-paper.md` measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidanceGains {
    /// Which law.
    pub mode: GuidanceMode,
    /// The yaw-rate law's sigmoid gain k_r1 [rad/s], in
    /// r_d = k_r1 (σ(b₁ ψ_e) − ½) + k_r2 ψ_e + ψ̇_r.
    pub k_r1: f64,
    /// The yaw-rate law's linear gain k_r2 [1/s].
    pub k_r2: f64,
    /// The yaw-rate law's sigmoid slope b₁ [1/rad].
    pub b1: f64,
    /// The speed law's sigmoid gain k_u1 [m/s], in
    /// u_d = k_u1 (σ(b₂ E) − ½) + k_u2 E + ‖Ċ‖.
    pub k_u1: f64,
    /// The speed law's linear gain k_u2 [1/s].
    pub k_u2: f64,
    /// The speed law's sigmoid slope b₂ [1/m].
    pub b2: f64,
    /// Inside this distance of the centroid the vessel holds station [m].
    pub arrival_radius: f64,
    /// Inside this distance of its settled goal a `course` vessel stops
    /// turning and keeps station, until it is twice as far
    /// ([`station`](super::station)) [m]; 0: never.
    pub hold_radius: f64,
    /// Speed cap of the `course` mode [m/s].
    pub max_speed: f64,
    /// Yaw-rate cap of the `course` mode [rad/s]: the outer loop must ask
    /// only for turns the actuator can follow (the paper's vessel reaches
    /// 1 rad/s² at most), or the yaw loop lags, overshoots and spins.
    pub max_yaw_rate: f64,
    /// Time constant of the filters on ψ̇_r, Ċ, u̇_d, ṙ_d [s].
    pub filter_time: f64,
    /// Largest rate of change of the `course` mode's yaw-rate command
    /// [rad/s²], like ArduPilot's `ATC_STR_ACC_MAX` (whose default, 120°/s²,
    /// this one's is). It is inside the guidance loop: much tighter, and
    /// its lag makes the heading weave (0.5 does, with ArduPilot's boats).
    /// A hull with less yaw authority (the paper's vessel: 1 rad/s²)
    /// declares its own bound ([`Agility`]).
    pub yaw_accel: f64,
    /// Largest rate of change of the `course` mode's surge command [m/s²],
    /// the turning bow's own rate included (the paper's vessel: 1 m/s²),
    /// like ArduPilot's `ATC_ACCEL_MAX`.
    pub surge_accel: f64,
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
            hold_radius: 0.2,
            max_speed: 2.0,
            max_yaw_rate: 1.0,
            filter_time: 0.5,
            yaw_accel: 2.0,
            surge_accel: 0.75,
        }
    }
}

/// The command rates one vessel can follow, as it declares them (the
/// simulated vessel: its reference governor's share of its actuators,
/// [`reference::agility`](super::reference::agility)). The `course` mode
/// bounds that vessel's ṙ_d and u̇_d by these as well as by the mission's
/// `yaw_accel`, `surge_accel`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Agility {
    /// |ṙ_d| [rad/s²]
    pub yaw_accel: f64,
    /// |u̇_d − v r| [m/s²]: what the actuators add to the surge's own rate
    /// of change in a turn.
    pub surge_accel: f64,
}

impl Agility {
    /// A vessel that declared nothing: the mission's bounds alone.
    pub const UNDECLARED: Agility = Agility {
        yaw_accel: f64::INFINITY,
        surge_accel: f64::INFINITY,
    };
}

/// One guidance output.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Command {
    /// Desired surge speed u_d [m/s].
    pub u_d: f64,
    /// Desired yaw rate r_d [rad/s].
    pub r_d: f64,
    /// The rate u̇_d [m/s²] the vessel extrapolates u_d with until the next
    /// command.
    pub u_d_dot: f64,
    /// The rate ṙ_d [rad/s²] the vessel extrapolates r_d with until the
    /// next command.
    pub r_d_dot: f64,
    /// Distance to the centroid E.
    pub e: f64,
    /// The heading error the yaw law acts on.
    pub psi_e: f64,
    /// How much the surge bound given to [`Guidance::track`] cut the
    /// command [m/s] (0 when it did not).
    pub surge_cut: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Last {
    t: f64,
    psi_r: f64,
    centroid: (f64, f64),
    u_d: f64,
    r_d: f64,
}

/// The `course` mode's command in force: its value at `t` and its rates,
/// the line the vessel follows until the next command.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Line {
    t: f64,
    u: f64,
    r: f64,
    u_dot: f64,
    r_dot: f64,
}

/// A line older than this [s] is not continued: the vessel was gone or
/// its commands stopped, and its own velocity is the better start.
const LINE_GAP: f64 = 1.0;

/// The command period assumed before two commands have given it [s]
/// (the coordinator's default tick, 10 Hz).
const FIRST_PERIOD: f64 = 0.1;

/// Guidance state of one vessel (the filters need history).
#[derive(Debug, Clone, PartialEq)]
pub struct Guidance {
    /// The law and its gains.
    pub gains: GuidanceGains,
    last: Option<Last>,
    psi_r_dot: f64,
    c_dot: (f64, f64),
    u_d_dot: f64,
    r_d_dot: f64,
    /// The `course` mode's command line in force.
    line: Option<Line>,
    /// Whether the `course` mode is thrusting astern.
    astern: bool,
    /// The vessel cannot thrust astern: the `course` mode turns it round
    /// instead and never asks for a negative surge (the `paper` law never
    /// does).
    pub ahead_only: bool,
    /// What the vessel declared it can follow.
    pub agility: Agility,
    /// The vessel holds a position by itself within this of its goal
    /// [m]: station keeping starts within the larger of this and
    /// `hold_radius` (never when `hold_radius` is 0).
    pub station_radius: Option<f64>,
    /// Where the `course` mode is in keeping station.
    station: Phase,
}

/// The surge an ahead-only vessel keeps while its bow comes round, so that
/// its rudder bites [m/s] (capped by the desired speed).
const STEERAGE: f64 = 0.5;

/// A law's raw (u_d, r_d, ψ_e, u̇_d when it has one).
type Output = (f64, f64, f64, Option<f64>);

/// The `course` mode switches between ahead and astern when the heading
/// error of the current choice exceeds this (a right angle plus hysteresis).
const ASTERN_SWITCH: f64 = 1.9;

impl Guidance {
    /// A vessel's guidance with no history yet: astern allowed, no declared
    /// agility, no station radius of its own.
    pub fn new(gains: GuidanceGains) -> Self {
        Guidance {
            gains,
            last: None,
            psi_r_dot: 0.0,
            c_dot: (0.0, 0.0),
            u_d_dot: 0.0,
            r_d_dot: 0.0,
            line: None,
            astern: false,
            ahead_only: false,
            agility: Agility::UNDECLARED,
            station_radius: None,
            station: Phase::Free,
        }
    }

    /// Whether the vessel is keeping station on arrival now (braking or
    /// keeping, [`station`](super::station)): a vessel that holds a
    /// position by itself may hold its goal instead.
    pub fn keeping_station(&self) -> bool {
        matches!(self.station, Phase::Braking | Phase::Keeping { .. })
    }

    /// The command at time `t` for a vessel in `state` whose cell's centroid
    /// is `centroid`.
    pub fn update(&mut self, t: f64, state: &State, centroid: (f64, f64)) -> Command {
        let e = (centroid.0 - state.x).hypot(centroid.1 - state.y);
        self.steer(t, state, centroid, e, None, UNBOUNDED)
    }

    /// The `course` mode's desired ground velocity towards `towards` with
    /// `remaining` metres still to go (a route may bend, so that can exceed
    /// the straight distance): w_d = S(remaining) along the line of sight,
    /// faded to 0 inside the arrival radius. The safety filter starts from this.
    pub fn desired_velocity(
        &self,
        state: &State,
        towards: (f64, f64),
        remaining: f64,
    ) -> (f64, f64) {
        let g = self.gains;
        let (ex, ey) = (towards.0 - state.x, towards.1 - state.y);
        let sight = ex.hypot(ey);
        // Inside the arrival radius the speed fades to zero smoothly (C¹)
        // instead of switching off, so that a vessel crossing it is asked
        // for no step (S(E) itself already vanishes with E).
        let arrive = if g.arrival_radius > 0.0 {
            smoothstep(remaining / g.arrival_radius)
        } else {
            1.0
        };
        let s = (g.k_u1 * (sigmoid(g.b2 * remaining) - 0.5) + g.k_u2 * remaining).min(g.max_speed)
            * arrive;
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
    /// [`update`](Self::update). `surge` bounds u_d (the safety filter's
    /// barrier; [`UNBOUNDED`] for none): where it moves past the command
    /// line, the line heads for it at the vessel's declared agility (at
    /// once, a step, for a vessel that declared none). The `paper` mode ignores `w_d` and
    /// `surge`: the literal law steers the bow, not a ground velocity.
    pub fn track(
        &mut self,
        t: f64,
        state: &State,
        towards: (f64, f64),
        remaining: f64,
        w_d: (f64, f64),
        surge: (f64, f64),
    ) -> Command {
        self.steer(t, state, towards, remaining, Some(w_d), surge)
    }

    /// The `course` mode's command line from `t` on, given the law's raw
    /// output (u, r, u̇ when it has one) and the surge bound: continuous in
    /// time and with bounded rates (see the module doc). Returns (u_d, r_d,
    /// u̇_d, ṙ_d, how much the bound cut the command).
    fn shape(
        &mut self,
        t: f64,
        state: &State,
        raw: (f64, f64, f64),
        surge: (f64, f64),
    ) -> (f64, f64, f64, f64, f64) {
        let g = self.gains;
        let yaw_accel = g.yaw_accel.min(self.agility.yaw_accel);
        // A declared surge agility is the actuators' share, and actuators
        // change the surge relative to what the hull does unforced: a body
        // turning at r with sway v has its surge change at v r with no force
        // at all (the rigid-body Coriolis term; all of it for the paper's
        // hull, m11 = m22). Going astern in a hard turn that is more than
        // the actuators can hold, so the agility bounds u̇_d around v r, not
        // around zero; the mission's bound, like ArduPilot's, stays absolute
        // and gives way where the two do not meet (the hull's physics wins).
        let natural = match state.vel.y * state.vel.z {
            // A pose too wild for the product is bounded by the mission's alone.
            x if x.is_finite() => x,
            _ => 0.0,
        };
        let agile = (
            natural - self.agility.surge_accel,
            natural + self.agility.surge_accel,
        );
        let (lo, hi) = if self.ahead_only {
            (surge.0.max(0.0), surge.1.max(0.0))
        } else {
            surge
        };
        let (raw_u, raw_r, raw_u_dot) = raw;
        let bounded_u = raw_u.max(lo).min(hi);
        // Where the line in force has got to; a vessel without one starts
        // from its own velocity, so its first command is no step either.
        let (u0, r0, period) = match self.line {
            Some(l) if t >= l.t && t - l.t <= LINE_GAP => {
                let since = t - l.t;
                let period = if since > 0.0 { since } else { FIRST_PERIOD };
                (l.u + l.u_dot * since, l.r + l.r_dot * since, period)
            }
            _ => (state.vel.x, state.vel.z, FIRST_PERIOD),
        };
        // The bound is a safety constraint: where it moves past the line,
        // the line heads for it, from where it is, as fast as the vessel
        // declared it can follow (a vessel that declared nothing is put
        // inside at once). A step would be no faster at the hull, whose
        // governor takes it at that same rate, and the bound does jump:
        // where a bow swings across a constraint's normal.
        let inside = u0.max(lo).min(hi);
        let u = if self.agility.surge_accel.is_finite() {
            u0
        } else {
            inside
        };
        let r = r0.clamp(-g.max_yaw_rate, g.max_yaw_rate);
        let cut = (bounded_u - raw_u).abs().max((inside - u0).abs());
        // Reach the law's output by the next command if the rate bounds
        // allow (u's own rate fed forward), never leaving the bounds, and
        // from outside them head there at the declared rate.
        let u_dot = (raw_u_dot + (bounded_u - u) / period)
            .clamp(-g.surge_accel, g.surge_accel)
            .clamp(agile.0, agile.1)
            .max(((lo - u) / period).min(agile.1.max(0.0)))
            .min(((hi - u) / period).max(agile.0.min(0.0)));
        let r_dot = ((raw_r - r) / period).clamp(-yaw_accel, yaw_accel).clamp(
            (-g.max_yaw_rate - r) / period,
            (g.max_yaw_rate - r) / period,
        );
        self.line = Some(Line {
            t,
            u,
            r,
            u_dot,
            r_dot,
        });
        (u, r, u_dot, r_dot, cut)
    }

    /// The `course` law's raw output for the desired ground velocity `wd`
    /// (see the module doc), its turn scaled by `authority` (see
    /// [`Order::Steer`]): (u_d, r_d, ψ_e, u̇_d).
    fn course(&mut self, state: &State, wd: (f64, f64), authority: f64) -> Output {
        let g = self.gains;
        let yaw = |err: f64| g.k_r1 * (sigmoid(g.b1 * err) - 0.5) + g.k_r2 * err;
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
            let r_d = authority
                * (yaw(psi_e) * (need / FADE).min(1.0)).clamp(-g.max_yaw_rate, g.max_yaw_rate);
            // Track only as far as the bow points the right way; else
            // coast (u_d = u at its natural rate v r), so no thrust
            // turns the velocity along with the hull.
            let alpha = psi_e.cos().max(0.0).powi(2);
            let (u, v) = (state.vel.x, state.vel.y);
            let u_d = alpha * u_d + (1.0 - alpha) * u;
            let u_d_dot = alpha * r_d * beam + (1.0 - alpha) * v * r_d;
            if self.ahead_only {
                // A hull that cannot go astern mostly cannot turn on
                // the spot either: its rudder or outboard bites only
                // with water flowing past. Coasting at rest, it would
                // never come round (ArduPilot's boats turn at
                // 0.03 rad/s so); keep steerage way instead, no more
                // than the speed wanted, so a vessel at its goal
                // stays put.
                let steerage = STEERAGE.min(wd.0.hypot(wd.1)) * (1.0 - alpha);
                if u_d < steerage {
                    (steerage, r_d, psi_e, Some(0.0))
                } else {
                    (u_d, r_d, psi_e, Some(u_d_dot))
                }
            } else {
                (u_d, r_d, psi_e, Some(u_d_dot))
            }
        }
    }

    fn steer(
        &mut self,
        t: f64,
        state: &State,
        centroid: (f64, f64),
        e: f64,
        w_d: Option<(f64, f64)>,
        surge: (f64, f64),
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
                let desired = self.desired_velocity(state, centroid, e);
                let wd = w_d.unwrap_or(desired);
                let yielding = (wd.0 - desired.0).hypot(wd.1 - desired.1) > YIELD;
                let hold_radius = match self.station_radius {
                    Some(r) if g.hold_radius > 0.0 => r.max(g.hold_radius),
                    _ => g.hold_radius,
                };
                let order = self.station.advance(&Look {
                    hold_radius,
                    state,
                    goal: centroid,
                    e,
                    goal_speed: self.c_dot.0.hypot(self.c_dot.1),
                    t,
                    yielding,
                    ahead_only: self.ahead_only,
                    holds_itself: self.station_radius.is_some(),
                });
                match order {
                    Order::Steer(authority) => self.course(state, wd, authority),
                    Order::Brake => self.course(state, (0.0, 0.0), 1.0),
                    Order::Hold { u, r, u_dot, psi_e } => (u, r, psi_e, Some(u_dot)),
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
        match (g.mode, exact_u_d_dot) {
            (GuidanceMode::Course, Some(u_dot)) => {
                let (u_d, r_d, u_d_dot, r_d_dot, surge_cut) =
                    self.shape(t, state, (u_d, r_d, u_dot), surge);
                Command {
                    u_d,
                    r_d,
                    u_d_dot,
                    r_d_dot,
                    e,
                    psi_e,
                    surge_cut,
                }
            }
            _ => Command {
                u_d,
                r_d,
                u_d_dot: self.u_d_dot,
                r_d_dot: self.r_d_dot,
                e,
                psi_e,
                surge_cut: 0.0,
            },
        }
    }
}

#[cfg(test)]
mod tests;
