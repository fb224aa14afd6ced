//! The mission's store: what was acknowledged survives `kill -9` at any
//! moment, and a fleet finds the same mission after a restart.
//!
//! The SIGKILL test drives the real `seacover serve` binary with a stream of
//! writes, kills it at a random moment, restarts it on the same data
//! directory and compares what is stored with a model of every acknowledged
//! write. The one write in flight at the kill may or may not have landed;
//! nothing else may differ.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use crate::common::inprocess::Server;
use crate::common::process::signal;
use crate::common::server::{eventually, get_json, mission, serve_command, spawn_server, start};
use rand::{RngExt, SeedableRng};
use seacover::agent::{AgentConfig, paper_vessels, run_fleet};
use seacover::control::model::VesselParams;
use seacover::protocol::{MissionDocument, RiskObjectDocument, VesselStatusDocument};
use seacover::server::ServeConfig;
use serde_json::json;
use tokio_util::sync::CancellationToken;

/// The risk part of the mission as the model sees it: base and objects by id
/// in order.
#[derive(Debug, Clone, PartialEq)]
struct Model {
    base: f64,
    objects: Vec<(String, f64)>,
}

impl Model {
    fn of(m: &MissionDocument) -> Model {
        Model {
            base: m.risk.base,
            objects: m
                .risk
                .objects
                .iter()
                .map(|o| (o.id.clone().unwrap(), o.alpha))
                .collect(),
        }
    }
}

enum Write {
    Base(f64),
    Add(String, f64),
    Put(String, f64),
    Delete(String),
}

impl Write {
    fn apply(&self, m: &mut Model) {
        match self {
            Write::Base(b) => m.base = *b,
            Write::Add(id, a) => m.objects.push((id.clone(), *a)),
            Write::Put(id, a) => {
                m.objects.iter_mut().find(|(i, _)| i == id).unwrap().1 = *a;
            }
            Write::Delete(id) => m.objects.retain(|(i, _)| i != id),
        }
    }

    /// Sends the write; `Ok(true)` when acknowledged, `Ok(false)` when
    /// refused (rate limit), `Err` when the server died under it.
    async fn send(&self, http: &reqwest::Client, addr: &str) -> Result<bool, reqwest::Error> {
        let url = |p: &str| format!("http://{addr}{p}");
        let response = match self {
            Write::Base(b) => {
                http.put(url("/api/v1/mission/risk/base"))
                    .json(&json!({ "value": b }))
                    .send()
                    .await?
            }
            Write::Add(id, a) => {
                http.post(url("/api/v1/risk-objects"))
                    .json(&json!({"id": id, "x": 50.0, "y": 50.0, "alpha": a, "sigma": 5.0}))
                    .send()
                    .await?
            }
            Write::Put(id, a) => {
                http.put(url(&format!("/api/v1/risk-objects/{id}")))
                    .json(&json!({"x": 40.0, "y": 60.0, "alpha": a, "sigma": 7.0}))
                    .send()
                    .await?
            }
            Write::Delete(id) => {
                http.delete(url(&format!("/api/v1/risk-objects/{id}")))
                    .send()
                    .await?
            }
        };
        let status = response.status();
        // The acknowledgement is the whole answer, not just its status line.
        response.bytes().await?;
        assert!(
            status.is_success() || status == reqwest::StatusCode::TOO_MANY_REQUESTS,
            "write answered {status}"
        );
        Ok(status.is_success())
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigkill_during_writes_loses_nothing_acknowledged() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let config = dir.path().join("seacover.toml");
    // Room for the test's write rate; the limit itself is tested elsewhere.
    std::fs::write(
        &config,
        "[server]\nwrite_rate = 10000\nwrite_burst = 10000\n",
    )
    .unwrap();
    let http = reqwest::Client::new();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);

    let (mut child, mut addr) = spawn_server(&data, &config);
    let mut model = Model::of(&mission(&http, &addr).await);
    let mut next_id = 0;
    let mut acknowledged_total = 0;
    for round in 0..6 {
        // Kill at a random moment, somewhere in the middle of the writes.
        let kill_after = Duration::from_millis(rng.random_range(150..600));
        let killer = {
            let pid = child.id();
            tokio::spawn(async move {
                tokio::time::sleep(kill_after).await;
                signal(pid, "-KILL");
            })
        };
        let in_flight = loop {
            let write = match rng.random_range(0..10) {
                0..=4 => {
                    next_id += 1;
                    Write::Add(format!("w{next_id}"), rng.random_range(1.0..20.0))
                }
                5..=6 if !model.objects.is_empty() => {
                    let i = rng.random_range(0..model.objects.len());
                    Write::Put(model.objects[i].0.clone(), rng.random_range(1.0..20.0))
                }
                7 if !model.objects.is_empty() => {
                    let i = rng.random_range(0..model.objects.len());
                    Write::Delete(model.objects[i].0.clone())
                }
                _ => Write::Base(rng.random_range(0.01..1.0)),
            };
            match write.send(&http, &addr).await {
                Ok(true) => {
                    write.apply(&mut model);
                    acknowledged_total += 1;
                }
                Ok(false) => {}
                Err(_) => break write,
            }
        };
        killer.await.unwrap();
        let _ = child.wait();

        let (restarted, addr2) = spawn_server(&data, &config);
        child = restarted;
        let stored = Model::of(&mission(&http, &addr2).await);
        let mut with_in_flight = model.clone();
        in_flight.apply(&mut with_in_flight);
        assert!(
            stored == model || stored == with_in_flight,
            "round {round}: the store lost or invented a write: stored base {} with {} objects, \
             acknowledged base {} with {} objects",
            stored.base,
            stored.objects.len(),
            model.base,
            model.objects.len(),
        );
        model = stored;
        // The next round writes to the restarted server.
        addr = addr2;
    }
    assert!(acknowledged_total > 30, "only {acknowledged_total} writes");
    let _ = child.kill();
    let _ = child.wait();
}

