//! An independent reference for [`curved`](super::curved)'s integrals over
//! [`arcs`](crate::geometry::arcs)' cells (mixed β), by vertical slabs: it
//! shares nothing with the boundary and Green's theorem. Test-only.
//!
//! **Method.** At a fixed x the cell of vessel i is a set of y from the
//! actuators themselves: the region's y-intervals on the vertical line
//! (even–odd crossings of shell and holes), intersected for every other
//! vessel j with {y : ln k_i − β_i‖q − p_i‖² ≥ ln k_j − β_j‖q − p_j‖²},
//! A y² + B y + C ≥ 0 with A = β_j − β_i, solved from k, β and positions,
//! not through [`dominance`](super::dominance). Over each y-interval the inner integral
//! of g = exp(λ − a‖q − m‖²) is closed form: its mass is
//! e^{λ − a(x−m_x)²} √π/(2√a) (erf t₁ − erf t₀), t = √a (y − m_y), taken
//! as a difference of erfc on the side of m_y both ends are on (no
//! cancellation in the tails); its y-moment m_y M + e^{λ − a(x−m_x)²}
//! (e^{−t₀²} − e^{−t₁²})/(2a); its x-moment x M.
//!
//! **Outer integral.** F(x), the inner integral, is analytic between the
//! breakpoints: the region's vertices, circles' leftmost and rightmost x,
//! vertical bisectors' x, and every crossing of two curves (generous: it
//! costs panels, not accuracy). At a breakpoint F has a jump, a kink or, at
//! a circle's vertical tangent, a square root √(x − x₀). On each panel [x_a, x_b]
//! the substitution x = (x_a + x_b)/2 − (x_b − x_a)/2 · cos θ, θ ∈ [0, π],
//! makes x − x_a = (x_b − x_a) sin²(θ/2): √(x − x_a) becomes analytic in θ,
//! and so does F(x(θ)) dx/dθ on the closed interval, where Gauss–Legendre
//! converges geometrically. Panels are cut to at most 0.5/√a wide (the
//! Gaussian changes by a bounded factor across each).
//!
//! **Nodes and self-proof.** Each panel gets 16 and 24 Gauss–Legendre
//! nodes in θ (our own rule); |Q₁₆ − Q₂₄| generously estimates Q₂₄'s error.
//! The worst panel is halved until the sum is below 1e-13 of the mass (for
//! a singularity just beyond a panel's end). The tests check the reference
//! by that estimate, a rerun with other rules (20/32 nodes, half-width
//! panels), and closed forms (a disc and its complement in the square).

use std::f64::consts::PI;

use super::fleet::Vessel;
use super::gaussian::Gaussian;
use crate::geometry::{Point, Region, dot, norm2};

fn pt(x: f64, y: f64) -> Point {
    Point { x, y }
}

/// The n-point Gauss–Legendre rule on [−1, 1].
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut nodes, mut weights) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let k = k as f64;
                (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let step = p1 / dp;
            x -= step;
            if step.abs() < 1e-16 {
                break;
            }
        }
        nodes.push(x);
        weights.push(2.0 / ((1.0 - x * x) * dp * dp));
    }
    (nodes, weights)
}

/// How finely the reference integrates (see the module doc).
pub(super) struct Rule {
    low: (Vec<f64>, Vec<f64>),
    high: (Vec<f64>, Vec<f64>),
    /// Widest panel, in units of 1/√a.
    width: f64,
    /// Target of the summed error estimates, relative to the mass.
    tol: f64,
}

impl Rule {
    pub(super) fn new(low: usize, high: usize, width: f64, tol: f64) -> Rule {
        Rule {
            low: gauss_legendre(low),
            high: gauss_legendre(high),
            width,
            tol,
        }
    }

    /// The rule of the module doc.
    pub(super) fn standard() -> Rule {
        Rule::new(16, 24, 0.5, 1e-13)
    }
}

/// A curve h(z) = a‖z‖² + b·z + c = 0, z = q − p_i: a circle (a ≠ 0) or a
/// line.
#[derive(Clone, Copy)]
struct Conic(f64, Point, f64);

/// The reference integrals of one cell, with what the tests report.
#[derive(Debug, Clone, Copy)]
pub(super) struct Reference {
    /// [∫ g, ∫ x g, ∫ y g] (g = 1 for the area).
    pub value: [f64; 3],
    /// The summed error estimates of the mass.
    pub error: f64,
    /// The most y-intervals on one vertical line.
    pub most_intervals: usize,
}

