//! The safety filter: control barrier functions on the fleet's desired
//! ground velocities.
//!
//! ## What is kept safe
//! For every pair of vessels the gap h_ij = ‖p_i − p_j‖ − D (D the safety
//! distance between centres), and for every vessel and shore edge the gap
//! h_ik = d(p_i, edge) − D_s (D_s the shore distance, signed: negative when
//! the vessel is outside Q). The filter keeps every gap ≥ 0.
//!
//! ## The barrier condition
//! A first-order barrier asks ḣ ≥ −α(h) of the commanded motion. ḣ_ij =
//! n_ij · (w_i − w_j) with n_ij the unit vector from j to i, so the condition
//! is linear in the desired ground velocities w. The class-K function α is
//! where the vessel's inertia enters: a hull cannot stop at once — with the
//! `course` guidance it first turns its bow (up to a right angle, astern
//! thrust allowed) and then brakes — so α(h) is the closing speed from which
//! a vessel that reacts after τ seconds and then brakes at a m/s² stops
//! within the gap h:
//!
//! ```text
//! s τ + s² / (2a) = h   ⇒   α(h) = a (√(τ² + 2h/a) − τ),   h ≥ 0,
//! α(h) = h / τ,                                            h < 0,
//! ```
//!
//! (the braking-distance barrier of Wang, Ames & Egerstedt's safety barrier
//! certificates for double integrators, with a reaction time added). The
//! second branch continues α with its slope 1/τ at 0, so a vessel already
//! inside the safety distance is asked to leave at a speed proportional to
//! the intrusion. A command that obeys α never asks to close a gap faster
//! than the hull can still cancel; τ and a are parameters, and their
//! defaults are measured against the paper's vessel (2000 kg, 1 m/s² of
//! thrust, 1 rad/s of yaw rate) — see `docs/safety.md`.
//!
//! ## The hull's lag: a relative-velocity-aware gap
//! The barrier constrains the *command*; the hull follows it seconds later
//! (the paper's hull keeps its ground velocity while it turns its bow, and
//! its sway is barely damped). A gap that the vessels are closing now will be
//! smaller when the command takes hold, so the filter uses the gap predicted
//! `lookahead` seconds ahead at the current closing speed,
//! h̃ = h − T max(0, s), s = −n · (w_i − w_j) the actual closing speed (own
//! velocity alone for the shore). A pair closing fast is filtered as if it
//! were already nearer, so braking starts early enough; a pair opening is
//! not relaxed. T is the lookahead plus the time the hull needs to turn its
//! thrust axis (ahead or astern) onto n at its yaw-rate limit, arccos|n·bow|
//! / r_max: a hull drifting sideways towards the shore must first turn
//! before any thrust slows that drift, so its gap is predicted further
//! ahead. h̃ is continuous in the state, so the filtered command does not
//! chatter from tick to tick.
//!
//! ## Decentralised, reciprocal
//! Each vessel solves its own problem with the positions it sees and takes
//! half of each pairwise budget: n_ij · w_i ≥ −α(h_ij)/2 (the Robotarium's
//! reciprocal split). If both vessels keep their halves the pair keeps the
//! whole; if one of them does not move at all (holding station, or its
//! command is stale) the other alone still never closes faster than α/2.
//! Shore constraints are the vessel's alone: n_ik · w_i ≥ −α(h_ik), n_ik
//! pointing from the nearest shore point into the water. A vessel's filter
//! needs no other vessel's command, so the fleet's filters are independent,
//! the order of vessels does not matter, and the result is deterministic.
//!
//! ## The filter
//! w_i = argmin ‖w − w_nom,i‖² subject to those half-planes
//! ([`halfplanes::nearest_feasible`](super::halfplanes::nearest_feasible)):
//! the smallest change of the nominal command that is safe. When the
//! constraints contradict each other (a vessel already too close to several
//! others and the shore at once) every demand to move away is dropped to
//! "close no gap" (b := min(b, 0)), which w = 0 always meets, and the
//! problem is solved again; the result is then capped at the vessel's
//! speed limit (scaling towards 0 keeps every "close no gap" constraint).
//!
//! ## The hull moves along its bow
//! The hull cannot take the filtered velocity at once: its thrust is along
//! the bow, and while it turns towards w_i it moves at its surge speed along
//! the bow plus whatever sway it has. The tracking sets the surge command
//! to the projection of w_i on the bow (or lets the hull coast while the bow
//! points the wrong way), which may close a gap w_i itself would not: two
//! hulls at rest, bows towards each other, asked to pass sideways, would
//! surge straight at each other. So the filter also returns, per vessel, the
//! interval of surge speeds u for which u·bow + sway meets every one of its
//! constraints ([`Safe::surge`]), and the caller holds the surge command
//! to it: an underactuated hull is only ever asked for the part of the
//! safe motion its thrust can give now. (The interval is not continuous
//! in the bow: it flips where the bow crosses the normal of a constraint
//! the sway alone does not meet, so the guidance approaches it at the
//! hull's own rate.) The interval always holds 0 when the
//! sway meets the constraints; when it does not, the constraints are
//! relaxed as above.
//!
//! ## Cost
//! Only neighbours and shore edges close enough for their constraint to
//! bind at the vessel's top speed v are considered ([`Barrier::horizon`]):
//! the reach 2vτ + 2v²/a (pairs, closing at most at 2v), resp. vτ + v²/(2a)
//! (shore), plus the longest prediction, (T + π/(2 r_max)) times that
//! closing speed. Neighbours come
//! from a bucket grid and shore edges from an R-tree, so the fleet costs
//! O(n k) for k neighbours per vessel.

