//! The real `seacover serve` process: SIGTERM stops it within 2 s, and a
//! linked vessel is told why.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::process::signal;
use futures_util::{SinkExt, StreamExt};
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_stops_the_server_within_two_seconds() {
    let data = tempfile::tempdir().unwrap();
    let mut command = Command::new(env!("CARGO_BIN_EXE_seacover"));
    command
        .args(["serve", "--bind", "127.0.0.1:0", "--data-dir"])
        .arg(data.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::null());
    let (mut child, addr) = crate::common::server::start(command);

    let (socket, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/api/v1/vessels/link"))
        .await
        .unwrap();
    let (mut sink, mut stream) = socket.split();
    sink.send(Message::text(
        json!({"type": "hello", "vessel": "v", "protocol": 1}).to_string(),
    ))
    .await
    .unwrap();
    let welcome = stream.next().await.unwrap().unwrap();
    assert!(welcome.to_text().unwrap().contains("welcome"));

    let started = Instant::now();
    signal(child.id(), "-TERM");
    // The vessel hears why the link ends.
    let mut told = false;
    while let Ok(Some(Ok(msg))) = tokio::time::timeout(Duration::from_secs(3), stream.next()).await
    {
        if let Message::Text(t) = msg {
            let v: Value = serde_json::from_str(&t).unwrap();
            if v["type"] == "error" && v["code"] == "shutting_down" {
                told = true;
            }
        }
    }
    assert!(told, "no shutting_down error reached the vessel");
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            assert!(status.success(), "{status:?}");
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(2),
            "still running after 2 s"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}
