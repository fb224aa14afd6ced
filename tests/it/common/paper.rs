//! The paper's scenario for the peer-fleet tests: the vessels' starts, the
//! coverage at given positions and Lloyd's optimum from them (by the real
//! `seacover evaluate`), the centralized run's H (`seacover sim`), and
//! checks collected so that one run reports every number.

use std::collections::BTreeMap;
use std::process::{Command, Stdio};
use std::sync::OnceLock;

use serde_json::{Value, json};

pub(crate) const BIN: &str = env!("CARGO_BIN_EXE_seacover");
/// The paper's scenario: the mission file, and the vessels' starts.
pub(crate) const PAPER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper.json");
/// The paper's scenario with every second vessel's actuator four times
/// as concentrated (β = 0.004: usv-2, -4, -6, -8).
pub(crate) const MIXED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper-mixed.json");
/// The paper's square and fleet with a flat risk, the paper's map as its
/// hidden `truth` (docs/learning.md).
pub(crate) const LEARNING: &str =
    concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper-learning.json");
/// Mission seconds per wall second for every test but g's. Each vessel
/// simulates its hull at 1 kHz of mission time: eight of them at 10 took
/// about 1.2 of a 2-core machine's cores in a debug build, about 0.7 in the
/// optimized test profile (measured with top), the observers a little.
pub(crate) const WARP: f64 = 10.0;
/// Beacons per second of mission time (the documented rate).
pub(crate) const BEACON_HZ: f64 = 5.0;
/// A neighbour silent longer than this leaves a vessel's partition [s of
/// mission time] (the documented default).
pub(crate) const STALE_AFTER: f64 = 3.0;
/// The vessels, usv-1 … usv-8, in hosts 1 … 8.
pub(crate) const N: usize = 8;
/// The documented largest beacon payload [bytes].
pub(crate) const MAX_BEACON: usize = 96;
/// `seq` counts a vessel's beacons modulo this (documented).
pub(crate) const SEQ_MODULUS: i64 = 256;
/// The documented keys of a beacon.
pub(crate) const BEACON_KEYS: [&str; 13] = [
    "id",
    "seq",
    "t",
    "x",
    "y",
    "psi",
    "u",
    "v",
    "r",
    "k",
    "beta",
    "rev",
    "controlled",
];

// ---------------------------------------------------------------------------
// The scenario, evaluation and the centralized reference.

pub(crate) fn paper() -> &'static Value {
    static PAPER_DOC: OnceLock<Value> = OnceLock::new();
    PAPER_DOC.get_or_init(|| {
        let text = std::fs::read_to_string(PAPER).unwrap_or_else(|e| panic!("{PAPER}: {e}"));
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{PAPER}: {e}"))
    })
}

/// A vessel's position (and heading) in the mission's plane.
#[derive(Debug, Clone)]
pub(crate) struct Pos {
    pub id: String,
    pub x: f64,
    pub y: f64,
    pub psi: f64,
}

pub(crate) fn num(v: &Value, what: &str) -> f64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("{what}: not a number: {v}"))
}

/// The scenario document in `path`.
pub(crate) fn scenario(path: &str) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The paper's vessels where they start.
pub(crate) fn starts() -> Vec<Pos> {
    starts_in(paper())
}

/// The vessels of a scenario where they start.
pub(crate) fn starts_in(doc: &Value) -> Vec<Pos> {
    let vessels = doc["vessels"].as_array().expect("a scenario: vessels");
    vessels
        .iter()
        .map(|v| Pos {
            id: v["id"].as_str().unwrap().to_string(),
            x: num(&v["x"], "x"),
            y: num(&v["y"], "y"),
            psi: num(&v["psi"], "psi"),
        })
        .collect()
}

/// Runs `program args…` with `input` on its stdin; its stdout, or a panic
/// naming it and its stderr.
pub(crate) fn run_stdin(program: &str, args: &[&str], input: &str) -> String {
    use std::io::Write;
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("{program} {args:?}: {e}"));
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{program} {args:?} failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// What `seacover evaluate` says of a fleet at some positions.
pub(crate) struct Evaluation {
    pub h: f64,
    pub centroids: BTreeMap<String, (f64, f64)>,
}

/// `seacover evaluate` on the paper's region and risk with the vessels
/// `at` (each with its actuator from the paper).
pub(crate) fn evaluate(at: &[Pos]) -> Evaluation {
    evaluate_in(paper(), at)
}

/// [`evaluate`] in another scenario: `base` (the paper's with its region
/// and risk replaced by [`with_mission`], or another of its own), each
/// vessel with its actuator from `base`.
pub(crate) fn evaluate_in(base: &Value, at: &[Pos]) -> Evaluation {
    let mut doc = base.clone();
    let actuators: BTreeMap<String, (f64, f64)> = base["vessels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| {
            (
                v["id"].as_str().unwrap().to_string(),
                (num(&v["k"], "k"), num(&v["beta"], "beta")),
            )
        })
        .collect();
    doc["vessels"] = at
        .iter()
        .map(|p| {
            let (k, beta) = actuators[&p.id];
            json!({"id": p.id, "x": p.x, "y": p.y, "psi": p.psi, "k": k, "beta": beta})
        })
        .collect();
    let out = run_stdin(BIN, &["evaluate", "-"], &doc.to_string());
    let v: Value = serde_json::from_str(&out).unwrap_or_else(|e| panic!("evaluate: {e}: {out}"));
    let centroids = v["cells"]
        .as_array()
        .unwrap_or_else(|| panic!("evaluate: no cells: {out}"))
        .iter()
        .map(|c| {
            (
                c["id"].as_str().unwrap().to_string(),
                (
                    num(&c["centroid"][0], "centroid"),
                    num(&c["centroid"][1], "centroid"),
                ),
            )
        })
        .collect();
    Evaluation {
        h: num(&v["H"], "H"),
        centroids,
    }
}

