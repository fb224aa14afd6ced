//! The safety watch of a simulated run: collisions, incursions and the
//! closest approaches, measured on the true states at every integration
//! step (1 kHz), not only at the coverage ticks.
//!
//! Definitions (`docs/safety.md`):
//! - a **collision** is two vessels' centres closer than twice the hull
//!   radius (their hull discs overlap); counted once per episode of a pair;
//! - an **incursion** is a vessel's hull disc reaching the shore: its centre
//!   outside Q (in an island, beyond the shell) or closer than the hull
//!   radius to ∂Q; counted once per episode of a vessel;
//! - **safety-distance breaches** count episodes of two centres closer than
//!   the safety distance, or of a centre closer than the shore distance to
//!   ∂Q — what the filter is meant to prevent, stricter than the above.
//!
//! An episode already under way at t = 0 (the scenario put the vessels
//! there: the paper's starts are 0.42 m from the edge) is counted apart, in
//! the `*_at_start` counts, and not in the plain ones, which count only the
//! episodes that begin later — what the run itself did. An episode present
//! at the start and still going counts once, at the start; once it ends,
//! a new one counts as any other.
//!
//! Cost: checking all pairs and the shore at every step would dominate the
//! run, so the checks are exact only where they can matter. At each tick
//! every pair closer than D + 2 (v̂ + 5 m/s) T is kept as a candidate (v̂ the
//! fleet's top speed at the tick, T the tick period): no other pair can
//! come within D before the next tick unless a hull gains 5 m/s within one
//! tick (50 m/s², far beyond any preset). For the shore each vessel keeps
//! its last exact clearance and the distance it has run since; it is
//! recomputed only once that could bring it within the shore distance
//! (plus 0.5 m).

use std::collections::BTreeSet;

use crate::control::model::State;
use crate::geometry::grid::NeighbourGrid;
use crate::geometry::shore::Shore;
use crate::geometry::{Point, norm2};

/// Fleets up to this size also get their closest pair at every tick from
/// all pairs.
const ALL_PAIRS_UP_TO: usize = 200;

/// What the watch found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyRecord {
    /// Episodes that began after t = 0.
    pub collisions: usize,
    pub incursions: usize,
    pub pair_breaches: usize,
    pub shore_breaches: usize,
    /// Episodes already under way at t = 0 (at the first tick, before any
    /// step): where the starts put the vessels, not what the run did.
    pub collisions_at_start: usize,
    pub incursions_at_start: usize,
    pub pair_breaches_at_start: usize,
    pub shore_breaches_at_start: usize,
    /// Least distance between two centres [m] (∞ for one vessel).
    pub min_pair_distance: f64,
    /// Least signed distance of a centre to ∂Q [m] (negative: outside Q).
    pub min_shore_clearance: f64,
    /// Vessel-ticks at which the filter intervened, and all vessel-ticks.
    pub interventions: usize,
    pub vessel_ticks: usize,
}

impl SafetyRecord {
    /// Fraction of vessel-ticks at which the filter changed the command.
    pub fn intervention_rate(&self) -> f64 {
        if self.vessel_ticks == 0 {
            0.0
        } else {
            self.interventions as f64 / self.vessel_ticks as f64
        }
    }
}

/// The watch's state between steps.
#[derive(Debug, Clone)]
pub struct Monitor {
    hull_radius: f64,
    safety_distance: f64,
    shore_distance: f64,
    tick_period: f64,
    candidates: Vec<(usize, usize)>,
    colliding: BTreeSet<(usize, usize)>,
    breaching: BTreeSet<(usize, usize)>,
    last_clearance: Vec<f64>,
    travelled: Vec<f64>,
    last_position: Vec<Point>,
    intruding: Vec<bool>,
    near_shore: Vec<bool>,
    /// No step taken yet: what is found now was there at t = 0.
    at_start: bool,
    pub record: SafetyRecord,
}

