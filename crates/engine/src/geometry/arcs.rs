//! Regions bounded by segments and circular arcs: the task region cut by
//! half-planes, discs and disc complements, as a generalized Voronoi cell
//! with different actuator reaches is (paper eq. 6 with β_i ≠ β_j).
//!
//! The result is the cell's **oriented boundary**, a list of [`Piece`]s
//! with the cell on the left of each, not assembled into rings. Green's
//! theorem needs no more, and holes and cells in several pieces need no
//! special case: each boundary curve (a region edge, a bound's line or
//! circle) keeps the parameter intervals where it lies inside the region
//! and inside every other bound, and those become pieces.
//!
//! Numerics: every intersection is solved on the curve's own parameter
//! (a line's arc length, a circle's angle), so the pieces meet to
//! rounding, not exactly; an integral over them is off by rounding times
//! the boundary's length. Near-equal reaches make circles of radius
//! R ~ ‖P‖/ε (1e6 to 1e10 m) whose crossings with other curves are a tiny
//! angle ℓ/R apart: there cos φ = v rounds to 1 and acos(v) amplifies its
//! rounding by R/ℓ (or returns 0). So 1 − v and 1 + v are formed from
//! their exact factorizations, products of differences of lengths
//! (1 − v = (ρ + r − D)(ρ − r + D)/(2rD) for two circles, (r − h)/r for a
//! line at signed distance h), each difference accurate to the rounding
//! of the lengths, and φ = 2 asin √((1 − v)/2), which keeps the relative
//! accuracy of a small φ; a line's crossing with a circle likewise takes
//! |w|² − r² as (|w| − r)(|w| + r). An arc's area share is the triangle
//! of its ends plus its circular segment ½R²(w − sin w) (a series for
//! small w), not R² times a difference of cosines of nearby angles.
//! What remains is the representation: a circle of radius R stored as
//! f64 centre and radius, and its points evaluated as c + R u(θ), sit
//! ~1e-16 R off the exact edge (measured: 1e-6 m at R = 4.8e9, 1e-7 m at
//! 4.8e8), which no solving here can undo (curved_reference's
//! near-equal test).
//!
//! A curve tangent to another bound touches it in a point and is kept or
//! dropped as rounding decides: either way the measure is zero. Two equal
//! bounds are one bound (they are deduplicated): otherwise each would keep
//! its curve on the other's and count that boundary twice.
//!
//! Cost: O(m (m + e)) for m bounds and e region edges.

use std::f64::consts::TAU;

use smallvec::{SmallVec, smallvec};

use super::{Point, Region, cross, dot, norm2, segment_distance2};

/// One constraint of a cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// The points q with `normal · q ≤ offset` (`normal` non-zero).
    HalfPlane {
        /// The line's normal, pointing away from the kept side (any length).
        normal: Point,
        /// The largest `normal · q` kept.
        offset: f64,
    },
    /// The points within `radius` of `centre`.
    Disc {
        /// The disc's centre.
        centre: Point,
        /// Its radius [m].
        radius: f64,
    },
    /// The points at least `radius` from `centre`.
    Outside {
        /// The centre of the disc left out.
        centre: Point,
        /// Its radius [m].
        radius: f64,
    },
}

impl Bound {
    /// Whether `q` meets the bound (a point on its edge does).
    pub fn contains(&self, q: Point) -> bool {
        match *self {
            Bound::HalfPlane { normal, offset } => dot(normal, q) <= offset,
            Bound::Disc { centre, radius } => norm2(q - centre) <= radius * radius,
            Bound::Outside { centre, radius } => norm2(q - centre) >= radius * radius,
        }
    }

