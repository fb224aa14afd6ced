//! Integrals over a straight-edged cell of many Gaussians of one decay whose
//! centres lie on a grid (columns x_i, rows y_j), as a learned belief's
//! lattice does (docs/learning.md, "Cost in the tick"): the fast path of
//! [`integrate`](super::integrate) for them.
//!
//! ## Separable sums
//! g = Σ_ij c_ij e^{−a(x − x_i)²} e^{−a(y − y_j)²} is a sum of products, so
//! with G_i′(x) = e^{−a(x − x_i)²}, H_i′(x) = x e^{−a(x − x_i)²} and
//! E_j(y) = e^{−a(y − y_j)²}, Green's theorem with the fields (G_i E_j, 0),
//! (H_i E_j, 0) and (G_i y E_j, 0) gives, over a cell P whose rings have their
//! interior on the left,
//!
//! - ∫_P g = ∮ Σ_ij c_ij G_i(x) E_j(y) dy,
//! - ∫_P x g = ∮ Σ_ij c_ij H_i(x) E_j(y) dy, H_i = x_i G_i − e^{−a(x − x_i)²} / (2a),
//! - ∫_P y g = ∮ y Σ_ij c_ij G_i(x) E_j(y) dy.
//!
//! At a node of the boundary that is n_x + n_y exponentials for the
//! one-dimensional factors and n_x erfc, each taken from its column's
//! exponential with a rational function ([`super::erfc`]), then n_x n_y
//! multiply-adds, where each of the grid's terms integrated on its own
//! ([`super::boundary`]) costs twelve exponentials per piece of every edge
//! near it: for the hundreds of Gaussians of a belief, several times less
//! work, and no less exact. The exponentials are taken in loops of their
//! own, which the compiler runs in vector registers; that, and not
//! computing erfc's exponential twice, made the path 1.8× faster on
//! docs/learning.md's 400-Gaussian belief.
//!
//! ## Anchors
//! Any constant added to G_i (or H_i) adds a multiple of ∮ E_j dy = 0, so each
//! column's antiderivative may start where it suits: at −∞ for a column right
//! of the cell's middle, at +∞ (G_i = −∫_x^∞) for one left of it. Then |G_i|
//! is at most the part of the column's Gaussian on the cell's side of x_i,
//! and no far column adds a large constant that the ring would have to
//! cancel to rounding.
//!
//! ## Quadrature
//! Along an edge every factor is an entire function of the arc length that
//! varies on the scale 1/√a (erfc's derivatives are Gaussians times
//! polynomials), so the edges are cut into pieces no longer than 2/√a with
//! the 12-point Gauss–Legendre rule, as [`super::boundary`] does for one
//! Gaussian (~1e-16 relative). Edges with dy = 0 contribute nothing.

use std::f64::consts::PI;

use super::boundary::{GL, WIDTHS, exp_fast};
use super::erfc::erfc_with;
use std::f64::consts::LOG10_E;

use crate::geometry::{Point, norm2};

/// The grid's terms as one cell sees them: columns `xs`, rows `ys`, and
/// the weights `c[j · xs.len() + i]` (row j, column i; 0 where no term).
pub(super) struct Window<'a> {
    /// The common decay a > 0 [1/m²].
    pub a: f64,
    /// Column centres x_i.
    pub xs: &'a [f64],
    /// Row centres y_j.
    pub ys: &'a [f64],
    /// Weights, row by row.
    pub c: &'a [f64],
    /// Per weight, ln c less a·d², d the distance from its centre to the
    /// cell (0 inside): the log of its largest value on the cell. Read only
    /// where c > 0.
    pub bounds: &'a [f64],
}

/// Pieces of 2/√a the rings need at least: the caller's cost model.
pub(super) fn pieces(rings: &[&Vec<Point>], a: f64) -> f64 {
    let sqrt_a = a.sqrt();
    let mut count = 0.0;
    for ring in rings {
        let n = ring.len();
        for k in 0..n {
            let (p, q) = (ring[k], ring[(k + 1) % n]);
            if q.y != p.y {
                count += (norm2(q - p).sqrt() * sqrt_a / WIDTHS).ceil().max(1.0);
            }
        }
    }
    count
}

