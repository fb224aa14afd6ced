//! Child processes of the tests: POSIX signals sent with `kill`, a child
//! killed and reaped when its guard is dropped, and the test venv's Python.

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

/// Sends `sig` (as `kill` takes it: `-TERM`, `-KILL`, `-STOP`, …) to `pid`
/// and asserts that `kill` succeeded.
pub(crate) fn signal(pid: u32, sig: &str) {
    let status = Command::new("kill")
        .args([sig, &pid.to_string()])
        .status()
        .unwrap();
    assert!(status.success(), "kill {sig} {pid}: {status}");
}

/// A child process, killed and waited for when dropped.
pub(crate) struct KillOnDrop(pub Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The test venv's interpreter, `SEACOVER_PYTHON` or else target/test-venv,
/// if it imports every one of `modules`. `None` (after "skipped: <test>
/// needs <what>") without one, except under CI=true, where that panics:
/// scripts/test makes the venv.
pub(crate) fn venv_python(test: &str, modules: &[&str], what: &str) -> Option<PathBuf> {
    let candidates = [
        std::env::var_os("SEACOVER_PYTHON").map(PathBuf::from),
        Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/target/test-venv/bin/python"
        ))),
    ];
    let import = format!("import {}", modules.join(", "));
    for p in candidates.into_iter().flatten() {
        let ok = Command::new(&p)
            .args(["-c", &import])
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            return Some(p);
        }
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "CI=true: {test} needs {what} (scripts/test makes target/test-venv)"
    );
    eprintln!("skipped: {test} needs {what} (run scripts/test, or set SEACOVER_PYTHON)");
    None
}

/// The independent reader's report of a recording
/// (`tests/python/check_recording.py`: Foxglove's `mcap` and `jsonschema`):
/// channels, counts and schema failures. `None` where [`venv_python`] is.
pub(crate) fn check_recording(test: &str, file: &std::path::Path) -> Option<serde_json::Value> {
    let python = venv_python(
        test,
        &["mcap", "jsonschema"],
        "Python with Foxglove's mcap package and jsonschema",
    )?;
    Some(recording_report(&python, file))
}

/// The independent reader's report of `file`, read with `python`.
pub(crate) fn recording_report(
    python: &std::path::Path,
    file: &std::path::Path,
) -> serde_json::Value {
    let out = Command::new(python)
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/python/check_recording.py"
        ))
        .arg(file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}
