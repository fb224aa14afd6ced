//! The dashboard as a fleet changes under it, in a real browser against
//! the real coordinator and real agents: a vessel that joins changes no
//! other vessel's colour; a vessel whose link closed leaves the table a
//! minute (of mission time) later, counted as gone; H(P) is charted only
//! where there is a partition (no H = 0 stretching the axis); a click
//! outside the region adds no risk object, while one on its water does.
//! Without chromium it skips as `dashboard.rs`'s tests do.

use std::time::Duration;

use crate::common::browser::{
    browser_or_skip, click_at, open_browser, screen_of, start_driver, until,
};
use crate::common::inprocess::Server;
use fantoccini::Client;
use seacover::agent::{AgentConfig, fleet, paper_vessels, run_fleet};
use seacover::control::model::VesselParams;
use seacover::server::ServeConfig;
use serde_json::{Value, json};
use tokio_util::sync::CancellationToken;

const WARP: f64 = 20.0;

async fn eval(client: &Client, js: &str) -> Value {
    client.execute(js, vec![]).await.unwrap()
}

/// Every vessel's colour on the map, by id.
async fn colours(client: &Client) -> Value {
    eval(
        client,
        "const out = {};
         for (const v of window.seacover.state.snapshot.vessels)
             out[v.id] = window.seacover.view.colourFor(v.id);
         return out;",
    )
    .await
}

async fn objects(server: &Server) -> usize {
    let list: Vec<Value> = reqwest::get(server.http("/api/v1/risk-objects"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    list.len()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_follows_the_fleet_as_it_changes() {
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };
    let server = Server::start(ServeConfig {
        time_warp: WARP,
        ..ServeConfig::default()
    })
    .await;
    let agents = |stop: &CancellationToken, vessels| {
        tokio::spawn(run_fleet(
            AgentConfig {
                url: server.ws(),
                time_warp: WARP,
                pose_hz: 20.0,
                seed: 1,
                token: None,
            },
            vessels,
            stop.clone(),
        ))
    };
    let stop = server.shutdown();
    let eight = agents(&stop, paper_vessels(VesselParams::PAPER));
    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client
        .goto(&format!("http://{}/", server.addr))
        .await
        .unwrap();
    until(
        &client,
        "eight vessels in the table",
        "window.seacover && document.querySelectorAll('#vessels tr[data-vessel-id]').length === 8",
    )
    .await;
    let before = colours(&client).await;

    // A ninth joins, whose id sorts before every other.
    let late_stop = CancellationToken::new();
    let late = agents(
        &late_stop,
        fleet(1, Some("aa-late".into()), VesselParams::PAPER, 1).unwrap(),
    );
    until(
        &client,
        "nine vessels in the table",
        "document.querySelectorAll('#vessels tr[data-vessel-id]').length === 9",
    )
    .await;
    let after = colours(&client).await;
    for (id, colour) in before.as_object().unwrap() {
        assert_eq!(
            &after[id], colour,
            "{id}'s colour changed when aa-late joined"
        );
    }
    assert!(
        !before
            .as_object()
            .unwrap()
            .values()
            .any(|c| c == &after["aa-late"]),
        "aa-late took a colour in use: {after}"
    );

    // H is charted from the partition on: no zero.
    let h = eval(
        &client,
        "const p = window.seacover.state.h.points;
         return [p.length, p.filter((q) => !(q[1] > 0)).length];",
    )
    .await;
    assert!(h[0].as_u64().unwrap() > 0, "{h}");
    assert_eq!(h[1], json!(0), "[points, points with H ≤ 0]");

    // A click outside the region adds nothing; one on its water adds one.
    let count = objects(&server).await;
    let (ox, oy) = screen_of(&client, -3.0, 50.0).await;
    click_at(&client, ox, oy).await;
    tokio::time::sleep(Duration::from_millis(800)).await;
    assert_eq!(
        objects(&server).await,
        count,
        "a click outside Q added an object"
    );
    let (ix, iy) = screen_of(&client, 50.0, 50.0).await;
    click_at(&client, ix, iy).await;
    let mut added = false;
    for _ in 0..50 {
        if objects(&server).await == count + 1 {
            added = true;
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    assert!(added, "a click on Q's water added no object");

    // aa-late's link closes: a minute of mission time later it has left
    // the table, and the count says so.
    late_stop.cancel();
    late.await
        .unwrap()
        .expect("the late vessel's link ended cleanly");
    tokio::time::sleep(Duration::from_secs_f64(60.0 / WARP)).await;
    until(
        &client,
        "aa-late gone from the table",
        "document.querySelectorAll('#vessels tr[data-vessel-id]').length === 8
         && !document.querySelector(\"#vessels tr[data-vessel-id='aa-late']\")
         && document.getElementById('vessel-count').textContent === '(8 · 1 gone)'",
    )
    .await;

    client.close().await.unwrap();
    stop.cancel();
    eight.await.unwrap().expect("no vessel link gave up");
    server.stop_unbounded().await;
}