/// Scratch buffers of one integration.
#[derive(Default)]
struct Scratch {
    ys: Vec<f64>,
    cur: Vec<(f64, f64)>,
    next: Vec<(f64, f64)>,
    most: usize,
}

/// Cell `own` of `fleet` in `region`, by vertical slabs.
pub(super) struct Slabs<'a> {
    edges: Vec<(Point, Point)>,
    /// Every other vessel j: p_j − p_i, β_j and ln(k_i/k_j).
    rivals: Vec<(Point, f64, f64)>,
    origin: Point,
    beta: f64,
    g: Option<&'a Gaussian>,
    lo: f64,
    hi: f64,
}

impl<'a> Slabs<'a> {
    /// `g` None integrates 1 (the area).
    pub(super) fn new(
        region: &Region,
        fleet: &[Vessel],
        own: usize,
        g: Option<&'a Gaussian>,
    ) -> Self {
        let rings = std::iter::once(region.shell()).chain(region.holes().iter().map(Vec::as_slice));
        let edges = rings
            .flat_map(|r| (0..r.len()).map(move |k| (r[k], r[(k + 1) % r.len()])))
            .collect();
        let me = fleet[own];
        let others = fleet.iter().enumerate().filter(|&(j, _)| j != own);
        let rivals = others
            .map(|(_, v)| (v.position - me.position, v.beta, (me.k / v.k).ln()))
            .collect();
        let (lo, hi) = region.bounds();
        Slabs {
            edges,
            rivals,
            origin: me.position,
            beta: me.beta,
            g,
            lo: lo.x,
            hi: hi.x,
        }
    }

    /// The cell's y-intervals at x, into `s.cur`.
    fn intervals(&self, x: f64, s: &mut Scratch) {
        s.ys.clear();
        for &(a, b) in &self.edges {
            // Half-open in x, so a vertex is crossed once.
            if (a.x <= x) != (b.x <= x) {
                s.ys.push(a.y + (x - a.x) * (b.y - a.y) / (b.x - a.x));
            }
        }
        s.ys.sort_by(f64::total_cmp);
        s.cur.clear();
        s.cur.extend(s.ys.chunks_exact(2).map(|w| (w[0], w[1])));
        let xl = x - self.origin.x;
        for &(p, beta_j, log_ratio) in &self.rivals {
            if s.cur.is_empty() {
                break;
            }
            // h(Y) = ln(k_i/k_j) − β_i(X² + Y²) + β_j((X − P_x)² + (Y − P_y)²),
            // Y = y − p_i.y; C is kept as a sum of like-signed terms.
            let b = -2.0 * beta_j * p.y;
            let c =
                log_ratio - self.beta * xl * xl + beta_j * ((xl - p.x) * (xl - p.x) + p.y * p.y);
            let (set, n) = nonnegative(beta_j - self.beta, b, c);
            s.next.clear();
            for &(lo, hi) in &set[..n] {
                let (lo, hi) = (lo + self.origin.y, hi + self.origin.y);
                for &(u, v) in &s.cur {
                    let (l, h) = (u.max(lo), v.min(hi));
                    if l < h {
                        s.next.push((l, h));
                    }
                }
            }
            // Sets of two half-lines give out-of-order pieces.
            s.next.sort_by(|p, q| p.0.total_cmp(&q.0));
            std::mem::swap(&mut s.cur, &mut s.next);
        }
        s.most = s.most.max(s.cur.len());
    }

    /// F(x): the inner integrals at x.
    fn inner(&self, x: f64, s: &mut Scratch) -> [f64; 3] {
        self.intervals(x, s);
        let mut out = [0.0; 3];
        match self.g {
            None => {
                for &(y0, y1) in &s.cur {
                    out[0] += y1 - y0;
                    out[2] += 0.5 * (y1 - y0) * (y1 + y0);
                }
            }
            Some(g) => {
                let ra = g.a.sqrt();
                let scale = (g.log_weight - g.a * (x - g.center.x).powi(2)).exp();
                for &(y0, y1) in &s.cur {
                    let (t0, t1) = (ra * (y0 - g.center.y), ra * (y1 - g.center.y));
                    let mass = scale * PI.sqrt() / (2.0 * ra) * erf_difference(t0, t1);
                    out[0] += mass;
                    out[2] += g.center.y * mass
                        + scale * ((-t0 * t0).exp() - (-t1 * t1).exp()) / (2.0 * g.a);
                }
            }
        }
        out[1] = x * out[0];
        out
    }

