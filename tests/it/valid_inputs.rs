//! No valid input panics: generated valid scenario documents (uniform
//! maps, one vessel, regions from half a metre to a hundred kilometres
//! across, islands) through the real binary's `sim` (short, figures
//! included) and `evaluate`, as a user would run them.

use std::process::Command;

use proptest::prelude::*;
use serde_json::{Value, json};

/// A scenario document: a square of side `side` (with a square island in
/// its middle when `island`), `vessels` as fractions of the side, a base
/// and Gaussians as (x, y fractions, α, σ as a fraction of the side).
fn document(
    side: f64,
    island: bool,
    vessels: &[(f64, f64)],
    base: f64,
    objects: &[(f64, f64, f64, f64)],
) -> Value {
    let at = |f: f64| f * side;
    let holes = if island {
        vec![json!([
            [at(0.4), at(0.4)],
            [at(0.6), at(0.4)],
            [at(0.6), at(0.6)],
            [at(0.4), at(0.6)]
        ])]
    } else {
        Vec::new()
    };
    json!({
        "name": "generated",
        "region": {
            "polygon": [[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]],
            "holes": holes,
        },
        "risk": {
            "base": base,
            "objects": objects.iter().map(|&(x, y, alpha, sigma)| json!({
                "x": at(x), "y": at(y), "alpha": alpha, "sigma": at(sigma),
            })).collect::<Vec<_>>(),
        },
        "vessels": vessels.iter().enumerate().map(|(i, &(x, y))| json!({
            "id": format!("usv-{}", i + 1), "x": at(x), "y": at(y), "psi": 0.3 * i as f64,
        })).collect::<Vec<_>>(),
    })
}

/// A fraction of the side clear of the island (the middle fifth).
fn clear() -> impl Strategy<Value = f64> {
    prop_oneof![0.05..0.35, 0.65..0.95]
}

fn seacover(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(args)
        .output()
        .expect("the binary runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn valid_scenarios_simulate_draw_and_evaluate(
        side in prop_oneof![0.5..5.0, 20.0..500.0, 1e4..1e5],
        island in any::<bool>(),
        vessels in prop::collection::vec((clear(), clear()), 1..=4),
        base in prop_oneof![Just(0.1), 0.001..10.0],
        objects in prop::collection::vec((0.0..1.0, 0.0..1.0, 0.0..20.0, 0.02..0.5), 0..=2),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("scenario.json");
        let doc = document(side, island, &vessels, base, &objects);
        std::fs::write(&file, doc.to_string()).unwrap();
        let scenario = file.to_str().unwrap();
        let (ok, err) = seacover(&["evaluate", scenario]);
        prop_assert!(ok, "evaluate {doc}: {err}");
        let out = dir.path().join("run");
        let (ok, err) = seacover(&[
            "sim", "--scenario", scenario, "--duration", "2", "--out", out.to_str().unwrap(),
        ]);
        prop_assert!(ok, "sim {doc}: {err}");
        let png = std::fs::read(out.join("fig4-evolution.png")).unwrap();
        prop_assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    }
}
