//! The generalized Voronoi partition V_i = { q ∈ Q : f_i(q) ≥ f_j(q) ∀ j }
//! (paper eq. 6) as power cells clipped to the region.
//!
//! With one β, f_i ≥ f_j ⟺ ‖q − p_i‖² − ln k_i / β ≤ ‖q − p_j‖² − ln k_j / β, a
//! power diagram. In coordinates x = q − p_i and with d = p_j − p_i the
//! condition is the half-plane
//!
//! ```text
//! d · x ≤ ‖d‖² / 2 − (ln k_j − ln k_i) / (2β)
//! ```
//!
//! Each cell starts as Q's bounding box and is clipped by the half-planes of
//! the other vessels in order of distance (nearest-neighbour iteration in an
//! R-tree). A vessel j at distance ‖d‖ can only cut a cell whose farthest
//! vertex is at R if its line lies closer than R, i.e. if
//! ‖d‖/2 − (ln k_j − ln k_i)/(2β‖d‖) < R. With W_i = (ln k_max − ln k_i)/(2β)
//! no vessel with ‖d‖ ≥ R + √(R² + 2 W_i) can, and neither can any farther
//! one, so the iteration stops there (the "security radius" of meshless
//! Voronoi methods, extended to power weights). For well-spread fleets a cell
//! looks at O(1) neighbours, and the whole partition costs O(n log n).
//!
//! The convex cell is then intersected with Q: by half-planes when Q is
//! convex; otherwise it is kept whole when no boundary segment of Q meets it
//! and its interior point is in Q, dropped when none meets it and the point is
//! outside; the remaining boundary cells clip every ring of Q (shell and
//! holes) to the convex cell, which is exact for non-convex shells and holes
//! alike (`geo`'s own Voronoi clipping is not used because it lets cells
//! overlap holes, and its boolean operations snap to an integer grid).
//!
//! Ties: vessels at the same position with the same k would own the same
//! cell; the first in input order keeps it and the others get an empty cell.

use geo::{Area, BooleanOps, LineString, MultiPolygon, Polygon};
use rstar::RTree;
use rstar::primitives::GeomWithData;

use super::fleet::{Fleet, Vessel};
use crate::geometry::arcs::Piece;
use crate::geometry::bridges::without_bridges;
#[cfg(test)]
use crate::geometry::cross;
use crate::geometry::{
    ConvexPolygon, Point, Region, bounds, even_odd_contains, norm2, outline, ring_signed_area,
};

/// The region a vessel is responsible for.
#[derive(Debug, Clone, PartialEq)]
pub enum CellGeometry {
    /// Outside Q, or dominated by other vessels.
    Empty,
    /// A convex cell inside Q, in world coordinates.
    Convex(ConvexPolygon),
    /// A cell cut by Q's boundary: `hull` is the convex power cell and `rings`
    /// the exact intersection Q ∩ hull as an oriented chain — the shell's part
    /// counter-clockwise, holes' parts clockwise, possibly with zero-width
    /// bridges between pieces (see [`ConvexPolygon::clip_ring`]). Areas and
    /// integrals over the chain are exact; [`CellGeometry::pieces`] gives clean
    /// polygons for display.
    Clipped {
        /// The convex power cell, before Q clips it.
        hull: ConvexPolygon,
        /// Q ∩ `hull` as an oriented chain, in world coordinates.
        rings: Vec<Vec<Point>>,
    },
    /// A cell of a fleet with different reaches β ([`mixed`](super::mixed)):
    /// its oriented boundary of segments and arcs, in world coordinates,
    /// not assembled into rings (holes and several pieces included).
    Curved {
        /// The boundary's pieces, the cell on the left of each.
        pieces: Vec<Piece>,
    },
}

impl CellGeometry {
    /// Whether the cell is [`CellGeometry::Empty`].
    pub fn is_empty(&self) -> bool {
        matches!(self, CellGeometry::Empty)
    }

    /// Whether `p` is in the cell (even–odd over the chain; on the boundary
    /// either answer may come back).
    pub fn contains(&self, p: Point) -> bool {
        match self {
            CellGeometry::Empty => false,
            CellGeometry::Convex(c) => c.contains(p),
            CellGeometry::Clipped { rings, .. } => even_odd_contains(rings, p),
            CellGeometry::Curved { pieces } => outline::contains(pieces, p),
        }
    }

