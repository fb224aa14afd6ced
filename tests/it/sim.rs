//! `seacover sim` end to end: the real binary on the built-in paper scenario,
//! the files it writes, determinism, and the guidance modes' behaviour.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

fn sim(out: &Path, args: &[&str]) -> Value {
    sim_saying(out, args).0
}

/// [`sim`], and what it printed on standard error.
fn sim_saying(out: &Path, args: &[&str]) -> (Value, String) {
    let status = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["sim", "--out"])
        .arg(out)
        .args(args)
        .output()
        .expect("binary runs");
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let printed: Value = serde_json::from_slice(&status.stdout).unwrap();
    let saved: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(printed, saved);
    (saved, String::from_utf8(status.stderr).unwrap())
}

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("seacover-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn writes_csv_summary_and_figures() {
    let out = tmp("files");
    let s = sim(&out, &["--duration", "12"]);
    let mut keys: Vec<&str> = s.as_object().unwrap().keys().map(String::as_str).collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            "E_max_end",
            "H_end",
            "H_start",
            "T1_observer_s",
            "command_lag_max_after_20s",
            "duration",
            "guidance",
            "lloyd",
            "observer_error_max_after_10s",
            "preset",
            "seed",
            "velocity_error_max_after_20s",
            "wall_seconds"
        ]
    );
    assert_eq!(s["guidance"], "course");
    assert_eq!(s["preset"], "paper");
    let mut lloyd: Vec<&str> = s["lloyd"]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    lloyd.sort();
    assert_eq!(lloyd, ["E_max_end", "H_end"]);
    assert!(s["velocity_error_max_after_20s"]["u"].is_number());
    // The paper scenario's H at the start is what `evaluate` says.
    assert!((s["H_start"].as_f64().unwrap() - 7750.855074653).abs() < 1e-6);
    for name in [
        "fig1-observer",
        "fig2-tracking",
        "fig3-metric",
        "fig4-evolution",
    ] {
        for ext in ["png", "svg"] {
            let meta =
                std::fs::metadata(out.join(format!("{name}.{ext}"))).expect("figure written");
            assert!(meta.len() > 10_000, "{name}.{ext} is suspiciously small");
        }
    }
    let png = std::fs::read(out.join("fig4-evolution.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let csv = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,vessel,x,y,psi,u,v,r,u_d,r_d,u_ref,r_ref,u_e_peak,r_e_peak,E,psi_e,tau_ud,tau_vd,tau_rd,tau_ud_hat,tau_vd_hat,tau_rd_hat,H"
    );
    // 10 Hz ticks from 0 to 12 s inclusive, 8 vessels.
    assert_eq!(lines.count(), 121 * 8);
    std::fs::remove_dir_all(out).unwrap();
}

