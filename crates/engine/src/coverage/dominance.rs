//! Where one vessel's actuator beats another's, f_i(q) ≥ f_j(q) (paper
//! eq. 6), for any k and β: the bound a generalized Voronoi cell gets from
//! each other vessel ([`Bound`]).
//!
//! With y = q − p_i, P = p_j − p_i and d = β_j − β_i, taking logarithms:
//! ln(k_i/k_j) + d‖y‖² − 2β_j P·y + β_j‖P‖² ≥ 0.
//! - d = 0: a half-plane, P·y ≤ ‖P‖²/2 + ln(k_i/k_j)/(2β) (the power
//!   diagram's edge).
//! - d ≠ 0: completing the square, ‖q − c‖² compared with ρ², where
//!   c = p_i + β_j P/d and ρ² = (β_i β_j ‖P‖² − d ln(k_i/k_j)) / d².
//!   d > 0 (j the more concentrated): i wins outside the disc (everywhere
//!   when ρ² ≤ 0); d < 0: i wins inside it (nowhere when ρ² ≤ 0).
//!
//! Both are computed about p_i, so far-off coordinates do not cancel.
//! When |d| ≤ 1e-9 max(β_i, β_j) the circle's radius is beyond 1e9 ‖P‖
//! (1e11 m for vessels 100 m apart) and its arc across any region is a
//! straight line to rounding; the d‖y‖² term is dropped (over a region of
//! 1e4 m it moves the edge by under 1e-9 · β‖y‖²/(β‖P‖) m). The circle
//! kept just above the threshold is itself only as good as f64 places it:
//! centre and radius of size R = ‖P‖/ε round to ~1e-16 R, 1e-6 m at
//! ε = 1e-8 and ‖P‖ = 50 m, more than the line's 1e-7 m at ε = 1e-9 for
//! ‖y‖ = 100 m; the threshold is not raised, as the line's error grows
//! with ‖y‖, which is not known here.

use super::fleet::Vessel;
use crate::geometry::arcs::Bound;
use crate::geometry::{Point, dot, norm2};

/// Relative difference of β below which an edge is a line.
const SAME_BETA: f64 = 1e-9;

/// Where `own` beats `other`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Dominance {
    /// At every point: `other` puts no bound on `own`'s cell.
    Everywhere,
    /// At no point: `own`'s cell is empty.
    Nowhere,
    /// Within this half-plane, disc or disc's complement.
    Within(Bound),
}

/// Where `own` beats (or ties) `other` (see the module doc).
pub fn dominance(own: &Vessel, other: &Vessel) -> Dominance {
    let (bi, bj) = (own.beta, other.beta);
    let p = other.position - own.position;
    let log_ratio = (own.k / other.k).ln();
    let d = bj - bi;
    if d.abs() <= SAME_BETA * bi.max(bj) {
        if norm2(p) == 0.0 {
            return if log_ratio >= 0.0 {
                Dominance::Everywhere
            } else {
                Dominance::Nowhere
            };
        }
        // P·(q − p_i) ≤ ‖P‖²/2 + ln(k_i/k_j)/(2β_j).
        let offset = 0.5 * norm2(p) + log_ratio / (2.0 * bj) + dot(p, own.position);
        return Dominance::Within(Bound::HalfPlane { normal: p, offset });
    }
    let rho2 = (bi * bj * norm2(p) - d * log_ratio) / (d * d);
    let centre = own.position + p * (bj / d);
    match (d > 0.0, rho2 > 0.0) {
        (true, false) => Dominance::Everywhere,
        (false, false) => Dominance::Nowhere,
        (true, true) => Dominance::Within(Bound::Outside {
            centre,
            radius: rho2.sqrt(),
        }),
        (false, true) => Dominance::Within(Bound::Disc {
            centre,
            radius: rho2.sqrt(),
        }),
    }
}

/// The bounds of `own`'s cell among `others` (itself not among them), or
/// `None` when another vessel wins everywhere.
pub fn cell_bounds<'a>(
    own: &Vessel,
    others: impl IntoIterator<Item = &'a Vessel>,
) -> Option<Vec<Bound>> {
    let mut bounds = Vec::new();
    for other in others {
        match dominance(own, other) {
            Dominance::Everywhere => {}
            Dominance::Nowhere => return None,
            Dominance::Within(b) => bounds.push(b),
        }
    }
    Some(bounds)
}

/// Whether `own` beats `other` at `q`, from the actuators themselves (for
/// tests of the bounds).
pub fn beats(own: &Vessel, other: &Vessel, q: Point) -> bool {
    own.k.ln() - own.beta * norm2(q - own.position)
        >= other.k.ln() - other.beta * norm2(q - other.position)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn the_bound_holds_where_the_actuator_wins() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut checked = 0;
        for _ in 0..2000 {
            let v = |rng: &mut rand_chacha::ChaCha8Rng| Vessel {
                position: Point {
                    x: rng.random_range(0.0..100.0),
                    y: rng.random_range(0.0..100.0),
                },
                k: rng.random_range(0.2..2.0),
                beta: [0.001, 0.002, 0.004][rng.random_range(0..3)],
            };
            let (a, b) = (v(&mut rng), v(&mut rng));
            let q = Point {
                x: rng.random_range(-50.0..150.0),
                y: rng.random_range(-50.0..150.0),
            };
            // Away from the edge (where rounding decides).
            let margin = (a.k.ln() - a.beta * norm2(q - a.position))
                - (b.k.ln() - b.beta * norm2(q - b.position));
            if margin.abs() < 1e-9 {
                continue;
            }
            let inside = match dominance(&a, &b) {
                Dominance::Everywhere => true,
                Dominance::Nowhere => false,
                Dominance::Within(bound) => bound.contains(q),
            };
            assert_eq!(inside, beats(&a, &b, q), "{a:?} {b:?} {q:?}");
            checked += 1;
        }
        assert!(checked > 1900);
    }
}
