//! A range-limited radio on the medium, as MOOS-IvP's uFldNodeComms: the
//! packets between two vessels farther apart than R are dropped
//! ([`Medium::cut_pairs`](super::netns::Medium::cut_pairs)), from the
//! positions the observer hears, re-evaluated at a fixed interval of wall
//! time (the medium's lists change only when the set of cut pairs does).

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use super::fleet::Fleet;
use super::paper::Pos;

pub(crate) struct Range {
    range: f64,
    period: Duration,
    last: Instant,
    /// The pairs (hosts a < b) cut now.
    pub cut: BTreeSet<(usize, usize)>,
    /// Every pair ever cut, the most at once, the changes made.
    pub ever: BTreeSet<(usize, usize)>,
    pub most: usize,
    pub updates: usize,
    /// The longest interval between two evaluations.
    pub slowest: Duration,
}

impl Range {
    /// Cuts the pairs of `fleet` farther apart than `range` at `at`
    /// (usv-i in host i, in id order), to be followed every `period`.
    pub(crate) fn start(fleet: &Fleet, at: &[Pos], range: f64, period: Duration) -> Range {
        let cut = out_of_range(at, range);
        fleet
            .medium
            .cut_pairs(&cut.iter().copied().collect::<Vec<_>>());
        Range {
            range,
            period,
            last: Instant::now(),
            most: cut.len(),
            ever: cut.clone(),
            cut,
            updates: 0,
            slowest: Duration::ZERO,
        }
    }

    /// Cuts by the fleet's newest positions, once `period` has passed
    /// since the last time (for [`Fleet::run_until`]).
    pub(crate) fn follow(&mut self, fleet: &Fleet) {
        if self.last.elapsed() < self.period {
            return;
        }
        self.slowest = self.slowest.max(self.last.elapsed());
        self.last = Instant::now();
        let now_cut = out_of_range(&fleet.positions(), self.range);
        if now_cut != self.cut {
            fleet
                .medium
                .cut_pairs(&now_cut.iter().copied().collect::<Vec<_>>());
            self.updates += 1;
            self.most = self.most.max(now_cut.len());
            self.ever.extend(now_cut.iter().copied());
            self.cut = now_cut;
        }
    }
}

/// The host pairs (a < b; vessel i in host i + 1) farther apart than
/// `range` at `at`.
fn out_of_range(at: &[Pos], range: f64) -> BTreeSet<(usize, usize)> {
    let mut pairs = BTreeSet::new();
    for a in 0..at.len() {
        for b in a + 1..at.len() {
            if (at[a].x - at[b].x).hypot(at[a].y - at[b].y) > range {
                pairs.insert((a + 1, b + 1));
            }
        }
    }
    pairs
}
