//! The coordinator and agents over real sockets on loopback: the real server
//! on port 0, real WebSocket and HTTP clients, time warp so that minutes of
//! mission run in seconds.

use std::time::{Duration, Instant};

use crate::common::inprocess::Server;
use crate::common::link::{hello, next_json};
use futures_util::{SinkExt, StreamExt};
use seacover::agent::{AgentConfig, paper_vessels, run_fleet};
use seacover::control::model::VesselParams;
use seacover::protocol::{CoverageDocument, VesselStatusDocument};
use seacover::server::{ServeConfig, serve};
use serde_json::{Value, json};
use tokio::net::TcpListener;
use tokio_tungstenite::tungstenite::Message;
use tokio_util::sync::CancellationToken;

const WARP: f64 = 20.0;

async fn start() -> Server {
    start_with(None).await
}

async fn start_with(token: Option<&str>) -> Server {
    Server::start(ServeConfig {
        time_warp: WARP,
        token: token.map(str::to_string),
        ..ServeConfig::default()
    })
    .await
}

/// `GET path` on the server, parsed.
async fn get_json<T: serde::de::DeserializeOwned>(s: &Server, path: &str) -> T {
    reqwest::get(s.http(path))
        .await
        .unwrap()
        .json()
        .await
        .unwrap()
}

