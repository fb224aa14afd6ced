//! The generalized Voronoi partition of a fleet with different reaches β
//! (paper eq. 6 in general): each cell is the region intersected with
//! the bounds the other vessels impose ([`dominance`]: half-planes between
//! equal β, discs and disc complements otherwise), as the oriented
//! boundary of segments and arcs of [`geometry::arcs`].
//!
//! Which vessels can matter. A vessel j at distance D from p_i can only
//! cut the part of i's cell within R of p_i if somewhere there f_j ≥ f_i:
//! there ln f_i ≥ ln k_i − β_i R² and, for D > R, ln f_j ≤ ln k_j − β_j
//! (D − R)². So no vessel with
//!
//! ```text
//! D > R + √(max(0, ln k_max − ln k_i + β_i R²) / β_min)
//! ```
//!
//! can, and neither can any farther one: the neighbours are taken nearest
//! first and the scan stops there. (With one β this is the power
//! diagram's security radius of [`partition`](super::partition).) R is an
//! upper bound of the cell's distance from p_i, kept as the cell is cut:
//! the farthest vertex of Q's bounding box clipped by the half-planes met
//! so far, or the far side of a disc the cell must lie in, whichever is
//! nearer. A vessel of wide reach among concentrated ones owns the water
//! between their discs and looks at every one of them: its cost is the
//! number of vessels within its reach, not O(1).
//!
//! A disc bound also clips the hull by the disc's bounding square. Bounds
//! that cannot touch the final hull (a half-plane or disc holding all its
//! vertices, a disc complement whose disc misses it) are dropped before
//! the boundary is built, whose cost is quadratic in the bounds.
//!
//! Ties: two vessels at the same place with the same k and β own the same
//! cell; as in the power diagram the first in input order keeps it.
//!
//! [`dominance`]: super::dominance
//! [`geometry::arcs`]: crate::geometry::arcs

use super::dominance::{Dominance, dominance};
use super::fleet::{Fleet, Vessel};
use super::partition::{CellGeometry, Cutting, cut_by_neighbours, tree_of};
use crate::geometry::arcs::{Bound, Piece, boundary};
use crate::geometry::{ConvexPolygon, Point, Region, dot, norm2, segment_distance2};

/// What every cell of one partition shares.
struct Setup<'a> {
    vessels: &'a [Vessel],
    ln_k_max: f64,
    beta_min: f64,
    lo: Point,
    hi: Point,
}

impl<'a> Setup<'a> {
    fn new(region: &Region, fleet: &'a Fleet) -> Setup<'a> {
        let vessels = fleet.vessels();
        let ln_k_max = vessels
            .iter()
            .map(|v| v.k.ln())
            .fold(f64::NEG_INFINITY, f64::max);
        let beta_min = vessels.iter().map(|v| v.beta).fold(f64::INFINITY, f64::min);
        let (rmin, rmax) = region.bounds();
        let margin = 1e-3 * (rmax.x - rmin.x).max(rmax.y - rmin.y) + 1.0;
        Setup {
            vessels,
            ln_k_max,
            beta_min,
            lo: rmin
                - Point {
                    x: margin,
                    y: margin,
                },
            hi: rmax
                + Point {
                    x: margin,
                    y: margin,
                },
        }
    }
}

/// One cell being cut.
struct Cell<'s, 'a> {
    setup: &'s Setup<'a>,
    i: usize,
    /// Q's bounding box cut by the half-planes so far, about p_i.
    hull: ConvexPolygon,
    /// The far side of the nearest disc the cell must lie in.
    disc_reach: f64,
    /// Each bound with the vessel it comes from.
    bounds: Vec<(usize, Bound)>,
    empty: bool,
    /// The hull's next vertices, reused from clip to clip.
    scratch: Vec<Point>,
}

impl<'s, 'a> Cell<'s, 'a> {
    fn new(setup: &'s Setup<'a>, i: usize) -> Self {
        let p = setup.vessels[i].position;
        Cell {
            setup,
            i,
            hull: ConvexPolygon::rectangle(setup.lo - p, setup.hi - p),
            disc_reach: f64::INFINITY,
            bounds: Vec::new(),
            empty: false,
            scratch: Vec::new(),
        }
    }

    /// R of the module doc.
    fn reach(&self) -> f64 {
        self.hull
            .max_distance2(Point { x: 0.0, y: 0.0 })
            .sqrt()
            .min(self.disc_reach)
    }

