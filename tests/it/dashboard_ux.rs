//! The dashboard's first hour (the issue "The first hour of a new user",
//! its "Dashboard" part), in a real browser against the real coordinator,
//! real agents and a real recording:
//!
//! - no console errors, live or replay (a live page asks nothing that
//!   answers 404: the server marks the page with what it is);
//! - a replay's page says "replay" and offers no editing;
//! - the vessel table never wraps an id or a header, even with an
//!   operator's take-over in it (a compact badge, the detail on hover);
//! - every quantity column of the table has a unit;
//! - the H(P) chart of a page opened mid-mission starts at the mission's
//!   start (`GET /api/v1/coverage/history`, live and in a replay);
//! - "fit" leaves the whole region visible, clear of the hint bar and the
//!   map's other overlays.
//!
//! And the history's route over HTTP: bounded, thinned, from tick 1.
//! Without chromium the browser tests skip as `dashboard.rs`'s do.

use std::time::Duration;

use crate::common::browser::{
    browser_or_skip, console_errors, drag, open_browser, screenshot, start_driver, until,
};
use crate::common::inprocess::Server;
use crate::common::schema::Validator;
use fantoccini::{Client, Locator};
use seacover::agent::{AgentConfig, paper_vessels, run_fleet};
use seacover::control::model::VesselParams;
use seacover::protocol::{CoverageDocument, CoverageHistoryDocument};
use seacover::server::ServeConfig;
use serde_json::{Value, json};
use tokio::net::TcpListener;
use tokio_util::sync::CancellationToken;

async fn get<T: serde::de::DeserializeOwned>(url: String) -> T {
    let response = reqwest::get(&url).await.unwrap();
    assert_eq!(response.status(), 200, "{url}");
    response.json().await.unwrap()
}

/// `js`'s value in the page.
async fn eval(client: &Client, js: &str) -> Value {
    client.execute(js, vec![]).await.unwrap()
}

/// A list of numbers from the page (JSON writes 1.0 as 1).
fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// No errors: none in the console (failed loads included) and none the
/// page caught itself; every request the page made was answered without
/// an error, and none asked whether the server is a replay unless it is.
async fn assert_quiet(client: &Client, driver_port: u16, replay: bool) {
    let errors = console_errors(client, driver_port).await;
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    let own = eval(client, "return window.__errors;").await;
    assert_eq!(own, json!([]), "the page reported errors");
    let loads = eval(
        client,
        "return performance.getEntriesByType('resource').map(e => [e.name, e.responseStatus]);",
    )
    .await;
    for load in loads.as_array().unwrap() {
        let (url, status) = (load[0].as_str().unwrap(), load[1].as_u64().unwrap());
        assert!(status < 400, "{url} answered {status}");
        assert!(
            replay || !url.contains("/api/v1/replay"),
            "a live page asked {url}"
        );
    }
}

/// Cells of the vessel table that wrap (more than one line) or overflow,
/// and whether the table is wider than its pane.
const WRAPPING: &str = "
    const wrap = document.querySelector('#vessels-panel .table-wrap');
    const bad = [];
    for (const cell of document.querySelectorAll('#vessels th, #vessels td')) {
      const range = document.createRange();
      range.selectNodeContents(cell);
      const lines = range.getBoundingClientRect().height / parseFloat(getComputedStyle(cell).lineHeight);
      if (lines > 1.3 || cell.scrollWidth > cell.clientWidth) bad.push([cell.textContent, lines]);
    }
    return [bad, wrap.scrollWidth - wrap.clientWidth];";

/// The region's bounding box on screen, and the overlays over it.
const REGION_ON_SCREEN: &str = "
    const v = window.seacover.view;
    const c = document.getElementById('map').getBoundingClientRect();
    const pts = window.seacover.state.snapshot.mission.region.polygon
      .map(([x, y]) => v.toScreen(x, y)).map(([sx, sy]) => [c.left + sx, c.top + sy]);
    const box = {
      left: Math.min(...pts.map(p => p[0])), right: Math.max(...pts.map(p => p[0])),
      top: Math.min(...pts.map(p => p[1])), bottom: Math.max(...pts.map(p => p[1])),
    };
    const inside = box.left >= c.left && box.right <= c.right && box.top >= c.top && box.bottom <= c.bottom;
    const over = ['map-hint', 'legend', 'scale-bar', 'map-tools', 'north-arrow']
      .map(id => [id, document.getElementById(id).getBoundingClientRect()])
      .filter(([, r]) => r.width > 0 && r.height > 0)
      .filter(([, r]) => r.left < box.right && r.right > box.left && r.top < box.bottom && r.bottom > box.top)
      .map(([id]) => id);
    return [inside, over, box, [c.left, c.top, c.right, c.bottom]];";

