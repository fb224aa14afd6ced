//! Recording (docs/recording.md): real `seacover serve` and `seacover agent`
//! processes on port 0, the files they leave read back by seacover's own
//! reader and by an independent one (Foxglove's Python `mcap` package,
//! `tests/python/check_recording.py`, from the venv scripts/test makes:
//! `SEACOVER_PYTHON`), with every message validated against its channel's
//! schema.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use crate::common::process::{KillOnDrop, signal};
use crate::common::server::{
    eventually, get_json, metric_sum, metrics, record_sim, start, start_saying,
};
use seacover::recorder::messages;
use seacover::recorder::reader::Recording;
use serde_json::{Value, json};

const BIN: &str = env!("CARGO_BIN_EXE_seacover");

/// The interpreter with `mcap` and `jsonschema`; `None` (the test is
/// skipped with a message) without one, except under CI=true.
fn python() -> Option<PathBuf> {
    crate::common::process::venv_python(
        "recording",
        &["mcap", "jsonschema"],
        "Python with Foxglove's mcap package and jsonschema",
    )
}

/// The independent reader's report of `file`.
fn check(python: &Path, file: &Path) -> Value {
    crate::common::process::recording_report(python, file)
}

struct Server {
    child: Child,
    addr: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(data: &Path, extra: &[&str]) -> Server {
    let mut command = Command::new(BIN);
    command
        .args([
            "serve",
            "--bind",
            "127.0.0.1:0",
            "--time-warp",
            "4",
            "--data-dir",
        ])
        .arg(data)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::null());
    let (child, addr) = start(command);
    Server { child, addr }
}

