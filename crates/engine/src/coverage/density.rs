//! Risk density Φ(q) = φ0 + Σ_j α_j exp(−‖q − s_j‖² / (2 σ_j²))  (paper eq. 5).
//!
//! Objects sit in an R-tree so that a cell only looks at the objects that can
//! change its integrals by more than a fraction of the tolerance; far objects
//! are cut off with a bound, not a guess (see [`RiskField::objects_near`]).
//! Objects of one σ whose centres lie on a grid (a learned belief's lattice,
//! docs/learning.md) are found once, here, so that a cell can integrate
//! them together ([`ObjectGrid`]).

use rstar::RTree;
use rstar::primitives::GeomWithData;

use super::{InputError, check_range};
use crate::geometry::region::MAX_COORDINATE;
use crate::geometry::{Point, norm2};

/// Largest α, φ0 accepted.
pub const MAX_DENSITY: f64 = 1.0e12;
/// Most risk objects accepted.
pub const MAX_OBJECTS: usize = 10_000;

/// One Gaussian risk object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RiskObject {
    /// Its centre s_j [m].
    pub center: Point,
    /// Its peak α_j > 0: what it adds to φ0 at its centre (paper eq. 5).
    pub alpha: f64,
    /// Its spread σ_j > 0 [m] (paper eq. 5).
    pub sigma: f64,
}

/// The most objects of one σ, when their centres fill at least a quarter of
/// the points of a grid (columns × rows of their distinct coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectGrid {
    /// Their common σ [m].
    pub sigma: f64,
    /// The columns' x, increasing.
    pub xs: Vec<f64>,
    /// The rows' y, increasing.
    pub ys: Vec<f64>,
    /// Per object: its (column, row), or `None` for an object off the grid.
    pub at: Vec<Option<(u32, u32)>>,
}

/// Fewest objects worth a grid: below, one by one is as cheap.
const GRID_MIN: usize = 16;

impl ObjectGrid {
    /// The grid of `objects`, if they have one.
    fn find(objects: &[RiskObject]) -> Option<ObjectGrid> {
        let mut count = std::collections::BTreeMap::new();
        for o in objects {
            *count.entry(o.sigma.to_bits()).or_insert(0usize) += 1;
        }
        // The most common σ; the smallest of equally common ones.
        let (&bits, &n) = count
            .iter()
            .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))?;
        let sigma = f64::from_bits(bits);
        if n < GRID_MIN {
            return None;
        }
        let distinct = |f: fn(&RiskObject) -> f64| {
            let mut v: Vec<f64> = objects.iter().filter(|o| o.sigma == sigma).map(f).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        };
        let (xs, ys) = (distinct(|o| o.center.x), distinct(|o| o.center.y));
        if xs.len() * ys.len() > 4 * n {
            return None;
        }
        let index = |v: &[f64], x: f64| v.binary_search_by(|y| y.total_cmp(&x)).ok();
        let at = objects
            .iter()
            .map(|o| {
                let i = index(&xs, o.center.x)?;
                let j = index(&ys, o.center.y)?;
                (o.sigma == sigma).then_some((i as u32, j as u32))
            })
            .collect();
        Some(ObjectGrid { sigma, xs, ys, at })
    }
}

/// A validated risk density.
#[derive(Debug, Clone)]
pub struct RiskField {
    base: f64,
    objects: Vec<RiskObject>,
    grid: Option<ObjectGrid>,
    tree: RTree<GeomWithData<[f64; 2], usize>>,
    alpha_max: f64,
    sigma_max: f64,
}

impl RiskField {
    /// Validates φ0 ≥ 0 and every object's α > 0, σ > 0 and position.
    pub fn new(base: f64, objects: Vec<RiskObject>) -> Result<Self, InputError> {
        check_range(|| "risk.base".into(), base, 0.0, true, MAX_DENSITY)?;
        if objects.len() > MAX_OBJECTS {
            return Err(InputError::invalid(
                "risk.objects",
                format!("at most {MAX_OBJECTS} objects"),
            ));
        }
        for (i, o) in objects.iter().enumerate() {
            let f = |name: &str| format!("risk.objects[{i}].{name}");
            check_range(|| f("x"), o.center.x, -MAX_COORDINATE, true, MAX_COORDINATE)?;
            check_range(|| f("y"), o.center.y, -MAX_COORDINATE, true, MAX_COORDINATE)?;
            check_range(|| f("alpha"), o.alpha, 0.0, false, MAX_DENSITY)?;
            check_range(|| f("sigma"), o.sigma, 0.0, false, MAX_COORDINATE)?;
            // σ so small that 1/(2σ²) overflows is not a density anyone means.
            if o.sigma < 1e-6 {
                return Err(InputError::invalid(f("sigma"), "must be at least 1e-6 m"));
            }
        }
        let tree = RTree::bulk_load(
            objects
                .iter()
                .enumerate()
                .map(|(i, o)| GeomWithData::new([o.center.x, o.center.y], i))
                .collect(),
        );
        let alpha_max = objects.iter().map(|o| o.alpha).fold(0.0, f64::max);
        let sigma_max = objects.iter().map(|o| o.sigma).fold(0.0, f64::max);
        Ok(RiskField {
            base,
            grid: ObjectGrid::find(&objects),
            objects,
            tree,
            alpha_max,
            sigma_max,
        })
    }

