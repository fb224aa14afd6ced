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
//! ## Pieces and their cost
//! Every node costs one exponential, shared by mass and moment. A piece has
//! 12 Gauss–Legendre nodes and is no longer than 2/√a (the Gaussian's
//! scale: error ~1e-16 relative), than 3/(a u) where it starts at u > 0
//! (there e^{−a s²} falls like e^{−2au(s − u)}: error < 3e-17), and, in the
//! split form, than r (the poles: error < 1e-14). The near form needs no
//! fold at the foot of the perpendicular, its integrands being entire: an
//! edge across it that fits in one piece is one piece, not two. For a
//! convex cell with k edges around its vessel that is about 12 k
//! evaluations, against hundreds of triangle-rule points for the same
//! accuracy. The exponentials are computed inline (`exp_fast`,
//! `exp_m1_fast`: within 4 ulp), twelve at a time in vector registers.
//!
//! Against the plainer rule of `previous_edge` (folded edges, pieces of 2/(a u),
//! the library's `exp` and `exp_m1`, about 40 % more nodes): edges agree to
//! 2e-14 of their own size and whole cells to 6e-15 (unit tests below);
//! on `examples/fleet-1000.json` the masses to 7e-16 and H to the bit.

use std::sync::LazyLock;

use super::gaussian::Gaussian;
use crate::geometry::quadrature::gauss_legendre_01;
use crate::geometry::{Point, dot, norm2};

/// Gauss–Legendre points per piece.
const NODES: usize = 12;
pub(super) static GL: LazyLock<([f64; NODES], [f64; NODES])> = LazyLock::new(|| {
    let (x, w) = gauss_legendre_01(NODES);
    (
        x.try_into().expect("NODES nodes"),
        w.try_into().expect("NODES weights"),
    )
});

/// Beyond a s² = CUTOFF, e^{−a s²} < 2e−22: negligible next to what came before.
const CUTOFF: f64 = 50.0;

/// Longest piece in widths 1/√a of the Gaussian: at 2 the 12-point rule's
/// error is ~1e-16 relative for e^{−a s²} on [0, 2/√a] (≤ 5e-16 on a piece
/// centred on s = 0), less for the mass integrands.
pub(super) const WIDTHS: f64 = 2.0;

/// Longest piece in local decay lengths 1/(a u) where the piece starts at
/// u > 0: there e^{−a s²} ≈ e^{−a u²} e^{−2 a u (s − u)}, and pieces of
/// 3/(a u) keep the rule's error below 3e-17 relative (2/(a u), which this
/// module used before, gave 1e-20: more pieces than the accuracy needs).
pub(super) const DECAY: f64 = 3.0;

/// [∫ g, ∫ x₁ g, ∫ x₂ g] over the polygon `rings` (coordinates of the caller's
/// frame; interior on the left of every directed edge). `far` selects the
/// split form and must be set exactly when g's centre is outside the polygon
/// with a·dist² ≥ 1 (see [`crate::geometry::ring_distances`]).
pub fn polygon_integrals<R: AsRef<[Point]>>(rings: &[R], g: &Gaussian, far: bool) -> [f64; 3] {
    polygon_integrals_above(rings, g, far, f64::NEG_INFINITY)
}

