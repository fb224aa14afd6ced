//! Distances to the region's boundary ∂Q (the shore of the shell and of every
//! island): the nearest boundary point, every boundary edge near a point, and
//! whether a straight run keeps a clearance. The safety filter's boundary
//! constraints, the path planner's visibility test and the simulator's
//! incursion watch all reduce to these.
//!
//! Invariants: built once from a validated [`Region`]; every query is exact
//! up to rounding (an R-tree of the boundary segments finds the candidates,
//! the distances are computed on the segments themselves), deterministic,
//! and total — a point on the boundary has clearance 0, never NaN.
//!
//! The R-tree is our own rather than the region's private one, because these
//! queries (nearest segment from inside Q, all segments within a radius) are
//! not the region's business.

use geo::kernels::{Kernel, Orientation, RobustKernel};
use rstar::primitives::Line as RLine;
use rstar::{AABB, RTree};

use super::{Point, Region, norm2, segment_closest, segment_distance2};

/// The boundary of a region, indexed for distance queries.
#[derive(Debug, Clone)]
pub struct Shore {
    region: Region,
    segments: RTree<RLine<[f64; 2]>>,
}

/// A boundary point near a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShorePoint {
    /// The nearest point of one boundary edge.
    pub point: Point,
    /// Its distance from the query point.
    pub distance: f64,
    /// The unit normal of that edge pointing into Q (Q lies to the left of
    /// every edge: the shell runs counter-clockwise, islands clockwise).
    pub inward: Point,
}

impl Shore {
    /// Indexes the boundary of `region`: its shell and every island.
    pub fn new(region: &Region) -> Shore {
        let mut lines = Vec::new();
        for ring in std::iter::once(region.shell()).chain(region.holes().iter().map(Vec::as_slice))
        {
            for k in 0..ring.len() {
                let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
                lines.push(RLine::new([a.x, a.y], [b.x, b.y]));
            }
        }
        Shore {
            region: region.clone(),
            segments: RTree::bulk_load(lines),
        }
    }

    /// The region whose boundary this is.
    pub fn region(&self) -> &Region {
        &self.region
    }

    /// Every ring's edges, each as (start, end), in no particular order.
    pub fn edges(&self) -> impl Iterator<Item = (Point, Point)> + '_ {
        self.segments.iter().map(ends)
    }

    /// The nearest boundary point to `p`.
    pub fn nearest(&self, p: Point) -> ShorePoint {
        match self.segments.nearest_neighbor(&[p.x, p.y]) {
            Some(l) => shore_point(p, l),
            None => ShorePoint {
                point: p,
                distance: 0.0,
                inward: Point { x: 0.0, y: 0.0 },
            },
        }
    }

    /// Distance from `p` to ∂Q, negative when `p` is outside Q (in a hole or
    /// beyond the shell), 0 on the boundary.
    pub fn signed_clearance(&self, p: Point) -> f64 {
        let d = self.nearest(p).distance;
        if d == 0.0 || self.region.contains(p) {
            d
        } else {
            -d
        }
    }

    /// The nearest point of every boundary edge within `radius` of `p`,
    /// appended to `out` after clearing it, nearest first (ties in a fixed
    /// order, so the result is deterministic).
    pub fn near(&self, p: Point, radius: f64, out: &mut Vec<ShorePoint>) {
        out.clear();
        let r2 = radius * radius;
        out.extend(
            self.segments
                .locate_within_distance([p.x, p.y], r2)
                .map(|l| shore_point(p, l)),
        );
        out.sort_unstable_by(|s, t| {
            s.distance
                .total_cmp(&t.distance)
                .then(s.point.x.total_cmp(&t.point.x))
                .then(s.point.y.total_cmp(&t.point.y))
        });
    }

    /// Whether the segment `a`–`b` stays at least `clearance` from ∂Q
    /// (it never crosses the boundary, so with `a` in Q it stays in Q).
    pub fn segment_clear(&self, a: Point, b: Point, clearance: f64) -> bool {
        let c = clearance.max(0.0);
        let env = AABB::from_corners(
            [a.x.min(b.x) - c, a.y.min(b.y) - c],
            [a.x.max(b.x) + c, a.y.max(b.y) + c],
        );
        let c2 = c * c;
        self.segments
            .locate_in_envelope_intersecting(&env)
            .all(|l| {
                let (p, q) = ends(l);
                let d2 = segments_distance2(a, b, p, q);
                if c > 0.0 { d2 >= c2 } else { d2 > 0.0 }
            })
    }
}

