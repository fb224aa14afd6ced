//! A plan for a fleet split in two groups that cannot hear each other (a
//! radio partition): where each vessel goes so that each group covers the
//! whole region by itself and no vessel of one comes within a separation of
//! a vessel of the other, on the way or there, with no word between them.
//!
//! Both groups compute the plan from the same inputs (each vessel's position
//! when the link broke: the other group's from their last beacons, its own
//! group's as it knows them) with this same deterministic code, so both
//! get the same plan up to how far those inputs differ; the caller gives
//! the groups in an order both agree on (see [`plan`]).
//!
//! ## The plan
//! 1. Each group's own optimum: Lloyd's iteration (every vessel to its
//!    cell's centroid, [`evaluate`]) from where it was, until no vessel
//!    moves more than [`SplitParams::tolerance`]. A group alone covers the
//!    whole region, so its optimum spreads over all of it, and the two
//!    groups' optima can put vessels on the same water.
//! 2. Pushed apart: every pair of places of different groups closer than
//!    the separation is moved apart along its line, half the deficit
//!    each. Near a group's optimum H is flat (its gradient vanishes
//!    there), so moving a vessel a few metres costs little coverage: in
//!    the paper's 4 | 4 split 0.5 % of each group's H for 8.5 m apart
//!    (docs/peer.md). Then the ways: where two vessels' straight ways
//!    would meet, one must go first and the other after it has passed.
//!    Going first, a vessel needs its way clear of where the other waits
//!    and its place clear of the other's way; of the two orders the one
//!    that lacks less is taken, and the first one's place is pushed off
//!    the other's way and away from where it waits (its start cannot
//!    move, so its way only moves with its end). Sweep after sweep until
//!    nothing is pushed or [`SplitParams::sweeps`] have passed.
//! 3. The way there: every vessel moves along the straight line from its
//!    start to its placement at [`SplitParams::speed`], leaving after a
//!    delay of its own. Straight ways of two groups that trade water cross,
//!    so the delays are chosen one vessel at a time, the longest move
//!    first: the least whole number of [`SplitParams::wait`]s for which its
//!    way keeps the separation from every vessel already given its delay,
//!    moving or waiting (and, for two vessels that start or end closer than
//!    that, no closer than they start or end). [`SplitPlan::closest`] is the
//!    least distance between vessels of different groups on the way. With
//!    [`SplitParams::starts_kept`] a way also keeps clear of where the
//!    other group's vessels started, for a while, as if they had not left.
//!    Where no delay up to [`SplitParams::waits`] clears a vessel (after it
//!    has been moved to the front of the order once) the plan is not
//!    [`SplitPlan::clear`], and the caller does not follow it.
//! 4. When the ways of step 3 are not clear, each group keeps to its own
//!    water instead ([`Water::Own`]): steps 1 to 3 again, with each
//!    group's optimum that of Lloyd's iteration among its own vessels and
//!    the other group's held where they were at the cut (so a group at the
//!    joint optimum stays where it is). It is what both readings of the
//!    silence allow: if the other group is cut off it covers its own water,
//!    and if it is wrecks they are never approached; the cost is that a
//!    wreck's water stays uncovered while the plan lasts.
//!
//! Pure and deterministic; it cannot fail once the inputs are valid (a
//! vessel that Lloyd's iteration would carry out of the region is kept at
//! the region's nearest point).

use super::density::RiskField;
use super::evaluate::{Options, evaluate};
use super::fleet::{Fleet, Vessel};
use crate::geometry::{Point, Region, dot, norm2};

/// How a split's plan is made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplitParams {
    /// Least distance between vessels of different groups [m].
    pub separation: f64,
    /// Speed of every vessel on the way [m/s].
    pub speed: f64,
    /// The step of the delays before a vessel leaves [s].
    pub wait: f64,
    /// At most this many steps of delay.
    pub waits: usize,
    /// Lloyd's iteration stops when no vessel moves more than this [m].
    pub tolerance: f64,
    /// At most this many Lloyd steps per group.
    pub steps: usize,
    /// At most this many sweeps of pushes.
    pub sweeps: usize,
    /// (radius [m], until [s]): every way keeps this far from where each
    /// vessel of the other group started until this long into the plan
    /// (or no nearer than it starts), whatever that vessel's own way:
    /// a group that fell silent together may be wrecks that never leave.
    /// `None`: only the vessels' ways count.
    pub starts_kept: Option<(f64, f64)>,
}

