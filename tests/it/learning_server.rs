//! A coordinator that learns the risk map (docs/learning.md, "In the
//! coordinator"): the real `seacover serve` with a `[learning]` section, a
//! flat mission risk as the prior, samples of the paper's map posted by a
//! survey over REST, and one vessel on a real link. Checked: the belief
//! `GET /api/v1/risk` answers is the map (within 10 % at its peaks), the
//! vessel's commanded centroid moves to where the map says, each bad sample
//! is refused alone with its code and counted, a coordinator without
//! `[learning]` refuses samples with 409, and an optimistic one's optimism
//! fades with the samples' age.

use std::io::Write;
use std::process::Stdio;

use futures_util::SinkExt;
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

use crate::common::process::KillOnDrop;
use crate::common::server::{density_at, get_json, metric_sum, metrics, serve_command, start};

/// The paper's map, Φ(x, y) = 0.1 + Σ α exp(−d² / 2σ²), σ = 10 m.
fn truth(x: f64, y: f64) -> f64 {
    let g = |cx: f64, cy: f64, a: f64| a * (-((x - cx).powi(2) + (y - cy).powi(2)) / 200.0).exp();
    0.1 + g(25.0, 70.0, 10.0) + g(70.0, 75.0, 13.0) + g(60.0, 25.0, 8.0)
}

fn serve(config: &str, learning: bool) -> (KillOnDrop, String, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("seacover.toml");
    let mut f = std::fs::File::create(&file).unwrap();
    f.write_all(config.as_bytes()).unwrap();
    if learning {
        f.write_all(b"\n[learning]\nrefit = 1.0\n").unwrap();
    }
    let mut command = serve_command(&dir.path().join("data"), &file);
    command.arg("--no-record").stderr(Stdio::null());
    let (child, addr) = start(command);
    (KillOnDrop(child), addr, dir)
}

const FLAT: &str = "[risk]\nbase = 0.1\nobjects = []\n";

async fn post(http: &reqwest::Client, addr: &str, samples: Value) -> (u16, Value) {
    let r = http
        .post(format!("http://{addr}/api/v1/samples"))
        .json(&json!({ "samples": samples }))
        .send()
        .await
        .unwrap();
    (r.status().as_u16(), r.json().await.unwrap())
}

/// Posts a noise-free survey of the map (σ 0.1) every 5 m along the rows
/// `rows` (y = 5 m × row), taken at mission time `t`, one source per row
/// (21 samples each, under its burst); each must be taken. Returns the
/// samples in the order posted.
async fn survey(
    http: &reqwest::Client,
    addr: &str,
    rows: std::ops::Range<u32>,
    t: f64,
) -> Vec<Value> {
    let mut posted = Vec::new();
    for row in rows {
        let y = 5.0 * f64::from(row);
        let samples: Vec<Value> = (0..=20)
            .map(|i| {
                let x = 5.0 * f64::from(i);
                json!({"vessel": format!("survey-{row}"), "t": t, "x": x, "y": y,
                       "value": truth(x, y), "sd": 0.1})
            })
            .collect();
        let (status, answer) = post(http, addr, Value::from(samples.clone())).await;
        assert_eq!((status, &answer["accepted"]), (200, &json!(21)), "{answer}");
        posted.extend(samples);
    }
    posted
}

