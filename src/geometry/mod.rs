//! Planar geometry for the coverage engine: the validated task region, convex
//! polygon clipping, and Gauss quadrature rules on triangles.
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

pub mod convex;
pub mod quadrature;
pub mod region;

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
    let ab = b - a;
    let len2 = norm2(ab);
    let t = if len2 > 0.0 {
        (dot(p - a, ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    norm2(p - (a + ab * t))
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