impl SplitParams {
    /// Both groups follow the plan, each taking half of every push.
    pub fn both(separation: f64, speed: f64) -> SplitParams {
        SplitParams {
            separation,
            speed,
            wait: 1.0,
            waits: 600,
            tolerance: 1e-3,
            steps: 2000,
            sweeps: 1000,
            starts_kept: None,
        }
    }
}

/// What each group of a plan covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Water {
    /// The whole region (steps 1 to 3 of the module doc).
    Region,
    /// Its own water, the other group held where it was (step 4).
    Own,
}

/// Where every vessel of both groups starts and ends, in the groups' order,
/// and when it leaves.
#[derive(Debug, Clone, PartialEq)]
pub struct SplitPlan {
    /// What each group covers.
    pub water: Water,
    /// Where each vessel starts: its position as given [m].
    pub start: [Vec<Point>; 2],
    /// Where each vessel ends: its group's optimum, pushed apart from the
    /// other group's (step 2) [m].
    pub end: [Vec<Point>; 2],
    /// Each group's own optimum before the pushes (step 1).
    pub optimum: [Vec<Point>; 2],
    /// Seconds from the plan's start until each vessel leaves.
    pub delay: [Vec<f64>; 2],
    /// Every vessel's speed on the way [m/s].
    pub speed: f64,
    /// Seconds from the start until every vessel is at its end.
    pub duration: f64,
    /// Whether every pair keeps, all the way, the separation (or, for two
    /// vessels that start or end nearer, no less than that): a plan that
    /// is not clear is not to be followed.
    pub clear: bool,
}

/// One vessel's way: waits at `a` until `leave`, moves at constant
/// velocity, is at `b` from `arrive` on.
#[derive(Debug, Clone, Copy)]
struct Way {
    a: Point,
    b: Point,
    leave: f64,
    arrive: f64,
}

impl Way {
    fn new(a: Point, b: Point, leave: f64, speed: f64) -> Way {
        let length = norm2(b - a).sqrt();
        let travel = if length > 0.0 && speed > 0.0 {
            length / speed
        } else {
            0.0
        };
        Way {
            a,
            b,
            leave,
            arrive: leave + travel,
        }
    }

    fn at(&self, tau: f64) -> Point {
        if tau <= self.leave || self.arrive <= self.leave {
            return if tau < self.arrive { self.a } else { self.b };
        }
        let s = ((tau - self.leave) / (self.arrive - self.leave)).clamp(0.0, 1.0);
        self.a + (self.b - self.a) * s
    }

    fn velocity(&self, tau: f64) -> Point {
        if tau < self.leave || tau >= self.arrive {
            Point { x: 0.0, y: 0.0 }
        } else {
            (self.b - self.a) * (1.0 / (self.arrive - self.leave))
        }
    }
}

/// The least distance between two vessels on their ways at any time. Both
/// move at constant velocity between consecutive times at which either
/// leaves or arrives, so their difference is a straight segment on each
/// such interval, and its least norm is at the clamped foot of the
/// perpendicular from 0.
fn least_between(u: &Way, v: &Way) -> f64 {
    let mut times = [0.0, u.leave, u.arrive, v.leave, v.arrive];
    times.sort_by(f64::total_cmp);
    let gap = |tau: f64| u.at(tau) - v.at(tau);
    let mut least = norm2(gap(times[4])).sqrt();
    for w in times.windows(2) {
        let (d0, d1) = (gap(w[0]), gap(w[1]));
        let delta = d1 - d0;
        let dd = norm2(delta);
        let s = if dd > 0.0 {
            (-dot(d0, delta) / dd).clamp(0.0, 1.0)
        } else {
            0.0
        };
        least = least.min(norm2(d0 + delta * s).sqrt());
    }
    least
}

