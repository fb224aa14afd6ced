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
//! not relaxed. h̃ is continuous in the state, so the filtered command does
//! not chatter from tick to tick.
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
//! ## Cost
//! Only neighbours and shore edges close enough for their constraint to
//! bind at the vessel's top speed v are considered: α(h) ≥ 2v (pairs) or
//! ≥ v (shore) beyond h = 2vτ + 2v²/a, resp. vτ + v²/(2a). Neighbours come
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
}

/// One vessel's input to the filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Desire {
    pub position: Point,
    /// Its actual ground velocity.
    pub actual: Point,
    /// The nominal desired ground velocity.
    pub velocity: Point,
    /// The vessel's speed limit [m/s].
    pub max_speed: f64,
}

/// Filters every vessel's desired velocity; returns the safe velocities in
/// the same order.
pub fn filter(barrier: &Barrier, shore: &Shore, fleet: &[Desire]) -> Vec<Point> {
    filter_with(
        barrier,
        shore,
        fleet,
        fleet.len() >= crate::coverage::PARALLEL_MIN,
    )
}

/// [`filter`], on every core or on this thread.
fn filter_with(barrier: &Barrier, shore: &Shore, fleet: &[Desire], parallel: bool) -> Vec<Point> {
    let top = fleet.iter().map(|d| d.max_speed).fold(0.0, f64::max);
    let pair_radius = barrier.safety_distance + barrier.reach(2.0 * top);
    let positions: Vec<Point> = fleet.iter().map(|d| d.position).collect();
    let grid = NeighbourGrid::new(&positions, pair_radius);
    // Each vessel's problem reads only the positions, so vessels are solved
    // independently; on every core for large fleets, with the same result.
    let solve = |i: usize,
                 (neighbours, shore_points, constraints): &mut (
        Vec<usize>,
        Vec<ShorePoint>,
        Vec<HalfPlane>,
    )| {
        let me = fleet[i];
        let p = me.position;
        constraints.clear();
        grid.within(
            i,
            barrier.safety_distance + barrier.reach(2.0 * me.max_speed),
            neighbours,
        );
        for &j in neighbours.iter() {
            let d = positions[j] - p;
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
            let closing = -dot(n, me.actual - fleet[j].actual);
            let gap = dist - barrier.safety_distance - barrier.lookahead * closing.max(0.0);
            constraints.push(HalfPlane {
                a: n,
                b: -0.5 * barrier.stopping_speed(gap),
            });
        }
        let inside = shore.region().contains(p);
        shore.near(
            p,
            barrier.shore_distance + barrier.reach(me.max_speed),
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
            let gap = signed - barrier.shore_distance - barrier.lookahead * closing.max(0.0);
            constraints.push(HalfPlane {
                a: n,
                b: -barrier.stopping_speed(gap),
            });
        }
        safe_velocity(me, constraints)
    };
    crate::coverage::map_indexed(fleet.len(), parallel, solve)
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
        }
    }

    fn square() -> Shore {
        Shore::new(
            &Region::new(
                vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)],
                vec![],
            )
            .unwrap(),
        )
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
        let w = filter(&barrier(), &open_water(), &fleet);
        assert_eq!(w, vec![p(2.0, 0.0), p(-2.0, 0.0)]);
    }

    #[test]
    fn head_on_vessels_slow_to_half_the_stopping_speed_each() {
        let b = barrier();
        let fleet = [
            at_rest(p(0.0, 0.0), p(2.0, 0.5)),
            at_rest(p(12.0, 0.0), p(-2.0, 0.0)),
        ];
        let w = filter(&b, &open_water(), &fleet);
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
        let w = filter(&b, &open_water(), &fleet);
        assert!((w[0].x + 0.5 * 2.0 / 2.5).abs() < 1e-12, "{:?}", w[0]);
        assert!((w[1].x - 0.5 * 2.0 / 2.5).abs() < 1e-12);
    }

    #[test]
    fn the_shore_limits_the_approach_and_allows_sliding_along_it() {
        let b = barrier();
        let shore = square();
        let fleet = [at_rest(p(50.0, 6.0), p(1.5, -1.5))];
        let w = filter(&b, &shore, &fleet);
        assert!((w[0].y + b.stopping_speed(2.0)).abs() < 1e-12, "{:?}", w[0]);
        assert_eq!(w[0].x, 1.5);
    }

    #[test]
    fn a_gap_closing_now_is_filtered_as_the_gap_it_will_be() {
        let b = barrier();
        let shore = square();
        let at = |actual| {
            filter(
                &b,
                &shore,
                &[Desire {
                    actual,
                    position: p(50.0, 10.0),
                    velocity: p(0.0, -2.0),
                    max_speed: 2.0,
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
        let w = filter(&b, &open_water(), &fleet);
        assert_eq!(w[1], p(0.0, 0.3));
    }
}
