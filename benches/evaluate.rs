//! Median time of one full evaluation (partition + integrals + H) per scenario,
//! single-threaded (`evaluate/…`), and on every core as `seacover evaluate`
//! runs it (`evaluate-parallel/…`, `Options::parallel`), on the scenario
//! documents kept in `examples/`.
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

/// One group of full evaluations with `options`, a scenario per name.
fn group_of(c: &mut Criterion, group: &str, names: &[&str], options: &Options) {
    let mut group = c.benchmark_group(group);
    for &name in names {
        let scenario = load(name);
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
            b.iter(|| black_box(scenario.evaluate(black_box(options))))
        });
    }
    group.finish();
}

fn evaluate(c: &mut Criterion) {
    // The mixed-β fleets (curved cells) beside their equal-β twins: the
    // same vessels, half of them at β = 0.004 (target: ≤ 3× the time, docs/performance.md).
    let names = [
        "paper",
        "paper-mixed",
        "fleet-100",
        "fleet-1000",
        "fleet-1000-mixed",
        "fleet-10000",
        // Learned beliefs (docs/learning.md): 400 Gaussians on the paper's
        // square, 5041 on fleet-1000's.
        "paper-belief",
        "fleet-1000-belief",
    ];
    group_of(c, "evaluate", &names, &Options::default());
}

/// The same evaluations spread over every core (rayon's pool), as the
/// `evaluate` command does them; the result is the same bit for bit.
fn evaluate_parallel(c: &mut Criterion) {
    let options = Options {
        parallel: true,
        ..Options::default()
    };
    let names = ["fleet-1000", "fleet-1000-mixed", "fleet-10000"];
    group_of(c, "evaluate-parallel", &names, &options);
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
    targets = evaluate, evaluate_parallel, partition
}
criterion_main!(benches);
