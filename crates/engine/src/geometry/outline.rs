//! A region bounded by segments and arcs ([`arcs::boundary`]'s pieces) as
//! the outside world needs it: which points it contains, exactly along the
//! arcs, and its outline as closed rings of vertices for display, GeoJSON
//! and the polygon tools of `geo`.
//!
//! - Containment is even–odd ray casting along +x: a segment is crossed
//!   with the usual half-open rule on its ends' y; a circle meets the ray's
//!   line at most twice, each crossing counted when its angle lies in the
//!   arc's half-open angular range. Pieces meet to rounding, so a point
//!   within rounding of a boundary may come back either way.
//! - Rings: pieces are chained end to start (nearest start, since pieces
//!   meet only to rounding); a ring closes when its own start is nearer
//!   than every unused piece's. Each arc becomes a chord polygon whose
//!   sagitta R (1 − cos(Δθ/2)) is at most the tolerance, so every point of
//!   the arc is within the tolerance of the outline and every vertex on
//!   the arc.
//!
//! Invariant: a ring's orientation is the pieces' (cell on the left):
//! outer rings counter-clockwise, holes clockwise.
//!
//! [`arcs::boundary`]: super::arcs::boundary

use std::f64::consts::{PI, TAU};

use geo::{LineString, MultiPolygon, Polygon};

use super::arcs::{Piece, counter_clockwise};
use super::{Point, even_odd_contains, ring_signed_area};

/// Whether `q` is inside the region bounded by `pieces` (see the module doc).
pub fn contains(pieces: &[Piece], q: Point) -> bool {
    let mut inside = false;
    for piece in pieces {
        match *piece {
            Piece::Segment { from, to } => {
                if (from.y > q.y) != (to.y > q.y) {
                    let x = from.x + (q.y - from.y) * (to.x - from.x) / (to.y - from.y);
                    if x > q.x {
                        inside = !inside;
                    }
                }
            }
            Piece::Arc {
                centre,
                radius,
                start,
                sweep,
            } => {
                let dy = q.y - centre.y;
                // R² − dy² as a product: no cancellation on a huge circle.
                let h2 = (radius - dy.abs()) * (radius + dy.abs());
                if h2 <= 0.0 {
                    continue;
                }
                let h = h2.sqrt();
                let (lo, span) = counter_clockwise(start, sweep);
                for x in [centre.x + h, centre.x - h] {
                    if x > q.x {
                        let theta = dy.atan2(x - centre.x);
                        if (theta - lo).rem_euclid(TAU) < span {
                            inside = !inside;
                        }
                    }
                }
            }
        }
    }
    inside
}

/// A piece's start and end points (also the tests' loop chaining).
pub(crate) fn ends(piece: &Piece) -> (Point, Point) {
    match *piece {
        Piece::Segment { from, to } => (from, to),
        Piece::Arc {
            centre,
            radius,
            start,
            sweep,
        } => (
            on_circle(centre, radius, start),
            on_circle(centre, radius, start + sweep),
        ),
    }
}

fn on_circle(centre: Point, radius: f64, theta: f64) -> Point {
    let (s, c) = theta.sin_cos();
    centre + Point { x: c, y: s } * radius
}

/// The piece's vertices from its start, its end left out (the next
/// piece's start): a segment's start, or an arc's chord polygon within
/// `tolerance` of it.
fn vertices(piece: &Piece, tolerance: f64, out: &mut Vec<Point>) {
    match *piece {
        Piece::Segment { from, .. } => out.push(from),
        Piece::Arc {
            centre,
            radius,
            start,
            sweep,
        } => {
            // Largest step with sagitta ≤ tolerance; never above π/8, so a
            // small circle still looks round.
            let step = if tolerance >= radius {
                PI / 8.0
            } else {
                (2.0 * (1.0 - tolerance / radius).acos()).min(PI / 8.0)
            };
            let n = (sweep.abs() / step).ceil().max(1.0) as usize;
            out.extend(
                (0..n).map(|k| on_circle(centre, radius, start + sweep * k as f64 / n as f64)),
            );
        }
    }
}

/// The pieces chained into closed loops (see the module doc); loops that
/// bound no area are left out.
pub fn loops(pieces: &[Piece]) -> Vec<Vec<Piece>> {
    let ends: Vec<(Point, Point)> = pieces.iter().map(ends).collect();
    let mut used = vec![false; pieces.len()];
    let mut out = Vec::new();
    while let Some(first) = used.iter().position(|u| !u) {
        used[first] = true;
        let mut chain = vec![pieces[first]];
        let origin = ends[first].0;
        let mut at = ends[first].1;
        loop {
            let closing = super::norm2(origin - at);
            let next = (0..pieces.len())
                .filter(|&k| !used[k])
                .map(|k| (super::norm2(ends[k].0 - at), k))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            match next {
                Some((d2, k)) if d2 < closing => {
                    used[k] = true;
                    chain.push(pieces[k]);
                    at = ends[k].1;
                }
                _ => break,
            }
        }
        let area: f64 = chain.iter().map(|p| p.area_share(origin)).sum();
        if area != 0.0 {
            out.push(chain);
        }
    }
    out
}

