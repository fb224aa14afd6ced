//! `seacover evaluate` as a user runs it: the real binary, a file or stdin, and
//! the exit status and streams it produces.

use std::io::Write;
use std::process::{Command, Output, Stdio};

use serde_json::{Value, json};

fn run(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary starts");
    // The command may exit without reading its input (a bad flag, a file
    // argument): a broken pipe here is its choice, not a failure.
    if let Err(e) = child.stdin.take().unwrap().write_all(stdin.as_bytes()) {
        assert_eq!(e.kind(), std::io::ErrorKind::BrokenPipe, "{e}");
    }
    child.wait_with_output().unwrap()
}

fn paper() -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Runs `evaluate` on stdin and asserts a clean rejection; returns the error.
fn rejected(doc: &str) -> (String, String) {
    let out = run(&["evaluate"], doc);
    assert_eq!(
        out.status.code(),
        Some(2),
        "stdout: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(out.stdout.is_empty());
    let stderr = String::from_utf8(out.stderr).unwrap();
    let last = stderr.lines().last().expect("an error line");
    let v: Value = serde_json::from_str(last).expect("stderr ends with the error JSON");
    let code = v["error"]["code"].as_str().unwrap().to_string();
    let message = v["error"]["message"].as_str().unwrap().to_string();
    assert!(!stderr.contains("panicked"));
    (code, message)
}

fn with(mut doc: Value, edit: impl FnOnce(&mut Value)) -> String {
    edit(&mut doc);
    doc.to_string()
}

#[test]
fn evaluates_a_file_and_stdin_identically() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper.json");
    let from_file = run(&["evaluate", path], "");
    assert!(from_file.status.success());
    let from_stdin = run(&["evaluate"], &paper().to_string());
    assert!(from_stdin.status.success());
    assert_eq!(from_file.stdout, from_stdin.stdout);
    let v: Value = serde_json::from_slice(&from_file.stdout).unwrap();
    let cells = v["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 8);
    assert_eq!(cells[0]["id"], "usv-1");
    let sum: f64 = cells.iter().map(|c| c["mass"].as_f64().unwrap()).sum();
    let h = v["H"].as_f64().unwrap();
    assert!((sum - h).abs() <= 1e-12 * h);
    let area: f64 = cells.iter().map(|c| c["area"].as_f64().unwrap()).sum();
    assert!((area - 1e4).abs() < 1e-8);
    for c in cells {
        assert_eq!(c["centroid"].as_array().unwrap().len(), 2);
        assert_eq!(c["gradient"].as_array().unwrap().len(), 2);
        assert!(c["polygon"].as_array().unwrap().len() >= 3);
    }
}

#[test]
fn reference_mode_agrees_with_the_default() {
    let doc = paper().to_string();
    let fast: Value = serde_json::from_slice(&run(&["evaluate"], &doc).stdout).unwrap();
    let slow: Value =
        serde_json::from_slice(&run(&["evaluate", "--tolerance", "1e-11"], &doc).stdout).unwrap();
    let (h1, h2) = (fast["H"].as_f64().unwrap(), slow["H"].as_f64().unwrap());
    assert!(((h1 - h2) / h2).abs() < 1e-9, "{h1} vs {h2}");
}

#[test]
fn malformed_json_is_rejected() {
    let (code, _) = rejected("{\"region\": ");
    assert_eq!(code, "malformed");
    let (code, _) = rejected("[1, 2, 3]");
    assert_eq!(code, "malformed");
    let (code, msg) = rejected(&with(paper(), |d| d["vessels"][0]["x"] = json!("ten")));
    assert_eq!(code, "malformed");
    assert!(msg.contains("invalid type"), "{msg}");
    // Beyond f64: not a number the document can hold.
    let text = paper().to_string().replace("67.583", "1e400");
    let (code, _) = rejected(&text);
    assert_eq!(code, "malformed");
}

#[test]
fn out_of_range_coordinates_are_rejected_naming_the_field() {
    let (code, msg) = rejected(&with(paper(), |d| d["vessels"][2]["y"] = json!(1e308)));
    assert_eq!(code, "invalid");
    assert!(msg.starts_with("vessels[2].y"), "{msg}");
    let (code, msg) = rejected(&with(paper(), |d| {
        d["region"]["polygon"][1] = json!([1e308, 0.0])
    }));
    assert_eq!(code, "invalid");
    assert!(msg.starts_with("region.polygon[1]"), "{msg}");
    let (_, msg) = rejected(&with(paper(), |d| {
        d["risk"]["objects"][0]["x"] = json!(-1e300)
    }));
    assert!(msg.starts_with("risk.objects[0].x"), "{msg}");
}

#[test]
fn bad_polygons_are_rejected() {
    let (code, msg) = rejected(&with(paper(), |d| {
        d["region"]["polygon"] = json!([[0, 0], [100, 100], [100, 0], [0, 100]])
    }));
    assert_eq!(code, "invalid");
    assert!(
        msg.contains("region.polygon") && msg.contains("intersects itself"),
        "{msg}"
    );
    let (_, msg) = rejected(&with(paper(), |d| {
        d["region"]["polygon"] = json!([[0, 0], [50, 50], [100, 100]])
    }));
    assert!(
        msg.contains("region.polygon") && msg.contains("zero area"),
        "{msg}"
    );
    let (_, msg) = rejected(&with(paper(), |d| {
        d["region"]["polygon"] = json!([[0, 0], [10, 0]])
    }));
    assert!(msg.contains("at least 3"), "{msg}");
    let (_, msg) = rejected(&with(paper(), |d| {
        d["region"]["holes"] = json!([[[200, 200], [210, 200], [210, 210]]])
    }));
    assert!(
        msg.starts_with("region.holes[0]") && msg.contains("not inside"),
        "{msg}"
    );
    let (_, msg) = rejected(&with(paper(), |d| {
        d["region"]["holes"] = json!([
            [[10, 10], [30, 10], [30, 30]],
            [[20, 12], [40, 12], [40, 40]]
        ])
    }));
    assert!(
        msg.contains("region.holes[0]") && msg.contains("region.holes[1]"),
        "{msg}"
    );
}

#[test]
fn bad_values_are_rejected_naming_the_field() {
    type Edit = Box<dyn FnOnce(&mut Value)>;
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|d| d["risk"]["objects"][1]["sigma"] = json!(0)),
            "risk.objects[1].sigma",
        ),
        (
            Box::new(|d| d["risk"]["objects"][1]["sigma"] = json!(-3)),
            "risk.objects[1].sigma",
        ),
        (
            Box::new(|d| d["risk"]["objects"][2]["alpha"] = json!(0)),
            "risk.objects[2].alpha",
        ),
        (Box::new(|d| d["risk"]["base"] = json!(-0.5)), "risk.base"),
        (
            Box::new(|d| d["vessels"][3]["k"] = json!(0)),
            "vessels[3].k",
        ),
        (
            Box::new(|d| d["vessels"][3]["k"] = json!(-1)),
            "vessels[3].k",
        ),
        (
            Box::new(|d| d["vessels"][4]["beta"] = json!(0)),
            "vessels[4].beta",
        ),
        (
            Box::new(|d| d["vessels"][5]["id"] = json!("usv-1")),
            "vessels[5].id",
        ),
        (
            Box::new(|d| d["vessels"][5]["id"] = json!("")),
            "vessels[5].id",
        ),
        (
            Box::new(|d| d["vessels"][5]["id"] = json!("has space")),
            "vessels[5].id",
        ),
        (Box::new(|d| d["vessels"] = json!([])), "vessels"),
        (
            Box::new(|d| {
                d.as_object_mut()
                    .unwrap()
                    .remove("region")
                    .map(|_| ())
                    .unwrap()
            }),
            "region",
        ),
    ];
    for (edit, field) in cases {
        let (code, msg) = rejected(&with(paper(), edit));
        assert_eq!(code, "invalid", "{msg}");
        assert!(msg.starts_with(field), "expected {field}: {msg}");
    }
}