use super::halfplanes::{HalfPlane, nearest_feasible};
use crate::geometry::grid::NeighbourGrid;
use crate::geometry::shore::{Shore, ShorePoint};
use crate::geometry::{Point, dot, norm2};

/// The filter's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Barrier {
    /// D: least distance between two vessels' centres [m].
    pub safety_distance: f64,
    /// D_s: least distance from a vessel's centre to the shore [m].
    pub shore_distance: f64,
    /// τ: time before braking starts (turning the bow, the command's hold) [s].
    pub reaction_time: f64,
    /// a: deceleration the hull can be counted on for [m/s²].
    pub braking: f64,
    /// T: how far ahead the gap is predicted at the actual closing speed [s].
    pub lookahead: f64,
}

impl Barrier {
    /// α(h): the closing speed that can still be cancelled within the gap h
    /// (negative inside the safety distance: the speed to leave at).
    pub fn stopping_speed(&self, h: f64) -> f64 {
        let (tau, a) = (self.reaction_time, self.braking);
        if h >= 0.0 {
            a * ((tau * tau + 2.0 * h / a).sqrt() - tau)
        } else {
            h / tau
        }
    }

    /// The gap beyond which α(h) exceeds `speed`, i.e. a constraint cannot
    /// bind for a command no faster than that.
    pub fn reach(&self, speed: f64) -> f64 {
        speed * self.reaction_time + speed * speed / (2.0 * self.braking)
    }

    /// The distance beyond which no constraint of a gap closing at most at
    /// `speed` can bind, for a hull turning at `turn_rate`: the reach plus
    /// the longest prediction (lookahead and a right-angle turn).
    pub fn horizon(&self, speed: f64, turn_rate: f64) -> f64 {
        let longest = self.lookahead + turn_time(std::f64::consts::FRAC_PI_2, turn_rate);
        self.reach(speed) + longest * speed
    }

    /// How far ahead a gap along `n` is predicted for a hull with bow `bow`:
    /// the lookahead plus the time to turn its thrust axis (ahead or
    /// astern) onto n — at most a right angle, which [`Barrier::horizon`]
    /// counts.
    fn prediction(&self, n: Point, me: &Desire) -> f64 {
        self.lookahead + turn_time(dot(n, me.bow).abs().min(1.0).acos(), me.turn_rate)
    }
}

