//! The dashboard in a real browser: Debian's chromium, headless, driven
//! through chromedriver (WebDriver) by fantoccini, against the real server
//! and real agents. Screenshots land in `target/dashboard/` for people to
//! look at.
//!
//! Without chromium and chromedriver the test says so and passes, except
//! under `CI=true`, where it fails: CI installs them (`scripts/test`).

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use crate::common::browser::{
    browser_or_skip, click_at, drag, open_browser, screen_of, screenshot, start_driver, until,
};
use crate::common::inprocess::Server;
use fantoccini::actions::{InputSource, MouseActions, PointerAction};
use fantoccini::{Client, Locator};
use seacover::agent::{AgentConfig, paper_vessels, run_fleet};
use seacover::control::model::VesselParams;
use seacover::protocol::RiskObjectDocument;
use seacover::server::ServeConfig;
use serde_json::{Value, json};
use tokio::net::TcpListener;
use tokio_util::sync::CancellationToken;

const TOKEN: &str = "harbour-master";

async fn objects(addr: SocketAddr) -> Vec<RiskObjectDocument> {
    reqwest::get(format!("http://{addr}/api/v1/risk-objects"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap()
}

async fn wait_objects(
    addr: SocketAddr,
    what: &str,
    check: impl Fn(&[RiskObjectDocument]) -> bool,
) -> Vec<RiskObjectDocument> {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let list = objects(addr).await;
        if check(&list) {
            return list;
        }
        assert!(Instant::now() < deadline, "timed out: {what}: {list:?}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// Answers the token dialog with `token`.
async fn give_token(client: &Client, token: &str) {
    until(
        client,
        "the token dialog",
        "document.getElementById('token-dialog').open",
    )
    .await;
    let input = client.find(Locator::Id("token-input")).await.unwrap();
    input.clear().await.unwrap();
    input.send_keys(token).await.unwrap();
    client
        .find(Locator::Css("#token-form button[value=ok]"))
        .await
        .unwrap()
        .click()
        .await
        .unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_shows_the_fleet_and_edits_risk() {
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };

    // The real coordinator with the paper's eight vessels on real links.
    let server = Server::start(ServeConfig {
        time_warp: 5.0,
        token: Some(TOKEN.into()),
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
            token: Some(TOKEN.into()),
        },
        paper_vessels(VesselParams::PAPER),
        stop.clone(),
    ));

    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&format!("http://{addr}/")).await.unwrap();

    // Loads without errors; lists the eight vessels; the map is drawn.
    until(&client, "the page's modules", "window.seacover").await;
    until(
        &client,
        "eight vessels in the table",
        "document.querySelectorAll('#vessels tr[data-vessel-id]').length === 8",
    )
    .await;
    let ids = client
        .execute(
            "return [...document.querySelectorAll('#vessels tr[data-vessel-id]')].map(r => r.dataset.vesselId);",
            vec![],
        )
        .await
        .unwrap();
    let expected: Vec<String> = (1..=8).map(|i| format!("usv-{i}")).collect();
    assert_eq!(ids, json!(expected));

    // A vessel an operator has taken over (what the MAVLink bridge reports
    // for a boat out of GUIDED) is marked in the table.
    {
        use futures_util::SinkExt;
        use tokio_tungstenite::tungstenite::{Message, client::IntoClientRequest};
        let mut request = format!("ws://{addr}/api/v1/vessels/link")
            .into_client_request()
            .unwrap();
        request
            .headers_mut()
            .insert("authorization", format!("Bearer {TOKEN}").parse().unwrap());
        let (mut link, _) = tokio_tungstenite::connect_async(request).await.unwrap();
        let hello = json!({"type": "hello", "vessel": "boat-9", "protocol": 1, "astern": false});
        link.send(Message::text(hello.to_string())).await.unwrap();
        for k in 0..40 {
            let pose = json!({"type": "pose", "t": f64::from(k) * 0.05, "x": 20, "y": 80, "psi": 0,
                "u": 0, "v": 0, "r": 0, "controlled": false, "telemetry": {"mode": "HOLD"}});
            link.send(Message::text(pose.to_string())).await.unwrap();
            if k == 0 {
                until(
                    &client,
                    "the taken-over vessel marked",
                    "(() => { const r = document.querySelector(\"#vessels tr[data-vessel-id='boat-9']\");
                              return r && r.cells[1].textContent.includes('operator (HOLD)')
                                     && r.cells[1].className === 'operator'; })()",
                )
                .await;
            }
        }
        link.close(None).await.unwrap();
    }
    until(
        &client,
        "cells on the map",
        "window.seacover.state.snapshot.vessels.every(v => v.polygon)",
    )
    .await;
    // Distinct colours over a grid of pixels: an empty or blank canvas has one.
    tokio::time::sleep(Duration::from_millis(300)).await;
    let colours = client
        .execute(
            "const c = document.getElementById('map');
             const ctx = c.getContext('2d');
             const seen = new Set();
             for (let i = 1; i < 20; i++) for (let j = 1; j < 20; j++) {
               const d = ctx.getImageData(Math.floor(c.width * i / 20), Math.floor(c.height * j / 20), 1, 1).data;
               seen.add(d[0] + ',' + d[1] + ',' + d[2]);
             }
             return seen.size;",
            vec![],
        )
        .await
        .unwrap();
    assert!(
        colours.as_u64().unwrap() > 20,
        "the map looks blank: {colours} colours"
    );
    let errors = client
        .execute("return window.__errors;", vec![])
        .await
        .unwrap();
    assert_eq!(errors, json!([]), "the page reported errors");
    screenshot(&client, "dashboard").await;

    // A wrong token is refused with a visible message, and nothing changes.
    client
        .execute("localStorage.setItem('seacover.token', 'wrong');", vec![])
        .await
        .unwrap();
    let before = objects(addr).await;
    let (sx, sy) = screen_of(&client, 20.0, 20.0).await;
    click_at(&client, sx, sy).await;
    give_token(&client, "still-wrong").await;
    until(
        &client,
        "a visible refusal",
        "[...document.querySelectorAll('#errors .error')].some(e => e.textContent.includes('401') && e.offsetParent !== null)",
    )
    .await;
    screenshot(&client, "wrong-token").await;
    assert_eq!(
        objects(addr).await,
        before,
        "a refused click changed the risk"
    );

    // Clicking the map adds a risk object where it was clicked (after the
    // right token is given once).
    click_at(&client, sx, sy).await;
    give_token(&client, TOKEN).await;
    let list = wait_objects(addr, "the new object", |l| l.len() == before.len() + 1).await;
    let added = list.last().unwrap().clone();
    let id = added.id.clone().unwrap();
    assert!(
        (added.x - 20.0).abs() < 1.5 && (added.y - 20.0).abs() < 1.5,
        "added at ({}, {}), clicked at (20, 20)",
        added.x,
        added.y
    );
    let stored = client
        .execute("return localStorage.getItem('seacover.token');", vec![])
        .await
        .unwrap();
    assert_eq!(stored, json!(TOKEN), "the token is kept");
    until(
        &client,
        "the new object on the page",
        &format!("window.seacover.state.snapshot.mission.risk.objects.some(o => o.id === '{id}')"),
    )
    .await;

    // Dragging moves it.
    let from = screen_of(&client, added.x, added.y).await;
    let to = screen_of(&client, 35.0, 45.0).await;
    drag(&client, from, to).await;
    let list = wait_objects(addr, "the moved object", |l| {
        l.iter().any(|o| {
            o.id.as_deref() == Some(id.as_str())
                && (o.x - 35.0).abs() < 1.5
                && (o.y - 45.0).abs() < 1.5
        })
    })
    .await;
    assert_eq!(list.len(), before.len() + 1);
    until(
        &client,
        "the moved object on the page",
        &format!("window.seacover.state.snapshot.mission.risk.objects.some(o => o.id === '{id}' && Math.abs(o.x - 35) < 1.5)"),
    )
    .await;
    screenshot(&client, "moved").await;

    // Selecting it and pressing delete removes it.
    let at = screen_of(&client, 35.0, 45.0).await;
    click_at(&client, at.0, at.1).await;
    until(
        &client,
        "the object panel",
        &format!("!document.getElementById('object-form').hidden && document.getElementById('object-id').textContent === '{id}'"),
    )
    .await;
    client
        .find(Locator::Id("object-delete"))
        .await
        .unwrap()
        .click()
        .await
        .unwrap();
    let list = wait_objects(addr, "the object deleted", |l| {
        l.iter().all(|o| o.id.as_deref() != Some(id.as_str()))
    })
    .await;
    assert_eq!(list, before);
    screenshot(&client, "deleted").await;

    // Clicking a vessel in the table selects it: its charts fill and the
    // map follows it.
    client
        .find(Locator::Css("#vessels tr[data-vessel-id='usv-3']"))
        .await
        .unwrap()
        .click()
        .await
        .unwrap();
    until(
        &client,
        "the vessel's charts",
        "!document.getElementById('vessel-charts').hidden && window.seacover.state.vesselSeries.u.points.length > 20 \
         && window.seacover.state.vesselSeries.obs.points.length > 20",
    )
    .await;
    let offset = client
        .execute(
            "const v = window.seacover.state.snapshot.vessels.find(v => v.id === 'usv-3');
             const view = window.seacover.view;
             const [sx, sy] = view.toScreen(v.pose.x, v.pose.y);
             return Math.hypot(sx - view.width / 2, sy - view.height / 2);",
            vec![],
        )
        .await
        .unwrap();
    assert!(
        offset.as_f64().unwrap() < 30.0,
        "the map does not follow the selected vessel: {offset} px off centre"
    );
    screenshot(&client, "vessel-selected").await;

    // A phone-sized window: the map stays usable above the panels.
    client.set_window_size(390, 844).await.unwrap();
    until(
        &client,
        "the phone layout",
        "(() => { const r = document.getElementById('map').getBoundingClientRect();
                  const s = document.getElementById('side').getBoundingClientRect();
                  return r.width > 300 && r.width <= 390 && r.height > 250 && s.top >= r.bottom - 1; })()",
    )
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    screenshot(&client, "phone").await;

    let errors = client
        .execute("return window.__errors;", vec![])
        .await
        .unwrap();
    assert_eq!(errors, json!([]), "the page reported errors");
    client.close().await.unwrap();
    stop.cancel();
    fleet.await.unwrap().expect("no vessel link gave up");
    server.stop_unbounded().await;
}

