//! The machine's two cores, shared by the tests that are timed in real
//! time and load both of them: a peer fleet of eight processes and its
//! observers at a time warp of 10, four ArduPilot SITL boats and their
//! bridges, the demo's eight hulls stepped at 1 kHz in real time, Chromium
//! rendering the dashboard. Their
//! checks are on timing (a neighbour dropped within a second or two of
//! mission time, a command followed to within 0.05); two of them side by
//! side starve each other, and a check that fails for that says nothing
//! about seacover. Each holds [`Heavy`] while it runs, so that at most one
//! runs at a time, beside tests that keep one core busy at most.
//!
//! [`Heavy`] is a lock on a file, not a mutex: it holds across processes,
//! so that scripts/test can run the heavy tests in one process of this
//! test binary and the others beside them in a second, instead of one
//! process whose second thread, drawn to the next heavy test, waits for
//! the lock with nothing to do.

use std::fs::File;

/// Held by each heavy test for as long as its processes run: an exclusive
/// `flock` on a file under the tests' scratch directory, taken through a
/// descriptor of its own (so it excludes threads of one process too), and
/// released when dropped, or by the kernel when its process dies.
pub(crate) struct Heavy {
    _file: File,
}

/// Waits for [`Heavy`], from a test that is not async.
pub(crate) fn heavy() -> Heavy {
    let path = concat!(env!("CARGO_TARGET_TMPDIR"), "/heavy.lock");
    let file = File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(path)
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    file.lock().unwrap_or_else(|e| panic!("{path}: lock: {e}"));
    Heavy { _file: file }
}

/// Waits for [`Heavy`] without blocking the test's runtime.
pub(crate) async fn heavy_async() -> Heavy {
    tokio::task::spawn_blocking(heavy)
        .await
        .expect("the lock's thread")
}
