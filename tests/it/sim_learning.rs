//! `seacover sim` learning a scenario's hidden truth (docs/learning.md, "In
//! the simulator"): every row of the page's table is run again with the
//! real binary and compared as the page prints it; the fleet that learns
//! reaches 99.5 % of H★ within 300 s for seeds 1–5, and the one that does
//! not stays below 93 %. Of the truths the lattice does not contain ("Other
//! truths": off the lattice, a plume, zero over half the region), seed 1 of
//! learning the mean, of the fading optimism and the fleet that does not
//! learn are run again and compared with the page's table. A truth that fails validation is named
//! as such. The comparison with Schwager's adaptive law and a grid Lloyd
//! ("Against Schwager's law and a grid Lloyd") is run again in full and
//! compared with its table, and what the page says of it with the table.

use std::process::Command;

use serde_json::Value;

const PAGE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/learning.md");
const SCENARIO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper-learning.json");
const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");

/// `seacover sim --scenario SCENARIO --duration 300 --no-figures ARGS`:
/// its `learning.json`.
fn learn(scenario: &str, args: &[&str]) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["sim", "--scenario", scenario, "--duration", "300"])
        .args(["--no-figures", "--out"])
        .arg(dir.path())
        .args(args)
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.path().join("learning.json")).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("learning.csv")).unwrap();
    assert!(csv.starts_with("t,H,H_true,share\n"), "{csv:.80}");
    assert_eq!(csv.lines().count(), 3002, "a header and 3001 ticks");
    serde_json::from_str(&text).unwrap()
}

/// A run's share of H★ at the end and from when on it stays at or above
/// 99.5 %, as the page prints them.
fn shown(l: &Value) -> (String, String) {
    let share = format!("{:.2} %", 100.0 * l["share_end"].as_f64().unwrap());
    let from = match l["t_99_5"].as_f64() {
        Some(t) => format!("{t:.1} s"),
        None => "never".to_string(),
    };
    (share, from)
}

/// The body rows of the page's table whose header starts with `header`,
/// each as its trimmed cells.
fn table(header: &str) -> Vec<Vec<String>> {
    let page = std::fs::read_to_string(PAGE).unwrap();
    let mut lines = page.lines().skip_while(|l| !l.starts_with(header));
    assert!(
        lines.next().is_some(),
        "docs/learning.md has the table {header:?}"
    );
    lines
        .skip(1)
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect()
}

/// The rows of the page's table (flags, share at 300 s, from when 99.5 %).
fn rows() -> Vec<(Vec<String>, String, String)> {
    table("| flags | H on the truth")
        .into_iter()
        .map(|cells| {
            let flags = cells[0]
                .trim_matches('`')
                .split_whitespace()
                .map(String::from)
                .collect();
            (flags, cells[1].clone(), cells[2].clone())
        })
        .collect()
}

#[test]
fn the_learning_table_is_what_sim_prints_and_learning_reaches_h_star() {
    let rows = rows();
    assert!(rows.len() >= 8, "{rows:?}");
    let mut seeds = 0;
    for (flags, share, since) in &rows {
        let args: Vec<&str> = flags.iter().map(String::as_str).collect();
        let l = learn(SCENARIO, &args);
        let got = l["share_end"].as_f64().unwrap();
        assert_eq!(shown(&l), (share.clone(), since.clone()), "{flags:?}");
        let h_star = l["H_star"].as_f64().unwrap();
        assert!(h_star > 9000.0, "{flags:?}: H★ {h_star}");
        match args.as_slice() {
            ["--seed", _] => {
                seeds += 1;
                assert!(got >= 0.995, "{flags:?}: {got}");
                assert_eq!(l["cover"], "learned");
                assert_eq!(l["samples"], 8 * 301, "one sample a second each");
                assert_eq!(l["fits"], 61, "one fit every 5 s");
            }
            ["--cover", "prior"] => {
                assert!(got < 0.93, "no learning: {got}");
                assert_eq!(l["samples"], 0);
            }
            _ => {}
        }
    }
    assert_eq!(seeds, 5, "the table has seeds 1–5");
}

/// The rows of the page's table of other truths: the scenario's name (a
/// file in examples/), the fleet, and seed 1's share of H★ at 300 s and
/// from when it stays at or above 99.5 %, as printed.
fn other_truths() -> Vec<(String, String, (String, String))> {
    table("| truth | fleet | H_true / H★ at 300 s")
        .into_iter()
        .map(|cells| {
            let first = |cell: &str| cell.split(", ").next().unwrap().to_string();
            let share = first(cells[2].trim_end_matches(" %")) + " %";
            let truth = cells[0].trim_matches('`').to_string();
            (truth, cells[1].clone(), (share, first(&cells[3])))
        })
        .collect()
}

