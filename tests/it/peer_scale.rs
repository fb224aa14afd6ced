//! A hundred vessels without a coordinator (docs/peer.md, "A hundred
//! vessels"): fleets of 8, 30 and 100 simulated peers at one density (100
//! per km²: squares of 283, 548 and 1000 m), each vessel a process in a
//! network namespace of its own, on a radio medium that drops every packet
//! between two vessels farther apart than R = 300 m (test e's range model,
//! in force before the vessels start: a fleet switched on where it was
//! deployed, one boat every 0.2 s).
//!
//! Each fleet runs [`RUN`] s of mission time from near an optimum (see
//! [`write_mission`]); then, with the observer gone (its queries and its
//! copy of every beacon would count), each vessel's CPU time, memory
//! (VmRSS) and the bytes on its link are read over a window; a new observer
//! then asks every vessel its status: the neighbours in its partition and
//! its steps' wall time (`step_time`). Time warp 0.5 ([`WARP`]); CPU and
//! bytes are given per second of mission time, what a vessel uses in real
//! time. Checked: E_max < 1 m and H within 1 % of the centralized loop's
//! (`seacover sim` from the same starts over the same time; R = 300 m
//! exceeds 2r = 235 m, where the range-limited cells are the centralized
//! ones); no pair closer than the safety distance; no vessel sends or
//! receives more than the 1 kB/s budget per neighbour within range (one
//! that sent to the whole fleet would, at 100 vessels, send to four times
//! as many); no vessel hears more vessels than are within range; and the
//! nodes with 20–30 vessels within range use, at 100 vessels, no more than
//! a quarter more CPU, memory and bytes than those at 30 (a node's cost
//! follows its neighbourhood, not the fleet). CPU time is the one the
//! machine's state moves (the same 30 took 2.3 to 3.6 % a node on
//! different days), so it is compared relative to a fleet of 8 run beside
//! each, on a medium of its own: a yardstick under the same load.
//! The fleet of 30 and its 8 run with a quarter of the machine (25 %,
//! measured), beside at most a peer fleet of eight at a time warp of 10
//! ([`machine`]); the 100 and its 8 (a twentieth of a core at the warp)
//! under the whole machine: the hundred keep both cores busy (97 %,
//! measured), so what is compared between 30 and 100 vessels is not made
//! lighter at 100.
//! `SEACOVER_SCALE=N` runs the fleet of N alone.

use std::path::Path;
use std::thread::sleep;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::common::fleet::{Fleet, Setup, check_safety, check_wire, skip};
use crate::common::machine;
use crate::common::paper::{
    BIN, Checks, Pos, coverage_in, evaluate_in, max_of, scenario, starts_in,
};
use crate::common::peer::now;
use crate::common::range::Range;
use crate::common::secure::{cpu_seconds, rss};

/// The radio's range [m].
const RANGE: f64 = 300.0;
/// Vessels per km².
const DENSITY: f64 = 100.0;
/// Mission seconds per wall second: a vessel process takes about 3 % of a
/// core in real time here (with 20–40 neighbours), and a hundred of them,
/// the observer and the medium more than this machine's two cores.
const WARP: f64 = 0.5;
/// The neighbourhoods (vessels within R) whose nodes are compared at 30
/// and 100 vessels.
const BAND: std::ops::RangeInclusive<usize> = 20..=30;
/// Wall time between two vessels' starts [s].
const LAUNCH_EVERY: f64 = 0.2;
/// Mission time the fleets run before they are judged [s].
const RUN: f64 = 60.0;
/// The measuring window, without the observer [s of wall time].
const WINDOW: f64 = 20.0;
/// Lloyd's iterations that take the grid near an optimum.
const START_ITERATIONS: usize = 300;
/// How far from there each vessel starts [m].
const OFFSET: f64 = 15.0;

/// What one fleet measured.
struct Row {
    n: usize,
    side: f64,
    /// Per vessel: CPU [% of a core], memory [MB], received and sent
    /// [B/s], neighbours within R, steps' median and longest wall time
    /// [ms].
    cpu: Vec<f64>,
    rss: Vec<f64>,
    rx: Vec<f64>,
    tx: Vec<f64>,
    in_range: Vec<usize>,
    step_median: Vec<f64>,
    step_max: Vec<f64>,
    partition: Vec<usize>,
    h_ratio: f64,
    e_max: f64,
    closest: f64,
}