    /// Area of the cell.
    pub fn area(&self) -> f64 {
        match self {
            CellGeometry::Empty => 0.0,
            CellGeometry::Convex(c) => c.area(),
            CellGeometry::Clipped { rings, .. } => rings
                .iter()
                .map(|r| ring_signed_area(r))
                .sum::<f64>()
                .max(0.0),
            CellGeometry::Curved { pieces } => {
                let origin = pieces
                    .first()
                    .map_or(Point { x: 0.0, y: 0.0 }, |p| match *p {
                        Piece::Segment { from, .. } => from,
                        Piece::Arc { centre, .. } => centre,
                    });
                pieces
                    .iter()
                    .map(|p| p.area_share(origin))
                    .sum::<f64>()
                    .max(0.0)
            }
        }
    }

    /// The cell as clean polygons (each piece with its holes), computed with
    /// `geo`'s boolean operations. For display and triangulation only: those
    /// snap to an integer grid, so their areas are exact to ~1e-9 relative,
    /// while [`area`](Self::area) is exact. A curved cell's arcs become
    /// chords within [`ARC_TOLERANCE`] of them.
    pub fn pieces(&self, region: &Region) -> MultiPolygon<f64> {
        let ring = |vs: &[Point]| {
            let mut r = vs.to_vec();
            r.push(vs[0]);
            LineString::from(r)
        };
        match self {
            CellGeometry::Empty => MultiPolygon(Vec::new()),
            CellGeometry::Convex(c) => MultiPolygon(vec![Polygon::new(ring(&c.vertices), vec![])]),
            CellGeometry::Clipped { hull, .. } => MultiPolygon(
                Polygon::new(ring(&hull.vertices), vec![])
                    .intersection(region.polygon())
                    .into_iter()
                    .filter(|piece| piece.unsigned_area() > 0.0)
                    .collect(),
            ),
            CellGeometry::Curved { pieces } => {
                outline::polygons(&outline::rings(pieces, ARC_TOLERANCE))
            }
        }
    }
}

/// How far a curved cell's outline ([`CellGeometry::pieces`]) may be from
/// its arcs, in metres.
pub const ARC_TOLERANCE: f64 = 0.1;

/// Computes every vessel's cell, in the fleet's order.
pub fn power_cells(region: &Region, fleet: &Fleet) -> Vec<CellGeometry> {
    power_cells_with(region, fleet, false)
}

/// [`power_cells`], on every core when `parallel` and the fleet is large
/// enough to pay for it. The fleet must have one β
/// ([`cells_with`](super::cells::cells_with) takes any). Each cell depends only on the fleet, never on
/// another cell, so the result is the same either way, bit for bit.
pub fn power_cells_with(region: &Region, fleet: &Fleet, parallel: bool) -> Vec<CellGeometry> {
    let vessels = fleet.vessels();
    let tree = tree_of(vessels);
    let setup = Setup::new(region, fleet);
    // A first radius that holds every neighbour a typical cell needs (its
    // farthest vertex is ~0.6 mean spacings away, so neighbours beyond ~1.2
    // spacings cannot cut it); the best-first iterator, which costs a heap
    // operation per neighbour, is only needed when that is not enough.
    let (lo, hi) = (setup.lo, setup.hi);
    let spacing = ((hi.x - lo.x) * (hi.y - lo.y) / vessels.len() as f64).sqrt();
    let first_radius = 2.5 * spacing;
    let cell_of = |i: usize, near: &mut Vec<(f64, usize)>| -> CellGeometry {
        let mut clipper = setup.clipper(i);
        cut_by_neighbours(&tree, vessels, i, first_radius, near, &mut clipper);
        clipper.finish(region)
    };
    super::map_indexed(
        vessels.len(),
        parallel && vessels.len() >= super::PARALLEL_MIN,
        cell_of,
    )
}

/// The vessels by position, their index as data.
pub(super) type Tree = RTree<GeomWithData<[f64; 2], usize>>;

