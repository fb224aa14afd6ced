//! A uniform bucket grid for fixed-radius neighbour queries among points.
//!
//! The safety filter and the simulator's collision watch both ask, for every
//! vessel, "which vessels are within r of it?" with one r per call. Bucketing
//! the points into square cells of side ≥ r and scanning the 3 × 3 cells
//! around a point answers that in O(1 + k) per point for well-spread fleets,
//! so all n queries cost O(n + Σk) instead of the O(n²) of all pairs; an
//! R-tree would answer the same in O(log n + k) with a larger constant.
//!
//! Invariants: building and querying are deterministic (buckets are sorted by
//! cell and then by index, and answers come in increasing index order);
//! non-finite points are never reported as anyone's neighbour.

use super::{Point, norm2};

/// Points bucketed into square cells of one side.
#[derive(Debug, Clone)]
pub struct NeighbourGrid {
    side: f64,
    /// (cell x, cell y, point index), sorted.
    entries: Vec<(i64, i64, usize)>,
    points: Vec<Point>,
}

impl NeighbourGrid {
    /// Buckets `points` for queries of radius up to `side` (> 0).
    pub fn new(points: &[Point], side: f64) -> Self {
        let side = if side.is_finite() && side > 0.0 {
            side
        } else {
            1.0
        };
        let mut entries: Vec<(i64, i64, usize)> = points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.x.is_finite() && p.y.is_finite())
            .map(|(i, p)| {
                let (cx, cy) = cell_of(*p, side);
                (cx, cy, i)
            })
            .collect();
        entries.sort_unstable();
        NeighbourGrid {
            side,
            entries,
            points: points.to_vec(),
        }
    }

    /// Indices j ≠ i with ‖p_j − p_i‖ ≤ `radius` (clamped to the grid's
    /// side), in increasing order, appended to `out` after clearing it.
    pub fn within(&self, i: usize, radius: f64, out: &mut Vec<usize>) {
        out.clear();
        let p = self.points[i];
        if !(p.x.is_finite() && p.y.is_finite()) {
            return;
        }
        let r2 = radius.min(self.side).powi(2);
        let (cx, cy) = cell_of(p, self.side);
        for dx in -1..=1 {
            for dy in -1..=1 {
                let key = (cx + dx, cy + dy);
                let start = self.entries.partition_point(|&(x, y, _)| (x, y) < key);
                for &(x, y, j) in &self.entries[start..] {
                    if (x, y) != key {
                        break;
                    }
                    if j != i && norm2(self.points[j] - p) <= r2 {
                        out.push(j);
                    }
                }
            }
        }
        out.sort_unstable();
    }
}

fn cell_of(p: Point, side: f64) -> (i64, i64) {
    // Coordinates are bounded (±1e7 m in a valid scenario), so the casts are
    // exact for any side above a micrometre; `as` saturates beyond that.
    ((p.x / side).floor() as i64, (p.y / side).floor() as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_exactly_the_points_within_the_radius() {
        // A deterministic scatter, checked against all pairs.
        let pts: Vec<Point> = (0..300)
            .map(|k| {
                let a = k as f64 * 2.399963;
                let r = (k as f64).sqrt() * 3.0;
                Point {
                    x: r * a.cos(),
                    y: r * a.sin(),
                }
            })
            .collect();
        let grid = NeighbourGrid::new(&pts, 7.5);
        let mut got = Vec::new();
        for i in 0..pts.len() {
            grid.within(i, 7.5, &mut got);
            let want: Vec<usize> = (0..pts.len())
                .filter(|&j| j != i && norm2(pts[j] - pts[i]) <= 7.5 * 7.5)
                .collect();
            assert_eq!(got, want, "point {i}");
        }
    }

    #[test]
    fn ignores_non_finite_points() {
        let pts = vec![
            Point { x: 0.0, y: 0.0 },
            Point {
                x: f64::NAN,
                y: 0.0,
            },
            Point { x: 1.0, y: 0.0 },
        ];
        let grid = NeighbourGrid::new(&pts, 5.0);
        let mut out = Vec::new();
        grid.within(0, 5.0, &mut out);
        assert_eq!(out, vec![2]);
        grid.within(1, 5.0, &mut out);
        assert!(out.is_empty());
    }
}