/// Truths the lattice does not contain: for each, seed 1 of learning the
/// mean, of the fading optimism and the fleet that does not learn end as
/// the page prints them.
#[test]
fn other_truths_are_what_sim_prints() {
    let rows = other_truths();
    let mut truths: Vec<&str> = rows.iter().map(|r| r.0.as_str()).collect();
    truths.dedup();
    assert_eq!(truths.len(), 3, "three truths: {truths:?}");
    for truth in truths {
        let scenario = format!("{EXAMPLES}/{truth}.json");
        let runs: [(&str, &[&str]); 3] = [
            ("learning (mean)", &["--seed", "1"]),
            (
                "learning (κ = 1, fade 30 s)",
                &["--seed", "1", "--kappa", "1"],
            ),
            ("no learning", &["--cover", "prior"]),
        ];
        for (fleet, args) in runs {
            let page = rows
                .iter()
                .find(|r| r.0 == truth && r.1 == fleet)
                .unwrap_or_else(|| panic!("{truth}: no {fleet} row"));
            let l = learn(&scenario, args);
            assert_eq!(shown(&l), page.2, "{truth}: {fleet}");
            let samples = if fleet == "no learning" { 0 } else { 8 * 301 };
            assert_eq!(l["samples"], samples, "{truth}: {fleet}");
        }
    }
}

#[test]
fn a_bad_truth_is_named_and_refused() {
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(SCENARIO).unwrap()).unwrap();
    doc["truth"]["objects"][1]["sigma"] = Value::from(-1.0);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.json");
    std::fs::write(&file, doc.to_string()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["sim", "--duration", "1", "--no-figures", "--scenario"])
        .arg(&file)
        .arg("--out")
        .arg(dir.path().join("out"))
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("truth.objects[1].sigma"), "{err}");
    // And a setting out of range names its flag.
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args([
            "sim",
            "--duration",
            "1",
            "--no-figures",
            "--scenario",
            SCENARIO,
        ])
        .args(["--noise", "0", "--out"])
        .arg(dir.path().join("out"))
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("--noise must be in (0, 1]"), "{err}");
}

/// `seacover sim learning-study --scenario SCENARIO --seeds SEEDS
/// --duration SECS` into a new directory: the directory and what it
/// printed.
fn study(seeds: &str, secs: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["sim", "learning-study", "--scenario", SCENARIO])
        .args(["--seeds", seeds, "--duration", secs, "--out"])
        .arg(dir.path())
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let printed = String::from_utf8_lossy(&out.stdout).into_owned();
    (dir, printed)
}

/// `sim learning-study`: the six ways of covering for one seed, its table,
/// JSON and figure; the clairvoyant ends at H★ by definition, and the
/// learning fleet ends above the one that does not learn.
#[test]
fn the_learning_study_compares_six_fleets() {
    let (dir, printed) = study("1", "150");
    let table = std::fs::read_to_string(dir.path().join("table.md")).unwrap();
    assert_eq!(printed, table);
    assert_eq!(table.lines().count(), 8, "{table}");
    assert!(
        table.starts_with("| fleet | H_true / H★ at 150 s, each seed | at or above 99.5 % from, each seed | at or above 99 % from, each seed |\n"),
        "{table}"
    );
    let rows: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("study.json")).unwrap())
            .unwrap();
    let share = |fleet: &str| {
        rows.as_array()
            .unwrap()
            .iter()
            .find(|r| r["fleet"] == fleet)
            .unwrap_or_else(|| panic!("no {fleet} in {rows}"))["share_end"]
            .as_f64()
            .unwrap()
    };
    assert_eq!(share("clairvoyant"), 1.0);
    assert!(share("learning (mean)") > share("no learning"), "{rows}");
    for fleet in ["schwager", "grid Lloyd"] {
        let s = share(fleet);
        assert!(s > 0.5 && s < 1.05, "{fleet}: {s}");
    }
    for file in ["learning.png", "learning.svg"] {
        let len = std::fs::metadata(dir.path().join(file)).unwrap().len();
        assert!(len > 10_000, "{file}: {len} bytes");
    }
}

/// The page's table of the comparison ("Against Schwager's law and a grid
/// Lloyd"): each row as its fleet and its three cells (share at the end,
/// from when 99.5 %, from when 99 %), each split into its seeds.
fn comparison() -> Vec<(String, [Vec<String>; 3])> {
    table("| fleet | H_true / H★ at 300 s, each seed | at or above 99.5 % from, each seed | at or above 99 %")
        .into_iter()
        .map(|cells| {
            let seeds = |cell: &str| {
                cell.trim_end_matches(" %")
                    .split(", ")
                    .map(String::from)
                    .collect()
            };
            let fleet = cells[0].clone();
            (fleet, [1, 2, 3].map(|i| seeds(&cells[i])))
        })
        .collect()
}

