//! The fault-injection suite, peer mode (docs/safety.md): real `seacover
//! agent --peer` and `serve --peer` processes in network namespaces of
//! their own on one radio medium (`crate::common::netns`), watched by the
//! independent Python observer (Zenoh's Python API and cbor2).
//!
//! - A member that hears no other vessel holds station and says so
//!   ("Why" 4: it covered the whole region alone); with `--alone` it covers.
//! - A coordinator joining a running fleet with an empty store takes the
//!   fleet's mission ("Why" 3: it published the built-in paper square as
//!   revision 1 and every boat took it); replacing it takes
//!   `--replace-fleet-mission`, and the revision says who made it. One
//!   whose first query finds nobody (the fleet out of reach as it starts)
//!   takes the fleet's mission once it hears it, though the fleet's
//!   revision number is the one it published itself.
//!
//! Needs root (network namespaces) and the test venv's Python: skipped with
//! a message without them, a failure under CI=true.

use std::path::Path;
use std::process::Stdio;
use std::thread::sleep;
use std::time::Duration;

use serde_json::Value;

use crate::common::netns::{Medium, cleanup_stale, root_or_skip};
use crate::common::peer::{Observer, python_or_skip, wait_for};
use crate::common::process::KillOnDrop;

const SEACOVER: &str = env!("CARGO_BIN_EXE_seacover");
const PAPER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper.json");
const HARBOUR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/harbour.json");
const WARP: &str = "4";

/// One case at a time: each is a medium of namespaces and its processes,
/// and the peer fleet tests beside them are timed.
static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn one() -> std::sync::MutexGuard<'static, ()> {
    ONE.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// What every case needs first: root and the test venv's Python (`None`
/// after saying why it is skipped), its turn, and no namespaces left over.
fn ready(test: &str) -> Option<(std::path::PathBuf, std::sync::MutexGuard<'static, ()>)> {
    if !root_or_skip(test) {
        return None;
    }
    let python = python_or_skip(test)?;
    let turn = one();
    cleanup_stale();
    Some((python, turn))
}

/// The outer ring of a mission document's region, as numbers (1 and 1.0
/// alike); empty when it has none.
fn region(m: &Value) -> Vec<Vec<f64>> {
    serde_json::from_value(m["region"]["polygon"].clone()).unwrap_or_default()
}

/// examples/harbour.json.
fn harbour() -> Value {
    serde_json::from_str(&std::fs::read_to_string(HARBOUR).unwrap()).unwrap()
}

/// The beacons the observer heard from `id`: (its x, y, rev).
fn track(observer: &Observer, id: &str) -> Vec<(f64, f64, u64)> {
    observer
        .of_kind("beacon")
        .iter()
        .map(|r| &r["beacon"])
        .filter(|b| b["id"] == id)
        .filter_map(|b| Some((b["x"].as_f64()?, b["y"].as_f64()?, b["rev"].as_u64()?)))
        .collect()
}

fn newest_status(observer: &Observer, id: &str) -> Option<Value> {
    observer
        .of_kind("status")
        .into_iter()
        .map(|r| r["status"].clone())
        .rfind(|s| s["id"] == id)
}

/// One vessel, `usv-1` at (20, 30) of the paper's square, alone on the
/// medium: how far it goes in 40 s of mission time, and its status.
fn lone_vessel(alone: bool) -> Option<(f64, Value)> {
    let (python, _turn) = ready("peer_faults alone")?;
    let medium = Medium::new(2);
    let mut cmd = medium.command(0, SEACOVER);
    cmd.args(["agent", "--peer", "--fleet", "lone", "--id", "usv-1"])
        .args(["--start", "20,30", "--mission", PAPER, "--time-warp", WARP])
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    if alone {
        cmd.arg("--alone");
    }
    let _vessel = KillOnDrop(cmd.spawn().unwrap());
    let observer = Observer::start(&medium, 1, &python, "lone", &["--query-status-every", "1"]);
    wait_for(30.0, "the vessel's first beacon", || {
        (!track(&observer, "usv-1").is_empty()).then_some(())
    });
    // 40 s of mission time.
    sleep(Duration::from_secs(10));
    let beacons = track(&observer, "usv-1");
    let (x0, y0, _) = beacons[0];
    let farthest = beacons
        .iter()
        .map(|&(x, y, _)| (x - x0).hypot(y - y0))
        .fold(0.0, f64::max);
    let status = wait_for(10.0, "a status reply", || newest_status(&observer, "usv-1"));
    Some((farthest, status))
}