    /// The parameters t of the points `o + t d` inside (d non-zero).
    fn on_line(&self, o: Point, d: Point) -> Intervals {
        match *self {
            Bound::HalfPlane { normal, offset } => {
                let s = dot(normal, d);
                let v = offset - dot(normal, o);
                if s > 0.0 {
                    smallvec![(f64::NEG_INFINITY, v / s)]
                } else if s < 0.0 {
                    smallvec![(v / s, f64::INFINITY)]
                } else if v >= 0.0 {
                    Intervals::from_slice(&ALL_LINE)
                } else {
                    smallvec![]
                }
            }
            Bound::Disc { centre, radius } => match line_circle(o, d, centre, radius) {
                Some((t0, t1)) => smallvec![(t0, t1)],
                None => smallvec![],
            },
            Bound::Outside { centre, radius } => match line_circle(o, d, centre, radius) {
                Some((t0, t1)) => smallvec![(f64::NEG_INFINITY, t0), (t1, f64::INFINITY)],
                None => Intervals::from_slice(&ALL_LINE),
            },
        }
    }

    /// The angles θ ∈ [0, 2π) of the points `c + r (cos θ, sin θ)` inside.
    fn on_circle(&self, c: Point, r: f64) -> Intervals {
        match *self {
            Bound::HalfPlane { normal, offset } => {
                // n̂·(c + r u) ≤ offset/|n|  ⇔  cos(θ − α) ≤ κ = h/r, h the
                // signed distance from c to the line (kept side positive).
                // 1 ∓ κ = (r ∓ h)/r: a difference of lengths, accurate
                // where κ itself would round to ±1 (see the module doc).
                let len = norm2(normal).sqrt();
                let h = offset / len - dot(normal, c) / len;
                let (below, above) = ((r - h) / r, (r + h) / r);
                if below <= 0.0 {
                    Intervals::from_slice(&ALL_CIRCLE)
                } else if above <= 0.0 {
                    smallvec![]
                } else {
                    let alpha = normal.y.atan2(normal.x);
                    let delta = acos_from(below, above);
                    angular(alpha + delta, alpha + TAU - delta)
                }
            }
            Bound::Disc { centre, radius } | Bound::Outside { centre, radius } => {
                let inside = matches!(self, Bound::Disc { .. });
                let to = centre - c;
                let dist = norm2(to).sqrt();
                if dist == 0.0 {
                    // Concentric: all or nothing.
                    return if (r <= radius) == inside || r == radius {
                        Intervals::from_slice(&ALL_CIRCLE)
                    } else {
                        smallvec![]
                    };
                }
                // |c + r u − centre|² ≤ radius²  ⇔  cos(θ − γ) ≥ v with
                // v = (r² + D² − ρ²)/(2rD), from its exact factorizations
                // 1 − v = (ρ + r − D)(ρ − r + D)/(2rD) and
                // 1 + v = (r + D − ρ)(r + D + ρ)/(2rD) (see the module doc).
                let two_rd = 2.0 * r * dist;
                let below = sum_less(radius, r, dist) * sum_less(radius, dist, r) / two_rd;
                let above = sum_less(r, dist, radius) * (r + dist + radius) / two_rd;
                let gamma = || to.y.atan2(to.x);
                match inside {
                    true if above <= 0.0 => Intervals::from_slice(&ALL_CIRCLE),
                    true if below <= 0.0 => smallvec![],
                    true => {
                        let (gamma, phi) = (gamma(), acos_from(below, above));
                        angular(gamma - phi, gamma + phi)
                    }
                    false if below <= 0.0 => Intervals::from_slice(&ALL_CIRCLE),
                    false if above <= 0.0 => smallvec![],
                    false => {
                        let (gamma, phi) = (gamma(), acos_from(below, above));
                        angular(gamma + phi, gamma + TAU - phi)
                    }
                }
            }
        }
    }
}

/// x + y − z (all ≥ 0) with the cancelling pair taken first: exact up to
/// one rounding of the result when z is near x + y.
fn sum_less(x: f64, y: f64, z: f64) -> f64 {
    if x >= y { (x - z) + y } else { (y - z) + x }
}

/// acos v from 1 − v and 1 + v, each accurate to its own size: through
/// asin of the half angle on the side where it is small, so a crossing
/// angle of 1e-9 keeps its relative accuracy (acos of a v that rounds to
/// 1 would give 0).
fn acos_from(below: f64, above: f64) -> f64 {
    if below <= above {
        2.0 * (0.5 * below).min(1.0).sqrt().asin()
    } else {
        std::f64::consts::PI - 2.0 * (0.5 * above).min(1.0).sqrt().asin()
    }
}

