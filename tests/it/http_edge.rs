//! The HTTP edge as a client sees it: every error is docs/api.md's JSON (an
//! unknown route's 404, a wrong method's 405 with `Allow`), unknown fields
//! and values that cannot matter are refused naming the request's own
//! fields, a 401 says which scheme to use, and a client that reuses its
//! connections (HTTP/1.1 keep-alive) never meets a broken pipe after a
//! refusal: the server keeps the connection or says `Connection: close`.

use std::time::Duration;

use reqwest::StatusCode;
use seacover::server::ServeConfig;
use serde_json::{Value, json};

use crate::common::inprocess::Server;

const TOKEN: &str = "edge-token";

async fn error_of(response: reqwest::Response) -> (StatusCode, Value) {
    let status = response.status();
    let json = response
        .headers()
        .get("content-type")
        .is_some_and(|v| v.as_bytes().starts_with(b"application/json"));
    assert!(json, "{status}: not JSON");
    (status, response.json().await.unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unknown_routes_and_methods_answer_json() {
    let server = Server::start(ServeConfig::default()).await;
    let http = reqwest::Client::new();

    for path in ["/api/v1/nothing", "/api/v2/mission", "/nothing.js"] {
        let (status, body) = error_of(http.get(server.http(path)).send().await.unwrap()).await;
        assert_eq!(status, StatusCode::NOT_FOUND, "{path}");
        assert_eq!(body["error"]["code"], "not_found", "{path}: {body}");
        assert!(
            body["error"]["message"].as_str().unwrap().contains(path),
            "{body}"
        );
    }

    let response = http
        .delete(server.http("/api/v1/mission"))
        .send()
        .await
        .unwrap();
    let allow = response
        .headers()
        .get("allow")
        .expect("a 405 says what is allowed")
        .to_str()
        .unwrap()
        .to_string();
    assert!(allow.contains("GET"), "{allow}");
    let (status, body) = error_of(response).await;
    assert_eq!(status, StatusCode::METHOD_NOT_ALLOWED);
    assert_eq!(body["error"]["code"], "method_not_allowed", "{body}");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn requests_are_checked_against_what_the_client_wrote() {
    let server = Server::start(ServeConfig::default()).await;
    let http = reqwest::Client::new();
    let post = |body: Value| {
        http.post(server.http("/api/v1/risk-objects"))
            .json(&body)
            .send()
    };

    // An unknown field is refused, naming it, and nothing is created.
    let (status, body) = error_of(
        post(json!({"x": 50, "y": 50, "alpha": 1, "sigma": 5, "extra": 1}))
            .await
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{body}");
    assert_eq!(body["error"]["code"], "malformed");
    assert!(
        body["error"]["message"]
            .as_str()
            .unwrap()
            .contains("`extra`"),
        "{body}"
    );
    // A body of the wrong shape is refused in JSON's words, never the
    // server's own type names.
    let (status, body) = error_of(post(json!([])).await.unwrap()).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{body}");
    let message = body["error"]["message"].as_str().unwrap();
    assert!(
        message.contains("expected a JSON object") && !message.contains("Document"),
        "{body}"
    );
    let (status, body) = error_of(
        http.put(server.http("/api/v1/mission/risk/base"))
            .json(&json!({"base": 0.2}))
            .send()
            .await
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{body}");
    assert!(
        body["error"]["message"]
            .as_str()
            .unwrap()
            .contains("`base`"),
        "{body}"
    );

    // A field's path is the request's own, not the object's place in the
    // mission's list (the paper's mission has objects already).
    let (status, body) = error_of(
        post(json!({"x": 50, "y": 50, "alpha": 1, "sigma": -1}))
            .await
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{body}");
    let message = body["error"]["message"].as_str().unwrap();
    assert!(message.starts_with("sigma:"), "{body}");

    // An object whose whole 5σ disc is outside the 100 m region cannot
    // matter; one whose disc reaches into it can.
    let (status, body) = error_of(
        post(json!({"x": 5000, "y": 50, "alpha": 1, "sigma": 5}))
            .await
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{body}");
    assert!(
        body["error"]["message"]
            .as_str()
            .unwrap()
            .contains("outside the region"),
        "{body}"
    );
    let reaching = post(json!({"x": 120, "y": 50, "alpha": 1, "sigma": 5}))
        .await
        .unwrap();
    assert_eq!(reaching.status(), StatusCode::CREATED);

    let objects: Vec<Value> = http
        .get(server.http("/api/v1/risk-objects"))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert!(objects.iter().all(|o| o["x"] != 5000.0), "{objects:?}");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_refused_write_names_the_scheme() {
    let server = Server::start(ServeConfig {
        token: Some(TOKEN.into()),
        ..ServeConfig::default()
    })
    .await;
    let response = reqwest::Client::new()
        .put(server.http("/api/v1/mission/risk/base"))
        .json(&json!({"value": 0.2}))
        .send()
        .await
        .unwrap();
    assert_eq!(
        response.headers().get("www-authenticate").unwrap(),
        "Bearer"
    );
    let (status, body) = error_of(response).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    assert_eq!(body["error"]["code"], "unauthorized");
    server.stop().await;
}

/// 300 requests on one pooled connection, a third of them refused before
/// their body is read (401 or 429): every one gets its answer.
async fn no_broken_pipes(server: &Server, headers: &[(&str, &str)]) -> (usize, usize) {
    let http = reqwest::Client::builder()
        .pool_max_idle_per_host(1)
        .timeout(Duration::from_secs(10))
        .build()
        .unwrap();
    let (mut refused, mut closed) = (0, 0);
    for i in 0..300 {
        let response = if i % 3 == 0 {
            let mut request = http
                .put(server.http("/api/v1/mission/risk/base"))
                .json(&json!({"value": 0.1 + 0.001 * i as f64}));
            for (name, value) in headers {
                request = request.header(*name, *value);
            }
            request.send().await
        } else {
            http.get(server.http("/api/v1/mission")).send().await
        };
        let response = response.unwrap_or_else(|e| panic!("request {i}: {e:?}"));
        let status = response.status();
        if status == StatusCode::UNAUTHORIZED || status == StatusCode::TOO_MANY_REQUESTS {
            refused += 1;
            closed += usize::from(
                response
                    .headers()
                    .get("connection")
                    .is_some_and(|v| v == "close"),
            );
        } else {
            assert!(status.is_success(), "request {i}: {status}");
        }
        // Read every body, as a client that reuses connections does.
        response.bytes().await.unwrap();
    }
    (refused, closed)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_that_reuses_connections_gets_every_answer() {
    // 401: writes without the token.
    let server = Server::start(ServeConfig {
        token: Some(TOKEN.into()),
        ..ServeConfig::default()
    })
    .await;
    let (refused, closed) = no_broken_pipes(&server, &[]).await;
    assert_eq!(refused, 100);
    assert_eq!(
        closed, refused,
        "each unread body's answer says Connection: close"
    );
    server.stop().await;

    // 429: writes beyond a budget of 1 a second.
    let server = Server::start(ServeConfig {
        write_rate: 1,
        write_burst: 1,
        ..ServeConfig::default()
    })
    .await;
    let (refused, closed) = no_broken_pipes(&server, &[]).await;
    assert!(refused >= 90, "{refused} of 100 writes refused");
    assert_eq!(closed, refused);
    server.stop().await;

    // A refusal without a body keeps the connection: nothing was left
    // unread.
    let server = Server::start(ServeConfig::default()).await;
    let response = reqwest::get(server.http("/api/v1/nothing")).await.unwrap();
    assert_eq!(response.status(), StatusCode::NOT_FOUND);
    assert!(response.headers().get("connection").is_none());
    server.stop().await;
}
