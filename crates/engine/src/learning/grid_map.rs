//! A map of Φ on a square grid built straight from the samples, the
//! baseline docs/learning.md ("Against Schwager's law and a grid Lloyd")
//! sets beside the Bayesian belief: no model, no fit.
//!
//! Each grid cell's value is the inverse-distance weighted mean (Shepard's
//! method) of the samples within `radius` of its centre, a sample at
//! distance d weighing 1 / (d² + (s/2)²) for grid spacing s (so a sample
//! in the cell itself does not take it over entirely); a cell with no
//! sample within reach keeps the prior's value at its centre. A value
//! below zero (noise about a zero field) is read as zero: a density is
//! never negative.
//!
//! Invariants: only cells whose centre lies in the region are kept; at
//! most [`GridMap::MAX`] of them; adding a sample touches only the cells
//! within `radius` of it, so the map is always up to date and its values
//! do not depend on the samples' order beyond rounding.

use super::Sample;
use crate::coverage::{InputError, RiskField, check_range};
use crate::geometry::region::MAX_COORDINATE;
use crate::geometry::{Point, Region};

/// The map: the sums of every in-region grid cell.
#[derive(Debug, Clone)]
pub struct GridMap {
    origin: Point,
    spacing: f64,
    columns: usize,
    rows: usize,
    radius: f64,
    /// Per grid cell (row-major over the region's box): index into the
    /// kept cells, or `usize::MAX` outside the region.
    index: Vec<usize>,
    centers: Vec<Point>,
    prior: Vec<f64>,
    weight: Vec<f64>,
    weighted: Vec<f64>,
}

impl GridMap {
    /// The most grid cells over the region's box.
    pub const MAX: usize = 4_000_000;

    /// A map of `region` on a grid of `spacing` metres from its box's
    /// corner, each sample reaching `radius` metres, the cells without a
    /// sample at `prior`'s value.
    pub fn over(
        region: &Region,
        prior: &RiskField,
        spacing: f64,
        radius: f64,
    ) -> Result<Self, InputError> {
        check_range(
            || "grid.spacing".into(),
            spacing,
            0.0,
            false,
            MAX_COORDINATE,
        )?;
        check_range(|| "grid.radius".into(), radius, 0.0, true, MAX_COORDINATE)?;
        let (min, max) = region.bounds();
        let (columns, rows) = (
            ((max.x - min.x) / spacing).ceil().max(1.0),
            ((max.y - min.y) / spacing).ceil().max(1.0),
        );
        if columns * rows > Self::MAX as f64 {
            return Err(InputError::invalid(
                "grid.spacing",
                format!(
                    "{spacing} m gives {columns} × {rows} cells; at most {}",
                    Self::MAX
                ),
            ));
        }
        let (columns, rows) = (columns as usize, rows as usize);
        let mut index = vec![usize::MAX; columns * rows];
        let mut centers = Vec::new();
        for j in 0..rows {
            for i in 0..columns {
                let c = Point {
                    x: min.x + (i as f64 + 0.5) * spacing,
                    y: min.y + (j as f64 + 0.5) * spacing,
                };
                if region.contains(c) {
                    index[j * columns + i] = centers.len();
                    centers.push(c);
                }
            }
        }
        let n = centers.len();
        Ok(GridMap {
            origin: min,
            spacing,
            columns,
            rows,
            radius,
            index,
            prior: centers.iter().map(|&c| prior.value(c)).collect(),
            centers,
            weight: vec![0.0; n],
            weighted: vec![0.0; n],
        })
    }

    /// Adds one sample to every cell within the radius of it.
    pub fn add(&mut self, sample: &Sample) {
        let (s, r) = (self.spacing, self.radius);
        let q = sample.position;
        let span = |at: f64, from: f64, n: usize| {
            let lo = ((at - r - from) / s - 0.5).ceil().max(0.0);
            let hi = ((at + r - from) / s - 0.5).floor().min(n as f64 - 1.0);
            (lo, hi)
        };
        let (i0, i1) = span(q.x, self.origin.x, self.columns);
        let (j0, j1) = span(q.y, self.origin.y, self.rows);
        if i1 < i0 || j1 < j0 {
            return;
        }
        for j in j0 as usize..=j1 as usize {
            for i in i0 as usize..=i1 as usize {
                let k = self.index[j * self.columns + i];
                if k == usize::MAX {
                    continue;
                }
                let d = self.centers[k] - q;
                let d2 = d.x * d.x + d.y * d.y;
                if d2 > r * r {
                    continue;
                }
                let w = 1.0 / (d2 + 0.25 * s * s);
                self.weight[k] += w;
                self.weighted[k] += w * sample.value;
            }
        }
    }

    /// Every in-region cell's centre and value, in row-major order.
    pub fn cells(&self) -> impl Iterator<Item = (Point, f64)> + '_ {
        (0..self.centers.len()).map(|k| {
            let value = if self.weight[k] > 0.0 {
                (self.weighted[k] / self.weight[k]).max(0.0)
            } else {
                self.prior[k]
            };
            (self.centers[k], value)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    fn map(radius: f64) -> GridMap {
        let ring = vec![p(0.0, 0.0), p(20.0, 0.0), p(20.0, 10.0), p(0.0, 10.0)];
        let region = Region::new(ring, vec![]).unwrap();
        GridMap::over(&region, &RiskField::new(0.1, vec![]).unwrap(), 1.0, radius).unwrap()
    }

    fn at(map: &GridMap, q: Point) -> f64 {
        map.cells()
            .find(|(c, _)| (c.x - q.x).abs() < 1e-9 && (c.y - q.y).abs() < 1e-9)
            .unwrap()
            .1
    }

    #[test]
    fn unseen_cells_keep_the_prior_and_seen_ones_average_their_samples() {
        let mut m = map(3.0);
        assert_eq!(m.cells().count(), 200);
        assert!(m.cells().all(|(_, v)| v == 0.1));
        // Two samples equally far from (5.5, 5.5): their plain mean.
        m.add(&Sample::new(p(4.5, 5.5), 2.0, 1.0).unwrap());
        m.add(&Sample::new(p(6.5, 5.5), 4.0, 1.0).unwrap());
        assert!((at(&m, p(5.5, 5.5)) - 3.0).abs() < 1e-12);
        // Nearer the first, nearer its value.
        assert!(at(&m, p(4.5, 5.5)) < 3.0);
        // Beyond the radius of both: the prior.
        assert_eq!(at(&m, p(12.5, 5.5)), 0.1);
        assert_eq!(at(&m, p(5.5, 9.5)), 0.1);
    }

    #[test]
    fn a_negative_mean_reads_as_zero_and_order_does_not_matter() {
        let (mut a, mut b) = (map(2.0), map(2.0));
        let s = [
            Sample::new(p(10.0, 5.0), -0.5, 1.0).unwrap(),
            Sample::new(p(10.5, 5.2), 0.2, 1.0).unwrap(),
        ];
        a.add(&s[0]);
        a.add(&s[1]);
        b.add(&s[1]);
        b.add(&s[0]);
        assert!(a.cells().all(|(_, v)| v >= 0.0));
        assert_eq!(at(&a, p(9.5, 4.5)), 0.0);
        for ((_, x), (_, y)) in a.cells().zip(b.cells()) {
            assert!((x - y).abs() <= 1e-15 * x.abs().max(1.0));
        }
    }
}
