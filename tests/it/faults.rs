//! The fault-injection suite, coordinator mode (docs/safety.md): the real
//! `seacover serve` and a real `seacover agent` fleet of eight simulated
//! vessels, and one faulty member driven from here over a real vessel
//! link. Each case checks that the rest of the fleet keeps receiving
//! commands, that the faulty member is refused alone, and that the fault
//! is counted (`/metrics`) and shown (`GET /api/v1/vessels`).

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

use crate::common::link::{hello, next_json};
use crate::common::process::KillOnDrop;
use crate::common::server::{metric_sum, metrics, serve_unrecorded, start};

const WARP: f64 = 10.0;

/// One harness at a time: each is a coordinator and eight simulated hulls
/// at time warp 10, and the suite's cases all at once would starve the
/// tests timed in real time that run beside them.
static ONE: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// A coordinator and eight simulated vessels, as separate processes.
struct Harness {
    _one: tokio::sync::MutexGuard<'static, ()>,
    server: KillOnDrop,
    _agents: KillOnDrop,
    addr: String,
    http: reqwest::Client,
    data: tempfile::TempDir,
}

impl Harness {
    async fn start() -> Harness {
        let one = ONE.lock().await;
        let data = tempfile::tempdir().unwrap();
        let mut serve = serve_unrecorded(data.path());
        serve
            .args(["--time-warp", &WARP.to_string()])
            .stderr(Stdio::null());
        let (server, addr) = start(serve);
        let agents = Command::new(env!("CARGO_BIN_EXE_seacover"))
            .args(["agent", "--server", &format!("http://{addr}")])
            .args(["--time-warp", &WARP.to_string()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let h = Harness {
            _one: one,
            server: KillOnDrop(server),
            _agents: KillOnDrop(agents),
            addr,
            http: reqwest::Client::new(),
            data,
        };
        h.until(30, "the eight vessels live", |vs| healthy(vs).len() == 8)
            .await;
        h
    }

    /// Kills the coordinator (SIGKILL) and starts it again on the same
    /// address with an empty data directory and the built-in mission.
    fn restart_with_an_empty_store(&mut self) {
        let _ = self.server.0.kill();
        let _ = self.server.0.wait();
        self.data = tempfile::tempdir().unwrap();
        let mut serve = Command::new(env!("CARGO_BIN_EXE_seacover"));
        serve
            .args(["serve", "--bind", &self.addr, "--no-record", "--data-dir"])
            .arg(self.data.path())
            .args(["--time-warp", &WARP.to_string()])
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        let (server, addr) = start(serve);
        assert_eq!(addr, self.addr);
        self.server = KillOnDrop(server);
    }

    async fn add_risk_object(&self, id: &str) {
        let r = self
            .http
            .post(format!("http://{}/api/v1/risk-objects", self.addr))
            .json(&json!({"id": id, "x": 20.0, "y": 80.0, "alpha": 4.0, "sigma": 6.0}))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 201, "{:?}", r.text().await);
    }

    fn ws(&self) -> String {
        format!("ws://{}/api/v1/vessels/link", self.addr)
    }

    async fn get(&self, path: &str) -> Value {
        let url = format!("http://{}{path}", self.addr);
        let response = self.http.get(url).send().await.unwrap();
        response.json().await.unwrap()
    }

    async fn vessels(&self) -> Vec<Value> {
        serde_json::from_value(self.get("/api/v1/vessels").await).unwrap()
    }

    async fn vessel(&self, id: &str) -> Value {
        self.get(&format!("/api/v1/vessels/{id}")).await
    }

    /// A metric's value from `/metrics`: the sum over the lines whose
    /// name and labels start with `prefix`.
    async fn metric(&self, prefix: &str) -> f64 {
        metric_sum(&metrics(&self.http, &self.addr).await, prefix, "")
    }

    /// Polls the vessels until `check` holds, for up to `secs`.
    async fn until(&self, secs: u64, what: &str, check: impl Fn(&[Value]) -> bool) {
        let deadline = Instant::now() + Duration::from_secs(secs);
        loop {
            let vs = self.vessels().await;
            if check(&vs) {
                return;
            }
            assert!(Instant::now() < deadline, "timed out: {what}: {vs:#?}");
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }

    /// The rest of the fleet keeps receiving commands: over `secs` of
    /// wall time, every one of the eight simulated vessels stays live and
    /// its newest command's tick keeps advancing (checked every 0.5 s).
    async fn fleet_keeps_going(&self, secs: f64) {
        let mut last: Vec<(String, u64)> = Vec::new();
        let start = Instant::now();
        while start.elapsed().as_secs_f64() < secs {
            tokio::time::sleep(Duration::from_millis(500)).await;
            let vs = self.vessels().await;
            let now = healthy(&vs);
            assert_eq!(now.len(), 8, "a simulated vessel is out: {vs:#?}");
            for (id, tick) in &now {
                if let Some((_, before)) = last.iter().find(|(i, _)| i == id) {
                    assert!(tick > before, "{id} got no command in 0.5 s (tick {tick})");
                }
            }
            last = now;
        }
    }
}

/// The simulated vessels (usv-*) live and commanded, with their newest
/// command's tick.
fn healthy(vs: &[Value]) -> Vec<(String, u64)> {
    vs.iter()
        .filter(|v| v["id"].as_str().is_some_and(|id| id.starts_with("usv-")))
        .filter(|v| v["live"] == true && v["quarantine"].is_null())
        .filter_map(|v| {
            Some((
                v["id"].as_str()?.to_string(),
                v["last_command"]["tick"].as_u64()?,
            ))
        })
        .collect()
}

fn pose(t: f64, x: f64, y: f64) -> Message {
    Message::text(
        json!({"type": "pose", "t": t, "x": x, "y": y, "psi": 0.0, "u": 0.5, "v": 0.0, "r": 0.0})
            .to_string(),
    )
}

/// Sends `frames` (mission time t0, 20 Hz) while reading what comes back:
/// returns the frames received (errors and commands).
async fn send_all<S, R>(sink: &mut S, stream: &mut R, frames: Vec<Message>) -> Vec<Value>
where
    S: SinkExt<Message> + Unpin,
    R: StreamExt<Item = Result<Message, tokio_tungstenite::tungstenite::Error>> + Unpin,
{
    let mut got = Vec::new();
    for frame in frames {
        let _ = sink.send(frame).await;
        let pause = tokio::time::sleep(Duration::from_secs_f64(0.05 / WARP));
        tokio::pin!(pause);
        loop {
            tokio::select! {
                _ = &mut pause => break,
                m = stream.next() => match m {
                    Some(Ok(Message::Text(t))) => got.push(serde_json::from_str(&t).unwrap()),
                    Some(Ok(_)) => {}
                    _ => return got,
                },
            }
        }
    }
    got
}

/// A steady track from the middle of the region, at 0.5 m/s.
fn track(t0: f64, n: usize) -> Vec<Message> {
    (0..n)
        .map(|i| {
            let t = t0 + i as f64 * 0.05;
            pose(t, 50.0 + 0.5 * (t - t0), 50.0)
        })
        .collect()
}

/// The faulty member's view: it was told why (a non-fatal `implausible`
/// error) and told to hold.
fn told_to_hold(got: &[Value], code: &str) {
    let error = got
        .iter()
        .find(|m| m["type"] == "error")
        .unwrap_or_else(|| panic!("no error frame: {got:?}"));
    assert_eq!(error["code"], "implausible", "{error}");
    assert!(
        error["message"].as_str().unwrap().contains("pose refused"),
        "{error}"
    );
    let hold = got
        .iter()
        .find(|m| m["type"] == "command" && m["hold"].is_string())
        .unwrap_or_else(|| panic!("no command to hold ({code}): {got:?}"));
    assert_eq!(
        (hold["u_d"].as_f64(), hold["r_d"].as_f64()),
        (Some(0.0), Some(0.0)),
        "{hold}"
    );
}

/// One quarantine case: `bad` frames after a steady track; the vessel is
/// quarantined with `code`, the fleet goes on, the refusal is counted, and
/// (with `recovers`) a steady track brings it back.
async fn quarantine_case(bad: impl Fn(f64) -> Vec<Message>, code: &str, recovers: bool) {
    let h = Harness::start().await;
    let (mut sink, mut stream) = hello(h.ws(), "faulty").await;
    let before = h
        .metric(&format!(
            "seacover_poses_refused_total{{reason=\"{code}\"}}"
        ))
        .await;
    let got = send_all(&mut sink, &mut stream, track(10.0, 40)).await;
    assert!(got.iter().all(|m| m["type"] == "command"), "{got:?}");
    let status = h.vessel("faulty").await;
    assert_eq!(status["live"], true, "{status}");

    let mut got = send_all(&mut sink, &mut stream, bad(12.0)).await;
    let status = h.vessel("faulty").await;
    assert_eq!(status["quarantine"]["code"], code, "{status}");
    // Still refused while it keeps sending: held, every tick. (The batch
    // again goes back in time, so the latest refusal may be that.)
    got.extend(send_all(&mut sink, &mut stream, bad(12.5)).await);
    told_to_hold(&got, code);
    let status = h.vessel("faulty").await;
    assert!(status["quarantine"]["code"].is_string(), "{status}");
    assert_eq!(status["live"], false, "{status}");
    assert_eq!(status["connected"], true, "{status}");
    let refused = h
        .metric(&format!(
            "seacover_poses_refused_total{{reason=\"{code}\"}}"
        ))
        .await;
    assert!(refused > before, "not counted: {before} → {refused}");
    assert_eq!(h.metric("seacover_vessels_quarantined").await, 1.0);
    h.fleet_keeps_going(2.0).await;

    if recovers {
        // Consistent poses again (from where the fault left it): back in
        // after ten poses over two seconds of its clock.
        let got = send_all(&mut sink, &mut stream, track(100.0, 60)).await;
        let status = h.vessel("faulty").await;
        assert!(status["quarantine"].is_null(), "still held: {status}");
        assert_eq!(status["live"], true, "{status}");
        assert!(
            got.iter()
                .any(|m| m["type"] == "command" && m["hold"].is_null()),
            "{got:?}"
        );
        assert_eq!(h.metric("seacover_vessels_quarantined").await, 0.0);
    }
    h.fleet_keeps_going(1.0).await;
}

/// "Why" 1: a pose with x = 2e7 made every tick's fleet invalid: no cell,
/// no command for anyone, H 0, until that link went quiet.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_out_of_range_pose_quarantines_its_vessel_alone() {
    quarantine_case(
        |t0| {
            (0..20)
                .map(|i| pose(t0 + i as f64 * 0.05, 2e7, 50.0))
                .collect()
        },
        "out_of_range",
        true,
    )
    .await;
}

/// "Why" 2: a pose 1000 km from the last one 50 ms later was believed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_jump_no_hull_can_make_quarantines_its_vessel() {
    // 300 m off the region (inside the 500 m margin) in 50 ms.
    quarantine_case(
        |t0| {
            (0..20)
                .map(|i| pose(t0 + i as f64 * 0.05, 400.0 + i as f64 * 0.05, 50.0))
                .collect()
        },
        "jump",
        true,
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_pose_a_thousand_kilometres_away_is_outside_the_region() {
    quarantine_case(
        |t0| {
            (0..20)
                .map(|i| pose(t0 + i as f64 * 0.05, 1.0e6, 50.0))
                .collect()
        },
        "outside_region",
        false,
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_clock_going_backwards_quarantines_its_vessel() {
    quarantine_case(
        // Each pose 1 s before the one before it.
        |t0| {
            (0..20)
                .map(|i| pose(t0 - 1.0 - i as f64, 51.0, 50.0))
                .collect()
        },
        "time_backwards",
        true,
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_pose_reporting_an_impossible_speed_quarantines_its_vessel() {
    let fast = |t0: f64| {
        (0..20)
            .map(|i| {
                Message::text(
                    json!({"type": "pose", "t": t0 + i as f64 * 0.05, "x": 51.0, "y": 50.0,
                           "psi": 0.0, "u": 40.0, "v": 0.0, "r": 0.0})
                    .to_string(),
                )
            })
            .collect()
    };
    quarantine_case(fast, "too_fast", true).await;
}

/// NaN and infinities cannot be written in JSON: such frames are refused
/// as malformed at the link, and the link closes after five.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn non_numbers_are_refused_at_the_link() {
    let h = Harness::start().await;
    let (mut sink, mut stream) = hello(h.ws(), "faulty").await;
    let before = h
        .metric("seacover_messages_rejected_total{reason=\"malformed\"}")
        .await;
    let frames = (0..3)
        .map(|i| {
            Message::text(format!(
                r#"{{"type":"pose","t":{i},"x":NaN,"y":1e999,"psi":0,"u":0,"v":0,"r":0}}"#
            ))
        })
        .collect();
    let got = send_all(&mut sink, &mut stream, frames).await;
    assert!(got.iter().any(|m| m["code"] == "malformed"), "{got:?}");
    let after = h
        .metric("seacover_messages_rejected_total{reason=\"malformed\"}")
        .await;
    assert!(after >= before + 3.0, "{before} → {after}");
    h.fleet_keeps_going(2.0).await;
}

/// A link flooding poses is cut to its budget; the others' commands keep
/// coming.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flooding_link_is_cut_to_its_budget() {
    let h = Harness::start().await;
    let (mut sink, mut stream) = hello(h.ws(), "flood").await;
    let flood = tokio::spawn(async move {
        let start = Instant::now();
        let mut sent = 0u64;
        let mut errors = 0u64;
        while start.elapsed() < Duration::from_secs(3) {
            for _ in 0..50 {
                let t = sent as f64 * 1e-4;
                if sink.send(pose(t, 50.0, 50.0)).await.is_err() {
                    return (sent, errors);
                }
                sent += 1;
            }
            while let Ok(Some(Ok(Message::Text(t)))) =
                tokio::time::timeout(Duration::from_millis(1), stream.next()).await
            {
                if t.contains("rate_limited") {
                    errors += 1;
                }
            }
        }
        (sent, errors)
    });
    h.fleet_keeps_going(3.0).await;
    let (sent, errors) = flood.await.unwrap();
    // What is still in the server's socket buffer is read and counted.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let dropped = h
        .metric("seacover_messages_rejected_total{reason=\"rate_limited\"}")
        .await;
    // 3 s of wall time at warp 10 is 30 mission seconds: a budget of 3000
    // poses, and a burst of 100.
    assert!(sent > 10_000, "the flood sent only {sent} poses");
    assert!(
        dropped >= sent.saturating_sub(3500) as f64,
        "{dropped} of {sent} dropped"
    );
    assert!(errors >= 1, "the flooding link was never told");
}

/// A vessel that falls silent with its link open leaves the partition
/// after the liveness timeout; the others take its water and go on.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_vessel_silent_on_an_open_link_leaves_the_partition() {
    let h = Harness::start().await;
    let (mut sink, mut stream) = hello(h.ws(), "quiet").await;
    let _ = send_all(&mut sink, &mut stream, track(10.0, 20)).await;
    assert_eq!(h.vessel("quiet").await["live"], true);
    // Silent: 3 mission seconds are 0.3 s here.
    tokio::time::sleep(Duration::from_millis(600)).await;
    let status = h.vessel("quiet").await;
    assert_eq!(
        (status["connected"].clone(), status["live"].clone()),
        (json!(true), json!(false)),
        "{status}"
    );
    h.fleet_keeps_going(2.0).await;
    drop(sink);
}

/// One id on two links: the newer link wins, the older is told
/// `replaced` and closed; the rest never notice.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_id_on_two_links_keeps_the_newer() {
    let h = Harness::start().await;
    let (mut a, mut a_in) = hello(h.ws(), "twin").await;
    let _ = send_all(&mut a, &mut a_in, track(10.0, 10)).await;
    let (mut b, mut b_in) = hello(h.ws(), "twin").await;
    let mut replaced = false;
    for _ in 0..20 {
        let m = next_json(&mut a_in).await;
        if m.is_null() {
            break;
        }
        replaced |= m["code"] == "replaced";
    }
    assert!(replaced, "the older link was not told");
    let got = send_all(&mut b, &mut b_in, track(11.0, 20)).await;
    assert!(got.iter().any(|m| m["type"] == "command"), "{got:?}");
    h.fleet_keeps_going(2.0).await;
}

/// "Why" 3, coordinator mode: a coordinator restarted on an empty store
/// served its built-in mission, and every vessel of a fleet at sea on
/// another took it. Now it holds them until an operator puts a mission;
/// the same mission (the same name) holds no one.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coordinator_restarted_without_the_mission_holds_the_fleet_until_one_is_put() {
    let mut h = Harness::start().await;
    h.restart_with_an_empty_store();
    h.until(30, "the same mission: eight live, none held", |vs| {
        healthy(vs).len() == 8
    })
    .await;

    // The fleet's mission is now one the built-in default is not.
    h.add_risk_object("fleet").await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    h.restart_with_an_empty_store();
    let stray = |vs: &[Value]| {
        vs.iter()
            .filter(|v| v["connected"] == true && v["live"] == false)
            .filter(|v| v["quarantine"]["code"] == "unknown_mission")
            .filter(|v| v["last_command"]["hold"].is_string())
            .filter(|v| v["last_command"]["u_d"] == 0.0 && v["last_command"]["r_d"] == 0.0)
            .count()
    };
    h.until(
        30,
        "eight vessels held for following another mission",
        |vs| stray(vs) == 8,
    )
    .await;
    // Their poses are consistent, and still they are held: only the
    // operator decides.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let vs = h.vessels().await;
    assert_eq!(stray(&vs), 8, "released without an operator: {vs:#?}");
    assert!(
        vs[0]["quarantine"]["reason"]
            .as_str()
            .is_some_and(|r| r.contains("put a mission")),
        "{:#}",
        vs[0]
    );
    assert_eq!(h.metric("seacover_vessels_quarantined").await, 8.0);
    let coverage = h.get("/api/v1/coverage").await;
    assert_eq!(
        coverage["cells"].as_array().map(Vec::len),
        Some(0),
        "{coverage}"
    );

    // The operator's change makes it the fleet's mission.
    h.add_risk_object("shore").await;
    h.until(10, "all eight released and commanded", |vs| {
        healthy(vs).len() == 8
    })
    .await;
    h.fleet_keeps_going(2.0).await;
}

/// "Why" 8: a coordinator that refuses the agents' token makes them say
/// which flag carries it and exit non-zero, instead of retrying for ever.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_agent_refused_its_token_names_the_flag_and_exits() {
    let data = tempfile::tempdir().unwrap();
    let mut serve = serve_unrecorded(data.path());
    serve.args(["--token", "right"]).stderr(Stdio::null());
    let (server, addr) = start(serve);
    let _server = KillOnDrop(server);
    for token in [None, Some("wrong")] {
        let mut agent = Command::new(env!("CARGO_BIN_EXE_seacover"));
        agent
            .args([
                "agent",
                "--server",
                &format!("http://{addr}"),
                "--vessels",
                "2",
            ])
            .env_remove("SEACOVER_TOKEN")
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        if let Some(t) = token {
            agent.args(["--token", t]);
        }
        let started = Instant::now();
        let child = KillOnDrop(agent.spawn().unwrap());
        let out = wait_with_timeout(child, Duration::from_secs(30));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{token:?}: exited {}", out.status);
        assert!(
            stderr.contains("--token") && stderr.contains("SEACOVER_TOKEN"),
            "{token:?}: {stderr}"
        );
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "took {:?}",
            started.elapsed()
        );
    }
}

