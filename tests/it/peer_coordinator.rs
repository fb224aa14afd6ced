//! The peer-fleet namespace test b (docs/peer.md): the coordinator as a
//! member of a peer fleet, lost and restarted.
//!
//! `seacover serve --peer` runs in a host of its own on the radio medium
//! (`crate::common::fleet`), the fleet's only mission source: the eight
//! vessels start without a mission file and take it from the fleet. The
//! coordinator is SIGKILLed 30 s of mission time in; the fleet must
//! converge as in test a (E_max < 0.5 m, H within 0.5 % of `seacover sim
//! --scenario paper`). Restarted on its data directory, it must list the
//! eight live vessels within a few seconds; then a risk object POSTed to it
//! must reach every vessel within 1 s (the first beacon with the new `rev`
//! from each, as the observer hears it, after the POST was sent), and the
//! fleet must converge to the new mission's optimum (E_max < 0.5 m in the
//! new mission, H within 0.5 % of Lloyd's optimum from where it ends). No
//! two vessels within the safety distance at any time.
//!
//! The REST calls are made from inside the coordinator's namespace (it
//! binds that namespace's loopback) by the test venv's Python, with
//! `urllib`: a real HTTP client on the real socket.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Stdio;
use std::time::Instant;

use serde_json::{Value, json};

use crate::common::fleet::*;
use crate::common::paper::*;
use crate::common::peer::{now, wait_for};
use crate::common::process::{KillOnDrop, signal};

const BIND: &str = "127.0.0.1:8080";

/// The coordinator process in the shore host.
struct Shore {
    child: KillOnDrop,
    log: std::path::PathBuf,
}

/// Starts `serve --peer` in the fleet's shore host on `data`, and waits
/// until it answers `/healthz`.
fn start_shore(fleet: &Fleet, python: &Path, data: &Path, n: usize) -> Shore {
    let host = fleet.shore.expect("a shore host");
    let log = fleet.logs.path().join(format!("coordinator-{n}.log"));
    let mut cmd = fleet.medium.command(host, BIN);
    cmd.args(["serve", "--peer", "--fleet", &fleet.name, "--bind", BIND])
        .arg("--data-dir")
        .arg(data)
        .args(["--no-record", "--time-warp", &fleet.warp.to_string()])
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap());
    let child = KillOnDrop(cmd.spawn().unwrap());
    let shore = Shore { child, log };
    wait_for(20.0, "the coordinator answers /healthz", || {
        (rest(fleet, python, "GET", "/healthz", None).0 == 200).then_some(())
    });
    shore
}

/// One HTTP request to the coordinator, from inside its namespace: the
/// status (0 when no answer) and the JSON body (`null` when not JSON).
fn rest(
    fleet: &Fleet,
    python: &Path,
    method: &str,
    path: &str,
    body: Option<&Value>,
) -> (u16, Value) {
    const CLIENT: &str = r#"
import json, sys, urllib.request, urllib.error
method, url, body = sys.argv[1], sys.argv[2], sys.argv[3]
req = urllib.request.Request(url, method=method, data=body.encode() if body else None,
                             headers={"content-type": "application/json"})
try:
    with urllib.request.urlopen(req, timeout=5) as r:
        status, text = r.status, r.read().decode()
except urllib.error.HTTPError as e:
    status, text = e.code, e.read().decode()
except Exception as e:
    status, text = 0, json.dumps(str(e))
print(status)
print(text)
"#;
    let host = fleet.shore.expect("a shore host");
    let url = format!("http://{BIND}{path}");
    let body = body.map(Value::to_string).unwrap_or_default();
    let out = fleet
        .medium
        .command(host, python)
        .args(["-c", CLIENT, method, &url, &body])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let (status, rest) = text.split_once('\n').unwrap_or(("0", ""));
    (
        status.trim().parse().unwrap_or(0),
        serde_json::from_str(rest.trim()).unwrap_or(Value::Null),
    )
}

