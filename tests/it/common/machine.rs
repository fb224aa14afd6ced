//! The machine's two cores, shared by the tests that are timed in real
//! time: a peer fleet of eight processes and its observers at a time warp
//! of 10, four ArduPilot SITL boats and their bridges, a hundred peer
//! vessels, the demo's eight hulls stepped at 1 kHz in real time, Chromium
//! rendering the dashboard. Their checks are on timing (a neighbour dropped
//! within a second or two of mission time, a command followed to within
//! 0.05); two of them that starve each other fail for a reason that says
//! nothing about seacover.
//!
//! Each such test holds the machine, or one of two [`Part`]s of it, while
//! it runs. Most leave most of it idle: measured alone on this two-core
//! machine (the busy share of both cores over the test, `/proc/stat`),
//! SITL boats 5–20 %, a peer fleet of 30 at a time warp of 0.5 25 %, a
//! peer fleet of eight at 10 29–49 %, the demo's hulls 1 %, Chromium up to
//! 81 % (a few seconds), a hundred peer vessels 97 %. So a test of a
//! quarter of the machine ([`Part::Quarter`]) may run beside one of half
//! of it ([`Part::Half`]), never two of one part (the SITL boats' ports
//! are fixed; two fleets of eight would take it all). Everything else
//! takes the whole machine ([`heavy`]) and runs alone among these tests,
//! beside tests that keep one core busy at most. The demo's hulls are not
//! a quarter for their 1 %: their tracking error, 0.00003 m/s alone, was
//! 0.026 beside a fleet of eight (the bound is 0.05): what they measure is
//! how promptly they are scheduled.
//!
//! A hold is a lock on a file per part, not a mutex: it holds across
//! processes, so that scripts/test can run the quarters' tests, the
//! halves' and the light ones in three processes of this test binary at
//! once (and the Docker demo as a quarter, `flock` on its file). The
//! whole machine locks the half, then the quarter (always in that order,
//! and a part's holder never waits for another: no deadlock).

use std::fs::File;

/// A part of the machine, for the tests that measured to need less.
#[derive(Clone, Copy)]
pub(crate) enum Part {
    /// A quarter: four ArduPilot SITL boats and their bridges (or a
    /// coordinator), or a peer fleet of 30 at a time warp of 0.5.
    Quarter,
    /// A half: a peer fleet of eight simulated vessels at a time warp of
    /// 10 and its observers.
    Half,
}

/// Held for as long as a test's processes run: an exclusive `flock` on the
/// file of each part it holds, under the tests' scratch directory, each
/// through a descriptor of its own (so it excludes threads of one process
/// too), released when dropped, or by the kernel when its process dies.
pub(crate) struct Heavy {
    _files: Vec<File>,
}

fn lock(part: Part) -> File {
    let path = match part {
        Part::Quarter => concat!(env!("CARGO_TARGET_TMPDIR"), "/machine-quarter.lock"),
        Part::Half => concat!(env!("CARGO_TARGET_TMPDIR"), "/machine-half.lock"),
    };
    let file = File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(path)
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    file.lock().unwrap_or_else(|e| panic!("{path}: lock: {e}"));
    file
}

/// Waits for the whole machine, from a test that is not async.
pub(crate) fn heavy() -> Heavy {
    let half = lock(Part::Half);
    let quarter = lock(Part::Quarter);
    Heavy {
        _files: vec![half, quarter],
    }
}

/// Waits for the whole machine without blocking the test's runtime.
pub(crate) async fn heavy_async() -> Heavy {
    tokio::task::spawn_blocking(heavy)
        .await
        .expect("the lock's thread")
}

/// Waits for one part of the machine, from a test that is not async.
pub(crate) fn part(part: Part) -> Heavy {
    Heavy {
        _files: vec![lock(part)],
    }
}

/// Waits for a quarter without blocking the test's runtime.
pub(crate) async fn quarter_async() -> Heavy {
    tokio::task::spawn_blocking(|| part(Part::Quarter))
        .await
        .expect("the lock's thread")
}
