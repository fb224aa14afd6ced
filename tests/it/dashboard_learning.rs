//! The dashboard of a coordinator that learns (docs/learning.md, "On the
//! dashboard"), in a real browser against the real coordinator: samples of
//! a field unlike the mission's risk are posted over REST, and the page
//! shows the learned belief (its peak where the samples put it, not where
//! the mission's prior does), its uncertainty (small where the samples are,
//! large where none were taken) and the samples themselves; the mission's
//! own risk stays one choice away. A coordinator that does not learn shows
//! no learning panel. Without chromium the test skips as `dashboard.rs`'s
//! do.

use crate::common::browser::{browser_or_skip, open_browser, screenshot, start_driver, until};
use crate::common::inprocess::Server;
use fantoccini::Client;
use seacover::server::{LearnSettings, ServeConfig};
use serde_json::{Value, json};

/// The field the samples measure: a bump of 31 at (20, 20), σ 12 m (wider
/// than the lattice's Gaussians, which a narrower one is smoothed by).
fn field(x: f64, y: f64) -> f64 {
    1.0 + 30.0 * (-((x - 20.0).powi(2) + (y - 20.0).powi(2)) / 288.0).exp()
}

async fn eval(client: &Client, js: &str) -> Value {
    client.execute(js, vec![]).await.unwrap()
}

/// Chooses what the map shows, as the operator does in the risk panel,
/// and waits until the legend names it `label`.
async fn choose(client: &Client, layer: &str, label: &str) {
    let js = format!(
        "const s = document.getElementById('layer-select'); s.value = '{layer}'; s.dispatchEvent(new Event('change'));"
    );
    client.execute(&js, vec![]).await.unwrap();
    until(
        client,
        &format!("the map showing {layer}"),
        &format!("document.getElementById('legend-label').textContent === '{label}'"),
    )
    .await;
}

async fn legend(client: &Client) -> (String, f64) {
    let v = eval(
        client,
        "return [document.getElementById('legend-label').textContent, Number(document.getElementById('legend-max').textContent)];",
    )
    .await;
    (v[0].as_str().unwrap().to_string(), v[1].as_f64().unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_shows_the_belief_its_uncertainty_and_the_samples() {
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };
    // The paper's mission (its three objects, 13.1 at most, are the
    // prior), learning with a fit every mission second.
    let server = Server::start(ServeConfig {
        learning: Some(LearnSettings {
            refit: 1.0,
            ..LearnSettings::default()
        }),
        ..ServeConfig::default()
    })
    .await;
    let http = reqwest::Client::new();
    let coverage: Value =
        crate::common::server::get_json(&http, &server.http("/api/v1/coverage")).await;
    let t = coverage["time"].as_f64().unwrap();
    // A survey of the south-west quarter, every 5 m.
    let samples: Vec<Value> = (0..=10)
        .flat_map(|j| (0..=10).map(move |i| (5.0 * f64::from(i), 5.0 * f64::from(j))))
        .map(|(x, y)| json!({"vessel": "survey", "t": t, "x": x, "y": y, "value": field(x, y), "sd": 0.1}))
        .collect();
    let answer: Value = http
        .post(server.http("/api/v1/samples"))
        .json(&json!({ "samples": samples }))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(answer["accepted"], 121, "{answer}");

    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&server.base()).await.unwrap();
    until(&client, "the page's modules", "window.seacover").await;
    until(
        &client,
        "the learning panel with a fitted belief and the samples",
        "!document.getElementById('learning-panel').hidden && window.seacover.view.belief && window.seacover.view.belief.fits >= 1 && window.seacover.view.samples.length === 121",
    )
    .await;
    let readout = eval(
        &client,
        "return document.getElementById('learning-readout').textContent;",
    )
    .await;
    assert!(
        readout.as_str().unwrap().starts_with("121 samples held"),
        "{readout}"
    );

    // The belief: its peak is the samples' (31), well above the prior's.
    until(
        &client,
        "the belief drawn",
        "document.getElementById('legend-label').textContent === 'Φ learned'",
    )
    .await;
    let (_, belief_max) = legend(&client).await;
    assert!(
        (belief_max - 31.0).abs() < 3.1,
        "the belief's largest value {belief_max}, the field's 31"
    );
    let at = |x: f64, y: f64| format!("window.seacover.view.field()({x}, {y})");
    let peak = eval(&client, &format!("return {};", at(20.0, 20.0))).await;
    assert!(
        (peak.as_f64().unwrap() - 31.0).abs() < 3.1,
        "belief at the bump {peak}"
    );
    screenshot(&client, "learning-belief").await;

    // The uncertainty: small where the survey was, large where it was not.
    choose(&client, "uncertainty", "σ of Φ").await;
    let (surveyed, unseen) = (
        eval(&client, &format!("return {};", at(20.0, 20.0))).await,
        eval(&client, &format!("return {};", at(85.0, 85.0))).await,
    );
    let (surveyed, unseen) = (surveyed.as_f64().unwrap(), unseen.as_f64().unwrap());
    assert!(
        surveyed >= 0.0 && unseen > 5.0 * surveyed,
        "σ where surveyed {surveyed}, where not {unseen}"
    );
    screenshot(&client, "learning-uncertainty").await;

    // The mission's own risk, one choice away.
    choose(&client, "mission", "Φ").await;
    let (_, mission_max) = legend(&client).await;
    assert!(
        mission_max < 14.0,
        "the mission's risk peaks at 13.1: {mission_max}"
    );
    let errors = eval(&client, "return window.__errors;").await;
    assert_eq!(errors, json!([]), "page errors");
    client.close().await.unwrap();
    server.stop().await;

    // Without [learning], no panel.
    let server = Server::start(ServeConfig::default()).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&server.base()).await.unwrap();
    until(
        &client,
        "the page's modules",
        "window.seacover && window.seacover.state.snapshot",
    )
    .await;
    tokio::time::sleep(std::time::Duration::from_millis(500)).await;
    let hidden = eval(
        &client,
        "return document.getElementById('learning-panel').hidden;",
    )
    .await;
    assert_eq!(hidden, json!(true));
    client.close().await.unwrap();
    server.stop().await;
}