    /// Where F(x) may fail to be analytic (see the module doc), sorted,
    /// from the region's left to its right.
    fn breakpoints(&self) -> Vec<f64> {
        let o = self.origin;
        let rivals = self.rivals.iter();
        let mut curves: Vec<Conic> = rivals
            .map(|&(p, bj, l)| Conic(bj - self.beta, p * (-2.0 * bj), bj * norm2(p) + l))
            .collect();
        let vessels = curves.len();
        curves.extend(self.edges.iter().map(|&(a, b)| {
            let n = pt(a.y - b.y, b.x - a.x);
            Conic(0.0, n, -dot(n, a - o))
        }));
        // In x − p_i.x: circles' leftmost and rightmost x, vertical lines,
        // and crossings (edge lines meet each other at the vertices, or
        // off the region: only pairs with a vessel's curve).
        let mut local = Vec::new();
        for (i, c) in curves[..vessels].iter().enumerate() {
            let Conic(a, b, _) = *c;
            if a != 0.0 {
                let (centre, r2) = circle(c);
                if r2 > 0.0 {
                    local.extend([centre.x - r2.sqrt(), centre.x + r2.sqrt()]);
                }
            } else if b.y == 0.0 && b.x != 0.0 {
                local.push(-c.2 / b.x);
            }
            for d in &curves[i + 1..] {
                crossings(c, d, &mut local);
            }
        }
        let mut xs: Vec<f64> = self.edges.iter().map(|e| e.0.x).collect();
        xs.extend(local.iter().map(|x| x + o.x));
        xs.retain(|&x| x > self.lo && x < self.hi);
        xs.extend([self.lo, self.hi]);
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        xs
    }

    /// One panel with both rules: (high-rule value, error estimate).
    fn panel(&self, rule: &Rule, xa: f64, xb: f64, s: &mut Scratch) -> ([f64; 3], f64) {
        let (mid, half) = (0.5 * (xa + xb), 0.5 * (xb - xa));
        let mut apply = |(nodes, weights): &(Vec<f64>, Vec<f64>)| {
            let mut sum = [0.0; 3];
            for (t, w) in nodes.iter().zip(weights) {
                // θ = π (t + 1)/2 ∈ (0, π); dx = half sin θ dθ.
                let theta = 0.5 * PI * (t + 1.0);
                let (sin, cos) = theta.sin_cos();
                let f = self.inner(mid - half * cos, s);
                let jac = w * 0.5 * PI * half * sin;
                for k in 0..3 {
                    sum[k] += jac * f[k];
                }
            }
            sum
        };
        let low = apply(&rule.low);
        let high = apply(&rule.high);
        // Moments count by their effect on a centroid across the region.
        let span = self.hi - self.lo;
        let error =
            (high[0] - low[0]).abs() + ((high[1] - low[1]).abs() + (high[2] - low[2]).abs()) / span;
        (high, error)
    }

    pub(super) fn integrate(&self, rule: &Rule) -> Reference {
        let mut s = Scratch::default();
        let widest = self.g.map_or(f64::INFINITY, |g| rule.width / g.a.sqrt());
        let mut panels: Vec<(f64, f64, [f64; 3], f64)> = Vec::new();
        for w in self.breakpoints().windows(2) {
            let (xa, xb) = (w[0], w[1]);
            let parts = ((xb - xa) / widest).ceil().max(1.0) as usize;
            for k in 0..parts {
                let a = xa + (xb - xa) * k as f64 / parts as f64;
                let b = xa + (xb - xa) * (k + 1) as f64 / parts as f64;
                let (v, e) = self.panel(rule, a, b, &mut s);
                panels.push((a, b, v, e));
            }
        }
        let total = |p: &[(f64, f64, [f64; 3], f64)]| {
            let mass: f64 = p.iter().map(|q| q.2[0]).sum();
            let error: f64 = p.iter().map(|q| q.3).sum();
            (mass, error)
        };
        loop {
            let (mass, error) = total(&panels);
            if error <= rule.tol * mass.abs() || panels.len() > 100_000 {
                break;
            }
            let worst = (0..panels.len())
                .max_by(|&i, &j| panels[i].3.total_cmp(&panels[j].3))
                .expect("a region has width");
            let (a, b, _, _) = panels[worst];
            let m = 0.5 * (a + b);
            let (v0, e0) = self.panel(rule, a, m, &mut s);
            let (v1, e1) = self.panel(rule, m, b, &mut s);
            panels[worst] = (a, m, v0, e0);
            panels.push((m, b, v1, e1));
        }
        let add = |v: [f64; 3], p: &(f64, f64, [f64; 3], f64)| [0, 1, 2].map(|k| v[k] + p.2[k]);
        let value = panels.iter().fold([0.0; 3], add);
        Reference {
            value,
            error: total(&panels).1,
            most_intervals: s.most,
        }
    }
}

