//! Shortest paths around islands and piers: a visibility graph over waypoints
//! set off the region's obstacle corners.
//!
//! In a polygon with holes the shortest path between two points is a chain
//! of straight runs that bend only at corners where the free water turns
//! around an obstacle: hole vertices that stick out into the water, and the
//! shell's reflex vertices (a pier's head). Vessels must keep a clearance c
//! from the shore, so each such corner v with incoming and outgoing edge
//! normals n₁, n₂ (pointing into Q) gets waypoints at distance c from it:
//! v + c n₁, v + c n̂ (n̂ the bisector) and v + c n₂ — the three points of a
//! chamfered arc of radius c around the corner; gentle corners (< 30°) get
//! the bisector point only. Two waypoints are joined when the straight run
//! between them keeps `visibility` (a fraction of c, so that the chords of
//! that arc count as clear: a chord of a 90° arc of radius c passes at
//! c cos 45° ≈ 0.71 c from the corner). All-pairs shortest distances are
//! precomputed (Floyd–Warshall, O(W³) once per region), so a query costs
//! O(W) visibility tests from each end plus O(W_a W_b) sums.
//!
//! Invariants: built once per region and clearance; queries are
//! deterministic and never fail — without a route (a passage narrower than
//! the clearance, or a region too detailed for the roadmap's cap) the answer
//! is `None` and the caller steers straight, leaving safety to the filter.
//! The path is a guide, not a guarantee: the safety filter keeps the
//! clearance while the vessel follows it.

use super::shore::Shore;
use super::{Point, cross, norm2};

/// Most waypoints a roadmap keeps; beyond this (regions with thousands of
/// obstacle corners) the O(W³) table is not built and paths are straight.
pub const MAX_WAYPOINTS: usize = 600;

/// Gentler corners than this get only their bisector waypoint [rad].
const GENTLE: f64 = std::f64::consts::PI / 6.0;

/// A visibility graph with all-pairs shortest distances.
#[derive(Debug, Clone)]
pub struct Roadmap {
    nodes: Vec<Point>,
    /// Row-major W × W shortest distances (∞ when disconnected).
    dist: Vec<f64>,
    clearance: f64,
    visibility: f64,
}

/// The first leg of a route.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leg {
    /// Where to steer now: the goal itself when it is in sight.
    pub towards: Point,
    /// Length of the whole route to the goal [m].
    pub length: f64,
}

impl Roadmap {
    /// Waypoints at `clearance` off the obstacle corners of `shore`, joined
    /// where a straight run keeps `visibility` from the shore.
    pub fn new(shore: &Shore, clearance: f64, visibility: f64) -> Roadmap {
        let region = shore.region();
        let mut nodes = Vec::new();
        for ring in std::iter::once(region.shell()).chain(region.holes().iter().map(Vec::as_slice))
        {
            let n = ring.len();
            for k in 0..n {
                let (u, v, w) = (ring[(k + n - 1) % n], ring[k], ring[(k + 1) % n]);
                corner_waypoints(u, v, w, clearance, &mut nodes);
            }
        }
        // A waypoint squeezed closer to some other shore than the visibility
        // clearance lies in a passage too narrow to use.
        nodes.retain(|&q| shore.signed_clearance(q) >= visibility);
        if nodes.len() > MAX_WAYPOINTS {
            nodes.clear();
        }
        let w = nodes.len();
        let mut dist = vec![f64::INFINITY; w * w];
        for a in 0..w {
            dist[a * w + a] = 0.0;
            for b in a + 1..w {
                if shore.segment_clear(nodes[a], nodes[b], visibility) {
                    let d = norm2(nodes[a] - nodes[b]).sqrt();
                    dist[a * w + b] = d;
                    dist[b * w + a] = d;
                }
            }
        }
        for k in 0..w {
            for a in 0..w {
                let ak = dist[a * w + k];
                if !ak.is_finite() {
                    continue;
                }
                for b in 0..w {
                    let via = ak + dist[k * w + b];
                    if via < dist[a * w + b] {
                        dist[a * w + b] = via;
                    }
                }
            }
        }
        Roadmap {
            nodes,
            dist,
            clearance,
            visibility,
        }
    }

    /// The waypoints.
    pub fn nodes(&self) -> &[Point] {
        &self.nodes
    }

    /// The clearance the waypoints keep from their corners [m].
    pub fn clearance(&self) -> f64 {
        self.clearance
    }