/// H at `at`, and each vessel's distance to its own cell's centroid (E).
pub(crate) fn coverage(at: &[Pos]) -> (f64, BTreeMap<String, f64>) {
    coverage_in(paper(), at)
}

/// [`coverage`] in another mission (see [`evaluate_in`]).
pub(crate) fn coverage_in(base: &Value, at: &[Pos]) -> (f64, BTreeMap<String, f64>) {
    let eval = evaluate_in(base, at);
    let e = at
        .iter()
        .map(|p| {
            let (cx, cy) = eval.centroids[&p.id];
            (p.id.clone(), (p.x - cx).hypot(p.y - cy))
        })
        .collect();
    (eval.h, e)
}

pub(crate) fn max_of(e: &BTreeMap<String, f64>) -> f64 {
    e.values().copied().fold(0.0, f64::max)
}

/// The optimum Lloyd's iteration reaches from `at` (every vessel moved to
/// its cell's centroid until none moves 1 mm), by `seacover evaluate`: H
/// there, the number of iterations and the vessels there.
pub(crate) fn lloyd(at: &[Pos]) -> (f64, usize, Vec<Pos>) {
    lloyd_in(paper(), at)
}

/// [`lloyd`] in another mission (see [`evaluate_in`]).
pub(crate) fn lloyd_in(base: &Value, at: &[Pos]) -> (f64, usize, Vec<Pos>) {
    let mut at = at.to_vec();
    for i in 1..=2000 {
        let eval = evaluate_in(base, &at);
        let mut moved: f64 = 0.0;
        for p in &mut at {
            let (cx, cy) = eval.centroids[&p.id];
            moved = moved.max((p.x - cx).hypot(p.y - cy));
            (p.x, p.y) = (cx, cy);
        }
        if moved < 1e-3 {
            return (evaluate_in(base, &at).h, i, at);
        }
    }
    panic!("Lloyd's iteration from {at:?} did not settle in 2000 steps")
}

/// Lloyd's iteration of `at` among `held`, who keep their places (a group
/// that keeps to its own water, docs/peer.md): H of all there, the
/// iterations, and where `at` ends.
pub(crate) fn lloyd_among(at: &[Pos], held: &[Pos]) -> (f64, usize, Vec<Pos>) {
    let mut all: Vec<Pos> = [at, held].concat();
    for i in 1..=2000 {
        let eval = evaluate(&all);
        let mut moved: f64 = 0.0;
        for p in &mut all[..at.len()] {
            let (cx, cy) = eval.centroids[&p.id];
            moved = moved.max((p.x - cx).hypot(p.y - cy));
            (p.x, p.y) = (cx, cy);
        }
        if moved < 1e-3 {
            let h = evaluate(&all).h;
            all.truncate(at.len());
            return (h, i, all);
        }
    }
    panic!("Lloyd's iteration of {at:?} among {held:?} did not settle in 2000 steps")
}

/// The final H of `seacover sim --scenario paper` (200 s, safety on), run
/// once per test process.
pub(crate) fn centralized_h() -> f64 {
    centralized_h_of("paper")
}

/// The final H of `seacover sim --scenario SCENARIO` (200 s, safety on),
/// run once per scenario and test process.
pub(crate) fn centralized_h_of(scenario: &str) -> f64 {
    static H: OnceLock<std::sync::Mutex<BTreeMap<String, f64>>> = OnceLock::new();
    let mut known = H.get_or_init(Default::default).lock().unwrap();
    *known.entry(scenario.to_string()).or_insert_with(|| {
        let dir = tempfile::tempdir().unwrap();
        let status = Command::new(BIN)
            .args(["sim", "--scenario", scenario, "--no-figures", "--out"])
            .arg(dir.path())
            .stdout(Stdio::null())
            .status()
            .unwrap();
        assert!(
            status.success(),
            "seacover sim --scenario {scenario}: {status}"
        );
        let path = dir.path().join("summary.json");
        let summary: Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        num(&summary["H_end"], "summary.json H_end")
    })
}

// ---------------------------------------------------------------------------
// Checks collected, so that one run reports every number.

pub(crate) struct Checks {
    pub test: String,
    pub failed: Vec<String>,
}

impl Checks {
    pub(crate) fn new(test: &str) -> Checks {
        Checks {
            test: test.to_string(),
            failed: Vec::new(),
        }
    }

    pub(crate) fn check(&mut self, ok: bool, what: impl Into<String>) {
        let what = what.into();
        eprintln!(
            "{}: {} {what}",
            self.test,
            if ok { "ok:" } else { "FAILED:" }
        );
        if !ok {
            self.failed.push(what);
        }
    }

    pub(crate) fn finish(self) {
        assert!(
            self.failed.is_empty(),
            "{}: {} check(s) failed:\n- {}",
            self.test,
            self.failed.len(),
            self.failed.join("\n- ")
        );
    }
}

/// The paper's scenario with the region and risk of `mission` (a mission
/// document as `GET /api/v1/mission` gives it): the same vessels and
/// actuators, for [`evaluate_in`].
pub(crate) fn with_mission(mission: &Value) -> Value {
    let mut doc = paper().clone();
    for key in ["region", "risk"] {
        doc[key] = mission[key].clone();
    }
    doc
}
