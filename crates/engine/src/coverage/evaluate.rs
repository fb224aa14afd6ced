//! One full evaluation: partition, then mass, centroid, area and gradient of
//! every cell, and H(P) = Σ_i M_i (paper eq. 7–9).
//!
//! Definitions for the edge cases (all documented results, never NaN):
//! - empty cell (vessel outside Q with no share of it, or dominated by other
//!   vessels, including the later of two coincident vessels): mass 0, area 0,
//!   gradient 0, centroid = the point of Q nearest the vessel (the vessel's own
//!   position when it is inside Q), so guidance brings an outsider back;
//! - Φ ≡ 0 (φ0 = 0 and no objects): every mass is 0 and each centroid is the
//!   f_i-weighted centroid of the cell, the limit of φ0 → 0⁺;
//! - a cell far from its vessel keeps its centroid even when its mass
//!   underflows to 0 (see [`integrate`](super::integrate) on scaling).

use super::cells::cells_with;
use super::curved::{integrate_pieces, pieces_box};
use super::density::RiskField;
use super::fleet::Fleet;
use super::gaussian::Gaussian;
use super::integrate::{GridTerms, Tolerance, integrate_with_grid};
use super::partition::CellGeometry;
use crate::geometry::arcs::Piece;
use crate::geometry::{Point, Region, bounds};

/// Evaluation settings.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Options {
    /// Which integrator computes each cell's figures, and to what accuracy.
    pub tolerance: Tolerance,
    /// Spread the cells over every core (rayon's pool) when the fleet has
    /// at least [`PARALLEL_MIN`](super::PARALLEL_MIN) vessels. The result
    /// is identical: cells are independent and H is summed in fleet order.
    /// Off by default, so the benchmarks and the simulator measure one core.
    pub parallel: bool,
}

/// Figures of one vessel's cell.
#[derive(Debug, Clone, PartialEq)]
pub struct CellResult {
    /// M_i = ∫_{V_i} f_i Φ.
    pub mass: f64,
    /// C_i.
    pub centroid: Point,
    /// Area of V_i.
    pub area: f64,
    /// ∂H/∂p_i = 2 β M_i (C_i − p_i).
    pub gradient: Point,
    /// V_i itself.
    pub geometry: CellGeometry,
}

/// The whole evaluation, cells in the fleet's order.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// H(P) = Σ_i M_i.
    pub h: f64,
    /// Every vessel's cell and its figures, in the fleet's order.
    pub cells: Vec<CellResult>,
}

/// Evaluates the coverage of `fleet` over `region` under `risk`.
///
/// ```
/// use seacover_engine::coverage::fleet::{DEFAULT_BETA, DEFAULT_K};
/// use seacover_engine::coverage::{Fleet, Options, RiskField, RiskObject, Vessel, evaluate};
/// use seacover_engine::geometry::{Point, Region};
///
/// let p = |x, y| Point { x, y };
/// let square = vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)];
/// let region = Region::new(square, vec![])?;
/// let hot = RiskObject { center: p(80.0, 50.0), alpha: 5.0, sigma: 10.0 };
/// let risk = RiskField::new(0.1, vec![hot])?;
/// let vessel = |x, y| Vessel { position: p(x, y), k: DEFAULT_K, beta: DEFAULT_BETA };
/// let fleet = Fleet::new(vec![vessel(25.0, 50.0), vessel(75.0, 50.0)])?;
///
/// let e = evaluate(&region, &risk, &fleet, &Options::default());
/// // Two halves of the square; the one with the risk object weighs more.
/// assert!((e.cells[0].area - 5000.0).abs() < 1e-9);
/// assert!(e.cells[1].mass > e.cells[0].mass);
/// assert!(e.cells[0].centroid.x < 50.0 && e.cells[1].centroid.x > 50.0);
/// assert_eq!(e.h, e.cells[0].mass + e.cells[1].mass);
/// # Ok::<(), seacover_engine::coverage::InputError>(())
/// ```
pub fn evaluate(region: &Region, risk: &RiskField, fleet: &Fleet, options: &Options) -> Evaluation {
    let geometries = cells_with(region, fleet, options.parallel);
    let cells: Vec<CellResult> = super::map_each(
        geometries.into_iter().zip(fleet.vessels()).collect(),
        options.parallel && fleet.len() >= super::PARALLEL_MIN,
        |_, (geometry, vessel), near: &mut Vec<usize>| {
            cell_figures(region, risk, vessel, geometry, options, near)
        },
    );
    let h = cells.iter().map(|c| c.mass).sum();
    Evaluation { h, cells }
}