/// Asserts that the whole region is on the canvas and under no overlay.
async fn assert_region_visible(client: &Client, when: &str) {
    let seen = eval(client, REGION_ON_SCREEN).await;
    assert_eq!(
        (&seen[0], &seen[1]),
        (&json!(true), &json!([])),
        "{when}: the region {} on the canvas {}: inside {}, under {}",
        seen[2],
        seen[3],
        seen[0],
        seen[1]
    );
}

/// A link whose vessel an operator has taken over (what the MAVLink bridge
/// says for an autopilot out of GUIDED), posing until `stop`.
async fn operator_link(url: String, id: &'static str, stop: CancellationToken) {
    use futures_util::SinkExt;
    use tokio_tungstenite::tungstenite::Message;
    let (mut link, _) = tokio_tungstenite::connect_async(url).await.unwrap();
    let hello = json!({"type": "hello", "vessel": id, "protocol": 1, "astern": false});
    link.send(Message::text(hello.to_string())).await.unwrap();
    let mut t = 0.0;
    while !stop.is_cancelled() {
        let pose = json!({"type": "pose", "t": t, "x": 20, "y": 80, "psi": 0, "u": 0, "v": 0,
            "r": 0, "controlled": false, "telemetry": {"mode": "HOLD"}});
        if link.send(Message::text(pose.to_string())).await.is_err() {
            return;
        }
        t += 0.05;
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let _ = link.close(None).await;
}

/// A live page opened 15 mission seconds into a mission: it says "live",
/// offers editing, charts H from the first tick, keeps its table on one
/// line per row with units on every quantity, fits the region clear of
/// its overlays, and logs no error.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_live_page_opened_mid_mission() {
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };
    let server = Server::start(ServeConfig {
        time_warp: 5.0,
        ..ServeConfig::default()
    })
    .await;
    let addr = server.addr;
    let stop = server.shutdown();
    let fleet = tokio::spawn(run_fleet(
        AgentConfig {
            url: server.ws(),
            time_warp: 5.0,
            pose_hz: 20.0,
            seed: 1,
            token: None,
        },
        paper_vessels(VesselParams::PAPER),
        stop.clone(),
    ));
    let operator = tokio::spawn(operator_link(server.ws(), "boat-9", stop.clone()));
    loop {
        let now: CoverageDocument = get(server.http("/api/v1/coverage")).await;
        if now.time >= 15.0 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let history: CoverageHistoryDocument = get(server.http("/api/v1/coverage/history")).await;
    let start = history.samples[0];
    assert_eq!((start.tick, start.time), (1, 0.1), "the history's start");

    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&format!("http://{addr}/")).await.unwrap();
    until(
        &client,
        "nine vessels in the table",
        "window.seacover && document.querySelectorAll('#vessels tr[data-vessel-id]').length === 9",
    )
    .await;

    // Live, with its editing controls, without the replay's.
    let mode = eval(
        &client,
        "const s = document.getElementById('status');
         const shown = (id) => document.getElementById(id).offsetParent !== null;
         return [document.documentElement.dataset.mode, s.dataset.state, s.textContent,
                 shown('base-form'), shown('token-button'), shown('replay-bar'), shown('risk-readout')];",
    )
    .await;
    assert_eq!(
        mode,
        json!(["live", "live", "live", true, true, false, false]),
        "[mode, badge state, badge, base form, token button, replay bar, read-only risk]"
    );

    // H(P) from the mission's first partition (the first ticks, before any
    // vessel, have H = 0: no coverage to chart), though the page opened
    // 15 s in.
    until(
        &client,
        "the H history",
        "window.seacover.state.h.points.length > 100",
    )
    .await;
    let h = eval(
        &client,
        "const p = window.seacover.state.h.points;
         return [p[0][0], p[0][1], p[p.length - 1][0], window.seacover.state.snapshot.time];",
    )
    .await;
    let first = history.samples.iter().find(|s| s.h > 0.0).unwrap();
    assert_eq!(
        (h[0].as_f64().unwrap(), h[1].as_f64().unwrap()),
        (first.time, first.h),
        "the H chart starts at {h}"
    );
    assert!(h[3].as_f64().unwrap() >= 15.0 && h[2].as_f64().unwrap() >= 15.0);

    // The taken-over vessel: a compact badge, the detail on hover.
    until(
        &client,
        "the operator's badge",
        "(() => { const r = document.querySelector(\"#vessels tr[data-vessel-id='boat-9']\");
                  return r && r.cells[1].querySelector('.badge'); })()",
    )
    .await;
    let badge = eval(
        &client,
        "const c = document.querySelector(\"#vessels tr[data-vessel-id='boat-9']\").cells[1];
         return [c.querySelector('.badge').textContent, c.title];",
    )
    .await;
    assert_eq!(badge[0], "op");
    assert!(
        badge[1].as_str().unwrap().contains("operator (HOLD)"),
        "{badge}"
    );

    // Units: every column of numbers says its unit in its header, and its
    // cells hold numbers only.
    let table = eval(
        &client,
        "const heads = [...document.querySelectorAll('#vessels thead th')].map(th => th.textContent.trim());
         const rows = [...document.querySelectorAll('#vessels tbody tr')].map(r => [...r.cells].map(c => c.textContent));
         return [heads, rows];",
    )
    .await;
    let heads: Vec<&str> = table[0]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| h.as_str().unwrap())
        .collect();
    assert_eq!(
        heads,
        ["id", "link", "E [m]", "speed [m/s]", "seen [s ago]"]
    );
    for (c, head) in heads.iter().enumerate() {
        let column: Vec<&str> = table[1]
            .as_array()
            .unwrap()
            .iter()
            .map(|row| row[c].as_str().unwrap())
            .collect();
        let numeric = column.iter().any(|v| v.parse::<f64>().is_ok());
        let unit = head.ends_with(']') && head.contains(" [");
        assert_eq!(numeric, unit, "column {head:?}: {column:?}");
        if numeric {
            assert!(
                column
                    .iter()
                    .all(|v| v.parse::<f64>().is_ok() || ["–", "never"].contains(v)),
                "column {head:?}: {column:?}"
            );
        }
    }

    // No cell wraps, and the table fits its pane, wide or narrow, and when
    // its rows scroll (a short window).
    for (width, height) in [(1400, 900), (800, 900), (1400, 600), (390, 844)] {
        client.set_window_size(width, height).await.unwrap();
        tokio::time::sleep(Duration::from_millis(600)).await;
        let wrapping = eval(&client, WRAPPING).await;
        assert_eq!(
            (&wrapping[0], wrapping[1].as_f64().unwrap() <= 0.0),
            (&json!([]), true),
            "{width}×{height}: cells on more than one line or clipped, and overflow [px]: {wrapping}"
        );
        screenshot(&client, &format!("ux-table-{width}")).await;
    }
    client.set_window_size(1400, 900).await.unwrap();

    // "fit": with an origin (a scale bar and a north arrow on the map too)
    // the region is clear of every overlay, first as the page fits it by
    // itself, then after a zoom and a pan and "fit".
    let origin = reqwest::Client::new()
        .put(server.http("/api/v1/mission/origin"))
        .json(&json!({"lat": 59.9, "lon": 10.7}))
        .send()
        .await
        .unwrap();
    assert_eq!(origin.status(), 200);
    until(
        &client,
        "the scale bar",
        "document.getElementById('scale-bar').offsetParent !== null",
    )
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_region_visible(&client, "as opened").await;
    for _ in 0..3 {
        client
            .find(Locator::Id("zoom-in"))
            .await
            .unwrap()
            .click()
            .await
            .unwrap();
    }
    let centre = eval(
        &client,
        "const r = document.getElementById('map').getBoundingClientRect();
         return [r.left + r.width / 2, r.top + r.height / 2];",
    )
    .await;
    let (cx, cy) = (centre[0].as_f64().unwrap(), centre[1].as_f64().unwrap());
    drag(&client, (cx, cy), (cx + 150.0, cy + 200.0)).await;
    let moved = eval(&client, REGION_ON_SCREEN).await;
    assert_eq!(moved[0], json!(false), "zoomed in, the region overflows");
    for (width, height) in [(1400, 900), (1400, 600)] {
        client.set_window_size(width, height).await.unwrap();
        tokio::time::sleep(Duration::from_millis(300)).await;
        client
            .find(Locator::Id("zoom-fit"))
            .await
            .unwrap()
            .click()
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert_region_visible(&client, &format!("fit at {width}×{height}")).await;
        screenshot(&client, &format!("ux-fit-{height}")).await;
    }

    assert_quiet(&client, port, false).await;
    client.close().await.unwrap();
    stop.cancel();
    fleet.await.unwrap().expect("no vessel link gave up");
    operator.await.unwrap();
    server.stop_unbounded().await;
}