/// A piece of a cell's boundary, the cell on its left.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Piece {
    /// The straight line from `from` to `to`.
    Segment {
        /// Where the piece starts.
        from: Point,
        /// Where it ends.
        to: Point,
    },
    /// `centre + radius (cos θ, sin θ)` for θ from `start` to `start +
    /// sweep`: counter-clockwise when `sweep` > 0 (the cell inside the
    /// circle), clockwise when < 0 (the cell outside).
    Arc {
        /// The circle's centre.
        centre: Point,
        /// The circle's radius [m].
        radius: f64,
        /// The angle θ where the arc starts [rad].
        start: f64,
        /// The signed angle the arc turns through [rad].
        sweep: f64,
    },
}

impl Piece {
    /// Squared distance from `q` to the piece.
    pub fn distance2(&self, q: Point) -> f64 {
        match *self {
            Piece::Segment { from, to } => segment_distance2(q, from, to),
            Piece::Arc {
                centre,
                radius,
                start,
                sweep,
            } => {
                let y = q - centre;
                let (lo, span) = counter_clockwise(start, sweep);
                let theta = y.y.atan2(y.x);
                if (theta - lo).rem_euclid(TAU) <= span {
                    let d = norm2(y).sqrt() - radius;
                    d * d
                } else {
                    let end = |t: f64| {
                        centre
                            + Point {
                                x: t.cos(),
                                y: t.sin(),
                            } * radius
                    };
                    norm2(q - end(lo)).min(norm2(q - end(lo + span)))
                }
            }
        }
    }

    /// A box (low, high corners) holding the piece: a segment's ends, an
    /// arc's ends and the points of its circle due east, north, west and
    /// south that it passes, widened by rounding: a circle's points are
    /// evaluated as c + R u(θ), off the stored ends by ~1e-16 (|c| + R).
    pub fn bounding_box(&self) -> (Point, Point) {
        match *self {
            Piece::Segment { from, to } => (
                Point {
                    x: from.x.min(to.x),
                    y: from.y.min(to.y),
                },
                Point {
                    x: from.x.max(to.x),
                    y: from.y.max(to.y),
                },
            ),
            Piece::Arc {
                centre,
                radius,
                start,
                sweep,
            } => {
                let (lo, span) = counter_clockwise(start, sweep);
                let at = |t: f64| {
                    let (s, c) = t.sin_cos();
                    centre + Point { x: c, y: s } * radius
                };
                let (a, b) = (at(lo), at(lo + span));
                let (mut low, mut high) = (
                    Point {
                        x: a.x.min(b.x),
                        y: a.y.min(b.y),
                    },
                    Point {
                        x: a.x.max(b.x),
                        y: a.y.max(b.y),
                    },
                );
                for (k, axis) in [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]
                    .into_iter()
                    .enumerate()
                {
                    let theta = k as f64 * std::f64::consts::FRAC_PI_2;
                    if (theta - lo).rem_euclid(TAU) <= span {
                        let q = centre
                            + Point {
                                x: axis.0,
                                y: axis.1,
                            } * radius;
                        low = Point {
                            x: low.x.min(q.x),
                            y: low.y.min(q.y),
                        };
                        high = Point {
                            x: high.x.max(q.x),
                            y: high.y.max(q.y),
                        };
                    }
                }
                let slack = 1e-12 * (centre.x.abs() + centre.y.abs() + radius) + 1e-9;
                let pad = Point { x: slack, y: slack };
                (low - pad, high + pad)
            }
        }
    }

    /// ½ ∮ (x dy − y dx) along the piece, about `origin`: the piece's share
    /// of the area of the cell it bounds.
    pub fn area_share(&self, origin: Point) -> f64 {
        match *self {
            Piece::Segment { from, to } => 0.5 * cross(from - origin, to - origin),
            Piece::Arc {
                centre,
                radius,
                start,
                sweep,
            } => {
                // The triangle (origin, ends) and the circular segment
                // between chord and arc: no term is larger than the
                // result's own size, however large the radius.
                let c = centre - origin;
                let end = |t: f64| {
                    let (s, co) = t.sin_cos();
                    c + Point { x: co, y: s } * radius
                };
                let triangle = 0.5 * cross(end(start), end(start + sweep));
                triangle + 0.5 * radius * radius * sweep_less_sin(sweep)
            }
        }
    }
}