/// {Y : a Y² + b Y + c ≥ 0} as at most two closed intervals.
fn nonnegative(a: f64, b: f64, c: f64) -> ([(f64, f64); 2], usize) {
    const ALL: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);
    let (none, all) = (([ALL; 2], 0), ([ALL; 2], 1));
    if a == 0.0 {
        return if b > 0.0 {
            ([(-c / b, f64::INFINITY), ALL], 1)
        } else if b < 0.0 {
            ([(f64::NEG_INFINITY, -c / b), ALL], 1)
        } else if c >= 0.0 {
            all
        } else {
            none
        };
    }
    let disc = b * b - 4.0 * a * c;
    if disc <= 0.0 {
        // A double root touches 0 in one point: measure zero.
        return if a > 0.0 { all } else { none };
    }
    // The root without cancellation, the other from the product.
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let (r0, r1) = (q / a, c / q);
    let (lo, hi) = (r0.min(r1), r0.max(r1));
    if a > 0.0 {
        ([(f64::NEG_INFINITY, lo), (hi, f64::INFINITY)], 2)
    } else {
        ([(lo, hi), ALL], 1)
    }
}

/// erf t₁ − erf t₀ (t₀ ≤ t₁) without cancellation in either tail.
fn erf_difference(t0: f64, t1: f64) -> f64 {
    if t0 >= 0.0 {
        libm::erfc(t0) - libm::erfc(t1)
    } else if t1 <= 0.0 {
        libm::erfc(-t1) - libm::erfc(-t0)
    } else {
        libm::erf(t1) - libm::erf(t0)
    }
}

/// A circle's centre and squared radius (≤ 0: no circle).
fn circle(&Conic(a, b, c): &Conic) -> (Point, f64) {
    let centre = b * (-0.5 / a);
    (centre, norm2(centre) - c / a)
}

