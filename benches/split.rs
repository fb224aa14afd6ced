//! The split plan's computation ([`plan`], docs/peer.md "What each loss
//! does"), for a fleet cut 4 | 4 and 25 | 25: how long the vessel that
//! detects a partition computes before it can follow the plan, against its
//! control tick (0.1 s of mission time).
//!
//! The fleet: the paper's density, 8 vessels on its 100 m square (one per
//! 1250 m²): the paper mission itself for 8, and for 50 a 250 m square with
//! the paper's density of risk objects (3 per 8 vessels, α in [6, 14],
//! σ = 10 m, φ0 = 0.1), seeded. The vessels start from a jittered grid
//! (seeded) and are carried to the whole fleet's optimum by Lloyd's
//! iteration before the cut, as a fleet that has been covering is when the
//! link breaks; the groups are every other vessel of a seeded shuffle, so
//! they are mixed over the region as two sides of a radio partition are.
//! The plan's parameters are those a vessel uses ([`split::params`]).
//!
//! `cargo bench --bench split`; numbers in docs/performance.md ("The split
//! plan").

mod common;

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use seacover::agent::peer::split;
use seacover::agent::peer::table::Ageing;
use seacover::coverage::split::plan;
use seacover::coverage::{Fleet, Options, Vessel, evaluate};
use seacover::geometry::{Point, norm2};
use seacover::mission::Mission;

/// Both groups' sizes.
const CUTS: [(usize, usize); 2] = [(4, 4), (25, 25)];

/// The paper mission for 8 vessels; for more, a square of its density.
fn mission(n: usize, rng: &mut rand_chacha::ChaCha8Rng) -> Mission {
    if n == 8 {
        return Mission::paper();
    }
    common::dense_mission(n, rng)
}

/// `n` vessels on a jittered grid over the mission's square, then at the
/// whole fleet's optimum (Lloyd's iteration to 1 mm).
fn at_optimum(m: &Mission, n: usize, rng: &mut rand_chacha::ChaCha8Rng) -> Vec<Vessel> {
    let side = common::side(n);
    let cols = (n as f64).sqrt().ceil() as usize;
    let rows = n.div_ceil(cols);
    let (w, h) = (side / cols as f64, side / rows as f64);
    let a = m.actuator();
    let mut vessels: Vec<Vessel> = (0..n)
        .map(|i| {
            let (c, r) = (i % cols, i / cols);
            Vessel {
                position: Point {
                    x: (c as f64 + 0.5 + rng.random_range(-0.25..0.25)) * w,
                    y: (r as f64 + 0.5 + rng.random_range(-0.25..0.25)) * h,
                },
                k: a.k,
                beta: a.beta,
            }
        })
        .collect();
    for _ in 0..2000 {
        let fleet = Fleet::new(vessels.clone()).expect("a valid fleet");
        let e = evaluate(m.region(), m.risk(), &fleet, &Options::default());
        let mut moved: f64 = 0.0;
        for (v, c) in vessels.iter_mut().zip(&e.cells) {
            moved = moved.max(norm2(c.centroid - v.position).sqrt());
            v.position = c.centroid;
        }
        if moved <= 1e-3 {
            break;
        }
    }
    vessels
}

fn split_plan(c: &mut Criterion) {
    let mut group = c.benchmark_group("split-plan");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    for (a, b) in CUTS {
        let n = a + b;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let m = mission(n, &mut rng);
        let mut fleet = at_optimum(&m, n, &mut rng);
        // Every other vessel of a seeded shuffle: two mixed groups.
        for i in (1..n).rev() {
            fleet.swap(i, rng.random_range(0..=i));
        }
        let groups: [Vec<Vessel>; 2] =
            [0, 1].map(|g| fleet.iter().skip(g).step_by(2).copied().collect());
        assert_eq!([groups[0].len(), groups[1].len()], [a, b]);
        let params = split::params(&m, &Ageing::default());
        let once =
            || plan(m.region(), m.risk(), [&groups[0], &groups[1]], &params).expect("two groups");
        let p = once();
        eprintln!(
            "split-plan/{a}|{b}: {:.1} m square; water {:?}, clear {}, closest {:.2} m, \
             duration {:.0} s",
            common::side(n),
            p.water,
            p.clear,
            p.closest(),
            p.duration,
        );
        group.bench_function(BenchmarkId::from_parameter(format!("{a}|{b}")), |bench| {
            bench.iter(|| black_box(once()))
        });
    }
    group.finish();
}

// No plots: as in benches/peer.rs (criterion's charts need a system font).
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = split_plan
}
criterion_main!(benches);
