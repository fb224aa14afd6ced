//! The coverage engine of the paper (sections 2–3): risk density Φ,
//! actuator performance f_i, the generalized Voronoi (power) partition,
//! cell mass and centroid, the metric H(P) and its gradient.
//!
//! Invariants:
//! - pure and deterministic: no I/O, no threads, no clocks, no randomness;
//! - inputs are validated once, by the constructors [`RiskField::new`] and
//!   [`Fleet::new`] (and [`crate::geometry::Region::new`]); after that
//!   [`evaluate()`] cannot fail: an empty cell is a result (mass 0, centroid the
//!   nearest point of Q), never an error or a NaN;
//! - cost grows as O(n log n) in the number of vessels (see [`partition`])
//!   when β is common; with mixed β, as the vessels within each one's reach
//!   (see [`mixed`]).
//!
//! Code map: [`density`] Φ; [`fleet`] f_i and the vessels; [`cells`] the
//! cells of any fleet: [`partition`] the power diagram (one β),
//! [`dominance`] and [`mixed`] curved cells (several β); [`integrate`] the
//! integrals of one straight-edged cell, by [`boundary`] edge integrals
//! (default) or adaptive triangle quadrature (reference), [`curved`] those
//! of a curved cell;
//! [`evaluate`](mod@evaluate) ties them together; [`range`] is one vessel's
//! range-limited cell in a peer fleet, [`split`] the plan of a peer fleet
//! split in two groups; [`goal`] turns a centroid
//! into a goal a vessel can reach among islands; [`grid_lloyd`] is
//! Lloyd's centroid on a gridded density (a baseline for learning).

pub mod boundary;
pub mod cells;
pub mod curved;
#[cfg(test)]
mod curved_reference;
pub mod density;
pub mod dominance;
mod erfc;
pub mod evaluate;
pub mod fleet;
pub mod gaussian;
pub mod goal;
mod grid;
pub mod grid_lloyd;
pub mod integrate;
pub mod mixed;
pub mod partition;
pub mod range;
pub mod split;

pub use density::{RiskField, RiskObject};
pub use evaluate::{CellResult, Evaluation, Options, evaluate};
pub use fleet::{Fleet, Vessel};
pub use partition::CellGeometry;

/// The fewest vessels for which [`Options::parallel`] spreads the work over
/// threads: below it a cell takes microseconds and handing cells to the
/// pool costs more than it saves.
pub const PARALLEL_MIN: usize = 64;

/// `f(0) … f(n − 1)` in order, on every core (rayon) when `parallel`, else on
/// this thread. Each worker gets its own scratch buffer (`B::default()`), so
/// `f` allocates nothing per item; the result is the same either way as
/// long as `f` depends only on its index.
pub fn map_indexed<T, B, F>(n: usize, parallel: bool, f: F) -> Vec<T>
where
    T: Send,
    B: Default,
    F: Fn(usize, &mut B) -> T + Sync,
{
    if parallel {
        use rayon::prelude::*;
        (0..n)
            .into_par_iter()
            .map_init(B::default, |buffer, i| f(i, buffer))
            .collect()
    } else {
        let mut buffer = B::default();
        (0..n).map(|i| f(i, &mut buffer)).collect()
    }
}

/// `f(i, items[i])` for every item, in order, on every core (rayon) when
/// `parallel`, else on this thread; [`map_indexed`] over owned items. Each
/// worker gets its own scratch buffer (`B::default()`); the result is the
/// same either way as long as `f` depends only on its arguments.
pub fn map_each<T, R, B, F>(items: Vec<T>, parallel: bool, f: F) -> Vec<R>
where
    T: Send,
    R: Send,
    B: Default,
    F: Fn(usize, T, &mut B) -> R + Sync,
{
    if parallel {
        use rayon::prelude::*;
        items
            .into_par_iter()
            .enumerate()
            .map_init(B::default, |buffer, (i, item)| f(i, item, buffer))
            .collect()
    } else {
        let mut buffer = B::default();
        items
            .into_iter()
            .enumerate()
            .map(|(i, item)| f(i, item, &mut buffer))
            .collect()
    }
}

/// Why inputs to the engine were rejected. Messages name the offending field
/// with the path a scenario document uses (`vessels[3].k`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    /// The task region is not valid.
    #[error(transparent)]
    Region(#[from] crate::geometry::RegionError),
    /// A value is out of range or malformed.
    #[error("{field}: {reason}")]
    Invalid {
        /// The offending field, as a scenario document names it.
        field: String,
        /// What is wrong with its value.
        reason: String,
    },
    /// A well-formed value asks for something the engine does not do.
    #[error("{field}: {reason}")]
    Unsupported {
        /// The offending field, as a scenario document names it.
        field: String,
        /// What is not supported.
        reason: String,
    },
}

impl InputError {
    /// An [`InputError::Invalid`] naming `field`, saying `reason`.
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        InputError::Invalid {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

/// Checks that `value` is finite and within `(low, high]` (or `[low, high]`
/// when `low_inclusive`).
pub(crate) fn check_range(
    field: impl Fn() -> String,
    value: f64,
    low: f64,
    low_inclusive: bool,
    high: f64,
) -> Result<(), InputError> {
    let above = if low_inclusive {
        value >= low
    } else {
        value > low
    };
    if value.is_finite() && above && value <= high {
        Ok(())
    } else {
        let bracket = if low_inclusive { '[' } else { '(' };
        Err(InputError::invalid(
            field(),
            format!(
                "must be a finite number in {bracket}{}, {}], got {value}",
                readable(low),
                readable(high)
            ),
        ))
    }
}

/// 0, 0.5, 100 as written; 1e12, -1e7, 1e-6 in exponent form.
fn readable(x: f64) -> String {
    if x != 0.0 && (x.abs() >= 1e4 || x.abs() < 1e-3) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}