/// Seconds to turn `angle` radians at `turn_rate` (none when the rate is not
/// positive: no turn is modelled).
fn turn_time(angle: f64, turn_rate: f64) -> f64 {
    if turn_rate > 0.0 {
        angle / turn_rate
    } else {
        0.0
    }
}

/// One vessel's input to the filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Desire {
    /// Where the vessel is [m].
    pub position: Point,
    /// Its actual ground velocity.
    pub actual: Point,
    /// The nominal desired ground velocity.
    pub velocity: Point,
    /// The vessel's speed limit [m/s].
    pub max_speed: f64,
    /// Its bow: the unit vector of its heading.
    pub bow: Point,
    /// The fastest it turns [rad/s] (the guidance's yaw-rate limit).
    pub turn_rate: f64,
}

/// One vessel's output of the filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Safe {
    /// The safe desired ground velocity, nearest the nominal one.
    pub velocity: Point,
    /// The surge speeds [m/s] that, along the bow and with the vessel's
    /// present sway, keep every constraint: `lo ≤ u ≤ hi`, within ± the
    /// speed limit.
    pub surge: (f64, f64),
}

/// Filters every vessel's desired velocity; returns the safe velocities and
/// surge intervals in the same order.
pub fn filter(barrier: &Barrier, shore: &Shore, fleet: &[Desire]) -> Vec<Safe> {
    filter_with(
        barrier,
        shore,
        fleet,
        fleet.len() >= crate::coverage::PARALLEL_MIN,
    )
}

/// [`filter`], on every core or on this thread.
fn filter_with(barrier: &Barrier, shore: &Shore, fleet: &[Desire], parallel: bool) -> Vec<Safe> {
    let traffic = Traffic::new(barrier, shore, fleet.iter().map(|d| d.mover()).collect());
    crate::coverage::map_indexed(fleet.len(), parallel, |i, scratch| {
        traffic.solve(i, fleet[i].velocity, scratch)
    })
}

/// A vessel's working memory for [`Traffic::solve`], reused from vessel to
/// vessel so that solving allocates nothing.
#[derive(Debug, Default)]
pub struct Scratch {
    neighbours: Vec<usize>,
    shore_points: Vec<ShorePoint>,
    constraints: Vec<HalfPlane>,
}

/// A vessel as the filters see it before its desired velocity is known:
/// everything in its [`Desire`] but the velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mover {
    /// Where the vessel is [m].
    pub position: Point,
    /// Its actual ground velocity.
    pub actual: Point,
    /// The unit vector of its heading.
    pub bow: Point,
    /// Its speed limit [m/s].
    pub max_speed: f64,
    /// The fastest it turns [rad/s].
    pub turn_rate: f64,
    /// How sure the others are of it ([`Margin::KNOWN`] for a vessel whose
    /// state is current).
    pub margin: Margin,
}

/// What the others keep in hand for a vessel they are not sure of: a
/// vessel of a peer fleet that fell silent is still physically there,
/// somewhere within `radius` of where it was last heard, and it may no
/// longer keep its half of any gap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margin {
    /// Added to the safety distance towards this vessel [m].
    pub radius: f64,
    /// Whether it keeps its half of each gap (the reciprocal split); when
    /// not, the other takes the whole budget, as it does towards the shore.
    pub reciprocal: bool,
}

impl Margin {
    /// A vessel whose state is current and whose filter runs.
    pub const KNOWN: Margin = Margin {
        radius: 0.0,
        reciprocal: true,
    };
}

impl Desire {
    /// This desire without its velocity.
    pub fn mover(&self) -> Mover {
        Mover {
            position: self.position,
            actual: self.actual,
            bow: self.bow,
            max_speed: self.max_speed,
            turn_rate: self.turn_rate,
            margin: Margin::KNOWN,
        }
    }
}

