//! Child processes of the tests: POSIX signals sent with `kill`, and a child
//! killed and reaped when its guard is dropped.

use std::process::{Child, Command};

/// Sends `sig` (as `kill` takes it: `-TERM`, `-KILL`, `-STOP`, …) to `pid`
/// and asserts that `kill` succeeded.
pub fn signal(pid: u32, sig: &str) {
    let status = Command::new("kill")
        .args([sig, &pid.to_string()])
        .status()
        .unwrap();
    assert!(status.success(), "kill {sig} {pid}: {status}");
}

/// A child process, killed and waited for when dropped.
pub struct KillOnDrop(pub Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}
