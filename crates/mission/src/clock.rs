//! The mission clock: mission seconds under a time warp (MOOS-IvP's
//! MOOSTimeWarp). Mission time, not wall time, is what guidance filters,
//! liveness and recordings count in, so a warped run behaves as a real one.

use std::time::{Duration, Instant};

/// The coordinator's mission clock: mission time is wall time since the
/// clock's origin, times the time warp; tick N is due when it reads
/// N / tick_hz.
#[derive(Debug, Clone, Copy)]
pub struct MissionClock {
    pub origin: Instant,
    pub warp: f64,
}

impl MissionClock {
    /// A clock whose first tick (tick 1, due one period after the origin)
    /// is due now.
    pub fn first_tick_now(warp: f64, tick_hz: f64) -> MissionClock {
        let period = Duration::from_secs_f64(1.0 / (tick_hz * warp));
        let now = Instant::now();
        MissionClock {
            origin: now.checked_sub(period).unwrap_or(now),
            warp,
        }
    }

    /// Mission time now [s].
    pub fn now(&self) -> f64 {
        self.origin.elapsed().as_secs_f64() * self.warp
    }
}
