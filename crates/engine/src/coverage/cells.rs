//! The cells of any fleet: the power diagram of [`partition`](super::partition)
//! when every vessel has the same β (straight edges), the curved cells of
//! [`mixed`](super::mixed) otherwise. Callers outside the partition code
//! use these two functions only.

use super::fleet::Fleet;
use super::mixed::{mixed_cell, mixed_cells};
use super::partition::{CellGeometry, power_cell, power_cells_with};
use crate::geometry::Region;

/// Every vessel's cell, in the fleet's order, on every core when
/// `parallel` and the fleet is large enough (the same result either way).
pub fn cells_with(region: &Region, fleet: &Fleet, parallel: bool) -> Vec<CellGeometry> {
    match fleet.common_beta() {
        Some(_) => power_cells_with(region, fleet, parallel),
        None => mixed_cells(region, fleet, parallel),
    }
}

/// Vessel `i`'s cell alone: the same as `cells_with(region, fleet, _)[i]`.
pub fn cell(region: &Region, fleet: &Fleet, i: usize) -> CellGeometry {
    match fleet.common_beta() {
        Some(_) => power_cell(region, fleet, i),
        None => mixed_cell(region, fleet, i),
    }
}