#[test]
fn a_hundred_vessels_converge_and_a_node_costs_what_its_neighbourhood_does() {
    let test = "peer_scale";
    let Some(python) = skip(test) else { return };
    let mut checks = Checks::new(test);
    let wall = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let rows = match std::env::var("SEACOVER_SCALE") {
        Ok(n) => {
            let n = n.parse().expect("SEACOVER_SCALE: a number of vessels");
            let _machine = hold(n);
            vec![fleet_of(n, dir.path(), &python, &mut checks)]
        }
        Err(_) => {
            let (beside30, thirty) = side_by_side(30, dir.path(), &python, &mut checks);
            let (eight, hundred) = side_by_side(100, dir.path(), &python, &mut checks);
            vec![eight, thirty, hundred, beside30]
        }
    };
    let median = |v: &[f64]| -> f64 {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        if v.is_empty() {
            f64::NAN
        } else {
            v[v.len() / 2]
        }
    };
    let most = |v: &[f64]| v.iter().copied().fold(f64::NAN, f64::max);
    let usize_f = |v: &[usize]| v.iter().map(|&x| x as f64).collect::<Vec<_>>();
    let table: Vec<String> = rows
        .iter()
        .map(|r| {
            format!(
                "{:>3} vessels on {:.0} m: neighbours within R {:.0} (most {:.0}), partition {:.0} | \
                 CPU {:.2} % (most {:.2}) | memory {:.1} MB (most {:.1}) | rx {:.0} B/s (most \
                 {:.0}), tx {:.0} B/s (most {:.0}) | step {:.2} ms (longest {:.1}) | H/H_opt \
                 {:.5}, E_max {:.3} m, closest {:.1} m",
                r.n,
                r.side,
                median(&usize_f(&r.in_range)),
                most(&usize_f(&r.in_range)),
                median(&usize_f(&r.partition)),
                median(&r.cpu),
                most(&r.cpu),
                median(&r.rss),
                most(&r.rss),
                median(&r.rx),
                most(&r.rx),
                median(&r.tx),
                most(&r.tx),
                median(&r.step_median),
                most(&r.step_max),
                r.h_ratio,
                r.e_max,
                r.closest,
            )
        })
        .collect();
    eprintln!(
        "SUMMARY {test}: R = {RANGE} m, {DENSITY} vessels per km², time warp {WARP}, medians \
         per node (and the most of any), CPU and bytes per second of mission time; the eight \
         beside the hundred, the 30, the hundred, the eight beside the 30:\n  {}\n  \
         {:.0} s wall",
        table.join("\n  "),
        wall.elapsed().as_secs_f64()
    );
    let [eight, at30, at100, beside30] = &rows[..] else {
        return checks.finish();
    };
    // Nodes with the same neighbourhood in both fleets: what the fleet's
    // size alone adds to a node's cost.
    let band = |row: &Row, of: &[f64]| -> Vec<f64> {
        (0..row.n)
            .filter(|&i| BAND.contains(&row.in_range[i]))
            .map(|i| of[i])
            .collect()
    };
    // CPU time is the one figure the machine's state moves: the same fleet
    // of 30 took 2.3 to 3.6 % a node on different days, and in one CI run
    // these nodes took 2.57 % at 30 and 3.24 at 100 (1.26 times) while the
    // eight beside the hundred took 1.23 % (1.08 in a run here the same
    // day): the machine, not the fleet, was slower then. So each fleet's
    // CPU is taken relative to the fleet of eight run beside it at the
    // same time on a medium of its own (7 neighbours each, the same in
    // both): what the fleet's size adds, not the machine's state.
    let relative = |row: &Row, yardstick: &Row| -> Vec<f64> {
        let y = median(&yardstick.cpu);
        band(row, &row.cpu).iter().map(|c| c / y).collect()
    };
    for (what, a, b) in [
        (
            "CPU (relative to the eight beside)",
            relative(at30, beside30),
            relative(at100, eight),
        ),
        ("memory", band(at30, &at30.rss), band(at100, &at100.rss)),
        ("sent bytes", band(at30, &at30.tx), band(at100, &at100.tx)),
        (
            "received bytes",
            band(at30, &at30.rx),
            band(at100, &at100.rx),
        ),
    ] {
        let (ma, mb) = (median(&a), median(&b));
        checks.check(
            a.len() >= 5 && b.len() >= 5 && mb <= 1.25 * ma,
            format!(
                "nodes with {BAND:?} neighbours within R: the median {what} at 100 vessels \
                 ({mb:.2}, {} nodes) within a quarter of that at 30 ({ma:.2}, {} nodes)",
                b.len(),
                a.len()
            ),
        );
    }
    checks.finish();
}

