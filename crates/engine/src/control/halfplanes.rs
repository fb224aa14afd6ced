//! The point of an intersection of half-planes nearest to a given point: the
//! quadratic programme min ‖w − w₀‖² s.t. a_k · w ≥ b_k in two dimensions,
//! which is what a control-barrier-function filter solves for one vessel.
//!
//! Incremental algorithm (Seidel's, for a strictly convex objective): keep
//! the optimum of the first k − 1 constraints; if it violates constraint k,
//! the new optimum lies on k's boundary line, where the problem is one
//! dimensional — minimise |t| over the interval the earlier constraints
//! leave on that line. Exact, O(m) per violated constraint, O(m²) at worst;
//! with the handful of constraints a vessel has (its neighbours and nearby
//! shore) that is a few hundred flops, cheaper and more predictable than a
//! general QP solver, and deterministic: constraints are taken in the order
//! given.
//!
//! When the constraints leave no point (a vessel squeezed between others
//! and the shore, each demanding it move away), the result says so and the
//! caller decides what to relax.

use crate::geometry::Point;

/// One constraint a · w ≥ b, with a a unit vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfPlane {
    /// The unit normal a, pointing into the allowed side.
    pub a: Point,
    /// The least a · w allowed.
    pub b: f64,
}

/// Slack below which a constraint counts as met (m/s, for velocities).
const SLACK: f64 = 1e-12;

/// The point nearest `w0` satisfying every constraint, or `None` when they
/// have no common point.
pub fn nearest_feasible(w0: Point, constraints: &[HalfPlane]) -> Option<Point> {
    let mut w = w0;
    for (k, hk) in constraints.iter().enumerate() {
        if dot(hk.a, w) >= hk.b - SLACK {
            continue;
        }
        // On the line a_k · w = b_k: w = q + t d, with q the projection of w0
        // (so the objective is ‖q − w0‖² + t²) and d along the line.
        let q = w0 + hk.a * (hk.b - dot(hk.a, w0));
        let d = Point {
            x: -hk.a.y,
            y: hk.a.x,
        };
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for hj in &constraints[..k] {
            let ad = dot(hj.a, d);
            let rhs = hj.b - dot(hj.a, q);
            if ad.abs() < 1e-12 {
                if rhs > SLACK {
                    return None; // parallel and on the wrong side
                }
            } else if ad > 0.0 {
                lo = lo.max(rhs / ad);
            } else {
                hi = hi.min(rhs / ad);
            }
        }
        if lo > hi + SLACK {
            return None;
        }
        let t = 0.0f64.clamp(lo, hi.max(lo));
        w = q + d * t;
    }
    Some(w)
}

fn dot(a: Point, b: Point) -> f64 {
    a.x * b.x + a.y * b.y
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    fn unit(x: f64, y: f64) -> Point {
        let n = (x * x + y * y).sqrt();
        p(x / n, y / n)
    }

    #[test]
    fn feasible_points_are_kept_and_single_constraints_project() {
        let h = [HalfPlane {
            a: p(1.0, 0.0),
            b: 0.5,
        }];
        assert_eq!(nearest_feasible(p(1.0, 2.0), &h), Some(p(1.0, 2.0)));
        assert_eq!(nearest_feasible(p(-1.0, 2.0), &h), Some(p(0.5, 2.0)));
    }

    #[test]
    fn corners_and_infeasibility() {
        let h = [
            HalfPlane {
                a: p(1.0, 0.0),
                b: 1.0,
            },
            HalfPlane {
                a: p(0.0, 1.0),
                b: 1.0,
            },
        ];
        assert_eq!(nearest_feasible(p(0.0, 0.0), &h), Some(p(1.0, 1.0)));
        let clash = [
            HalfPlane {
                a: p(1.0, 0.0),
                b: 1.0,
            },
            HalfPlane {
                a: p(-1.0, 0.0),
                b: 1.0,
            },
        ];
        assert_eq!(nearest_feasible(p(0.0, 0.0), &clash), None);
    }

    #[test]
    fn agrees_with_brute_force_on_random_problems() {
        // A fixed pseudo-random sequence; the brute force takes the best of
        // w0, every single projection and every pairwise corner.
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let m = 1 + (rnd().abs() * 6.0) as usize;
            let hs: Vec<HalfPlane> = (0..m)
                .map(|_| HalfPlane {
                    a: unit(rnd(), rnd()),
                    b: rnd(),
                })
                .collect();
            let w0 = p(3.0 * rnd(), 3.0 * rnd());
            let feasible = |w: Point| hs.iter().all(|h| dot(h.a, w) >= h.b - 1e-9);
            let mut cands = vec![w0];
            for h in &hs {
                cands.push(w0 + h.a * (h.b - dot(h.a, w0)));
            }
            for i in 0..m {
                for j in i + 1..m {
                    let (a, b) = (hs[i], hs[j]);
                    let det = a.a.x * b.a.y - a.a.y * b.a.x;
                    if det.abs() > 1e-9 {
                        cands.push(p(
                            (a.b * b.a.y - b.b * a.a.y) / det,
                            (a.a.x * b.b - b.a.x * a.b) / det,
                        ));
                    }
                }
            }
            let best = cands
                .into_iter()
                .filter(|w| feasible(*w))
                .map(|w| crate::geometry::norm2(w - w0))
                .fold(f64::INFINITY, f64::min);
            match nearest_feasible(w0, &hs) {
                Some(w) => {
                    assert!(feasible(w), "{hs:?} {w0:?} -> {w:?}");
                    assert!(
                        (crate::geometry::norm2(w - w0) - best).abs() < 1e-7,
                        "{hs:?}"
                    );
                }
                None => assert!(best.is_infinite(), "{hs:?} {w0:?}"),
            }
        }
    }
}
