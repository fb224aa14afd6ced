//! What a peer fleet's encryption is judged by: credentials for a test
//! fleet (the real `seacover fleet credentials`), what a receiver on the
//! medium reads (tests/python/capture.py in the medium's namespace), and
//! the CPU time and memory a process used (its `/proc/<pid>/stat` and
//! `status`).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};

use serde_json::Value;

use super::netns::Medium;
use super::paper::{BIN, N};

/// `seacover fleet credentials` in `dir` for fleet `fleet`: usv-1 … usv-N
/// and an observer per host of `observers`; the credentials' directory.
pub(crate) fn credentials(dir: &Path, fleet: &str, observers: &[usize]) -> PathBuf {
    let members: Vec<String> = ids()
        .chain(observers.iter().map(|h| format!("observer-{h}")))
        .collect();
    make_credentials(&dir.join("credentials"), fleet, &members)
}

/// `seacover fleet credentials CREDS --fleet FLEET --members …`, which
/// must print each member's configuration; returns `creds`.
pub(crate) fn make_credentials(creds: &Path, fleet: &str, members: &[String]) -> PathBuf {
    let out = std::process::Command::new(BIN)
        .args(["fleet", "credentials", "--fleet", fleet, "--members"])
        .arg(members.join(","))
        .arg(creds)
        .output()
        .unwrap();
    let printed = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "seacover fleet credentials: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    for id in members {
        assert!(printed.contains(&member_config(creds, id)), "{printed}");
    }
    creds.to_path_buf()
}

/// Member `id`'s Zenoh configuration in the credentials' directory `dir`.
pub(crate) fn member_config(dir: &Path, id: &str) -> String {
    dir.join("members")
        .join(id)
        .join("zenoh.json5")
        .display()
        .to_string()
}

/// usv-1 … usv-N.
fn ids() -> impl Iterator<Item = String> {
    (1..=N).map(|i| format!("usv-{i}"))
}

/// A capture on a medium: every frame crossing its bridge, searched for
/// strings in the clear, from [`Capture::start`] to [`Capture::finish`].
pub(crate) struct Capture {
    child: Child,
    out: BufReader<std::process::ChildStdout>,
}

impl Capture {
    /// Starts capturing in `medium`'s namespace, looking for `needles`;
    /// returns once the socket is open.
    pub(crate) fn start(medium: &Medium, python: &Path, needles: &[String]) -> Capture {
        let mut cmd = std::process::Command::new("ip");
        cmd.args(["netns", "exec", medium.medium_ns()])
            .arg(python)
            .arg(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/tests/python/capture.py"
            ))
            .args(needles.iter().flat_map(|n| ["--needle", n.as_str()]))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped());
        let mut child = cmd.spawn().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        out.read_line(&mut line).unwrap();
        assert_eq!(line.trim(), "ready", "capture.py: {line:?}");
        Capture { child, out }
    }

    /// Stops capturing: frames, bytes, and in how many frames each needle
    /// was found.
    pub(crate) fn finish(mut self) -> Value {
        drop(self.child.stdin.take());
        let mut line = String::new();
        self.out.read_line(&mut line).unwrap();
        let _ = self.child.wait();
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("capture.py: {e}: {line:?}"))
    }
}

/// What a receiver must not read off an encrypted fleet `fleet`: its
/// vessels' ids (in every beacon and status), its keys, and the mission's
/// and a status's JSON.
pub(crate) fn needles(fleet: &str) -> Vec<String> {
    let mut n: Vec<String> = ids().collect();
    n.extend([
        format!("seacover/{fleet}/"),
        "\"region\"".to_string(),
        "\"neighbours\"".to_string(),
    ]);
    n
}

/// `VmRSS` of process `pid` in bytes.
pub(crate) fn rss(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let kb: u64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kb * 1024)
}

/// The CPU time process `pid` has used, user and system [s].
pub(crate) fn cpu_seconds(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // The fields after the command's name (which may hold spaces).
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map_or(vec![], |(_, rest)| rest.split_whitespace().collect());
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // utime and stime are fields 14 and 15 of the line, 11 and 12 after it.
    (ticks(11) + ticks(12)) / clock_ticks()
}

fn clock_ticks() -> f64 {
    let out = std::process::Command::new("getconf")
        .arg("CLK_TCK")
        .output();
    out.ok()
        .and_then(|o| String::from_utf8_lossy(&o.stdout).trim().parse().ok())
        .unwrap_or(100.0)
}