/// The fleet as one tick's filters see it: every vessel's [`Mover`] and the
/// neighbour grid. Built once per tick; then each vessel's problem
/// ([`Traffic::solve`]) reads only this and the vessel's own desired
/// velocity, so vessels are solved independently, in any order and on any
/// thread, with the same result — which is what lets the coordinator send
/// each command as soon as it is computed.
#[derive(Debug)]
pub struct Traffic<'a> {
    barrier: Barrier,
    shore: &'a Shore,
    fleet: Vec<Mover>,
    grid: NeighbourGrid,
    /// The largest [`Margin::radius`] of the fleet: neighbours are searched
    /// that much farther.
    widest: f64,
}

impl<'a> Traffic<'a> {
    /// `fleet` is every vessel, in fleet order.
    pub fn new(barrier: &Barrier, shore: &'a Shore, fleet: Vec<Mover>) -> Traffic<'a> {
        let top = fleet.iter().map(|m| m.max_speed).fold(0.0, f64::max);
        let slowest_turn = fleet
            .iter()
            .map(|m| m.turn_rate)
            .fold(f64::INFINITY, f64::min);
        let widest = fleet.iter().map(|m| m.margin.radius).fold(0.0, f64::max);
        let pair_radius =
            barrier.safety_distance + widest + barrier.horizon(2.0 * top, slowest_turn);
        let positions: Vec<Point> = fleet.iter().map(|m| m.position).collect();
        let grid = NeighbourGrid::new(&positions, pair_radius);
        Traffic {
            barrier: *barrier,
            shore,
            fleet,
            grid,
            widest,
        }
    }

    /// Vessel `i`'s safe velocity and surge interval, for its nominal
    /// desired ground velocity `velocity`.
    pub fn solve(&self, i: usize, velocity: Point, scratch: &mut Scratch) -> Safe {
        let barrier = &self.barrier;
        let m = self.fleet[i];
        let me = Desire {
            position: m.position,
            actual: m.actual,
            velocity,
            max_speed: m.max_speed,
            turn_rate: m.turn_rate,
            bow: m.bow,
        };
        let Scratch {
            neighbours,
            shore_points,
            constraints,
        } = scratch;
        let p = me.position;
        constraints.clear();
        self.grid.within(
            i,
            barrier.safety_distance
                + self.widest
                + barrier.horizon(2.0 * me.max_speed, me.turn_rate),
            neighbours,
        );
        for &j in neighbours.iter() {
            let d = self.fleet[j].position - p;
            let dist = norm2(d).sqrt();
            // n from j to i; coincident vessels part along x, the lower
            // index to the west, so that the pair still separates.
            let n = if dist > 0.0 {
                -d / dist
            } else if i < j {
                Point { x: -1.0, y: 0.0 }
            } else {
                Point { x: 1.0, y: 0.0 }
            };
            let other = &self.fleet[j];
            let closing = -dot(n, me.actual - other.actual);
            let gap = dist
                - barrier.safety_distance
                - other.margin.radius
                - barrier.prediction(n, &me) * closing.max(0.0);
            let share = if other.margin.reciprocal { 0.5 } else { 1.0 };
            constraints.push(HalfPlane {
                a: n,
                b: -share * barrier.stopping_speed(gap),
            });
        }
        let inside = self.shore.region().contains(p);
        self.shore.near(
            p,
            barrier.shore_distance + barrier.horizon(me.max_speed, me.turn_rate),
            shore_points,
        );
        for q in shore_points.iter() {
            let (n, signed) = if q.distance > 0.0 {
                let n = (p - q.point) / q.distance;
                if inside {
                    (n, q.distance)
                } else {
                    (-n, -q.distance)
                }
            } else {
                (q.inward, 0.0)
            };
            let closing = -dot(n, me.actual);
            let gap =
                signed - barrier.shore_distance - barrier.prediction(n, &me) * closing.max(0.0);
            constraints.push(HalfPlane {
                a: n,
                b: -barrier.stopping_speed(gap),
            });
        }
        let velocity = safe_velocity(me, constraints);
        Safe {
            velocity,
            surge: surge_interval(me, constraints),
        }
    }
}

/// The nearest safe velocity to the nominal one (see the module doc for
/// the contradictory case).
fn safe_velocity(me: Desire, constraints: &mut [HalfPlane]) -> Point {
    let w = nearest_feasible(me.velocity, constraints).or_else(|| {
        for h in constraints.iter_mut() {
            h.b = h.b.min(0.0);
        }
        nearest_feasible(me.velocity, constraints)
    });
    let w = w.unwrap_or(Point { x: 0.0, y: 0.0 });
    let speed = norm2(w).sqrt();
    if speed > me.max_speed && speed > 0.0 {
        w * (me.max_speed / speed)
    } else {
        w
    }
}

/// The surge speeds that keep every constraint, moving along the bow with
/// the present sway (see the module doc).
fn surge_interval(me: Desire, constraints: &[HalfPlane]) -> (f64, f64) {
    let along = dot(me.actual, me.bow);
    let sway = me.actual - me.bow * along;
    // Constraint k as c_k u ≥ r_k: c_k = a_k·bow, r_k = b_k − a_k·sway.
    let rows = || {
        constraints
            .iter()
            .map(|h| (dot(h.a, me.bow), h.b - dot(h.a, sway)))
    };
    // Only surges the hull can be asked for count: a bow nearly across a
    // constraint would otherwise demand any speed at all.
    let top = me.max_speed;
    let (mut lo, mut hi) = (-top, top);
    for (c, r) in rows() {
        if c > 1e-9 {
            lo = lo.max(r / c);
        } else if c < -1e-9 {
            hi = hi.min(r / c);
        }
    }
    if lo <= hi {
        return (lo, hi);
    }
    // No surge keeps them all: the one that violates the worst of them
    // least. The worst violation max_k (r_k − c_k u) is convex in u, so
    // bisect on the slope of the constraint that attains it (60 halvings:
    // to the last bit of the speed, so the result does not depend on where
    // the bisection stopped).
    let rows: Vec<(f64, f64)> = rows().collect();
    let (mut left, mut right) = (-top, top);
    for _ in 0..60 {
        let u = 0.5 * (left + right);
        let worst = rows.iter().fold((f64::NEG_INFINITY, 0.0), |w, &(c, r)| {
            let v = r - c * u;
            if v > w.0 { (v, c) } else { w }
        });
        if worst.1 > 0.0 {
            left = u;
        } else {
            right = u;
        }
    }
    let u = 0.5 * (left + right);
    (u, u)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Region;

    #[test]
    fn on_every_core_it_is_the_same_bit_for_bit() {
        let shore = Shore::new(&crate::geometry::region::fixtures::square(false));
        // A dense, tangled fleet: every vessel has many constraints.
        let fleet: Vec<Desire> = (0..300)
            .map(|k| {
                let t = k as f64;
                Desire {
                    position: Point {
                        x: (t * 37.1) % 100.0,
                        y: (t * 61.7) % 100.0,
                    },
                    actual: Point {
                        x: (t * 0.37).sin(),
                        y: (t * 0.71).cos(),
                    },
                    velocity: Point {
                        x: (t * 1.3).cos() * 1.5,
                        y: (t * 0.9).sin() * 1.5,
                    },
                    max_speed: 1.5,
                    bow: Point {
                        x: (t * 0.3).cos(),
                        y: (t * 0.3).sin(),
                    },
                    turn_rate: 1.0,
                }
            })
            .collect();
        let barrier = Barrier {
            safety_distance: 8.0,
            shore_distance: 4.0,
            reaction_time: 2.5,
            braking: 0.5,
            lookahead: 2.0,
        };
        let one = filter_with(&barrier, &shore, &fleet, false);
        let all = filter_with(&barrier, &shore, &fleet, true);
        assert_eq!(format!("{one:?}"), format!("{all:?}"));
    }

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    fn velocities(b: &Barrier, shore: &Shore, fleet: &[Desire]) -> Vec<Point> {
        filter(b, shore, fleet).iter().map(|s| s.velocity).collect()
    }

    fn barrier() -> Barrier {
        Barrier {
            safety_distance: 8.0,
            shore_distance: 4.0,
            reaction_time: 2.5,
            braking: 0.5,
            lookahead: 2.0,
        }
    }

    /// A vessel at rest at `position` that wants `velocity`.
    fn at_rest(position: Point, velocity: Point) -> Desire {
        Desire {
            position,
            actual: p(0.0, 0.0),
            velocity,
            max_speed: 2.0,
            bow: p(1.0, 0.0),
            turn_rate: 1.0,
        }
    }

    fn square() -> Shore {
        Shore::new(&crate::geometry::region::fixtures::square(false))
    }

    fn open_water() -> Shore {
        Shore::new(
            &Region::new(
                vec![
                    p(-1000.0, -1000.0),
                    p(1000.0, -1000.0),
                    p(1000.0, 1000.0),
                    p(-1000.0, 1000.0),
                ],
                vec![],
            )
            .unwrap(),
        )
    }

    #[test]
    fn stopping_speed_is_the_braking_distance() {
        let b = barrier();
        for h in [0.0, 0.5, 3.0, 20.0] {
            let s = b.stopping_speed(h);
            // React for τ at s, then brake to rest at a: exactly h.
            assert!((s * b.reaction_time + s * s / (2.0 * b.braking) - h).abs() < 1e-12);
        }
        assert_eq!(b.stopping_speed(-1.0), -1.0 / 2.5);
        assert!((b.reach(b.stopping_speed(7.0)) - 7.0).abs() < 1e-12);
    }

    #[test]
    fn far_apart_vessels_keep_their_commands() {
        let fleet = [
            at_rest(p(0.0, 0.0), p(2.0, 0.0)),
            at_rest(p(100.0, 0.0), p(-2.0, 0.0)),
        ];
        let w = velocities(&barrier(), &open_water(), &fleet);
        assert_eq!(w, vec![p(2.0, 0.0), p(-2.0, 0.0)]);
    }

    #[test]
    fn head_on_vessels_slow_to_half_the_stopping_speed_each() {
        let b = barrier();
        let fleet = [
            at_rest(p(0.0, 0.0), p(2.0, 0.5)),
            at_rest(p(12.0, 0.0), p(-2.0, 0.0)),
        ];
        let w = velocities(&b, &open_water(), &fleet);
        let half = 0.5 * b.stopping_speed(4.0);
        assert!((w[0].x - half).abs() < 1e-12 && w[0].y == 0.5, "{:?}", w[0]);
        assert!((w[1].x + half).abs() < 1e-12 && w[1].y == 0.0);
    }

    #[test]
    fn a_vessel_inside_the_safety_distance_is_sent_away() {
        let b = barrier();
        let fleet = [
            at_rest(p(0.0, 0.0), p(0.0, 0.0)),
            at_rest(p(6.0, 0.0), p(0.0, 0.0)),
        ];
        let w = velocities(&b, &open_water(), &fleet);
        assert!((w[0].x + 0.5 * 2.0 / 2.5).abs() < 1e-12, "{:?}", w[0]);
        assert!((w[1].x - 0.5 * 2.0 / 2.5).abs() < 1e-12);
    }

    #[test]
    fn the_shore_limits_the_approach_and_allows_sliding_along_it() {
        let b = barrier();
        let shore = square();
        let fleet = [at_rest(p(50.0, 6.0), p(1.5, -1.5))];
        let w = velocities(&b, &shore, &fleet);
        assert!((w[0].y + b.stopping_speed(2.0)).abs() < 1e-12, "{:?}", w[0]);
        assert_eq!(w[0].x, 1.5);
    }

    #[test]
    fn a_gap_closing_now_is_filtered_as_the_gap_it_will_be() {
        let b = barrier();
        let shore = square();
        let at = |actual| {
            velocities(
                &b,
                &shore,
                &[Desire {
                    actual,
                    position: p(50.0, 10.0),
                    velocity: p(0.0, -2.0),
                    max_speed: 2.0,
                    bow: p(0.0, -1.0),
                    turn_rate: 1.0,
                }],
            )[0]
        };
        // 6 m of gap; closing at 1 m/s, it is filtered as 6 − 2 = 4 m.
        assert!((at(p(0.0, -1.0)).y + b.stopping_speed(4.0)).abs() < 1e-12);
        // Opening: the present gap.
        assert!((at(p(0.0, 1.0)).y + b.stopping_speed(6.0)).abs() < 1e-12);
    }

    #[test]
    fn contradictory_demands_settle_for_closing_no_gap() {
        let b = barrier();
        // Squeezed between two vessels 5 m either side: each pair asks the
        // middle one to move away from it, which no velocity can do.
        let fleet = [
            at_rest(p(-5.0, 0.0), p(0.0, 0.0)),
            at_rest(p(0.0, 0.0), p(1.0, 0.3)),
            at_rest(p(5.0, 0.0), p(0.0, 0.0)),
        ];
        let w = velocities(&b, &open_water(), &fleet);
        assert_eq!(w[1], p(0.0, 0.3));
    }

    #[test]
    fn hulls_bow_to_bow_asked_to_pass_sideways_may_not_surge_at_each_other() {
        let b = barrier();
        // 10 m apart, bows towards each other, both asked to go north: the
        // safe velocities are the nominal ones (nothing closes), but surging
        // along the bows would close the gap at twice the surge.
        let mut fleet = [
            at_rest(p(0.0, 0.0), p(0.0, 2.0)),
            at_rest(p(10.0, 0.0), p(0.0, 2.0)),
        ];
        fleet[1].bow = p(-1.0, 0.0);
        let safe = filter(&b, &open_water(), &fleet);
        assert_eq!(safe[0].velocity, p(0.0, 2.0));
        let half = 0.5 * b.stopping_speed(2.0);
        for s in &safe {
            assert!((s.surge.1 - half).abs() < 1e-12, "{s:?}");
            assert_eq!(s.surge.0, -2.0);
        }
    }

    #[test]
    fn the_surge_interval_counts_the_sway() {
        let b = barrier();
        let shore = square();
        // 6 m off the south shore, bow east, drifting south at 0.5 m/s of
        // sway: no surge along the bow can undo the drift, so the
        // constraint is relaxed to closing no faster than the drift; a bow
        // pointing away from the shore must surge off it.
        let mut me = Desire {
            position: p(50.0, 6.0),
            actual: p(0.0, -0.5),
            velocity: p(1.0, 0.0),
            max_speed: 2.0,
            bow: p(1.0, 0.0),
            turn_rate: 1.0,
        };
        let s = filter(&b, &shore, &[me])[0];
        assert_eq!(s.surge, (-2.0, 2.0));
        me.bow = p(0.0, 1.0);
        me.actual = p(0.0, -0.5);
        let s = filter(&b, &shore, &[me])[0];
        // The hull is closing at 0.5 m/s along its (reversed) bow: the gap
        // is filtered as 6 − 4 − 2·0.5 = 1 m.
        assert!((s.surge.0 + b.stopping_speed(1.0)).abs() < 1e-12, "{s:?}");
        assert_eq!(s.surge.1, 2.0);
    }
}