/// Seconds from a cell of the page ("64.5 s"), or none ("never").
fn seconds(cell: &str) -> Option<f64> {
    cell.strip_suffix(" s").map(|t| t.parse().unwrap())
}

/// Against Schwager's adaptive law and a grid Lloyd: the page's table is
/// what `sim learning-study` prints for seeds 1–5 over 300 s, its rows of
/// the learner are those of the study's table above it, and the learner
/// reaches 99 % of H★ first on every seed, as the page says.
#[test]
fn the_comparison_with_schwager_and_grid_lloyd_is_what_the_study_prints() {
    let page = comparison();
    let fleets: Vec<&str> = page.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(
        fleets,
        [
            "clairvoyant",
            "no learning",
            "learning (mean)",
            "learning (κ = 1, fade 30 s)",
            "schwager",
            "grid Lloyd"
        ]
    );
    let (_dir, printed) = study("5", "300");
    let page_text = std::fs::read_to_string(PAGE).unwrap();
    for line in printed.lines() {
        assert!(page_text.contains(line), "not on the page: {line}");
    }
    // The four fleets of the study's first table (above it on the page,
    // before the comparison's two) end and reach 99.5 % as they did.
    let older =
        table("| fleet | H_true / H★ at 300 s, each seed | at or above 99.5 % from, each seed |");
    assert_eq!(older.len(), 4, "{older:?}");
    for (row, (fleet, cells)) in older.iter().zip(&page) {
        assert_eq!(&row[0], fleet);
        assert_eq!(row[1], cells[0].join(", ") + " %", "{fleet}");
        assert_eq!(row[2], cells[1].join(", "), "{fleet}");
    }
    // What the page says of the table: the learner reaches 99 % on every
    // seed and the grid Lloyd on none; Schwager's law first on four
    // seeds of five, and the two averages as printed.
    let t99 = |row: &[Vec<String>; 3]| -> Vec<Option<f64>> {
        row[2].iter().map(|c| seconds(c)).collect()
    };
    let (learner, schwager, grid) = (t99(&page[2].1), t99(&page[4].1), t99(&page[5].1));
    assert!(learner.iter().all(Option::is_some), "{learner:?}");
    assert!(grid.iter().all(Option::is_none), "{grid:?}");
    let sooner = learner
        .iter()
        .zip(&schwager)
        .filter(|(l, s)| s.is_some_and(|s| s < l.unwrap()))
        .count();
    assert_eq!(sooner, 4, "{learner:?} {schwager:?}");
    let mean = |t: &[Option<f64>]| t.iter().map(|t| t.unwrap()).sum::<f64>() / t.len() as f64;
    let said = format!(
        "on average {:.1} s against {:.1} s",
        mean(&schwager),
        mean(&learner)
    );
    assert!(page_text.contains(&said), "the page does not say {said:?}");
}

/// The learner with the prior's weights held tighter (`--weight-sd 2`):
/// seeds 1–5 end and reach 99 % as the page's row says, and sooner than
/// the page's Schwager row on four seeds of five.
#[test]
fn a_tighter_prior_reaches_99_percent_sooner_than_schwager() {
    let page = std::fs::read_to_string(PAGE).unwrap();
    let row = page
        .lines()
        .map(str::trim_start)
        .find(|l| l.starts_with("| learning (mean), `weight_sd` 2 |"))
        .expect("the page has the weight_sd 2 row");
    let cells: Vec<Vec<&str>> = row
        .trim_matches('|')
        .split('|')
        .skip(1)
        .map(|c| c.trim().trim_end_matches(" %").split(", ").collect())
        .collect();
    let schwager = comparison()
        .into_iter()
        .find(|r| r.0 == "schwager")
        .expect("a schwager row")
        .1;
    let mut sooner = 0;
    for seed in 1..=5 {
        let n = seed.to_string();
        let l = learn(SCENARIO, &["--seed", &n, "--weight-sd", "2"]);
        let share = format!("{:.2}", 100.0 * l["share_end"].as_f64().unwrap());
        let t99 = l["t_99"].as_f64().expect("reaches 99 %");
        assert_eq!(share, cells[0][seed - 1], "seed {seed}");
        assert_eq!(format!("{t99:.1} s"), cells[2][seed - 1], "seed {seed}");
        if seconds(&schwager[2][seed - 1]).is_none_or(|s| t99 < s) {
            sooner += 1;
        }
    }
    assert_eq!(
        sooner, 4,
        "sooner than Schwager's law on four seeds of five"
    );
}