impl SplitPlan {
    fn way(&self, group: usize, i: usize) -> Way {
        Way::new(
            self.start[group][i],
            self.end[group][i],
            self.delay[group][i],
            self.speed,
        )
    }

    /// Where vessel `i` of `group` is `tau` seconds into the plan.
    pub fn at(&self, group: usize, i: usize, tau: f64) -> Point {
        self.way(group, i).at(tau)
    }

    /// Its velocity then [m/s] (zero while it waits and once there).
    pub fn velocity(&self, group: usize, i: usize, tau: f64) -> Point {
        self.way(group, i).velocity(tau)
    }

    /// The least distance between two vessels of different groups at any
    /// time of the plan [m].
    pub fn closest(&self) -> f64 {
        let mut least = f64::INFINITY;
        for i in 0..self.start[0].len() {
            for j in 0..self.start[1].len() {
                least = least.min(least_between(&self.way(0, i), &self.way(1, j)));
            }
        }
        least
    }
}

/// The plan for `groups` (each in an order both groups agree on, e.g. by
/// id, and the groups themselves in such an order) over `region` under
/// `risk`. `None` when a group is empty.
pub fn plan(
    region: &Region,
    risk: &RiskField,
    groups: [&[Vessel]; 2],
    params: &SplitParams,
) -> Option<SplitPlan> {
    if groups.iter().any(|g| g.is_empty()) {
        return None;
    }
    let whole = plan_for(region, risk, groups, params, Water::Region);
    if whole.clear {
        return Some(whole);
    }
    let own = plan_for(region, risk, groups, params, Water::Own);
    Some(if own.clear { own } else { whole })
}

/// Steps 1 to 3 for `water`.
fn plan_for(
    region: &Region,
    risk: &RiskField,
    groups: [&[Vessel]; 2],
    params: &SplitParams,
    water: Water,
) -> SplitPlan {
    let optimum = match water {
        Water::Region => groups.map(|g| lloyd(region, risk, g, &[], params)),
        Water::Own => [
            lloyd(region, risk, groups[0], groups[1], params),
            lloyd(region, risk, groups[1], groups[0], params),
        ],
    };
    let start = groups.map(|g| g.iter().map(|v| v.position).collect::<Vec<_>>());
    let mut end = optimum.clone();
    push_apart(region, &start, &mut end, params);
    let (delay, clear) = schedule(&start, &end, params);
    let duration = (0..2)
        .flat_map(|g| (0..start[g].len()).map(move |i| (g, i)))
        .map(|(g, i)| Way::new(start[g][i], end[g][i], delay[g][i], params.speed).arrive)
        .fold(0.0, f64::max);
    SplitPlan {
        water,
        start,
        end,
        optimum,
        delay,
        speed: params.speed,
        duration,
        clear,
    }
}

/// Step 3 of the module doc: each vessel's delay, and whether they clear
/// every pair.
fn schedule(
    start: &[Vec<Point>; 2],
    end: &[Vec<Point>; 2],
    params: &SplitParams,
) -> ([Vec<f64>; 2], bool) {
    let mut order: Vec<(usize, usize)> = (0..2)
        .flat_map(|g| (0..start[g].len()).map(move |i| (g, i)))
        .collect();
    let length = |&(g, i): &(usize, usize)| norm2(end[g][i] - start[g][i]).sqrt();
    // Longest first; ties in the groups' order (a stable sort).
    order.sort_by(|a, b| length(b).total_cmp(&length(a)));
    // A vessel no delay clears must leave before one placed ahead of it
    // (say, that one ends where it waits): it moves to the front and the
    // delays are chosen again, at most once per vessel.
    let mut best: Option<(usize, [Vec<f64>; 2])> = None;
    for _ in 0..=order.len() {
        let (failed, delay) = delays(&order, start, end, params);
        let Some(k) = failed else {
            return (delay, true);
        };
        if best.as_ref().is_none_or(|(placed, _)| k > *placed) {
            best = Some((k, delay));
        }
        let stuck = order.remove(k);
        order.insert(0, stuck);
    }
    let (_, delay) = best.expect("one round at least");
    (delay, false)
}