fn agents(addr: &str, n: usize) -> Child {
    Command::new(BIN)
        .args(["agent", "--server", &format!("http://{addr}")])
        .args(["--vessels", &n.to_string(), "--time-warp", "4"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

fn recordings(data: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(data.join("recordings"))
        .map(|d| d.map(|e| e.unwrap().path()).collect())
        .unwrap_or_default();
    files.sort();
    files
}

/// A metric's value from `/metrics` (summed over its labels).
async fn metric(http: &reqwest::Client, addr: &str, name: &str, label: &str) -> f64 {
    metric_sum(&metrics(http, addr).await, name, label)
}

fn counts(recording: &Recording) -> BTreeMap<String, u64> {
    recording
        .channels()
        .into_iter()
        .map(|(c, n)| (c.topic.to_string(), n))
        .collect()
}

/// A whole run: every pose received and every command sent is in the file,
/// with the mission, its change and the events; both readers agree and
/// every message fits its schema.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_is_recorded_whole() {
    let Some(python) = python() else { return };
    let data = tempfile::tempdir().unwrap();
    let server = serve(data.path(), &[]);
    let http = reqwest::Client::new();
    let mut fleet = agents(&server.addr, 3);
    let url = |p: &str| format!("http://{}{p}", server.addr);
    eventually(20, "three vessels commanded", || async {
        let v: Vec<Value> = get_json(&http, &url("/api/v1/vessels")).await;
        v.len() == 3 && v.iter().all(|v| !v["last_command"].is_null())
    })
    .await;
    let posted = http
        .post(url("/api/v1/risk-objects"))
        .json(&json!({"x": 30, "y": 40, "alpha": 20, "sigma": 10}))
        .send()
        .await
        .unwrap();
    assert!(posted.status().is_success());
    // A geo-referenced mission adds Foxglove's map channels.
    let origin = http
        .put(url("/api/v1/mission/origin"))
        .json(&json!({"lat": 59.91, "lon": 10.75}))
        .send()
        .await
        .unwrap();
    assert!(origin.status().is_success());
    let refused = http
        .put(url("/api/v1/mission/risk/base"))
        .body("not json")
        .send()
        .await
        .unwrap();
    assert_eq!(refused.status(), 400);
    tokio::time::sleep(Duration::from_secs(2)).await;
    // The fleet stops first, so that what the coordinator counted is final.
    signal(fleet.id(), "-TERM");
    fleet.wait().unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let poses_in = metric(&http, &server.addr, "seacover_messages_in_total", "pose").await;
    let commands_out = metric(
        &http,
        &server.addr,
        "seacover_messages_out_total",
        "command",
    )
    .await;
    let mut server = server;
    signal(server.child.id(), "-TERM");
    server.child.wait().unwrap();

    let files = recordings(data.path());
    assert_eq!(files.len(), 1, "{files:?}");
    let name = files[0].file_name().unwrap().to_str().unwrap().to_string();
    assert!(
        name.len() == "2026-11-23T10-00-00Z.mcap".len() && name.ends_with("Z.mcap"),
        "{name}"
    );
    let recording = Recording::open(&files[0]).unwrap();
    assert!(!recording.recovered(), "a finished file has its index");
    let ours = counts(&recording);
    assert_eq!(ours[messages::POSE] as f64, poses_in, "{ours:?}");
    let commands = ours[messages::COMMAND] as f64;
    assert!(
        (commands_out..=commands_out + 3.0).contains(&commands),
        "{commands} commands recorded, {commands_out} written"
    );
    assert_eq!(ours[messages::MISSION], 3, "the start and the two changes");
    assert!(ours[messages::MAP_CELLS] >= 1, "{ours:?}");
    assert!(ours["/seacover/map/fix/usv-1"] >= 1, "{ours:?}");
    assert!(ours[messages::COVERAGE] > 20);
    let events: Vec<String> = recording
        .messages(&|t| t == messages::EVENTS)
        .map(|m| {
            let e: Value = serde_json::from_slice(&m.unwrap().data).unwrap();
            e["kind"].as_str().unwrap().to_string()
        })
        .collect();
    for kind in ["link_up", "link_down", "rejected_request", "shutdown"] {
        assert!(events.iter().any(|e| e == kind), "{kind} in {events:?}");
    }
    // Every chunk spans at most a second of mission time.
    for (start, end) in recording.chunk_spans() {
        assert!(end - start <= 1_000_000_000, "{start}..{end}");
    }

    let theirs = check(&python, &files[0]);
    assert_eq!(theirs["finished"], true);
    assert_eq!(theirs["invalid"], 0, "{theirs}");
    for (topic, n) in &ours {
        assert_eq!(theirs["counts"][topic], json!(n), "{topic}: {theirs}");
    }
    assert_eq!(theirs["schemas"][messages::POSE], "seacover.PoseRecord");
    assert_eq!(theirs["schemas"][messages::MAP_CELLS], "foxglove.GeoJSON");
    assert_eq!(
        theirs["schemas"]["/seacover/map/fix/usv-1"],
        "foxglove.LocationFix"
    );
}

/// `kill -9` mid-run: the file has no summary, yet it reads — in Python's
/// recovery and in seacover's reader — up to at most the last second.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_coordinator_leaves_a_readable_recording() {
    let Some(python) = python() else { return };
    let data = tempfile::tempdir().unwrap();
    let mut server = serve(data.path(), &[]);
    let mut fleet = agents(&server.addr, 3);
    let http = reqwest::Client::new();
    let addr = server.addr.clone();
    eventually(20, "vessels commanded", || async {
        metric(&http, &addr, "seacover_messages_out_total", "command").await > 50.0
    })
    .await;
    tokio::time::sleep(Duration::from_secs(3)).await;
    let before: Value = get_json(&http, &format!("http://{addr}/api/v1/coverage")).await;
    server.child.kill().unwrap(); // SIGKILL
    server.child.wait().unwrap();
    let _ = fleet.kill();
    let _ = fleet.wait();
    let last_tick_time = before["time"].as_f64().unwrap();

    let files = recordings(data.path());
    assert_eq!(files.len(), 1);
    let recording = Recording::open(&files[0]).unwrap();
    assert!(recording.recovered(), "a killed run's file has no index");
    let (_, end) = recording.span().unwrap();
    // At most the last second (of mission time, at warp 4: a quarter
    // second of wall time) is lost, plus the time between the read of
    // /coverage and the kill.
    assert!(
        end as f64 * 1e-9 >= last_tick_time - 1.0,
        "recovered up to {} s, the coordinator was at {last_tick_time} s",
        end as f64 * 1e-9
    );
    let ours = counts(&recording);
    assert!(
        ours[messages::POSE] > 0 && ours[messages::COVERAGE] > 0,
        "{ours:?}"
    );

    let theirs = check(&python, &files[0]);
    assert_eq!(theirs["finished"], false);
    assert_eq!(theirs["invalid"], 0, "{theirs}");
    for topic in [messages::POSE, messages::COVERAGE, messages::MISSION] {
        let n = theirs["counts"][topic].as_u64().unwrap();
        assert!(
            n >= ours[topic],
            "{topic}: python {n}, ours {}",
            ours[topic]
        );
    }
}

/// `--record off` writes nothing; an unwritable recordings directory stops
/// the recording (error, metric) and not the coordinator; a small
/// `--record-max-mb` rotates, each file starting with the mission.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn off_unwritable_and_rotation() {
    let http = reqwest::Client::new();

    let off = tempfile::tempdir().unwrap();
    let server = serve(off.path(), &["--no-record"]);
    let fleet = agents(&server.addr, 2);
    tokio::time::sleep(Duration::from_secs(2)).await;
    assert!(!off.path().join("recordings").exists());
    drop(KillOnDrop(fleet));
    drop(server);

    let blocked = tempfile::tempdir().unwrap();
    std::fs::write(
        blocked.path().join("recordings"),
        b"a file, not a directory",
    )
    .unwrap();
    let server = serve(blocked.path(), &[]);
    let addr = server.addr.clone();
    eventually(10, "the recording error counted", || async {
        metric(&http, &addr, "seacover_recording_errors_total", "").await >= 1.0
    })
    .await;
    assert_eq!(
        metric(&http, &addr, "seacover_recording_active", "").await,
        0.0
    );
    let fleet = agents(&server.addr, 2);
    eventually(20, "the coordinator still commands", || async {
        metric(&http, &addr, "seacover_messages_out_total", "command").await > 20.0
    })
    .await;
    drop(KillOnDrop(fleet));
    drop(server);

    let rotated = tempfile::tempdir().unwrap();
    let mut server = serve(rotated.path(), &["--record-max-mb", "0"]);
    let fleet = agents(&server.addr, 2);
    let dir = rotated.path().to_path_buf();
    eventually(20, "three files", || async { recordings(&dir).len() >= 3 }).await;
    drop(KillOnDrop(fleet));
    signal(server.child.id(), "-TERM");
    server.child.wait().unwrap();
    for file in recordings(&dir) {
        let r = Recording::open(&file).unwrap();
        assert!(!r.recovered(), "{file:?} was finished when rotated");
        let first = r.messages(&|_| true).next().expect("not empty").unwrap();
        assert_eq!(&*first.topic, messages::MISSION, "{file:?}");
    }
}