/// An arc's angles as counter-clockwise from `lo` through `span` ≥ 0,
/// whichever way it runs.
pub fn counter_clockwise(start: f64, sweep: f64) -> (f64, f64) {
    if sweep >= 0.0 {
        (start, sweep)
    } else {
        (start + sweep, -sweep)
    }
}

/// w − sin w without cancellation: its series for small |w|, where the
/// first dropped term, w¹¹/11!, is below 1e-15 of w³/6.
fn sweep_less_sin(w: f64) -> f64 {
    if w.abs() < 0.1 {
        let w2 = w * w;
        w * w2 / 6.0 * (1.0 - w2 / 20.0 * (1.0 - w2 / 42.0 * (1.0 - w2 / 72.0)))
    } else {
        w - w.sin()
    }
}

/// Sorted, disjoint, closed parameter intervals.
/// Inline: a curve's intervals are one or two almost always, and the
/// partition builds tens of them per cell (heap allocations were a fifth
/// of a mixed-β partition).
type Intervals = SmallVec<[(f64, f64); 4]>;

const ALL_LINE: [(f64, f64); 1] = [(f64::NEG_INFINITY, f64::INFINITY)];
const ALL_CIRCLE: [(f64, f64); 1] = [(0.0, TAU)];

/// [s, e] (e − s ≤ 2π) as intervals of [0, 2π).
fn angular(s: f64, e: f64) -> Intervals {
    let s0 = s.rem_euclid(TAU);
    let e0 = s0 + (e - s);
    if e0 <= TAU {
        smallvec![(s0, e0)]
    } else {
        smallvec![(0.0, e0 - TAU), (s0, TAU)]
    }
}

fn intersect(a: &Intervals, b: &Intervals) -> Intervals {
    let (mut i, mut j) = (0, 0);
    let mut out = Intervals::new();
    while i < a.len() && j < b.len() {
        let lo = a[i].0.max(b[j].0);
        let hi = a[i].1.min(b[j].1);
        if lo < hi {
            out.push((lo, hi));
        }
        if a[i].1 < b[j].1 {
            i += 1;
        } else {
            j += 1;
        }
    }
    out
}

/// The parameters where `o + t d` crosses the circle, in order, when it
/// crosses it at two points.
fn line_circle(o: Point, d: Point, c: Point, r: f64) -> Option<(f64, f64)> {
    let a = norm2(d);
    let w = o - c;
    let b = dot(w, d);
    // |w|² − r² as a product: no cancellation for a huge circle.
    let dw = norm2(w).sqrt();
    let cc = (dw - r) * (dw + r);
    let disc = b * b - a * cc;
    if disc <= 0.0 {
        return None;
    }
    // The root without cancellation, then the other from the product.
    let q = -(b + b.signum() * disc.sqrt());
    if q == 0.0 {
        let t = (-cc / a).sqrt();
        return Some((-t, t));
    }
    let (t0, t1) = (q / a, cc / q);
    Some((t0.min(t1), t0.max(t1)))
}

/// Every edge of the region, from → to, the region on its left.
fn edges(region: &Region) -> impl Iterator<Item = (Point, Point)> + '_ {
    std::iter::once(region.shell())
        .chain(region.holes().iter().map(Vec::as_slice))
        .flat_map(|ring| (0..ring.len()).map(move |i| (ring[i], ring[(i + 1) % ring.len()])))
}

/// Whether `q` is in the cell: in the region and inside every bound.
pub fn contains(region: &Region, bounds: &[Bound], q: Point) -> bool {
    region.contains(q) && bounds.iter().all(|b| b.contains(q))
}