/// The [`loops`] as closed rings of vertices (without the closing
/// vertex), arcs within `tolerance`; rings of fewer than three vertices or
/// of zero area are left out.
pub fn rings(pieces: &[Piece], tolerance: f64) -> Vec<Vec<Point>> {
    loops(pieces)
        .iter()
        .map(|chain| {
            let mut ring = Vec::new();
            for piece in chain {
                vertices(piece, tolerance, &mut ring);
            }
            ring
        })
        .filter(|ring| ring.len() >= 3 && ring_signed_area(ring) != 0.0)
        .collect()
}

/// Rings from [`rings`] as polygons: each counter-clockwise ring a shell,
/// each clockwise ring a hole of the smallest shell around most of its
/// vertices.
pub fn polygons(rings: &[Vec<Point>]) -> MultiPolygon<f64> {
    let line = |ring: &[Point]| {
        let mut r = ring.to_vec();
        r.push(ring[0]);
        LineString::from(r)
    };
    let (shells, holes): (Vec<&Vec<Point>>, Vec<&Vec<Point>>) =
        rings.iter().partition(|r| ring_signed_area(r) > 0.0);
    let mut interiors: Vec<Vec<LineString<f64>>> = vec![Vec::new(); shells.len()];
    for hole in holes {
        let owner = shells
            .iter()
            .enumerate()
            // Most of its vertices, not one: a hole may touch its shell
            // (a disc tangent to the region's edge) at a vertex.
            .filter(|(_, s)| {
                let inside = hole
                    .iter()
                    .filter(|v| even_odd_contains(std::slice::from_ref(*s), **v))
                    .count();
                2 * inside > hole.len()
            })
            .min_by(|a, b| ring_signed_area(a.1).total_cmp(&ring_signed_area(b.1)));
        if let Some((k, _)) = owner {
            interiors[k].push(line(hole));
        }
    }
    MultiPolygon(
        shells
            .iter()
            .zip(interiors)
            .map(|(s, holes)| Polygon::new(line(s), holes))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Region;
    use crate::geometry::arcs::{Bound, boundary};
    use crate::geometry::norm2;
    use crate::geometry::region::fixtures::square;

    #[test]
    fn a_square_with_a_round_hole_is_one_shell_and_one_hole_within_the_tolerance() {
        let region: Region = square(false);
        let centre = Point { x: 50.0, y: 50.0 };
        let pieces = boundary(
            &region,
            &[Bound::Outside {
                centre,
                radius: 20.0,
            }],
        );
        let rings = rings(&pieces, 0.1);
        assert_eq!(rings.len(), 2);
        let mp = polygons(&rings);
        assert_eq!(mp.0.len(), 1);
        assert_eq!(mp.0[0].interiors().len(), 1);
        // Every vertex of the hole on the circle; every chord's midpoint
        // within 0.1 m of it.
        let hole = rings.iter().find(|r| ring_signed_area(r) < 0.0).unwrap();
        for (k, v) in hole.iter().enumerate() {
            assert!((norm2(*v - centre).sqrt() - 20.0).abs() < 1e-9);
            let w = hole[(k + 1) % hole.len()];
            let mid = (*v + w) * 0.5;
            let sag = 20.0 - norm2(mid - centre).sqrt();
            assert!((0.0..=0.1 + 1e-12).contains(&sag), "sagitta {sag}");
        }
        let exact: f64 = pieces.iter().map(|p| p.area_share(centre)).sum();
        let outlined: f64 = rings.iter().map(|r| ring_signed_area(r)).sum();
        assert!(outlined > exact && outlined - exact < 0.1 * TAU * 20.0);
        assert!(!contains(&pieces, centre));
        assert!(contains(&pieces, Point { x: 5.0, y: 5.0 }));
        assert!(contains(&pieces, Point { x: 50.0, y: 71.0 }));
        assert!(!contains(&pieces, Point { x: 50.0, y: 69.0 }));
        assert!(!contains(&pieces, Point { x: 150.0, y: 50.0 }));
    }

    #[test]
    fn the_corners_outside_a_big_disc_are_four_shells_and_a_disc_is_one() {
        let region: Region = square(false);
        let disc = Bound::Disc {
            centre: Point { x: 20.0, y: 50.0 },
            radius: 30.0,
        };
        let one = rings(&boundary(&region, &[disc]), 0.1);
        assert_eq!(one.len(), 1);
        assert!(ring_signed_area(&one[0]) > 0.0);
        let middle = Bound::Outside {
            centre: Point { x: 50.0, y: 50.0 },
            radius: 60.0,
        };
        let corners = polygons(&rings(&boundary(&region, &[middle]), 0.1));
        assert_eq!(corners.0.len(), 4);
        assert!(corners.0.iter().all(|p| p.interiors().is_empty()));
    }
}
