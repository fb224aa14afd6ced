//! Exact reduction of Gaussian area integrals to edge integrals (the fast path
//! of [`integrate`](super::integrate)).
//!
//! For g(x) = exp(λ − a‖x − m‖²) and a polygon P (any number of rings, holes
//! included, interior on the left of every edge), with y = x − m and r = ‖y‖:
//!
//! - **moment** — since (x − m) g = −∇g / (2a),
//!   ∫_P (x − m) g = −(1/2a) ∮ g n ds  (n the outward normal);
//! - **mass** — the radial field F(y) = y (1 − e^{−a r²}) / (2a r²) has
//!   div F = e^{−a r²}, and on an edge y·n = h is constant (the signed distance
//!   of the edge's line from m), so
//!   ∫_P g = e^λ Σ_edges (h / 2a) ∫ (1 − e^{−a(h² + s²)}) / (h² + s²) ds,
//!   s the arc length from the foot of the perpendicular.
//!
//! The mass integrand is an entire function of s (the zero of h² + s² is
//! cancelled by the numerator), so Gauss–Legendre on pieces of length ≤ 2/√a
//! converges geometrically; where e^{−a r²} has died out (a s² > 50) the rest of
//! the edge is the closed form (h/2a)(atan(s₁/h) − atan(s₀/h)).
//!
//! When m is far outside P (a·dist(m, P)² ≥ 1) the "1" parts of all edges add
//! up to (1/2a) × (total turning angle) = 0 exactly, but numerically they would
//! cancel catastrophically against a tiny result. There the mass uses the
//! split form −e^λ Σ (h/2a) ∫ e^{−a r²}/r² ds, whose terms are as small as the
//! result; r ≥ dist(m, P) keeps the poles at s = ±ih away from each piece.
//!
//! Every node costs one `exp`, shared by mass and moment. For a convex cell
//! with k edges and one Gaussian that is about 12 k evaluations, against
//! hundreds of triangle-rule points for the same accuracy.

use std::sync::LazyLock;

use super::gaussian::Gaussian;
use crate::geometry::quadrature::gauss_legendre_01;
use crate::geometry::{Point, dot, norm2};

/// Gauss–Legendre points per piece.
const NODES: usize = 12;
static GL: LazyLock<(Vec<f64>, Vec<f64>)> = LazyLock::new(|| gauss_legendre_01(NODES));

/// Beyond a s² = CUTOFF, e^{−a s²} < 2e−22: negligible next to what came before.
const CUTOFF: f64 = 50.0;

/// [∫ g, ∫ x₁ g, ∫ x₂ g] over the polygon `rings` (coordinates of the caller's
/// frame; interior on the left of every directed edge). `far` selects the
/// split form and must be set exactly when g's centre is outside the polygon
/// with a·dist² ≥ 1 (see [`crate::geometry::ring_distances`]).
pub fn polygon_integrals<R: AsRef<[Point]>>(rings: &[R], g: &Gaussian, far: bool) -> [f64; 3] {
    let m = g.center;
    let mut mass = 0.0;
    let mut moment = Point { x: 0.0, y: 0.0 };
    for ring in rings {
        let ring = ring.as_ref();
        let n = ring.len();
        for i in 0..n {
            let (mass_part, line) = segment(ring[i] - m, ring[(i + 1) % n] - m, g, far);
            mass += mass_part;
            moment = moment + line;
        }
    }
    let moment = moment * (-0.5 / g.a);
    // Back from the term's centre to the caller's frame.
    [mass, moment.x + m.x * mass, moment.y + m.y * mass]
}

