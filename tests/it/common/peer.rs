//! The Python side of the peer-fleet tests: an interpreter with Eclipse
//! Zenoh's Python API and `cbor2` (the venv scripts/test makes, found through
//! `SEACOVER_PYTHON`), and the independent tools started inside a
//! [`Medium`](super::netns::Medium)'s hosts: the observer
//! (`tests/python/observer.py`, which writes what it hears as JSON lines)
//! and the injector (`tests/python/inject.py`, raw payloads).
//!
//! Both tools print `ready` once their Zenoh session is open; the helpers
//! here wait for that line, so a test never races a tool's start-up. A
//! tool that exits before it is ready fails the test with its status (its
//! stderr goes to the test's stderr).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use serde_json::Value;

use super::netns::Medium;
use super::process::{KillOnDrop, signal, venv_python};

/// The observer script.
pub(crate) const OBSERVER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/observer.py");
/// The injector script.
pub(crate) const INJECT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/inject.py");

/// The interpreter with `zenoh` and `cbor2` (see [`venv_python`]).
pub(crate) fn python_or_skip(test: &str) -> Option<PathBuf> {
    venv_python(
        test,
        &["zenoh", "cbor2"],
        "Python with eclipse-zenoh and cbor2",
    )
}

/// The UTC time in seconds, as the tools write it.
pub(crate) fn now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_secs_f64()
}

/// Polls `check` every 100 ms until it gives a value; panics after `secs`
/// seconds naming `what`.
pub(crate) fn wait_for<T>(secs: f64, what: &str, check: impl FnMut() -> Option<T>) -> T {
    wait_explained(secs, what, check, String::new)
}

/// [`wait_for`], whose panic adds what `explain` says of the state then.
pub(crate) fn wait_explained<T>(
    secs: f64,
    what: &str,
    mut check: impl FnMut() -> Option<T>,
    explain: impl FnOnce() -> String,
) -> T {
    let deadline = Instant::now() + Duration::from_secs_f64(secs);
    loop {
        if let Some(v) = check() {
            return v;
        }
        if Instant::now() >= deadline {
            panic!("after {secs} s: {what}{}", explain());
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Starts `cmd` (stdout piped, stderr inherited) and waits up to `secs`
/// seconds for its `ready` line; the rest of its stdout is copied to the
/// test's stderr, prefixed with `what`.
pub(crate) fn start_ready(mut cmd: Command, what: &str, secs: u64) -> KillOnDrop {
    let mut child = KillOnDrop(
        cmd.stdin(Stdio::null())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("{what}: could not start {cmd:?}: {e}")),
    );
    let stdout = child.0.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    let name = what.to_string();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if line.trim() == "ready" {
                let _ = tx.send(());
            } else {
                eprintln!("{name}: {line}");
            }
        }
    });
    match rx.recv_timeout(Duration::from_secs(secs)) {
        Ok(()) => child,
        Err(mpsc::RecvTimeoutError::Timeout) => panic!("{what}: not ready after {secs} s"),
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            let status = child.0.wait().unwrap();
            panic!("{what}: exited before it was ready: {status}")
        }
    }
}

/// Sends SIGTERM to `child` and waits up to `secs` seconds for it to exit
/// with status 0.
pub(crate) fn terminate(child: &mut KillOnDrop, what: &str, secs: u64) {
    signal(child.0.id(), "-TERM");
    let status = wait_for(secs as f64, &format!("{what} exits on SIGTERM"), || {
        child.0.try_wait().unwrap()
    });
    assert!(status.success(), "{what}: exited with {status} on SIGTERM");
}

/// The observer, running in one host of a medium, writing to a file of its
/// own.
pub(crate) struct Observer {
    pub child: KillOnDrop,
    pub out: PathBuf,
    _dir: tempfile::TempDir,
}

impl Observer {
    /// Starts the observer in host `host` for fleet `fleet` (more options in
    /// `args`, e.g. `--connect`), and waits until it is ready.
    pub(crate) fn start(
        medium: &Medium,
        host: usize,
        python: &Path,
        fleet: &str,
        args: &[&str],
    ) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("observed.jsonl");
        let mut cmd = medium.command(host, python);
        cmd.arg(OBSERVER)
            .args(["--fleet", fleet, "--out"])
            .arg(&out)
            .args(args);
        let child = start_ready(cmd, &format!("observer (host {host})"), 30);
        Observer {
            child,
            out,
            _dir: dir,
        }
    }

    /// Every complete line written so far, parsed.
    pub(crate) fn records(&self) -> Vec<Value> {
        let text = std::fs::read_to_string(&self.out).unwrap_or_default();
        let complete = text.rfind('\n').map_or("", |i| &text[..i]);
        complete
            .lines()
            .map(|l| {
                serde_json::from_str(l)
                    .unwrap_or_else(|e| panic!("{}: {l:?}: {e}", self.out.display()))
            })
            .collect()
    }

    /// The records of `kind` (`beacon`, `alive`, …).
    pub(crate) fn of_kind(&self, kind: &str) -> Vec<Value> {
        self.records()
            .into_iter()
            .filter(|r| r["kind"] == kind)
            .collect()
    }

    /// A reader of this observer's records as they come (see [`Tail`]).
    pub(crate) fn tail(&self) -> Tail {
        Tail {
            path: self.out.clone(),
            offset: 0,
        }
    }

    /// Stops the observer with SIGTERM (it must exit 0) and returns every
    /// record.
    pub(crate) fn stop(mut self) -> Vec<Value> {
        terminate(&mut self.child, "observer", 15);
        self.records()
    }
}

/// Reads an observer's file as it grows: each [`Tail::read`] parses only
/// the complete lines written since the previous call (a long run's file
/// is never read twice).
pub(crate) struct Tail {
    path: PathBuf,
    offset: u64,
}

impl Tail {
    /// The records of the complete lines written since the previous call.
    pub(crate) fn read(&mut self) -> Vec<Value> {
        use std::io::{Read, Seek, SeekFrom};
        let Ok(mut file) = std::fs::File::open(&self.path) else {
            return Vec::new();
        };
        let mut bytes = Vec::new();
        file.seek(SeekFrom::Start(self.offset))
            .and_then(|_| file.read_to_end(&mut bytes))
            .unwrap_or_else(|e| panic!("{}: {e}", self.path.display()));
        let Some(end) = bytes.iter().rposition(|&b| b == b'\n') else {
            return Vec::new();
        };
        self.offset += end as u64 + 1;
        bytes[..end]
            .split(|&b| b == b'\n')
            .filter(|l| !l.is_empty())
            .map(|l| {
                serde_json::from_slice(l).unwrap_or_else(|e| {
                    panic!(
                        "{}: {:?}: {e}",
                        self.path.display(),
                        String::from_utf8_lossy(l)
                    )
                })
            })
            .collect()
    }
}
