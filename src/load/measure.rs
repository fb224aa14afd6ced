//! The load report made from what the links and the scrapes saw (the
//! figures are defined in the module doc of [`load`](super)).
//!
//! Invariant: pure arithmetic over the outcomes and the three scrapes
//! (before any link, at the window's start and at its end); no I/O.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use super::link::{LinkOutcome, Shared};
use super::report::{CoordinatorFigures, Latency, LinkCounts, LoadReport, TargetCheck, kib, opt};
use super::scrape::{Scrape, bucket_latency, delta, machine_shares};

/// Everything a run saw.
pub(super) struct Measured<'a> {
    pub(super) base: String,
    /// Links asked for, poses a second per link, the coordinator's warp.
    pub(super) vessels: usize,
    pub(super) rate_hz: f64,
    pub(super) time_warp: f64,
    pub(super) tick_hz: f64,
    pub(super) shared: &'a Shared,
    pub(super) outcomes: Vec<LinkOutcome>,
    /// Before any link, at the window's start, at its end.
    pub(super) scrapes: [Scrape; 3],
    pub(super) window: (Instant, Instant),
    pub(super) warmup: Duration,
    pub(super) notes: Vec<String>,
}

/// The report, or the first link's problem when no link connected.
pub(super) fn report(m: Measured<'_>) -> Result<LoadReport, String> {
    let Measured {
        base,
        vessels: n,
        rate_hz,
        time_warp,
        tick_hz,
        shared,
        mut outcomes,
        scrapes: [before_links, start, end],
        window: (window_start, window_end),
        warmup,
        mut notes,
    } = m;
    let connected = outcomes.iter().filter(|o| o.connected).count();
    if connected == 0 {
        let why = outcomes
            .iter()
            .find_map(|o| o.problem.clone())
            .unwrap_or_else(|| "cancelled".into());
        return Err(why);
    }
    let held = outcomes
        .iter()
        .filter(|o| o.connected && o.ended_at.is_none_or(|at| at >= window_end))
        .count();
    let window = (window_end - window_start).as_secs_f64();

    let mut pose_latency = Vec::new();
    let mut offsets = Vec::new();
    let (mut commands, mut poses) = (0, 0);
    for o in &mut outcomes {
        commands += o.commands;
        poses += o.poses;
        pose_latency.append(&mut o.pose_latency);
        offsets.append(&mut o.tick_offsets);
    }
    let (tick_clock, delays) = tick_delays(&offsets, &start, shared, &mut notes);
    let (first_delivery, delivery_spread) = per_tick(&delays);
    let wall = (end.at - start.at).as_secs_f64().max(1e-9);
    let coordinator = coordinator_figures(&before_links, &start, &end, connected, &mut notes);
    let (busy, steal) = machine_shares(start.machine, end.machine);
    let tick_to_command_ms = Latency::of(delays.iter().map(|d| d.1).collect());
    let links = LinkCounts {
        requested: n,
        connected,
        held,
        dropped: connected - held,
        failed: n - connected,
        first_problem: outcomes
            .iter()
            .filter(|o| !o.connected || o.ended_at.is_some_and(|at| at < window_end))
            .find_map(|o| o.problem.clone()),
    };
    let targets = targets(held, n, &tick_to_command_ms, &coordinator);
    Ok(LoadReport {
        server: base,
        vessels: n,
        rate_hz,
        tick_hz,
        time_warp,
        window_s: window,
        warmup_s: warmup.as_secs_f64(),
        links,
        commands_received: commands,
        commands_expected: n as f64 * shared.tick_rate * window,
        poses_sent: poses,
        pose_rate_per_link_hz: if window > 0.0 {
            poses as f64 / (n as f64 * window)
        } else {
            0.0
        },
        pose_to_command_ms: Latency::of(pose_latency),
        tick_to_command_ms,
        tick_clock: tick_clock.into(),
        tick_first_delivery_ms: first_delivery,
        tick_delivery_spread_ms: delivery_spread,
        coordinator,
        client_cpu_cores: delta(start.client_cpu, end.client_cpu).map(|d| d / wall),
        machine_busy_percent: busy,
        machine_steal_percent: steal,
        targets,
        notes,
    })
}

