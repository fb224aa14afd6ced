//! The machine's two cores, shared by the tests that are timed in real
//! time and load both of them: a peer fleet of eight processes and its
//! observers at a time warp of 10, four ArduPilot SITL boats and their
//! bridges, the demo's eight hulls stepped at 1 kHz in real time, Chromium
//! rendering the dashboard. Their
//! checks are on timing (a neighbour dropped within a second or two of
//! mission time, a command followed to within 0.05); two of them side by
//! side starve each other, and a check that fails for that says nothing
//! about seacover. Each holds [`HEAVY`] while it runs, so that at most one
//! runs at a time, beside tests that keep one core busy at most.

/// Held by each heavy test for as long as its processes run.
pub(crate) static HEAVY: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// [`HEAVY`], from a test that is not async.
pub(crate) fn heavy() -> tokio::sync::MutexGuard<'static, ()> {
    HEAVY.blocking_lock()
}
