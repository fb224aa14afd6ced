//! Random starting poses for a scenario's fleet, seeded.
//!
//! Starts are drawn uniformly over a box (the region's bounding box, or a
//! staging area inside it, so that the fleet has to spread out past islands
//! and each other) and kept when
//! they are legal starts for a safe fleet: at least the shore distance from
//! ∂Q (so in Q) and at least the safety distance from every start kept
//! before. Headings are uniform in (−π, π]. The same seed always gives the
//! same starts (ChaCha8); a region too crowded for the fleet after many
//! tries is an error rather than an endless loop.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::geometry::shore::Shore;
use crate::geometry::{Point, norm2};

/// Draws per vessel before giving up.
const TRIES: usize = 100_000;

/// `n` starts (position, heading) for `seed` inside `zone` (min, max corners;
/// the region's bounds when `None`), or `None` when there is no room.
pub fn random_starts(
    shore: &Shore,
    n: usize,
    seed: u64,
    safety_distance: f64,
    shore_distance: f64,
    zone: Option<(Point, Point)>,
) -> Option<Vec<(Point, f64)>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut min, mut max) = shore.region().bounds();
    if let Some((lo, hi)) = zone {
        (min.x, min.y) = (min.x.max(lo.x), min.y.max(lo.y));
        (max.x, max.y) = (max.x.min(hi.x), max.y.min(hi.y));
        if !(min.x < max.x && min.y < max.y) {
            return None;
        }
    }
    let mut starts: Vec<(Point, f64)> = Vec::with_capacity(n);
    for _ in 0..n {
        let mut placed = false;
        for _ in 0..TRIES {
            let q = Point {
                x: rng.random_range(min.x..max.x),
                y: rng.random_range(min.y..max.y),
            };
            let clear = shore.signed_clearance(q) >= shore_distance;
            if clear
                && starts
                    .iter()
                    .all(|(s, _)| norm2(*s - q) >= safety_distance * safety_distance)
            {
                let psi = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
                starts.push((q, psi));
                placed = true;
                break;
            }
        }
        if !placed {
            return None;
        }
    }
    Some(starts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Region;

    #[test]
    fn starts_are_legal_and_reproducible() {
        let p = |x, y| Point { x, y };
        let shore = Shore::new(
            &Region::new(
                vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)],
                vec![vec![
                    p(30.0, 30.0),
                    p(70.0, 30.0),
                    p(70.0, 70.0),
                    p(30.0, 70.0),
                ]],
            )
            .unwrap(),
        );
        let a = random_starts(&shore, 30, 7, 8.0, 4.0, None).unwrap();
        assert_eq!(a, random_starts(&shore, 30, 7, 8.0, 4.0, None).unwrap());
        assert_ne!(a, random_starts(&shore, 30, 8, 8.0, 4.0, None).unwrap());
        let zone = (p(0.0, 0.0), p(30.0, 100.0));
        let west = random_starts(&shore, 10, 7, 8.0, 4.0, Some(zone)).unwrap();
        assert!(west.iter().all(|(q, _)| q.x <= 30.0));
        for (i, (q, _)) in a.iter().enumerate() {
            assert!(shore.signed_clearance(*q) >= 4.0);
            for (r, _) in &a[..i] {
                assert!(norm2(*q - *r) >= 64.0);
            }
        }
        assert!(random_starts(&shore, 1000, 7, 8.0, 4.0, None).is_none());
    }
}
