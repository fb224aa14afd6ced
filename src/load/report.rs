//! The load benchmark's report: its figures, the targets of docs/performance.md they are
//! held to, and the table `seacover bench load` prints.

use std::fmt;

use serde::Serialize;

/// Percentiles of one latency, in milliseconds (`null` without samples).
#[derive(Debug, Clone, Serialize)]
pub struct Latency {
    pub samples: usize,
    pub p50: Option<f64>,
    pub p99: Option<f64>,
    pub max: Option<f64>,
}

impl Latency {
    pub(super) fn of(mut seconds: Vec<f64>) -> Latency {
        seconds.sort_by(f64::total_cmp);
        // Nearest rank: the smallest sample with at least p of them at or
        // below it.
        let rank = |p: f64| {
            let n = seconds.len();
            (n > 0).then(|| seconds[((p * n as f64).ceil() as usize).clamp(1, n) - 1] * 1e3)
        };
        Latency {
            samples: seconds.len(),
            p50: rank(0.5),
            p99: rank(0.99),
            max: seconds.last().map(|s| s * 1e3),
        }
    }

    pub(super) fn text(&self) -> String {
        match (self.p50, self.p99, self.max) {
            (Some(a), Some(b), Some(c)) => format!("{a:.1} / {b:.1} / {c:.1} ms"),
            _ => "no samples".into(),
        }
    }
}

/// Links at the end of the window.
#[derive(Debug, Clone, Serialize)]
pub struct LinkCounts {
    pub requested: usize,
    pub connected: usize,
    /// Connected and still open at the end of the window.
    pub held: usize,
    /// Connected, then closed or broken before the end of the window.
    pub dropped: usize,
    /// Refused or timed out before the welcome.
    pub failed: usize,
    /// Why the first failed or dropped link ended.
    pub first_problem: Option<String>,
}

/// Figures taken from the coordinator's `/metrics`.
#[derive(Debug, Clone, Serialize)]
pub struct CoordinatorFigures {
    /// Cores: Δ process_cpu_seconds_total / Δ wall over the window.
    pub cpu_cores: Option<f64>,
    pub rss_before_links_bytes: Option<f64>,
    pub rss_with_links_bytes: Option<f64>,
    /// (rss with links − rss before links) / links connected.
    pub memory_per_vessel_bytes: Option<f64>,
    /// Ticks skipped during the window because one overran.
    pub ticks_skipped: Option<f64>,
    /// Commands not queued during the window because a link's queue was full.
    pub commands_dropped_link_full: Option<f64>,
    /// Mean duration of the coordinator's ticks during the window.
    pub tick_mean_ms: Option<f64>,
    /// Tick due → command written to the link's socket, as the coordinator
    /// measures it (`seacover_command_delay_seconds`, 1 ms buckets, each
    /// sample read as its bucket's upper bound).
    pub command_delay_ms: Latency,
}

/// One target of docs/performance.md and whether this run met it (`null`: not measured).
#[derive(Debug, Clone, Serialize)]
pub struct TargetCheck {
    pub what: String,
    pub target: String,
    pub value: String,
    pub met: Option<bool>,
}

/// The result of a run: [`fmt::Display`] renders it as a Markdown table,
/// [`LoadReport::to_json`] as JSON.
#[derive(Debug, Clone, Serialize)]
pub struct LoadReport {
    pub server: String,
    pub vessels: usize,
    pub rate_hz: f64,
    /// The mission's tick rate (from the mission and the welcome).
    pub tick_hz: f64,
    pub time_warp: f64,
    /// Length of the measured window [s].
    pub window_s: f64,
    pub warmup_s: f64,
    pub links: LinkCounts,
    pub commands_received: u64,
    /// N × tick_hz × time_warp × window.
    pub commands_expected: f64,
    pub poses_sent: u64,
    /// Poses per second per link actually sent (the client keeping up).
    pub pose_rate_per_link_hz: f64,
    /// Pose sent → that link's next command received (the figure).
    pub pose_to_command_ms: Latency,
    /// Tick due → command received (compared with the target).
    pub tick_to_command_ms: Latency,
    /// How the ticks' due times were known: `published` (the coordinator's
    /// tick origin, exact on one host) or `estimated` (from the fastest
    /// delivery, a lower bound).
    pub tick_clock: String,
    /// Its two parts, one sample per tick: the tick's first delivery (how
    /// late the tick started and evaluated, against the fastest one) and
    /// the spread from its first delivery to its last (sending every link
    /// its command).
    pub tick_first_delivery_ms: Latency,
    pub tick_delivery_spread_ms: Latency,
    pub coordinator: CoordinatorFigures,
    /// CPU of this load client over the window, in cores.
    pub client_cpu_cores: Option<f64>,
    /// This machine's CPU over the window (Linux `/proc/stat`): the share of
    /// all cores busy, and the share stolen by the hypervisor. On loopback
    /// the coordinator runs here too; other load or steal shows in the
    /// latencies.
    pub machine_busy_percent: Option<f64>,
    pub machine_steal_percent: Option<f64>,
    pub targets: Vec<TargetCheck>,
    pub notes: Vec<String>,
}

impl LoadReport {
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("reports serialize")
    }

    /// Whether every measured target was met.
    pub fn all_met(&self) -> bool {
        self.targets.iter().all(|t| t.met != Some(false))
    }
}

pub(super) fn yes_no(met: Option<bool>) -> &'static str {
    match met {
        Some(true) => "yes",
        Some(false) => "**no**",
        None => "n/a",
    }
}

