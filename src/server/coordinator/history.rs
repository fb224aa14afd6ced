//! The H(P) history of a mission, bounded: what `GET /api/v1/coverage/history`
//! answers and the dashboard's H chart starts from.
//!
//! Every tick is kept until [`CAPACITY`] samples are held; then every
//! other sample is dropped (the first, the mission's start, stays) and the
//! stride doubles, so the history always spans the whole mission with
//! fewer than `CAPACITY` samples (at least half as many once it has been
//! full) `stride` ticks apart, whatever its length: at 10 Hz, every tick
//! for 100 s, every second tick up to 200 s, every fourth up to 400 s, and
//! so on. Keeping a sample costs O(1) amortised (a halving every
//! `CAPACITY / 2` samples).
//!
//! The tick task owns it; readers get an `Arc` of the document in each
//! published [`Snapshot`](super::Snapshot). The document is copied only
//! when a sample is kept while readers still hold the previous one
//! (`Arc::make_mut`): at most 1000 samples of 24 bytes. The replay keeps
//! one over the recording's coverage channel by the same rules.

use std::sync::Arc;

use crate::protocol::{CoverageHistoryDocument, CoverageSampleDocument};

/// The most samples a history holds (even, so a halving keeps the first).
pub(crate) const CAPACITY: usize = 1000;

/// A bounded, decimated H(P) history.
#[derive(Debug, Clone)]
pub(crate) struct History {
    document: Arc<CoverageHistoryDocument>,
}

impl Default for History {
    fn default() -> Self {
        History::new()
    }
}

impl History {
    pub(crate) fn new() -> History {
        History {
            document: Arc::new(CoverageHistoryDocument {
                stride: 1,
                samples: Vec::new(),
            }),
        }
    }

    /// Takes H at `tick` (mission time `time`): kept when it is the first or
    /// at least `stride` ticks after the last kept one (a tick published
    /// twice, or out of order, is not kept again); `true` when kept.
    pub(crate) fn push(&mut self, tick: u64, time: f64, h: f64) -> bool {
        let due = self
            .document
            .samples
            .last()
            .is_none_or(|last| tick >= last.tick + self.document.stride);
        if !due {
            return false;
        }
        let document = Arc::make_mut(&mut self.document);
        document
            .samples
            .push(CoverageSampleDocument { tick, time, h });
        if document.samples.len() >= CAPACITY {
            let mut k = 0;
            document.samples.retain(|_| {
                k += 1;
                k % 2 == 1
            });
            document.stride *= 2;
        }
        true
    }

    /// The history as readers get it.
    pub(crate) fn document(&self) -> Arc<CoverageHistoryDocument> {
        self.document.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// H at a tick, a value no sample could be confused with another's.
    fn h(tick: u64) -> f64 {
        (tick as f64).sqrt() + 0.25
    }

    #[test]
    fn every_tick_is_kept_until_the_history_is_full() {
        let mut history = History::new();
        for tick in 1..CAPACITY as u64 {
            assert!(history.push(tick, tick as f64 * 0.1, h(tick)));
            // A second publication of the same tick (a mission change)
            // adds nothing.
            assert!(!history.push(tick, tick as f64 * 0.1, h(tick)));
        }
        let doc = history.document();
        assert_eq!((doc.stride, doc.samples.len()), (1, CAPACITY - 1));
        assert!(doc.samples.iter().zip(1..).all(|(s, t)| s.tick == t));
    }

    #[test]
    fn a_long_mission_stays_bounded_and_reaches_back_to_its_start() {
        let mut history = History::new();
        let mut most = 0;
        // A million ticks (28 hours at 10 Hz), with runs of skipped ticks
        // (an overrunning tick skips the next ones; their numbers stay).
        let mut tick = 0;
        while tick < 1_000_000 {
            tick += if tick % 977 == 500 { 3 } else { 1 };
            history.push(tick, tick as f64 * 0.1, h(tick));
            most = most.max(history.document().samples.len());
        }
        let doc = history.document();
        assert!(most <= CAPACITY, "{most} samples held");
        assert!(
            doc.samples.len() >= CAPACITY / 2,
            "{} samples",
            doc.samples.len()
        );
        assert!(doc.stride.is_power_of_two() && doc.stride > 1);
        // From the mission's first tick …
        assert_eq!(doc.samples[0].tick, 1);
        // … to the newest but for less than a stride (a skipped tick may
        // overshoot by 2) …
        let last = doc.samples.last().unwrap().tick;
        assert!(tick - last <= doc.stride + 2, "last {last}, now {tick}");
        // … `stride` apart, or a little more where ticks were skipped (each
        // skip inside a gap widens it by at most 2), each sample the value
        // its tick had.
        for pair in doc.samples.windows(2) {
            let gap = pair[1].tick - pair[0].tick;
            assert!(
                gap >= doc.stride && gap - doc.stride <= 2 * (gap / 977 + 1),
                "gap {gap} at stride {}",
                doc.stride
            );
        }
        for s in &doc.samples {
            assert_eq!((s.h, s.time), (h(s.tick), s.tick as f64 * 0.1));
        }
    }

    #[test]
    fn readers_keep_the_history_they_were_given() {
        let mut history = History::new();
        history.push(1, 0.1, 1.0);
        let given = history.document();
        history.push(2, 0.2, 2.0);
        assert_eq!(given.samples.len(), 1);
        assert_eq!(history.document().samples.len(), 2);
    }
}