#[test]
fn a_vessel_that_hears_no_other_holds_station() {
    let Some((farthest, status)) = lone_vessel(false) else {
        return;
    };
    assert_eq!(status["alone"], true, "{status}");
    assert!(farthest < 2.0, "it moved {farthest:.2} m alone");
}

#[test]
fn with_alone_a_single_vessel_covers() {
    let Some((farthest, status)) = lone_vessel(true) else {
        return;
    };
    assert_eq!(status["alone"], false, "{status}");
    // From (20, 30) towards the centroid of the whole square, near (50, 50).
    assert!(farthest > 10.0, "it moved only {farthest:.2} m");
}

/// `serve --peer` in host `host` on a new data directory.
fn shore(medium: &Medium, host: usize, data: &Path, fleet: &str, extra: &[&str]) -> KillOnDrop {
    let mut cmd = medium.command(host, SEACOVER);
    cmd.args([
        "serve",
        "--peer",
        "--fleet",
        fleet,
        "--bind",
        "127.0.0.1:8080",
    ])
    .arg("--data-dir")
    .arg(data)
    .args(["--no-record", "--time-warp", WARP])
    .args(extra)
    .env("RUST_LOG", "warn")
    .stdin(Stdio::null())
    .stdout(Stdio::null())
    .stderr(Stdio::null());
    KillOnDrop(cmd.spawn().unwrap())
}

/// `GET path` on the coordinator in `host`, from inside its namespace, as
/// JSON.
fn get(medium: &Medium, python: &Path, host: usize, path: &str) -> Option<Value> {
    serde_json::from_str(&get_text(medium, python, host, path)?).ok()
}