/// The newest `rev` each vessel's beacons carry, as the observer heard.
fn revisions(fleet: &Fleet) -> BTreeMap<String, u64> {
    fleet
        .latest
        .iter()
        .map(|(id, r)| (id.clone(), r["beacon"]["rev"].as_u64().unwrap_or(0)))
        .collect()
}

#[test]
fn b_coordinator_lost_and_restarted() {
    let test = "peer_fleet b";
    let Some(python) = skip(test) else { return };
    let mut checks = Checks::new(test);
    let h_central = centralized_h();
    let wall = Instant::now();
    let mut setup = Setup::new("b", WARP);
    setup.shore = true;
    setup.mission_file = false;
    let mut fleet = Fleet::new(setup, &python);
    let data = tempfile::tempdir().unwrap();
    let mut shore = start_shore(&fleet, &python, data.path(), 1);
    fleet.launch();
    fleet.wait_heard_all();
    // Every vessel took its mission from the coordinator: all beacon
    // `controlled` once they hold it.
    wait_for(20.0, "every vessel controlled (holds the mission)", || {
        fleet.update();
        (fleet.latest.len() == N
            && fleet
                .latest
                .values()
                .all(|r| r["beacon"]["controlled"] == json!(true)))
        .then_some(())
    });
    let rev_first = revisions(&fleet);

    fleet.run_until(30.0, |_| {});
    signal(shore.child.0.id(), "-KILL");
    let _ = shore.child.0.wait();
    let killed_at = fleet.mission_time();
    fleet.run_until(200.0, |_| {});
    let (h_lost, e_lost) = coverage(&fleet.positions());
    let e_lost_max = max_of(&e_lost);
    let before = fleet.positions();
    // Which optimum the fleet is heading for: Lloyd's iteration from here.
    let (h_lost_opt, _, _) = lloyd(&before);
    let at_lost: Vec<String> = before
        .iter()
        .map(|p| format!("{} ({:.1}, {:.1})", p.id, p.x, p.y))
        .collect();

    // Restarted on its data directory: the live fleet within seconds.
    let restarted = now();
    let shore_log_first = shore.log.clone();
    shore = start_shore(&fleet, &python, data.path(), 2);
    let listed = wait_for(15.0, "the restarted coordinator lists 8 vessels", || {
        let (status, body) = rest(&fleet, &python, "GET", "/api/v1/vessels", None);
        (status == 200 && body.as_array().is_some_and(|v| v.len() == N)).then(|| now() - restarted)
    });

    // A risk object over REST: every vessel on the new revision within 1 s.
    fleet.update();
    let rev_before = revisions(&fleet).values().copied().max().unwrap_or(0);
    let object = json!({"x": 75.0, "y": 25.0, "alpha": 40.0, "sigma": 12.0});
    let posted = now();
    let (status, created) = rest(
        &fleet,
        &python,
        "POST",
        "/api/v1/risk-objects",
        Some(&object),
    );
    checks.check(
        status == 201,
        format!("POST /api/v1/risk-objects answers 201 (got {status}: {created})"),
    );
    let reached: BTreeMap<String, f64> = wait_for(10.0, "every vessel beacons a newer rev", || {
        fleet.update();
        let mut first = BTreeMap::new();
        for r in &fleet.beacons {
            let rev = r["beacon"]["rev"].as_u64().unwrap_or(0);
            let recv = r["recv"].as_f64().unwrap_or(0.0);
            if rev > rev_before && recv >= posted {
                let id = r["beacon"]["id"].as_str().unwrap_or("").to_string();
                first.entry(id).or_insert(recv - posted);
            }
        }
        (first.len() == N).then_some(first)
    });
    let slowest = reached.values().copied().fold(0.0, f64::max);
    let (_, mission) = rest(&fleet, &python, "GET", "/api/v1/mission", None);
    let objects = mission["risk"]["objects"].as_array().map_or(0, Vec::len);
    let new_mission = with_mission(&mission);

    let t_write = fleet.mission_time();
    fleet.run_until(t_write + 200.0, |_| {});
    let after = fleet.positions();
    let (h_new, e_new) = coverage_in(&new_mission, &after);
    let e_new_max = max_of(&e_new);
    let (h_opt, iterations, _) = lloyd_in(&new_mission, &after);
    let moved = before
        .iter()
        .zip(&after)
        .map(|(a, b)| (a.x - b.x).hypot(a.y - b.y))
        .fold(0.0, f64::max);
    let safety = fleet.safety_distance();
    let closest = check_safety(&mut checks, &fleet, safety);
    check_wire(&mut checks, &fleet);
    let shore_log = std::fs::read_to_string(&shore.log).unwrap_or_default();
    signal(shore.child.0.id(), "-TERM");
    let shore_exit = wait_for(15.0, "the coordinator exits on SIGTERM", || {
        shore.child.0.try_wait().unwrap()
    });
    fleet.shutdown(&mut checks);
    let first_log = std::fs::read_to_string(&shore_log_first).unwrap_or_default();
    if !first_log.is_empty() || !shore_log.is_empty() {
        eprintln!(
            "{test}: coordinator logs (RUST_LOG=warn): first run {} lines, second {} lines; \
             second, last lines:\n{}",
            first_log.lines().count(),
            shore_log.lines().count(),
            shore_log
                .lines()
                .rev()
                .take(5)
                .collect::<Vec<_>>()
                .join("\n")
        );
    }
    eprintln!(
        "SUMMARY {test}: time warp {WARP}, UDP links; mission from the coordinator (revisions \
         {rev_first:?}); coordinator SIGKILLed at {killed_at:.1} s of mission time; at 200 s: \
         H {h_lost:.1} / centralized {h_central:.1} = {:.5}, E_max {e_lost_max:.3} m, Lloyd's optimum from there {h_lost_opt:.1}, at \
         {at_lost:?}; restarted: \
         8 vessels listed after {listed:.2} s; risk object POSTed: every vessel beaconing the new \
         revision after at most {slowest:.3} s ({reached:.3?}); mission now has {objects} \
         object(s); {:.0} s later: H {h_new:.1}, Lloyd's optimum from there {h_opt:.1} ({iterations} \
         iterations), ratio {:.5}, E_max {e_new_max:.3} m ({e_new:.2?}), vessels moved up to \
         {moved:.1} m; closest pair {closest:.2} m (safety {safety} m); coordinator exit \
         {shore_exit}; {:.0} s wall",
        h_lost / h_central,
        fleet.mission_time() - t_write,
        h_new / h_opt,
        wall.elapsed().as_secs_f64(),
    );
    checks.check(
        rev_first.len() == N,
        format!("every vessel took the coordinator's mission ({rev_first:?})"),
    );
    checks.check(
        e_lost_max < 0.5,
        format!("coordinator lost: E_max {e_lost_max:.3} m < 0.5 m"),
    );
    checks.check(
        (h_lost / h_central - 1.0).abs() <= 0.005,
        format!(
            "coordinator lost: H {h_lost:.1} within 0.5 % of the centralized {h_central:.1} ({:.5})",
            h_lost / h_central
        ),
    );
    checks.check(
        listed <= 5.0,
        format!("restarted, the coordinator lists the 8 live vessels within 5 s ({listed:.2} s)"),
    );
    checks.check(
        slowest <= 1.0,
        format!("the risk object reaches every vessel within 1 s (slowest {slowest:.3} s)"),
    );
    checks.check(
        objects >= 1,
        format!("the mission holds the new object ({objects})"),
    );
    checks.check(
        e_new_max < 0.5,
        format!("re-converged in the new mission: E_max {e_new_max:.3} m < 0.5 m"),
    );
    checks.check(
        (h_new / h_opt - 1.0).abs() <= 0.005,
        format!(
            "re-converged: H {h_new:.1} within 0.5 % of the new optimum {h_opt:.1} ({:.5})",
            h_new / h_opt
        ),
    );
    checks.check(
        moved > 1.0,
        format!("the new risk moved the fleet (up to {moved:.1} m)"),
    );
    checks.check(
        shore_exit.success(),
        format!("the coordinator exits 0 on SIGTERM ({shore_exit})"),
    );
    checks.finish();
}
