//! Wall time of the paper scenario's closed loop: 200 s simulated at 1 kHz
//! dynamics with 10 Hz coverage ticks, 8 vessels, plus Lloyd's baseline
//! (target ≤ 2 s, i.e. ≥ 100× faster than real time). No files are written.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use seacover::sim::{Config, load_scenario, run};

fn paper_200s(c: &mut Criterion) {
    let (scenario, headings) = load_scenario("paper").expect("built-in scenario");
    let config = Config::new(scenario, headings, 200.0);
    let mut group = c.benchmark_group("sim");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10));
    group.bench_function("paper-200s", |b| {
        b.iter(|| black_box(run(&config, |_| {}).expect("runs")))
    });
    group.finish();
}

criterion_group!(benches, paper_200s);
criterion_main!(benches);
