//! One vessel's tick in a peer fleet (`seacover agent --peer`), among 100,
//! 1000 and 10 000 vessels at the paper's density: does a node's cost grow
//! with the fleet?
//!
//! The fleet: the paper's density, 8 vessels on its 100 m square (one per
//! 1250 m²), and its density of risk objects (3 per 8 vessels, α in
//! [6, 14], σ = 10 m, φ0 = 0.1), on a square region scaled so that N
//! vessels have that density (353.6 m for 100, 1118 m for 1000, 3536 m for
//! 10 000; `examples/fleet-*.json` are at 1 per 1000 m², a quarter denser,
//! so they are not used). Positions and headings seeded, every vessel at
//! 0.5 m/s. The node is the vessel nearest the region's centre; it has
//! heard every other vessel's beacon 0.1 s ago (all fresh).
//!
//! Per N, the node's tick and its parts:
//! - `tick`: [`Table::neighbours_near`] among the N − 1 beacons heard (it
//!   looks only at those filed near the node, and copies out those that
//!   can matter), then [`step`] with them: what the node does every
//!   control tick;
//! - `table`: [`Table::neighbours_near`] alone;
//! - `step`: [`step`] alone, with the N − 1 neighbours;
//! - `step-in-reach`: [`step`] with only the neighbours within r_i + r_j
//!   (the only ones that can change its cell or its safety filter: the
//!   command is checked to be the same bit for bit), i.e. what the step
//!   would cost if the node never looked at the others;
//! - `cell`: the range-limited cell alone ([`local_cell`]), from the N − 1
//!   neighbours;
//! - `cell-bounding`: the same cell (checked) from only the neighbours
//!   within twice its farthest vertex, the ones that can bound it: what the
//!   cell would cost if [`local_cell`] partitioned no more than the node's
//!   own cell needs (it partitions every vessel within r_i + r_j and keeps
//!   one cell).
//!
//! `cargo bench --bench peer`; numbers in docs/performance.md ("One
//! vessel's tick in a peer fleet").

mod common;

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use seacover::agent::peer::step::{relevance, step};
use seacover::agent::peer::table::{Ageing, Neighbour, Table};
use seacover::agent::peer::wire;
use seacover::control::Vec3;
use seacover::control::barrier::Scratch;
use seacover::control::guidance::Guidance;
use seacover::control::model::State;
use seacover::coverage::range::{local_cell, relevant};
use seacover::coverage::{CellGeometry, Options, Vessel};
use seacover::geometry::{Point, norm2};
use seacover::mission::Mission;

const FLEET: &str = "bench";
/// The fleet sizes: the 100 and 1000, and 10 000 to see the trend.
const SIZES: [usize; 3] = [100, 1000, 10_000];

struct Node {
    mission: Mission,
    me: String,
    own: State,
    actuator: (f64, f64),
    table: Table,
    /// When the node looks at its table (0.1 s after every beacon came).
    now: Instant,
    ageing: Ageing,
    /// The table's answer at `now`: every other vessel.
    neighbours: Vec<Neighbour>,
    /// Those within r_i + r_j of the node.
    in_reach: Vec<Neighbour>,
}

fn id(i: usize) -> String {
    // At most 5 characters: a beacon within wire::MAX_BEACON.
    format!("v{i:04}")
}

fn vessel_of(x: f64, y: f64, (k, beta): (f64, f64)) -> Vessel {
    Vessel {
        position: Point { x, y },
        k,
        beta,
    }
}

fn node(n: usize, seed: u64) -> Node {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let side = common::side(n);
    let mission = common::dense_mission(n, &mut rng);
    let actuator = wire::wire_actuator(mission.actuator().k, mission.actuator().beta);
    let states: Vec<State> = (0..n)
        .map(|_| {
            let psi: f64 = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
            State {
                x: rng.random_range(0.0..side),
                y: rng.random_range(0.0..side),
                psi,
                vel: Vec3::new(0.5, 0.0, 0.0),
            }
        })
        .collect();
    let centre = side / 2.0;
    let mine = (0..n)
        .min_by(|&a, &b| {
            let d = |s: &State| (s.x - centre).hypot(s.y - centre);
            d(&states[a]).total_cmp(&d(&states[b]))
        })
        .expect("a fleet");
    let me = id(mine);
    let ageing = Ageing::default();
    let mut table = Table::new(FLEET, [me.clone()]);
    let keys = wire::Keys {
        fleet: FLEET.into(),
    };
    let t0 = Instant::now();
    let utc = 1.8e9;
    for (i, s) in states.iter().enumerate() {
        let beacon = wire::beacon_of(
            s,
            wire::Said {
                id: &id(i),
                seq: 1,
                t: utc,
                actuator,
                rev: 0,
                controlled: true,
            },
        );
        let bytes = wire::encode(&beacon);
        table.offer(
            &keys.beacon(&beacon.id),
            &bytes,
            i == mine,
            t0,
            utc,
            &ageing,
        );
    }
    assert!(table.refused().is_empty(), "{:?}", table.refused());
    let now = t0 + Duration::from_millis(100);
    let neighbours = table.neighbours(&me, now, &ageing);
    assert_eq!(neighbours.len(), n - 1);
    assert!(neighbours.iter().all(|nb| nb.silent.is_none()));
    let own = states[mine];
    let me_vessel = vessel_of(own.x, own.y, actuator);
    let in_reach: Vec<Neighbour> = neighbours
        .iter()
        .filter(|nb| relevant(&me_vessel, &vessel_of(nb.beacon.x, nb.beacon.y, actuator)))
        .cloned()
        .collect();
    Node {
        mission,
        me,
        own,
        actuator,
        table,
        now,
        ageing,
        neighbours,
        in_reach,
    }
}