/// [∫ g, ∫ x g, ∫ y g] over `rings` for the grid's terms `w`, or `None`
/// when the edges need more than `budget` pieces (then one by one is
/// cheaper).
pub(super) fn grid_integrals(rings: &[&Vec<Point>], w: &Window, budget: usize) -> Option<[f64; 3]> {
    let (lo, hi) = crate::geometry::bounds(rings.iter().copied().flatten());
    let middle = 0.5 * (lo.x + hi.x);
    // The terms within 16 decades of the largest set the pieces' lengths.
    let nx = w.xs.len();
    let top = (w.c.iter().zip(w.bounds))
        .filter(|t| *t.0 > 0.0)
        .map(|t| *t.1)
        .fold(f64::NEG_INFINITY, f64::max);
    let mut terms = Significant::default();
    for (t, (&c, &bound)) in w.c.iter().zip(w.bounds).enumerate() {
        if c > 0.0 && bound >= top - SIGNIFICANT {
            terms.x.push(w.xs[t % nx]);
            terms.y.push(w.ys[t / nx]);
            terms.log_c.push(c.ln());
        }
    }
    let mut nodes = Nodes {
        w,
        right: w.xs.iter().map(|&x| x >= middle).collect(),
        u: vec![0.0; nx],
        ex: vec![0.0; nx],
        ey: vec![0.0; w.ys.len()],
        terms,
        top,
    };
    let mut sum = [0.0; 3];
    let mut left = budget;
    for ring in rings {
        let n = ring.len();
        for k in 0..n {
            let (p, q) = (ring[k], ring[(k + 1) % n]);
            if q.y == p.y {
                continue;
            }
            let len = norm2(q - p).sqrt();
            let e = (q - p) / len;
            let mut edge = [0.0; 3];
            let mut s = 0.0;
            while s < len {
                left = left.checked_sub(1)?;
                let start = p + e * s;
                let piece = nodes.piece_length(start, e).min(len - s);
                let v = nodes.piece(start, e * piece);
                for (acc, x) in edge.iter_mut().zip(v) {
                    *acc += x * (e.y * piece);
                }
                s += piece;
            }
            for (acc, v) in sum.iter_mut().zip(edge) {
                *acc += v;
            }
        }
    }
    Some(sum)
}

/// What the nodes of one cell share.
struct Nodes<'a> {
    w: &'a Window<'a>,
    /// Per column: anchored at −∞ (right of the cell's middle) or +∞.
    right: Vec<bool>,
    /// Scratch: u_i = Σ_j c_ij E_j(y) at a node.
    u: Vec<f64>,
    /// Scratch: e^{−a(x − x_i)²} and E_j(y) at a node.
    ex: Vec<f64>,
    ey: Vec<f64>,
    /// The terms within [`SIGNIFICANT`] of the largest on the cell.
    terms: Significant,
    /// The largest term's log upper bound on the cell.
    top: f64,
}

/// Centres and ln c of the terms that set the pieces' lengths, one array
/// each so that [`Nodes::piece_length`]'s loop runs in vector registers.
#[derive(Default)]
struct Significant {
    x: Vec<f64>,
    y: Vec<f64>,
    log_c: Vec<f64>,
}

/// 16 decades: a term that far below the largest one on the cell sets no
/// limit on the pieces.
const SIGNIFICANT: f64 = 16.0 * std::f64::consts::LN_10;