async fn mission_time(http: &reqwest::Client, addr: &str) -> f64 {
    let c: Value = get_json(http, &format!("http://{addr}/api/v1/coverage")).await;
    c["time"].as_f64().unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coordinator_learns_the_map_from_posted_samples() {
    let (_server, addr, _dir) = serve(FLAT, true);
    let http = reqwest::Client::new();
    let risk_url = format!("http://{addr}/api/v1/risk");
    let before: Value = get_json(&http, &risk_url).await;
    assert_eq!(before["source"], "mission", "{before}");
    assert_eq!(before["fits"], 0);

    // One vessel at the square's centre, on a real link: its centroid.
    let ws = format!("ws://{addr}/api/v1/vessels/link");
    let (mut sink, mut stream) = crate::common::link::hello(ws, "usv-1").await;
    let pose = json!({"type": "pose", "t": 0, "x": 50, "y": 50, "psi": 0, "u": 0, "v": 0, "r": 0});
    let centroid = async |sink: &mut _, stream: &mut _| loop {
        SinkExt::send(sink, Message::text(pose.to_string()))
            .await
            .ok()
            .unwrap();
        let frame = crate::common::link::next_json(stream).await;
        if frame["type"] == "command" {
            let c = &frame["centroid"];
            break (c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
        }
    };
    let flat = centroid(&mut sink, &mut stream).await;
    assert!(
        (flat.0 - 50.0).abs() < 0.5 && (flat.1 - 50.0).abs() < 0.5,
        "over a flat map the centroid is the centre: {flat:?}"
    );

    // A survey every 5 m, one source per row (21 samples each, under its
    // burst), noise-free with σ 0.1.
    let t = mission_time(&http, &addr).await;
    survey(&http, &addr, 0..21, t).await;
    let deadline = tokio::time::Instant::now() + std::time::Duration::from_secs(20);
    let learned = loop {
        let risk: Value = get_json(&http, &risk_url).await;
        if risk["source"] == "learned" {
            break risk;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "no fit in 20 s: {risk}"
        );
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    };
    assert_eq!(learned["samples"], 441, "{learned}");
    for (x, y) in [(25.0, 70.0), (70.0, 75.0), (60.0, 25.0), (5.0, 5.0)] {
        let (got, want) = (density_at(&learned["risk"], x, y), truth(x, y));
        assert!(
            (got - want).abs() <= 0.1 * want.max(1.0),
            "belief at ({x}, {y}): {got} against {want}"
        );
    }
    // The vessel now covers the map: its centroid moves towards the
    // heaviest object, north-east of the centre.
    let mut moved = flat;
    for _ in 0..50 {
        moved = centroid(&mut sink, &mut stream).await;
        if moved.1 > 55.0 {
            break;
        }
    }
    assert!(
        moved.1 > 55.0 && (moved.0 - flat.0).abs() + (moved.1 - flat.1).abs() > 5.0,
        "centroid over the learned map {moved:?}, over the flat one {flat:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn each_bad_sample_is_refused_alone_and_counted() {
    let (_server, addr, _dir) = serve(FLAT, true);
    let http = reqwest::Client::new();
    let t = mission_time(&http, &addr).await;
    let s = |vessel: &str, t: f64, x: f64, value: f64, sd: f64| json!({"vessel": vessel, "t": t, "x": x, "y": 50, "value": value, "sd": sd});
    let batch = json!([
        s("a", t, 50.0, 1.0, 0.1),
        s("a", t, 50.0, 1e300, 0.1),
        s("a", t, 50.0, 1.0, 0.0),
        s("a", t, 400.0, 1.0, 0.1),
        s("a", t + 60.0, 50.0, 1.0, 0.1),
        s("a", t - 3600.0, 50.0, 1.0, 0.1),
        s("bad id!", t, 50.0, 1.0, 0.1),
        s("b", t, 50.0, 1.0, 0.1),
    ]);
    let (status, answer) = post(&http, &addr, batch).await;
    assert_eq!(status, 200, "{answer}");
    assert_eq!(answer["accepted"], 2, "{answer}");
    let codes: Vec<(u64, &str)> = answer["refused"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| (r["index"].as_u64().unwrap(), r["code"].as_str().unwrap()))
        .collect();
    assert_eq!(
        codes,
        [
            (1, "invalid"),
            (2, "invalid"),
            (3, "outside_region"),
            (4, "future"),
            (5, "stale"),
            (6, "invalid")
        ],
        "{answer}"
    );
    // A flood from one source is refused for that source alone.
    let flood: Vec<Value> = (0..300).map(|_| s("loud", t, 50.0, 1.0, 0.1)).collect();
    let (_, answer) = post(&http, &addr, Value::from(flood)).await;
    let floods = answer["refused"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["code"] == "flood")
        .count();
    assert_eq!(answer["accepted"], 200, "the burst");
    assert_eq!(floods, 100);
    let (_, answer) = post(&http, &addr, json!([s("quiet", t, 50.0, 1.0, 0.1)])).await;
    assert_eq!(answer["accepted"], 1, "another source is not held back");
    let text = metrics(&http, &addr).await;
    for (label, n) in [
        ("accepted", 203.0),
        ("invalid", 3.0),
        ("outside_region", 1.0),
        ("future", 1.0),
        ("stale", 1.0),
        ("flood", 100.0),
    ] {
        let got = metric_sum(&text, "seacover_samples_total", &format!("\"{label}\""));
        assert_eq!(got, n, "seacover_samples_total{{outcome={label:?}}}");
    }
    // Too large a batch is refused whole.
    let many: Vec<Value> = (0..1001).map(|_| s("a", t, 50.0, 1.0, 0.1)).collect();
    let (status, _) = post(&http, &addr, Value::from(many)).await;
    assert_eq!(status, 422);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coordinator_that_does_not_learn_refuses_samples() {
    let (_server, addr, _dir) = serve(FLAT, false);
    let http = reqwest::Client::new();
    let sample = json!([{"vessel": "a", "t": 0, "x": 1, "y": 1, "value": 1, "sd": 1}]);
    let (status, answer) = post(&http, &addr, sample).await;
    assert_eq!(status, 409, "{answer}");
    assert!(
        answer["error"]["message"]
            .as_str()
            .unwrap()
            .contains("[learning]"),
        "{answer}"
    );
    let risk: Value = get_json(&http, &format!("http://{addr}/api/v1/risk")).await;
    assert_eq!(risk["source"], "mission");
    assert_eq!(risk["risk"]["base"], 0.1);
}

/// Samples on the vessel link: placed where the vessel is, refused while
/// none of its poses is believed (answered on the link, which stays open),
/// taken once one is.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn samples_on_the_vessel_link_are_taken_once_the_vessel_is_placed() {
    let (_server, addr, _dir) = serve(FLAT, true);
    let http = reqwest::Client::new();
    let ws = format!("ws://{addr}/api/v1/vessels/link");
    let (mut sink, mut stream) = crate::common::link::hello(ws, "usv-1").await;
    let sample = json!({"type": "sample", "x": 50, "y": 50, "value": 2.5, "sd": 0.1});
    sink.send(Message::text(sample.to_string()))
        .await
        .ok()
        .unwrap();
    let error = crate::common::link::next_json(&mut stream).await;
    assert_eq!(error["type"], "error", "{error}");
    assert_eq!(error["code"], "sample_unplaced", "{error}");
    let pose = json!({"type": "pose", "t": 0, "x": 50, "y": 50, "psi": 0, "u": 0, "v": 0, "r": 0});
    loop {
        sink.send(Message::text(pose.to_string()))
            .await
            .ok()
            .unwrap();
        let frame = crate::common::link::next_json(&mut stream).await;
        assert!(!frame.is_null(), "the link stays open");
        if frame["type"] == "command" {
            break;
        }
    }
    sink.send(Message::text(sample.to_string()))
        .await
        .ok()
        .unwrap();
    let risk_url = format!("http://{addr}/api/v1/risk");
    let deadline = tokio::time::Instant::now() + std::time::Duration::from_secs(10);
    loop {
        let risk: Value = get_json(&http, &risk_url).await;
        if risk["samples"] == 1 {
            break;
        }
        assert!(tokio::time::Instant::now() < deadline, "{risk}");
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
    let text = metrics(&http, &addr).await;
    assert_eq!(
        metric_sum(&text, "seacover_samples_total", "\"unplaced\""),
        1.0
    );
}

/// What a learning coordinator shows and keeps besides the density: the
/// belief's uncertainty (small where samples were taken, the prior's where
/// none were), the newest samples (`GET /api/v1/samples`, in the order
/// taken), and a recording with every sample judged (refusals with their
/// code) and every belief taken up, each valid against its schema for
/// Foxglove's reader.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_uncertainty_and_the_samples_are_served_and_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("seacover.toml");
    std::fs::write(&file, format!("{FLAT}\n[learning]\nrefit = 1.0\n")).unwrap();
    let data = dir.path().join("data");
    let mut command = serve_command(&data, &file);
    command.stderr(Stdio::null());
    let (child, addr) = start(command);
    let mut server = KillOnDrop(child);
    let http = reqwest::Client::new();

    // The south half, every 5 m; one source per row.
    let t = mission_time(&http, &addr).await;
    let posted = survey(&http, &addr, 0..10, t).await;
    let bad = json!([
        {"vessel": "survey-0", "t": t, "x": 500, "y": 5, "value": 1, "sd": 0.1},
        {"vessel": "survey-0", "t": t, "x": 5, "y": 5, "value": 1, "sd": 0}
    ]);
    let (_, answer) = post(&http, &addr, bad).await;
    assert_eq!(answer["refused"].as_array().unwrap().len(), 2, "{answer}");

    let recent: Value = get_json(&http, &format!("http://{addr}/api/v1/samples")).await;
    assert_eq!(recent["samples"], Value::from(posted.clone()));

    let risk_url = format!("http://{addr}/api/v1/risk");
    let deadline = tokio::time::Instant::now() + std::time::Duration::from_secs(20);
    let learned = loop {
        let risk: Value = get_json(&http, &risk_url).await;
        if risk["source"] == "learned" {
            break risk;
        }
        assert!(tokio::time::Instant::now() < deadline, "no fit: {risk}");
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    };
    assert_eq!(learned["learning"], true);
    let u = &learned["uncertainty"];
    assert_eq!((u["nx"].as_u64(), u["ny"].as_u64()), (Some(40), Some(40)));
    assert_eq!(u["step"].as_f64(), Some(2.5));
    let sd: Vec<f64> = u["sd"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(sd.len(), 1600);
    assert!(sd.iter().all(|s| s.is_finite() && *s >= 0.0));
    // Rows of 2.5 m from the south: the survey's (y < 45 m) against the
    // north's beyond 70 m, where the nearest sample is 25 m away.
    let mean = |rows: std::ops::Range<usize>| {
        let n = rows.len() * 40;
        rows.flat_map(|j| sd[j * 40..(j + 1) * 40].to_vec())
            .sum::<f64>()
            / n as f64
    };
    let (south, north) = (mean(0..18), mean(28..40));
    assert!(
        north > 10.0 * south,
        "mean σ in the north {north}, in the surveyed south {south}"
    );

    // A graceful stop finishes the recording.
    crate::common::process::signal(server.0.id(), "-TERM");
    assert!(server.0.wait().unwrap().success());
    let files: Vec<_> = std::fs::read_dir(data.join("recordings"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let recording = seacover::recorder::reader::Recording::open(&files[0]).unwrap();
    use seacover::recorder::messages::{BELIEF, BeliefRecord, SAMPLE, SampleRecord};
    let judged: Vec<SampleRecord> = recording
        .messages(&|topic| topic == SAMPLE)
        .map(|m| serde_json::from_slice(&m.unwrap().data).unwrap())
        .collect();
    let outcomes: Vec<&str> = judged.iter().map(|r| r.outcome.as_str()).collect();
    assert_eq!(outcomes.len(), 212);
    assert!(outcomes[..210].iter().all(|o| *o == "accepted"));
    assert_eq!(outcomes[210..], ["outside_region", "invalid"]);
    let beliefs: Vec<BeliefRecord> = recording
        .messages(&|topic| topic == BELIEF)
        .map(|m| serde_json::from_slice(&m.unwrap().data).unwrap())
        .collect();
    assert!(!beliefs.is_empty());
    let last = serde_json::to_value(&beliefs[beliefs.len() - 1].belief).unwrap();
    assert_eq!(last["source"], "learned");
    assert_eq!(last["samples"], 210);
    assert!(last["uncertainty"]["sd"].as_array().unwrap().len() == 1600);
    if let Some(report) = crate::common::process::check_recording("learning_server", &files[0]) {
        assert_eq!(report["invalid"], 0, "{report}");
        assert_eq!(report["counts"][SAMPLE], 212, "{report}");
        assert_eq!(report["counts"][BELIEF], beliefs.len(), "{report}");
    }
}

/// The optimism fades (docs/learning.md, "Optimism that fades"): with κ 1
/// fading over 5 mission seconds, each fit covers κ·exp(−a / 5), a the age
/// of the oldest sample at the fit, as `GET /api/v1/risk` says; a fit
/// seven seconds later (the same southern survey and one new sample) is
/// less than half as optimistic in the water no sample has seen.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_optimism_fades_with_the_age_of_the_samples() {
    let config = format!("{FLAT}\n[learning]\nrefit = 1.0\nkappa = 1.0\nfade = 5.0\n");
    let (_server, addr, _dir) = serve(&config, false);
    let http = reqwest::Client::new();
    let risk_url = format!("http://{addr}/api/v1/risk");
    let t0 = mission_time(&http, &addr).await;
    survey(&http, &addr, 0..5, t0).await;
    // The first fit after mission time `after` (a fit comes once new
    // samples have).
    let fit_after = async |after: f64| {
        let deadline = tokio::time::Instant::now() + std::time::Duration::from_secs(20);
        loop {
            let risk: Value = get_json(&http, &risk_url).await;
            if risk["fitted_at"].as_f64().is_some_and(|at| at >= after) {
                break risk;
            }
            assert!(tokio::time::Instant::now() < deadline, "no fit: {risk}");
            tokio::time::sleep(std::time::Duration::from_millis(50)).await;
        }
    };
    let kappa = |risk: &Value| {
        let (got, at) = (
            risk["kappa"].as_f64().unwrap(),
            risk["fitted_at"].as_f64().unwrap(),
        );
        let want = (-(at - t0) / 5.0).exp();
        assert!(
            (got - want).abs() < 1e-9,
            "κ {got} at {at}, {want} wanted: {risk}"
        );
        got
    };
    let first = fit_after(t0).await;
    let k1 = kappa(&first);
    // Eight mission seconds on (seven after the first fit at most), one
    // more sample, far from the north.
    loop {
        if mission_time(&http, &addr).await > t0 + 8.0 {
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    }
    let t1 = mission_time(&http, &addr).await;
    let one = json!([{"vessel": "late", "t": t1, "x": 50.0, "y": 10.0,
                      "value": truth(50.0, 10.0), "sd": 0.1}]);
    assert_eq!(post(&http, &addr, one).await.0, 200);
    let later = fit_after(t1).await;
    let k2 = kappa(&later);
    assert!(k2 < 0.4 * k1, "κ {k1} then {k2}");
    let (north1, north2) = (
        density_at(&first["risk"], 50.0, 90.0),
        density_at(&later["risk"], 50.0, 90.0),
    );
    assert!(
        north1 > 1.0 && north2 < 0.5 * north1,
        "unseen water: {north1} at first, {north2} later"
    );
}
