//! The task region Q: a simple polygon (convex or not) with optional holes.
//!
//! [`Region::new`] is the only constructor and enforces the invariants every
//! other part of the engine relies on:
//! - every ring has ≥ 3 distinct vertices, finite coordinates within
//!   ±[`MAX_COORDINATE`], and non-zero area;
//! - no ring crosses or touches itself (including collinear spikes);
//! - holes lie strictly inside the shell, outside each other, and no two rings
//!   touch;
//! - afterwards the shell is counter-clockwise and holes clockwise.
//!
//! Validation uses an R-tree of all boundary segments, so it costs
//! O(n log n) for well-spread rings instead of the O(n²) of pairwise checks,
//! and the same tree answers "which boundary edges are near this cell" for
//! the partition and "closest point of Q" for vessels outside it.

use geo::kernels::{Kernel, Orientation, RobustKernel};
use geo::{Intersects, Line, LineString, Polygon};
use rstar::primitives::{GeomWithData, Line as RLine};
use rstar::{AABB, RTree, RTreeObject};

use super::{Point, bounds, dot, even_odd_contains, norm2, ring_signed_area, segment_closest};

/// Largest absolute coordinate accepted, in metres (10 000 km): far beyond any
/// mission, small enough that squared distances never overflow.
pub const MAX_COORDINATE: f64 = 1.0e7;
/// Most vertices accepted over all rings of a region.
pub const MAX_REGION_VERTICES: usize = 100_000;

/// Which ring of the region a problem is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum RingRole {
    /// The outer boundary (`region.polygon`).
    Shell,
    /// The hole of this index (`region.holes[i]`).
    Hole(usize),
}

impl std::fmt::Display for RingRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RingRole::Shell => write!(f, "region.polygon"),
            RingRole::Hole(i) => write!(f, "region.holes[{i}]"),
        }
    }
}

/// Why a region was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RegionError {
    /// A ring has fewer than 3 distinct vertices.
    #[error("{0}: needs at least 3 distinct vertices")]
    TooFewVertices(RingRole),
    /// A ring's vertex (its index as given) is not finite or beyond
    /// ±[`MAX_COORDINATE`].
    #[error("{0}[{1}]: coordinate is not finite or beyond ±1e7 m")]
    CoordinateOutOfRange(RingRole, usize),
    /// A ring encloses no area, or none to rounding for its size.
    #[error("{0}: ring has zero area (degenerate)")]
    Degenerate(RingRole),
    /// A ring crosses or touches itself.
    #[error("{0}: ring intersects itself")]
    SelfIntersection(RingRole),
    /// A hole is not inside the shell.
    #[error("{0}: hole is not inside the region's polygon")]
    HoleOutsideShell(RingRole),
    /// Two rings touch or cross.
    #[error("{0} and {1} touch or intersect")]
    RingsIntersect(RingRole, RingRole),
    /// The second hole lies inside the first.
    #[error("{1} lies inside {0}")]
    HoleInsideHole(RingRole, RingRole),
    /// The rings have more than [`MAX_REGION_VERTICES`] vertices in all.
    #[error("region has more than {MAX_REGION_VERTICES} vertices")]
    TooManyVertices,
}

/// A boundary segment with its ring and index within the ring.
type Segment = GeomWithData<RLine<[f64; 2]>, (RingRole, usize)>;

/// A validated task region. See the module documentation for its invariants.
#[derive(Debug, Clone)]
pub struct Region {
    shell: Vec<Point>,
    holes: Vec<Vec<Point>>,
    polygon: Polygon<f64>,
    area: f64,
    min: Point,
    max: Point,
    convex: bool,
    segments: RTree<Segment>,
}