/// A thousand vessels at 10 Hz (the load benchmark's links, in this process):
/// the page lists all of them, keeps drawing without errors, and reports what
/// a frame and a snapshot cost (printed; the README quotes the release
/// figures).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_keeps_up_with_a_thousand_vessels() {
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };
    // The mission made for a thousand vessels (fleet-1000's 1 km square, as
    // the load benchmark uses): in the paper's 100 m square they would sit
    // 3 m apart, inside each other's safety distance, and the collision
    // filter's stress case would be timed here instead of the dashboard.
    let mission =
        seacover::server::config::Settings::parse(include_str!("../../examples/fleet-1000.toml"))
            .expect("the shipped benchmark mission")
            .mission;
    let config = ServeConfig {
        mission,
        ..ServeConfig::default()
    };
    let server = Server::start(config).await;
    let addr = server.addr;
    let stop = server.shutdown();
    let mut load =
        seacover::load::LoadConfig::new(server.base(), 1000, 10.0, Duration::from_secs(20));
    load.warmup = Duration::from_secs(1);
    let fleet = tokio::spawn(seacover::load::run(load, stop.clone()));

    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&format!("http://{addr}/")).await.unwrap();
    until(
        &client,
        "a thousand vessels with cells",
        "window.seacover && window.seacover.state.snapshot \
         && window.seacover.state.snapshot.vessels.filter(v => v.polygon).length === 1000 \
         && document.querySelectorAll('#vessels tr[data-vessel-id]').length === 1000",
    )
    .await;
    let start = client
        .execute(
            "return [window.seacover.view.draws, window.seacover.state.snapshots];",
            vec![],
        )
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_secs(3)).await;
    let end = client
        .execute(
            "return [window.seacover.view.draws, window.seacover.state.snapshots,
                     window.seacover.view.drawMs, window.seacover.state.snapshotMs];",
            vec![],
        )
        .await
        .unwrap();
    let draws = end[0].as_f64().unwrap() - start[0].as_f64().unwrap();
    let snapshots = end[1].as_f64().unwrap() - start[1].as_f64().unwrap();
    eprintln!(
        "dashboard at 1000 vessels: {:.1} snapshots/s, {:.1} frames drawn/s, {:.1} ms per frame, {:.1} ms per snapshot",
        snapshots / 3.0,
        draws / 3.0,
        end[2].as_f64().unwrap(),
        end[3].as_f64().unwrap()
    );
    assert!(
        snapshots >= 3.0,
        "the page took in {snapshots} snapshots in 3 s"
    );
    // Every snapshot drawn, but for one in flight at each end of the window
    // (taken in, its frame not yet drawn), which the two counters read at
    // different moments cannot tell apart.
    assert!(
        draws >= snapshots.min(10.0) - 2.0,
        "{draws} frames for {snapshots} snapshots"
    );
    screenshot(&client, "thousand").await;
    let errors = client
        .execute("return window.__errors;", vec![])
        .await
        .unwrap();
    assert_eq!(errors, json!([]), "the page reported errors");
    client.close().await.unwrap();
    stop.cancel();
    let _ = fleet.await.unwrap();
    server.stop_unbounded().await;
}

