//! Prometheus metrics (`GET /metrics`): connected and live vessels, tick
//! duration histogram, skipped ticks, H, messages in and out, rejected
//! messages by reason, refused poses by reason and quarantined vessels, and on Linux the standard process metrics
//! `process_cpu_seconds_total` and `process_resident_memory_bytes`.
//!
//! The recorder is process-global (the `metrics` facade allows one), so
//! several servers in one process — as in the tests — share it.
//!
//! The process metrics are read from `/proc` at render time and appended as
//! text rather than recorded through the facade: its counters are integers,
//! and whole CPU seconds are too coarse for `seacover bench load`, which
//! divides a difference of two scrapes by the wall time between them.
//!
//! Invariant: memory is bounded whether or not anyone scrapes. The exporter
//! keeps every histogram sample (a value and an `Instant`, 24 bytes) in a
//! queue until an upkeep folds it into the fixed buckets; the upkeep runs
//! at each render and, on the thread [`handle`] starts, every
//! [`UPKEEP_EVERY`]. Without that thread a coordinator nobody scraped kept
//! every tick's duration and every command's delay: 7 MB per mission hour
//! with 8 vessels at time warp 20 (docs/performance.md).

use std::sync::OnceLock;

use metrics_exporter_prometheus::{Matcher, PrometheusBuilder, PrometheusHandle};

pub const VESSELS_CONNECTED: &str = "seacover_vessels_connected";
pub const VESSELS_LIVE: &str = "seacover_vessels_live";
pub const TICK_SECONDS: &str = "seacover_tick_seconds";
pub const TICKS_SKIPPED: &str = "seacover_ticks_skipped_total";
pub const COVERAGE_H: &str = "seacover_coverage_h";
pub const MESSAGES_IN: &str = "seacover_messages_in_total";
pub const MESSAGES_OUT: &str = "seacover_messages_out_total";
pub const MESSAGES_REJECTED: &str = "seacover_messages_rejected_total";
/// Poses refused as implausible, by reason (`not_finite`, `out_of_range`,
/// `time_backwards`, `outside_region`, `too_fast`, `jump`, `fix`).
pub const POSES_REFUSED: &str = "seacover_poses_refused_total";
/// Samples of the risk field, by outcome (`accepted`, or the refusal's
/// code: `invalid`, `outside_region`, `stale`, `future`, `flood`; on a
/// vessel link also `unplaced`, a vessel whose poses are refused, and
/// `dropped`, the coordinator's queue full).
pub const SAMPLES: &str = "seacover_samples_total";
/// Fits of the learned risk map.
pub const FITS: &str = "seacover_learning_fits_total";
/// Vessels out of the partition and held because their poses are refused.
pub const VESSELS_QUARANTINED: &str = "seacover_vessels_quarantined";
/// Commands the safety filter changed (vessel-ticks); over
/// `seacover_messages_out_total{kind="command"}` it is the intervention rate.
pub const SAFETY_INTERVENTIONS: &str = "seacover_safety_interventions_total";
/// From the moment a tick was due to its command written to the link's
/// socket, per command.
pub const COMMAND_DELAY: &str = "seacover_command_delay_seconds";
/// Wall-clock (Unix) time at which tick 0 was due; tick N is due at
/// origin + N × period.
pub const TICK_ORIGIN: &str = "seacover_tick_origin_seconds";
/// Wall-clock seconds between ticks (1 / (tick_hz × time warp)).
pub const TICK_PERIOD: &str = "seacover_tick_period_seconds";

/// `COMMAND_DELAY`'s buckets: every millisecond up to 40 ms, where the
/// 20 ms target lies, then coarser; `seacover bench load` reads its
/// percentiles from them.
pub const COMMAND_DELAY_BUCKETS: [f64; 46] = {
    let mut b = [0.0; 46];
    let mut i = 0;
    while i < 40 {
        b[i] = (i + 1) as f64 * 1e-3;
        i += 1;
    }
    let tail = [0.05, 0.1, 0.2, 0.5, 1.0, 5.0];
    let mut j = 0;
    while j < tail.len() {
        b[40 + j] = tail[j];
        j += 1;
    }
    b
};

static HANDLE: OnceLock<PrometheusHandle> = OnceLock::new();

/// How often histogram samples are folded into their buckets when nobody
/// scrapes: the queue then holds at most this long's samples (at 1000
/// vessels and 10 Hz, 10 000 command delays, 240 kB).
pub const UPKEEP_EVERY: std::time::Duration = std::time::Duration::from_secs(1);