/// `--record-keep` with a byte limit: the oldest files go first (an
/// earlier run's file before this run's), names the recorder did not give
/// are left alone, the directory never holds more than the limit, and
/// every file left stands alone for Foxglove's reader (it starts with the
/// mission, is finished, and every message fits its schema).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn retention_deletes_the_oldest_first() {
    let Some(python) = python() else { return };
    let http = reqwest::Client::new();
    let data = tempfile::tempdir().unwrap();
    let dir = data.path().join("recordings");
    std::fs::create_dir_all(&dir).unwrap();
    // An earlier run's file (cut short: it has no summary) and an
    // operator's note.
    let earlier = dir.join("2000-01-01T00-00-00Z.mcap");
    std::fs::write(
        &earlier,
        [b"\x89MCAP0\r\n".as_slice(), &[0; 20_000]].concat(),
    )
    .unwrap();
    let note = dir.join("notes.mcap.txt");
    std::fs::write(&note, b"not a recording").unwrap();
    const LIMIT: u64 = 60_000;
    // A quarter of the limit is below a second's worth: a file a second.
    let mut server = serve(data.path(), &["--record-keep", "60kB"]);
    let fleet = KillOnDrop(agents(&server.addr, 3));
    let addr = server.addr.clone();
    let within = |files: &[PathBuf]| {
        let bytes: u64 = files
            .iter()
            .filter_map(|f| std::fs::metadata(f).ok())
            .map(|m| m.len())
            .sum();
        // A flush may land just before the pass that deletes.
        assert!(bytes <= LIMIT + 32 * 1024, "{bytes} bytes in {files:?}");
    };
    eventually(40, "three files deleted", || async {
        within(&recordings(data.path()));
        metric(&http, &addr, "seacover_recording_files_deleted_total", "").await >= 3.0
    })
    .await;
    drop(fleet);
    signal(server.child.id(), "-TERM");
    server.child.wait().unwrap();
    assert!(!earlier.exists(), "the earlier run's file goes first");
    assert!(note.exists(), "a file the recorder did not name stays");
    let files: Vec<PathBuf> = recordings(data.path())
        .into_iter()
        .filter(|f| f.extension().is_some_and(|e| e == "mcap"))
        .collect();
    within(&files);
    assert!(files.len() >= 2, "{files:?}");
    for file in &files {
        let theirs = check(&python, file);
        assert_eq!(theirs["finished"], true, "{file:?}: {theirs}");
        assert_eq!(theirs["invalid"], 0, "{file:?}: {theirs}");
        let r = Recording::open(file).unwrap();
        let first = r.messages(&|_| true).next().expect("not empty").unwrap();
        assert_eq!(&*first.topic, messages::MISSION, "{file:?}");
    }
}

