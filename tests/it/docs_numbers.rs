//! The figures docs/reproducing-the-paper.md quotes are what the commands
//! print: every row of its two tables is run again with the real binary
//! (`sim`, as `scripts/reproduce-paper` runs it) and every column but the
//! wall time compared as the page prints it.

use std::process::Command;

use serde_json::Value;

const PAGE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/reproducing-the-paper.md");

/// The rows of the page's table whose header starts with `header`, as
/// cells.
fn rows(page: &str, header: &str) -> Vec<Vec<String>> {
    let mut lines = page.lines().skip_while(|l| !l.starts_with(header));
    assert!(lines.next().is_some(), "no table headed {header:?}");
    lines
        .skip(1) // the alignment row
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect()
}

/// `seacover sim ARGS` (no figures), its summary.
fn sim(args: &[&str]) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["sim", "--hold-radius", "0", "--no-figures", "--out"])
        .arg(dir.path())
        .args(args)
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

/// The columns both tables share, as the page prints them: H at the
/// start and the end, Lloyd's H at the end, the change against it, E_max.
fn coverage_columns(s: &Value) -> Vec<String> {
    let (h, lloyd) = (num(&s["H_end"]), num(&s["lloyd"]["H_end"]));
    vec![
        format!("{:.1}", num(&s["H_start"])),
        format!("{h:.2}"),
        format!("{lloyd:.2}"),
        format!("{:+.3} %", 100.0 * (h - lloyd) / lloyd),
        format!("{:.3}", num(&s["E_max_end"])),
    ]
}

#[test]
fn the_paper_tables_are_what_sim_prints() {
    let page = std::fs::read_to_string(PAGE).unwrap();
    let mut wrong = Vec::new();
    let main = rows(&page, "| guidance | preset | disturbance | safety |");
    assert!(main.len() >= 10, "{main:?}");
    for row in &main {
        let [guidance, preset, disturbance, safety] = [0, 1, 2, 3].map(|i| row[i].as_str());
        let s = sim(&[
            "--guidance",
            guidance,
            "--preset",
            preset,
            "--disturbance",
            disturbance,
            "--safety",
            safety,
        ]);
        let (v, l) = (
            &s["velocity_error_max_after_20s"],
            &s["command_lag_max_after_20s"],
        );
        let mut printed = coverage_columns(&s);
        printed.extend([
            format!("{:.4}", num(&s["observer_error_max_after_10s"])),
            format!("{:.2}", num(&s["T1_observer_s"])),
            format!("{:.4}", num(&v["u"])),
            format!("{:.4}", num(&v["r"])),
            format!("{:.3} / {:.3}", num(&l["u"]), num(&l["r"])),
        ]);
        if row[4..14] != printed[..] {
            wrong.push(format!("{row:?}\n  sim prints {printed:?}"));
        }
    }
    let mixed = rows(&page, "| fleet | safety |");
    assert_eq!(mixed.len(), 4, "{mixed:?}");
    for row in &mixed {
        let scenario = if row[0].contains("0.004") {
            concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper-mixed.json")
        } else {
            "paper"
        };
        let s = sim(&["--scenario", scenario, "--safety", &row[1]]);
        let mut printed = coverage_columns(&s);
        printed.push(format!("{:.3}", num(&s["lloyd"]["E_max_end"])));
        if row[2..8] != printed[..] {
            wrong.push(format!("{row:?}\n  sim prints {printed:?}"));
        }
    }
    assert!(
        wrong.is_empty(),
        "docs/reproducing-the-paper.md quotes what sim no longer prints \
         (scripts/reproduce-paper prints the rows):\n{}",
        wrong.join("\n")
    );
}
