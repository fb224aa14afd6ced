//! How still ArduPilot boats are, from their own telemetry, and their
//! quiet arrival under a coordinator (docs/ardupilot.md, "Quiet
//! arrival"): what ardupilot_sitl and ardupilot_quiet judge of boats that
//! have converged.

use std::time::{Duration, Instant};

use super::sitl::{Seen, Station, wait_for};

/// How still the boats are from now over the next `ms` of ArduPilot's
/// clock, from their own telemetry: each boat's mean |yaw rate| (ATTITUDE,
/// rad/s) and mean speed over ground (GLOBAL_POSITION_INT, m/s).
pub(crate) async fn quiet_over(stations: &[Station], ms: u32) -> Vec<(f64, f64)> {
    let from: Vec<u32> = stations.iter().map(|s| s.seen(Seen::clock_ms)).collect();
    wait_for(Duration::from_secs(60), async || {
        passed(stations, &from, ms).then_some(())
    })
    .await
    .expect("the boats' clocks advance");
    stillness(stations, &from)
}

fn passed(stations: &[Station], from: &[u32], ms: u32) -> bool {
    stations
        .iter()
        .zip(from)
        .all(|(s, t0)| s.seen(Seen::clock_ms) >= t0 + ms)
}

fn stillness(stations: &[Station], from: &[u32]) -> Vec<(f64, f64)> {
    let mean = |x: Vec<f64>| x.iter().sum::<f64>() / x.len().max(1) as f64;
    stations
        .iter()
        .zip(from)
        .map(|(s, t0)| {
            s.seen(|s| {
                let r = s
                    .attitudes
                    .range(t0..)
                    .map(|(_, (_, rate))| f64::from(*rate).abs());
                let v = (s.positions.range(t0..))
                    .map(|(_, p)| f64::from(p.vx).hypot(f64::from(p.vy)) / 100.0);
                (mean(r.collect()), mean(v.collect()))
            })
        })
        .collect()
}

/// Quiet arrival on ArduPilot boats (docs/ardupilot.md): how long after
/// now (ArduPilot's clock, s) every boat was commanded to keep station,
/// and then, after `settle` ms for it to reach the point, over `ms`: each
/// boat's mean |yaw rate| and mean speed ([`quiet_over`]'s), the largest
/// distance from its goal the coordinator saw, and how many of its
/// commands then did not say `station`.
pub(crate) struct Arrival {
    pub keeping_after: f64,
    pub boats: Vec<(f64, f64, f64, usize)>,
}

pub(crate) async fn quiet_arrival(
    stations: &[Station],
    ids: &[String],
    vessels: impl AsyncFn() -> Vec<seacover::protocol::VesselStatusDocument>,
    (settle, ms): (u32, u32),
) -> Option<Arrival> {
    let start = stations[0].seen(Seen::clock_ms);
    let keeping = wait_for(Duration::from_secs(120), async || {
        let vs = vessels().await;
        ids.iter()
            .all(|id| {
                vs.iter().any(|v| {
                    v.id == *id && v.last_command.as_ref().is_some_and(|c| c.station.is_some())
                })
            })
            .then(|| stations[0].seen(Seen::clock_ms))
    })
    .await?;
    let now: Vec<u32> = stations.iter().map(|s| s.seen(Seen::clock_ms)).collect();
    wait_for(Duration::from_secs(60), async || {
        passed(stations, &now, settle).then_some(())
    })
    .await?;
    let from: Vec<u32> = stations.iter().map(|s| s.seen(Seen::clock_ms)).collect();
    let mut far = vec![(0.0f64, 0usize); ids.len()];
    let began = Instant::now();
    while !passed(stations, &from, ms) && began.elapsed() < Duration::from_secs(60) {
        tokio::time::sleep(Duration::from_millis(100)).await;
        let vs = vessels().await;
        for (k, id) in ids.iter().enumerate() {
            let Some(v) = vs.iter().find(|v| v.id == *id) else {
                continue;
            };
            if let (Some(p), Some(c)) = (&v.pose, &v.centroid) {
                far[k].0 = far[k].0.max((c[0] - p.x).hypot(c[1] - p.y));
            }
            if v.last_command.as_ref().is_none_or(|c| c.station.is_none()) {
                far[k].1 += 1;
            }
        }
    }
    let boats = stillness(stations, &from)
        .into_iter()
        .zip(far)
        .map(|((r, v), (e, off))| (r, v, e, off))
        .collect();
    Some(Arrival {
        keeping_after: f64::from(keeping - start) / 1000.0,
        boats,
    })
}

/// H now (`GET /api/v1/coverage` of the coordinator at `base`) and H with
/// every vessel of `vessels` that has a cell at its centroid (`POST
/// /api/v1/coverage/evaluate`).
pub(crate) async fn coverage_now(
    http: &reqwest::Client,
    base: &str,
    vessels: &[seacover::protocol::VesselStatusDocument],
) -> (f64, f64) {
    let now: seacover::protocol::CoverageDocument =
        crate::common::server::get_json(http, &format!("{base}/api/v1/coverage")).await;
    let at_centroids = serde_json::json!({"vessels": vessels.iter().filter_map(|v| {
        let c = v.centroid?;
        Some(serde_json::json!({"id": v.id, "x": c[0], "y": c[1]}))
    }).collect::<Vec<_>>()});
    let ideal: serde_json::Value = http
        .post(format!("{base}/api/v1/coverage/evaluate"))
        .json(&at_centroids)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    (now.h, ideal["H"].as_f64().unwrap())
}