    /// φ0.
    pub fn base(&self) -> f64 {
        self.base
    }

    /// The objects, in the order given.
    pub fn objects(&self) -> &[RiskObject] {
        &self.objects
    }

    /// The objects that lie on one grid, if enough do.
    pub fn grid(&self) -> Option<&ObjectGrid> {
        self.grid.as_ref()
    }

    /// Φ(q).
    pub fn value(&self, q: Point) -> f64 {
        self.base
            + self
                .objects
                .iter()
                .map(|o| o.alpha * (-norm2(q - o.center) / (2.0 * o.sigma * o.sigma)).exp())
                .sum::<f64>()
    }

    /// Φ's range (largest less smallest) over the box `min`–`max`, read on
    /// a grid of at most 501 × 501 points 1 m apart or closer: what a
    /// sensor's noise is given as a share of.
    pub fn range_over(&self, min: Point, max: Point) -> f64 {
        let steps = |a: f64, b: f64| ((b - a).ceil() as usize).clamp(1, 500);
        let (nx, ny) = (steps(min.x, max.x), steps(min.y, max.y));
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for j in 0..=ny {
            for i in 0..=nx {
                let q = Point {
                    x: min.x + (max.x - min.x) * i as f64 / nx as f64,
                    y: min.y + (max.y - min.y) * j as f64 / ny as f64,
                };
                let v = self.value(q);
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        hi - lo
    }

    /// Indices of the objects that can matter on the box [min, max]: every
    /// object left out is bounded on the box by `rel · φ0 / m` (m objects), so
    /// together they change any integral of f·Φ over the box by at most a
    /// relative `rel`. With φ0 = 0 there is no such floor and all objects are
    /// returned (the integrator still drops negligible terms per cell).
    pub fn objects_near(&self, min: Point, max: Point, rel: f64, out: &mut Vec<usize>) {
        out.clear();
        if self.objects.is_empty() {
            return;
        }
        if self.base <= 0.0 {
            out.extend(0..self.objects.len());
            return;
        }
        let m = self.objects.len() as f64;
        // α e^{−d²/2σ²} ≤ rel φ0 / m  ⇐  d ≥ σ √(2 ln(α m / (rel φ0))).
        let ratio = self.alpha_max * m / (rel * self.base);
        let cutoff = if ratio > 1.0 {
            self.sigma_max * (2.0 * ratio.ln()).sqrt()
        } else {
            0.0
        };
        let center = [(min.x + max.x) * 0.5, (min.y + max.y) * 0.5];
        let half_diag = 0.5 * ((max.x - min.x).hypot(max.y - min.y));
        let r = half_diag + cutoff;
        out.extend(
            self.tree
                .locate_within_distance(center, r * r)
                .map(|g| g.data),
        );
        // Deterministic order whatever the tree's traversal order.
        out.sort_unstable();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obj(x: f64, y: f64, alpha: f64, sigma: f64) -> RiskObject {
        RiskObject {
            center: Point { x, y },
            alpha,
            sigma,
        }
    }

    #[test]
    fn value_matches_formula() {
        let f = RiskField::new(0.1, vec![obj(0.0, 0.0, 2.0, 10.0)]).unwrap();
        let v = f.value(Point { x: 10.0, y: 0.0 });
        assert!((v - (0.1 + 2.0 * (-0.5f64).exp())).abs() < 1e-15);
    }

    #[test]
    fn rejects_bad_values() {
        for (alpha, sigma) in [
            (0.0, 1.0),
            (-1.0, 1.0),
            (1.0, 0.0),
            (1.0, -2.0),
            (f64::NAN, 1.0),
            (1.0, f64::INFINITY),
        ] {
            let e = RiskField::new(
                0.1,
                vec![obj(0.0, 0.0, 1.0, 1.0), obj(0.0, 0.0, alpha, sigma)],
            )
            .unwrap_err();
            assert!(e.to_string().starts_with("risk.objects[1]."), "{e}");
        }
        assert!(
            RiskField::new(-0.1, vec![])
                .unwrap_err()
                .to_string()
                .starts_with("risk.base")
        );
    }

    #[test]
    fn far_objects_are_cut_off_with_a_bound() {
        let objs = vec![obj(0.0, 0.0, 10.0, 10.0), obj(1000.0, 0.0, 10.0, 10.0)];
        let f = RiskField::new(0.1, objs).unwrap();
        let mut out = vec![];
        f.objects_near(
            Point { x: -5.0, y: -5.0 },
            Point { x: 5.0, y: 5.0 },
            1e-12,
            &mut out,
        );
        assert_eq!(out, vec![0]);
        // The dropped object really is negligible on the box.
        let worst = 10.0 * (-(995.0f64).powi(2) / 200.0).exp();
        assert!(worst <= 1e-12 * 0.1 / 2.0);
    }
}