/// The x of the points where two curves cross.
fn crossings(p: &Conic, q: &Conic, out: &mut Vec<f64>) {
    let (&Conic(pa, pb, pc), &Conic(qa, qb, qc)) = (p, q);
    if pa == 0.0 && qa == 0.0 {
        let det = pb.x * qb.y - pb.y * qb.x;
        if det != 0.0 {
            out.push((qc * pb.y - pc * qb.y) / det);
        }
        return;
    }
    // A circle, and a line: the other curve, or the radical line of two
    // circles (h_p/a_p − h_q/a_q, linear).
    let (round, Conic(_, n, c)) = match (pa != 0.0, qa != 0.0) {
        (true, true) => (p, Conic(0.0, pb / pa - qb / qa, pc / pa - qc / qa)),
        (true, false) => (p, *q),
        _ => (q, *p),
    };
    let (centre, r2) = circle(round);
    let len = norm2(n).sqrt();
    let s = (dot(n, centre) + c) / len;
    let h2 = r2 - s * s;
    if r2 > 0.0 && len > 0.0 && h2 >= 0.0 {
        let foot = centre - n * (s / len);
        let along = -n.y * h2.sqrt() / len;
        out.extend([foot.x + along, foot.x - along]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::curved::{curved_integrals, is_far};
    use crate::coverage::dominance::cell_bounds;
    use crate::geometry::arcs::{Bound, Piece, boundary, contains};
    use crate::geometry::outline::ends;
    use crate::geometry::region::fixtures::square;
    use proptest::prelude::*;
    use rand::{RngExt, SeedableRng};

    const MID: Point = Point { x: 50.0, y: 50.0 };

    fn vessel(x: f64, y: f64, k: f64, beta: f64) -> Vessel {
        let position = pt(x, y);
        Vessel { position, k, beta }
    }

    fn rel(x: f64, want: f64) -> f64 {
        (x - want).abs() / want.abs()
    }

    fn centroid(v: [f64; 3]) -> Point {
        pt(v[1] / v[0], v[2] / v[0])
    }

    /// The square, the square with its island, and a notched square with
    /// a triangular island (not convex, slanted edges).
    fn region(no: usize) -> Region {
        match no % 3 {
            0 => square(false),
            1 => square(true),
            _ => {
                let ring = |c: &[f64]| c.chunks(2).map(|p| pt(p[0], p[1])).collect::<Vec<_>>();
                let shell = ring(&[
                    0., 0., 100., 0., 100., 100., 60., 100., 50., 55., 40., 100., 0., 100.,
                ]);
                let hole = ring(&[20., 20., 35., 25., 25., 40.]);
                Region::new(shell, vec![hole]).expect("a valid region")
            }
        }
    }

    /// A risk object (centre, σ, weight) times the vessel's actuator.
    fn object_term(v: &Vessel, object: Point, sigma: f64, weight: f64) -> Gaussian {
        let a_obj = 1.0 / (2.0 * sigma * sigma);
        let a = a_obj + v.beta;
        let log_weight = (weight * v.k).ln() - a_obj * v.beta / a * norm2(object - v.position);
        gauss(log_weight, a, (object * a_obj + v.position * v.beta) / a)
    }

    fn gauss(log_weight: f64, a: f64, center: Point) -> Gaussian {
        Gaussian {
            log_weight,
            a,
            center,
        }
    }

    /// The base risk (1) times the actuator.
    fn base_term(v: &Vessel) -> Gaussian {
        gauss(v.k.ln(), v.beta, v.position)
    }

    /// The code under test's cell: its bounds and boundary.
    type Cell = (Vec<Piece>, Vec<Bound>);

    fn cell(region: &Region, fleet: &[Vessel], i: usize) -> Cell {
        let others = fleet.iter().enumerate().filter(|&(j, _)| j != i);
        let bounds = cell_bounds(&fleet[i], others.map(|(_, v)| v));
        bounds.map_or_else(Default::default, |b| (boundary(region, &b), b))
    }

    /// The code under test's integrals of `g` over a cell, and whether
    /// they took the far form.
    fn engine(region: &Region, (pieces, bounds): &Cell, g: &Gaussian) -> ([f64; 3], bool) {
        if pieces.is_empty() {
            return ([0.0; 3], false);
        }
        let far = is_far(pieces, g, contains(region, bounds, g.center));
        (curved_integrals(pieces, g, far), far)
    }

    fn area(pieces: &[Piece]) -> f64 {
        pieces.iter().map(|p| p.area_share(MID)).sum()
    }

    /// The closed loops of a boundary, chained end to start (within 1e-6
    /// m), each as (signed area, has an arc, has a segment). The cell is
    /// on the left of every piece, so an outer loop is counter-clockwise
    /// (area > 0) and a hole's clockwise: the cell's pieces are its
    /// positive loops, its holes the negative. Where two pieces of a cell
    /// touch in a point the chaining may join their loops: the counts only
    /// tell what the test set covers.
    fn loops(pieces: &[Piece]) -> Vec<(f64, bool, bool)> {
        let mut used = vec![false; pieces.len()];
        let mut out = Vec::new();
        let arc = |p: &Piece| matches!(p, Piece::Arc { .. });
        while let Some(first) = used.iter().position(|u| !u) {
            let (start, mut end) = ends(&pieces[first]);
            let mut k = first;
            let (mut sum, mut arcs, mut segs) = (0.0, false, false);
            loop {
                used[k] = true;
                sum += pieces[k].area_share(MID);
                arcs |= arc(&pieces[k]);
                segs |= !arc(&pieces[k]);
                if norm2(end - start) <= 1e-12 {
                    break;
                }
                let gap = |l: usize| norm2(ends(&pieces[l]).0 - end);
                let next = (0..pieces.len()).filter(|&l| !used[l]);
                match next.min_by(|&l, &m| gap(l).total_cmp(&gap(m))) {
                    Some(l) if gap(l) <= 1e-12 => k = l,
                    _ => break,
                }
                end = ends(&pieces[k]).1;
            }
            out.push((sum, arcs, segs));
        }
        out
    }

    /// The reference against closed forms: vessel 0 (β 0.004) wins a disc
    /// inside the square against vessel 1 (β 0.001); a Gaussian centred on
    /// it has π/a (1 − e^{−aR²}) e^λ there, and over the square a product
    /// of erfs, so over the square minus the disc the difference.
    #[test]
    fn the_reference_integrates_a_disc_and_its_complement_exactly() {
        let region = square(false);
        let fleet = [
            vessel(45.0, 52.0, 1.0, 0.004),
            vessel(70.0, 40.0, 1.0, 0.001),
        ];
        // Centre p_i + β_j P/(β_j − β_i), R² = β_i β_j ‖P‖²/(β_j − β_i)².
        let p = fleet[1].position - fleet[0].position;
        let d = fleet[1].beta - fleet[0].beta;
        let centre = fleet[0].position + p * (fleet[1].beta / d);
        let r2 = fleet[0].beta * fleet[1].beta * norm2(p) / (d * d);
        let g = gauss(0.3, 0.01, centre);
        let rule = Rule::standard();
        let run = |i, g| Slabs::new(&region, &fleet, i, g).integrate(&rule);
        let disc = run(0, Some(&g));
        let want = 0.3f64.exp() * PI / g.a * -(-g.a * r2).exp_m1();
        assert!(rel(disc.value[0], want) < 1e-12, "{disc:?} {want}");
        assert!(norm2(centroid(disc.value) - centre).sqrt() < 1e-9);
        let area = run(0, None);
        assert!(rel(area.value[0], PI * r2) < 1e-12, "{area:?}");

        let ra = g.a.sqrt();
        let side = |c: f64| libm::erf(ra * (100.0 - c)) + libm::erf(ra * c);
        let whole = 0.3f64.exp() * PI / (4.0 * g.a) * side(centre.x) * side(centre.y);
        let rest = run(1, Some(&g));
        assert!(rel(rest.value[0], whole - want) < 1e-12, "{rest:?}");
        let area = run(1, None);
        assert!(rel(area.value[0], 1e4 - PI * r2) < 1e-12, "{area:?}");
        assert_eq!(area.most_intervals, 2, "the disc is a hole");
    }

    #[derive(Default)]
    struct Worst {
        mass: f64,
        centroid: f64,
        h: f64,
        estimate: f64,
        rerun_mass: f64,
        rerun_centroid: f64,
    }

    /// The accuracy check of mixed-β cells: 240 random fleets of 3–10 vessels
    /// (β from {0.001, 0.002, 0.004} or, one vessel in four, uniform in
    /// 0.0008–0.005; k 0.3–1.5) in the three regions. Every cell, with two
    /// integrands (a risk object of σ 5–20 m times the actuator, and the
    /// base risk times the actuator), against the slab reference: mass to
    /// 1e-6 relative and centroid to 1e-4 m where the term's mass is at
    /// least 1e-12 of the fleet's H (below, its error must be below 1e-12
    /// of H: it cannot move H); H to 1e-6 relative. The set must include
    /// cells with holes (arcs' and islands') and cells in several pieces,
    /// counted from the boundary's loops.
    #[test]
    fn curved_integrals_match_the_slab_reference_on_random_mixed_fleets() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(31);
        let rule = Rule::standard();
        let rerun_rule = Rule::new(20, 32, 0.25, 1e-14);
        let mut worst = Worst::default();
        let (mut cells, mut terms, mut arcs, mut far_terms) = (0, 0, 0, 0);
        let (mut circle_holes, mut island_holes, mut several) = (0, 0, 0);
        let fleets = 240;
        for fleet_no in 0..fleets {
            let region = region(fleet_no);
            let n = rng.random_range(3..=10);
            let mut draw = |lo: f64, hi: f64| rng.random_range(lo..hi);
            let fleet: Vec<Vessel> = (0..n)
                .map(|_| {
                    let (x, y, k) = (draw(5.0, 95.0), draw(5.0, 95.0), draw(0.3, 1.5));
                    let beta = match draw(0.0, 4.0) as usize {
                        0 => draw(0.0008, 0.005),
                        _ => [0.001, 0.002, 0.004][draw(0.0, 3.0) as usize],
                    };
                    vessel(x, y, k, beta)
                })
                .collect();
            let (object, sigma) = (pt(draw(0.0, 100.0), draw(0.0, 100.0)), draw(5.0, 20.0));
            let mut results = Vec::new();
            for i in 0..n {
                let cell = cell(&region, &fleet, i);
                let pieces = &cell.0;
                cells += usize::from(!pieces.is_empty());
                arcs += pieces
                    .iter()
                    .filter(|p| matches!(p, Piece::Arc { .. }))
                    .count();
                let loops = loops(pieces);
                let holes: Vec<_> = loops.iter().filter(|l| l.0 < -1e-9).collect();
                several += usize::from(loops.iter().filter(|l| l.0 > 1e-9).count() >= 2);
                circle_holes += holes.iter().filter(|l| l.1 && !l.2).count();
                island_holes += holes.iter().filter(|l| l.2 && !l.1).count();
                let mut most = 0;
                for g in [
                    object_term(&fleet[i], object, sigma, 8.0),
                    base_term(&fleet[i]),
                ] {
                    let (got, far) = engine(&region, &cell, &g);
                    far_terms += usize::from(far);
                    let slabs = Slabs::new(&region, &fleet, i, Some(&g));
                    let want = slabs.integrate(&rule);
                    let w = want.value;
                    most = most.max(want.most_intervals);
                    if w[0] > 0.0 {
                        worst.estimate = worst.estimate.max(want.error / w[0]);
                    }
                    if fleet_no % 4 == 0 && w[0] > 0.0 {
                        let again = slabs.integrate(&rerun_rule).value;
                        worst.rerun_mass = worst.rerun_mass.max(rel(again[0], w[0]));
                        let moved = norm2(centroid(again) - centroid(w)).sqrt();
                        worst.rerun_centroid = worst.rerun_centroid.max(moved);
                    }
                    results.push((i, got, w));
                }
                // A cell with a hole has a vertical line crossing it twice.
                assert!(holes.is_empty() || most >= 2, "fleet {fleet_no} cell {i}");
            }
            let h_got: f64 = results.iter().map(|r| r.1[0]).sum();
            let h_want: f64 = results.iter().map(|r| r.2[0]).sum();
            let h = rel(h_got, h_want);
            worst.h = worst.h.max(h);
            assert!(h < 1e-6, "fleet {fleet_no}: H {h_got} vs {h_want}");
            for (i, got, want) in results {
                let case = format!("fleet {fleet_no} cell {i}: {got:?} vs {want:?} ({fleet:?})");
                if want[0] < 1e-12 * h_want {
                    assert!((got[0] - want[0]).abs() < 1e-12 * h_want, "{case}");
                    continue;
                }
                terms += 1;
                let moved = norm2(centroid(got) - centroid(want)).sqrt();
                worst.mass = worst.mass.max(rel(got[0], want[0]));
                worst.centroid = worst.centroid.max(moved);
                assert!(rel(got[0], want[0]) < 1e-6 && moved < 1e-4, "{case}");
            }
        }
        eprintln!(
            "{fleets} fleets, {cells} non-empty cells, {terms} terms compared ({far_terms} in \
             the far form), {arcs} arcs, {circle_holes} circular holes, {island_holes} island \
             holes, {several} cells in several pieces"
        );
        let w = &worst;
        eprintln!(
            "worst: mass {:.2e} relative, centroid {:.2e} m, H {:.2e} relative; reference: \
             estimate {:.2e}, rerun mass {:.2e}, rerun centroid {:.2e} m",
            w.mass, w.centroid, w.h, w.estimate, w.rerun_mass, w.rerun_centroid
        );
        assert!(w.estimate < 1e-11, "the reference's own estimate");
        assert!(w.rerun_mass < 1e-11 && w.rerun_centroid < 1e-8);
        assert!(arcs > 1000 && far_terms > 50, "{arcs} {far_terms}");
        assert!(circle_holes >= 10 && island_holes >= 10 && several >= 10);
    }

    /// Reaches differing by ε = 1e-4 down to 2e-9 relative (a random draw
    /// had 1.7e-5): their edge is a circle of radius ~‖P‖/ε meeting an
    /// ordinary one in the square. Mass and centroid hold at every ε, the
    /// area to 1e-9 of Q down to ε 1e-7 only: a circle of radius R in f64
    /// lies ~1e-16 R off the exact edge, 1e-4 m² at ε ≤ 1e-8.
    #[test]
    fn near_equal_reaches_keep_their_accuracy() {
        near_equal(&[1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 3e-9, 2e-9], 1e-7);
    }

    #[test] // The area below ε = 1e-7: needs `Bound`/`Piece` about a local anchor.
    #[ignore = "a 5e9 m circle in f64 centre/radius lies 1e-6 m off the edge: area 1e-4 m²"]
    fn near_equal_areas_below_1e_7() {
        near_equal(&[1e-8, 3e-9, 2e-9], 0.0);
    }

    fn near_equal(epsilons: &[f64], area_from: f64) {
        #[rustfmt::skip]
        let raw = [
            37.65863283286569, 68.7285488638007, 1.3934312166206513, 0.004,
            20.799745072757197, 22.744511991311825, 1.1192622033319648, 0.001,
            5.580123538110724, 77.98280805588529, 1.1541087382826, 0.001656615518985566,
            28.79633052906941, 69.75524473398292, 0.9884016325187543, 0.001,
        ];
        let mut fleet: Vec<_> = raw
            .chunks(4)
            .map(|v| vessel(v[0], v[1], v[2], v[3]))
            .collect();
        let object = pt(64.30427926088878, 39.586347151406784);
        let region = square(true);
        let rule = Rule::standard();
        let mut failures = Vec::new();
        for &eps in epsilons {
            fleet[1].beta = 0.001 * (1.0 + eps);
            for i in 0..fleet.len() {
                let cell = cell(&region, &fleet, i);
                let want_area = Slabs::new(&region, &fleet, i, None).integrate(&rule).value[0];
                let g = object_term(&fleet[i], object, 9.920547182608795, 8.0);
                let got = engine(&region, &cell, &g).0;
                let want = Slabs::new(&region, &fleet, i, Some(&g))
                    .integrate(&rule)
                    .value;
                let moved = norm2(centroid(got) - centroid(want)).sqrt();
                let (mass, off) = (rel(got[0], want[0]), (area(&cell.0) - want_area).abs());
                let area_ok = eps < area_from || off < 1e-9 * region.area();
                if mass >= 1e-6 || moved >= 1e-4 || !area_ok {
                    failures.push(format!(
                        "ε {eps:e} cell {i}: mass {mass:.1e}, centroid {moved:.1e} m, area {off:.1e} m²"
                    ));
                }
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    fn any_vessel() -> impl Strategy<Value = Vessel> {
        let beta = prop_oneof![Just(0.001), Just(0.002), Just(0.004), 0.0008..0.005f64];
        (5.0..95.0f64, 5.0..95.0f64, 0.3..1.5f64, beta)
            .prop_map(|(x, y, k, beta)| vessel(x, y, k, beta))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// The cells tile the region: their areas (the boundary's, and
        /// the reference's) sum to the region's, each cell's boundary area
        /// is its reference area, and one Gaussian common to all cells (a
        /// risk object alone) integrates over the cells to its integral
        /// over the region, by the engine and by the reference.
        #[test]
        fn curved_cells_tile_the_region(
            fleet in prop::collection::vec(any_vessel(), 2..10),
            region_no in 0usize..3,
            (ox, oy, sigma) in (0.0..100.0f64, 0.0..100.0f64, 5.0..20.0f64),
        ) {
            let region = region(region_no);
            let g = gauss(0.0, 0.5 / (sigma * sigma), pt(ox, oy));
            let rule = Rule::standard();
            let slabs = |fleet: &[Vessel], i, g| Slabs::new(&region, fleet, i, g).integrate(&rule);
            let (mut areas, mut ref_areas, mut mass, mut ref_mass) = (0.0, 0.0, 0.0, 0.0);
            for i in 0..fleet.len() {
                let cell = cell(&region, &fleet, i);
                let (a, r) = (area(&cell.0), slabs(&fleet, i, None).value[0]);
                prop_assert!((a - r).abs() < 1e-9 * region.area(), "cell {i}: {a} vs {r}");
                areas += a;
                ref_areas += r;
                mass += engine(&region, &cell, &g).0[0];
                ref_mass += slabs(&fleet, i, Some(&g)).value[0];
            }
            let whole = (boundary(&region, &[]), Vec::new());
            let want = engine(&region, &whole, &g).0[0];
            let ref_want = slabs(&fleet[..1], 0, Some(&g)).value[0];
            prop_assert!(rel(areas, region.area()) < 1e-9, "areas {areas}");
            prop_assert!(rel(ref_areas, region.area()) < 1e-10, "reference areas {ref_areas}");
            prop_assert!(rel(ref_want, want) < 1e-9, "region mass {ref_want} vs {want}");
            prop_assert!(rel(mass, want) < 1e-9, "cell masses {mass} vs {want}");
            prop_assert!(rel(ref_mass, ref_want) < 1e-10, "reference {ref_mass} vs {ref_want}");
        }
    }
}