/// The machine's hold for a fleet of `n` (and the 8 beside it): a
/// quarter up to 30 (what 30 measured to need), else the whole (the
/// hundred keep both cores busy).
fn hold(n: usize) -> machine::Heavy {
    if n > 30 {
        machine::heavy()
    } else {
        machine::part(machine::Part::Quarter)
    }
}

/// The fleet of `n` and one of 8 beside it, on a medium of its own, under
/// one hold of the machine.
fn side_by_side(n: usize, dir: &Path, python: &Path, checks: &mut Checks) -> (Row, Row) {
    let _machine = hold(n);
    let test = checks.test.clone();
    std::thread::scope(|s| {
        let eight = s.spawn(move || {
            let mut own = Checks::new(&test);
            let row = fleet_of(8, dir, python, &mut own);
            (row, own.failed)
        });
        let big = fleet_of(n, dir, python, checks);
        let (eight, failed) = eight
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        checks.failed.extend(failed);
        (eight, big)
    })
}

/// Runs a fleet of `n` and judges it, under the machine's hold that the
/// caller took ([`hold`]).
fn fleet_of(n: usize, dir: &Path, python: &Path, checks: &mut Checks) -> Row {
    let (path, side) = write_mission(n, dir);
    let base = scenario(path);
    let mut setup = Setup::new(&format!("s{n}"), WARP);
    setup.mission = path;
    setup.part = None;
    // Boats switched on one after another, not a hundred processes
    // starting Zenoh in the same second on two cores.
    setup.launch_every = LAUNCH_EVERY;
    let mut fleet = Fleet::new(setup, python);
    let mut range = Range::start(
        &fleet,
        &starts_in(&base),
        RANGE,
        Duration::from_secs_f64(0.5),
    );
    fleet.launch();
    let heard_in = fleet.wait_heard_all();
    let safety = fleet.safety_distance();
    fleet.run_until(RUN, |f| range.follow(f));
    let updates = range.updates;
    let positions = fleet.positions();
    let (h, e) = coverage_in(&base, &positions);
    let closest = check_safety(checks, &fleet, safety);
    check_wire(checks, &fleet);
    // The window: the observer gone, the medium as the fleet left it (the
    // vessels hold their cells).
    let observer = fleet.observers.pop().unwrap();
    observer.stop();
    fleet.update();
    fleet.tails.clear();
    sleep(Duration::from_secs(2));
    let before = measure(&fleet);
    sleep(Duration::from_secs_f64(WINDOW));
    let after = measure(&fleet);
    let pids: Vec<u32> = fleet.vessels.iter().map(|v| v.child.0.id()).collect();
    let rss: Vec<f64> = pids
        .iter()
        .map(|&p| rss(p).map_or(f64::NAN, |b| b as f64 / (1024.0 * 1024.0)))
        .collect();
    // Per second of mission time: what a vessel in real time would use.
    let rate = |k: usize| -> Vec<f64> {
        before
            .iter()
            .zip(&after)
            .map(|(b, a)| (a[k] - b[k]) / ((a[0] - b[0]) * WARP))
            .collect()
    };
    let (cpu, rx, tx) = (
        rate(1).iter().map(|c| 100.0 * c).collect::<Vec<_>>(),
        rate(2),
        rate(3),
    );
    // A new observer asks for every status.
    fleet.observer_args = vec!["--query-status-every".into(), "1".into()];
    fleet.start_observer(0, python);
    let since = now();
    let deadline = Instant::now() + Duration::from_secs(30);
    while fleet.newest_statuses(since).len() < n && Instant::now() < deadline {
        sleep(Duration::from_millis(200));
        fleet.update();
    }
    let statuses = fleet.newest_statuses(since);
    checks.check(
        statuses.len() == n,
        format!(
            "{n} vessels: all answer a status query ({} did)",
            statuses.len()
        ),
    );
    fleet.shutdown(checks);
    let status = |id: &str| statuses.get(id).map_or(&Value::Null, |s| &s["status"]);
    let ids = fleet.ids();
    let partition: Vec<usize> = ids
        .iter()
        .map(|id| status(id)["neighbours"].as_u64().unwrap_or(0) as usize)
        .collect();
    let step = |k: &str| -> Vec<f64> {
        ids.iter()
            .map(|id| status(id)["step_time"][k].as_f64().unwrap_or(f64::NAN))
            .collect()
    };
    let (step_median, step_max) = (step("median_ms"), step("max_ms"));
    let in_range: Vec<usize> = positions
        .iter()
        .map(|p| {
            positions
                .iter()
                .filter(|q| q.id != p.id && (p.x - q.x).hypot(p.y - q.y) <= RANGE)
                .count()
        })
        .collect();
    let h_opt = centralized(path);
    let e_max = max_of(&e);
    let tag = format!("{n} vessels");
    eprintln!(
        "{tag}: heard in {heard_in:.1} s, range model updated {updates} times; H {h:.1} / the \
         centralized {h_opt:.1} = {:.5}, E_max {e_max:.3} m ({e:.2?}); CPU \
         {cpu:.2?} %; memory {rss:.1?} MB; rx {rx:.0?} B/s; tx {tx:.0?} B/s; within R \
         {in_range:?}; partitions {partition:?}; step medians {step_median:.2?} ms, longest \
         {step_max:.1?} ms",
        h / h_opt
    );
    checks.check(e_max < 1.0, format!("{tag}: E_max {e_max:.3} m < 1 m"));
    checks.check(
        (h / h_opt - 1.0).abs() <= 0.01,
        format!("{tag}: H {h:.1} within 1 % of the centralized {h_opt:.1}"),
    );
    for (i, id) in ids.iter().enumerate() {
        let budget = 1000.0 * in_range[i].max(1) as f64;
        if rx[i] > budget || tx[i] > budget {
            checks.check(
                false,
                format!(
                    "{tag}: {id} rx {:.0} B/s and tx {:.0} B/s ≤ 1 kB/s per neighbour within R \
                     ({})",
                    rx[i], tx[i], in_range[i]
                ),
            );
        }
        if partition[i] > in_range[i] {
            checks.check(
                false,
                format!(
                    "{tag}: {id} hears {} vessels, more than the {} within R",
                    partition[i], in_range[i]
                ),
            );
        }
        if !step_max[i].is_finite() {
            checks.check(false, format!("{tag}: {id}'s status has no step_time"));
        }
    }
    Row {
        n,
        side,
        cpu,
        rss,
        rx,
        tx,
        in_range,
        step_median,
        step_max,
        partition,
        h_ratio: h / h_opt,
        e_max,
        closest,
    }
}