/// `--record-max-minutes` rotates by age (here 3 s of mission time, 0.75 s
/// of wall time at warp 4), and the
/// events channel tells a link's story with who and why: its link up with
/// the peer, a refused frame (code, peer), its fall into silence (liveness
/// takeover) and its return, a refused request (code, peer), the link down
/// and the shutdown; a story told across the rotated files.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rotation_by_age_and_a_links_events() {
    use futures_util::SinkExt;
    use tokio_tungstenite::tungstenite::Message;
    let data = tempfile::tempdir().unwrap();
    let mut server = serve(data.path(), &["--record-max-minutes", "0.05"]);
    let http = reqwest::Client::new();
    let ws = format!("ws://{}/api/v1/vessels/link", server.addr);
    let pose = |x: f64| {
        Message::text(
            json!({"type": "pose", "t": 0, "x": x, "y": 20, "psi": 0, "u": 0, "v": 0, "r": 0})
                .to_string(),
        )
    };
    let (mut sink, mut stream) = crate::common::link::hello(ws, "probe").await;
    sink.send(pose(10.0)).await.ok().unwrap();
    sink.send(Message::text("not a frame")).await.ok().unwrap();
    let error = loop {
        let frame = crate::common::link::next_json(&mut stream).await;
        assert!(
            !frame.is_null(),
            "the link stays open after a refused frame"
        );
        if frame["type"] != "command" {
            break frame;
        }
    };
    assert_eq!(error["type"], "error", "{error}");
    // The link reads what it is sent (a link must keep up) until it closes.
    let drain = tokio::spawn(async move {
        while crate::common::link::next_json(&mut stream).await != Value::Null {}
    });
    // Silent for 2 s of wall time: 8 s of mission time at warp 4, past
    // the 3 s liveness timeout. The link stays open, so only liveness can
    // take the vessel out.
    tokio::time::sleep(Duration::from_secs(2)).await;
    sink.send(pose(11.0)).await.ok().unwrap();
    let refused = http
        .post(format!("http://{}/api/v1/risk-objects", server.addr))
        .json(&json!({"x": 30, "y": 40, "alpha": -1, "sigma": 10}))
        .send()
        .await
        .unwrap();
    assert_eq!(refused.status(), 422);
    let dir = data.path().to_path_buf();
    eventually(20, "three files, rotated by age", || async {
        recordings(&dir).len() >= 3
    })
    .await;
    drop(sink);
    let _ = drain.await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    signal(server.child.id(), "-TERM");
    server.child.wait().unwrap();

    let files = recordings(&dir);
    let mut events = Vec::new();
    for file in &files {
        let r = Recording::open(file).unwrap();
        assert!(!r.recovered(), "{file:?} was finished when rotated");
        let first = r.messages(&|_| true).next().expect("not empty").unwrap();
        assert_eq!(&*first.topic, messages::MISSION, "{file:?}");
        // Rotated by age, not size: every file is far below 256 MiB.
        assert!(std::fs::metadata(file).unwrap().len() < 1 << 20);
        events.extend(
            r.messages(&|t| t == messages::EVENTS)
                .map(|m| serde_json::from_slice::<Value>(&m.unwrap().data).unwrap()),
        );
    }
    let find = |kind: &str| {
        events
            .iter()
            .find(|e| e["kind"] == kind)
            .unwrap_or_else(|| panic!("no {kind} in {events:?}"))
            .clone()
    };
    let local = |e: &Value| {
        e["peer"]
            .as_str()
            .is_some_and(|p| p.starts_with("127.0.0.1:"))
    };
    let up = find("link_up");
    assert!(up["vessel"] == "probe" && local(&up), "{up}");
    let frame = find("rejected_frame");
    assert!(frame["vessel"] == "probe" && local(&frame), "{frame}");
    assert_eq!(frame["code"], error["code"], "{frame}");
    let takeover = find("liveness_takeover");
    let regained = find("liveness_regained");
    assert_eq!(takeover["vessel"], "probe");
    assert_eq!(regained["vessel"], "probe");
    assert!(
        takeover["time"].as_f64().unwrap() > frame["time"].as_f64().unwrap()
            && regained["time"].as_f64().unwrap() > takeover["time"].as_f64().unwrap(),
        "{events:?}"
    );
    let request = find("rejected_request");
    assert!(local(&request), "{request}");
    assert_eq!(request["code"], "invalid", "{request}");
    assert_eq!(find("link_down")["vessel"], "probe");
    find("shutdown");
}

