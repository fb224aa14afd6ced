//! Planar geometry for the coverage engine: the validated task region, convex
//! polygon clipping, and Gauss quadrature rules on triangles; and for safe
//! motion: distances to the shore, a neighbour grid, and a roadmap of paths
//! around islands.
//!
//! Invariants of this module (and of the whole pure core):
//! - no I/O, no async, no global mutable state; every function is deterministic;
//! - a [`Region`] can only be built through [`Region::new`], which validates it, so
//!   every other function may assume a simple polygon with simple, disjoint holes;
//! - computations on valid inputs cannot fail: an empty clip result is an empty
//!   polygon, not an error.
//!
//! Points are [`geo::Coord<f64>`] throughout, so results pass to `geo` algorithms
//! (boolean operations, triangulation) without conversion.

pub mod arcs;
pub mod bridges;
pub mod convex;
pub mod geodesy;
pub mod grid;
pub mod outline;
pub mod quadrature;
pub mod region;
pub mod roadmap;
pub mod shore;

pub use convex::ConvexPolygon;
pub use quadrature::TriangleRule;
pub use region::{Region, RegionError, RingRole};

/// A point or vector in the earth frame, in metres.
pub type Point = geo::Coord<f64>;

/// Dot product.
#[inline]
pub fn dot(a: Point, b: Point) -> f64 {
    a.x * b.x + a.y * b.y
}

/// z component of the cross product a × b.
#[inline]
pub fn cross(a: Point, b: Point) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Squared Euclidean norm.
#[inline]
pub fn norm2(a: Point) -> f64 {
    a.x * a.x + a.y * a.y
}

/// Squared distance from `p` to the segment `a`–`b`.
pub fn segment_distance2(p: Point, a: Point, b: Point) -> f64 {
    norm2(p - segment_closest(p, a, b))
}

/// Closest point to `p` on the segment `a`–`b`.
pub fn segment_closest(p: Point, a: Point, b: Point) -> Point {
    let ab = b - a;
    let len2 = norm2(ab);
    let t = if len2 > 0.0 {
        (dot(p - a, ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    a + ab * t
}

/// Signed area of a ring given without its closing vertex (positive when
/// counter-clockwise).
pub fn ring_signed_area(ring: &[Point]) -> f64 {
    let n = ring.len();
    if n < 3 {
        return 0.0;
    }
    // Relative to the first vertex, so large coordinates do not cancel.
    let o = ring[0];
    let mut twice = 0.0;
    for i in 1..n - 1 {
        twice += cross(ring[i] - o, ring[i + 1] - o);
    }
    0.5 * twice
}

/// Axis-aligned bounds (min, max) of `points`; (+∞, −∞) when there are none.
pub fn bounds<'a>(points: impl IntoIterator<Item = &'a Point>) -> (Point, Point) {
    let mut min = Point {
        x: f64::INFINITY,
        y: f64::INFINITY,
    };
    let mut max = Point {
        x: f64::NEG_INFINITY,
        y: f64::NEG_INFINITY,
    };
    for v in points {
        min.x = min.x.min(v.x);
        min.y = min.y.min(v.y);
        max.x = max.x.max(v.x);
        max.y = max.y.max(v.y);
    }
    (min, max)
}

/// Where a point lies with respect to a polygon given as rings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingDistances {
    /// Inside by the even–odd rule over all rings (so holes are outside).
    pub inside: bool,
    /// Squared distance to the nearest edge.
    pub boundary2: f64,
    /// Squared distance to the farthest vertex.
    pub farthest2: f64,
}

/// [`RingDistances`] of `p`, in one pass over the edges.
pub fn ring_distances<R: AsRef<[Point]>>(rings: &[R], p: Point) -> RingDistances {
    let mut out = RingDistances {
        inside: false,
        boundary2: f64::INFINITY,
        farthest2: 0.0,
    };
    for ring in rings {
        let ring = ring.as_ref();
        let Some(&last) = ring.last() else { continue };
        let mut b = last;
        for &a in ring {
            out.farthest2 = out.farthest2.max(norm2(a - p));
            out.boundary2 = out.boundary2.min(segment_distance2(p, a, b));
            out.inside ^= crosses(a, b, p);
            b = a;
        }
    }
    out
}

/// Even–odd containment over all rings (so holes count as outside); points on
/// the boundary may go either way.
pub fn even_odd_contains<R: AsRef<[Point]>>(rings: &[R], p: Point) -> bool {
    let mut inside = false;
    for ring in rings {
        let ring = ring.as_ref();
        let Some(&last) = ring.last() else { continue };
        let mut b = last;
        for &a in ring {
            inside ^= crosses(a, b, p);
            b = a;
        }
    }
    inside
}

/// Whether the edge a–b crosses the horizontal ray from `p` towards +x.
#[inline]
fn crosses(a: Point, b: Point, p: Point) -> bool {
    (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x)
}
