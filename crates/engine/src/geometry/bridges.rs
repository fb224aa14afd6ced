//! Removing the zero-width bridges that clipping a non-convex ring leaves
//! on the clipping lines (`ConvexPolygon::clip_ring`, Sutherland–Hodgman).
//!
//! A bridge is traversed once each way, so in exact arithmetic it adds
//! nothing to an area or a boundary integral. In floating point its two
//! traversals cancel only to rounding of their own size, and a bridge can
//! run far from the piece it hangs on: towards a risk object's centre, the
//! two traversals of a Gaussian integral are then e^{a(d_cell² − d_bridge²)}
//! times the cell's own integral, and their rounding is the whole result (a
//! 0.2 m² cell 40 m from a σ = 3 m object, whose bridge reached 14 m from
//! it: e^84; its centroid came out 40 m from the cell).
//!
//! [`without_bridges`] cancels every stretch of a clipping line that the
//! chain covers as often in one direction as in the other, and links what
//! is left into closed rings. Invariants:
//! - no new coordinates: an edge on a line is cut only at vertices that
//!   already lie on it, so the remaining edges meet end to end exactly;
//! - the result encloses the same area (to rounding) and the same points;
//! - deterministic: edges are walked in the order of the input.

use std::collections::BTreeMap;

use super::{Point, dot};

/// A clipping line `normal · x = offset` (any scale of `normal`).
#[derive(Debug, Clone, Copy)]
pub struct Line {
    /// The line's normal (non-zero, any length).
    pub normal: Point,
    /// `normal · x` at every point x of the line.
    pub offset: f64,
}

/// `rings` (an oriented chain: interior on the left, possibly with bridges
/// along `lines`) as closed rings without the stretches of `lines` that
/// cancel. Rings of fewer than three vertices are dropped: what remains of
/// them encloses nothing.
pub fn without_bridges(rings: &[Vec<Point>], lines: &[Line]) -> Vec<Vec<Point>> {
    let mut edges: Vec<(Point, Point)> = Vec::new();
    let mut on_line: Vec<Vec<(Point, Point)>> = vec![Vec::new(); lines.len()];
    let reach = rings
        .iter()
        .flatten()
        .map(|v| v.x.abs().max(v.y.abs()))
        .fold(0.0, f64::max);
    for ring in rings {
        for (i, &a) in ring.iter().enumerate() {
            let b = ring[(i + 1) % ring.len()];
            match lines
                .iter()
                .position(|l| near(l, a, reach) && near(l, b, reach))
            {
                Some(k) => on_line[k].push((a, b)),
                None => edges.push((a, b)),
            }
        }
    }
    for (line, those) in lines.iter().zip(&on_line) {
        if !those.is_empty() {
            net_edges(line, those, &mut edges);
        }
    }
    link(&edges)
}

/// Whether `p` lies on `line` to the rounding of coordinates up to `reach`.
fn near(line: &Line, p: Point, reach: f64) -> bool {
    let scale = line.normal.x.abs().max(line.normal.y.abs());
    (dot(line.normal, p) - line.offset).abs() <= 1e-9 * scale * (reach + 1.0)
}

/// The edges on one line, cut at every vertex of theirs and summed with
/// their directions: each elementary stretch goes out as many times as the
/// chain covers it net, in the direction of the net.
fn net_edges(line: &Line, those: &[(Point, Point)], out: &mut Vec<(Point, Point)>) {
    let along = Point {
        x: -line.normal.y,
        y: line.normal.x,
    };
    let key = |p: Point| (dot(along, p), p.x.to_bits(), p.y.to_bits());
    let mut points: Vec<Point> = those.iter().flat_map(|&(a, b)| [a, b]).collect();
    points.sort_by(|&p, &q| {
        let (kp, kq) = (key(p), key(q));
        kp.0.total_cmp(&kq.0).then((kp.1, kp.2).cmp(&(kq.1, kq.2)))
    });
    points.dedup_by(|p, q| p.x.to_bits() == q.x.to_bits() && p.y.to_bits() == q.y.to_bits());
    let index: BTreeMap<(u64, u64), usize> = points
        .iter()
        .enumerate()
        .map(|(i, p)| ((p.x.to_bits(), p.y.to_bits()), i))
        .collect();
    let at = |p: Point| index[&(p.x.to_bits(), p.y.to_bits())];
    let mut net = vec![0i64; points.len().saturating_sub(1)];
    for &(a, b) in those {
        let (i, j) = (at(a), at(b));
        let (lo, hi, sign) = if i < j { (i, j, 1) } else { (j, i, -1) };
        for n in &mut net[lo..hi] {
            *n += sign;
        }
    }
    for (j, &n) in net.iter().enumerate() {
        let (a, b) = (points[j], points[j + 1]);
        for _ in 0..n.unsigned_abs() {
            out.push(if n > 0 { (a, b) } else { (b, a) });
        }
    }
}