pub(super) fn tree_of(vessels: &[Vessel]) -> Tree {
    RTree::bulk_load(
        vessels
            .iter()
            .enumerate()
            .map(|(i, v)| GeomWithData::new([v.position.x, v.position.y], i))
            .collect(),
    )
}

/// A cell being cut by the other vessels, nearest first.
pub(super) trait Cutting {
    /// Whether no vessel at distance ≥ `dist` can cut the cell any more.
    fn settled(&self, dist: f64) -> bool;
    /// Cuts by vessel `j`; false once the cell is empty.
    fn cut(&mut self, j: usize) -> bool;
}

/// Cuts vessel `i`'s `cell` by the others, nearest first (ties by index),
/// until it is settled or empty: those within `first_radius` from one
/// range query, sorted in `near` (scratch), and beyond it, only when the
/// cell is not settled there, the best-first iterator, which costs a heap
/// operation per neighbour.
pub(super) fn cut_by_neighbours(
    tree: &Tree,
    vessels: &[Vessel],
    i: usize,
    first_radius: f64,
    near: &mut Vec<(f64, usize)>,
    cell: &mut impl Cutting,
) {
    let p = vessels[i].position;
    near.clear();
    near.extend(
        tree.locate_within_distance([p.x, p.y], first_radius * first_radius)
            .filter(|nb| nb.data != i)
            .map(|nb| (norm2(vessels[nb.data].position - p), nb.data)),
    );
    near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    for &(d2, j) in near.iter() {
        if cell.settled(d2.sqrt()) {
            return;
        }
        if !cell.cut(j) {
            return;
        }
    }
    if cell.settled(first_radius) {
        return;
    }
    for (nb, d2) in tree.nearest_neighbor_iter_with_distance_2(&[p.x, p.y]) {
        let j = nb.data;
        if j == i || d2 <= first_radius * first_radius {
            continue; // itself, or already applied
        }
        if cell.settled(d2.sqrt()) || !cell.cut(j) {
            return;
        }
    }
}

/// Vessel `i`'s cell alone: the same cell as `power_cells(region,
/// fleet)[i]`, clipped by the same vessels in the same order (nearest
/// first, ties by index) up to the same security radius, without the
/// others' cells or a spatial index. For one vessel of a peer fleet,
/// which needs only its own cell among the ~140 vessels within its reach
/// (`coverage::range`): one sort of the given vessels by distance.
pub fn power_cell(region: &Region, fleet: &Fleet, i: usize) -> CellGeometry {
    let vessels = fleet.vessels();
    let setup = Setup::new(region, fleet);
    let p = vessels[i].position;
    let mut order: Vec<(f64, usize)> = vessels
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != i)
        .map(|(j, v)| (norm2(v.position - p), j))
        .collect();
    order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut clipper = setup.clipper(i);
    for (d2, j) in order {
        if clipper.settled(d2.sqrt()) || !clipper.cut(j) {
            break;
        }
    }
    clipper.finish(region)
}

/// What every cell of one partition shares: the vessels, their ln k, β,
/// and the starting box (Q's bounding box with a margin, so that Q's
/// boundary never coincides with it).
struct Setup<'a> {
    vessels: &'a [Vessel],
    ln_k: Vec<f64>,
    ln_k_max: f64,
    beta: f64,
    lo: Point,
    hi: Point,
}

