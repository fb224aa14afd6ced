//! Vessels and their actuator performance f_i(q) = k_i exp(−β_i ‖q − p_i‖²)
//! (paper eq. 4).
//!
//! Invariant of a [`Fleet`]: at least one vessel, every k_i, β_i positive and
//! finite, positions within range. With a common β the partition f_i ≥ f_j
//! is a power diagram with straight edges ([`partition`](super::partition));
//! with different β an edge between two reaches is a circle
//! ([`dominance`](super::dominance), [`mixed`](super::mixed)).

use super::{InputError, check_range};
use crate::geometry::Point;
use crate::geometry::region::MAX_COORDINATE;

/// Most vessels accepted.
pub const MAX_VESSELS: usize = 10_000;
/// Largest k accepted.
pub const MAX_K: f64 = 1.0e12;
/// Largest β accepted (1/√β ≥ 1 mm).
pub const MAX_BETA: f64 = 1.0e6;

/// The paper's actuator gain k.
pub const DEFAULT_K: f64 = 0.5;
/// The paper's actuator decay β (1/m²).
pub const DEFAULT_BETA: f64 = 0.001;

/// One vessel as the engine sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vessel {
    /// p_i, in the region's plane [m].
    pub position: Point,
    /// The actuator's gain k_i > 0: its performance at p_i itself (paper
    /// eq. 4).
    pub k: f64,
    /// The actuator's decay β_i > 0 [1/m²]: the larger, the shorter the
    /// vessel's reach (paper eq. 4).
    pub beta: f64,
}

impl Vessel {
    /// f_i(q).
    pub fn performance(&self, q: Point) -> f64 {
        self.k * (-self.beta * crate::geometry::norm2(q - self.position)).exp()
    }
}

/// A validated, non-empty fleet.
#[derive(Debug, Clone)]
pub struct Fleet {
    vessels: Vec<Vessel>,
    /// β when every vessel has the same one (bit for bit).
    common_beta: Option<f64>,
}

impl Fleet {
    /// Validates at least one and at most [`MAX_VESSELS`] vessels, each with
    /// a position within ±[`MAX_COORDINATE`], 0 < k ≤ [`MAX_K`] and
    /// 0 < β ≤ [`MAX_BETA`]; errors name the field (`vessels[3].k`).
    pub fn new(vessels: Vec<Vessel>) -> Result<Self, InputError> {
        if vessels.is_empty() {
            return Err(InputError::invalid(
                "vessels",
                "at least one vessel is required",
            ));
        }
        if vessels.len() > MAX_VESSELS {
            return Err(InputError::invalid(
                "vessels",
                format!("at most {MAX_VESSELS} vessels"),
            ));
        }
        for (i, v) in vessels.iter().enumerate() {
            let f = |name: &str| format!("vessels[{i}].{name}");
            check_range(
                || f("x"),
                v.position.x,
                -MAX_COORDINATE,
                true,
                MAX_COORDINATE,
            )?;
            check_range(
                || f("y"),
                v.position.y,
                -MAX_COORDINATE,
                true,
                MAX_COORDINATE,
            )?;
            check_range(|| f("k"), v.k, 0.0, false, MAX_K)?;
            check_range(|| f("beta"), v.beta, 0.0, false, MAX_BETA)?;
        }
        let beta = vessels[0].beta;
        let common_beta = vessels.iter().all(|v| v.beta == beta).then_some(beta);
        Ok(Fleet {
            vessels,
            common_beta,
        })
    }

    /// The vessels, in the order given.
    pub fn vessels(&self) -> &[Vessel] {
        &self.vessels
    }

    /// The number of vessels (at least one).
    pub fn len(&self) -> usize {
        self.vessels.len()
    }

    /// Whether the fleet has no vessels: never, as [`Fleet::new`] refuses
    /// an empty one.
    pub fn is_empty(&self) -> bool {
        self.vessels.is_empty()
    }

    /// The β every vessel shares, or `None` in a fleet of different
    /// reaches (curved cell edges).
    pub fn common_beta(&self) -> Option<f64> {
        self.common_beta
    }
}