impl Nodes<'_> {
    /// The longest piece from `start` along the unit vector `e` that the
    /// 12-point rule integrates to rounding of the largest term on the
    /// cell. A term whose foot on the edge's line is u from `start` changes
    /// along the piece at a rate of at most κ = 2a(u + ℓ) over a piece of
    /// length ℓ, and the rule's relative error on e^{−κt} over [0, ℓ] (the
    /// hardest case of a Gaussian's tail) is 1e-16 at κℓ = 9, 1e-14 at 12,
    /// 1e-10 at 20, 1e-7 at 30: so a term whose largest value on the piece
    /// is D decades below the largest term's bound on the cell may have
    /// κℓ ≤ 9 + 2D, and one more than 16 decades below sets no limit. At
    /// most 2/√a, as in [`super::boundary`].
    fn piece_length(&self, start: Point, e: Point) -> f64 {
        let a = self.w.a;
        let most = WIDTHS / a.sqrt();
        let t = &self.terms;
        let mut piece = most;
        // A minimum over the terms, so the loop has no carried branch.
        for k in 0..t.x.len() {
            let (dx, dy) = (start.x - t.x[k], start.y - t.y[k]);
            let along = dx * e.x + dy * e.y;
            let across = dx * e.y - dy * e.x;
            // A bound of its largest value on a piece no longer than 2/√a:
            // at `start` when its foot is behind, else at the piece's point
            // nearest the foot.
            let gap = if along >= 0.0 {
                along
            } else {
                (-along - most).max(0.0)
            };
            let nearest = across * across + gap * gap;
            let decades = ((self.top - (t.log_c[k] - a * nearest)) * LOG10_E).max(0.0);
            let (k2, u) = (2.0 * (9.0 + 2.0 * decades) / a, along.abs());
            // κℓ = 2a(u + ℓ)ℓ ≤ k  ⇔  ℓ ≤ (√(u² + 2k/a) − u) / 2, written
            // without the difference.
            let length = 0.5 * k2 / ((u * u + k2).sqrt() + u);
            piece = if decades <= 16.0 {
                piece.min(length)
            } else {
                piece
            };
        }
        piece
    }

    /// The 12-point rule's [Σ w F₁, Σ w F₂, Σ w y F₁] over the piece from
    /// `start` along `step` (F₁ = Σ c G E, F₂ = Σ c H E; per unit dy).
    fn piece(&mut self, start: Point, step: Point) -> [f64; 3] {
        let w = self.w;
        let (a, nx) = (w.a, w.xs.len());
        let sqrt_a = a.sqrt();
        let half_width = 0.5 * (PI / a).sqrt();
        let half_over_a = 0.5 / a;
        let (x_nodes, weights) = &*GL;
        let mut out = [0.0; 3];
        for (&t, &wt) in x_nodes.iter().zip(weights) {
            let at = start + step * t;
            // The exponentials first, in loops of their own that run in
            // vector registers; then u_i = Σ_j c_ij E_j(y), whole rows at a
            // time.
            for (e, &y) in self.ey.iter_mut().zip(w.ys) {
                let d = at.y - y;
                *e = exp_fast(-a * d * d);
            }
            for (e, &x) in self.ex.iter_mut().zip(w.xs) {
                let d = at.x - x;
                *e = exp_fast(-a * d * d);
            }
            let u = &mut self.u;
            u.fill(0.0);
            for (row, &ej) in w.c.chunks_exact(nx).zip(&self.ey) {
                if ej != 0.0 {
                    for (ui, &c) in u.iter_mut().zip(row) {
                        *ui += c * ej;
                    }
                }
            }
            let (mut mass, mut moment) = (0.0, 0.0);
            let columns = u.iter().zip(w.xs).zip(&self.right).zip(&self.ex);
            for (((&ui, &x), &right), &e) in columns {
                if ui == 0.0 {
                    continue;
                }
                let d = at.x - x;
                let (tail, sign) = if right { (-d, 1.0) } else { (d, -1.0) };
                let gi = sign * half_width * erfc(sqrt_a * tail, e);
                mass += ui * gi;
                moment += ui * (x * gi - e * half_over_a);
            }
            out[0] += wt * mass;
            out[1] += wt * moment;
            out[2] += wt * mass * at.y;
        }
        out
    }
}

