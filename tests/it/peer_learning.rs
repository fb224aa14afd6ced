//! A peer fleet that learns the risk map (docs/learning.md, "In a peer
//! fleet"): eight real `seacover agent --peer --learn` processes in network
//! namespaces of their own (as tests/it/peer_fleet.rs runs them), no
//! coordinator, the mission `examples/paper-learning.json` (the paper's
//! square and fleet, a flat risk as the prior) and, hidden from the fleet,
//! its truth (the paper's map) measured by each simulated hull at 1 Hz
//! (`--truth`). Judged from outside the vessels:
//!
//! - H on the truth at the positions the observer hears (`seacover
//!   evaluate` of the paper's scenario, whose risk is the truth) reaches 99 %
//!   of H★, the final H of the centralized run that knows the truth
//!   (`seacover sim --scenario paper`), within 400 s of mission time;
//! - every vessel's belief (its status, asked with `?belief`) is within 3 %
//!   of the truth's range of every other's at every point of a 2 m grid,
//!   and two vessels that report the same digest hold the same belief;
//! - every batch of samples on the wire is a CBOR array of at most 16 maps
//!   of the documented keys, and no vessel refuses a sample;
//! - no two vessels come within the safety distance.
//!
//! Needs root and the test venv (skipped with a message otherwise, a
//! failure under CI=true).

use std::collections::BTreeMap;

use crate::common::fleet::*;
use crate::common::paper::*;
use crate::common::peer::now;
use serde_json::Value;

/// Mission time warp: a fit every 10 mission seconds in eight processes
/// leaves the two cores room for the hulls.
const LEARN_WARP: f64 = 5.0;

/// The truth, the paper's map: Φ = 0.1 + three Gaussians of σ 10 m.
fn truth(x: f64, y: f64) -> f64 {
    let g = |cx: f64, cy: f64, a: f64| a * (-((x - cx).powi(2) + (y - cy).powi(2)) / 200.0).exp();
    0.1 + g(25.0, 70.0, 10.0) + g(70.0, 75.0, 13.0) + g(60.0, 25.0, 8.0)
}

fn density(risk: &Value, x: f64, y: f64) -> f64 {
    crate::common::server::density_at(risk, x, y)
}