/// `sim --record`: the same seed gives the same messages; the
/// file replays, and a seek puts the vessels where the simulation had them
/// at that moment; the replay refuses writes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_simulation_records_the_same_file_and_replays() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str| record_sim(dir.path(), name);
    let (a, b) = (run("a"), run("b"));
    // The same messages (the summary's order of channels is the mcap
    // crate's hash map order, so the files' bytes may differ there).
    let all = |f: &Path| -> Vec<(String, u64, u64, Vec<u8>)> {
        Recording::open(f)
            .unwrap()
            .messages(&|_| true)
            .map(|m| {
                let m = m.unwrap();
                (m.topic.to_string(), m.log_time, m.publish_time, m.data)
            })
            .collect()
    };
    assert!(all(&a) == all(&b), "the same seed, the same messages");
    let recording = Recording::open(&a).unwrap();
    let n = counts(&recording);
    assert_eq!(n[messages::COVERAGE], 61, "{n:?}");
    assert_eq!(n[messages::SIM_VESSEL], 8 * 61);
    // Where the simulation had each vessel at 3.0 s and 5.0 s.
    let truth_at = |t: f64| -> BTreeMap<String, [f64; 2]> {
        recording
            .messages(&|topic| topic == messages::SIM_VESSEL)
            .map(|m| serde_json::from_slice::<messages::SimVesselRecord>(&m.unwrap().data).unwrap())
            .filter(|r| (r.time - t).abs() < 1e-9)
            .map(|r| (r.vessel, [r.truth[0], r.truth[1]]))
            .collect()
    };

    let mut command = Command::new(BIN);
    command
        .args(["replay", "--bind", "127.0.0.1:0", "--speed", "1"])
        .arg(&a)
        .stdout(Stdio::piped())
        .stderr(Stdio::null());
    let (child, addr) = start_saying(command, "seacover: replaying");
    let replay = KillOnDrop(child);
    let url = |p: &str| format!("http://{addr}{p}");
    let http = reqwest::Client::new();
    let status: Value = get_json(&http, &url("/api/v1/replay")).await;
    assert_eq!(status["end"], json!(6.0), "{status}");
    for t in [3.0, 5.0] {
        let began = std::time::Instant::now();
        let seek = http
            .put(url("/api/v1/replay"))
            .json(&json!({"playing": false, "time": t}))
            .send()
            .await
            .unwrap();
        assert!(seek.status().is_success());
        let took = began.elapsed();
        let vessels: Vec<Value> = get_json(&http, &url("/api/v1/vessels")).await;
        let truth = truth_at(t);
        assert_eq!(vessels.len(), 8);
        for v in &vessels {
            let id = v["id"].as_str().unwrap();
            let (x, y) = (
                v["pose"]["x"].as_f64().unwrap(),
                v["pose"]["y"].as_f64().unwrap(),
            );
            assert_eq!([x, y], truth[id], "{id} at {t} s");
        }
        let coverage: Value = get_json(&http, &url("/api/v1/coverage")).await;
        assert!((coverage["time"].as_f64().unwrap() - t).abs() < 1e-9);
        eprintln!("seek to {t} s answered in {took:?}");
    }
    let write = http
        .post(url("/api/v1/risk-objects"))
        .json(&json!({"x": 30, "y": 40, "alpha": 20, "sigma": 10}))
        .send()
        .await
        .unwrap();
    assert_eq!(write.status(), 409);
    let body: Value = write.json().await.unwrap();
    assert!(
        body["error"]["message"]
            .as_str()
            .unwrap()
            .contains("replay"),
        "{body}"
    );
    drop(replay);
}