/// Delays in `order`; the place in `order` of the first vessel no delay
/// clears (it is left without one), if any.
fn delays(
    order: &[(usize, usize)],
    start: &[Vec<Point>; 2],
    end: &[Vec<Point>; 2],
    params: &SplitParams,
) -> (Option<usize>, [Vec<f64>; 2]) {
    let mut delay = [vec![0.0; start[0].len()], vec![0.0; start[1].len()]];
    // Vessels of one group hear each other and keep their gaps by
    // themselves, but a plan that needs them to dodge would leave its ways:
    // every pair is kept apart alike.
    let mut placed: Vec<Way> = Vec::new();
    let mut failed = None;
    for (k, &(g, i)) in order.iter().enumerate() {
        let clear = |way: &Way| {
            placed.iter().all(|other| {
                let need = params
                    .separation
                    .min(norm2(way.a - other.a).sqrt())
                    .min(norm2(way.b - other.b).sqrt());
                least_between(way, other) >= need - 1e-9
            }) && params.starts_kept.is_none_or(|(radius, until)| {
                // Until then the way runs from its start to where it is at
                // `until`: that segment keeps clear of every start.
                let reached = way.at(until);
                start[1 - g].iter().all(|&q| {
                    let need = radius.min(norm2(way.a - q).sqrt());
                    norm2(closest_on_segment(way.a, reached, q) - q).sqrt() >= need - 1e-9
                })
            })
        };
        let chosen = (0..=params.waits)
            .map(|n| Way::new(start[g][i], end[g][i], n as f64 * params.wait, params.speed))
            .find(|w| clear(w));
        let way = chosen.unwrap_or_else(|| {
            failed = failed.or(Some(k));
            Way::new(start[g][i], end[g][i], 0.0, params.speed)
        });
        delay[g][i] = way.leave;
        placed.push(way);
    }
    (failed, delay)
}

/// A group's own optimum by Lloyd's iteration from where it is, among
/// `held` vessels that keep their places (none: the whole region).
fn lloyd(
    region: &Region,
    risk: &RiskField,
    group: &[Vessel],
    held: &[Vessel],
    params: &SplitParams,
) -> Vec<Point> {
    let mut vessels = [group, held].concat();
    for _ in 0..params.steps {
        // Positions stay inside the region (centroids of cells in it), so
        // the fleet stays valid.
        let Ok(fleet) = Fleet::new(vessels.clone()) else {
            break;
        };
        let evaluation = evaluate(region, risk, &fleet, &Options::default());
        let mut moved: f64 = 0.0;
        for (v, c) in vessels.iter_mut().zip(&evaluation.cells).take(group.len()) {
            moved = moved.max(norm2(c.centroid - v.position).sqrt());
            v.position = c.centroid;
        }
        if moved <= params.tolerance {
            break;
        }
    }
    vessels[..group.len()].iter().map(|v| v.position).collect()
}