    /// The cell: the bounds that can touch it, then its boundary in Q.
    fn finish(self, region: &Region) -> CellGeometry {
        if self.empty {
            return CellGeometry::Empty;
        }
        let p = self.setup.vessels[self.i].position;
        let r = self.reach();
        let mut bounds = self.bounds;
        // In vessel order, so that a cell is the same however its
        // neighbours were found (ties in distance included).
        bounds.sort_by_key(|&(j, _)| j);
        // Against the hull (about p), which holds the cell: a bound that
        // holds at every vertex with room to spare holds on it (half-plane,
        // disc: convex), and so does a disc complement whose disc misses it.
        let hull = &self.hull.vertices;
        let bounds: Vec<Bound> = bounds
            .into_iter()
            .map(|(_, b)| b)
            .filter(|b| match *b {
                Bound::HalfPlane { normal, offset } => {
                    // Kept when it reaches the hull, edges on its line
                    // included (the hull was clipped by it).
                    let o = offset - dot(normal, p);
                    let slack = 1e-9 * norm2(normal).sqrt() * (r + 1.0);
                    hull.iter().any(|v| dot(normal, *v) > o - slack)
                }
                Bound::Disc { centre, radius } => {
                    let c = centre - p;
                    hull.iter().any(|v| norm2(*v - c) > radius * radius)
                }
                Bound::Outside { centre, radius } => {
                    let c = centre - p;
                    norm2(c).sqrt() < r + radius
                        && (self.hull.contains(c)
                            || (0..hull.len()).any(|k| {
                                segment_distance2(c, hull[k], hull[(k + 1) % hull.len()])
                                    < radius * radius
                            }))
                }
            })
            .collect();
        from_pieces(boundary(region, &bounds))
    }
}

impl Cutting for Cell<'_, '_> {
    /// Whether no vessel at distance ≥ `dist` can cut the cell any more.
    fn settled(&self, dist: f64) -> bool {
        let own = &self.setup.vessels[self.i];
        let r = self.reach();
        let lead = (self.setup.ln_k_max - own.k.ln() + own.beta * r * r).max(0.0);
        dist > r + (lead / self.setup.beta_min).sqrt()
    }

    /// Cuts by vessel j; false once the cell is empty.
    fn cut(&mut self, j: usize) -> bool {
        let vessels = self.setup.vessels;
        let (own, other) = (&vessels[self.i], &vessels[j]);
        match dominance(own, other) {
            Dominance::Everywhere
                if other.position == own.position
                    && dominance(other, own) == Dominance::Everywhere =>
            {
                // The same actuator: the first in input order keeps the cell.
                self.empty = j < self.i;
            }
            Dominance::Everywhere => {}
            Dominance::Nowhere => self.empty = true,
            Dominance::Within(bound) => {
                let p = own.position;
                match bound {
                    Bound::HalfPlane { normal, offset } => {
                        self.hull
                            .clip_with(normal, offset - dot(normal, p), &mut self.scratch);
                        self.empty = self.hull.is_empty();
                    }
                    Bound::Disc { centre, radius } => {
                        self.disc_reach = self.disc_reach.min(norm2(centre - p).sqrt() + radius);
                        // The cell lies in the disc's bounding square too,
                        // which keeps the hull (and R) tight.
                        let c = centre - p;
                        for (normal, offset) in [
                            (Point { x: 1.0, y: 0.0 }, c.x + radius),
                            (Point { x: -1.0, y: 0.0 }, radius - c.x),
                            (Point { x: 0.0, y: 1.0 }, c.y + radius),
                            (Point { x: 0.0, y: -1.0 }, radius - c.y),
                        ] {
                            self.hull.clip_with(normal, offset, &mut self.scratch);
                        }
                        self.empty = self.hull.is_empty();
                    }
                    Bound::Outside { .. } => {}
                }
                self.bounds.push((j, bound));
            }
        }
        !self.empty
    }
}

/// A cell from its boundary: empty when nothing of it encloses area.
pub(super) fn from_pieces(pieces: Vec<Piece>) -> CellGeometry {
    let area: f64 = match pieces.first() {
        None => return CellGeometry::Empty,
        Some(first) => {
            // About a point of the boundary, so far-off coordinates do not
            // cancel.
            let origin = match *first {
                Piece::Segment { from, .. } => from,
                Piece::Arc { centre, .. } => centre,
            };
            pieces.iter().map(|p| p.area_share(origin)).sum()
        }
    };
    if area > 0.0 {
        CellGeometry::Curved { pieces }
    } else {
        CellGeometry::Empty
    }
}

/// Every vessel's cell, in the fleet's order, for a fleet of any β (on
/// every core when `parallel`; the same result either way).
pub fn mixed_cells(region: &Region, fleet: &Fleet, parallel: bool) -> Vec<CellGeometry> {
    let vessels = fleet.vessels();
    let tree = tree_of(vessels);
    let setup = Setup::new(region, fleet);
    // Neighbours as the power diagram takes them (`cut_by_neighbours`,
    // nearest first, ties by index, as `mixed_cell` takes them).
    // Different reaches look farther than one β's security radius (a
    // mixed cell of fleet-1000 takes ~19 neighbours): a first radius of
    // 3.5 mean spacings holds ~38 and settles most cells.
    let (lo, hi) = (setup.lo, setup.hi);
    let spacing = ((hi.x - lo.x) * (hi.y - lo.y) / vessels.len() as f64).sqrt();
    let first_radius = 3.5 * spacing;
    let cell_of = |i: usize, near: &mut Vec<(f64, usize)>| -> CellGeometry {
        let mut cell = Cell::new(&setup, i);
        cut_by_neighbours(&tree, vessels, i, first_radius, near, &mut cell);
        cell.finish(region)
    };
    super::map_indexed(
        vessels.len(),
        parallel && vessels.len() >= super::PARALLEL_MIN,
        cell_of,
    )
}

/// Vessel `i`'s cell alone, the same as `mixed_cells(region, fleet)[i]`.
pub fn mixed_cell(region: &Region, fleet: &Fleet, i: usize) -> CellGeometry {
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
    let mut cell = Cell::new(&setup, i);
    for (d2, j) in order {
        if cell.settled(d2.sqrt()) || !cell.cut(j) {
            break;
        }
    }
    cell.finish(region)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::dominance::cell_bounds;
    use crate::coverage::partition::power_cells;
    use crate::geometry::region::fixtures::square;
    use rand::{RngExt, SeedableRng};

    fn fleet(rng: &mut rand_chacha::ChaCha8Rng, n: usize, betas: &[f64]) -> Fleet {
        Fleet::new(
            (0..n)
                .map(|_| Vessel {
                    position: Point {
                        x: rng.random_range(-10.0..110.0),
                        y: rng.random_range(-10.0..110.0),
                    },
                    k: rng.random_range(0.3..1.5),
                    beta: betas[rng.random_range(0..betas.len())],
                })
                .collect(),
        )
        .unwrap()
    }

    /// The pruned cells against cells cut by every other vessel, and one
    /// cell alone against the partition: the same areas; the cells tile Q.
    #[test]
    fn pruned_cells_are_the_cells_of_every_bound_and_tile_the_region() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut curved = 0;
        for n in [2, 5, 20, 60] {
            for island in [false, true] {
                let region = square(island);
                let fleet = fleet(&mut rng, n, &[0.001, 0.003, 0.01]);
                let cells = mixed_cells(&region, &fleet, false);
                let mut total = 0.0;
                for (i, c) in cells.iter().enumerate() {
                    let v = fleet.vessels();
                    let others = v
                        .iter()
                        .enumerate()
                        .filter(|&(j, _)| j != i)
                        .map(|(_, o)| o);
                    let full = match cell_bounds(&v[i], others) {
                        None => 0.0,
                        Some(b) => from_pieces(boundary(&region, &b)).area(),
                    };
                    assert!(
                        (c.area() - full).abs() <= 1e-9 * region.area(),
                        "n {n} vessel {i}: {} vs {full}",
                        c.area()
                    );
                    assert_eq!(&mixed_cell(&region, &fleet, i), c, "vessel {i} alone");
                    curved += matches!(c, CellGeometry::Curved { pieces } if pieces.iter().any(|p| matches!(p, Piece::Arc { .. })))
                        as usize;
                    total += c.area();
                }
                assert!(
                    (total - region.area()).abs() <= 1e-9 * region.area(),
                    "tiling {total}"
                );
            }
        }
        assert!(curved > 40, "{curved} cells with arcs");
    }