/// erfc(z) from e = e^{−z²}, but 2 at once where it rounds to 2 (z < −6:
/// erfc(−6) = 2 − 2.2e-17, below half an ulp of 2).
#[inline]
fn erfc(z: f64, e: f64) -> f64 {
    if z < -6.0 { 2.0 } else { erfc_with(z, e) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::boundary::polygon_integrals;
    use crate::coverage::boundary::tests::random_convex_ring;
    use crate::coverage::gaussian::Gaussian;
    use crate::geometry::ring_distances;
    use rand::{RngExt, SeedableRng};

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    /// Random convex cells, grids of random weights over, around and away
    /// from them: the grid's integrals equal the sum of its terms each
    /// integrated by the edge method to 1e-13 of the mass (and of mass ×
    /// size for the moments).
    #[test]
    fn the_shortcut_is_the_librarys_erfc() {
        for k in 0..=3400 {
            let z = -40.0 + 0.01 * k as f64;
            assert_eq!(erfc(z, 0.0), libm::erfc(z), "{z}");
        }
    }

    #[test]
    fn grid_sums_equal_the_terms_one_by_one() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (mut worst, mut used): (f64, usize) = (0.0, 0);
        for _ in 0..600 {
            let size = 10f64.powf(rng.random_range(0.5..2.5));
            let n = rng.random_range(3..9);
            let ring = random_convex_ring(&mut rng, n, size);
            let a = 1.0 / size.powi(2) * 10f64.powf(rng.random_range(-1.0..2.0));
            let spacing = rng.random_range(0.3..1.5) / a.sqrt();
            let (nx, ny) = (rng.random_range(1..12), rng.random_range(1..12));
            let origin = p(rng.random_range(-2.0..1.0), rng.random_range(-2.0..1.0)) * size;
            let xs: Vec<f64> = (0..nx).map(|i| origin.x + i as f64 * spacing).collect();
            let ys: Vec<f64> = (0..ny).map(|j| origin.y + j as f64 * spacing).collect();
            let c: Vec<f64> = (0..nx * ny)
                .map(|_| {
                    if rng.random_range(0.0..1.0) < 0.2 {
                        0.0
                    } else {
                        rng.random_range(0.0..3.0f64).exp()
                    }
                })
                .collect();
            let rings = [&ring];
            // What the caller asks of a grid (see integrate's grid_sum):
            // its largest term on the cell is centred within 1/√a of it.
            let top = (0..nx * ny)
                .filter(|&t| c[t] > 0.0)
                .map(|t| {
                    let at = ring_distances(&rings, p(xs[t % nx], ys[t / nx]));
                    let d2 = if at.inside { 0.0 } else { at.boundary2 };
                    (c[t].ln() - a * d2, a * d2 < 1.0)
                })
                .max_by(|x, y| x.0.total_cmp(&y.0));
            if !top.is_some_and(|t| t.1) {
                continue;
            }
            used += 1;
            let bounds: Vec<f64> = (0..nx * ny)
                .map(|t| {
                    let at = ring_distances(&rings, p(xs[t % nx], ys[t / nx]));
                    let d2 = if at.inside { 0.0 } else { at.boundary2 };
                    c[t].ln() - a * d2
                })
                .collect();
            let got = grid_integrals(
                &rings,
                &Window {
                    a,
                    xs: &xs,
                    ys: &ys,
                    c: &c,
                    bounds: &bounds,
                },
                usize::MAX,
            )
            .expect("no budget");
            let mut want = [0.0; 3];
            for j in 0..ny {
                for i in 0..nx {
                    if c[j * nx + i] == 0.0 {
                        continue;
                    }
                    let g = Gaussian {
                        log_weight: c[j * nx + i].ln(),
                        a,
                        center: p(xs[i], ys[j]),
                    };
                    let at = ring_distances(&rings, g.center);
                    let far = !at.inside && a * at.boundary2 >= 1.0;
                    let v = polygon_integrals(&rings, &g, far);
                    for k in 0..3 {
                        want[k] += v[k];
                    }
                }
            }
            if want[0] < 1e-200 {
                continue;
            }
            let errors = [
                ((got[0] - want[0]) / want[0]).abs(),
                ((got[1] - want[1]) / (want[0] * size)).abs(),
                ((got[2] - want[2]) / (want[0] * size)).abs(),
            ];
            for e in errors {
                assert!(e < 1e-13, "{got:?} vs {want:?}: a {a}, size {size}");
                worst = worst.max(e);
            }
        }
        assert!(worst > 0.0, "two methods, not one");
        assert!(used > 200, "{used} cases");
        assert!(worst < 1e-13, "worst {worst:e}");
    }
}