/// With a WGS84 origin the map becomes a chart: the pointer's latitude and
/// longitude, a scale bar and a north arrow, each checked against an
/// independent computation (geographiclib for positions and north, the
/// view's own scale for the bar).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_places_the_map_on_the_globe() {
    use crate::common::geo::{locate, place};
    use geographiclib_rs::{DirectGeodesic, Geodesic};
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };
    // ArduPilot SITL's home, Canberra.
    let origin = (-35.363261, 149.16523);
    let server = Server::start(ServeConfig::default()).await;
    let addr = server.addr;
    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&format!("http://{addr}/")).await.unwrap();
    until(
        &client,
        "the first snapshot",
        "window.seacover && window.seacover.state.snapshot",
    )
    .await;
    let shown = "['geo-readout', 'scale-bar', 'north-arrow'].map(id => document.getElementById(id).offsetParent !== null)";
    let none = client
        .execute(&format!("return {shown};"), vec![])
        .await
        .unwrap();
    assert_eq!(
        none,
        json!([false, false, false]),
        "a chart without an origin"
    );

    // Setting the origin over REST brings them onto the open page.
    let response = reqwest::Client::new()
        .put(format!("http://{addr}/api/v1/mission/origin"))
        .json(&json!({"lat": origin.0, "lon": origin.1}))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    until(
        &client,
        "the readout, the scale bar and the north arrow",
        &format!("{shown}.every(v => v)"),
    )
    .await;

    // The scale bar: a 1, 2 or 5 × 10^k length, as long on screen as the
    // view's scale makes it.
    let bar = client
        .execute(
            "const b = document.getElementById('scale-bar');
             return [Number(b.dataset.metres), b.querySelector('.bar').getBoundingClientRect().width,
                     window.seacover.view.scale, b.querySelector('.label').textContent];",
            vec![],
        )
        .await
        .unwrap();
    let (length, width, scale) = (
        bar[0].as_f64().unwrap(),
        bar[1].as_f64().unwrap(),
        bar[2].as_f64().unwrap(),
    );
    let decade = 10f64.powf(length.log10().floor());
    assert!(
        [1.0, 2.0, 5.0]
            .iter()
            .any(|m| (length - m * decade).abs() < 1e-9 * decade),
        "a scale bar of {length} m"
    );
    assert!(
        (width - length * scale).abs() < 1.0,
        "{length} m drawn {width} px wide at {scale} px/m"
    );
    // About 120 px rounded down to 1, 2 or 5: never less than 2/5 of it.
    assert!(
        (47.9..=120.1).contains(&width),
        "a scale bar {width} px wide"
    );
    assert_eq!(bar[3], json!(format!("{length} m")));

    // The pointer over a known point of the map: the readout is where
    // geographiclib puts that point (the pixel the pointer really is at,
    // whole pixels being all WebDriver moves by).
    let (sx, sy) = screen_of(&client, 30.0, 70.0).await;
    let (sx, sy) = (sx.round(), sy.round());
    client
        .perform_actions(
            MouseActions::new("mouse".into()).then(PointerAction::MoveTo {
                duration: None,
                x: sx,
                y: sy,
            }),
        )
        .await
        .unwrap();
    until(
        &client,
        "the pointer's position",
        "document.getElementById('geo-readout').dataset.lat !== undefined",
    )
    .await;
    let read = client
        .execute(
            "const r = document.getElementById('map').getBoundingClientRect();
             const v = window.seacover.view;
             const d = document.getElementById('geo-readout');
             return [Number(d.dataset.lat), Number(d.dataset.lon), d.textContent,
                     (arguments[0] - r.left - v.ox) / v.scale, (v.oy - (arguments[1] - r.top)) / v.scale];",
            vec![json!(sx), json!(sy)],
        )
        .await
        .unwrap();
    let (lat, lon) = (read[0].as_f64().unwrap(), read[1].as_f64().unwrap());
    let (wx, wy) = (read[3].as_f64().unwrap(), read[4].as_f64().unwrap());
    assert!(
        (wx - 30.0).abs() < 1.0 && (wy - 70.0).abs() < 1.0,
        "the pointer is at ({wx}, {wy})"
    );
    let (want_lat, want_lon) = place(origin, wx, wy);
    // 1e-8° is a millimetre; the plane's distortion 76 m out is 1e-12 of it.
    assert!(
        (lat - want_lat).abs() < 1e-8 && (lon - want_lon).abs() < 1e-8,
        "the readout says {lat}, {lon}; geographiclib {want_lat}, {want_lon}"
    );
    // As people read it: degrees to 7 decimals (a centimetre) with the
    // hemisphere, "35.3626306° S  149.1655598° E".
    let text = read[2].as_str().unwrap();
    let words: Vec<&str> = text.split_whitespace().collect();
    let degrees = |w: &str| w.trim_end_matches('°').parse::<f64>().unwrap();
    assert_eq!((words.len(), words[1], words[3]), (4, "S", "E"), "{text}");
    assert!(
        (degrees(words[0]) + want_lat).abs() <= 5.1e-8
            && (degrees(words[2]) - want_lon).abs() <= 5.1e-8
            && words[0]
                .split_once('.')
                .unwrap()
                .1
                .trim_end_matches('°')
                .len()
                == 7,
        "{text}"
    );
    screenshot(&client, "geo").await;

    // The north arrow points to true north at the centre of the map: there
    // the meridians have turned by Δλ sin φ from the origin's (0.19° 30 km
    // east of Canberra). geographiclib's step north, seen in the plane,
    // gives the expected angle.
    let g = Geodesic::wgs84();
    let north_at = |cx: f64, cy: f64| -> f64 {
        let (lat, lon) = place(origin, cx, cy);
        let (nlat, nlon): (f64, f64) = g.direct(lat, lon, 0.0, 10.0);
        let (nx, ny) = locate(origin, nlat, nlon);
        (nx - cx).atan2(ny - cy).to_degrees()
    };
    for east in [0.0, 30_000.0] {
        let centre = client
            .execute(
                "const v = window.seacover.view;
                 v.pan(-arguments[0] * v.scale, 0);
                 return v.toWorld(v.width / 2, v.height / 2);",
                vec![json!(east)],
            )
            .await
            .unwrap();
        let (cx, cy) = (centre[0].as_f64().unwrap(), centre[1].as_f64().unwrap());
        let want = north_at(cx, cy);
        until(
            &client,
            "the arrow turned",
            &format!(
                "Math.abs(Number(document.getElementById('north-arrow').dataset.rotation) - ({want})) < 1e-4"
            ),
        )
        .await;
        if east > 0.0 {
            // In the southern hemisphere the meridians meet below, at the
            // south pole: east of the origin, north leans east (clockwise)
            // by Δλ |sin φ| = 30 km / (N cos φ) × sin 35.36° = 0.19°.
            assert!((0.18..0.2).contains(&want), "north at {cx} m east: {want}°");
        }
    }
    screenshot(&client, "geo-30-km-east").await;

    let errors = client
        .execute("return window.__errors;", vec![])
        .await
        .unwrap();
    assert_eq!(errors, json!([]), "the page reported errors");
    client.close().await.unwrap();
    server.stop_unbounded().await;
}