/// [`polygon_integrals`] without the parts of edges where g is below
/// e^`floor`: from the first point of an edge's half (either side of the
/// foot of the perpendicular) where g < e^`floor`, the rest of that half is
/// left out (far form) or taken as if g were 0 there (near form: the
/// closed-form tail). For s ≥ u, e^{−a(h² + s²)} ≤ e^{−a(h² + u²)} < e^`floor`,
/// so each half so cut changes the mass, (|h|/2a) ∫ e^{…}/(h² + s²) ds, by
/// less than e^`floor` π / (4a) (∫_0^∞ |h| / (h² + s²) ds = π/2), and
/// ∫ (x − m) g, (1/2a) |∫ e^{…} n ds|, by less than e^`floor` √π / (4a^{3/2})
/// (∫_u^∞ e^{−a s²} ds ≤ e^{−a u²} √π / (2√a)).
/// [`integrate`](super::integrate) sets `floor` from its error budget.
pub fn polygon_integrals_above<R: AsRef<[Point]>>(
    rings: &[R],
    g: &Gaussian,
    far: bool,
    floor: f64,
) -> [f64; 3] {
    let m = g.center;
    // e^λ once for the polygon (the near form's factor; the far form keeps
    // λ inside its exponentials).
    let scale = if far { 0.0 } else { g.log_weight.exp() };
    let mut mass = 0.0;
    let mut moment = Point { x: 0.0, y: 0.0 };
    for ring in rings {
        let ring = ring.as_ref();
        let n = ring.len();
        for i in 0..n {
            let (mass_part, line) =
                segment_scaled(ring[i] - m, ring[(i + 1) % n] - m, g, far, scale, floor);
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
    let scale = if far { 0.0 } else { g.log_weight.exp() };
    segment_scaled(a, b, g, far, scale, f64::NEG_INFINITY)
}

/// [`segment`] with the near form's e^λ given, cut below e^`floor` as
/// [`polygon_integrals_above`] says.
#[inline]
fn segment_scaled(
    a: Point,
    b: Point,
    g: &Gaussian,
    far: bool,
    scale: f64,
    floor: f64,
) -> (f64, Point) {
    let len = norm2(b - a).sqrt();
    if len == 0.0 {
        return (0.0, Point { x: 0.0, y: 0.0 });
    }
    let e = (b - a) / len;
    let normal = Point { x: e.y, y: -e.x };
    let h = dot(a, normal);
    let s0 = dot(a, e);
    let (mass, line) = edge(g.a, g.log_weight, scale, h, s0, s0 + len, far, floor);
    (mass, normal * line)
}

/// One edge on the line at signed distance `h`, for s in [s0, s1]: returns
/// (its mass contribution, ∫ e^{λ − a r²} ds up to a constant times the
/// edge length, which cancels around every closed ring). `scale` = e^λ,
/// used by the near form only; where g falls below e^`floor` the rest of
/// each half is cut ([`polygon_integrals_above`]).
#[allow(clippy::too_many_arguments)]
fn edge(
    a: f64,
    lambda: f64,
    scale: f64,
    h: f64,
    s0: f64,
    s1: f64,
    far: bool,
    floor: f64,
) -> (f64, f64) {
    let h2 = h * h;
    let sqrt_a = a.sqrt();
    // An edge across the foot of the perpendicular (s0 < 0 < s1), short
    // enough to be one piece: the near form's integrands are entire in s,
    // so one piece over [s0, s1] is as accurate as the two folded ones and
    // costs half. (The far form keeps the fold: its 1/r² has poles at
    // s = ±ih, which a piece centred under them sees closer.)
    if !far
        && s0 < 0.0
        && s1 > 0.0
        && (s1 - s0) * sqrt_a <= WIDTHS
        && a * (h2 + (s0 * s0).max(s1 * s1)) <= CUTOFF
    {
        let len = s1 - s0;
        let (mi, li) = near_piece(a, h2, s0, len);
        return (h / (2.0 * a) * (mi * len) * scale, li * len * scale);
    }
    // Both integrands are even in s: fold [s0, s1] onto s ≥ 0.
    let (parts, count) = if s0 < 0.0 && s1 > 0.0 {
        ([(0.0, -s0), (0.0, s1)], 2)
    } else if s1 <= 0.0 {
        ([(-s1, -s0), (0.0, 0.0)], 1)
    } else {
        ([(s0, s1), (0.0, 0.0)], 1)
    };
    let mut mass_integral = 0.0;
    let mut line = 0.0;
    for &(u0, u1) in &parts[..count] {
        let mut u = u0;
        while u < u1 {
            // Below the caller's floor the rest is within its budget.
            let below = lambda - a * (h2 + u * u) < floor;
            if far {
                if below || a * (u * u - u0 * u0) > CUTOFF {
                    break; // negligible next to this edge's own start
                }
            } else if below || a * (h2 + u * u) > CUTOFF {
                // e^{−a r²} is gone: (1 − E)/r² = 1/r², and E − 1 = −1.
                // atan(u₁/h) − atan(u/h) = atan(h (u₁ − u) / (h² + u u₁)) for
                // 0 ≤ u ≤ u₁, without the cancellation of two angles near
                // π/2 when the edge's line passes close to the centre.
                if h != 0.0 {
                    mass_integral += (h * (u1 - u) / (h2 + u * u1)).atan() / h;
                }
                line -= u1 - u;
                break;
            }
            let mut piece = WIDTHS / sqrt_a;
            if u > 0.0 {
                piece = piece.min(DECAY / (a * u));
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
            let (mi, li) = if far {
                far_piece(a, lambda, h2, u, len)
            } else {
                near_piece(a, h2, u, len)
            };
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

/// The near form's rule on [u, u + len], per unit length: (Σ w (1 − E)/r²,
/// Σ w (E − 1)) with E = e^{−a r²}. E − 1 rather than E: the constant's
/// ∮ n ds is 0, and dropping it avoids cancellation for flat Gaussians.
#[inline]
fn near_piece(a: f64, h2: f64, u: f64, len: f64) -> (f64, f64) {
    let (x, w) = &*GL;
    let mut em1 = [0.0; NODES];
    let mut per_r2 = [0.0; NODES];
    for k in 0..NODES {
        let s = u + len * x[k];
        let r2 = h2 + s * s;
        em1[k] = exp_m1_fast(-(a * r2));
        // (1 − E)/r² → a as r → 0 (only a node exactly on g's centre).
        per_r2[k] = if r2 > 0.0 { -em1[k] / r2 } else { a };
    }
    weighted_sums(w, &per_r2, &em1)
}

/// The far form's rule on [u, u + len], per unit length: (Σ w e^{λ − a r²}/r²,
/// Σ w e^{λ − a r²}).
#[inline]
fn far_piece(a: f64, lambda: f64, h2: f64, u: f64, len: f64) -> (f64, f64) {
    let (x, w) = &*GL;
    let mut decay = [0.0; NODES];
    let mut per_r2 = [0.0; NODES];
    for k in 0..NODES {
        let s = u + len * x[k];
        let r2 = h2 + s * s;
        decay[k] = exp_fast(lambda - a * r2);
        per_r2[k] = decay[k] / r2;
    }
    weighted_sums(w, &per_r2, &decay)
}

/// (Σ w p, Σ w q), in a fixed order (two interleaved partial sums, so that
/// the compiler may keep them in one vector register).
#[inline]
fn weighted_sums(w: &[f64; NODES], p: &[f64; NODES], q: &[f64; NODES]) -> (f64, f64) {
    let (mut sp, mut sq) = ([0.0; 2], [0.0; 2]);
    for k in (0..NODES).step_by(2) {
        for j in 0..2 {
            sp[j] += w[k + j] * p[k + j];
            sq[j] += w[k + j] * q[k + j];
        }
    }
    (sp[0] + sp[1], sq[0] + sq[1])
}

// e^x and e^x − 1 for the nodes, branch-free so that a piece's twelve
// evaluate together in vector registers (plain SSE2 on x86-64), and inlined:
// the library's calls were a third of this module's time.
//
// x = k ln 2 + r with k = round(x / ln 2), |r| ≤ ln 2 / 2 (Cody–Waite: ln 2
// in two parts, the first with enough trailing zeros that k·LN2_HI is exact),
// then e^r − 1 = P(r), the Taylor polynomial of degree 13: its truncation
// error is below r¹⁴/14! < 1.2e-17 |P| on that interval. Then
// e^x = 2^k (1 + P) and e^x − 1 = 2^k P + (2^k − 1), which has no
// cancellation for small x (k = 0: P itself). Both are within a few ulp
// of the correctly rounded value (the unit tests check 4 ulp against the
// library's over the whole range used here).

/// ln 2 = LN2_HI + LN2_LO, the first with 21 trailing zero bits.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
/// 1.5 · 2^52: adding it rounds to an integer held in the low mantissa bits.
const ROUND: f64 = 6_755_399_441_055_744.0;
/// Below this, e^x < 2.3e-308 (the smallest normal double): taken as 0.
const EXP_MIN: f64 = -708.0;
const EXP_MAX: f64 = 709.0;

/// (2^k, P(r)) for x clamped to [EXP_MIN, EXP_MAX].
#[inline(always)]
fn reduce(x: f64) -> (f64, f64) {
    let x = x.clamp(EXP_MIN, EXP_MAX);
    let t = x * std::f64::consts::LOG2_E + ROUND;
    let k = t - ROUND;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let ki = t.to_bits().wrapping_sub(ROUND.to_bits());
    let two_k = f64::from_bits(ki.wrapping_add(1023) << 52);
    // 1/n! for n = 13 down to 2.
    const C: [f64; 12] = [
        1.0 / 6_227_020_800.0,
        1.0 / 479_001_600.0,
        1.0 / 39_916_800.0,
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
    ];
    let mut p = C[0];
    for c in &C[1..] {
        p = p * r + c;
    }
    (two_k, (p * r + 1.0) * r)
}

/// e^x; 0 below EXP_MIN.
#[inline(always)]
pub(super) fn exp_fast(x: f64) -> f64 {
    let (two_k, p) = reduce(x);
    let v = (1.0 + p) * two_k;
    if x < EXP_MIN { 0.0 } else { v }
}

/// e^x − 1 for x ≤ 0 (−1 below EXP_MIN).
#[inline(always)]
pub(super) fn exp_m1_fast(x: f64) -> f64 {
    let (two_k, p) = reduce(x);
    let v = two_k * p + (two_k - 1.0);
    if x < EXP_MIN { -1.0 } else { v }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    /// A random convex ring of `n` vertices around the origin, at
    /// distances between half `size` and `size` (also the lattice path's
    /// tests).
    pub(in crate::coverage) fn random_convex_ring(
        rng: &mut impl RngExt,
        n: usize,
        size: f64,
    ) -> Vec<Point> {
        let mut angles: Vec<f64> = (0..n)
            .map(|_| rng.random_range(0.0..std::f64::consts::TAU))
            .collect();
        angles.sort_by(f64::total_cmp);
        angles
            .iter()
            .map(|t| p(t.cos(), t.sin()) * (size * rng.random_range(0.5..1.0)))
            .collect()
    }

    /// Distance in units of the last place of `b` (also the curved
    /// quadrature's tests).
    pub(in crate::coverage) fn ulps(a: f64, b: f64) -> f64 {
        let ulp = f64::from_bits(b.abs().to_bits() + 1) - b.abs();
        (a - b).abs() / ulp
    }

    #[test]
    fn fast_exponentials_are_within_four_ulp_of_the_library() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let mut xs: Vec<f64> = (0..200_000)
            .map(|i| match i % 4 {
                0 => rng.random_range(-708.0..1.0),
                1 => rng.random_range(-60.0..0.0),
                2 => rng.random_range(-1.0..0.0),
                _ => -(10f64.powf(rng.random_range(-300.0..0.0))),
            })
            .collect();
        xs.extend([
            0.0,
            -0.0,
            -EXP_MIN.abs(),
            -0.5 * std::f64::consts::LN_2,
            -1e-300,
        ]);
        for x in xs {
            assert!(ulps(exp_fast(x), x.exp()) <= 4.0, "exp({x:e})");
            assert!(ulps(exp_m1_fast(x), x.exp_m1()) <= 4.0, "exp_m1({x:e})");
        }
        for x in [-708.5, -745.0, -1e6, f64::NEG_INFINITY] {
            assert_eq!(exp_fast(x), 0.0);
            assert_eq!(exp_m1_fast(x), -1.0);
        }
    }

    /// A plainer edge rule (pieces of 2/(a u), the
    /// fold at the foot of the perpendicular, the library's exp and exp_m1),
    /// kept as the reference for the present one. `stable_tail` writes its
    /// closed-form tail as the present rule does (as it was, the difference
    /// of two angles near π/2 lost up to 1e-11 of that edge's share when its
    /// line passed within centimetres of the centre).
    fn previous_edge(
        a: f64,
        lambda: f64,
        h: f64,
        s0: f64,
        s1: f64,
        far: bool,
        stable_tail: bool,
    ) -> (f64, f64) {
        let (parts, count) = if s0 < 0.0 && s1 > 0.0 {
            ([(0.0, -s0), (0.0, s1)], 2)
        } else if s1 <= 0.0 {
            ([(-s1, -s0), (0.0, 0.0)], 1)
        } else {
            ([(s0, s1), (0.0, 0.0)], 1)
        };
        let (x, w) = gauss_legendre_01(NODES);
        let h2 = h * h;
        let sqrt_a = a.sqrt();
        let (mut mass_integral, mut line) = (0.0, 0.0);
        for &(u0, u1) in &parts[..count] {
            let mut u = u0;
            while u < u1 {
                if far {
                    if a * (u * u - u0 * u0) > CUTOFF {
                        break;
                    }
                } else if a * (h2 + u * u) > CUTOFF {
                    if h != 0.0 && stable_tail {
                        mass_integral += (h * (u1 - u) / (h2 + u * u1)).atan() / h;
                    } else if h != 0.0 {
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
                assert!(end > u, "the tests stay away from the Laplace tail");
                let len = end - u;
                let (mut mi, mut li) = (0.0, 0.0);
                for (xk, wk) in x.iter().zip(&w) {
                    let s = u + len * xk;
                    let r2 = h2 + s * s;
                    if far {
                        let decay = (lambda - a * r2).exp();
                        li += wk * decay;
                        mi += wk * decay / r2;
                    } else {
                        let em1 = (-a * r2).exp_m1();
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
            let scale = lambda.exp();
            (h / (2.0 * a) * mass_integral * scale, line * scale)
        }
    }

    /// Every edge's two parts (sums of terms of one sign, so relative
    /// errors are well defined) equal the previous rule's to 1e-13, over
    /// random edges at every distance and length in units of the width.
    #[test]
    fn edges_equal_the_previous_rule() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let mut worst: f64 = 0.0;
        for i in 0..100_000 {
            let a = 10f64.powf(rng.random_range(-4.0..1.0));
            let width = 1.0 / a.sqrt();
            let far = i % 2 == 0;
            let h = width * rng.random_range(-6.0..6.0);
            let s0 = width * rng.random_range(-8.0..8.0);
            let s1 = s0 + width * 10f64.powf(rng.random_range(-3.0..1.2));
            // The far form is for centres at least one width from the edge.
            let dist2 = h * h
                + if s0 > 0.0 {
                    s0 * s0
                } else if s1 < 0.0 {
                    s1 * s1
                } else {
                    0.0
                };
            if far && a * dist2 < 1.0 {
                continue;
            }
            let lambda: f64 = rng.random_range(-3.0..1.0);
            let scale = if far { 0.0 } else { lambda.exp() };
            let new = edge(a, lambda, scale, h, s0, s1, far, f64::NEG_INFINITY);
            let old = previous_edge(a, lambda, h, s0, s1, far, true);
            for (n, o) in [(new.0, old.0), (new.1, old.1)] {
                let e = if o == 0.0 {
                    n.abs()
                } else {
                    ((n - o) / o).abs()
                };
                assert!(
                    e < 1e-13,
                    "a={a} h={h} s=[{s0}, {s1}] far={far}: {n:e} vs {o:e}"
                );
                worst = worst.max(e);
            }
        }
        assert!(worst > 0.0, "the rule did change");
    }

    /// Whole cells as [`integrate`](super::super::integrate) sums them: a
    /// random convex cell around its vessel (the origin), the base term
    /// e^{−β r²} centred there and risk objects' terms in and around it
    /// (near and far forms). Mass and moments (relative to mass × size)
    /// equal the previous rule's to 1e-12; the worst seen is ~1e-15.
    #[test]
    fn cells_equal_the_previous_rule() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut worst: f64 = 0.0;
        for _ in 0..3000 {
            let n = rng.random_range(3..10);
            let size = 10f64.powf(rng.random_range(0.5..2.7));
            let ring = random_convex_ring(&mut rng, n, size);
            if !crate::geometry::ring_distances(&[&ring], p(0.0, 0.0)).inside {
                continue; // the vessel is in its own cell
            }
            let beta = 10f64.powf(rng.random_range(-4.0..-1.0));
            let mut terms = vec![Gaussian {
                log_weight: rng.random_range(-3.0..0.0),
                a: beta,
                center: p(0.0, 0.0),
            }];
            for _ in 0..rng.random_range(0..4) {
                let sigma = 10f64.powf(rng.random_range(0.0..1.5));
                let a = beta + 1.0 / (2.0 * sigma * sigma);
                terms.push(Gaussian {
                    log_weight: rng.random_range(-2.0..3.0),
                    a,
                    center: p(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)) * size,
                });
            }
            let (mut new, mut old) = ([0.0; 3], [0.0; 3]);
            for g in &terms {
                let at = crate::geometry::ring_distances(&[&ring], g.center);
                let far = !at.inside && g.a * at.boundary2 >= 1.0;
                let v = polygon_integrals(&[&ring], g, far);
                let (mut mass, mut moment) = (0.0, p(0.0, 0.0));
                for i in 0..n {
                    let (u, v) = (ring[i] - g.center, ring[(i + 1) % n] - g.center);
                    let len = norm2(v - u).sqrt();
                    let e = (v - u) / len;
                    let normal = p(e.y, -e.x);
                    let s0 = dot(u, e);
                    let h = dot(u, normal);
                    let (m, l) = previous_edge(g.a, g.log_weight, h, s0, s0 + len, far, false);
                    mass += m;
                    moment = moment + normal * l;
                }
                let moment = moment * (-0.5 / g.a);
                let w = [
                    mass,
                    moment.x + g.center.x * mass,
                    moment.y + g.center.y * mass,
                ];
                for k in 0..3 {
                    new[k] += v[k];
                    old[k] += w[k];
                }
            }
            let errors = [
                ((new[0] - old[0]) / old[0]).abs(),
                ((new[1] - old[1]) / (old[0] * size)).abs(),
                ((new[2] - old[2]) / (old[0] * size)).abs(),
            ];
            for e in errors {
                assert!(e < 1e-12, "{new:?} vs {old:?}");
                worst = worst.max(e);
            }
        }
        assert!(worst > 0.0 && worst < 1e-13, "worst {worst:e}");
    }
}