async fn vessels(s: &Server) -> Vec<VesselStatusDocument> {
    get_json(s, "/api/v1/vessels").await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_paper_fleet_converges_through_the_network() {
    let server = start().await;
    let agents = CancellationToken::new();
    let config = AgentConfig {
        url: server.ws(),
        time_warp: WARP,
        pose_hz: 20.0,
        seed: 1,
        token: None,
    };
    let fleet = tokio::spawn(run_fleet(
        config,
        paper_vessels(VesselParams::PAPER),
        agents.clone(),
    ));

    let started = Instant::now();
    let mut e_max = f64::INFINITY;
    while started.elapsed() < Duration::from_secs(60) {
        tokio::time::sleep(Duration::from_millis(250)).await;
        let vs = vessels(&server).await;
        let coverage: CoverageDocument = get_json(&server, "/api/v1/coverage").await;
        if vs.len() == 8 && vs.iter().all(|v| v.live) && coverage.time > 120.0 {
            e_max = vs
                .iter()
                .map(|v| v.last_command.as_ref().unwrap().e)
                .fold(0.0, f64::max);
            if e_max < 1.0 {
                assert!(coverage.h > 9000.0, "H = {}", coverage.h);
                assert_eq!(coverage.cells.len(), 8);
                break;
            }
        }
    }
    assert!(e_max < 1.0, "E_max {e_max} after {:?}", started.elapsed());
    agents.cancel();
    fleet.await.unwrap().expect("no vessel link gave up");
    server.stop().await;
}

fn pose(x: f64, y: f64) -> Message {
    Message::text(
        json!({"type": "pose", "t": 0.0, "x": x, "y": y, "psi": 0.0, "u": 0.0, "v": 0.0, "r": 0.0})
            .to_string(),
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn links_are_validated_replaced_and_expire() {
    let server = start().await;

    // A pose before hello closes the link with an error.
    let (socket, _) = tokio_tungstenite::connect_async(server.ws()).await.unwrap();
    let (mut sink, mut stream) = socket.split();
    sink.send(pose(1.0, 1.0)).await.unwrap();
    let e = next_json(&mut stream).await;
    assert_eq!(e["type"], "error");
    assert_eq!(e["code"], "protocol");

    // Two vessels report; both get commands and share the region.
    let (mut a, mut a_in) = hello(server.ws(), "a").await;
    let (mut b, mut b_in) = hello(server.ws(), "b").await;
    let _ = a.send(pose(20.0, 50.0)).await;
    let _ = b.send(pose(80.0, 50.0)).await;
    let cmd = next_json(&mut a_in).await;
    assert_eq!(cmd["type"], "command", "{cmd}");
    assert!(cmd["centroid"][0].as_f64().unwrap() < 50.0);
    let _ = next_json(&mut b_in).await;

    // Garbage is answered, not fatal at first.
    let _ = a.send(Message::text("{not json")).await;
    let mut saw_error = false;
    for _ in 0..5 {
        let m = next_json(&mut a_in).await;
        if m["type"] == "error" {
            assert_eq!(m["code"], "malformed");
            saw_error = true;
            break;
        }
    }
    assert!(saw_error);

    // A second link for "a" replaces the first, which is told and closed.
    let (mut a2, _a2_in) = hello(server.ws(), "a").await;
    let mut replaced = false;
    for _ in 0..20 {
        let m = next_json(&mut a_in).await;
        if m.is_null() {
            break;
        }
        if m["type"] == "error" && m["code"] == "replaced" {
            replaced = true;
        }
    }
    assert!(replaced);
    let _ = a2.send(pose(20.0, 50.0)).await;

    // "b" goes silent: after the 3 s liveness timeout (mission time) "a" owns
    // the whole region.
    let _ = b.send(Message::Close(None)).await;
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let _ = a2.send(pose(20.0, 50.0)).await;
        let cov: CoverageDocument = get_json(&server, "/api/v1/coverage").await;
        if cov.cells.len() == 1 && cov.cells[0].id == "a" {
            assert!((cov.cells[0].area - 10_000.0).abs() < 1e-6);
            break;
        }
        assert!(
            Instant::now() < deadline,
            "b never left the partition: {:?}",
            cov.cells.iter().map(|c| &c.id).collect::<Vec<_>>()
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let b_status: VesselStatusDocument = get_json(&server, "/api/v1/vessels/b").await;
    assert!(!b_status.connected && !b_status.live);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rest_reads_and_what_if_evaluation() {
    let server = start().await;
    let client = reqwest::Client::new();
    assert_eq!(
        reqwest::get(server.http("/healthz"))
            .await
            .unwrap()
            .text()
            .await
            .unwrap(),
        "ok"
    );
    let mission: Value = get_json(&server, "/api/v1/mission").await;
    assert_eq!(mission["tick_hz"], 10.0);
    assert_eq!(mission["risk"]["objects"].as_array().unwrap().len(), 3);
    assert_eq!(mission["actuator"]["beta"], 0.001);
    let objects: Value = get_json(&server, "/api/v1/risk-objects").await;
    assert_eq!(objects[0]["id"], "object-1");

    // Region and risk come from the mission when omitted.
    let r = client
        .post(server.http("/api/v1/coverage/evaluate"))
        .body(
            json!({"vessels": [{"id": "a", "x": 30, "y": 30}, {"id": "b", "x": 70, "y": 70}]})
                .to_string(),
        )
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let eval: Value = r.json().await.unwrap();
    assert_eq!(eval["cells"].as_array().unwrap().len(), 2);
    let area: f64 = eval["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["area"].as_f64().unwrap())
        .sum();
    assert!((area - 10_000.0).abs() < 1e-6);

    for (body, status, code) in [
        ("{oops".to_string(), 400, "malformed"),
        (json!({"vessels": []}).to_string(), 422, "invalid"),
        (
            json!({"vessels": [{"id": "a", "x": 1, "y": 1, "k": -1}]}).to_string(),
            422,
            "invalid",
        ),
    ] {
        let r = client
            .post(server.http("/api/v1/coverage/evaluate"))
            .body(body)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), status);
        let e: Value = r.json().await.unwrap();
        assert_eq!(e["error"]["code"], code);
    }
    let r = reqwest::get(server.http("/api/v1/vessels/nobody"))
        .await
        .unwrap();
    assert_eq!(r.status(), 404);
    let e: Value = r.json().await.unwrap();
    assert_eq!(e["error"]["code"], "not_found");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_stream_sends_a_snapshot_on_connect() {
    let server = start().await;
    let (socket, _) =
        tokio_tungstenite::connect_async(format!("ws://{}/api/v1/stream", server.addr))
            .await
            .unwrap();
    let (_sink, mut stream) = socket.split();
    let first = next_json(&mut stream).await;
    assert!(first["mission"]["region"]["polygon"].is_array());
    let second = next_json(&mut stream).await;
    assert!(second["tick"].as_u64().unwrap() > first["tick"].as_u64().unwrap());
    server.stop().await;
}

#[tokio::test]
async fn refuses_to_serve_publicly_without_a_token() {
    let Ok(listener) = TcpListener::bind("0.0.0.0:0").await else {
        return;
    };
    let err = serve(listener, ServeConfig::default(), CancellationToken::new())
        .await
        .unwrap_err();
    assert!(err.to_string().contains("without a token"), "{err}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn risk_objects_and_mission_writes() {
    let server = start().await;
    let c = reqwest::Client::new();
    let objects = || async {
        let v: Value = get_json(&server, "/api/v1/risk-objects").await;
        v
    };

    // Create: 201 with the stored object and a fresh id.
    let r = c
        .post(server.http("/api/v1/risk-objects"))
        .body(json!({"x": 40, "y": 40, "alpha": 5, "sigma": 8}).to_string())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let created: Value = r.json().await.unwrap();
    let id = created["id"].as_str().unwrap().to_string();
    assert_eq!(id, "object-4");
    assert_eq!(objects().await.as_array().unwrap().len(), 4);
    let got: Value = get_json(&server, &format!("/api/v1/risk-objects/{id}")).await;
    assert_eq!(got, created);

    // Invalid values and duplicate ids are refused and change nothing.
    let before = objects().await;
    for (body, status, code) in [
        (
            json!({"x": 40, "y": 40, "alpha": 5, "sigma": 0}),
            422,
            "invalid",
        ),
        (
            json!({"x": 40, "y": 40, "alpha": -5, "sigma": 3}),
            422,
            "invalid",
        ),
        (
            json!({"id": "object-1", "x": 4, "y": 4, "alpha": 5, "sigma": 3}),
            409,
            "conflict",
        ),
        (
            json!({"id": "bad id", "x": 4, "y": 4, "alpha": 5, "sigma": 3}),
            422,
            "invalid",
        ),
        (json!({"x": 4, "y": 4}), 400, "malformed"),
    ] {
        let r = c
            .post(server.http("/api/v1/risk-objects"))
            .body(body.to_string())
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), status, "{body}");
        let e: Value = r.json().await.unwrap();
        assert_eq!(e["error"]["code"], code);
    }
    assert_eq!(objects().await, before);

    // Update and delete.
    let r = c
        .put(server.http(&format!("/api/v1/risk-objects/{id}")))
        .body(json!({"x": 60, "y": 45, "alpha": 7, "sigma": 9}).to_string())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let updated: Value = r.json().await.unwrap();
    assert_eq!(updated["x"], 60.0);
    assert_eq!(updated["id"], id.as_str());
    let r = c
        .delete(server.http(&format!("/api/v1/risk-objects/{id}")))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 204);
    let r = c
        .delete(server.http(&format!("/api/v1/risk-objects/{id}")))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 404);
    assert_eq!(objects().await.as_array().unwrap().len(), 3);

    // Base density and region.
    let r = c
        .put(server.http("/api/v1/mission/risk/base"))
        .body(json!({"value": 0.3}).to_string())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let m: Value = r.json().await.unwrap();
    assert_eq!(m["risk"]["base"], 0.3);
    let r = c
        .put(server.http("/api/v1/mission/risk/base"))
        .body(json!({"value": -1}).to_string())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 422);
    let bow_tie = json!({"polygon": [[0, 0], [100, 100], [100, 0], [0, 100]]});
    let r = c
        .put(server.http("/api/v1/mission/region"))
        .body(bow_tie.to_string())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 422);
    let region = json!({
        "polygon": [[0.0, 0.0], [200.0, 0.0], [200.0, 100.0], [0.0, 100.0]],
        "holes": [[[90.0, 40.0], [110.0, 40.0], [110.0, 60.0], [90.0, 60.0]]]
    });
    let r = c
        .put(server.http("/api/v1/mission/region"))
        .body(region.to_string())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let mission: Value = get_json(&server, "/api/v1/mission").await;
    assert_eq!(mission["region"], region);
    assert_eq!(mission["risk"]["base"], 0.3);
    // The what-if evaluation now uses the new region.
    let eval: Value = c
        .post(server.http("/api/v1/coverage/evaluate"))
        .body(json!({"vessels": [{"id": "a", "x": 50, "y": 50}]}).to_string())
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert!((eval["cells"][0]["area"].as_f64().unwrap() - 19_600.0).abs() < 1e-6);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_token_guards_writes_and_links_but_not_reads() {
    let server = start_with(Some("s3cret")).await;
    let c = reqwest::Client::new();
    let object = json!({"x": 40, "y": 40, "alpha": 5, "sigma": 8}).to_string();

    let r = c
        .post(server.http("/api/v1/risk-objects"))
        .body(object.clone())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 401);
    let e: Value = r.json().await.unwrap();
    assert_eq!(e["error"]["code"], "unauthorized");
    let r = c
        .post(server.http("/api/v1/risk-objects"))
        .bearer_auth("wrong")
        .body(object.clone())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 401);
    let objects: Value = get_json(&server, "/api/v1/risk-objects").await;
    assert_eq!(
        objects.as_array().unwrap().len(),
        3,
        "a refused write changed nothing"
    );
    let r = c
        .post(server.http("/api/v1/risk-objects"))
        .bearer_auth("s3cret")
        .body(object)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);

    // Links: refused at the upgrade without the token; header or ?token= work.
    let refused = tokio_tungstenite::connect_async(server.ws()).await;
    match refused {
        Err(tokio_tungstenite::tungstenite::Error::Http(resp)) => assert_eq!(resp.status(), 401),
        other => panic!("expected a 401, got {:?}", other.map(|_| ())),
    }
    let (_socket, _) = tokio_tungstenite::connect_async(format!("{}?token=s3cret", server.ws()))
        .await
        .unwrap();
    let agents = CancellationToken::new();
    let config = AgentConfig {
        url: server.ws(),
        time_warp: WARP,
        pose_hz: 20.0,
        seed: 1,
        token: Some("s3cret".into()),
    };
    let fleet = tokio::spawn(run_fleet(
        config,
        paper_vessels(VesselParams::PAPER)
            .into_iter()
            .take(2)
            .collect(),
        agents.clone(),
    ));
    let deadline = Instant::now() + Duration::from_secs(5);
    while vessels(&server).await.iter().filter(|v| v.live).count() < 2 {
        assert!(
            Instant::now() < deadline,
            "authenticated agents never became live"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    agents.cancel();
    fleet.await.unwrap().expect("no vessel link gave up");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn writes_are_rate_limited_and_bodies_bounded() {
    let server = Server::start(ServeConfig {
        write_rate: 2,
        write_burst: 5,
        ..ServeConfig::default()
    })
    .await;
    let c = reqwest::Client::new();
    let mut accepted = Vec::new();
    let mut limited = 0;
    for i in 0..20 {
        let value = 0.01 * (i + 1) as f64;
        let r = c
            .put(server.http("/api/v1/mission/risk/base"))
            .json(&json!({ "value": value }))
            .send()
            .await
            .unwrap();
        match r.status().as_u16() {
            200 => accepted.push(value),
            429 => {
                limited += 1;
                assert_eq!(r.headers()["retry-after"], "1");
                let e: Value = r.json().await.unwrap();
                assert_eq!(e["error"]["code"], "rate_limited");
            }
            other => panic!("unexpected status {other}"),
        }
    }
    // A burst of 5 passes (plus what refilled meanwhile); the rest is refused.
    assert!((5..=8).contains(&accepted.len()), "{accepted:?}");
    assert_eq!(limited, 20 - accepted.len());
    let mission: Value = get_json(&server, "/api/v1/mission").await;
    assert_eq!(
        mission["risk"]["base"].as_f64(),
        accepted.last().copied(),
        "a refused write changed the mission"
    );
    // Reads are not limited.
    for _ in 0..20 {
        let r = reqwest::get(server.http("/api/v1/mission")).await.unwrap();
        assert_eq!(r.status(), 200);
    }

    // Over 1 MiB: 413 in the JSON error shape, nothing changed.
    tokio::time::sleep(Duration::from_millis(600)).await;
    let huge = format!(
        "{{\"polygon\": [{}[0, 0]], \"holes\": []}}",
        "[0, 0], ".repeat(150_000)
    );
    assert!(huge.len() > 1024 * 1024);
    let r = c
        .put(server.http("/api/v1/mission/region"))
        .header("content-type", "application/json")
        .body(huge)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 413);
    let e: Value = r.json().await.unwrap();
    assert_eq!(e["error"]["code"], "too_large");
    let after: Value = get_json(&server, "/api/v1/mission").await;
    assert_eq!(after, mission);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn deleting_a_vessel_forgets_it_and_tells_its_link() {
    let server = start().await;
    let (mut sink, mut stream) = hello(server.ws(), "gone-1").await;
    let _ = sink.send(pose(30.0, 30.0)).await;
    let deadline = Instant::now() + Duration::from_secs(5);
    while !vessels(&server)
        .await
        .iter()
        .any(|v| v.id == "gone-1" && v.live)
    {
        assert!(Instant::now() < deadline, "the vessel never became live");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let c = reqwest::Client::new();
    let r = c
        .delete(server.http("/api/v1/vessels/gone-1"))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 204);
    assert!(vessels(&server).await.iter().all(|v| v.id != "gone-1"));
    let r = reqwest::get(server.http("/api/v1/vessels/gone-1"))
        .await
        .unwrap();
    assert_eq!(r.status(), 404);
    let mut told = false;
    while let Ok(Some(Ok(msg))) = tokio::time::timeout(Duration::from_secs(2), stream.next()).await
    {
        if let Message::Text(t) = msg {
            let v: Value = serde_json::from_str(&t).unwrap();
            if v["type"] == "error" {
                assert_eq!(v["code"], "removed");
                told = true;
            }
        }
    }
    assert!(told, "the link was not told");
    let r = c
        .delete(server.http("/api/v1/vessels/gone-1"))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 404);
    let e: Value = r.json().await.unwrap();
    assert_eq!(e["error"]["code"], "not_found");
    server.stop().await;
}

/// A vessel that declares in its hello the command rates it can follow
/// (`agility`) is asked for no more; one that declares nothing gets the
/// mission's bounds (`yaw_accel` 2 rad/s²); a declaration that is not a
/// pair of positive numbers is refused.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn commands_change_no_faster_than_the_vessel_declared() {
    let server = start().await;
    // `null` declares nothing.
    let link = |id: &'static str, agility: Value| {
        let url = server.ws();
        async move {
            let (socket, _) = tokio_tungstenite::connect_async(url).await.unwrap();
            let (mut sink, mut stream) = socket.split();
            let mut hello = json!({"type": "hello", "vessel": id, "protocol": 1});
            hello["agility"] = agility;
            sink.send(Message::text(hello.to_string())).await.unwrap();
            let first = next_json(&mut stream).await;
            (sink, stream, first)
        }
    };
    for (bad, code) in [
        (json!({"yaw_accel": 0.0, "surge_accel": 0.1}), "invalid"),
        (json!({"yaw_accel": -1.0, "surge_accel": 0.1}), "invalid"),
        (json!({"yaw_accel": 0.2}), "malformed"),
        (
            json!({"yaw_accel": "fast", "surge_accel": 0.1}),
            "malformed",
        ),
    ] {
        let (_, _, first) = link("slow", bad.clone()).await;
        assert_eq!(first["type"], "error", "{bad}: {first}");
        assert_eq!(first["code"], code, "{bad}: {first}");
    }

    let (mut slow, mut slow_in, welcome) =
        link("slow", json!({"yaw_accel": 0.2, "surge_accel": 0.1})).await;
    assert_eq!(welcome["type"], "welcome", "{welcome}");
    let (mut nimble, mut nimble_in, welcome) = link("nimble", Value::Null).await;
    assert_eq!(welcome["type"], "welcome", "{welcome}");
    // Both at rest with their bows away from their goals: each command line
    // heads for a hard turn and ramps as fast as it may.
    let at = |x: f64, psi: f64| {
        Message::text(
            json!({"type": "pose", "t": 0.0, "x": x, "y": 30.0, "psi": psi,
                   "u": 0.0, "v": 0.0, "r": 0.0})
            .to_string(),
        )
    };
    let (mut slow_rates, mut nimble_rates) = ((0.0f64, 0.0f64), (0.0f64, 0.0f64));
    let mut seen = (0, 0);
    for _ in 0..40 {
        let _ = slow.send(at(80.0, 0.0)).await;
        let _ = nimble.send(at(20.0, std::f64::consts::PI)).await;
        for (stream, rates, count) in [
            (&mut slow_in, &mut slow_rates, &mut seen.0),
            (&mut nimble_in, &mut nimble_rates, &mut seen.1),
        ] {
            let m = next_json(stream).await;
            if m["type"] == "command" {
                let r_dot = m["r_d_dot"].as_f64().unwrap().abs();
                let u_dot = m["u_d_dot"].as_f64().unwrap().abs();
                rates.0 = rates.0.max(r_dot);
                rates.1 = rates.1.max(u_dot);
                *count += 1;
            }
        }
    }
    assert!(seen.0 >= 30 && seen.1 >= 30, "commands seen: {seen:?}");
    assert!(
        slow_rates.0 <= 0.2 + 1e-9 && slow_rates.1 <= 0.1 + 1e-9,
        "the slow vessel was asked for |ṙ_d|, |u̇_d| up to {slow_rates:?}"
    );
    assert!(
        nimble_rates.0 > 1.0,
        "the undeclared vessel's commands never used the mission's yaw_accel: {nimble_rates:?}"
    );
    server.stop().await;
}