/// `seacover replay` in the browser: the replay bar appears, and a seek
/// with its slider moves the vessels on the map to where the recording
/// had them at that moment, forwards and backwards.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_replays_a_recording() {
    use seacover::recorder::messages::{self, SimVesselRecord};
    use seacover::recorder::reader::Recording;
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let file = crate::common::server::record_sim(dir.path(), "sim");
    let recording = Recording::open(&file).unwrap();
    let truth = |t: f64| -> Vec<(String, f64, f64)> {
        let mut v: Vec<(String, f64, f64)> = recording
            .messages(&|topic| topic == messages::SIM_VESSEL)
            .map(|m| serde_json::from_slice::<SimVesselRecord>(&m.unwrap().data).unwrap())
            .filter(|r| (r.time - t).abs() < 1e-9)
            .map(|r| (r.vessel, r.truth[0], r.truth[1]))
            .collect();
        v.sort_by(|a, b| a.0.cmp(&b.0));
        v
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
    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&format!("http://{addr}/")).await.unwrap();
    until(
        &client,
        "the replay bar",
        "document.body.dataset.replay === 'true' && window.seacover.replay && window.seacover.state.snapshot",
    )
    .await;
    // Paused first, with the button, as a user would.
    client
        .execute(
            "if (window.seacover.replay.status().playing) document.getElementById('replay-play').click();",
            vec![],
        )
        .await
        .unwrap();
    until(
        &client,
        "paused",
        "!window.seacover.replay.status().playing",
    )
    .await;
    for t in [4.0, 1.5] {
        // The slider, moved and let go.
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
        until(
            &client,
            &format!("the map at {t} s"),
            &format!("Math.abs(window.seacover.state.snapshot.time - {t}) < 1e-9"),
        )
        .await;
        let shown = client
            .execute(
                "return window.seacover.view.vessels
                   .map(v => [v.id, v.pose.x, v.pose.y])
                   .sort((a, b) => a[0] < b[0] ? -1 : 1);",
                vec![],
            )
            .await
            .unwrap();
        let expected: Vec<Value> = truth(t)
            .into_iter()
            .map(|(id, x, y)| json!([id, x, y]))
            .collect();
        assert_eq!(shown, json!(expected), "the vessels on the map at {t} s");
        screenshot(&client, &format!("replay-{t}")).await;
    }
    let errors = client
        .execute("return window.__errors;", vec![])
        .await
        .unwrap();
    assert!(errors.as_array().is_none_or(|e| e.is_empty()), "{errors}");
    client.close().await.unwrap();
    stop.cancel();
    server.await.unwrap().unwrap();
}