impl Region {
    /// Validates and normalises a region. Rings may repeat their first vertex
    /// at the end; consecutive duplicate vertices are dropped.
    pub fn new(shell: Vec<Point>, holes: Vec<Vec<Point>>) -> Result<Region, RegionError> {
        let total: usize = shell.len() + holes.iter().map(Vec::len).sum::<usize>();
        if total > MAX_REGION_VERTICES {
            return Err(RegionError::TooManyVertices);
        }
        let mut shell = clean_ring(shell, RingRole::Shell)?;
        let mut holes: Vec<Vec<Point>> = holes
            .into_iter()
            .enumerate()
            .map(|(i, h)| clean_ring(h, RingRole::Hole(i)))
            .collect::<Result<_, _>>()?;
        if ring_signed_area(&shell) < 0.0 {
            shell.reverse();
        }
        for h in &mut holes {
            if ring_signed_area(h) > 0.0 {
                h.reverse();
            }
        }

        let mut segs = Vec::with_capacity(total);
        let rings = std::iter::once((RingRole::Shell, &shell)).chain(
            holes
                .iter()
                .enumerate()
                .map(|(i, h)| (RingRole::Hole(i), h)),
        );
        for (role, ring) in rings {
            for i in 0..ring.len() {
                let a = ring[i];
                let b = ring[(i + 1) % ring.len()];
                segs.push(GeomWithData::new(
                    RLine::new([a.x, a.y], [b.x, b.y]),
                    (role, i),
                ));
            }
        }
        let segments = RTree::bulk_load(segs);
        check_boundary_crossings(&segments, &shell, &holes)?;
        check_area(&shell, RingRole::Shell)?;
        for (i, h) in holes.iter().enumerate() {
            check_area(h, RingRole::Hole(i))?;
        }

        for (i, h) in holes.iter().enumerate() {
            // Boundaries are disjoint, so one vertex decides containment.
            if !point_in_ring(h[0], &shell) {
                return Err(RegionError::HoleOutsideShell(RingRole::Hole(i)));
            }
            for (j, other) in holes.iter().enumerate() {
                if i != j && point_in_ring(h[0], other) {
                    return Err(RegionError::HoleInsideHole(
                        RingRole::Hole(j),
                        RingRole::Hole(i),
                    ));
                }
            }
        }

        let area =
            ring_signed_area(&shell) + holes.iter().map(|h| ring_signed_area(h)).sum::<f64>();
        let (min, max) = bounds(&shell);
        let convex = holes.is_empty() && is_convex_ccw(&shell);
        let polygon = Polygon::new(
            LineString::from(shell.clone()),
            holes.iter().map(|h| LineString::from(h.clone())).collect(),
        );
        Ok(Region {
            shell,
            holes,
            polygon,
            area,
            min,
            max,
            convex,
            segments,
        })
    }

    /// Shell vertices, counter-clockwise, without the closing vertex.
    pub fn shell(&self) -> &[Point] {
        &self.shell
    }

    /// Holes, each clockwise, without the closing vertex.
    pub fn holes(&self) -> &[Vec<Point>] {
        &self.holes
    }

    /// The region as a `geo` polygon (closed rings).
    pub fn polygon(&self) -> &Polygon<f64> {
        &self.polygon
    }

    /// Area of the shell minus the holes.
    pub fn area(&self) -> f64 {
        self.area
    }

    /// Axis-aligned bounds (min, max).
    pub fn bounds(&self) -> (Point, Point) {
        (self.min, self.max)
    }

    /// Whether the region is a convex polygon without holes.
    pub fn is_convex(&self) -> bool {
        self.convex
    }

    /// Whether `p` is in the closed region (boundary included).
    pub fn contains(&self, p: Point) -> bool {
        if p.x < self.min.x || p.x > self.max.x || p.y < self.min.y || p.y > self.max.y {
            return false;
        }
        if self.on_boundary(p) {
            return true;
        }
        point_in_ring(p, &self.shell) && !self.holes.iter().any(|h| point_in_ring(p, h))
    }

    fn on_boundary(&self, p: Point) -> bool {
        let env = AABB::from_point([p.x, p.y]);
        self.segments
            .locate_in_envelope_intersecting(&env)
            .any(|s| {
                let l = s.geom();
                let (a, b) = (to_point(l.from), to_point(l.to));
                RobustKernel::orient2d(a, b, p) == Orientation::Collinear
            })
    }

    /// The point of Q nearest to `p` (`p` itself when inside).
    pub fn closest_point(&self, p: Point) -> Point {
        if self.contains(p) {
            return p;
        }
        match self.segments.nearest_neighbor(&[p.x, p.y]) {
            Some(s) => {
                let l = s.geom();
                segment_closest(p, to_point(l.from), to_point(l.to))
            }
            None => p,
        }
    }

    /// Boundary segments whose bounding boxes meet the box [min, max].
    pub fn segments_in(&self, min: Point, max: Point) -> impl Iterator<Item = (Point, Point)> + '_ {
        let env = AABB::from_corners([min.x, min.y], [max.x, max.y]);
        self.segments
            .locate_in_envelope_intersecting(&env)
            .map(|s| (to_point(s.geom().from), to_point(s.geom().to)))
    }
}

fn to_point(a: [f64; 2]) -> Point {
    Point { x: a[0], y: a[1] }
}