/// The process's Prometheus handle, installing the recorder (and starting
/// its upkeep thread) on first use.
pub fn handle() -> &'static PrometheusHandle {
    HANDLE.get_or_init(|| {
        let builder = PrometheusBuilder::new()
            .set_buckets_for_metric(
                Matcher::Full(TICK_SECONDS.to_string()),
                &[
                    1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0,
                ],
            )
            .expect("non-empty buckets")
            .set_buckets_for_metric(
                Matcher::Full(COMMAND_DELAY.to_string()),
                &COMMAND_DELAY_BUCKETS,
            )
            .expect("non-empty buckets");
        let recorder = builder.build_recorder();
        let handle = recorder.handle();
        // If another recorder was installed first, ours stays empty but valid.
        let _ = metrics::set_global_recorder(recorder);
        let upkept = handle.clone();
        // A thread rather than a task: the handle is process-global and
        // outlives any one runtime (the tests run several servers in one
        // process, each on its own runtime). If it cannot be spawned the
        // renders still drain the queue.
        let spawned = std::thread::Builder::new()
            .name("seacover-metrics".into())
            .spawn(move || {
                loop {
                    std::thread::sleep(UPKEEP_EVERY);
                    upkept.run_upkeep();
                }
            });
        if let Err(e) = spawned {
            tracing::warn!(error = %e, "no metrics upkeep thread; only scrapes drain histograms");
        }
        handle
    })
}

/// `GET /metrics`.
pub async fn render() -> ([(axum::http::HeaderName, &'static str); 1], String) {
    let h = handle();
    h.run_upkeep();
    (
        [(
            axum::http::header::CONTENT_TYPE,
            "text/plain; version=0.0.4",
        )],
        h.render() + &process_metrics(),
    )
}

/// The process metrics in Prometheus text, or nothing where `/proc` is
/// missing or unreadable.
fn process_metrics() -> String {
    let mut out = String::new();
    if let Some(cpu) = std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| cpu_seconds(&s))
    {
        out.push_str(&format!(
            "# HELP process_cpu_seconds_total Total user and system CPU time spent in seconds.\n\
             # TYPE process_cpu_seconds_total counter\n\
             process_cpu_seconds_total {cpu}\n"
        ));
    }
    if let Some(rss) = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| resident_bytes(&s))
    {
        out.push_str(&format!(
            "# HELP process_resident_memory_bytes Resident memory size in bytes.\n\
             # TYPE process_resident_memory_bytes gauge\n\
             process_resident_memory_bytes {rss}\n"
        ));
    }
    out
}

/// CPU seconds this process has used so far (Linux only), for the load
/// client (`seacover bench load`) to report its own share of a shared
/// machine.
pub fn own_cpu_seconds() -> Option<f64> {
    cpu_seconds(&std::fs::read_to_string("/proc/self/stat").ok()?)
}

/// utime + stime of every thread of the process, from `/proc/self/stat`.
/// The command name (field 2) may contain spaces and parentheses, so fields
/// are counted from the last `)`. They are in USER_HZ ticks, which Linux
/// fixes at 100 on every architecture it exports `/proc` for (the
/// Prometheus Go client assumes the same).
fn cpu_seconds(stat: &str) -> Option<f64> {
    const USER_HZ: f64 = 100.0;
    let rest = &stat[stat.rfind(')')? + 1..];
    // After the name: state (field 3) … utime (14), stime (15).
    let mut fields = rest.split_whitespace().skip(11);
    let utime: u64 = fields.next()?.parse().ok()?;
    let stime: u64 = fields.next()?.parse().ok()?;
    Some((utime + stime) as f64 / USER_HZ)
}

/// `VmRSS` of `/proc/self/status` in bytes. It is in kB already, so no page
/// size is needed (which `statm` would, and only libc can tell).
fn resident_bytes(status: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kb: u64 = line
        .trim_start_matches("VmRSS:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_cpu_time_past_a_name_with_spaces_and_parentheses() {
        let stat = "4242 (tokio (rt) x) S 1 4242 4242 0 -1 4194560 1 0 0 0 \
                    250 75 0 0 20 0 9 0 100 1000 10 18446744073709551615";
        assert_eq!(cpu_seconds(stat), Some(3.25));
        assert_eq!(cpu_seconds("garbage"), None);
    }

    #[test]
    fn reads_resident_memory_in_bytes() {
        let status = "Name:\tseacover\nVmPeak:\t  900 kB\nVmRSS:\t   1234 kB\nThreads:\t3\n";
        assert_eq!(resident_bytes(status), Some(1234 * 1024));
        assert_eq!(resident_bytes("Name:\tx\n"), None);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn this_process_reports_both() {
        let text = process_metrics();
        let value = |name: &str| -> f64 {
            text.lines()
                .find_map(|l| l.strip_prefix(name)?.trim().parse().ok())
                .unwrap()
        };
        assert!(value("process_cpu_seconds_total ") >= 0.0);
        // Any running Rust test binary is resident in more than 100 kB.
        assert!(value("process_resident_memory_bytes ") > 100e3);
    }
}