/// One vessel's figures, from its geometry in the partition of the whole
/// fleet ([`cells_with`]): [`evaluate`] is the partition and then this
/// for every vessel, so a caller may compute the cells one by one, in any
/// order and on any thread, with the same result. `near` is scratch space,
/// reused from cell to cell.
///
/// ```
/// use seacover_engine::coverage::cells::cell;
/// use seacover_engine::coverage::evaluate::cell_figures;
/// use seacover_engine::coverage::{Fleet, Options, RiskField, Vessel, evaluate};
/// use seacover_engine::geometry::{Point, Region};
///
/// let p = |x, y| Point { x, y };
/// let square = vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)];
/// let region = Region::new(square, vec![])?;
/// let risk = RiskField::new(1.0, vec![])?;
/// let vessel = |x, y| Vessel { position: p(x, y), k: 0.5, beta: 0.001 };
/// let fleet = Fleet::new(vec![vessel(25.0, 50.0), vessel(75.0, 50.0)])?;
///
/// // Vessel 1's cell alone: the right half of the square.
/// let (options, vessel) = (Options::default(), &fleet.vessels()[1]);
/// let geometry = cell(&region, &fleet, 1);
/// let one = cell_figures(&region, &risk, vessel, geometry, &options, &mut Vec::new());
/// assert!((one.area - 5000.0).abs() < 1e-9);
/// // Φ is flat and the vessel at the half's middle: so is the centroid.
/// assert!((one.centroid.x - 75.0).abs() < 1e-9 && (one.centroid.y - 50.0).abs() < 1e-9);
/// assert_eq!(one, evaluate(&region, &risk, &fleet, &options).cells[1]);
/// # Ok::<(), seacover_engine::coverage::InputError>(())
/// ```
pub fn cell_figures(
    region: &Region,
    risk: &RiskField,
    vessel: &super::Vessel,
    geometry: CellGeometry,
    options: &Options,
    near: &mut Vec<usize>,
) -> CellResult {
    let p = vessel.position;
    let beta = vessel.beta;
    let zero = Point { x: 0.0, y: 0.0 };
    let rings = local_rings(&geometry, p);
    let pieces = local_pieces(&geometry, p);
    if rings.is_empty() && pieces.is_empty() {
        return CellResult {
            mass: 0.0,
            centroid: region.closest_point(p),
            area: 0.0,
            gradient: zero,
            geometry: CellGeometry::Empty,
        };
    }
    let area = geometry.area();
    let local_box = pieces_box(&pieces);
    let (min, max) = if pieces.is_empty() {
        world_bounds(&rings, p)
    } else {
        (local_box.0 + p, local_box.1 + p)
    };

    let ln_k = vessel.k.ln();
    let mut terms = Vec::new();
    // Per term, its place on the risk's grid of objects (none for the base).
    let mut on_grid = Vec::new();
    if risk.base() > 0.0 {
        on_grid.push(None);
        terms.push(Gaussian {
            log_weight: ln_k + risk.base().ln(),
            a: beta,
            center: zero,
        });
    }
    let tol = options.tolerance;
    risk.objects_near(min, max, 1e-3 * tol.relative, near);
    for &j in near.iter() {
        let o = risk.objects()[j];
        let b = 1.0 / (2.0 * o.sigma * o.sigma);
        let s = o.center - p;
        let a = beta + b;
        terms.push(Gaussian {
            log_weight: ln_k + o.alpha.ln() - beta * b / a * (s.x * s.x + s.y * s.y),
            a,
            center: s * (b / a),
        });
        on_grid.push(risk.grid().and_then(|g| g.at[j]));
    }
    let weightless = terms.is_empty();
    if weightless {
        // Φ ≡ 0: the centroid is the limit of φ0 → 0⁺, the mass is 0.
        on_grid.push(None);
        terms.push(Gaussian {
            log_weight: 0.0,
            a: beta,
            center: zero,
        });
    }
    let r = if pieces.is_empty() {
        // The grid's centres as the terms have them: the same operations,
        // so a term on the grid sits exactly on its column and row.
        let local = risk.grid().map(|g| {
            let b = 1.0 / (2.0 * g.sigma * g.sigma);
            let a = beta + b;
            let xs: Vec<f64> = g.xs.iter().map(|x| (x - p.x) * (b / a)).collect();
            let ys: Vec<f64> = g.ys.iter().map(|y| (y - p.y) * (b / a)).collect();
            (a, xs, ys)
        });
        let grid = local.as_ref().map(|(a, xs, ys)| GridTerms {
            a: *a,
            xs,
            ys,
            at: &on_grid,
        });
        integrate_with_grid(&rings, &terms, grid, tol)
    } else {
        integrate_pieces(&pieces, local_box, &terms, tol)
    };
    if !(r.mass > 0.0 && r.mass.is_finite()) {
        return CellResult {
            mass: 0.0,
            centroid: region.closest_point(p),
            area,
            gradient: zero,
            geometry,
        };
    }
    let scale = if weightless { 0.0 } else { r.log_scale.exp() };
    let mass = r.mass * scale;
    let offset = r.moment / r.mass;
    CellResult {
        mass,
        centroid: p + offset,
        area,
        gradient: r.moment * (2.0 * beta * scale),
        geometry,
    }
}

/// The cell's oriented rings relative to `p` (for a clipped cell, the exact
/// chain), as [`integrate`] needs them.
fn local_rings(geometry: &CellGeometry, p: Point) -> Vec<Vec<Point>> {
    let shift = |ring: &[Point]| ring.iter().map(|v| *v - p).collect::<Vec<_>>();
    match geometry {
        CellGeometry::Empty => Vec::new(),
        CellGeometry::Convex(c) => vec![shift(&c.vertices)],
        CellGeometry::Clipped { rings, .. } => rings.iter().map(|r| shift(r)).collect(),
        CellGeometry::Curved { .. } => Vec::new(),
    }
}

/// A curved cell's pieces relative to `p`; none for other cells.
fn local_pieces(geometry: &CellGeometry, p: Point) -> Vec<Piece> {
    match geometry {
        CellGeometry::Curved { pieces } => pieces
            .iter()
            .map(|piece| match *piece {
                Piece::Segment { from, to } => Piece::Segment {
                    from: from - p,
                    to: to - p,
                },
                Piece::Arc {
                    centre,
                    radius,
                    start,
                    sweep,
                } => Piece::Arc {
                    centre: centre - p,
                    radius,
                    start,
                    sweep,
                },
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// World-coordinate bounds of local rings.
fn world_bounds(rings: &[Vec<Point>], p: Point) -> (Point, Point) {
    let (min, max) = bounds(rings.iter().flatten());
    (min + p, max + p)
}