/// `GET path` on the coordinator in `host`, from inside its namespace.
fn get_text(medium: &Medium, python: &Path, host: usize, path: &str) -> Option<String> {
    const CLIENT: &str = r#"
import sys, urllib.request
with urllib.request.urlopen(sys.argv[1], timeout=5) as r:
    print(r.read().decode())
"#;
    let out = medium
        .command(host, python)
        .args(["-c", CLIENT, &format!("http://127.0.0.1:8080{path}")])
        .stderr(Stdio::null())
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Three vessels of `fleet` on the harbour's mission in host 0, and the
/// observer in host `observer_host`, once it has heard all three.
fn harbour_fleet(
    medium: &Medium,
    python: &Path,
    fleet: &str,
    observer_host: usize,
) -> (KillOnDrop, Observer) {
    let mut cmd = medium.command(0, SEACOVER);
    cmd.args(["agent", "--peer", "--fleet", fleet, "--vessels", "3"])
        .args(["--mission", HARBOUR, "--time-warp", WARP])
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    let vessels = KillOnDrop(cmd.spawn().unwrap());
    // It also asks for the mission every second: a put goes out once, and
    // may go out before the observer's session has found the shore's.
    let observer = Observer::start(
        medium,
        observer_host,
        python,
        fleet,
        &["--query-mission-every", "1"],
    );
    wait_for(30.0, "the three vessels heard", || {
        (1..=3)
            .all(|i| !track(&observer, &format!("usv-{i}")).is_empty())
            .then_some(())
    });
    (vessels, observer)
}

#[test]
fn a_fresh_shore_takes_the_fleets_mission_and_replaces_it_only_when_told() {
    let Some((python, _turn)) = ready("peer_faults shore") else {
        return;
    };
    let fleet = "hb";
    // Host 0: three vessels on the harbour's mission; 1, 2: shores; 3: the
    // observer.
    let medium = Medium::new(4);
    let (_vessels, observer) = harbour_fleet(&medium, &python, fleet, 3);
    let harbour = harbour();

    // A coordinator on an empty data directory (the built-in paper square
    // is its own mission): it takes the fleet's, revision 0.
    let dir = tempfile::tempdir().unwrap();
    let _fresh = shore(&medium, 1, &dir.path().join("fresh"), fleet, &[]);
    let mission = wait_for(30.0, "the fresh shore answers", || {
        get(&medium, &python, 1, "/api/v1/mission")
    });
    assert!(!region(&mission).is_empty(), "{mission}");
    wait_for(10.0, "the fresh shore holds the harbour's region", || {
        let m = get(&medium, &python, 1, "/api/v1/mission")?;
        (region(&m) == region(&harbour)).then_some(())
    });
    let seen = observer.of_kind("beacon").len();
    sleep(Duration::from_secs(5));
    let after: Vec<u64> = observer.of_kind("beacon")[seen..]
        .iter()
        .filter_map(|r| r["beacon"]["rev"].as_u64())
        .collect();
    assert!(
        !after.is_empty() && after.iter().all(|&r| r == 0),
        "re-tasked: revisions {after:?}"
    );

    // Told to replace it: revision 1, said to be made so.
    let _replacing = shore(
        &medium,
        2,
        &dir.path().join("replacing"),
        fleet,
        &["--replace-fleet-mission"],
    );
    wait_for(30.0, "every vessel on revision 1", || {
        (1..=3)
            .all(|i| {
                track(&observer, &format!("usv-{i}"))
                    .last()
                    .is_some_and(|b| b.2 == 1)
            })
            .then_some(())
    });
    // Put, or in a reply to the observer's own query.
    let by = wait_for(5.0, "the observer heard revision 1", || {
        let mut missions = observer.of_kind("mission");
        missions.extend(observer.of_kind("mission_reply"));
        missions
            .iter()
            .find(|m| m["revision"] == 1)
            .map(|m| m["by"].clone())
    });
    assert!(
        by.as_str()
            .is_some_and(|b| b.contains("--replace-fleet-mission")),
        "by {by}"
    );
}

/// A shore that starts out of the fleet's reach publishes its own mission
/// as revision 0, the number the fleet's mission has too; once the medium
/// joins them it takes the fleet's, and the fleet keeps its own. (Met on
/// a busy machine, where the first query's second went by before Zenoh
/// had found the vessels: the shore showed the paper square for ever while
/// the boats worked the harbour.)
#[test]
fn a_shore_whose_first_query_finds_nobody_takes_the_fleets_mission_later() {
    let Some((python, _turn)) = ready("peer_faults late shore") else {
        return;
    };
    let fleet = "late";
    // Host 0: three vessels on the harbour's mission; 1: the shore; 2: the
    // observer. The shore starts cut off.
    let medium = Medium::new(3);
    medium.partition(&[vec![0, 2], vec![1]]);
    let (_vessels, observer) = harbour_fleet(&medium, &python, fleet, 2);
    let dir = tempfile::tempdir().unwrap();
    let _shore = shore(&medium, 1, &dir.path().join("late"), fleet, &[]);
    // It has published its own mission once the revision gauge shows.
    wait_for(30.0, "the shore publishes its own mission", || {
        let text = get_text(&medium, &python, 1, "/metrics")?;
        text.lines()
            .any(|l| l.starts_with("seacover_peer_mission_revision 0"))
            .then_some(())
    });
    let harbour = harbour();
    let own = get(&medium, &python, 1, "/api/v1/mission").expect("the shore answers");
    assert_ne!(region(&own), region(&harbour), "cut off, it holds its own");

    medium.heal();
    let seen = observer.of_kind("beacon").len();
    wait_for(20.0, "the shore holds the harbour's region", || {
        let m = get(&medium, &python, 1, "/api/v1/mission")?;
        (region(&m) == region(&harbour)).then_some(())
    });
    sleep(Duration::from_secs(3));
    let after: Vec<u64> = observer.of_kind("beacon")[seen..]
        .iter()
        .filter_map(|r| r["beacon"]["rev"].as_u64())
        .collect();
    assert!(
        !after.is_empty() && after.iter().all(|&r| r == 0),
        "re-tasked: revisions {after:?}"
    );
    // The shore's own revision was put while it was cut off, and never
    // again: nothing of it reached the fleet's side.
    let missions = observer.of_kind("mission");
    assert!(
        missions
            .iter()
            .all(|m| !m["by"].as_str().is_some_and(|b| b.contains("serve --peer"))),
        "the fleet heard the shore's mission: {missions:?}"
    );
}
