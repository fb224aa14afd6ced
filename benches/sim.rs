//! Wall time of the paper scenario's closed loop: 200 s simulated at 1 kHz
//! dynamics with 10 Hz coverage ticks, 8 vessels, plus Lloyd's baseline
//! (target ≤ 2 s, i.e. ≥ 100× faster than real time). No files are written.
//!
//! And one tick of the safety layer (goals, routes, barrier filter, tracking)
//! for 1000 vessels: what the coordinator's tick adds to the evaluation.

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

fn safety_tick(c: &mut Criterion) {
    use seacover::control::Vec3;
    use seacover::control::guidance::{Guidance, GuidanceGains};
    use seacover::control::model::State;
    use seacover::control::safety::{SafetyLayer, SafetyParams};
    use seacover::coverage::Options;
    let path = format!("{}/examples/fleet-1000.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(path).expect("scenario file");
    let doc = seacover::mission::scenario::parse_document(&text).expect("parses");
    let scenario = seacover::mission::scenario::Scenario::from_document(&doc).expect("valid");
    let eval = scenario.evaluate(&Options::default());
    let states: Vec<State> = scenario
        .fleet
        .vessels()
        .iter()
        .map(|v| State {
            x: v.position.x,
            y: v.position.y,
            psi: 0.3,
            vel: Vec3::new(0.5, 0.1, 0.0),
        })
        .collect();
    let layer = SafetyLayer::new(&scenario.region, SafetyParams::default()).expect("valid");
    let mut guidance: Vec<Guidance> = states
        .iter()
        .map(|_| Guidance::new(GuidanceGains::default()))
        .collect();
    let mut group = c.benchmark_group("safety");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(5));
    let mut t = 0.0;
    group.bench_function("fleet-1000-tick", |b| {
        b.iter(|| {
            t += 0.1;
            black_box(layer.commands(t, &states, &eval.cells, &mut guidance))
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
    targets = paper_200s, safety_tick
}
criterion_main!(benches);