#[test]
fn a_peer_fleet_learns_the_map_and_reaches_h_star() {
    let test = "peer_learning";
    let Some(python) = skip(test) else { return };
    let mut checks = Checks::new(test);
    let h_star = centralized_h();
    let mut setup = Setup::new("l", LEARN_WARP).status_every(5.0);
    setup.observer_args.push("--status-belief".into());
    setup.mission = LEARNING;
    setup.vessel_args = ["--learn", "--refit", "10", "--truth", LEARNING]
        .map(String::from)
        .to_vec();
    let mut fleet = Fleet::new(setup, &python);
    fleet.launch();
    fleet.wait_heard_all();
    let mut series: Vec<(f64, f64)> = Vec::new();
    let mut next = 20.0;
    fleet.run_until(400.0, |f| {
        let t = f.mission_time();
        if t >= next {
            next = t + 20.0;
            let (h, _) = coverage(&f.positions());
            series.push((t, h / h_star));
        }
    });
    let reached = series.iter().find(|(_, s)| *s >= 0.99).map(|(t, _)| *t);
    let end = series.last().map_or(0.0, |(_, s)| *s);
    let since = now() - 12.0;
    let statuses = fleet.newest_statuses(since);
    let beliefs: BTreeMap<String, (Value, String)> = statuses
        .iter()
        .filter_map(|(id, s)| {
            let l = &s["status"]["learning"];
            Some((
                id.clone(),
                (l["belief"].clone(), l["digest"].as_str()?.to_string()),
            ))
        })
        .filter(|(_, (b, _))| b.is_object())
        .collect();
    let range = 13.0; // the truth's largest less smallest, to 1 %
    let mut worst: f64 = 0.0;
    let mut same_digest = (0, 0);
    let ids: Vec<&String> = beliefs.keys().collect();
    for (i, a) in ids.iter().enumerate() {
        for b in &ids[i + 1..] {
            let ((ba, da), (bb, db)) = (&beliefs[*a], &beliefs[*b]);
            let mut gap: f64 = 0.0;
            for k in 0..=2500 {
                let (x, y) = (f64::from(k % 51) * 2.0, f64::from(k / 51) * 2.0);
                gap = gap.max((density(ba, x, y) - density(bb, x, y)).abs());
            }
            worst = worst.max(gap / range);
            if da == db {
                same_digest.0 += 1;
                if ba == bb {
                    same_digest.1 += 1;
                }
            }
        }
    }
    let learned_error = beliefs
        .values()
        .map(|(b, _)| {
            [(25.0, 70.0), (70.0, 75.0), (60.0, 25.0)]
                .iter()
                .map(|&(x, y)| (density(b, x, y) - truth(x, y)).abs() / range)
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    let batches: Vec<Value> = fleet
        .other
        .iter()
        .filter(|r| r["kind"] == "samples")
        .cloned()
        .collect();
    let largest = batches
        .iter()
        .map(|r| r["size"].as_u64().unwrap_or(u64::MAX))
        .max()
        .unwrap_or(0);
    let samples: Vec<&Value> = batches
        .iter()
        .flat_map(|r| r["samples"].as_array().into_iter().flatten())
        .collect();
    let keys_ok = samples.iter().all(|s| {
        s.as_object().is_some_and(|m| {
            let mut k: Vec<&str> = m.keys().map(String::as_str).collect();
            k.sort_unstable();
            k == ["id", "n", "sd", "t", "value", "x", "y"]
        })
    });
    let most = batches
        .iter()
        .map(|r| r["samples"].as_array().map_or(0, Vec::len))
        .max()
        .unwrap_or(0);
    let refused: u64 = statuses
        .values()
        .flat_map(|s| {
            s["status"]["refused"]
                .as_object()
                .into_iter()
                .flatten()
                .filter(|(k, _)| k.starts_with("sample_"))
                .map(|(_, v)| v.as_u64().unwrap_or(0))
        })
        .sum();
    let held: Vec<u64> = statuses
        .values()
        .map(|s| s["status"]["learning"]["samples"].as_u64().unwrap_or(0))
        .collect();
    let safety = fleet.safety_distance();
    let closest = check_safety(&mut checks, &fleet, safety);
    fleet.shutdown(&mut checks);
    eprintln!(
        "SUMMARY {test}: 8 processes, time warp {LEARN_WARP}, truth hidden (the paper's map), flat \
         prior; H on the truth / H★ ({h_star:.1}) every 20 s: {:?}; 99 % from {reached:?} s; \
         beliefs of {} vessels: largest gap between two {:.2} % of the range, at the peaks \
         within {:.2} % of the truth; {}/{} pairs with the same digest hold the same belief; \
         samples held {held:?}; {} samples heard by the observer in {} batches, the largest \
         {largest} B ({most} samples); \
         {refused} refused; closest pair {closest:.2} m",
        series
            .iter()
            .map(|(t, s)| format!("{t:.0}:{:.2}%", 100.0 * s))
            .collect::<Vec<_>>(),
        beliefs.len(),
        100.0 * worst,
        100.0 * learned_error,
        same_digest.1,
        same_digest.0,
        samples.len(),
        batches.len(),
    );
    checks.check(
        reached.is_some_and(|t| t <= 400.0) && end >= 0.99,
        format!("H on the truth ≥ 99 % of H★ within 400 s and at the end ({end:.4})"),
    );
    checks.check(
        beliefs.len() == N,
        format!("a belief from every vessel ({})", beliefs.len()),
    );
    checks.check(
        worst <= 0.03,
        format!(
            "beliefs within 3 % of the range of each other ({:.2} %)",
            100.0 * worst
        ),
    );
    checks.check(
        same_digest.0 == same_digest.1,
        "the same digest, the same belief",
    );
    checks.check(
        !samples.is_empty() && keys_ok && most <= 16 && largest <= 16 * 96,
        format!(
            "batches of at most 16 samples, ≤ 16 × 96 B, each a CBOR map of the documented \
             keys ({most} samples, {largest} B)"
        ),
    );
    checks.check(refused == 0, format!("no sample refused ({refused})"));
    checks.finish();
}