/// Step 2 of the module doc.
fn push_apart(
    region: &Region,
    start: &[Vec<Point>; 2],
    end: &mut [Vec<Point>; 2],
    params: &SplitParams,
) {
    let sep = params.separation;
    // A little past the deficit, so that a pair pushed to exactly the
    // separation is not pushed again by rounding.
    let over = 1e-6;
    let away = |d: Point, dist: f64| {
        if dist > 0.0 {
            d * (1.0 / dist)
        } else {
            Point { x: 1.0, y: 0.0 }
        }
    };
    for _ in 0..params.sweeps {
        let mut pushed = false;
        for i in 0..end[0].len() {
            for j in 0..end[1].len() {
                let d = end[0][i] - end[1][j];
                let dist = norm2(d).sqrt();
                if dist >= sep {
                    continue;
                }
                pushed = true;
                let u = away(d, dist);
                let deficit = sep - dist + over;
                end[0][i] = region.closest_point(end[0][i] + u * (deficit * 0.5));
                end[1][j] = region.closest_point(end[1][j] - u * (deficit * 0.5));
            }
        }
        // Two ways that meet: one vessel goes first, the other after it
        // (step 3 finds when). Going first, a needs its way clear of where
        // b waits and its place clear of b's way, later; whichever order
        // lacks less is kept, and the place of the vessel that goes first
        // is pushed off the other's way (the way itself, from a start that
        // cannot move, is only moved by moving its end).
        for i in 0..end[0].len() {
            for j in 0..end[1].len() {
                let a = (start[0][i], end[0][i]);
                let b = (start[1][j], end[1][j]);
                if least_between(&Way::new(a.0, a.1, 0.0, 1.0), &Way::new(b.0, b.1, 0.0, 1.0))
                    >= sep
                {
                    continue;
                }
                let lack = |first: (Point, Point), then: (Point, Point)| {
                    let waits = norm2(then.0 - closest_on_segment(first.0, first.1, then.0)).sqrt();
                    let ends = norm2(first.1 - closest_on_segment(then.0, then.1, first.1)).sqrt();
                    (sep - waits).max(0.0) + (sep - ends).max(0.0)
                };
                let (g, k, o, l) = if lack(a, b) <= lack(b, a) {
                    (0, i, 1, j)
                } else {
                    (1, j, 0, i)
                };
                let q = end[g][k];
                let foot = closest_on_segment(start[o][l], end[o][l], q);
                let d = q - foot;
                let dist = norm2(d).sqrt();
                if dist < sep {
                    pushed = true;
                    end[g][k] = region.closest_point(q + away(d, dist) * (sep - dist + over));
                }
                // Its way clear of where the other waits: only the end of
                // a way can move, so only when the end is what is near.
                let waits = start[o][l];
                let foot = closest_on_segment(start[g][k], end[g][k], waits);
                let d = end[g][k] - waits;
                let dist = norm2(d).sqrt();
                if foot == end[g][k] && dist < sep {
                    pushed = true;
                    end[g][k] =
                        region.closest_point(end[g][k] + away(d, dist) * (sep - dist + over));
                }
            }
        }
        if !pushed {
            break;
        }
    }
}