/// H at the end of `seacover sim` (the centralized loop, safety on) from
/// the same starts over the same mission time.
fn centralized(path: &str) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(BIN)
        .args(["sim", "--scenario", path, "--no-figures", "--duration"])
        .arg(RUN.to_string())
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "seacover sim --scenario {path}: {out:?}"
    );
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap())
            .unwrap();
    summary["H_end"].as_f64().expect("summary.json: H_end")
}

/// Per vessel: [UTC s, CPU s, received bytes, sent bytes].
fn measure(fleet: &Fleet) -> Vec<[f64; 4]> {
    fleet
        .vessels
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let (rx, tx) = fleet.medium.bytes(i + 1);
            [now(), cpu_seconds(v.child.0.id()), rx as f64, tx as f64]
        })
        .collect()
}

/// The mission for `n` vessels at [`DENSITY`]: a square, the paper's
/// actuator and risk base, its density of risk objects (3 per 8 vessels),
/// each a gentle rise (peak 1.5–3.5, σ 60 m) over the vessels' 100 m
/// spacing; the vessels where [`START_ITERATIONS`] of Lloyd's iteration
/// take a jittered grid, each then moved [`OFFSET`] in a random direction.
/// Near an optimum, so that a fleet converges within a minute, and away
/// from it by far more than the 1 m it must come within: from the grid
/// itself, or with the paper's steep objects (peaks 6–14, σ 10 m at its
/// spacing), `seacover sim` took minutes, its fleet still rearranging
/// after 100 s. All drawn from a fixed seed. Written to `dir`; its path
/// (for the lifetime of the test process) and the square's side.
fn write_mission(n: usize, dir: &Path) -> (&'static str, f64) {
    let side = (n as f64 / DENSITY).sqrt() * 1000.0;
    let mut rng = SplitMix(0x5eac_0e44 ^ n as u64);
    let objects: Vec<Value> = (0..(3 * n).div_ceil(8))
        .map(|_| {
            json!({
                "x": rng.uniform(0.1, 0.9) * side,
                "y": rng.uniform(0.1, 0.9) * side,
                "alpha": rng.uniform(1.5, 3.5),
                "sigma": 60.0,
            })
        })
        .collect();
    let cols = (n as f64).sqrt().ceil() as usize;
    let rows = n.div_ceil(cols);
    let mut at = Vec::new();
    for r in 0..rows {
        let in_row = (n - r * cols).min(cols);
        let (dx, dy) = (side / in_row as f64, side / rows as f64);
        for c in 0..in_row {
            at.push(Pos {
                id: format!("usv-{}", at.len() + 1),
                x: (c as f64 + 0.5 + rng.uniform(-0.15, 0.15)) * dx,
                y: (r as f64 + 0.5 + rng.uniform(-0.15, 0.15)) * dy,
                psi: rng.uniform(-std::f64::consts::PI, std::f64::consts::PI),
            });
        }
    }
    let vessel =
        |p: &Pos| json!({"id": p.id, "x": p.x, "y": p.y, "psi": p.psi, "k": 0.5, "beta": 0.001});
    let mut doc = json!({
        "name": format!("scale-{n}"),
        "region": {"polygon": [[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]], "holes": []},
        "risk": {"base": 0.1, "objects": objects},
        "vessels": at.iter().map(vessel).collect::<Vec<_>>(),
    });
    for _ in 0..START_ITERATIONS {
        let eval = evaluate_in(&doc, &at);
        for p in &mut at {
            (p.x, p.y) = eval.centroids[&p.id];
        }
    }
    // Each moved in a direction that keeps it 20 m (2.5 safety distances)
    // from those already moved and those still to be.
    for i in 0..at.len() {
        let (x, y) = (at[i].x, at[i].y);
        let clear = |at: &[Pos], (nx, ny): (f64, f64)| {
            at.iter()
                .enumerate()
                .all(|(j, q)| j == i || (q.x - nx).hypot(q.y - ny) >= 20.0)
        };
        let moved = (0..100)
            .map(|_| rng.uniform(-std::f64::consts::PI, std::f64::consts::PI))
            .map(|a| (x + OFFSET * a.cos(), y + OFFSET * a.sin()))
            .find(|&p| clear(&at, p))
            .unwrap_or((x, y));
        (at[i].x, at[i].y) = moved;
    }
    doc["vessels"] = at.iter().map(vessel).collect();
    let dir = std::env::var_os("SEACOVER_PEER_KEEP").map_or(dir.to_path_buf(), Into::into);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("scale-{n}.json"));
    std::fs::write(&path, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    let path: &'static str = Box::leak(path.to_string_lossy().into_owned().into_boxed_str());
    (path, side)
}

/// A fixed sequence of numbers (SplitMix64), so that every run draws the
/// same missions.
struct SplitMix(u64);

impl SplitMix {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        lo + (hi - lo) * (z >> 11) as f64 / (1u64 << 53) as f64
    }
}
