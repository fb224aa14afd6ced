//! Gauss quadrature on triangles.
//!
//! A rule of order `n` is the collapsed (Duffy / Stroud conical) product of an
//! `n`-point Gauss–Jacobi rule with weight (1 − s) and an `n`-point Gauss–Legendre
//! rule on [0, 1]: the square (s, t) maps to the reference triangle by
//! u = s, v = (1 − s) t, whose Jacobian (1 − s) is absorbed by the Jacobi weight.
//! It has n² points, all strictly inside the triangle, positive weights, and is
//! exact for every polynomial of total degree ≤ 2n − 1.
//!
//! Nodes and weights are computed once, deterministically, by the Golub–Welsch
//! method (eigen-decomposition of the Jacobi matrix of the three-term recurrence),
//! so there is no table of constants to mistype.

use nalgebra::{DMatrix, SymmetricEigen};

/// A quadrature rule on the reference triangle (0,0), (1,0), (0,1).
///
/// Weights sum to 1 (they are fractions of the triangle's area), so for a
/// triangle of area A, ∫ g ≈ A Σ w_k g(x_k).
#[derive(Debug, Clone)]
pub struct TriangleRule {
    /// Barycentric-style coordinates (u, v): the point is A + u (B − A) + v (C − A).
    pub nodes: Vec<(f64, f64)>,
    /// Weights as fractions of the triangle's area; they sum to 1.
    pub weights: Vec<f64>,
    /// Highest total degree integrated exactly.
    pub degree: usize,
}

impl TriangleRule {
    /// The collapsed Gauss rule with `n` × `n` points (degree 2n − 1).
    pub fn collapsed_gauss(n: usize) -> Self {
        assert!((1..=32).contains(&n), "rule order out of range");
        let (sj, wj) = gauss_jacobi_01(n, 1.0);
        let (tl, wl) = gauss_jacobi_01(n, 0.0);
        let mut nodes = Vec::with_capacity(n * n);
        let mut weights = Vec::with_capacity(n * n);
        for i in 0..n {
            for j in 0..n {
                nodes.push((sj[i], (1.0 - sj[i]) * tl[j]));
                // ∫_ref du dv = 1/2; the weights as fractions of area are doubled.
                weights.push(2.0 * wj[i] * wl[j]);
            }
        }
        TriangleRule {
            nodes,
            weights,
            degree: 2 * n - 1,
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the rule has no points (never true for a constructed rule).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
}

/// The `n`-point Gauss–Legendre rule on [0, 1]: nodes ascending, weights
/// summing to 1; exact for polynomials of degree ≤ 2n − 1.
pub fn gauss_legendre_01(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!((1..=64).contains(&n), "rule order out of range");
    gauss_jacobi_01(n, 0.0)
}

/// Gauss–Jacobi rule for the weight (1 − s)^alpha on [0, 1] with `n` points,
/// from the Golub–Welsch eigenvalue method. Returns nodes ascending and weights
/// summing to ∫₀¹ (1 − s)^alpha ds.
fn gauss_jacobi_01(n: usize, alpha: f64) -> (Vec<f64>, Vec<f64>) {
    // Jacobi polynomials P^(alpha, 0) on [-1, 1] (weight (1 − x)^alpha).
    let beta = 0.0;
    let ab = alpha + beta;
    let mut j = DMatrix::<f64>::zeros(n, n);
    for k in 0..n {
        let kf = k as f64;
        let diag = if k == 0 {
            (beta - alpha) / (ab + 2.0)
        } else {
            (beta * beta - alpha * alpha) / ((2.0 * kf + ab) * (2.0 * kf + ab + 2.0))
        };
        j[(k, k)] = diag;
        if k + 1 < n {
            let m = kf + 1.0;
            let num = 4.0 * m * (m + alpha) * (m + beta) * (m + ab);
            let den = (2.0 * m + ab).powi(2) * (2.0 * m + ab + 1.0) * (2.0 * m + ab - 1.0);
            let off = (num / den).sqrt();
            j[(k, k + 1)] = off;
            j[(k + 1, k)] = off;
        }
    }
    // μ0 = ∫_{-1}^{1} (1 − x)^alpha dx = 2^(alpha+1) / (alpha + 1).
    let mu0 = 2f64.powf(alpha + 1.0) / (alpha + 1.0);
    let eig = SymmetricEigen::new(j);
    let mut pairs: Vec<(f64, f64)> = (0..n)
        .map(|k| {
            let v0 = eig.eigenvectors[(0, k)];
            (eig.eigenvalues[k], mu0 * v0 * v0)
        })
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    // x = 2s − 1: dx = 2 ds and (1 − x)^alpha = 2^alpha (1 − s)^alpha.
    let scale = 2f64.powf(alpha + 1.0);
    let nodes = pairs.iter().map(|p| 0.5 * (p.0 + 1.0)).collect();
    let weights = pairs.iter().map(|p| p.1 / scale).collect();
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factorial(n: u32) -> f64 {
        (1..=n).map(f64::from).product()
    }

    #[test]
    fn collapsed_rules_are_exact_to_their_degree() {
        for n in 1..=10 {
            let rule = TriangleRule::collapsed_gauss(n);
            assert_eq!(rule.len(), n * n);
            assert!(rule.weights.iter().all(|w| *w > 0.0));
            let deg = rule.degree as u32;
            for a in 0..=deg {
                for b in 0..=(deg - a) {
                    // ∫_ref u^a v^b = a! b! / (a + b + 2)!, over area 1/2.
                    let exact = factorial(a) * factorial(b) / factorial(a + b + 2) * 2.0;
                    let got: f64 = rule
                        .nodes
                        .iter()
                        .zip(&rule.weights)
                        .map(|(&(u, v), w)| w * u.powi(a as i32) * v.powi(b as i32))
                        .sum();
                    assert!(
                        (got - exact).abs() <= 1e-13 * exact.max(1e-3),
                        "n={n} u^{a} v^{b}: {got} vs {exact}"
                    );
                }
            }
        }
    }

    #[test]
    fn collapsed_rule_is_not_exact_one_degree_higher() {
        // Guards the test above against a rule that is accidentally trivial.
        let rule = TriangleRule::collapsed_gauss(3);
        let a = 6;
        let exact = factorial(a) / factorial(a + 2) * 2.0;
        let got: f64 = rule
            .nodes
            .iter()
            .zip(&rule.weights)
            .map(|(&(u, _), w)| w * u.powi(a as i32))
            .sum();
        assert!((got - exact).abs() > 1e-8);
    }

    #[test]
    fn gauss_legendre_is_exact_to_degree_2n_minus_1() {
        for n in 1..=16 {
            let (x, w) = gauss_legendre_01(n);
            for d in 0..(2 * n) as i32 {
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(d)).sum();
                assert!((got - 1.0 / (d as f64 + 1.0)).abs() < 1e-14, "n={n} d={d}");
            }
        }
    }

    #[test]
    fn nodes_lie_strictly_inside() {
        let rule = TriangleRule::collapsed_gauss(8);
        for &(u, v) in &rule.nodes {
            assert!(u > 0.0 && v > 0.0 && u + v < 1.0);
        }
    }
}