    /// The shortest route from `from` to `to` through the roadmap, or
    /// straight when `to` is in sight. A run from an end point counts as
    /// clear with the visibility clearance, or 0.9 of that end's own
    /// clearance when it is closer to the shore (a vessel pressed against a
    /// wall must still be able to leave it). `None` when there is no route.
    pub fn leg(&self, shore: &Shore, from: Point, to: Point) -> Option<Leg> {
        let relaxed = |p: Point| {
            self.visibility
                .min(0.9 * shore.signed_clearance(p).max(0.0))
        };
        let (cf, ct) = (relaxed(from), relaxed(to));
        // hypot, as guidance measures the distance to its target, so that a
        // goal in sight gives bit-for-bit the plain guidance's command.
        let direct = (to.x - from.x).hypot(to.y - from.y);
        if shore.segment_clear(from, to, cf.min(ct)) {
            return Some(Leg {
                towards: to,
                length: direct,
            });
        }
        let w = self.nodes.len();
        // Ends whose own clearance is below a waypoint's reach the roadmap
        // with their relaxed clearance.
        let seen = |p: Point, c: f64| -> Vec<(usize, f64)> {
            (0..w)
                .filter(|&a| shore.segment_clear(p, self.nodes[a], c))
                .map(|a| (a, norm2(self.nodes[a] - p).sqrt()))
                .collect()
        };
        let starts = seen(from, cf);
        if starts.is_empty() {
            return None;
        }
        let goals = seen(to, ct);
        let mut best: Option<Leg> = None;
        for &(a, da) in &starts {
            for &(b, db) in &goals {
                let length = da + self.dist[a * w + b] + db;
                if length.is_finite() && best.is_none_or(|l| length < l.length) {
                    best = Some(Leg {
                        towards: self.nodes[a],
                        length,
                    });
                }
            }
        }
        best
    }
}

/// Waypoints around the corner v (edges u→v→w, Q to the left of both) when
/// the free water turns around it (a right turn), at distance c from v.
fn corner_waypoints(u: Point, v: Point, w: Point, c: f64, out: &mut Vec<Point>) {
    let (e1, e2) = (v - u, w - v);
    let (l1, l2) = (norm2(e1).sqrt(), norm2(e2).sqrt());
    if l1 == 0.0 || l2 == 0.0 || cross(e1, e2) >= 0.0 {
        return; // straight or a left turn: the water is on the inside of it
    }
    let n1 = Point {
        x: -e1.y / l1,
        y: e1.x / l1,
    };
    let n2 = Point {
        x: -e2.y / l2,
        y: e2.x / l2,
    };
    let sum = n1 + n2;
    let len = norm2(sum).sqrt();
    // A needle (a 180° turn) has opposite normals: its bisector points along
    // the incoming edge.
    let bisector = if len > 1e-9 { sum / len } else { e1 / l1 };
    let turn = (n1.x * n2.x + n1.y * n2.y).clamp(-1.0, 1.0).acos();
    if turn > GENTLE {
        out.push(v + n1 * c);
        out.push(v + bisector * c);
        out.push(v + n2 * c);
    } else {
        out.push(v + bisector * c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Region;

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    fn island() -> Shore {
        Shore::new(
            &Region::new(
                vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)],
                vec![vec![
                    p(30.0, 40.0),
                    p(70.0, 40.0),
                    p(70.0, 60.0),
                    p(30.0, 60.0),
                ]],
            )
            .unwrap(),
        )
    }

    #[test]
    fn waypoints_go_round_the_islands_corners_only() {
        let s = island();
        let map = Roadmap::new(&s, 5.0, 3.5);
        // 4 right-angled island corners × 3; the shell's corners turn left.
        assert_eq!(map.nodes().len(), 12);
        for q in map.nodes() {
            assert!((s.signed_clearance(*q) - 5.0).abs() < 1e-9);
        }
    }

    #[test]
    fn the_route_across_an_island_goes_round_it() {
        let s = island();
        let map = Roadmap::new(&s, 5.0, 3.5);
        let leg = map.leg(&s, p(50.0, 30.0), p(50.0, 70.0)).unwrap();
        // Round either end: 20 m across, 20 m along the long side to a
        // corner's arc, … at least the taut string over the corners.
        let taut = 2.0 * (20f64.powi(2) + 10f64.powi(2)).sqrt() + 20.0;
        assert!(
            leg.length > taut && leg.length < taut + 15.0,
            "{}",
            leg.length
        );
        assert!(s.segment_clear(p(50.0, 30.0), leg.towards, 0.0));
        // In sight: straight.
        let direct = map.leg(&s, p(10.0, 10.0), p(90.0, 10.0)).unwrap();
        assert_eq!(direct.towards, p(90.0, 10.0));
        assert_eq!(direct.length, 80.0);
    }
}