impl Monitor {
    pub fn new(
        n: usize,
        hull_radius: f64,
        safety_distance: f64,
        shore_distance: f64,
        tick_period: f64,
    ) -> Monitor {
        Monitor {
            hull_radius,
            safety_distance,
            shore_distance,
            tick_period,
            candidates: Vec::new(),
            colliding: BTreeSet::new(),
            breaching: BTreeSet::new(),
            last_clearance: vec![f64::NEG_INFINITY; n],
            travelled: vec![0.0; n],
            last_position: vec![Point { x: 0.0, y: 0.0 }; n],
            intruding: vec![false; n],
            near_shore: vec![false; n],
            at_start: true,
            record: SafetyRecord {
                collisions: 0,
                incursions: 0,
                pair_breaches: 0,
                shore_breaches: 0,
                collisions_at_start: 0,
                incursions_at_start: 0,
                pair_breaches_at_start: 0,
                shore_breaches_at_start: 0,
                min_pair_distance: f64::INFINITY,
                min_shore_clearance: f64::INFINITY,
                interventions: 0,
                vessel_ticks: 0,
            },
        }
    }

    /// At a tick: new pair candidates, exact shore clearances, and the
    /// filter's interventions of this tick.
    pub fn tick(
        &mut self,
        states: &[State],
        shore: &Shore,
        intervened: impl Iterator<Item = bool>,
    ) {
        for flag in intervened {
            self.record.vessel_ticks += 1;
            self.record.interventions += usize::from(flag);
        }
        let positions: Vec<Point> = states.iter().map(|s| Point { x: s.x, y: s.y }).collect();
        let top = states
            .iter()
            .map(|s| {
                let (vx, vy) = s.ground_velocity();
                vx.hypot(vy)
            })
            .fold(0.0, f64::max);
        let radius =
            self.safety_distance.max(2.0 * self.hull_radius) + 2.0 * (top + 5.0) * self.tick_period;
        self.candidates.clear();
        let grid = NeighbourGrid::new(&positions, radius);
        let mut near = Vec::new();
        for i in 0..positions.len() {
            grid.within(i, radius, &mut near);
            self.candidates
                .extend(near.iter().filter(|&&j| j > i).map(|&j| (i, j)));
        }
        for (i, &q) in positions.iter().enumerate() {
            self.shore_exact(i, q, shore);
        }
        // The closest pair even when none comes near: all pairs at the tick
        // while that is cheap.
        if positions.len() <= ALL_PAIRS_UP_TO {
            for i in 0..positions.len() {
                for j in i + 1..positions.len() {
                    let d = norm2(positions[i] - positions[j]).sqrt();
                    self.record.min_pair_distance = self.record.min_pair_distance.min(d);
                }
            }
        }
        self.pairs(states);
    }

    /// After an integration step.
    pub fn step(&mut self, states: &[State], shore: &Shore) {
        self.at_start = false;
        for (i, s) in states.iter().enumerate() {
            let p = Point { x: s.x, y: s.y };
            self.travelled[i] += norm2(p - self.last_position[i]).sqrt();
            self.last_position[i] = p;
            if self.last_clearance[i] - self.travelled[i] < self.shore_distance + 0.5 {
                self.shore_exact(i, p, shore);
            }
        }
        self.pairs(states);
    }

    fn shore_exact(&mut self, i: usize, p: Point, shore: &Shore) {
        let c = shore.signed_clearance(p);
        self.last_clearance[i] = c;
        self.travelled[i] = 0.0;
        self.last_position[i] = p;
        let at_start = self.at_start;
        let r = &mut self.record;
        r.min_shore_clearance = r.min_shore_clearance.min(c);
        let intruding = c < self.hull_radius;
        if intruding && !self.intruding[i] {
            *if at_start {
                &mut r.incursions_at_start
            } else {
                &mut r.incursions
            } += 1;
        }
        self.intruding[i] = intruding;
        let near = c < self.shore_distance;
        if near && !self.near_shore[i] {
            *if at_start {
                &mut r.shore_breaches_at_start
            } else {
                &mut r.shore_breaches
            } += 1;
        }
        self.near_shore[i] = near;
    }