fn clean_ring(ring: Vec<Point>, role: RingRole) -> Result<Vec<Point>, RegionError> {
    for (i, v) in ring.iter().enumerate() {
        if !(v.x.is_finite() && v.y.is_finite())
            || v.x.abs() > MAX_COORDINATE
            || v.y.abs() > MAX_COORDINATE
        {
            return Err(RegionError::CoordinateOutOfRange(role, i));
        }
    }
    let mut out: Vec<Point> = Vec::with_capacity(ring.len());
    for v in ring {
        if out.last() != Some(&v) {
            out.push(v);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    if out.len() < 3 {
        return Err(RegionError::TooFewVertices(role));
    }
    let o = out[0];
    let far = out
        .iter()
        .copied()
        .max_by(|a, b| norm2(*a - o).total_cmp(&norm2(*b - o)))
        .unwrap_or(o);
    if out
        .iter()
        .all(|v| RobustKernel::orient2d(o, far, *v) == Orientation::Collinear)
    {
        return Err(RegionError::Degenerate(role));
    }
    Ok(out)
}

/// Rejects a ring whose area is negligible against its extent (collinear
/// points, or a sliver no vessel could cover).
fn check_area(ring: &[Point], role: RingRole) -> Result<(), RegionError> {
    let (min, max) = bounds(ring);
    let diag2 = (max.x - min.x).powi(2) + (max.y - min.y).powi(2);
    if ring_signed_area(ring).abs() <= 1e-12 * diag2 {
        return Err(RegionError::Degenerate(role));
    }
    Ok(())
}

/// Rejects any contact between boundary segments other than two consecutive
/// edges of one ring meeting at their shared vertex.
fn check_boundary_crossings(
    segments: &RTree<Segment>,
    shell: &[Point],
    holes: &[Vec<Point>],
) -> Result<(), RegionError> {
    let ring_len = |r: RingRole| match r {
        RingRole::Shell => shell.len(),
        RingRole::Hole(i) => holes[i].len(),
    };
    for s in segments.iter() {
        let (ra, ia) = s.data;
        let la = s.geom();
        let a = Line::new(to_point(la.from), to_point(la.to));
        for t in segments.locate_in_envelope_intersecting(&s.envelope()) {
            let (rb, ib) = t.data;
            if (ra, ia) >= (rb, ib) {
                continue; // each unordered pair once, and never a segment with itself
            }
            let lb = t.geom();
            let b = Line::new(to_point(lb.from), to_point(lb.to));
            if ra == rb {
                let n = ring_len(ra);
                let (first, second) = if (ia + 1) % n == ib {
                    (a, b)
                } else if (ib + 1) % n == ia {
                    (b, a)
                } else {
                    if a.intersects(&b) {
                        return Err(RegionError::SelfIntersection(ra));
                    }
                    continue;
                };
                // Consecutive edges share first.end == second.start; they may only
                // meet there, so a fold back along the same line is a spike.
                let o = RobustKernel::orient2d(first.start, first.end, second.end);
                if o == Orientation::Collinear
                    && dot(first.end - first.start, second.end - second.start) < 0.0
                {
                    return Err(RegionError::SelfIntersection(ra));
                }
                // A triangle's first and last edges are also consecutive: done above.
            } else if a.intersects(&b) {
                return Err(RegionError::RingsIntersect(ra, rb));
            }
        }
    }
    Ok(())
}

/// Even–odd point-in-ring test (the boundary case is handled by the caller).
fn point_in_ring(p: Point, ring: &[Point]) -> bool {
    even_odd_contains(&[ring], p)
}

fn is_convex_ccw(ring: &[Point]) -> bool {
    let n = ring.len();
    (0..n).all(|i| {
        let (a, b, c) = (ring[i], ring[(i + 1) % n], ring[(i + 2) % n]);
        RobustKernel::orient2d(a, b, c) != Orientation::Clockwise
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(pts: &[(f64, f64)]) -> Vec<Point> {
        pts.iter().map(|&(x, y)| Point { x, y }).collect()
    }

    fn square(s: f64) -> Vec<Point> {
        ring(&[(0.0, 0.0), (s, 0.0), (s, s), (0.0, s)])
    }

    #[test]
    fn square_is_valid_convex_and_oriented() {
        let cw = ring(&[(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]);
        let r = Region::new(cw, vec![]).unwrap();
        assert_eq!(r.shell().len(), 4);
        assert!(ring_signed_area(r.shell()) > 0.0);
        assert!(r.is_convex());
        assert!((r.area() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn hole_area_is_subtracted_and_orientation_fixed() {
        let hole = ring(&[(1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0)]);
        let r = Region::new(square(4.0), vec![hole]).unwrap();
        assert!((r.area() - 15.0).abs() < 1e-12);
        assert!(ring_signed_area(&r.holes()[0]) < 0.0);
        assert!(!r.is_convex());
        assert!(!r.contains(Point { x: 1.5, y: 1.5 }));
        assert!(r.contains(Point { x: 1.0, y: 1.5 }));
        assert!(r.contains(Point { x: 0.5, y: 0.5 }));
        let c = r.closest_point(Point { x: 1.5, y: 1.2 });
        assert!((c.y - 1.0).abs() < 1e-12 && (c.x - 1.5).abs() < 1e-12);
    }

    #[test]
    fn rejects_bow_tie() {
        let bow = ring(&[(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)]);
        assert_eq!(
            Region::new(bow, vec![]).unwrap_err(),
            RegionError::SelfIntersection(RingRole::Shell)
        );
    }

    #[test]
    fn rejects_spike() {
        let spike = ring(&[
            (0.0, 0.0),
            (2.0, 0.0),
            (2.0, 2.0),
            (2.0, 3.0),
            (2.0, 1.0),
            (0.0, 2.0),
        ]);
        assert!(matches!(
            Region::new(spike, vec![]).unwrap_err(),
            RegionError::SelfIntersection(_)
        ));
    }

    #[test]
    fn rejects_degenerate_and_short_rings() {
        let line = ring(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]);
        assert_eq!(
            Region::new(line, vec![]).unwrap_err(),
            RegionError::Degenerate(RingRole::Shell)
        );
        let two = ring(&[(0.0, 0.0), (1.0, 1.0), (1.0, 1.0), (0.0, 0.0)]);
        assert_eq!(
            Region::new(two, vec![]).unwrap_err(),
            RegionError::TooFewVertices(RingRole::Shell)
        );
    }

    #[test]
    fn rejects_bad_coordinates() {
        let mut sq = square(1.0);
        sq[2].x = f64::NAN;
        assert_eq!(
            Region::new(sq, vec![]).unwrap_err(),
            RegionError::CoordinateOutOfRange(RingRole::Shell, 2)
        );
        let mut sq = square(1.0);
        sq[1].y = 1e308;
        assert!(Region::new(sq, vec![]).is_err());
    }

    #[test]
    fn rejects_bad_holes() {
        let outside = ring(&[(5.0, 5.0), (6.0, 5.0), (6.0, 6.0)]);
        assert_eq!(
            Region::new(square(4.0), vec![outside]).unwrap_err(),
            RegionError::HoleOutsideShell(RingRole::Hole(0))
        );
        let crossing = ring(&[(3.0, 1.0), (5.0, 1.0), (5.0, 2.0), (3.0, 2.0)]);
        assert!(matches!(
            Region::new(square(4.0), vec![crossing]).unwrap_err(),
            RegionError::RingsIntersect(RingRole::Shell, RingRole::Hole(0))
        ));
        let a = ring(&[(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)]);
        let b = ring(&[(1.5, 1.5), (2.5, 1.5), (2.5, 2.5)]);
        assert!(matches!(
            Region::new(square(4.0), vec![a.clone(), b]).unwrap_err(),
            RegionError::HoleInsideHole(..)
        ));
        let c = ring(&[(2.0, 2.0), (3.5, 2.0), (3.5, 3.5)]);
        assert!(matches!(
            Region::new(square(4.0), vec![a, c]).unwrap_err(),
            RegionError::RingsIntersect(RingRole::Hole(0), RingRole::Hole(1))
        ));
    }

    #[test]
    fn non_convex_shell_is_valid() {
        let l = ring(&[
            (0.0, 0.0),
            (2.0, 0.0),
            (2.0, 1.0),
            (1.0, 1.0),
            (1.0, 2.0),
            (0.0, 2.0),
        ]);
        let r = Region::new(l, vec![]).unwrap();
        assert!(!r.is_convex());
        assert!((r.area() - 3.0).abs() < 1e-12);
        assert!(!r.contains(Point { x: 1.5, y: 1.5 }));
        let c = r.closest_point(Point { x: 1.6, y: 1.5 });
        assert!((c.x - 1.6).abs() < 1e-12 && (c.y - 1.0).abs() < 1e-12);
    }
}

/// Regions shared by the core's unit tests.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::{Point, Region};

    /// The 100 m square from the origin, with a 20 m square island in its
    /// middle when `island`.
    pub(crate) fn square(island: bool) -> Region {
        let p = |x, y| Point { x, y };
        let holes = if island {
            vec![vec![
                p(40.0, 40.0),
                p(60.0, 40.0),
                p(60.0, 60.0),
                p(40.0, 60.0),
            ]]
        } else {
            vec![]
        };
        Region::new(
            vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)],
            holes,
        )
        .expect("a valid region")
    }
}