/// A uniform risk map is a valid scenario: the heat map of Fig. 4 has
/// nothing to scale, and must still be drawn (it once panicked in the
/// colour map on a zero range).
#[test]
fn a_uniform_map_is_simulated_and_drawn() {
    let out = tmp("uniform");
    let mut doc: Value =
        serde_json::from_str(&std::fs::read_to_string(crate::common::paper::PAPER).unwrap())
            .unwrap();
    doc["risk"] = serde_json::json!({"base": 0.1, "objects": []});
    std::fs::create_dir_all(&out).unwrap();
    let file = out.join("uniform.json");
    std::fs::write(&file, doc.to_string()).unwrap();
    let s = sim(
        &out,
        &["--scenario", file.to_str().unwrap(), "--duration", "5"],
    );
    assert!(s["H_end"].as_f64().unwrap() > 0.0, "{s}");
    let png = std::fs::read(out.join("fig4-evolution.png")).expect("Fig. 4 drawn");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn the_final_state_is_recorded_between_ticks() {
    let out = tmp("odd");
    sim(&out, &["--duration", "1.25", "--no-figures"]);
    let csv = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let last = csv.lines().last().unwrap();
    assert!(last.starts_with("1.250,usv-8,"), "{last}");
    assert_eq!(csv.lines().count(), 1 + 14 * 8);
    std::fs::remove_dir_all(out).unwrap();
}

#[test]
fn runs_are_deterministic_for_a_seed() {
    let (a, b, c) = (tmp("det-a"), tmp("det-b"), tmp("det-c"));
    let args = ["--duration", "8", "--disturbance", "gusts", "--no-figures"];
    sim(&a, &[&args[..], &["--seed", "5"]].concat());
    sim(&b, &[&args[..], &["--seed", "5"]].concat());
    sim(&c, &[&args[..], &["--seed", "6"]].concat());
    let read = |d: &Path| std::fs::read_to_string(d.join("timeseries.csv")).unwrap();
    assert_eq!(read(&a), read(&b));
    assert_ne!(read(&a), read(&c));
    for d in [a, b, c] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

/// The paper's figures (docs/reproducing-the-paper.md) on its scenario, 200 s, with `args` (preset,
/// disturbance, safety) and without station keeping, as the table there
/// is made (the paper has none: with it a settled vessel may rest up to
/// twice the hold radius off, `converged_vessels_keep_station…` below):
/// after 20 s every vessel tracks the reference its
/// controller is given to within 0.05 (m/s, rad/s), and the coordinator's
/// command itself (tracking error plus how far that reference lags the
/// command) as well; it ends within 0.2 m of its centroid with H within
/// 0.1 % of Lloyd's. Under the paper's disturbance and the gusts the
/// observer's error after 10 s stays below 0.005 too (a current fixed in
/// the earth frame changes, seen from a turning hull, as fast as the hull
/// turns: the observer's error under it, 0.008 N of 15, is documented,
/// not bounded here).
fn the_papers_claims_hold(name: &str, args: &[&str]) {
    let out = tmp(name);
    let s = sim(
        &out,
        &[args, &["--no-figures", "--hold-radius", "0"]].concat(),
    );
    let e = s["E_max_end"].as_f64().unwrap();
    let (h, lloyd) = (
        s["H_end"].as_f64().unwrap(),
        s["lloyd"]["H_end"].as_f64().unwrap(),
    );
    assert!(e < 0.2, "E_max at the end {e}");
    assert!((h - lloyd).abs() < 1e-3 * lloyd, "H {h} vs Lloyd {lloyd}");
    let pair = |key: &str| {
        let v = &s[key];
        (v["u"].as_f64().unwrap(), v["r"].as_f64().unwrap())
    };
    let (u, r) = pair("velocity_error_max_after_20s");
    assert!(u < 0.05 && r < 0.05, "tracking after 20 s: u {u}, r {r}");
    let (lag_u, lag_r) = pair("command_lag_max_after_20s");
    assert!(
        u + lag_u < 0.05 && r + lag_r < 0.05,
        "against the command after 20 s: u {u} + {lag_u}, r {r} + {lag_r}"
    );
    if !args.contains(&"current") {
        let observer = s["observer_error_max_after_10s"].as_f64().unwrap();
        assert!(observer < 0.005, "observer error after 10 s {observer}");
    }
    std::fs::remove_dir_all(out).unwrap();
}

#[test]
fn course_guidance_converges_and_tracks_on_the_papers_vessel() {
    the_papers_claims_hold("course", &["--safety", "on"]);
}

#[test]
fn the_papers_own_pipeline_converges_and_tracks() {
    the_papers_claims_hold("course-none", &["--safety", "none"]);
}

#[test]
fn the_claims_hold_for_the_otter_and_other_disturbances() {
    for (name, args) in [
        ("otter", ["--preset", "otter", "--safety", "none"]),
        ("gusts", ["--disturbance", "gusts", "--safety", "none"]),
        ("current", ["--disturbance", "current", "--safety", "none"]),
    ] {
        the_papers_claims_hold(name, &args);
    }
}

#[test]
fn the_literal_law_fails_on_the_papers_vessel_but_not_with_sway_damping() {
    // The literal law's weakness (docs/reproducing-the-paper.md): with
    // m22/d22 ≈ 67 s the bow's heading barely steers the velocity. The
    // Otter's sway is damped in ≈ 1.6 s.
    let (a, b) = (tmp("literal-paper"), tmp("literal-otter"));
    let paper = sim(
        &a,
        &["--duration", "150", "--guidance", "paper", "--no-figures"],
    );
    let otter = sim(
        &b,
        &[
            "--duration",
            "150",
            "--guidance",
            "paper",
            "--preset",
            "otter",
            "--no-figures",
        ],
    );
    assert!(
        paper["E_max_end"].as_f64().unwrap() > 1.0,
        "{}",
        paper["E_max_end"]
    );
    assert!(
        otter["E_max_end"].as_f64().unwrap() < 0.5,
        "{}",
        otter["E_max_end"]
    );
    for d in [a, b] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

/// The last `window` seconds of a run's `timeseries.csv`: (mean |r|,
/// mean |u|, largest E, the last H).
fn settled(out: &Path, window: f64) -> (f64, f64, f64, f64) {
    let text = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t, u, r, e, h) = (col("t"), col("u"), col("r"), col("E"), col("H"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .enumerate()
                .map(|(i, x)| if i == 1 { 0.0 } else { x.parse().unwrap() })
                .collect()
        })
        .collect();
    let end = rows.last().unwrap()[t];
    let last: Vec<&Vec<f64>> = rows.iter().filter(|x| x[t] >= end - window).collect();
    let mean = |c: usize| last.iter().map(|x| x[c].abs()).sum::<f64>() / last.len() as f64;
    let e_max = last.iter().map(|x| x[e]).fold(0.0, f64::max);
    (mean(r), mean(u), e_max, rows.last().unwrap()[h])
}

#[test]
fn converged_vessels_keep_station_without_turning_inside_the_hold_radius() {
    // "Why" 6: without station keeping (`--hold-radius 0`) a converged
    // vessel chases a goal centimetres away and turns for ever; with it
    // (the default, docs/reproducing-the-paper.md "Quiet arrival") it stops
    // turning and H is as it was, and every hand-over between keeping and
    // the `course` law is one the vessel follows. 600 s: well after the
    // fleet has settled.
    for preset in ["paper", "otter"] {
        let (a, b) = (
            tmp(&format!("hold-none-{preset}")),
            tmp(&format!("hold-on-{preset}")),
        );
        let common = ["--preset", preset, "--duration", "600", "--no-figures"];
        sim(&a, &[&common[..], &["--hold-radius", "0"]].concat());
        let summary = sim(&b, &common);
        let pair = |key: &str| {
            let v = &summary[key];
            (v["u"].as_f64().unwrap(), v["r"].as_f64().unwrap())
        };
        let ((u_err, r_err), (lag_u, lag_r)) = (
            pair("velocity_error_max_after_20s"),
            pair("command_lag_max_after_20s"),
        );
        assert!(
            u_err + lag_u < 0.05 && r_err + lag_r < 0.05,
            "{preset}: against the command after 20 s: u {u_err} + {lag_u}, r {r_err} + {lag_r}"
        );
        let (r0, _, _, h0) = settled(&a, 100.0);
        let (r, u, e, h) = settled(&b, 100.0);
        println!(
            "{preset}, last 100 s: without: mean |r| {r0:.4}, H {h0:.2}; with: mean |r| {r:.4}, \
             mean |u| {u:.4}, E_max {e:.3}, H {h:.2}"
        );
        assert!(
            r0 > 0.02,
            "{preset}: without station keeping the fleet already sits still: {r0}"
        );
        assert!(r < 0.02, "{preset}: mean |r| {r}");
        assert!(u < 0.05, "{preset}: mean |u| {u}");
        assert!(e < 0.5, "{preset}: E_max {e}");
        assert!((h - h0).abs() < 1e-3 * h0, "{preset}: H {h} against {h0}");
        for d in [a, b] {
            std::fs::remove_dir_all(d).unwrap();
        }
    }
}

#[test]
fn bad_arguments_exit_2() {
    for args in [
        &["--guidance", "magic"][..],
        &["--preset", "titanic"],
        &["--duration", "-1"],
        &["--scenario", "/nonexistent.json"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
            .args(["sim", "--no-figures", "--out"])
            .arg(std::env::temp_dir().join("seacover-test-bad"))
            .args(args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
    }
}

#[test]
fn harbour_runs_from_random_starts_report_their_safety() {
    let (a, b) = (tmp("harbour-a"), tmp("harbour-b"));
    let args = [
        "--scenario",
        "harbour-8",
        "--starts",
        "random",
        "--seed",
        "3",
        "--duration",
        "15",
        "--no-figures",
    ];
    sim(&a, &args);
    sim(&b, &[&args[..], &["--safety", "off"]].concat());
    let read = |d: &Path| -> Value {
        serde_json::from_str(&std::fs::read_to_string(d.join("safety.json")).unwrap()).unwrap()
    };
    let (on, off) = (read(&a), read(&b));
    assert_eq!(on["filter"], true);
    assert_eq!(off["filter"], false);
    assert_eq!(off["intervention_rate"], 0.0);
    for s in [&on, &off] {
        for key in [
            "collisions",
            "incursions",
            "min_pair_distance",
            "min_shore_clearance",
            "intervention_rate",
            "H_end",
        ] {
            assert!(s[key].is_number(), "{key} in {s}");
        }
        // Random starts are legal: 8 m apart, off the shore.
        assert!(s["min_pair_distance"].as_f64().unwrap() > 7.0);
    }
    // Random starts differ from the scenario's own.
    let first = |d: &Path| {
        let csv = std::fs::read_to_string(d.join("timeseries.csv")).unwrap();
        csv.lines().nth(1).unwrap().to_string()
    };
    assert_eq!(first(&a), first(&b));
    assert!(
        !first(&a).contains(",12.000000,12.000000,"),
        "{}",
        first(&a)
    );
    for d in [a, b] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn bad_safety_arguments_exit_2() {
    for args in [
        &["--safety", "maybe"][..],
        &["--starts", "nowhere"],
        &["--safety-distance", "-1"],
        &["--scenario", "harbour-1000"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
            .args(["sim", "--no-figures", "--duration", "1", "--out"])
            .arg(std::env::temp_dir().join("seacover-test-bad-safety"))
            .args(args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
    }
}

/// The paper's starts put two vessels 0.42 m and 0.46 m from the edge,
/// inside the hull radius: the default run (200 s, filter on) reports those
/// two incursions as present at the start, none after, and says why.
#[test]
fn the_papers_starts_are_reported_as_incursions_present_at_the_start() {
    let out = tmp("paper-starts");
    let (_, stderr) = sim_saying(&out, &["--no-figures"]);
    let safety: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("safety.json")).unwrap()).unwrap();
    let count = |key: &str| {
        safety[key]
            .as_u64()
            .unwrap_or_else(|| panic!("{key} in {safety}"))
    };
    // Independently, from the scenario document: the vessels within the
    // hull radius of the 100 m square's edge, and the pairs within twice it.
    let doc: Value = serde_json::from_str(
        &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper.json"))
            .unwrap(),
    )
    .unwrap();
    let r = safety["hull_radius"].as_f64().unwrap();
    let starts: Vec<(f64, f64)> = doc["vessels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| (v["x"].as_f64().unwrap(), v["y"].as_f64().unwrap()))
        .collect();
    let ashore = starts
        .iter()
        .filter(|(x, y)| x.min(*y).min(100.0 - x).min(100.0 - y) < r)
        .count() as u64;
    let touching = starts
        .iter()
        .enumerate()
        .flat_map(|(i, a)| starts[i + 1..].iter().map(move |b| (a, b)))
        .filter(|(a, b)| (a.0 - b.0).hypot(a.1 - b.1) < 2.0 * r)
        .count() as u64;
    assert_eq!((ashore, touching), (2, 0));
    assert_eq!(count("incursions_at_start"), ashore);
    assert_eq!(count("incursions"), 0);
    assert_eq!(count("collisions_at_start"), touching);
    assert_eq!(count("collisions"), 0);
    // Within the hull radius is within the shore distance too.
    assert_eq!(count("shore_distance_breaches_at_start"), ashore);
    let line = stderr
        .lines()
        .find(|l| l.starts_with("safety (filter on):"))
        .unwrap_or_else(|| panic!("no safety line in {stderr}"));
    assert!(
        line.contains("0 collisions, 2 incursions present at the start (the scenario's starts are within the hull radius, 2 m, of the shore), 0 after,"),
        "{line}"
    );
    std::fs::remove_dir_all(out).unwrap();
}