/// `sim --record` of a geo-referenced scenario (the paper's, given an
/// origin) has Foxglove's map channels: once a second each vessel's
/// `foxglove.LocationFix`, where geographiclib places its true position
/// (to the plane's s³/6R², far below a millimetre here), and the cells and
/// vessels as `foxglove.GeoJSON`.
#[test]
fn a_geo_referenced_simulation_records_the_map_channels() {
    use seacover::recorder::messages::{GeoJson, LocationFix, SimVesselRecord};
    let dir = tempfile::tempdir().unwrap();
    let origin = (59.91, 10.75);
    let mut scenario: Value =
        serde_json::from_str(seacover::mission::builtin::PAPER_SCENARIO).unwrap();
    scenario["origin"] = json!({"lat": origin.0, "lon": origin.1});
    let path = dir.path().join("paper-oslo.json");
    std::fs::write(&path, scenario.to_string()).unwrap();
    let file = crate::common::server::record_scenario(dir.path(), "geo", &path, 3.0);
    let recording = Recording::open(&file).unwrap();
    let ours = counts(&recording);
    // Seconds 0, 1, 2 and 3 of a 3 s run.
    assert_eq!(ours[messages::MAP_CELLS], 4, "{ours:?}");
    let truth: Vec<SimVesselRecord> = recording
        .messages(&|t| t == messages::SIM_VESSEL)
        .map(|m| serde_json::from_slice(&m.unwrap().data).unwrap())
        .collect();
    let mut fixes = 0;
    for m in recording.messages(&|t| t.starts_with(messages::MAP_FIX_PREFIX)) {
        let m = m.unwrap();
        let fix: LocationFix = serde_json::from_slice(&m.data).unwrap();
        let at = m.log_time as f64 / 1e9;
        let t = truth
            .iter()
            .find(|r| r.vessel == fix.frame_id && (r.time - at).abs() < 1e-9)
            .unwrap_or_else(|| panic!("no truth of {} at {at}", fix.frame_id));
        let (lat, lon) = crate::common::geo::place(origin, t.truth[0], t.truth[1]);
        let (dx, dy) = crate::common::geo::locate((lat, lon), fix.latitude, fix.longitude);
        assert!(dx.hypot(dy) < 1e-3, "{}: {dx} {dy}", fix.frame_id);
        fixes += 1;
    }
    assert_eq!(fixes, 8 * 4);
    let cells = recording
        .messages(&|t| t == messages::MAP_CELLS)
        .next()
        .unwrap()
        .unwrap();
    let cells: GeoJson = serde_json::from_slice(&cells.data).unwrap();
    let cells: Value = serde_json::from_str(&cells.geojson).unwrap();
    let kinds = |kind: &str| {
        cells["features"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|f| f["properties"]["kind"] == kind)
            .count()
    };
    assert_eq!((kinds("cell"), kinds("vessel")), (8, 8), "{cells}");
}