/// Vessels with different β (once refused as `unsupported`) are one
/// fleet: the cells tile the region and the vessel with the larger β has
/// arcs in its exact boundary, `edges`, beside its densified `polygon`.
#[test]
fn mixed_beta_gives_curved_cells() {
    let out = run(
        &["evaluate"],
        &with(paper(), |d| d["vessels"][6]["beta"] = json!(0.004)),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let cells = v["cells"].as_array().unwrap();
    let area: f64 = cells.iter().map(|c| c["area"].as_f64().unwrap()).sum();
    assert!((area - 1e4).abs() < 1e-8, "{area}");
    let arcs = |c: &Value| {
        c["edges"].as_array().map_or(0, |loops| {
            loops
                .iter()
                .flat_map(|l| l.as_array().unwrap())
                .filter(|e| e["kind"] == "arc")
                .count()
        })
    };
    assert!(arcs(&cells[6]) > 0, "{}", cells[6]);
    for c in cells {
        assert!(c["polygon"].as_array().unwrap().len() >= 3, "{c}");
    }
    // A fleet with one β answers without `edges`, as before.
    let out = run(&["evaluate"], &paper().to_string());
    assert!(!String::from_utf8(out.stdout).unwrap().contains("edges"));
}

#[test]
fn unreadable_file_and_bad_flags_exit_2() {
    let out = run(&["evaluate", "/nonexistent/scenario.json"], "");
    assert_eq!(out.status.code(), Some(2));
    let v: Value = serde_json::from_slice(&out.stderr).unwrap();
    assert_eq!(v["error"]["code"], "io");
    let out = run(&["evaluate", "--tolerance", "0"], &paper().to_string());
    assert_eq!(out.status.code(), Some(2));
}

/// `seacover agent` runs in one of two modes: without either, the error
/// names both, not only the coordinator's URL.
#[test]
fn an_agent_without_a_mode_names_both() {
    let out = run(&["agent"], "");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--server") && err.contains("--peer"), "{err}");
}

/// Runs `args`, which must be refused at start: its exit status and
/// standard error, or a panic if it is still running after 10 s (it took
/// the flags and started).
fn refused(args: &[&str]) -> (Option<i32>, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary starts");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    while child.try_wait().unwrap().is_none() {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?} was not refused: it started");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A peer's `--actuator` is checked as a scenario's vessel is, and its
/// `--beacon-hz` within [1, 20], before anything joins a fleet; and the
/// flags only a peer takes are refused
/// beside `--server` rather than ignored (they were: `--mission`,
/// `--alone`, `--learn`).
#[test]
fn peer_flags_are_checked_and_refused_without_peer() {
    for (value, says) in [
        ("0,0.001", "actuator.k"),
        ("0.5,-1", "actuator.beta"),
        ("0.5", "K,BETA"),
        ("x,0.001", "K:"),
    ] {
        let (code, err) = refused(&["agent", "--peer", "--actuator", value]);
        assert_eq!(code, Some(2), "{value}: {err}");
        assert!(err.contains(says), "--actuator {value}: {err}");
    }
    for value in ["0.5", "21", "0", "-3", "NaN", "inf", "x"] {
        let (code, err) = refused(&["agent", "--peer", &format!("--beacon-hz={value}")]);
        assert_eq!(code, Some(2), "{value}: {err}");
        assert!(err.contains("--beacon-hz"), "--beacon-hz {value}: {err}");
    }
    let mission = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper.json");
    for flags in [
        &["--actuator", "0.5,0.004"][..],
        &["--mission", mission],
        &["--alone"],
        &["--learn"],
        &["--beacon-hz", "3"],
    ] {
        let args = [&["agent", "--server", "http://127.0.0.1:1"][..], flags].concat();
        let (code, err) = refused(&args);
        assert_eq!(code, Some(2), "{flags:?}: {err}");
        assert!(err.contains("--server"), "{flags:?}: {err}");
    }
}

fn harbour() -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/harbour.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Bergen's harbour: a mid-latitude origin where a degree of longitude is
/// half a degree of latitude.
const BERGEN: crate::common::geo::Origin = (60.3913, 5.3221);

/// The harbour scenario given in WGS84 (placed by geographiclib): the
/// region as a GeoJSON Feature whose interior rings are the islands, the
/// risk objects and vessels at lat, lon.
fn geo_harbour() -> Value {
    use crate::common::geo::{at_lat_lon, polygon};
    let local = harbour();
    let mut geo = local.clone();
    geo["origin"] = json!({"lat": BERGEN.0, "lon": BERGEN.1});
    geo["region"] = json!({
        "type": "Feature",
        "properties": {"name": "harbour"},
        "geometry": polygon(BERGEN, &local["region"]),
    });
    for o in geo["risk"]["objects"].as_array_mut().unwrap() {
        *o = at_lat_lon(BERGEN, o);
    }
    for v in geo["vessels"].as_array_mut().unwrap() {
        *v = at_lat_lon(BERGEN, v);
    }
    geo
}

#[test]
fn a_geo_referenced_scenario_evaluates_as_its_local_twin() {
    let evaluate = |doc: &Value| -> Value {
        let out = run(&["evaluate"], &doc.to_string());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let local = evaluate(&harbour());
    let geo = evaluate(&geo_harbour());
    // The two placements differ by the plane's distortion over 250 m,
    // s³/(6R²) < 0.1 µm (tests/it/geodesy.rs), so the figures agree to that;
    // areas to 1e-8, since the clipping itself moves cell vertices by
    // about 1e-7 m either way.
    let h = |v: &Value| v["H"].as_f64().unwrap();
    assert!(
        ((h(&geo) - h(&local)) / h(&local)).abs() < 1e-9,
        "H {} vs {}",
        h(&geo),
        h(&local)
    );
    let (cells, twins) = (
        local["cells"].as_array().unwrap(),
        geo["cells"].as_array().unwrap(),
    );
    assert_eq!(cells.len(), 30);
    for (a, b) in cells.iter().zip(twins) {
        assert_eq!(a["id"], b["id"]);
        let f = |v: &Value, k: &str| v[k].as_f64().unwrap();
        assert!(
            (f(a, "mass") - f(b, "mass")).abs() <= 1e-8 * f(a, "mass").max(1.0),
            "{a} {b}"
        );
        assert!(
            (f(a, "area") - f(b, "area")).abs() <= 1e-8 * f(a, "area"),
            "{a} {b}"
        );
        for k in 0..2 {
            let (p, q) = (
                a["centroid"][k].as_f64().unwrap(),
                b["centroid"][k].as_f64().unwrap(),
            );
            assert!((p - q).abs() < 1e-6, "{}: centroid {a} {b}", a["id"]);
        }
    }
}

#[test]
fn geo_referenced_mistakes_name_the_field() {
    // No origin: the region, an object or a vessel in WGS84 names it.
    for edit in ["region", "risk", "vessels"] {
        let doc = with(geo_harbour(), |d| {
            d.as_object_mut().unwrap().remove("origin");
            let local = harbour();
            for other in ["region", "risk", "vessels"] {
                if other != edit {
                    d[other] = local[other].clone();
                }
            }
        });
        let (code, msg) = rejected(&doc);
        assert_eq!(code, "invalid", "{msg}");
        assert!(msg.starts_with("origin: "), "{edit}: {msg}");
    }
    // An origin off the globe.
    let (code, msg) = rejected(&with(geo_harbour(), |d| d["origin"]["lat"] = json!(91)));
    assert_eq!(code, "invalid");
    assert!(msg.starts_with("origin.lat"), "{msg}");
    // A ring that does not close, named by its path in the GeoJSON.
    let (code, msg) = rejected(&with(geo_harbour(), |d| {
        d["region"]["geometry"]["coordinates"][2]
            .as_array_mut()
            .unwrap()
            .pop();
    }));
    assert_eq!(code, "invalid");
    assert!(
        msg.starts_with("region.geometry.coordinates[2][3]"),
        "{msg}"
    );
    // A vessel 0.72° north, past the plane's 50 km: 0.72° of the meridian
    // at 60.4° N, M(60.4°) = 6383.9 km, is 80.2 km.
    let (code, msg) = rejected(&with(geo_harbour(), |d| {
        d["vessels"][4]["lat"] = json!(BERGEN.0 + 0.72)
    }));
    assert_eq!(code, "invalid");
    assert!(
        msg.starts_with("vessels[4].lat") && msg.contains("80.2 km"),
        "{msg}"
    );
    // Both positions at once is not a shape either form has.
    let (code, msg) = rejected(&with(geo_harbour(), |d| {
        d["vessels"][0]["x"] = json!(1);
        d["vessels"][0]["y"] = json!(1)
    }));
    assert_eq!(code, "malformed");
    assert!(msg.contains("not both"), "{msg}");
}