/// The oriented boundary of the region cut by `bounds` (see the module
/// doc).
pub fn boundary(region: &Region, bounds: &[Bound]) -> Vec<Piece> {
    let mut unique: SmallVec<[Bound; 16]> = SmallVec::new();
    for b in bounds {
        if !unique.contains(b) {
            unique.push(*b);
        }
    }
    let bounds = &unique[..];
    let mut pieces = Vec::new();
    // The region's edges, inside every bound.
    for (a, b) in edges(region) {
        let d = b - a;
        let mut keep = smallvec![(0.0, 1.0)];
        for bound in bounds {
            keep = intersect(&keep, &bound.on_line(a, d));
            if keep.is_empty() {
                break;
            }
        }
        pieces.extend(keep.into_iter().map(|(t0, t1)| Piece::Segment {
            from: a + d * t0,
            to: a + d * t1,
        }));
    }
    // Each bound's curve, inside the region and every other bound.
    for (k, bound) in bounds.iter().enumerate() {
        let others = bounds
            .iter()
            .enumerate()
            .filter(move |&(l, _)| l != k)
            .map(|(_, b)| b);
        match *bound {
            Bound::HalfPlane { normal, offset } => {
                let len2 = norm2(normal);
                let o = normal * (offset / len2);
                // The kept side (−normal) on the left.
                let d = Point {
                    x: -normal.y,
                    y: normal.x,
                } / len2.sqrt();
                // The other bounds first: most curves of a cell end empty
                // against them, and then the region's crossings are never
                // computed. (Intervals intersect by picking endpoints, so
                // the order changes nothing in the result.)
                let mut keep = Intervals::from_slice(&ALL_LINE);
                for other in others {
                    keep = intersect(&keep, &other.on_line(o, d));
                    if keep.is_empty() {
                        break;
                    }
                }
                if !keep.is_empty() {
                    keep = intersect(&keep, &line_in_region(region, o, d));
                }
                pieces.extend(keep.into_iter().map(|(t0, t1)| Piece::Segment {
                    from: o + d * t0,
                    to: o + d * t1,
                }));
            }
            Bound::Disc { centre, radius } | Bound::Outside { centre, radius } => {
                let mut keep = Intervals::from_slice(&ALL_CIRCLE);
                for other in others {
                    keep = intersect(&keep, &other.on_circle(centre, radius));
                    if keep.is_empty() {
                        break;
                    }
                }
                if !keep.is_empty() {
                    keep = intersect(&keep, &circle_in_region(region, centre, radius));
                }
                let ccw = matches!(bound, Bound::Disc { .. });
                pieces.extend(keep.into_iter().map(|(t0, t1)| Piece::Arc {
                    centre,
                    radius,
                    start: if ccw { t0 } else { t1 },
                    sweep: if ccw { t1 - t0 } else { t0 - t1 },
                }));
            }
        }
    }
    pieces
}

/// A curve's parameters where it crosses the region's edges.
type Crossings = SmallVec<[f64; 16]>;

/// The parameters of `o + t d` inside the region.
fn line_in_region(region: &Region, o: Point, d: Point) -> Intervals {
    let mut ts: Crossings = SmallVec::new();
    for (a, b) in edges(region) {
        let e = b - a;
        let den = cross(d, e);
        if den == 0.0 {
            continue;
        }
        // o + t d = a + s e.
        let w = a - o;
        let s = cross(w, d) / den;
        if (0.0..=1.0).contains(&s) {
            ts.push(cross(w, e) / den);
        }
    }
    runs_inside(region, ts, |t| o + d * t)
}

/// The angles of the circle's points inside the region.
fn circle_in_region(region: &Region, c: Point, r: f64) -> Intervals {
    let mut ts: Crossings = SmallVec::new();
    for (a, b) in edges(region) {
        let d = b - a;
        if let Some((t0, t1)) = line_circle(a, d, c, r) {
            for t in [t0, t1] {
                if (0.0..=1.0).contains(&t) {
                    let p = a + d * t - c;
                    ts.push(p.y.atan2(p.x).rem_euclid(TAU));
                }
            }
        }
    }
    let at = |t: f64| {
        c + Point {
            x: t.cos(),
            y: t.sin(),
        } * r
    };
    if ts.is_empty() {
        return if region.contains(at(0.0)) {
            Intervals::from_slice(&ALL_CIRCLE)
        } else {
            smallvec![]
        };
    }
    ts.push(0.0);
    ts.push(TAU);
    runs_inside(region, ts, at)
}