pub(super) fn kib(bytes: f64) -> String {
    if bytes.abs() >= 1024.0 * 1024.0 {
        format!("{:.1} MiB", bytes / (1024.0 * 1024.0))
    } else {
        format!("{:.1} KiB", bytes / 1024.0)
    }
}

pub(super) fn opt<T>(v: Option<T>, f: impl FnOnce(T) -> String) -> String {
    v.map_or_else(|| "n/a".to_string(), f)
}

/// A row of the report's table: the figure, its value, and the target it
/// meets (`what` of a [`TargetCheck`], or "" for none).
type Row = (String, String, &'static str);

impl LoadReport {
    /// The links', commands' and latencies' rows.
    fn traffic_rows(&self) -> Vec<Row> {
        let l = &self.links;
        let ratio = if self.commands_expected > 0.0 {
            format!(
                " ({:.2} %)",
                100.0 * self.commands_received as f64 / self.commands_expected
            )
        } else {
            String::new()
        };
        vec![
            (
                "links held".into(),
                format!(
                    "{} of {} ({} dropped, {} failed to connect)",
                    l.held, l.requested, l.dropped, l.failed
                ),
                "links",
            ),
            (
                "commands received / expected".into(),
                format!(
                    "{} / {:.0}{ratio}",
                    self.commands_received, self.commands_expected
                ),
                "",
            ),
            (
                "poses sent".into(),
                format!(
                    "{} ({:.2} Hz per link)",
                    self.poses_sent, self.pose_rate_per_link_hz
                ),
                "",
            ),
            (
                format!(
                    "tick due → command received ({} tick clock), p50 / p99 / max",
                    self.tick_clock
                ),
                self.tick_to_command_ms.text(),
                "latency",
            ),
            (
                "… of which the tick's first delivery (per tick)".into(),
                self.tick_first_delivery_ms.text(),
                "",
            ),
            (
                "… and the first → last delivery of a tick (per tick)".into(),
                self.tick_delivery_spread_ms.text(),
                "",
            ),
            (
                "pose sent → next command, p50 / p99 / max".into(),
                self.pose_to_command_ms.text(),
                "",
            ),
        ]
    }

    /// The coordinator's and the machine's rows.
    fn machine_rows(&self) -> Vec<Row> {
        let c = &self.coordinator;
        let memory = match (
            c.memory_per_vessel_bytes,
            c.rss_before_links_bytes,
            c.rss_with_links_bytes,
        ) {
            (Some(v), Some(a), Some(b)) => format!(
                "{} ({} resident before the links, {} with them)",
                kib(v),
                kib(a),
                kib(b)
            ),
            _ => "n/a".into(),
        };
        vec![
            (
                "tick due → command written, coordinator's histogram, p50 / p99 / max".into(),
                c.command_delay_ms.text(),
                "",
            ),
            (
                "coordinator CPU".into(),
                opt(c.cpu_cores, |v| format!("{v:.2} cores")),
                "cpu",
            ),
            ("coordinator memory per vessel".into(), memory, "memory"),
            (
                "coordinator ticks".into(),
                format!(
                    "mean {}, {} skipped; {} commands dropped on full links",
                    opt(c.tick_mean_ms, |v| format!("{v:.2} ms")),
                    opt(c.ticks_skipped, |v| format!("{v:.0}")),
                    opt(c.commands_dropped_link_full, |v| format!("{v:.0}")),
                ),
                "",
            ),
            (
                "load client CPU (same machine)".into(),
                opt(self.client_cpu_cores, |v| format!("{v:.2} cores")),
                "",
            ),
            (
                "this machine's CPU".into(),
                match (self.machine_busy_percent, self.machine_steal_percent) {
                    (Some(b), Some(s)) => {
                        format!("{b:.0} % busy, {s:.1} % stolen by the hypervisor")
                    }
                    _ => "n/a".into(),
                },
                "",
            ),
        ]
    }
}

impl fmt::Display for LoadReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "seacover bench load: {} vessels, poses at {} Hz, {:.1} s measured after {:.1} s of warm-up; \
             coordinator {} ticking at {} Hz (time warp {})",
            self.vessels,
            self.rate_hz,
            self.window_s,
            self.warmup_s,
            self.server,
            self.tick_hz,
            self.time_warp
        )?;
        writeln!(f)?;
        writeln!(f, "| figure | value | target | met |")?;
        writeln!(f, "| --- | --- | --- | --- |")?;
        for (name, value, what) in self.traffic_rows().into_iter().chain(self.machine_rows()) {
            let target = self.targets.iter().find(|t| t.what == what);
            let (t, m) = target.map_or(("", ""), |t| (t.target.as_str(), yes_no(t.met)));
            writeln!(f, "| {name} | {value} | {t} | {m} |")?;
        }
        writeln!(f)?;
        writeln!(
            f,
            "The 20 ms target is compared with tick → command delivered: the coordinator sends \
             commands on its own {} Hz clock, not in answer to poses, so pose → next command \
             includes the wait for the next tick (up to {:.0} ms) by design.",
            self.tick_hz,
            1e3 / (self.tick_hz * self.time_warp)
        )?;
        for note in &self.notes {
            writeln!(f, "Note: {note}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let l = Latency::of((1..=100).rev().map(|i| i as f64 / 1e3).collect());
        assert_eq!(l.samples, 100);
        assert_eq!(l.p50, Some(50.0));
        assert_eq!(l.p99, Some(99.0));
        assert_eq!(l.max, Some(100.0));
        let one = Latency::of(vec![0.002]);
        assert_eq!((one.p50, one.p99), (Some(2.0), Some(2.0)));
        assert!(Latency::of(Vec::new()).p99.is_none());
    }
}
