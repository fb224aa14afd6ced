//! The wall time of a vessel's newest steps on board, for its status
//! (`step_time`): what a node's loop costs, measured where it runs rather
//! than estimated from a benchmark (docs/peer.md, "A hundred vessels").

use std::collections::VecDeque;
use std::time::Duration;

use crate::protocol::peer::StepTimeDocument;

/// Steps kept: at 10 Hz, the last 10 s of mission time.
const KEPT: usize = 100;

/// The newest [`KEPT`] steps' durations.
#[derive(Debug, Default)]
pub(super) struct StepTimes(VecDeque<Duration>);

impl StepTimes {
    pub(super) fn record(&mut self, took: Duration) {
        if self.0.len() == KEPT {
            self.0.pop_front();
        }
        self.0.push_back(took);
    }

    /// Their median and longest; `None` before the first.
    pub(super) fn document(&self) -> Option<StepTimeDocument> {
        let mut ms: Vec<f64> = self.0.iter().map(|d| d.as_secs_f64() * 1e3).collect();
        if ms.is_empty() {
            return None;
        }
        ms.sort_by(f64::total_cmp);
        let n = ms.len();
        let median = if n % 2 == 1 {
            ms[n / 2]
        } else {
            (ms[n / 2 - 1] + ms[n / 2]) / 2.0
        };
        Some(StepTimeDocument {
            steps: n as u32,
            median_ms: median,
            max_ms: ms[n - 1],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_newest_hundred_and_reports_their_median_and_longest() {
        let mut times = StepTimes::default();
        assert_eq!(times.document(), None);
        // A slow first step that falls out of the window.
        times.record(Duration::from_millis(50));
        for i in 1..=KEPT as u64 {
            times.record(Duration::from_micros(i * 10));
        }
        let doc = times.document().unwrap();
        assert_eq!(doc.steps, KEPT as u32);
        assert!((doc.max_ms - 1.0).abs() < 1e-9, "{doc:?}");
        assert!((doc.median_ms - 0.505).abs() < 1e-9, "{doc:?}");
        times.record(Duration::from_millis(2));
        assert!((times.document().unwrap().max_ms - 2.0).abs() < 1e-9);
    }
}