fn peer(c: &mut Criterion) {
    let mut group = c.benchmark_group("peer");
    group
        .sample_size(50)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(4));
    for n in SIZES {
        let mut node = node(n, 1);
        let m = &node.mission;
        let options = Options::default();

        // The neighbours beyond reach change nothing: the same command,
        // bit for bit, and the same cell.
        let once = |neighbours: &[Neighbour]| {
            let mut g = Guidance::new(m.guidance());
            step(
                m,
                m.risk(),
                &node.own,
                node.actuator,
                neighbours,
                None,
                &mut g,
                1.0,
                1,
                &mut Scratch::default(),
            )
        };
        let (all, near) = (once(&node.neighbours), once(&node.in_reach));
        assert_eq!(all.command, near.command);
        // And those the table hands out on board (what `tick` uses).
        let on_board = node.table.neighbours_near(
            &node.me,
            (node.own.x, node.own.y),
            relevance(m, node.actuator),
            node.now,
            &node.ageing,
        );
        assert_eq!(once(&on_board).command, all.command);
        assert_eq!(all.partition, node.neighbours.len());
        eprintln!(
            "peer/{n}: {:.1} m square, {} risk objects; the node hears {} vessels, \
             {} of them within r_i + r_j",
            common::side(n),
            m.risk().objects().len(),
            node.neighbours.len(),
            node.in_reach.len(),
        );

        let mut guidance = Guidance::new(m.guidance());
        let mut scratch = Scratch::default();
        let mut t = 0.0;
        let mut tick = 0u64;
        group.bench_function(BenchmarkId::new("tick", n), |b| {
            b.iter(|| {
                t += 0.1;
                tick += 1;
                let neighbours = node.table.neighbours_near(
                    &node.me,
                    (node.own.x, node.own.y),
                    relevance(&node.mission, node.actuator),
                    node.now,
                    &node.ageing,
                );
                black_box(step(
                    &node.mission,
                    node.mission.risk(),
                    &node.own,
                    node.actuator,
                    &neighbours,
                    None,
                    &mut guidance,
                    t,
                    tick,
                    &mut scratch,
                ))
            })
        });
        group.bench_function(BenchmarkId::new("table", n), |b| {
            b.iter(|| {
                black_box(node.table.neighbours_near(
                    &node.me,
                    (node.own.x, node.own.y),
                    relevance(&node.mission, node.actuator),
                    node.now,
                    &node.ageing,
                ))
            })
        });
        for (name, neighbours) in [
            ("step", &node.neighbours),
            ("step-in-reach", &node.in_reach),
        ] {
            let mut guidance = Guidance::new(node.mission.guidance());
            let mut t = 0.0;
            group.bench_function(BenchmarkId::new(name, n), |b| {
                b.iter(|| {
                    t += 0.1;
                    black_box(step(
                        &node.mission,
                        node.mission.risk(),
                        &node.own,
                        node.actuator,
                        black_box(neighbours),
                        None,
                        &mut guidance,
                        t,
                        1,
                        &mut scratch,
                    ))
                })
            });
        }
        // The cell alone, from every vessel heard (as `step` computes it),
        // and from only those within twice its farthest vertex, the ones
        // that can bound it: the same cell, and what it would cost if the
        // engine partitioned no more than it needs.
        let me = vessel_of(node.own.x, node.own.y, node.actuator);
        let heard: Vec<Vessel> = node
            .neighbours
            .iter()
            .map(|nb| vessel_of(nb.beacon.x, nb.beacon.y, (nb.beacon.k, nb.beacon.beta)))
            .collect();
        let cell = |others: &[Vessel]| {
            local_cell(
                node.mission.region(),
                node.mission.risk(),
                me,
                others.iter().copied(),
                &options,
            )
            .expect("one β")
        };
        let full = cell(&heard);
        let far = match &full.geometry {
            CellGeometry::Convex(c) => c.max_distance2(me.position).sqrt(),
            CellGeometry::Clipped { hull, .. } => hull.max_distance2(me.position).sqrt(),
            CellGeometry::Empty | CellGeometry::Curved { .. } => {
                unreachable!("an interior vessel of one β has a power cell")
            }
        };
        let bounding: Vec<Vessel> = heard
            .iter()
            .filter(|o| norm2(o.position - me.position).sqrt() <= 2.0 * far + 1.0)
            .copied()
            .collect();
        let own_only = cell(&bounding);
        assert_eq!(own_only.mass, full.mass);
        assert_eq!(own_only.centroid, full.centroid);
        eprintln!(
            "peer/{n}: the node's cell reaches {far:.1} m; {} vessels within twice that",
            bounding.len()
        );
        for (name, others) in [("cell", &heard), ("cell-bounding", &bounding)] {
            group.bench_function(BenchmarkId::new(name, n), |b| {
                b.iter(|| black_box(cell(black_box(others))))
            });
        }
    }
    group.finish();
}

// No plots: criterion's comparison charts need a system sans-serif font
// that a slim machine may lack (it panics after measuring), and the numbers
// are what the docs quote.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = peer
}
criterion_main!(benches);
