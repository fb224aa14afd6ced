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
        // Weights relative to the vessel's own k: the same centroid, and
        // no underflow far from it.
        let (i, log_f) = owner(fleet, q);
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

/// The vessel whose generalized Voronoi cell holds `q` (the one whose
/// f_i = k_i exp(−β_i ‖q − p_i‖²) is the largest; a tie goes to the first)
/// and ln f_i(q). A fleet is never empty, so there always is one.
pub fn owner(fleet: &Fleet, q: Point) -> (usize, f64) {
    let mut best = (0, f64::NEG_INFINITY);
    for (i, v) in fleet.vessels().iter().enumerate() {
        let d = q - v.position;
        let log_f = v.k.ln() - v.beta * dot(d, d);
        if log_f > best.1 {
            best = (i, log_f);
        }
    }
    best
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

    /// The owner is the vessel of the largest f_i: the nearest one when k
    /// and β agree, a larger k reaching past the bisector, a tie to the
    /// first; ln f_i is returned with it.
    #[test]
    fn the_owner_has_the_largest_performance() {
        let vessel = |x, k| Vessel {
            position: p(x, 0.0),
            k,
            beta: 0.01,
        };
        let even = Fleet::new(vec![vessel(0.0, 0.5), vessel(10.0, 0.5)]).unwrap();
        assert_eq!(owner(&even, p(4.0, 3.0)).0, 0);
        assert_eq!(owner(&even, p(6.0, 3.0)).0, 1);
        assert_eq!(owner(&even, p(5.0, 3.0)).0, 0);
        let (i, log_f) = owner(&even, p(6.0, 3.0));
        assert_eq!(i, 1);
        assert!((log_f - (0.5f64.ln() - 0.01 * 25.0)).abs() < 1e-15);
        // k 0.9 against 0.5: ln(0.9/0.5) = 0.588 moves the edge past the
        // bisector by 0.588 / (0.01 · 2 · 10) = 2.94 m.
        let uneven = Fleet::new(vec![vessel(0.0, 0.9), vessel(10.0, 0.5)]).unwrap();
        assert_eq!(owner(&uneven, p(7.9, 0.0)).0, 0);
        assert_eq!(owner(&uneven, p(8.0, 0.0)).0, 1);
    }
}
