//! The state every handler and link shares ([`AppState`]): the way to the
//! tick task (its request channel and snapshot `watch`), shutdown and task
//! tracking, the write budget and the recorder. Cheap to clone; nothing in
//! it is locked across an `.await`.

use std::num::NonZeroU32;
use std::sync::Arc;
use std::sync::atomic::AtomicU64;

use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use super::coordinator::{Request, Snapshot};
use crate::mission::MissionClock;
use crate::recorder::Recorder;

/// Shared by every handler; cheap to clone.
#[derive(Clone)]
pub struct AppState {
    /// Required for writes and vessel links when set.
    pub token: Option<Arc<str>>,
    pub requests: mpsc::Sender<Request>,
    pub snapshot: watch::Receiver<Arc<Snapshot>>,
    pub tracker: TaskTracker,
    pub shutdown: CancellationToken,
    pub next_link: Arc<AtomicU64>,
    /// One token bucket for every write of every client: writes are an
    /// operator's, and each costs an fsync.
    pub writes: Arc<WriteLimiter>,
    /// Where links hand their poses and events (off: does nothing).
    pub recorder: Recorder,
    /// Mission time for what links and handlers record.
    pub clock: MissionClock,
}

/// The shared write budget.
pub struct WriteLimiter {
    pub(super) bucket: governor::DefaultDirectRateLimiter,
    pub(super) per_second: u32,
}

/// A bucket refilled at `per_second` that holds `burst` writes.
pub(super) fn write_limiter(per_second: u32, burst: u32) -> WriteLimiter {
    let rate = NonZeroU32::new(per_second.max(1)).expect("at least 1");
    let burst = NonZeroU32::new(burst.max(1)).expect("at least 1");
    WriteLimiter {
        bucket: governor::RateLimiter::direct(governor::Quota::per_second(rate).allow_burst(burst)),
        per_second: rate.get(),
    }
}