/// A replay's page, opened at 4 s into a recording: it says "replay",
/// hides every editing control (and a click on the map edits nothing),
/// charts H from the recording's first tick up to the replay's time and
/// again after a seek either way, and logs no error.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_replay_page_is_a_replay() {
    use seacover::recorder::messages::{self, CoverageRecord};
    use seacover::recorder::reader::Recording;
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let file = crate::common::server::record_sim(dir.path(), "sim");
    // The recording's H, read here: (log time, tick, time, H).
    let recorded: Vec<(u64, u64, f64, f64)> = Recording::open(&file)
        .unwrap()
        .messages(&|topic| topic == messages::COVERAGE)
        .map(|m| {
            let m = m.unwrap();
            let c: CoverageRecord = serde_json::from_slice(&m.data).unwrap();
            (m.log_time, c.tick, c.time, c.h)
        })
        .collect();
    let upto = |t: f64| -> Vec<(u64, f64, f64)> {
        recorded
            .iter()
            .filter(|r| r.0 <= (t * 1e9) as u64)
            .map(|r| (r.1, r.2, r.3))
            .collect()
    };
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let stop = CancellationToken::new();
    let server = tokio::spawn(seacover::server::replay::serve(
        listener,
        file.clone(),
        1.0,
        stop.clone(),
    ));

    // Paused at 4 s, before the page opens.
    let http = reqwest::Client::new();
    let paused = http
        .put(format!("http://{addr}/api/v1/replay"))
        .json(&json!({"time": 4.0, "playing": false}))
        .send()
        .await
        .unwrap();
    assert_eq!(paused.status(), 200);
    // The history route: the recording's coverage up to the replay's time.
    let history: CoverageHistoryDocument =
        get(format!("http://{addr}/api/v1/coverage/history")).await;
    let served: Vec<(u64, f64, f64)> = history
        .samples
        .iter()
        .map(|s| (s.tick, s.time, s.h))
        .collect();
    assert_eq!(history.stride, 1);
    assert_eq!(served, upto(4.0), "the replay's history at 4 s");
    assert!(served.len() > 10);

    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&format!("http://{addr}/")).await.unwrap();
    until(
        &client,
        "the replay bar",
        "window.seacover && window.seacover.replay && window.seacover.state.snapshot",
    )
    .await;
    until(
        &client,
        "the badge",
        "document.getElementById('status').textContent === 'replay'",
    )
    .await;
    let shown = eval(
        &client,
        "const s = document.getElementById('status');
         const shown = (el) => el.offsetParent !== null && getComputedStyle(el).display !== 'none';
         const editing = [...document.querySelectorAll('#base-form, #object-form, #token-button, #map-hint .editing, #base-input')];
         return [document.documentElement.dataset.mode, s.dataset.state, editing.filter(shown).map(e => e.id || e.className),
                 shown(document.getElementById('replay-bar')), document.getElementById('risk-readout').textContent,
                 document.getElementById('map-hint').innerText];",
    )
    .await;
    assert_eq!(
        (&shown[0], &shown[1], &shown[2], &shown[3]),
        (&json!("replay"), &json!("replay"), &json!([]), &json!(true)),
        "[mode, badge state, editing controls shown, replay bar]: {shown}"
    );
    assert!(
        shown[4].as_str().unwrap().starts_with("base φ₀ = "),
        "{shown}"
    );
    assert!(
        !shown[5].as_str().unwrap().contains("add a risk object"),
        "{shown}"
    );

    // A click on the map edits nothing: no object panel, no refusal.
    let map = client.find(Locator::Id("map")).await.unwrap();
    map.click().await.unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let after = eval(
        &client,
        "return [document.getElementById('object-form').hidden,
                 document.querySelectorAll('#errors .error').length];",
    )
    .await;
    assert_eq!(
        after,
        json!([true, 0]),
        "[object panel hidden, errors shown]"
    );

    // H from the recording's start up to the replay's time.
    let series = "window.seacover.state.h.points.map(p => p[0])";
    let times = |t: f64| -> Vec<f64> { upto(t).into_iter().map(|s| s.1).collect() };
    until(
        &client,
        "the H history",
        &format!("{series}.length >= {}", times(4.0).len()),
    )
    .await;
    assert_eq!(
        floats(&eval(&client, &format!("return {series};")).await),
        times(4.0)
    );
    // A seek back and one forward with the slider: from the start again,
    // up to the new time.
    for t in [1.5, 5.0] {
        client
            .execute(
                "const s = document.getElementById('replay-time');
                 s.value = String(arguments[0]);
                 s.dispatchEvent(new Event('input'));
                 s.dispatchEvent(new Event('change'));",
                vec![json!(t)],
            )
            .await
            .unwrap();
        let want = times(t);
        until(
            &client,
            &format!("the H history at {t} s"),
            &format!(
                "(() => {{ const p = {series}; return p.length === {} && p[0] === {} && p[p.length - 1] === {}; }})()",
                want.len(),
                want[0],
                want[want.len() - 1]
            ),
        )
        .await;
        assert_eq!(
            floats(&eval(&client, &format!("return {series};")).await),
            want
        );
    }
    screenshot(&client, "ux-replay").await;

    // Playing, the header and the replay bar say the same time at every
    // moment: the snapshot's on screen.
    let play = http
        .put(format!("http://{addr}/api/v1/replay"))
        .json(&json!({"playing": true}))
        .send()
        .await
        .unwrap();
    assert_eq!(play.status(), 200);
    let mut differ = Vec::new();
    for _ in 0..12 {
        tokio::time::sleep(Duration::from_millis(170)).await;
        let texts = eval(
            &client,
            "return [document.getElementById('summary').textContent,
                     document.getElementById('replay-label').textContent];",
        )
        .await;
        let header = texts[0].as_str().unwrap();
        let label = texts[1].as_str().unwrap();
        let time = label.split(" / ").next().unwrap();
        if !header.starts_with(&format!("t = {time} s")) {
            differ.push(format!("{header:?} vs {label:?}"));
        }
    }
    assert!(differ.is_empty(), "header vs replay bar: {differ:?}");

    assert_quiet(&client, port, true).await;
    client.close().await.unwrap();
    stop.cancel();
    server.await.unwrap().unwrap();
}