/// `sim --record` of a scenario with a truth also records what the fleet
/// learned from: every sample its hulls took (at their true positions) and
/// every belief it covered; each tick's cells are those of the belief
/// covered then (the run's H), not of the scenario's prior.
#[test]
fn a_learning_simulation_records_its_samples_and_beliefs() {
    use seacover::recorder::messages::{
        BeliefRecord, CoverageRecord, SampleRecord, SimVesselRecord,
    };
    let dir = tempfile::tempdir().unwrap();
    let scenario = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/paper-learning.json"
    ));
    let file = crate::common::server::record_scenario(dir.path(), "learn", scenario, 12.0);
    let learning: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("learn/learning.json")).unwrap(),
    )
    .unwrap();
    let recording = Recording::open(&file).unwrap();
    let ours = counts(&recording);
    assert_eq!(
        ours[messages::SAMPLE],
        learning["samples"].as_u64().unwrap(),
        "{ours:?} {learning}"
    );
    assert_eq!(ours[messages::BELIEF], learning["fits"].as_u64().unwrap());
    let truth: Vec<SimVesselRecord> = recording
        .messages(&|t| t == messages::SIM_VESSEL)
        .map(|m| serde_json::from_slice(&m.unwrap().data).unwrap())
        .collect();
    // Each sample where its hull was.
    for m in recording.messages(&|t| t == messages::SAMPLE) {
        let r: SampleRecord = serde_json::from_slice(&m.unwrap().data).unwrap();
        assert_eq!(r.outcome, "accepted");
        let hull = truth
            .iter()
            .find(|h| h.vessel == r.sample.vessel && (h.time - r.sample.t).abs() < 1e-9)
            .unwrap_or_else(|| panic!("no hull for {:?}", r.sample));
        assert_eq!([r.sample.x, r.sample.y], [hull.truth[0], hull.truth[1]]);
    }
    // The last tick's cells are of the last belief: their masses are the
    // engine's over that belief at the recorded positions.
    let beliefs: Vec<BeliefRecord> = recording
        .messages(&|t| t == messages::BELIEF)
        .map(|m| serde_json::from_slice(&m.unwrap().data).unwrap())
        .collect();
    let last = beliefs.last().unwrap();
    assert_eq!(last.belief.fits as usize, beliefs.len());
    let coverage: CoverageRecord = recording
        .messages(&|t| t == messages::COVERAGE)
        .last()
        .map(|m| serde_json::from_slice(&m.unwrap().data).unwrap())
        .unwrap();
    assert!(last.time <= coverage.time);
    let risk = seacover::mission::convert::risk_field(&last.belief.risk).unwrap();
    let (scenario, _) = seacover::sim::load_scenario(scenario.to_str().unwrap()).unwrap();
    let at_end: Vec<_> = truth
        .iter()
        .filter(|h| (h.time - coverage.time).abs() < 1e-9)
        .collect();
    let fleet = seacover::coverage::Fleet::new(
        at_end
            .iter()
            .zip(scenario.fleet.vessels())
            .map(|(h, v)| seacover::coverage::Vessel {
                position: seacover::geometry::Point {
                    x: h.truth[0],
                    y: h.truth[1],
                },
                ..*v
            })
            .collect(),
    )
    .unwrap();
    let eval = seacover::coverage::evaluate(
        &scenario.region,
        &risk,
        &fleet,
        &seacover::coverage::Options::default(),
    );
    for (cell, ours) in coverage.cells.iter().zip(&eval.cells) {
        assert!(
            (cell.mass - ours.mass).abs() <= 1e-9 * ours.mass.max(1.0),
            "{}: recorded {} against {}",
            cell.id,
            cell.mass,
            ours.mass
        );
    }
    if let Some(report) = crate::common::process::check_recording("recording", &file) {
        assert_eq!(report["invalid"], 0, "{report}");
        assert_eq!(
            report["counts"][messages::BELIEF],
            beliefs.len(),
            "{report}"
        );
    }
}
