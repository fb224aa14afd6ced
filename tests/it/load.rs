//! `seacover bench load` against the real coordinator on loopback at time
//! warp 1: behaviour of the measurement, not speed (docs/performance.md has the
//! measured figures). The measured coordinator runs as its own process, as
//! the benchmark is meant to be used: its `/metrics` (the published tick
//! clock, the command-delay histogram) are per process, and other tests of
//! this crate run coordinators in this one.

use std::time::Duration;

use crate::common::inprocess::Server;
use seacover::load::{LoadConfig, run};
use seacover::server::ServeConfig;
use tokio::net::TcpListener;
use tokio_util::sync::CancellationToken;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn twenty_links_are_held_and_commanded_every_tick() {
    let data = tempfile::tempdir().unwrap();
    let mut command = crate::common::server::serve_unrecorded(data.path());
    command.stderr(std::process::Stdio::null());
    let (child, addr) = crate::common::server::start(command);
    let mut coordinator = crate::common::process::KillOnDrop(child);

    let mut load = LoadConfig::new(format!("http://{addr}"), 20, 20.0, Duration::from_secs(2));
    load.warmup = Duration::from_millis(500);
    let report = run(load, CancellationToken::new()).await.unwrap();

    // It stops cleanly on SIGTERM within 5 s.
    crate::common::process::signal(coordinator.0.id(), "-TERM");
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    let status = loop {
        if let Some(status) = coordinator.0.try_wait().unwrap() {
            break status;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the coordinator stops within 5 s"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    assert!(status.success(), "{status}");

    let text = report.to_string();
    assert_eq!(report.links.held, 20, "{text}");
    assert_eq!(report.links.dropped + report.links.failed, 0, "{text}");
    assert_eq!(report.tick_hz, 10.0);
    assert!((report.window_s - 2.0).abs() < 0.2, "{text}");

    // 20 links × 10 Hz × 2 s: one command per tick per link, give or take
    // the tick at either edge of the window.
    let expected = report.commands_expected;
    assert!((expected - 400.0).abs() < 40.0, "{text}");
    let received = report.commands_received as f64;
    assert!(
        received >= 0.9 * expected && received <= expected + 2.0 * 20.0,
        "{text}"
    );
    // Poses at 20 Hz per link.
    assert!((report.pose_rate_per_link_hz - 20.0).abs() < 2.0, "{text}");

    // Pose → next command waits for the next tick: samples for about every
    // pose, spread over [0, 100 ms) plus delivery.
    let pose = &report.pose_to_command_ms;
    assert!(pose.samples as u64 >= report.poses_sent * 9 / 10, "{text}");
    let (p50, p99, max) = (pose.p50.unwrap(), pose.p99.unwrap(), pose.max.unwrap());
    assert!(p50 > 5.0 && p50 < 100.0, "{text}");
    assert!(p50 <= p99 && p99 <= max && max < 1000.0, "{text}");
    assert!(
        p99 > 50.0,
        "a tick period apart, some poses wait most of it: {text}"
    );

    // Tick → command is measured from when each tick was due, on the clock
    // the coordinator publishes (one host here): non-negative, one sample
    // per command, and well under a tick period on a quiet machine's
    // loopback (a generous bound: this is not a timed test).
    assert_eq!(report.tick_clock, "published", "{text}");
    let tick = &report.tick_to_command_ms;
    assert_eq!(tick.samples as u64, report.commands_received, "{text}");
    let (t50, t99) = (tick.p50.unwrap(), tick.p99.unwrap());
    assert!(
        t50 >= 0.0 && t50 <= t99 && t99 <= tick.max.unwrap(),
        "{text}"
    );
    assert!(t50 < 100.0, "{text}");
    assert!(t50 < p50, "tick → command excludes the wait: {text}");
    // The coordinator's own figure stops at the socket, before loopback and
    // this client: no later than what the client sees, give or take its
    // 1 ms buckets and the scrapes' slightly different window.
    let written = &report.coordinator.command_delay_ms;
    assert!(
        written.samples as u64 >= report.commands_received * 9 / 10,
        "{text}"
    );
    assert!(written.p50.unwrap() <= t99 + 1.0, "{text}");

    // Process figures come from /metrics (Linux /proc); here the coordinator
    // shares the process with the client, so only their presence and sign
    // are checked.
    #[cfg(target_os = "linux")]
    {
        let c = &report.coordinator;
        let cpu = c.cpu_cores.unwrap();
        assert!((0.0..4.0).contains(&cpu), "{text}");
        assert!(c.rss_before_links_bytes.unwrap() > 0.0, "{text}");
        assert!(c.rss_with_links_bytes.unwrap() > 0.0, "{text}");
        assert!(c.memory_per_vessel_bytes.is_some(), "{text}");
        assert!(c.tick_mean_ms.unwrap() > 0.0, "{text}");
        assert!(report.client_cpu_cores.is_some(), "{text}");
    }

    // The JSON carries the same figures.
    let json: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
    assert_eq!(json["links"]["held"], 20);
    assert_eq!(json["commands_received"], report.commands_received);
    assert!(json["targets"].as_array().unwrap().len() == 4);
    assert!(text.contains("| links held | 20 of 20"), "{text}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_unreachable_coordinator_is_an_error() {
    // A port that was free a moment ago.
    let addr = TcpListener::bind("127.0.0.1:0")
        .await
        .unwrap()
        .local_addr()
        .unwrap();
    let load = LoadConfig::new(format!("http://{addr}"), 2, 20.0, Duration::from_secs(1));
    let err = run(load, CancellationToken::new()).await.unwrap_err();
    assert!(err.to_string().contains("/api/v1/mission"), "{err}");

    let bad = LoadConfig::new("localhost:1", 2, 20.0, Duration::from_secs(1));
    assert!(run(bad, CancellationToken::new()).await.is_err());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wrong_token_fails_every_link() {
    let server = Server::start(ServeConfig {
        token: Some("right".into()),
        ..Default::default()
    })
    .await;
    let mut load = LoadConfig::new(server.base(), 3, 20.0, Duration::from_secs(1));
    load.token = Some("wrong".into());
    let err = run(load, CancellationToken::new()).await.unwrap_err();
    assert!(err.to_string().contains("no vessel link"), "{err}");
    server.stop_ignoring_result().await;
}
