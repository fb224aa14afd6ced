//! The table's two indexes over the beacons it holds, so that a node's tick
//! looks at the vessels near it and the ones gone quiet, not at the fleet.
//!
//! - **By place**: a uniform grid of [`CELL`] m squares over the beacons'
//!   reported positions (a hash map of the occupied squares only: the
//!   positions a beacon may carry span 100 km). A square keeps each slot
//!   with its position, so a query rejects the slots outside its disc
//!   without reading the table (whose entries lie scattered in memory);
//!   the caller checks the exact reach of the rest.
//! - **By arrival**: oldest first. A beacon's age is its time since arrival
//!   plus its transit (at most [`MAX_TRANSIT`](super::table::MAX_TRANSIT)),
//!   so the ones that can be older than a limit are a prefix of this order,
//!   and the caller walks only that prefix.
//!
//! Invariants: every slot the table holds is in exactly one square (the
//! one of its newest beacon) and once in the arrival order (its newest
//! arrival); [`Index::remove`] with the key [`Index::place`] returned
//! undoes both.

use std::collections::BTreeMap;
use std::time::Instant;

use rustc_hash::FxHashMap;

/// Side of a square of the grid [m]: a quarter of what a vessel of the
/// paper's actuator reaches (2r ≈ 235 m plus 60 m of extrapolation), so a
/// query looks at some 100 squares, most of them inside its disc.
pub(super) const CELL: f64 = 64.0;

type Square = (i32, i32);

/// A slot as a square keeps it.
#[derive(Debug, Clone, Copy)]
struct Filed {
    slot: usize,
    x: f64,
    y: f64,
}

/// Where a slot is filed: its square and its place in the arrival order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Key {
    square: Square,
    arrival: (Instant, u64),
}

#[derive(Debug, Default)]
pub(super) struct Index {
    squares: FxHashMap<Square, Vec<Filed>>,
    arrivals: BTreeMap<(Instant, u64), usize>,
    /// Breaks ties between beacons that arrived at the same instant.
    counter: u64,
}

fn square_of(x: f64, y: f64) -> Square {
    // Positions are validated finite and within 50 km: no overflow.
    ((x / CELL).floor() as i32, (y / CELL).floor() as i32)
}

impl Index {
    /// Files `slot`, whose newest beacon is at (x, y) and arrived at
    /// `arrived`, in place of where `old` filed it.
    pub(super) fn place(
        &mut self,
        slot: usize,
        old: Option<Key>,
        (x, y): (f64, f64),
        arrived: Instant,
    ) -> Key {
        let square = square_of(x, y);
        if let Some(old) = old {
            self.arrivals.remove(&old.arrival);
            self.unfile(slot, old.square);
        }
        self.squares
            .entry(square)
            .or_default()
            .push(Filed { slot, x, y });
        self.counter += 1;
        let arrival = (arrived, self.counter);
        self.arrivals.insert(arrival, slot);
        Key { square, arrival }
    }

    /// Forgets `slot`, filed under `key`.
    pub(super) fn remove(&mut self, slot: usize, key: Key) {
        self.arrivals.remove(&key.arrival);
        self.unfile(slot, key.square);
    }

    fn unfile(&mut self, slot: usize, square: Square) {
        if let Some(slots) = self.squares.get_mut(&square) {
            if let Some(at) = slots.iter().position(|f| f.slot == slot) {
                slots.swap_remove(at);
            }
            if slots.is_empty() {
                self.squares.remove(&square);
            }
        }
    }

    /// The slots in arrival order, oldest first, with their arrival.
    pub(super) fn oldest(&self) -> impl Iterator<Item = (Instant, usize)> + '_ {
        self.arrivals.iter().map(|(&(at, _), &slot)| (at, slot))
    }

    /// Every slot whose newest beacon is within the disc of `radius` about
    /// `centre`, or `None` when the disc touches more squares than `limit`
    /// (the caller then walks every slot: an unbounded or fleet-wide
    /// disc).
    pub(super) fn near(
        &self,
        centre: (f64, f64),
        radius: f64,
        limit: usize,
    ) -> Option<impl Iterator<Item = usize> + '_> {
        if !radius.is_finite() {
            return None;
        }
        let (x0, y0) = square_of(centre.0 - radius, centre.1 - radius);
        let (x1, y1) = square_of(centre.0 + radius, centre.1 + radius);
        let span = (i64::from(x1) - i64::from(x0) + 1) * (i64::from(y1) - i64::from(y0) + 1);
        if span > limit as i64 {
            return None;
        }
        let r2 = radius * radius;
        let inside = move |f: &&Filed| {
            let (dx, dy) = (f.x - centre.0, f.y - centre.1);
            dx * dx + dy * dy <= r2
        };
        Some((x0..=x1).flat_map(move |i| {
            (y0..=y1)
                .filter_map(move |j| self.squares.get(&(i, j)))
                .flatten()
                .filter(inside)
                .map(|f| f.slot)
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_slot_is_found_where_its_newest_beacon_is_and_only_there() {
        let mut index = Index::default();
        let t0 = Instant::now();
        let a = index.place(0, None, (10.0, 10.0), t0);
        let b = index.place(1, None, (500.0, 10.0), t0);
        let near = |index: &Index, x: f64| {
            let mut v: Vec<usize> = index.near((x, 10.0), 20.0, 100).unwrap().collect();
            v.sort();
            v
        };
        assert_eq!(near(&index, 0.0), [0]);
        // Slot 0 moves next to slot 1, and arrives later.
        let a = index.place(0, Some(a), (490.0, 10.0), t0 + Duration::from_secs(1));
        assert_eq!(near(&index, 0.0), Vec::<usize>::new());
        assert_eq!(near(&index, 495.0), [0, 1]);
        let order: Vec<usize> = index.oldest().map(|(_, s)| s).collect();
        assert_eq!(order, [1, 0]);
        index.remove(1, b);
        assert_eq!(near(&index, 495.0), [0]);
        index.remove(0, a);
        assert!(index.squares.is_empty() && index.arrivals.is_empty());
    }

    #[test]
    fn a_disc_wider_than_the_limit_asks_for_a_walk() {
        let index = Index::default();
        assert!(index.near((0.0, 0.0), f64::INFINITY, 100).is_none());
        assert!(index.near((0.0, 0.0), 10.0 * CELL, 100).is_none());
        assert!(index.near((0.0, 0.0), 4.0 * CELL, 100).is_some());
    }
}
