//! Convex polygons and half-plane clipping (Sutherland–Hodgman for one plane).
//!
//! Power cells are intersections of half-planes, hence convex; clipping one
//! convex polygon by a half-plane is exact up to rounding and O(vertices), which
//! is why cells are built here rather than with general boolean operations.
//! Vertices are counter-clockwise; an empty vertex list is the empty polygon.

use super::bridges::Line;
use super::{Point, cross, dot, ring_signed_area};

/// A convex polygon, counter-clockwise, without the closing vertex.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConvexPolygon {
    /// The vertices, counter-clockwise; fewer than three: the empty polygon.
    pub vertices: Vec<Point>,
}

impl ConvexPolygon {
    /// The axis-aligned rectangle [min, max].
    pub fn rectangle(min: Point, max: Point) -> Self {
        ConvexPolygon {
            vertices: vec![
                min,
                Point { x: max.x, y: min.y },
                max,
                Point { x: min.x, y: max.y },
            ],
        }
    }

    /// Whether the polygon has no interior.
    pub fn is_empty(&self) -> bool {
        self.vertices.len() < 3
    }

    /// Keeps the part where `normal · x ≤ offset`.
    ///
    /// Vertices within a relative `1e-12` of the line count as on it, so a plane
    /// through an existing vertex does not create a sliver vertex next to it.
    pub fn clip(&mut self, normal: Point, offset: f64) {
        self.clip_with(normal, offset, &mut Vec::new());
    }

    /// [`clip`](Self::clip) with `scratch` for the new vertices (it takes
    /// the old ones): no allocation once both have grown, for a caller
    /// that clips many times.
    pub fn clip_with(&mut self, normal: Point, offset: f64, scratch: &mut Vec<Point>) {
        match clip_ring_into(&self.vertices, normal, offset, scratch) {
            Clipped::Unchanged => {}
            Clipped::Empty => self.vertices.clear(),
            Clipped::Cut => {
                std::mem::swap(&mut self.vertices, scratch);
                if ring_signed_area(&self.vertices) <= 0.0 {
                    self.vertices.clear();
                }
            }
        }
    }

    /// Clips any ring (convex or not, either orientation) to this polygon.
    ///
    /// For a non-convex ring the result can contain zero-width "bridges"
    /// between pieces. They enclose no area and every boundary integral over
    /// them cancels, so the result is exact as an oriented chain.
    /// [`without_bridges`](super::bridges::without_bridges) removes them
    /// before the chain is integrated.
    pub fn clip_ring(&self, ring: &[Point]) -> Vec<Point> {
        let mut out = ring.to_vec();
        for line in self.edge_lines() {
            out = clip_ring(&out, line.normal, line.offset);
            if out.is_empty() {
                break;
            }
        }
        out
    }

    /// The lines of the edges, each as the half-plane `normal · x ≤ offset`
    /// that holds the polygon.
    pub fn edge_lines(&self) -> Vec<Line> {
        let n = self.vertices.len();
        (0..n)
            .map(|i| {
                let (a, b) = (self.vertices[i], self.vertices[(i + 1) % n]);
                let e = b - a;
                // Inside is to the left of a→b: cross(e, x − a) ≥ 0.
                let normal = Point { x: e.y, y: -e.x };
                Line {
                    normal,
                    offset: dot(normal, a),
                }
            })
            .collect()
    }

    /// Area (non-negative).
    pub fn area(&self) -> f64 {
        ring_signed_area(&self.vertices).max(0.0)
    }

    /// Largest squared distance from `p` to a vertex.
    pub fn max_distance2(&self, p: Point) -> f64 {
        self.vertices
            .iter()
            .map(|v| super::norm2(*v - p))
            .fold(0.0, f64::max)
    }

    /// Whether `p` is inside or on the boundary.
    pub fn contains(&self, p: Point) -> bool {
        if self.is_empty() {
            return false;
        }
        let n = self.vertices.len();
        (0..n).all(|i| {
            let a = self.vertices[i];
            let b = self.vertices[(i + 1) % n];
            cross(b - a, p - a) >= 0.0
        })
    }

    /// Whether the closed segment `a`–`b` meets the polygon (inside or boundary).
    pub fn intersects_segment(&self, a: Point, b: Point) -> bool {
        if self.is_empty() {
            return false;
        }
        // Cyrus–Beck: clip the parameter interval [0, 1] by every edge.
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let d = b - a;
        let n = self.vertices.len();
        for i in 0..n {
            let p = self.vertices[i];
            let q = self.vertices[(i + 1) % n];
            let e = q - p;
            // Inside is cross(e, x − p) ≥ 0, i.e. num + t den ≥ 0.
            let num = cross(e, a - p);
            let den = cross(e, d);
            if den == 0.0 {
                if num < 0.0 {
                    return false;
                }
            } else {
                let t = -num / den;
                if den > 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
                if t0 > t1 {
                    return false;
                }
            }
        }
        true
    }

    /// Axis-aligned bounds (min, max); meaningless for an empty polygon.
    pub fn bounds(&self) -> (Point, Point) {
        super::bounds(&self.vertices)
    }

    /// The vertex average: a point strictly inside a non-empty convex polygon.
    pub fn interior_point(&self) -> Point {
        let n = self.vertices.len() as f64;
        let s = self
            .vertices
            .iter()
            .fold(Point { x: 0.0, y: 0.0 }, |acc, v| acc + *v);
        s / n
    }