/// The point of the segment a–b nearest q.
fn closest_on_segment(a: Point, b: Point, q: Point) -> Point {
    let ab = b - a;
    let n = norm2(ab);
    if n == 0.0 {
        return a;
    }
    a + ab * (dot(q - a, ab) / n).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::RiskObject;
    use crate::coverage::fleet::{DEFAULT_BETA, DEFAULT_K};
    use crate::geometry::region::fixtures::square;

    fn vessel(x: f64, y: f64) -> Vessel {
        Vessel {
            position: Point { x, y },
            k: DEFAULT_K,
            beta: DEFAULT_BETA,
        }
    }

    fn h(region: &Region, risk: &RiskField, points: &[Point]) -> f64 {
        let fleet = Fleet::new(points.iter().map(|p| vessel(p.x, p.y)).collect()).unwrap();
        evaluate(region, risk, &fleet, &Options::default()).h
    }

    /// Two groups of two on a uniform square, interleaved: alone, each
    /// group's optimum is the same pair of points, so the pushes decide.
    #[test]
    fn the_groups_end_apart_and_stay_apart_on_the_way() {
        let region = square(false);
        let risk = RiskField::new(1.0, vec![]).unwrap();
        let a = [vessel(20.0, 30.0), vessel(70.0, 60.0)];
        let b = [vessel(30.0, 70.0), vessel(80.0, 20.0)];
        let params = SplitParams::both(9.0, 0.5);
        let plan = plan(&region, &risk, [&a, &b], &params).unwrap();
        for p in &plan.end[0] {
            for q in &plan.end[1] {
                assert!(norm2(*p - *q).sqrt() >= 9.0 - 1e-9, "{p:?} {q:?}");
            }
        }
        // On the way: sampled every 10 ms, no two vessels of different
        // groups closer than the separation, and `closest` no farther than
        // the samples' least distance.
        let mut sampled = f64::INFINITY;
        let steps = (plan.duration * 100.0).ceil() as usize;
        for k in 0..=steps {
            let tau = k as f64 / 100.0;
            for i in 0..2 {
                for j in 0..2 {
                    let d = norm2(plan.at(0, i, tau) - plan.at(1, j, tau)).sqrt();
                    sampled = sampled.min(d);
                }
            }
        }
        assert!(plan.clear);
        assert!(sampled >= 9.0 - 1e-6, "{sampled}");
        assert!(plan.closest() >= 9.0 - 1e-6, "{}", plan.closest());
        assert!(plan.closest() <= sampled + 1e-9);
        // Each group keeps most of its own optimum's H.
        for g in 0..2 {
            let ratio = h(&region, &risk, &plan.end[g]) / h(&region, &risk, &plan.optimum[g]);
            assert!(ratio > 0.95 && ratio <= 1.0 + 1e-12, "group {g}: {ratio}");
        }
        // Every vessel moves at the plan's speed once it leaves, and is at
        // its end when the plan's duration is over.
        for g in 0..2 {
            for i in 0..2 {
                let length = norm2(plan.end[g][i] - plan.start[g][i]).sqrt();
                let leave = plan.delay[g][i];
                let w = plan.velocity(g, i, leave + 1e-3);
                assert!(length == 0.0 || (norm2(w).sqrt() - 0.5).abs() < 1e-9);
                assert!(leave + length / 0.5 <= plan.duration + 1e-9);
                assert_eq!(plan.at(g, i, plan.duration), plan.end[g][i]);
                assert_eq!(plan.at(g, i, leave), plan.start[g][i]);
                assert_eq!(plan.at(g, i, -1.0), plan.start[g][i]);
            }
        }
    }

    /// With the other group's starts kept: no way comes within the radius
    /// of one before `until` (sampled), though the plan's ends are the same
    /// and some way does come that near later (the ends trade water).
    #[test]
    fn starts_are_kept_clear_until_the_time_given() {
        let region = square(false);
        let risk = RiskField::new(1.0, vec![]).unwrap();
        let a = [vessel(22.0, 50.0), vessel(78.0, 50.0)];
        let b = [vessel(40.0, 45.0), vessel(60.0, 55.0)];
        let free = plan(&region, &risk, [&a, &b], &SplitParams::both(9.0, 0.5)).unwrap();
        let params = SplitParams {
            starts_kept: Some((17.0, 60.0)),
            ..SplitParams::both(9.0, 0.5)
        };
        let kept = plan(&region, &risk, [&a, &b], &params).unwrap();
        assert!(kept.clear);
        assert_eq!(kept.end, free.end);
        let nearest = |p: &SplitPlan, from: f64, to: f64| {
            let mut least = f64::INFINITY;
            let steps = ((to - from) * 100.0).ceil() as usize;
            for k in 0..=steps {
                let tau = from + k as f64 / 100.0;
                for g in 0..2 {
                    for i in 0..2 {
                        for q in &p.start[1 - g] {
                            least = least.min(norm2(p.at(g, i, tau) - *q).sqrt());
                        }
                    }
                }
            }
            least
        };
        assert!(nearest(&free, 0.0, 60.0) < 17.0, "the case needs the rule");
        assert!(nearest(&kept, 0.0, 60.0) >= 17.0 - 1e-6);
        assert!(nearest(&kept, 60.0, kept.duration) < 17.0);
    }

    /// Two vessels trading places head on (a straight way through the
    /// other's end): one of them waits until the other has passed.
    #[test]
    fn crossing_ways_are_taken_one_after_the_other() {
        let a0 = Point { x: 10.0, y: 50.0 };
        let b0 = Point { x: 90.0, y: 52.0 };
        let start = [vec![a0], vec![b0]];
        let end = [
            vec![Point { x: 80.0, y: 50.0 }],
            vec![Point { x: 20.0, y: 52.0 }],
        ];
        let params = SplitParams::both(9.0, 1.0);
        let (delay, clear) = schedule(&start, &end, &params);
        let (u, v) = (
            Way::new(start[0][0], end[0][0], delay[0][0], 1.0),
            Way::new(start[1][0], end[1][0], delay[1][0], 1.0),
        );
        // Both go straight through each other's water: no delay clears
        // that (each ends on the other's way), and the plan says so.
        assert!(least_between(&u, &v) < 9.0);
        assert!(!clear);
        // Crossing at right angles: the second waits for the first.
        let start = [
            vec![Point { x: 10.0, y: 50.0 }],
            vec![Point { x: 50.0, y: 10.0 }],
        ];
        let end = [
            vec![Point { x: 90.0, y: 50.0 }],
            vec![Point { x: 50.0, y: 90.0 }],
        ];
        let (delay, clear) = schedule(&start, &end, &params);
        let (u, v) = (
            Way::new(start[0][0], end[0][0], delay[0][0], 1.0),
            Way::new(start[1][0], end[1][0], delay[1][0], 1.0),
        );
        assert!(clear);
        assert!(least_between(&u, &v) >= 9.0 - 1e-9);
        assert_eq!(delay[0][0], 0.0);
        assert!(delay[1][0] > 0.0, "{delay:?}");
        // Without the delay they would meet.
        let w = Way::new(start[1][0], end[1][0], 0.0, 1.0);
        assert!(least_between(&u, &w) < 1.0);
    }

    /// A fleet cut at its joint optimum whose ways would cross keeps to
    /// its own water: nobody moves, and the plan is clear.
    #[test]
    fn at_the_joint_optimum_each_group_keeping_its_own_water_stays_put() {
        let region = square(false);
        let risk = RiskField::new(
            0.1,
            vec![RiskObject {
                center: Point { x: 35.0, y: 60.0 },
                alpha: 5.0,
                sigma: 20.0,
            }],
        )
        .unwrap();
        let params = SplitParams::both(9.0, 0.5);
        let starts = [
            vessel(15.0, 20.0),
            vessel(40.0, 85.0),
            vessel(80.0, 30.0),
            vessel(60.0, 60.0),
            vessel(25.0, 55.0),
        ];
        let joint = lloyd(&region, &risk, &starts, &[], &params);
        let at: Vec<Vessel> = joint.iter().map(|p| vessel(p.x, p.y)).collect();
        let (a, b) = at.split_at(3);
        let own = plan_for(&region, &risk, [a, b], &params, Water::Own);
        assert!(own.clear);
        for g in 0..2 {
            for (end, start) in own.end[g].iter().zip(&own.start[g]) {
                assert!(norm2(*end - *start).sqrt() < 0.01, "{end:?} {start:?}");
            }
        }
        // `plan` takes it only when the whole region's ways are not clear.
        let chosen = plan(&region, &risk, [a, b], &params).unwrap();
        let whole = plan_for(&region, &risk, [a, b], &params, Water::Region);
        assert_eq!(
            chosen.water,
            if whole.clear {
                Water::Region
            } else {
                Water::Own
            }
        );
    }

    /// The same inputs give the same plan, bit for bit (both groups compute
    /// it), and an empty group none.
    #[test]
    fn the_same_inputs_give_the_same_plan() {
        let region = square(false);
        let risk = RiskField::new(
            0.1,
            vec![RiskObject {
                center: Point { x: 40.0, y: 60.0 },
                alpha: 5.0,
                sigma: 15.0,
            }],
        )
        .unwrap();
        let a = [vessel(10.0, 10.0), vessel(50.0, 50.0), vessel(90.0, 20.0)];
        let b = [vessel(30.0, 80.0), vessel(70.0, 75.0)];
        let params = SplitParams::both(10.0, 0.5);
        let one = plan(&region, &risk, [&a, &b], &params).unwrap();
        let two = plan(&region, &risk, [&a, &b], &params).unwrap();
        assert_eq!(one, two);
        assert!(plan(&region, &risk, [&a, &[]], &params).is_none());
    }
}
