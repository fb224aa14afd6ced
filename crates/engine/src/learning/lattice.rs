//! The belief's Gaussians: a square lattice over a box, every Gaussian of
//! spread equal to the spacing, so that neighbours overlap enough for a
//! smooth sum and few enough touch any point.
//!
//! Invariant: at most [`Lattice::MAX`] Gaussians; spacing > 0.

use crate::coverage::{InputError, check_range};
use crate::geometry::Point;
use crate::geometry::region::MAX_COORDINATE;

/// Centres on a square lattice over a box, of spacing (and spread) h.
#[derive(Debug, Clone, PartialEq)]
pub struct Lattice {
    origin: Point,
    spacing: f64,
    columns: usize,
    rows: usize,
}

/// Beyond this many spreads a Gaussian is below 4e-6 of its peak: left
/// out of the features.
const REACH: f64 = 5.0;

impl Lattice {
    /// The most Gaussians a lattice may have: the fit's dense matrices grow
    /// as its square.
    pub const MAX: usize = 2_500;

    /// The lattice of spacing `spacing` that covers the box [min, max]
    /// (centres on its corners and edges, one step apart).
    pub fn over(min: Point, max: Point, spacing: f64) -> Result<Self, InputError> {
        check_range(
            || "learning.spacing".into(),
            spacing,
            0.0,
            false,
            MAX_COORDINATE,
        )?;
        let count = |span: f64| (span / spacing).ceil().max(0.0) + 1.0;
        let (columns, rows) = (count(max.x - min.x), count(max.y - min.y));
        if columns * rows > Self::MAX as f64 {
            return Err(InputError::invalid(
                "learning.spacing",
                format!(
                    "{spacing} m gives {columns} × {rows} Gaussians; at most {} are allowed",
                    Self::MAX
                ),
            ));
        }
        Ok(Lattice {
            origin: min,
            spacing,
            columns: columns as usize,
            rows: rows as usize,
        })
    }

    /// How many Gaussians.
    pub fn len(&self) -> usize {
        self.columns * self.rows
    }

    /// Whether it has none (never, once built).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The spacing, which is also every Gaussian's spread σ [m].
    pub fn spacing(&self) -> f64 {
        self.spacing
    }

    /// Gaussian `k`'s centre.
    pub fn center(&self, k: usize) -> Point {
        let (i, j) = (k % self.columns, k / self.columns);
        Point {
            x: self.origin.x + i as f64 * self.spacing,
            y: self.origin.y + j as f64 * self.spacing,
        }
    }

    /// The Gaussians that matter at `q`, with their values there
    /// (exp(−‖q − c_k‖² / 2h²)), in index order, into `out`.
    pub fn features(&self, q: Point, out: &mut Vec<(usize, f64)>) {
        out.clear();
        let h = self.spacing;
        let span = |at: f64, from: f64, n: usize| {
            let lo = ((at - from) / h - REACH).ceil().max(0.0);
            let hi = ((at - from) / h + REACH).floor().min(n as f64 - 1.0);
            (lo as usize, hi)
        };
        let (i0, i1) = span(q.x, self.origin.x, self.columns);
        let (j0, j1) = span(q.y, self.origin.y, self.rows);
        if i1 < i0 as f64 || j1 < j0 as f64 {
            return;
        }
        for j in j0..=j1 as usize {
            for i in i0..=i1 as usize {
                let k = j * self.columns + i;
                let c = self.center(k);
                let d2 = (q.x - c.x).powi(2) + (q.y - c.y).powi(2);
                out.push((k, (-d2 / (2.0 * h * h)).exp()));
            }
        }
    }
}