/// Closed rings through `edges`, which meet end to end exactly (every
/// vertex has as many edges in as out).
fn link(edges: &[(Point, Point)]) -> Vec<Vec<Point>> {
    let bits = |p: Point| (p.x.to_bits(), p.y.to_bits());
    let mut leaving: BTreeMap<(u64, u64), Vec<usize>> = BTreeMap::new();
    for (i, &(a, _)) in edges.iter().enumerate().rev() {
        leaving.entry(bits(a)).or_default().push(i);
    }
    let mut used = vec![false; edges.len()];
    let mut rings = Vec::new();
    for first in 0..edges.len() {
        if used[first] {
            continue;
        }
        let start = bits(edges[first].0);
        let mut ring = Vec::new();
        let mut e = first;
        loop {
            used[e] = true;
            ring.push(edges[e].0);
            let end = bits(edges[e].1);
            if end == start {
                break;
            }
            let next = leaving.get_mut(&end).and_then(|out| {
                while let Some(&i) = out.last() {
                    if used[i] {
                        out.pop();
                    } else {
                        return Some(i);
                    }
                }
                None
            });
            match next {
                Some(i) => e = i,
                // Unbalanced input (not a closed chain): keep what was walked.
                None => break,
            }
        }
        if ring.len() >= 3 {
            rings.push(ring);
        }
    }
    rings
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ring_signed_area;

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    #[test]
    fn a_dead_end_spike_goes() {
        // A triangle with a spike along y = x from (1, 1) out to (5, 5).
        let ring = vec![
            p(0.0, 0.0),
            p(1.0, 0.0),
            p(1.0, 1.0),
            p(5.0, 5.0),
            p(0.5, 0.5),
        ];
        let line = Line {
            normal: p(1.0, -1.0),
            offset: 0.0,
        };
        let rings = without_bridges(std::slice::from_ref(&ring), &[line]);
        assert_eq!(rings.len(), 1);
        assert!(!rings[0].contains(&p(5.0, 5.0)), "{rings:?}");
        assert_eq!(ring_signed_area(&rings[0]), ring_signed_area(&ring));
    }

    #[test]
    fn a_bridge_between_two_pieces_splits_them() {
        // Two unit squares joined along y = 0 by a bridge from x = 1 to 3.
        let ring = vec![
            p(0.0, 0.0),
            p(1.0, 0.0),
            p(3.0, 0.0),
            p(4.0, 0.0),
            p(4.0, 1.0),
            p(3.0, 1.0),
            p(3.0, 0.0),
            p(1.0, 0.0),
            p(1.0, 1.0),
            p(0.0, 1.0),
        ];
        let line = Line {
            normal: p(0.0, 1.0),
            offset: 0.0,
        };
        let rings = without_bridges(&[ring], &[line]);
        assert_eq!(rings.len(), 2, "{rings:?}");
        for r in &rings {
            assert_eq!(ring_signed_area(r), 1.0);
            assert!(r.iter().all(|v| v.x <= 1.0) || r.iter().all(|v| v.x >= 3.0));
        }
    }

    #[test]
    fn a_ring_off_the_lines_is_unchanged() {
        let ring = vec![p(0.0, 0.0), p(2.0, 0.0), p(2.0, 2.0), p(0.0, 2.0)];
        let line = Line {
            normal: p(1.0, 1.0),
            offset: 100.0,
        };
        assert_eq!(
            without_bridges(std::slice::from_ref(&ring), &[line]),
            vec![ring]
        );
    }
}