fn shore_point(p: Point, l: &RLine<[f64; 2]>) -> ShorePoint {
    let (a, b) = ends(l);
    let q = segment_closest(p, a, b);
    let e = b - a;
    let len = norm2(e).sqrt();
    ShorePoint {
        point: q,
        distance: norm2(q - p).sqrt(),
        inward: Point {
            x: -e.y / len,
            y: e.x / len,
        },
    }
}

fn ends(l: &RLine<[f64; 2]>) -> (Point, Point) {
    (
        Point {
            x: l.from[0],
            y: l.from[1],
        },
        Point {
            x: l.to[0],
            y: l.to[1],
        },
    )
}

/// Whether the closed segments a–b and p–q meet (robust orientation tests).
fn segments_cross(a: Point, b: Point, p: Point, q: Point) -> bool {
    let o = |u: Point, v: Point, w: Point| RobustKernel::orient2d(u, v, w);
    let (d1, d2) = (o(a, b, p), o(a, b, q));
    let (d3, d4) = (o(p, q, a), o(p, q, b));
    let opposite = |x: Orientation, y: Orientation| {
        matches!(
            (x, y),
            (Orientation::Clockwise, Orientation::CounterClockwise)
                | (Orientation::CounterClockwise, Orientation::Clockwise)
        )
    };
    if opposite(d1, d2) && opposite(d3, d4) {
        return true;
    }
    // Touching or collinear overlap: some endpoint lies on the other segment.
    let on = |u: Point, v: Point, w: Point| segment_distance2(w, u, v) == 0.0;
    on(a, b, p) || on(a, b, q) || on(p, q, a) || on(p, q, b)
}

/// Squared distance between the closed segments a–b and p–q.
pub fn segments_distance2(a: Point, b: Point, p: Point, q: Point) -> f64 {
    if segments_cross(a, b, p, q) {
        return 0.0;
    }
    // Disjoint segments are nearest at an endpoint of one of them.
    segment_distance2(a, p, q)
        .min(segment_distance2(b, p, q))
        .min(segment_distance2(p, a, b))
        .min(segment_distance2(q, a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    fn square_with_island() -> Region {
        crate::geometry::region::fixtures::square(true)
    }

    #[test]
    fn clearance_is_signed_and_exact() {
        let s = Shore::new(&square_with_island());
        assert_eq!(s.signed_clearance(p(10.0, 50.0)), 10.0);
        assert_eq!(s.signed_clearance(p(35.0, 50.0)), 5.0);
        assert_eq!(s.signed_clearance(p(50.0, 45.0)), -5.0);
        assert_eq!(s.signed_clearance(p(-3.0, 50.0)), -3.0);
        assert_eq!(s.signed_clearance(p(40.0, 50.0)), 0.0);
        // Off a corner: the distance to the corner itself.
        let c = s.signed_clearance(p(37.0, 36.0));
        assert!((c - 5.0).abs() < 1e-12, "{c}");
    }

    #[test]
    fn near_lists_every_edge_within_the_radius() {
        let s = Shore::new(&square_with_island());
        let mut out = Vec::new();
        s.near(p(35.0, 35.0), 8.0, &mut out);
        // Two island edges meet at the corner (40, 40), 7.07 m away.
        assert_eq!(out.len(), 2);
        assert!(
            out.iter()
                .all(|q| (q.distance - 50f64.sqrt()).abs() < 1e-12)
        );
        s.near(p(5.0, 5.0), 6.0, &mut out);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].distance, 5.0);
    }

    #[test]
    fn a_run_across_an_island_is_not_clear() {
        let s = Shore::new(&square_with_island());
        assert!(!s.segment_clear(p(30.0, 50.0), p(70.0, 50.0), 0.0));
        assert!(s.segment_clear(p(30.0, 30.0), p(70.0, 30.0), 9.9));
        assert!(!s.segment_clear(p(30.0, 30.0), p(70.0, 30.0), 10.1));
        // Grazing a corner.
        assert!(!s.segment_clear(p(30.0, 50.0), p(50.0, 30.0), 0.0));
    }
}