/// The coordinator in this process on `bind`, storing the mission in `data`.
async fn start_in_process(bind: &str, data: &Path) -> Server {
    let config = ServeConfig {
        time_warp: 10.0,
        data_dir: Some(data.to_path_buf()),
        ..ServeConfig::default()
    };
    Server::start_on(bind, config).await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn vessels_reconnect_after_a_restart_and_find_the_mission_intact() {
    let dir = tempfile::tempdir().unwrap();
    let http = reqwest::Client::new();
    let server = start_in_process("127.0.0.1:0", dir.path()).await;
    let addr = server.addr;
    let base = server.base();

    let fleet_stop = CancellationToken::new();
    let agents = AgentConfig {
        url: server.ws(),
        time_warp: 10.0,
        pose_hz: 20.0,
        seed: 3,
        token: None,
    };
    let mut vessels = paper_vessels(VesselParams::PAPER);
    vessels.truncate(3);
    let fleet = tokio::spawn(run_fleet(agents, vessels, fleet_stop.clone()));

    let live = |http: reqwest::Client, base: String| async move {
        let Ok(r) = http.get(format!("{base}/api/v1/vessels")).send().await else {
            return Vec::new();
        };
        let vs: Vec<VesselStatusDocument> = r.json().await.unwrap_or_default();
        vs.into_iter()
            .filter(|v| v.connected && v.live && v.last_command.is_some())
            .map(|v| v.id)
            .collect::<Vec<_>>()
    };
    eventually(20, "three vessels live", || {
        let f = live(http.clone(), base.clone());
        async move { f.await.len() == 3 }
    })
    .await;

    // Change the mission, then restart the coordinator on the same address.
    let r = http
        .post(format!("{base}/api/v1/risk-objects"))
        .json(&json!({"id": "kept", "x": 10.0, "y": 90.0, "alpha": 4.0, "sigma": 3.0}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let r = http
        .put(format!("{base}/api/v1/mission/region"))
        .json(&json!({"polygon": [[0, 0], [100, 0], [100, 100], [0, 100]],
                      "holes": [[[45, 45], [55, 45], [55, 55], [45, 55]]]}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let before: MissionDocument = get_json(&http, &format!("{base}/api/v1/mission")).await;
    server.stop().await;

    let server = start_in_process(&addr.to_string(), dir.path()).await;
    assert_eq!(server.addr, addr);
    let after: MissionDocument = get_json(&http, &format!("{base}/api/v1/mission")).await;
    assert_eq!(after, before, "the mission changed across the restart");
    let objects: Vec<RiskObjectDocument> =
        get_json(&http, &format!("{base}/api/v1/risk-objects")).await;
    assert_eq!(objects.last().unwrap().id.as_deref(), Some("kept"));

    // The agents' backoff tops out at 5 s; they come back on their own and
    // get commands again.
    eventually(20, "the fleet back after the restart", || {
        let f = live(http.clone(), base.clone());
        async move { f.await.len() == 3 }
    })
    .await;
    let ids: BTreeMap<String, ()> = live(http.clone(), base.clone())
        .await
        .into_iter()
        .map(|id| (id, ()))
        .collect();
    assert_eq!(
        ids.keys().cloned().collect::<Vec<_>>(),
        ["usv-1", "usv-2", "usv-3"]
    );

    fleet_stop.cancel();
    fleet.await.unwrap().expect("no vessel link gave up");
    server.stop().await;
}

#[test]
fn a_bad_config_file_is_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("bad.toml");
    std::fs::write(&config, "[guidance]\nmax_speed = -2\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["serve", "--bind", "127.0.0.1:0", "--data-dir"])
        .arg(dir.path().join("data"))
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("guidance.max_speed"), "{err}");
    assert!(
        !dir.path().join("data").exists(),
        "a refused config touched the store"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_config_file_seeds_the_store_and_logs_can_be_json() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let config = dir.path().join("seacover.toml");
    std::fs::write(
        &config,
        "tick_hz = 5.0\n[region]\npolygon = [[0, 0], [50, 0], [50, 50], [0, 50]]\n",
    )
    .unwrap();
    let mut command = serve_command(&data, &config);
    command
        .args(["--log-format", "json"])
        .stderr(Stdio::piped());
    let (mut child, addr) = start(command);
    let m = mission(&reqwest::Client::new(), &addr).await;
    assert_eq!(m.tick_hz, 5.0);
    assert_eq!(m.region.polygon[2], [50.0, 50.0]);
    child.kill().unwrap();
    let out = child.wait_with_output().unwrap();
    let logs = String::from_utf8_lossy(&out.stderr);
    let first = logs.lines().next().expect("a log line");
    let entry: serde_json::Value = serde_json::from_str(first).expect("JSON log lines");
    assert_eq!(entry["level"], "INFO", "{entry}");
    assert!(logs.contains("seeded"), "{logs}");
}
