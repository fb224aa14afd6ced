//! Lloyd's algorithm as in the paper's Fig. 3b: single-integrator vessels
//! ṗ_i = k (C_i − p_i) moving towards the same generalized centroids.

use crate::geometry::Point;

/// Advances every position by `dt` with the centroids held: the exact
/// solution p + (C − p)(1 − e^{−k dt}) of ṗ = k (C − p).
pub fn step(positions: &mut [Point], centroids: &[Point], k: f64, dt: f64) {
    let a = 1.0 - (-k * dt).exp();
    for (p, c) in positions.iter_mut().zip(centroids) {
        *p = *p + (*c - *p) * a;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn approaches_the_centroid_exponentially() {
        let mut p = vec![Point { x: 0.0, y: 0.0 }];
        let c = vec![Point { x: 10.0, y: 0.0 }];
        for _ in 0..10 {
            step(&mut p, &c, 0.5, 0.1);
        }
        assert!((p[0].x - 10.0 * (1.0 - (-0.5f64).exp())).abs() < 1e-12);
    }
}