/// `GET /api/v1/coverage/history` of a coordinator 2500 ticks into its
/// mission (at 100 × real time): at most 1000 samples, thinned to a
/// power-of-two stride, from tick 1, each at its tick's time; as the
/// OpenAPI document describes it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_coverage_history_is_bounded_and_thinned() {
    let server = Server::start(ServeConfig {
        time_warp: 100.0,
        ..ServeConfig::default()
    })
    .await;
    loop {
        let now: CoverageDocument = get(server.http("/api/v1/coverage")).await;
        if now.tick >= 2500 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let body: Value = get(server.http("/api/v1/coverage/history")).await;
    let doc: Value = serde_json::from_str(seacover::server::openapi::json()).unwrap();
    let schema = json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$ref": "#/components/schemas/CoverageHistoryDocument",
        "components": {"schemas": doc["components"]["schemas"]},
    });
    if let Some(mut checker) =
        Validator::start("dashboard_ux::the_coverage_history_is_bounded_and_thinned")
    {
        let errors = checker.errors(&schema, &body);
        assert!(errors.is_empty(), "{body}: {errors:?}");
    }
    assert_eq!(
        doc["paths"]["/api/v1/coverage/history"]["get"]["responses"]["200"]["content"]["application/json"]
            ["schema"]["$ref"],
        "#/components/schemas/CoverageHistoryDocument"
    );
    let history: CoverageHistoryDocument = serde_json::from_value(body).unwrap();
    let n = history.samples.len();
    assert!((500..1000).contains(&n), "{n} samples");
    assert!(
        history.stride.is_power_of_two() && history.stride >= 4,
        "stride {}",
        history.stride
    );
    assert_eq!(history.samples[0].tick, 1);
    for s in &history.samples {
        assert_eq!(s.time, s.tick as f64 / 10.0);
    }
    // `stride` apart, or more where ticks were skipped (the test machine
    // is busy); never closer.
    for pair in history.samples.windows(2) {
        assert!(pair[1].tick - pair[0].tick >= history.stride, "{pair:?}");
    }
    server.stop().await;
}