    /// With one β the curved cells are the power diagram's.
    #[test]
    fn with_one_beta_the_cells_are_the_power_cells() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
        let region = square(true);
        let fleet = fleet(&mut rng, 30, &[0.002]);
        let mixed = mixed_cells(&region, &fleet, false);
        let power = power_cells(&region, &fleet);
        for (i, (m, p)) in mixed.iter().zip(&power).enumerate() {
            assert!(
                (m.area() - p.area()).abs() <= 1e-9 * region.area(),
                "vessel {i}: {} vs {}",
                m.area(),
                p.area()
            );
        }
    }

    /// The concentrated vessel wins a disc, the wide one the rest: a hole.
    #[test]
    fn a_concentrated_vessel_makes_a_hole_in_a_wide_ones_cell() {
        let region = square(false);
        let wide = Vessel {
            position: Point { x: 20.0, y: 20.0 },
            k: 1.0,
            beta: 0.001,
        };
        let sharp = Vessel {
            position: Point { x: 60.0, y: 60.0 },
            k: 1.0,
            beta: 0.01,
        };
        let fleet = Fleet::new(vec![wide, sharp]).unwrap();
        let cells = mixed_cells(&region, &fleet, false);
        // d = 0.009, c = p_w + β_s P/d, ρ² = β_w β_s ‖P‖² / d².
        let p = sharp.position - wide.position;
        let c = wide.position + p * (0.01 / 0.009);
        let rho = (0.001 * 0.01 * norm2(p)).sqrt() / 0.009;
        let disc = std::f64::consts::PI * rho * rho;
        assert!(c.x + rho < 100.0 && c.y + rho < 100.0 && c.x - rho > 0.0);
        assert!((cells[1].area() - disc).abs() < 1e-9 * disc);
        assert!((cells[0].area() - (1e4 - disc)).abs() < 1e-9 * 1e4);
        assert!(cells[0].contains(Point { x: 5.0, y: 95.0 }));
        assert!(!cells[0].contains(c) && cells[1].contains(c));
        let outline = cells[0].pieces(&region);
        assert_eq!(outline.0.len(), 1);
        assert_eq!(outline.0[0].interiors().len(), 1);
    }
}
