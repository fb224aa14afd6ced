//! Where a vessel should actually go: its cell's centroid, made reachable.
//!
//! A centroid is a mass-weighted mean, so in a region with islands it can lie
//! on an island (an island inside a cell pulls the mean into itself), in
//! another piece of the cell (a pier or an island that cuts the cell in two),
//! or closer to the shore than a vessel may go. The goal is therefore:
//!
//! 1. the centroid C itself when it lies in the vessel's own piece of its
//!    cell — the connected part of V_i that contains the vessel (or, for a
//!    vessel outside its cell, the nearest part);
//! 2. otherwise the point of that piece nearest to C (on its boundary);
//! 3. then moved out to `clearance` from the shore: from the nearest shore
//!    point q along the direction from q to the point (the edge's inward
//!    normal when the point is on it), repeated a few times so that a goal
//!    pushed off one wall of a concave corner into another's margin is
//!    pushed again. This approximates the nearest point of the piece eroded
//!    by the clearance; in a passage narrower than twice the clearance there
//!    is none, and the goal settles on the passage's middle line;
//! 4. should that leave it on the shore (a needle of water too thin for
//!    any push, the goal left on its tip), a point inside the vessel's own
//!    piece instead, else inside Q (`geo`'s interior point).
//!
//! Only the shore (∂Q) counts for the clearance, not the cell's edges to
//! other vessels: those are not obstacles, and a goal just across one is
//! fine. Cost: the common case (C in Q and in plain sight of the vessel, so
//! in the same piece, since both lie in the convex power cell) is one
//! segment query; only otherwise are the cell's pieces built.
//!
//! Invariants: pure, deterministic, total (an empty cell's centroid is
//! already the nearest point of Q and is only moved off the shore); the goal
//! is in Q.

use geo::{Contains, Coord, InteriorPoint};

use super::{CellGeometry, CellResult};
use crate::geometry::shore::Shore;
use crate::geometry::{Point, norm2, segment_closest};

/// How many times a goal is pushed off the shore (concave corners).
const PUSHES: usize = 4;

/// The reachable goal of a vessel at `p` whose cell is `cell`, at least
/// `clearance` from the shore where the water allows it.
pub fn reachable_goal(shore: &Shore, cell: &CellResult, p: Point, clearance: f64) -> Point {
    let region = shore.region();
    let c = cell.centroid;
    let projected = match &cell.geometry {
        CellGeometry::Empty => c,
        geometry => {
            let in_hull = match geometry {
                CellGeometry::Convex(h) | CellGeometry::Clipped { hull: h, .. } => h.contains(p),
                // A curved cell has no convex hull in which a straight
                // line stays in one piece: always take its own piece.
                CellGeometry::Empty | CellGeometry::Curved { .. } => false,
            };
            if in_hull && region.contains(c) && shore.segment_clear(p, c, 0.0) {
                c
            } else {
                on_own_piece(geometry, shore, p, c)
            }
        }
    };
    let goal = off_the_shore(shore, projected, clearance);
    if region.contains(goal) {
        return goal;
    }
    // Water too thin for any push (a needle of Q, the goal left on its
    // tip, on the shore): a point inside the vessel's own piece, else
    // inside Q. Rare, so the cost of building the pieces does not matter.
    let inside = |poly: &geo::Polygon<f64>| {
        poly.interior_point()
            .map(|q| Point { x: q.x(), y: q.y() })
            .filter(|q| region.contains(*q))
    };
    let piece = match &cell.geometry {
        CellGeometry::Empty => None,
        geometry => own_piece(geometry, shore, p),
    };
    piece
        .as_ref()
        .and_then(inside)
        .or_else(|| inside(region.polygon()))
        .unwrap_or(goal)
}

/// The piece of the cell (cell ∩ Q) that contains the vessel at `p`, or
/// the nearest one; `None` for a cell without pieces.
fn own_piece(geometry: &CellGeometry, shore: &Shore, p: Point) -> Option<geo::Polygon<f64>> {
    let distance_to = |poly: &geo::Polygon<f64>, q: Point| -> f64 {
        if poly.contains(&Coord { x: q.x, y: q.y }) {
            0.0
        } else {
            nearest_on_boundary(poly, q).1
        }
    };
    geometry
        .pieces(shore.region())
        .0
        .into_iter()
        .map(|poly| (distance_to(&poly, p), poly))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, poly)| poly)
}

/// The point of the vessel's own piece of the cell nearest to `c`.
fn on_own_piece(geometry: &CellGeometry, shore: &Shore, p: Point, c: Point) -> Point {
    match own_piece(geometry, shore, p) {
        None => c,
        Some(poly) => {
            if poly.contains(&Coord { x: c.x, y: c.y }) {
                c
            } else {
                nearest_on_boundary(&poly, c).0
            }
        }
    }
}