    fn pairs(&mut self, states: &[State]) {
        let collide2 = (2.0 * self.hull_radius).powi(2);
        let breach2 = self.safety_distance.powi(2);
        let r = &mut self.record;
        let (collisions, breaches) = if self.at_start {
            (&mut r.collisions_at_start, &mut r.pair_breaches_at_start)
        } else {
            (&mut r.collisions, &mut r.pair_breaches)
        };
        for &(i, j) in &self.candidates {
            let d2 = (states[i].x - states[j].x).powi(2) + (states[i].y - states[j].y).powi(2);
            r.min_pair_distance = r.min_pair_distance.min(d2.sqrt());
            if d2 < collide2 {
                if self.colliding.insert((i, j)) {
                    *collisions += 1;
                }
            } else {
                self.colliding.remove(&(i, j));
            }
            if d2 < breach2 {
                if self.breaching.insert((i, j)) {
                    *breaches += 1;
                }
            } else {
                self.breaching.remove(&(i, j));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Vec3;

    fn at(x: f64, y: f64) -> State {
        State {
            x,
            y,
            psi: 0.0,
            vel: Vec3::zeros(),
        }
    }

    #[test]
    fn counts_episodes_not_steps() {
        let p = |x, y| Point { x, y };
        let square = crate::geometry::Region::new(
            vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)],
            vec![],
        )
        .expect("a valid region");
        let shore = Shore::new(&square);
        let mut m = Monitor::new(2, 2.0, 8.0, 4.0, 0.1);
        let mut s = vec![at(50.0, 50.0), at(58.0, 50.0)];
        m.tick(&s, &shore, [false, true].into_iter());
        // Vessel 1 runs through vessel 0 and on, then vessel 0 ashore.
        for k in 0..200 {
            s[1].x = 58.0 - 0.1 * k as f64;
            m.step(&s, &shore);
        }
        for k in 0..110 {
            s[0].y = 50.0 - 0.5 * k as f64;
            m.step(&s, &shore);
        }
        let r = m.record;
        assert_eq!((r.collisions, r.pair_breaches), (1, 1));
        assert_eq!((r.incursions, r.shore_breaches), (1, 1));
        assert_eq!(
            (
                r.collisions_at_start,
                r.pair_breaches_at_start,
                r.incursions_at_start,
                r.shore_breaches_at_start
            ),
            (0, 0, 0, 0)
        );
        assert!(r.min_pair_distance < 0.1);
        assert!(r.min_shore_clearance < 0.0);
        assert_eq!(r.intervention_rate(), 0.5);
    }

    #[test]
    fn what_the_starts_put_there_counts_apart() {
        let p = |x, y| Point { x, y };
        let square = crate::geometry::Region::new(
            vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)],
            vec![],
        )
        .expect("a valid region");
        let shore = Shore::new(&square);
        // Vessel 0 starts 0.42 m from the edge (as the paper's do), vessels
        // 1 and 2 start 3 m apart (hulls overlap).
        let mut m = Monitor::new(3, 2.0, 8.0, 4.0, 0.1);
        let mut s = vec![at(0.42, 50.0), at(50.0, 50.0), at(53.0, 50.0)];
        m.tick(&s, &shore, [false, false, false].into_iter());
        // All leave: vessel 0 to 10 m off the shore, vessel 2 to 20 m away.
        for k in 1..=100 {
            s[0].x = 0.42 + 0.0958 * k as f64;
            s[2].x = 53.0 + 0.17 * k as f64;
            m.step(&s, &shore);
            if k % 10 == 0 {
                m.tick(&s, &shore, [false, false, false].into_iter());
            }
        }
        let r = m.record;
        assert_eq!((r.incursions_at_start, r.incursions), (1, 0));
        assert_eq!((r.shore_breaches_at_start, r.shore_breaches), (1, 0));
        assert_eq!((r.collisions_at_start, r.collisions), (1, 0));
        assert_eq!((r.pair_breaches_at_start, r.pair_breaches), (1, 0));
        // Back ashore later: a new incursion, counted as the run's.
        for k in 1..=30 {
            s[0].x = 10.0 - 0.5 * k as f64;
            m.step(&s, &shore);
        }
        let r = m.record;
        assert_eq!((r.incursions_at_start, r.incursions), (1, 1));
        assert_eq!((r.shore_breaches_at_start, r.shore_breaches), (1, 1));
    }
}
