//! What the load client reads besides its links: the coordinator's
//! Prometheus text (`/metrics`) and the machine's CPU counters
//! (`/proc/stat`, Linux only).

use std::time::Instant;

use super::report::Latency;

/// One scrape of `/metrics`.
#[derive(Debug, Clone)]
pub(super) struct Scrape {
    pub(super) at: Instant,
    pub(super) cpu: Option<f64>,
    pub(super) rss: Option<f64>,
    pub(super) ticks_skipped: Option<f64>,
    pub(super) link_full: Option<f64>,
    pub(super) tick_sum: Option<f64>,
    pub(super) tick_count: Option<f64>,
    /// When tick 0 was due (Unix seconds) and the tick period, as the
    /// coordinator publishes them.
    pub(super) tick_origin: Option<f64>,
    pub(super) tick_period: Option<f64>,
    /// `seacover_command_delay_seconds`: (upper bound [s], cumulative count).
    pub(super) command_delay: Vec<(f64, f64)>,
    pub(super) client_cpu: Option<f64>,
    pub(super) machine: Option<MachineCpu>,
}

/// Cumulative CPU time of the whole machine, in USER_HZ ticks.
#[derive(Debug, Clone, Copy)]
pub(super) struct MachineCpu {
    pub(super) total: u64,
    pub(super) idle: u64,
    pub(super) steal: u64,
}

/// The `cpu` line of `/proc/stat`: user nice system idle iowait irq
/// softirq steal (guest time is already in user).
pub(super) fn machine_cpu(stat: &str) -> Option<MachineCpu> {
    let line = stat.lines().find(|l| l.starts_with("cpu "))?;
    let v: Vec<u64> = line
        .split_whitespace()
        .skip(1)
        .take(8)
        .map(|f| f.parse().ok())
        .collect::<Option<_>>()?;
    (v.len() == 8).then(|| MachineCpu {
        total: v.iter().sum(),
        idle: v[3] + v[4],
        steal: v[7],
    })
}

/// (busy %, steal %) between two readings.
pub(super) fn machine_shares(
    a: Option<MachineCpu>,
    b: Option<MachineCpu>,
) -> (Option<f64>, Option<f64>) {
    match (a, b) {
        (Some(a), Some(b)) if b.total > a.total => {
            let total = (b.total - a.total) as f64;
            let idle = b.idle.saturating_sub(a.idle) as f64;
            let steal = b.steal.saturating_sub(a.steal) as f64;
            (
                Some(100.0 * (total - idle) / total),
                Some(100.0 * steal / total),
            )
        }
        _ => (None, None),
    }
}

/// The value of the series `series` (name and labels exactly as rendered).
pub(super) fn series(text: &str, series: &str) -> Option<f64> {
    text.lines().filter(|l| !l.starts_with('#')).find_map(|l| {
        let (name, value) = l.rsplit_once(' ')?;
        (name.trim() == series).then(|| value.trim().parse().ok())?
    })
}

/// The cumulative buckets of the histogram `name`, in rendered order
/// (ascending), `+Inf` included.
pub(super) fn buckets(text: &str, name: &str) -> Vec<(f64, f64)> {
    let prefix = format!("{name}_bucket{{le=\"");
    text.lines()
        .filter_map(|l| {
            let rest = l.strip_prefix(&prefix)?;
            let (le, rest) = rest.split_once('"')?;
            let count = rest.rsplit_once(' ')?.1.trim().parse().ok()?;
            let le = if le == "+Inf" {
                f64::INFINITY
            } else {
                le.parse().ok()?
            };
            Some((le, count))
        })
        .collect()
}

/// Percentiles (ms) of the samples a histogram gained between two scrapes,
/// each read as the upper bound of its bucket (so never under-stated, and
/// at most one bucket width, 1 ms below 40 ms, over). No maximum: a
/// histogram does not keep one, `max` is the upper bound of the highest
/// non-empty bucket.
pub(super) fn bucket_latency(start: &[(f64, f64)], end: &[(f64, f64)]) -> Latency {
    let gained: Vec<(f64, f64)> = end
        .iter()
        .map(|&(le, c)| {
            let before = start
                .iter()
                .find(|(l, _)| *l == le)
                .map_or(0.0, |(_, c)| *c);
            (le, c - before)
        })
        .collect();
    let total = gained.last().map_or(0.0, |(_, c)| *c);
    let rank = |p: f64| {
        (total > 0.0)
            .then(|| {
                let want = (p * total).ceil().max(1.0);
                gained
                    .iter()
                    .find(|(_, c)| *c >= want)
                    .map(|(le, _)| le * 1e3)
            })
            .flatten()
    };
    Latency {
        samples: total as usize,
        p50: rank(0.5),
        p99: rank(0.99),
        max: rank(1.0),
    }
}

pub(super) fn parse_scrape(text: &str, at: Instant) -> Scrape {
    Scrape {
        at,
        cpu: series(text, "process_cpu_seconds_total"),
        rss: series(text, "process_resident_memory_bytes"),
        // Counters the coordinator has not touched yet are not rendered.
        ticks_skipped: series(text, crate::server::metrics::TICKS_SKIPPED).or(Some(0.0)),
        link_full: series(
            text,
            &format!(
                "{}{{reason=\"link_full\"}}",
                crate::server::metrics::MESSAGES_REJECTED
            ),
        )
        .or(Some(0.0)),
        tick_sum: series(
            text,
            &format!("{}_sum", crate::server::metrics::TICK_SECONDS),
        ),
        tick_count: series(
            text,
            &format!("{}_count", crate::server::metrics::TICK_SECONDS),
        ),
        tick_origin: series(text, crate::server::metrics::TICK_ORIGIN),
        tick_period: series(text, crate::server::metrics::TICK_PERIOD),
        command_delay: buckets(text, crate::server::metrics::COMMAND_DELAY),
        client_cpu: crate::server::metrics::own_cpu_seconds(),
        machine: std::fs::read_to_string("/proc/stat")
            .ok()
            .and_then(|s| machine_cpu(&s)),
    }
}

pub(super) fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

pub(super) fn delta(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    Some(b? - a?)
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_series_from_prometheus_text() {
        let text = "# TYPE a counter\na 3\nseacover_messages_rejected_total{reason=\"link_full\"} 7\n\
                    seacover_messages_rejected_total{reason=\"malformed\"} 1\nb_sum 0.25\n";
        assert_eq!(series(text, "a"), Some(3.0));
        assert_eq!(
            series(
                text,
                "seacover_messages_rejected_total{reason=\"link_full\"}"
            ),
            Some(7.0)
        );
        assert_eq!(series(text, "b_sum"), Some(0.25));
        assert_eq!(series(text, "b"), None);
    }

    #[test]
    fn machine_cpu_shares() {
        let a = machine_cpu("cpu  100 0 50 800 50 0 0 0 0 0\ncpu0 1 2 3\n").unwrap();
        let b = machine_cpu("cpu  200 0 100 1000 50 0 0 50 0 0\n").unwrap();
        let (busy, steal) = machine_shares(Some(a), Some(b));
        // 400 ticks: 200 idle, 50 stolen.
        assert_eq!(busy, Some(50.0));
        assert_eq!(steal, Some(12.5));
        assert!(machine_cpu("intr 1 2").is_none());
    }
}
