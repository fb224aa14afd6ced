//! Prometheus metrics (`GET /metrics`): connected and live vessels, tick
//! duration histogram, skipped ticks, H, messages in and out, rejected
//! messages by reason.
//!
//! The recorder is process-global (the `metrics` facade allows one), so
//! several servers in one process — as in the tests — share it.

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

static HANDLE: OnceLock<PrometheusHandle> = OnceLock::new();

/// The process's Prometheus handle, installing the recorder on first use.
pub fn handle() -> &'static PrometheusHandle {
    HANDLE.get_or_init(|| {
        let builder = PrometheusBuilder::new()
            .set_buckets_for_metric(
                Matcher::Full(TICK_SECONDS.to_string()),
                &[
                    1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0,
                ],
            )
            .expect("non-empty buckets");
        let recorder = builder.build_recorder();
        let handle = recorder.handle();
        // If another recorder was installed first, ours stays empty but valid.
        let _ = metrics::set_global_recorder(recorder);
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
        h.render(),
    )
}