impl<'a> Setup<'a> {
    fn new(region: &Region, fleet: &'a Fleet) -> Setup<'a> {
        let vessels = fleet.vessels();
        let ln_k: Vec<f64> = vessels.iter().map(|v| v.k.ln()).collect();
        let ln_k_max = ln_k.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (rmin, rmax) = region.bounds();
        let margin = 1e-3 * (rmax.x - rmin.x).max(rmax.y - rmin.y) + 1.0;
        Setup {
            vessels,
            ln_k,
            ln_k_max,
            beta: fleet
                .common_beta()
                .expect("the power diagram is for a fleet of one beta"),
            lo: Point {
                x: rmin.x - margin,
                y: rmin.y - margin,
            },
            hi: Point {
                x: rmax.x + margin,
                y: rmax.y + margin,
            },
        }
    }

    /// Vessel `i`'s cell before any clipping, in coordinates centred on it.
    fn clipper(&self, i: usize) -> Clipper<'_, 'a> {
        let p = self.vessels[i].position;
        Clipper {
            setup: self,
            i,
            p,
            w_i: (self.ln_k_max - self.ln_k[i]) / (2.0 * self.beta),
            cell: ConvexPolygon::rectangle(self.lo - p, self.hi - p),
        }
    }
}

/// One cell being clipped (coordinates centred on its vessel).
struct Clipper<'s, 'a> {
    setup: &'s Setup<'a>,
    i: usize,
    p: Point,
    /// W_i of the module doc.
    w_i: f64,
    cell: ConvexPolygon,
}

impl Cutting for Clipper<'_, '_> {
    /// Clips by vessel j; false once the cell is empty.
    fn cut(&mut self, j: usize) -> bool {
        let s = self.setup;
        let (i, ln_k) = (self.i, &s.ln_k);
        let d = s.vessels[j].position - self.p;
        let d2 = norm2(d);
        if d2 == 0.0 {
            if ln_k[j] > ln_k[i] || (ln_k[j] == ln_k[i] && j < i) {
                self.cell.vertices.clear();
            }
        } else {
            self.cell
                .clip(d, 0.5 * d2 - (ln_k[j] - ln_k[i]) / (2.0 * s.beta));
        }
        !self.cell.is_empty()
    }

