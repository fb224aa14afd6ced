//! The split plan computed off a vessel's loop: for a large group it takes
//! longer than a tick (docs/performance.md, "The split plan"), and the loop
//! also steps the hull and sends beacons. One job at a time: a newer job
//! replaces the one being computed, whose result is then never taken.

use tokio::sync::oneshot::{self, error::TryRecvError};

use crate::agent::peer::split::{Job, Planned};

/// The plan being computed, if one is.
#[derive(Debug, Default)]
pub(super) struct OffTick(Option<oneshot::Receiver<Planned>>);

impl OffTick {
    /// Computes `job` on tokio's blocking pool (in a runtime).
    pub(super) fn spawn(&mut self, job: Job) {
        let (tx, rx) = oneshot::channel();
        tokio::task::spawn_blocking(move || {
            // A dropped receiver (a newer job, the vessel gone): no one
            // wants this plan any more.
            let _ = tx.send(job.compute());
        });
        self.0 = Some(rx);
    }

    /// The result, once it has come (once).
    pub(super) fn arrived(&mut self, vessel: &str) -> Option<Planned> {
        let result = self.0.as_mut()?.try_recv();
        if matches!(result, Err(TryRecvError::Empty)) {
            return None;
        }
        self.0 = None;
        result
            .inspect_err(|_| tracing::error!(vessel, "fleet split: the plan's computation failed"))
            .ok()
    }
}