/// The segment a → b (relative to g's centre, the region on its left):
/// its share of the mass and of ∮ g n ds (near form: ∮ (g − e^λ) n ds),
/// as [`polygon_integrals`] sums them; also the straight pieces of a
/// curved cell ([`curved`](super::curved)).
pub(super) fn segment(a: Point, b: Point, g: &Gaussian, far: bool) -> (f64, Point) {
    let len = norm2(b - a).sqrt();
    if len == 0.0 {
        return (0.0, Point { x: 0.0, y: 0.0 });
    }
    let e = (b - a) / len;
    let normal = Point { x: e.y, y: -e.x };
    let h = dot(a, normal);
    let s0 = dot(a, e);
    let (mass, line) = edge(g.a, g.log_weight, h, s0, s0 + len, far);
    (mass, normal * line)
}

/// One edge on the line at signed distance `h`, for s in [s0, s1]: returns
/// (its mass contribution, ∫ e^{λ − a r²} ds up to a constant times the
/// edge length, which cancels around every closed ring).
fn edge(a: f64, lambda: f64, h: f64, s0: f64, s1: f64, far: bool) -> (f64, f64) {
    // Both integrands are even in s: fold [s0, s1] onto s ≥ 0.
    let (parts, count) = if s0 < 0.0 && s1 > 0.0 {
        ([(0.0, -s0), (0.0, s1)], 2)
    } else if s1 <= 0.0 {
        ([(-s1, -s0), (0.0, 0.0)], 1)
    } else {
        ([(s0, s1), (0.0, 0.0)], 1)
    };
    let (x, w) = &*GL;
    let h2 = h * h;
    let sqrt_a = a.sqrt();
    let mut mass_integral = 0.0;
    let mut line = 0.0;
    let scale = lambda.exp();
    for &(u0, u1) in &parts[..count] {
        let mut u = u0;
        while u < u1 {
            if far {
                if a * (u * u - u0 * u0) > CUTOFF {
                    break; // negligible next to this edge's own start
                }
            } else if a * (h2 + u * u) > CUTOFF {
                // e^{−a r²} is gone: (1 − E)/r² = 1/r², and E − 1 = −1.
                if h != 0.0 {
                    mass_integral += ((u1 / h).atan() - (u / h).atan()) / h;
                }
                line -= u1 - u;
                break;
            }
            let mut piece = 2.0 / sqrt_a;
            if u > 0.0 {
                piece = piece.min(2.0 / (a * u));
            }
            if far {
                piece = piece.min((h2 + u * u).sqrt());
            }
            let end = (u + piece).min(u1);
            if end <= u {
                // The Gaussian decays within one float step of u (a·u² ≳
                // 1e16: a needle-thin object millions of metres away), so the
                // steps cannot advance. What is left is the Laplace tail
                // ∫_u^∞ e^{λ − a(h² + s²)} ds ≈ e^{λ − a r²} / (2 a u), with
                // 1/r² constant across it.
                let r2 = h2 + u * u;
                let tail = if far {
                    (lambda - a * r2).exp()
                } else {
                    (-a * r2).exp_m1()
                } / (2.0 * a * u);
                line += tail;
                mass_integral += if far { tail / r2 } else { -tail / r2 };
                break;
            }
            let len = end - u;
            let (mut mi, mut li) = (0.0, 0.0);
            for (xk, wk) in x.iter().zip(w) {
                let s = u + len * xk;
                let r2 = h2 + s * s;
                let ar2 = a * r2;
                if far {
                    let decay = (lambda - ar2).exp();
                    li += wk * decay;
                    mi += wk * decay / r2;
                } else {
                    // E − 1 rather than E: the constant's ∮ n ds is 0, and
                    // dropping it avoids cancellation for flat Gaussians.
                    let em1 = (-ar2).exp_m1();
                    li += wk * em1;
                    mi += wk * if r2 > 0.0 { -em1 / r2 } else { a };
                }
            }
            mass_integral += mi * len;
            line += li * len;
            u = end;
        }
    }
    if far {
        (-h / (2.0 * a) * mass_integral, line)
    } else {
        (h / (2.0 * a) * mass_integral * scale, line * scale)
    }
}