    /// Whether no vessel at distance ≥ `dist` can cut the cell any more.
    fn settled(&self, dist: f64) -> bool {
        let r2 = self.cell.max_distance2(Point { x: 0.0, y: 0.0 });
        dist >= r2.sqrt() + (r2 + 2.0 * self.w_i).sqrt()
    }
}

impl Clipper<'_, '_> {
    /// The cell in world coordinates, intersected with Q.
    fn finish(mut self, region: &Region) -> CellGeometry {
        if self.cell.is_empty() {
            return CellGeometry::Empty;
        }
        self.cell.translate(self.p);
        clip_to_region(self.cell, region)
    }
}

/// Intersects a convex cell (world coordinates) with Q.
fn clip_to_region(mut cell: ConvexPolygon, region: &Region) -> CellGeometry {
    if region.is_convex() {
        let shell = region.shell();
        let n = shell.len();
        for k in 0..n {
            let (a, b) = (shell[k], shell[(k + 1) % n]);
            let e = b - a;
            // Inside is to the left of a→b: cross(e, x − a) ≥ 0.
            let normal = Point { x: e.y, y: -e.x };
            cell.clip(normal, normal.x * a.x + normal.y * a.y);
            if cell.is_empty() {
                return CellGeometry::Empty;
            }
        }
        return CellGeometry::Convex(cell);
    }
    let (min, max) = cell.bounds();
    let touches = region
        .segments_in(min, max)
        .any(|(a, b)| cell.intersects_segment(a, b));
    if !touches {
        return if region.contains(cell.interior_point()) {
            CellGeometry::Convex(cell)
        } else {
            CellGeometry::Empty
        };
    }
    let (lo, hi) = (min, max);
    let overlaps = |ring: &[Point]| {
        let (a, b) = bounds(ring);
        a.x <= hi.x && b.x >= lo.x && a.y <= hi.y && b.y >= lo.y
    };
    let rings: Vec<Vec<Point>> = std::iter::once(region.shell())
        .chain(region.holes().iter().map(Vec::as_slice))
        .filter(|r| overlaps(r))
        .map(|r| cell.clip_ring(r))
        .filter(|r| r.len() >= 3 && ring_signed_area(r) != 0.0)
        .collect();
    let rings = without_bridges(&rings, &cell.edge_lines());
    let area: f64 = rings.iter().map(|r| ring_signed_area(r)).sum();
    if area <= 0.0 {
        CellGeometry::Empty
    } else {
        CellGeometry::Clipped { hull: cell, rings }
    }
}

/// Whether a convex polygon is counter-clockwise and convex (for tests).
#[cfg(test)]
pub(crate) fn is_ccw_convex(c: &ConvexPolygon) -> bool {
    let n = c.vertices.len();
    (0..n).all(|i| {
        let (a, b, d) = (
            c.vertices[i],
            c.vertices[(i + 1) % n],
            c.vertices[(i + 2) % n],
        );
        cross(b - a, d - b) >= -1e-9 * norm2(b - a).max(norm2(d - b))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::fleet::Vessel;

    fn v(x: f64, y: f64) -> Vessel {
        Vessel {
            position: Point { x, y },
            k: 0.5,
            beta: 0.001,
        }
    }

    fn square(s: f64) -> Region {
        Region::new(
            vec![
                Point { x: 0.0, y: 0.0 },
                Point { x: s, y: 0.0 },
                Point { x: s, y: s },
                Point { x: 0.0, y: s },
            ],
            vec![],
        )
        .unwrap()
    }

    #[test]
    fn one_cell_alone_is_that_cell_of_the_partition_bit_for_bit() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let region = square(300.0);
        let vessels: Vec<Vessel> = (0..150)
            .map(|i| Vessel {
                position: Point {
                    x: rng.random_range(-20.0..320.0),
                    y: rng.random_range(-20.0..320.0),
                },
                // Two gains: power weights, not only bisectors.
                k: if i % 3 == 0 { 0.8 } else { 0.5 },
                beta: 0.001,
            })
            .collect();
        let fleet = Fleet::new(vessels).unwrap();
        let all = power_cells(&region, &fleet);
        for (i, cell) in all.iter().enumerate() {
            assert_eq!(&power_cell(&region, &fleet, i), cell, "vessel {i}");
        }
    }

    #[test]
    fn two_vessels_split_a_square_in_half() {
        let fleet = Fleet::new(vec![v(25.0, 50.0), v(75.0, 50.0)]).unwrap();
        let cells = power_cells(&square(100.0), &fleet);
        for c in &cells {
            assert!((c.area() - 5000.0).abs() < 1e-9);
            if let CellGeometry::Convex(p) = c {
                assert!(is_ccw_convex(p));
            } else {
                panic!("expected convex cells");
            }
        }
    }

    #[test]
    fn stronger_actuator_gets_the_bigger_cell() {
        let mut strong = v(25.0, 50.0);
        strong.k = 1.0;
        let fleet = Fleet::new(vec![strong, v(75.0, 50.0)]).unwrap();
        let cells = power_cells(&square(100.0), &fleet);
        // Boundary x with d·x = |d|²/2 − ln(k_j/k_i)/(2β), measured from p_0.
        let shift = (0.5f64 / 1.0).ln() / (2.0 * 0.001) / 50.0;
        let x_edge = 25.0 + 25.0 - shift;
        assert!((cells[0].area() - 100.0 * x_edge).abs() < 1e-8);
    }

    #[test]
    fn coincident_vessels_first_wins() {
        let fleet = Fleet::new(vec![v(30.0, 30.0), v(30.0, 30.0), v(70.0, 70.0)]).unwrap();
        let cells = power_cells(&square(100.0), &fleet);
        assert!(!cells[0].is_empty());
        assert!(cells[1].is_empty());
        assert!((cells[0].area() + cells[2].area() - 1e4).abs() < 1e-8);
    }

    #[test]
    fn vessel_far_outside_gets_nothing() {
        let fleet = Fleet::new(vec![v(50.0, 50.0), v(500.0, 50.0)]).unwrap();
        let cells = power_cells(&square(100.0), &fleet);
        assert!(cells[1].is_empty());
        assert!((cells[0].area() - 1e4).abs() < 1e-8);
    }

    #[test]
    fn hole_is_cut_out() {
        let region = Region::new(
            square(100.0).shell().to_vec(),
            vec![vec![
                Point { x: 40.0, y: 40.0 },
                Point { x: 60.0, y: 40.0 },
                Point { x: 60.0, y: 60.0 },
                Point { x: 40.0, y: 60.0 },
            ]],
        )
        .unwrap();
        let fleet = Fleet::new(vec![v(50.0, 20.0), v(50.0, 80.0)]).unwrap();
        let cells = power_cells(&region, &fleet);
        let total: f64 = cells.iter().map(CellGeometry::area).sum();
        assert!((total - region.area()).abs() < 1e-9 * region.area());
        assert!((cells[0].area() - (5000.0 - 200.0)).abs() < 1e-8);
    }
}