/// The runs between consecutive crossing parameters `ts` (closed at ±∞
/// for a line) whose middle is inside the region, merged.
fn runs_inside(region: &Region, mut ts: Crossings, at: impl Fn(f64) -> Point) -> Intervals {
    ts.sort_by(f64::total_cmp);
    ts.dedup();
    let mut out = Intervals::new();
    for w in ts.windows(2) {
        let (t0, t1) = (w[0], w[1]);
        if t1 > t0 && region.contains(at(0.5 * (t0 + t1))) {
            match out.last_mut() {
                Some(last) if last.1 == t0 => last.1 = t1,
                _ => out.push((t0, t1)),
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(pieces: &[Piece]) -> f64 {
        pieces
            .iter()
            .map(|p| p.area_share(Point { x: 50.0, y: 50.0 }))
            .sum()
    }

    #[test]
    fn a_disc_inside_the_square_and_its_complement_tile_it() {
        let square = super::super::region::fixtures::square(false);
        let (centre, radius) = (Point { x: 40.0, y: 55.0 }, 20.0);
        let inside = boundary(&square, &[Bound::Disc { centre, radius }]);
        let outside = boundary(&square, &[Bound::Outside { centre, radius }]);
        let disc = std::f64::consts::PI * radius * radius;
        assert!((area(&inside) - disc).abs() < 1e-9, "{}", area(&inside));
        assert!((area(&outside) - (square.area() - disc)).abs() < 1e-9);
    }

    #[test]
    fn a_lens_and_a_crescent_have_their_closed_form_areas() {
        let square = super::super::region::fixtures::square(false);
        let (c1, r1) = (Point { x: 40.0, y: 50.0 }, 25.0);
        let (c2, r2) = (Point { x: 62.0, y: 57.0 }, 18.0);
        let d = norm2(c2 - c1).sqrt();
        // The lens: two circular segments.
        let seg = |r: f64, a: f64| r * r * (a - a.sin()) / 2.0;
        let a1 = 2.0 * ((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1)).acos();
        let a2 = 2.0 * ((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2)).acos();
        let lens = seg(r1, a1) + seg(r2, a2);
        let disc = |centre, radius| Bound::Disc { centre, radius };
        let got = area(&boundary(&square, &[disc(c1, r1), disc(c2, r2)]));
        assert!((got - lens).abs() < 1e-10 * lens, "{got} vs {lens}");
        let crescent = std::f64::consts::PI * r1 * r1 - lens;
        let outside = Bound::Outside {
            centre: c2,
            radius: r2,
        };
        let got = area(&boundary(&square, &[disc(c1, r1), outside]));
        assert!(
            (got - crescent).abs() < 1e-10 * crescent,
            "{got} vs {crescent}"
        );
    }

    #[test]
    fn a_disc_across_the_shell_and_a_half_plane() {
        let square = super::super::region::fixtures::square(false);
        let (lo, hi) = square.bounds();
        // A disc of radius w/2 centred on the left edge, cut at y ≤ mid:
        // a quarter of the disc.
        let w = hi.x - lo.x;
        let mid = Point {
            x: lo.x,
            y: 0.5 * (lo.y + hi.y),
        };
        let cut = [
            Bound::Disc {
                centre: mid,
                radius: 0.5 * w,
            },
            Bound::HalfPlane {
                normal: Point { x: 0.0, y: 1.0 },
                offset: mid.y,
            },
        ];
        let quarter = std::f64::consts::PI * w * w / 16.0;
        let pieces = boundary(&square, &cut);
        assert!(
            (area(&pieces) - quarter).abs() < 1e-9 * quarter,
            "{}",
            area(&pieces)
        );
        // Equal bounds count once.
        let twice = boundary(&square, &[cut[0], cut[1], cut[0]]);
        assert_eq!(pieces, twice);
    }
}