/// "Why" 8: `demo` on a public address without a token refuses before it
/// prints anything or starts a vessel.
#[test]
fn demo_refuses_a_public_bind_without_a_token_at_once() {
    let started = Instant::now();
    let mut demo = Command::new(env!("CARGO_BIN_EXE_seacover"));
    demo.args(["demo", "--bind", "0.0.0.0:0"])
        .env_remove("SEACOVER_TOKEN")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let out = wait_with_timeout(KillOnDrop(demo.spawn().unwrap()), Duration::from_secs(10));
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stdout).is_empty(),
        "printed a banner"
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("without a token"));
    assert!(started.elapsed() < Duration::from_secs(5));
}

/// Waits for a child up to `limit`, killing it past that.
fn wait_with_timeout(mut child: KillOnDrop, limit: Duration) -> std::process::Output {
    let deadline = Instant::now() + limit;
    while child.0.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "still running after {limit:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
    let mut stderr = String::new();
    let mut stdout = String::new();
    use std::io::Read;
    if let Some(mut e) = child.0.stderr.take() {
        let _ = e.read_to_string(&mut stderr);
    }
    if let Some(mut o) = child.0.stdout.take() {
        let _ = o.read_to_string(&mut stdout);
    }
    std::process::Output {
        status: child.0.wait().unwrap(),
        stdout: stdout.into_bytes(),
        stderr: stderr.into_bytes(),
    }
}