    /// Translates every vertex by `d`.
    pub fn translate(&mut self, d: Point) {
        for v in &mut self.vertices {
            *v = *v + d;
        }
    }
}

/// Sutherland–Hodgman against one half-plane `normal · x ≤ offset`.
///
/// Vertices within a relative `1e-12` of the line count as on it, so a plane
/// through an existing vertex does not create a sliver vertex next to it.
/// Returns an empty ring when nothing is left.
pub fn clip_ring(ring: &[Point], normal: Point, offset: f64) -> Vec<Point> {
    let mut out = Vec::new();
    match clip_ring_into(ring, normal, offset, &mut out) {
        Clipped::Unchanged => ring.to_vec(),
        Clipped::Empty => Vec::new(),
        Clipped::Cut => out,
    }
}

/// What [`clip_ring_into`] did.
enum Clipped {
    /// The ring is inside the half-plane; `out` is untouched.
    Unchanged,
    /// Nothing is left.
    Empty,
    /// `out` holds the clipped ring.
    Cut,
}

/// [`clip_ring`] without allocating when the plane misses the ring, which is
/// the common case when a cell is clipped by far neighbours.
fn clip_ring_into(ring: &[Point], normal: Point, offset: f64, out: &mut Vec<Point>) -> Clipped {
    let (mut lo, mut hi, mut scale) = (f64::INFINITY, f64::NEG_INFINITY, offset.abs());
    for v in ring {
        let d = dot(normal, *v);
        scale = scale.max(d.abs());
        lo = lo.min(d - offset);
        hi = hi.max(d - offset);
    }
    let eps = 1e-12 * scale.max(f64::MIN_POSITIVE);
    if ring.is_empty() || hi <= eps {
        return Clipped::Unchanged;
    }
    if lo >= -eps {
        return Clipped::Empty;
    }
    let side = |v: &Point| dot(normal, *v) - offset;
    let n = ring.len();
    out.clear();
    out.reserve(n + 2);
    let mut sa = side(&ring[0]);
    for i in 0..n {
        let j = (i + 1) % n;
        let (a, b) = (ring[i], ring[j]);
        let sb = side(&b);
        if sa <= eps {
            out.push(a);
        }
        if (sa < -eps && sb > eps) || (sa > eps && sb < -eps) {
            let t = sa / (sa - sb);
            out.push(a + (b - a) * t);
        }
        sa = sb;
    }
    if out.len() < 3 {
        out.clear();
        Clipped::Empty
    } else {
        Clipped::Cut
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    #[test]
    fn clip_square_in_half() {
        let mut sq = ConvexPolygon::rectangle(p(0.0, 0.0), p(2.0, 2.0));
        sq.clip(p(1.0, 0.0), 1.0);
        assert!((sq.area() - 2.0).abs() < 1e-15);
        assert_eq!(sq.vertices.len(), 4);
    }

    #[test]
    fn clip_everything_and_nothing() {
        let mut sq = ConvexPolygon::rectangle(p(0.0, 0.0), p(1.0, 1.0));
        sq.clip(p(1.0, 1.0), 5.0);
        assert!((sq.area() - 1.0).abs() < 1e-15);
        sq.clip(p(1.0, 1.0), -1.0);
        assert!(sq.is_empty());
        assert_eq!(sq.area(), 0.0);
    }

    #[test]
    fn clip_through_a_vertex_adds_no_sliver() {
        let mut sq = ConvexPolygon::rectangle(p(0.0, 0.0), p(1.0, 1.0));
        // The diagonal through (0,0) and (1,1), keeping the lower-right half.
        sq.clip(p(-1.0, 1.0), 0.0);
        assert_eq!(sq.vertices.len(), 3);
        assert!((sq.area() - 0.5).abs() < 1e-15);
    }

    #[test]
    fn clipping_a_non_convex_ring_keeps_its_area_exactly() {
        // A U shape cut by a band across both arms: two pieces joined by a bridge.
        let u = vec![
            p(0.0, 0.0),
            p(30.0, 0.0),
            p(30.0, 30.0),
            p(20.0, 30.0),
            p(20.0, 10.0),
            p(10.0, 10.0),
            p(10.0, 30.0),
            p(0.0, 30.0),
        ];
        let band = ConvexPolygon::rectangle(p(-5.0, 20.0), p(35.0, 25.0));
        let clipped = band.clip_ring(&u);
        assert!((ring_signed_area(&clipped) - 2.0 * 10.0 * 5.0).abs() < 1e-12);
        // A clockwise hole stays clockwise: its area counts negative.
        let hole: Vec<Point> = vec![p(1.0, 21.0), p(1.0, 22.0), p(2.0, 22.0), p(2.0, 21.0)];
        assert!((ring_signed_area(&band.clip_ring(&hole)) + 1.0).abs() < 1e-12);
    }

    #[test]
    fn segment_intersection() {
        let sq = ConvexPolygon::rectangle(p(0.0, 0.0), p(1.0, 1.0));
        assert!(sq.intersects_segment(p(-1.0, 0.5), p(2.0, 0.5)));
        assert!(sq.intersects_segment(p(0.2, 0.2), p(0.3, 0.3)));
        assert!(!sq.intersects_segment(p(-1.0, 2.0), p(2.0, 2.0)));
        assert!(!sq.intersects_segment(p(1.5, -1.0), p(3.0, 0.5)));
        assert!(sq.intersects_segment(p(1.0, -1.0), p(1.0, 2.0)));
    }
}
