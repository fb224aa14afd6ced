//! A learned belief as documents: the density the fleet covers as a
//! mission's risk, and its uncertainty as a grid (docs/learning.md).
//!
//! Invariants: the grid covers the bounding box it is given with square
//! cells, [`CELLS`] along its longer side, and holds `nx · ny` finite,
//! non-negative values.

use seacover_engine::coverage::RiskField;
use seacover_engine::geometry::Point;
use seacover_engine::learning::Belief;
use seacover_protocol::{RiskDocument, RiskObjectDocument, UncertaintyDocument};

/// Cells along the grid's longer side: enough to see which water has been
/// measured, small enough to send every fit (1600 values for a square).
pub const CELLS: u32 = 40;

/// A density as a mission's risk document (objects without ids).
pub fn risk_document(field: &RiskField) -> RiskDocument {
    RiskDocument {
        base: field.base(),
        objects: field
            .objects()
            .iter()
            .map(|o| RiskObjectDocument {
                id: None,
                x: o.center.x,
                y: o.center.y,
                alpha: o.alpha,
                sigma: o.sigma,
            })
            .collect(),
    }
}

/// The belief's posterior standard deviation of Φ over the box `min`–`max`.
///
/// ```
/// use seacover_engine::coverage::RiskField;
/// use seacover_engine::geometry::Point;
/// use seacover_engine::learning::{Lattice, Learner, Params, Sample};
///
/// let (min, max) = (Point { x: 0.0, y: 0.0 }, Point { x: 100.0, y: 50.0 });
/// let lattice = Lattice::over(min, max, 10.0).unwrap();
/// let prior = RiskField::new(1.0, vec![]).unwrap();
/// let mut learner = Learner::new(lattice, prior, Params::default());
/// // A survey of the south-west corner, every 2 m.
/// for (i, j) in (0..=10).flat_map(|i| (0..=5).map(move |j| (i, j))) {
///     let q = Point { x: 2.0 * f64::from(i), y: 2.0 * f64::from(j) };
///     learner.add(Sample::new(q, 1.0, 0.05).unwrap());
/// }
/// let grid = seacover_mission::belief::uncertainty(&learner.fit(), min, max);
/// assert_eq!((grid.nx, grid.ny), (40, 20));
/// // Measured water (the south-west) is known far better than the rest.
/// assert!(grid.sd[0] < grid.sd[grid.sd.len() - 1] / 100.0);
/// ```
pub fn uncertainty(belief: &Belief, min: Point, max: Point) -> UncertaintyDocument {
    let (w, h) = ((max.x - min.x).max(0.0), (max.y - min.y).max(0.0));
    let step = (w.max(h) / f64::from(CELLS)).max(1e-3);
    let count = |side: f64| ((side / step).ceil() as u32).clamp(1, CELLS);
    let (nx, ny) = (count(w), count(h));
    let mut sd = Vec::with_capacity((nx * ny) as usize);
    for j in 0..ny {
        for i in 0..nx {
            let q = Point {
                x: min.x + (f64::from(i) + 0.5) * step,
                y: min.y + (f64::from(j) + 0.5) * step,
            };
            let s = belief.sd_at(q);
            sd.push(if s.is_finite() { s } else { 0.0 });
        }
    }
    UncertaintyDocument {
        x0: min.x,
        y0: min.y,
        step,
        nx,
        ny,
        sd,
    }
}
