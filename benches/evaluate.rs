//! Median time of one full evaluation (partition + integrals + H) per scenario,
//! single-threaded, on the scenario documents kept in `examples/`.
//!
//! `cargo bench --bench evaluate`; `scripts/bench-baseline` runs this and the
//! NumPy baseline in one go and prints the table of docs/performance.md.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use seacover::coverage::Options;
use seacover::mission::scenario::{Scenario, parse_document};

fn load(name: &str) -> Scenario {
    let path = format!("{}/examples/{name}.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect("scenario file");
    Scenario::from_document(&parse_document(&text).expect("parses")).expect("valid")
}

fn evaluate(c: &mut Criterion) {
    let mut group = c.benchmark_group("evaluate");
    for name in ["paper", "fleet-100", "fleet-1000", "fleet-10000"] {
        let scenario = load(name);
        let options = Options::default();
        if name == "fleet-10000" {
            group
                .sample_size(10)
                .measurement_time(Duration::from_secs(8));
        } else {
            group
                .sample_size(30)
                .measurement_time(Duration::from_secs(4));
        }
        group.bench_function(name, |b| {
            b.iter(|| black_box(scenario.evaluate(black_box(&options))))
        });
    }
    group.finish();
}

/// The partition alone (power cells clipped to the region), the part of an
/// evaluation that is not per-cell integration.
fn partition(c: &mut Criterion) {
    let mut group = c.benchmark_group("partition");
    let scenario = load("fleet-1000");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(4));
    group.bench_function("fleet-1000", |b| {
        b.iter(|| {
            black_box(seacover::coverage::partition::power_cells(
                black_box(&scenario.region),
                black_box(&scenario.fleet),
            ))
        })
    });
    group.finish();
}

// No plots: criterion's comparison charts need a system sans-serif font
// that a slim machine may lack (it panics after measuring), and the numbers
// are what the docs quote.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = evaluate, partition
}
criterion_main!(benches);
