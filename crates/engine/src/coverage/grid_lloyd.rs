//! Lloyd's algorithm on a gridded density: each vessel's cell is the grid
//! points where its performance f_i is the largest (the generalized
//! Voronoi cell, paper eq. 6; the nearest vessel when every k and β are
//! the same), and its centroid the f_i Φ-weighted mean of those points,
//! the engine's centroid ([`super::evaluate`]) by the midpoint rule. The
//! baseline docs/learning.md ("Against Schwager's law and a grid Lloyd")
//! steers with it over a map built from samples.
//!
//! Why f_i in the weights: so that on the true map its fixed point is the
//! one the engine's fleets come to, and a difference between fleets is
//! the map's, not the objective's.
//!
//! Invariants: pure, deterministic and never NaN; a cell without mass
//! (no grid point, or Φ zero over all of them) keeps its vessel where it
//! is; a tie goes to the first vessel, as in the engine's partition.

use super::Fleet;
use crate::geometry::{Point, dot};

/// Every vessel's centroid on the grid `points` (each a centre and Φ
/// there), in the fleet's order.
pub fn centroids(fleet: &Fleet, points: impl IntoIterator<Item = (Point, f64)>) -> Vec<Point> {
    let vessels = fleet.vessels();
    let mut sums = vec![(0.0, 0.0, 0.0); vessels.len()];
    for (q, phi) in points {
        let mut best = (0, f64::NEG_INFINITY);
        for (i, v) in vessels.iter().enumerate() {
            let d = q - v.position;
            let log_f = v.k.ln() - v.beta * dot(d, d);
            if log_f > best.1 {
                best = (i, log_f);
            }
        }
        // Weights relative to the vessel's own k: the same centroid, and
        // no underflow far from it.
        let (i, log_f) = best;
        let w = (log_f - vessels[i].k.ln()).exp() * phi.max(0.0);
        let s = &mut sums[i];
        (s.0, s.1, s.2) = (s.0 + w, s.1 + w * q.x, s.2 + w * q.y);
    }
    vessels
        .iter()
        .zip(sums)
        .map(|(v, (m, x, y))| {
            if m > 0.0 && m.is_finite() {
                Point { x: x / m, y: y / m }
            } else {
                v.position
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::{Options, RiskField, RiskObject, Vessel, evaluate};
    use crate::geometry::Region;

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    /// The centres of a `step` grid over the 100 m square, Φ = `risk`.
    fn grid(step: f64, risk: &RiskField) -> Vec<(Point, f64)> {
        let n = (100.0 / step) as usize;
        (0..n * n)
            .map(|k| {
                let q = p(((k % n) as f64 + 0.5) * step, ((k / n) as f64 + 0.5) * step);
                (q, risk.value(q))
            })
            .collect()
    }

    /// Three vessels (one with a larger k, so its edges are not
    /// bisectors) on the uniform map and on a Gaussian one: the grid's
    /// centroids are the engine's exact ones to the grid's accuracy
    /// (within 0.005 m at 0.125 m; 0.07 m at 0.5 m, 0.02 m at 0.25 m).
    #[test]
    fn grid_centroids_are_the_exact_ones_to_the_grid() {
        let square = vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)];
        let region = Region::new(square, vec![]).unwrap();
        let vessel = |x, y, k| Vessel {
            position: p(x, y),
            k,
            beta: 0.001,
        };
        let fleet = Fleet::new(vec![
            vessel(20.0, 30.0, 0.5),
            vessel(75.0, 40.0, 0.5),
            vessel(45.0, 80.0, 0.9),
        ])
        .unwrap();
        let hill = RiskObject {
            center: p(60.0, 70.0),
            alpha: 10.0,
            sigma: 12.0,
        };
        for risk in [
            RiskField::new(1.0, vec![]).unwrap(),
            RiskField::new(0.1, vec![hill]).unwrap(),
        ] {
            let exact = evaluate(&region, &risk, &fleet, &Options::default());
            let got = centroids(&fleet, grid(0.125, &risk));
            for (g, e) in got.iter().zip(&exact.cells) {
                let d = (*g - e.centroid).x.hypot((*g - e.centroid).y);
                assert!(d < 0.005, "{g:?} against {:?}", e.centroid);
            }
        }
    }

    #[test]
    fn a_cell_without_mass_keeps_its_vessel() {
        let vessel = |x, y| Vessel {
            position: p(x, y),
            k: 0.5,
            beta: 0.001,
        };
        let fleet = Fleet::new(vec![vessel(10.0, 10.0), vessel(90.0, 90.0)]).unwrap();
        let zero = RiskField::new(0.0, vec![]).unwrap();
        let got = centroids(&fleet, grid(1.0, &zero));
        assert_eq!(got, vec![p(10.0, 10.0), p(90.0, 90.0)]);
        let got = centroids(&fleet, std::iter::empty());
        assert_eq!(got, vec![p(10.0, 10.0), p(90.0, 90.0)]);
    }
}