/// The nearest point of a polygon's rings to `q`, and its distance.
fn nearest_on_boundary(poly: &geo::Polygon<f64>, q: Point) -> (Point, f64) {
    let mut best = (q, f64::INFINITY);
    for ring in std::iter::once(poly.exterior()).chain(poly.interiors()) {
        for line in ring.lines() {
            let x = segment_closest(q, line.start, line.end);
            let d = norm2(x - q).sqrt();
            if d < best.1 {
                best = (x, d);
            }
        }
    }
    best
}

/// `g` moved to at least `clearance` from the shore (see the module doc).
fn off_the_shore(shore: &Shore, g: Point, clearance: f64) -> Point {
    let mut x = g;
    for _ in 0..PUSHES {
        let near = shore.nearest(x);
        let inside = shore.region().contains(x);
        if inside && near.distance >= clearance {
            return x;
        }
        let away = if near.distance > 1e-9 * (1.0 + clearance) {
            let d = (x - near.point) / near.distance;
            if inside { d } else { -d }
        } else {
            near.inward
        };
        x = near.point + away * clearance;
    }
    if shore.region().contains(x) {
        x
    } else {
        shore.region().closest_point(g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::{Fleet, Options, RiskField, Vessel, evaluate};
    use crate::geometry::Region;

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    fn vessel(x: f64, y: f64) -> Vessel {
        Vessel {
            position: p(x, y),
            k: 0.5,
            beta: 0.001,
        }
    }

    #[test]
    fn a_centroid_on_an_island_moves_to_the_shore_off_it() {
        // One vessel south of a square island, and a risk object on the
        // island that pulls the centroid onto it.
        let region = crate::geometry::region::fixtures::square(true);
        let shore = Shore::new(&region);
        // A weak decay, so that the vessel barely pulls the centroid south.
        let fleet = Fleet::new(vec![Vessel {
            beta: 1e-5,
            ..vessel(50.0, 20.0)
        }])
        .unwrap();
        let risk = RiskField::new(
            0.01,
            vec![crate::coverage::RiskObject {
                center: p(50.0, 50.0),
                alpha: 10.0,
                sigma: 15.0,
            }],
        )
        .unwrap();
        let eval = evaluate(&region, &risk, &fleet, &Options::default());
        let cell = &eval.cells[0];
        assert!(!region.contains(cell.centroid), "{:?}", cell.centroid);
        let g = reachable_goal(&shore, cell, p(50.0, 20.0), 5.0);
        // The centroid is on the symmetry line x = 50, pulled south of the
        // island's centre by the vessel: nearest free point 5 m off the
        // island's south side.
        assert!(
            (g.y - 35.0).abs() < 1e-6 && (g.x - 50.0).abs() < 1e-6,
            "{g:?}"
        );
        assert!((shore.signed_clearance(g) - 5.0).abs() < 1e-9);
    }

    #[test]
    fn a_centroid_across_a_pier_stays_on_the_vessels_side() {
        // A pier from the south shore, 60–64 m east, 80 m long.
        let region = Region::new(
            vec![
                p(0.0, 0.0),
                p(60.0, 0.0),
                p(60.0, 80.0),
                p(64.0, 80.0),
                p(64.0, 0.0),
                p(100.0, 0.0),
                p(100.0, 100.0),
                p(0.0, 100.0),
            ],
            vec![],
        )
        .unwrap();
        let shore = Shore::new(&region);
        // The second vessel's cell takes the north, so the pier cuts the
        // first one's cell into a west and an east piece; a risk object pulls
        // the centroid into the west one.
        let fleet = Fleet::new(vec![vessel(80.0, 20.0), vessel(20.0, 95.0)]).unwrap();
        let risk = RiskField::new(
            0.1,
            vec![crate::coverage::RiskObject {
                center: p(30.0, 20.0),
                alpha: 50.0,
                sigma: 10.0,
            }],
        )
        .unwrap();
        let eval = evaluate(&region, &risk, &fleet, &Options::default());
        assert!(
            eval.cells[0].centroid.x < 60.0,
            "{:?}",
            eval.cells[0].centroid
        );
        let cell = &eval.cells[0];
        let g = reachable_goal(&shore, cell, p(80.0, 20.0), 3.0);
        assert!(
            g.x >= 64.0 + 3.0 - 1e-9,
            "goal {g:?} for centroid {:?}",
            cell.centroid
        );
        assert!(shore.signed_clearance(g) >= 3.0 - 1e-9);
    }

    #[test]
    fn a_reachable_centroid_is_kept_exactly() {
        let region = crate::geometry::region::fixtures::square(false);
        let shore = Shore::new(&region);
        let fleet = Fleet::new(vec![vessel(30.0, 30.0), vessel(70.0, 60.0)]).unwrap();
        let eval = evaluate(
            &region,
            &RiskField::new(0.1, vec![]).unwrap(),
            &fleet,
            &Options::default(),
        );
        for (cell, v) in eval.cells.iter().zip(fleet.vessels()) {
            assert_eq!(reachable_goal(&shore, cell, v.position, 5.0), cell.centroid);
        }
    }
}