/// Each command's delay after its tick was due, on this client's clock,
/// and which clock that was. The coordinator publishes its tick origin and
/// period; on the same host (one wall clock) that gives every command's
/// exact delay. A delay below zero means the clocks differ (another host):
/// then the origin is estimated from the fastest delivery, which
/// under-states every delay by that one.
fn tick_delays(
    offsets: &[(u64, f64)],
    start: &Scrape,
    shared: &Shared,
    notes: &mut Vec<String>,
) -> (&'static str, Vec<(u64, f64)>) {
    let published = match (start.tick_origin, start.tick_period) {
        (Some(origin), Some(period)) if period > 0.0 => Some((origin - shared.origin_unix, period)),
        _ => None,
    }
    .filter(|&(origin, period)| {
        offsets
            .iter()
            .all(|&(tick, at)| at - (origin + tick as f64 * period) > -1e-3)
    });
    if let Some((origin, period)) = published {
        let delays = offsets
            .iter()
            .map(|&(tick, at)| (tick, at - (origin + tick as f64 * period)))
            .collect();
        return ("published", delays);
    }
    let due = |tick: u64| tick as f64 / shared.tick_rate;
    let t0 = offsets
        .iter()
        .map(|&(tick, at)| at - due(tick))
        .fold(f64::INFINITY, f64::min);
    if !offsets.is_empty() {
        notes.push(
            "the coordinator's tick clock could not be used (not published, or on another \
             host's clock): tick → command is measured from the fastest delivery seen and \
             under-states every delay by that delivery's own"
                .into(),
        );
    }
    let delays = offsets
        .iter()
        .map(|&(tick, at)| (tick, at - due(tick) - t0))
        .collect();
    ("estimated", delays)
}

/// Per tick: its first delivery (the tick's start and evaluation) and the
/// spread to its last (sending every link its command).
fn per_tick(delays: &[(u64, f64)]) -> (Latency, Latency) {
    let mut ticks: HashMap<u64, (f64, f64)> = HashMap::new();
    for &(tick, d) in delays {
        let e = ticks.entry(tick).or_insert((d, d));
        (e.0, e.1) = (e.0.min(d), e.1.max(d));
    }
    (
        Latency::of(ticks.values().map(|(first, _)| *first).collect()),
        Latency::of(ticks.values().map(|(first, last)| last - first).collect()),
    )
}

/// The coordinator's own figures over the window, from its `/metrics`.
fn coordinator_figures(
    before_links: &Scrape,
    start: &Scrape,
    end: &Scrape,
    connected: usize,
    notes: &mut Vec<String>,
) -> CoordinatorFigures {
    let wall = (end.at - start.at).as_secs_f64().max(1e-9);
    let tick_mean_ms = match (
        delta(start.tick_sum, end.tick_sum),
        delta(start.tick_count, end.tick_count),
    ) {
        (Some(s), Some(c)) if c > 0.0 => Some(1e3 * s / c),
        _ => None,
    };
    let coordinator = CoordinatorFigures {
        cpu_cores: delta(start.cpu, end.cpu).map(|d| d / wall),
        rss_before_links_bytes: before_links.rss,
        rss_with_links_bytes: end.rss,
        memory_per_vessel_bytes: delta(before_links.rss, end.rss).map(|d| d / connected as f64),
        ticks_skipped: delta(start.ticks_skipped, end.ticks_skipped),
        commands_dropped_link_full: delta(start.link_full, end.link_full),
        tick_mean_ms,
        command_delay_ms: bucket_latency(&start.command_delay, &end.command_delay),
    };
    if coordinator.cpu_cores.is_none() || coordinator.rss_with_links_bytes.is_none() {
        notes.push(
            "the coordinator's /metrics has no process_cpu_seconds_total or \
             process_resident_memory_bytes (not Linux, or an older seacover)"
                .into(),
        );
    }
    if coordinator.ticks_skipped.is_some_and(|s| s > 0.0) {
        notes.push(
            "the coordinator skipped ticks in the window: tick → command is inflated by one \
             tick period per skip after it"
                .into(),
        );
    }
    coordinator
}

/// The benchmark's targets (docs/performance.md) against what was measured.
fn targets(
    held: usize,
    n: usize,
    tick_to_command_ms: &Latency,
    coordinator: &CoordinatorFigures,
) -> Vec<TargetCheck> {
    vec![
        TargetCheck {
            what: "links".into(),
            target: "none dropped".into(),
            value: format!("{held} of {n} held"),
            met: Some(held == n),
        },
        TargetCheck {
            what: "latency".into(),
            target: "p99 ≤ 20 ms".into(),
            value: tick_to_command_ms.text(),
            met: tick_to_command_ms.p99.map(|p| p <= 20.0),
        },
        TargetCheck {
            what: "cpu".into(),
            target: "≤ 1 core".into(),
            value: opt(coordinator.cpu_cores, |v| format!("{v:.2} cores")),
            met: coordinator.cpu_cores.map(|c| c <= 1.0),
        },
        TargetCheck {
            what: "memory".into(),
            target: "≤ 64 KiB per vessel".into(),
            value: opt(coordinator.memory_per_vessel_bytes, kib),
            met: coordinator
                .memory_per_vessel_bytes
                .map(|m| m <= 64.0 * 1024.0),
        },
    ]
}
