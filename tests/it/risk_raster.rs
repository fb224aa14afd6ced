//! `seacover risk fit` as a user runs it (docs/rasters.md): GeoTIFFs written
//! by rasterio (GDAL) of a known field round SITL's home, in EPSG:4326 and
//! in its UTM zone, fitted by the real binary against a mission over the
//! same place; the written risk is checked against the field's own formula
//! here, and what is not supported must be refused in words.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::{Value, json};

use crate::common::process::venv_python;
use crate::common::sitl::ORIGIN;

/// SITL's home is at 149.17° E, 35.36° S: UTM zone 55 south.
const UTM: &str = "EPSG:32755";

/// The field the rasters hold, in the mission's plane [m]: three Gaussians
/// on a base, of spreads a lattice of ~7 m can follow.
fn field() -> Value {
    json!({
        "base": 0.5,
        "objects": [
            {"x": -40.0, "y": 30.0, "alpha": 8.0, "sigma": 25.0},
            {"x": 45.0, "y": -35.0, "alpha": 5.0, "sigma": 30.0},
            {"x": 20.0, "y": 55.0, "alpha": 3.0, "sigma": 15.0},
        ]
    })
}

/// A risk document's (or the field's) value at (x, y).
fn value(doc: &Value, x: f64, y: f64) -> f64 {
    crate::common::server::density_at(doc, x, y)
}

/// A mission round SITL's home, as `serve --config` reads it: a 200 m
/// square with a hole, so that the error is measured inside the region
/// only.
fn mission(dir: &Path, origin: bool) -> PathBuf {
    let origin = if origin {
        format!("origin = {{ lat = {}, lon = {} }}\n", ORIGIN.0, ORIGIN.1)
    } else {
        String::new()
    };
    let text = format!(
        "{origin}[region]\n\
         polygon = [[-100, -100], [100, -100], [100, 100], [-100, 100]]\n\
         holes = [[[60, 60], [80, 60], [80, 80], [60, 80]]]\n"
    );
    let path = dir.join(if origin.is_empty() {
        "local.toml"
    } else {
        "mission.toml"
    });
    std::fs::write(&path, text).unwrap();
    path
}

/// Writes a raster of [`field`] with `tests/python/write_raster.py`.
fn write(python: &Path, out: &Path, crs: &str, pixel: f64, extra: &[&str]) {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/write_raster.py");
    let run = Command::new(python)
        .arg(script)
        .arg(out)
        .args(["--crs", crs, "--half", "130", "--pixel", &pixel.to_string()])
        .args(["--origin", &ORIGIN.0.to_string(), &ORIGIN.1.to_string()])
        .args(["--field", &field().to_string()])
        .args(extra)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "write_raster.py {crs} {extra:?}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
}

fn fit(raster: &Path, mission: &Path, out: Option<&Path>) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_seacover"));
    command
        .args(["risk", "fit"])
        .arg(raster)
        .arg("--mission")
        .arg(mission);
    if let Some(out) = out {
        command.arg("--out").arg(out);
    }
    command.output().unwrap()
}

/// The RMS and max error [%] of the summary's last line.
fn errors(stderr: &str) -> (f64, f64) {
    let last = stderr.lines().last().expect("a summary");
    let after = |key: &str| -> f64 {
        let rest = &last[last.find(key).unwrap_or_else(|| panic!("{key} in {last}")) + key.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    (after("RMS "), after("max "))
}

/// Fits `raster` and checks the error the binary reports and the written
/// risk against the field at points across the region.
fn check_fit(dir: &Path, raster: &Path) -> (f64, f64) {
    let out = dir.join("risk.json");
    let run = fit(raster, &mission(dir, true), Some(&out));
    let stderr = String::from_utf8_lossy(&run.stderr).to_string();
    assert!(run.status.success(), "{stderr}");
    eprintln!("{stderr}");
    let (rms, max) = errors(&stderr);
    // Measured: RMS 0.004–0.01 %, max 0.03–0.08 % (docs/rasters.md).
    assert!(
        rms < 0.05 && max < 0.5,
        "RMS {rms} %, max {max} %: {stderr}"
    );
    let risk: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let truth = field();
    let range = 8.0 + 0.5; // the field's largest value is near 8.5, its least 0.5
    for (x, y) in [
        (0.0, 0.0),
        (-40.0, 30.0),
        (45.0, -35.0),
        (20.0, 55.0),
        (-90.0, -90.0),
        (90.0, -90.0),
        (-95.0, 95.0),
        (10.0, -60.0),
    ] {
        let (got, want) = (value(&risk, x, y), value(&truth, x, y));
        assert!(
            (got - want).abs() < 0.005 * range,
            "at ({x}, {y}): fitted {got}, field {want}"
        );
    }
    (rms, max)
}

#[test]
fn rasters_in_wgs84_and_utm_fit_the_field() {
    let Some(python) = venv_python("risk_raster", &["rasterio"], "rasterio") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let geographic = dir.path().join("wgs84.tif");
    write(&python, &geographic, "EPSG:4326", 2.0, &[]);
    let (rms, max) = check_fit(dir.path(), &geographic);
    eprintln!("EPSG:4326: RMS {rms} %, max {max} %");
    // NoData inside the region: skipped, or its −9999 would be refused.
    // Pixels of 1 m: samples are means of 2 × 2 pixels.
    let projected = dir.path().join("utm.tif");
    write(
        &python,
        &projected,
        UTM,
        1.0,
        &["--nodata-box", "-20", "-80", "0", "-60"],
    );
    let (rms, max) = check_fit(dir.path(), &projected);
    eprintln!("{UTM}: RMS {rms} %, max {max} %");
}

/// Runs a fit that must fail and returns its message.
fn refused(raster: &Path, mission: &Path) -> String {
    let run = fit(raster, mission, None);
    let stderr = String::from_utf8_lossy(&run.stderr).to_string();
    assert_eq!(run.status.code(), Some(2), "{stderr}");
    assert!(run.stdout.is_empty(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn unsupported_rasters_are_refused_in_words() {
    let Some(python) = venv_python("risk_raster", &["rasterio"], "rasterio") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let with_origin = mission(d, true);
    let cases: [(&str, &str, &[&str], &str); 4] = [
        ("bands.tif", UTM, &["--bands", "3"], "has 3 bands"),
        (
            "mercator.tif",
            "EPSG:3857",
            &[],
            "coordinate reference system EPSG:3857 is not supported",
        ),
        (
            "rotated.tif",
            UTM,
            &["--rotate", "10"],
            "only north-up rasters are supported",
        ),
        ("negative.tif", UTM, &["--negative"], "must be finite, ≥ 0"),
    ];
    for (name, crs, extra, expected) in cases {
        let path = d.join(name);
        write(&python, &path, crs, 2.0, extra);
        let message = refused(&path, &with_origin);
        assert!(message.contains(expected), "{name}: {message}");
        assert!(message.starts_with("seacover: "), "{name}: {message}");
    }
    let good = d.join("good.tif");
    write(&python, &good, "EPSG:4326", 2.0, &[]);
    let message = refused(&good, &mission(d, false));
    assert!(message.contains("the mission has no origin"), "{message}");
    let message = refused(&d.join("missing.tif"), &with_origin);
    assert!(message.contains("missing.tif: No such file"), "{message}");
}

/// A raster named where a risk goes is fitted in its place: `[risk] raster
/// = …` in `serve --config` (the served mission's risk is the field), and
/// `"risk"`/`"truth": {"raster": …}` in a scenario for `seacover sim` (which
/// then learns the raster's truth from a flat prior). Paths are the file's
/// directory's.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_raster_named_in_a_mission_file_is_its_risk() {
    let Some(python) = venv_python("risk_raster", &["rasterio"], "rasterio") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(&python, &d.join("wgs84.tif"), "EPSG:4326", 2.0, &[]);
    let config = mission(d, true);
    let text = std::fs::read_to_string(&config).unwrap();
    std::fs::write(&config, format!("{text}[risk]\nraster = \"wgs84.tif\"\n")).unwrap();
    let mut command = crate::common::server::serve_command(&d.join("data"), &config);
    command
        .arg("--no-record")
        .stderr(std::process::Stdio::piped());
    let (child, addr) = crate::common::server::start(command);
    let _server = crate::common::process::KillOnDrop(child);
    let http = reqwest::Client::new();
    let served: Value =
        crate::common::server::get_json(&http, &format!("http://{addr}/api/v1/mission")).await;
    let range = 8.0 + 0.5;
    for (x, y) in [(0.0, 0.0), (-40.0, 30.0), (45.0, -35.0), (-90.0, 90.0)] {
        let (got, want) = (value(&served["risk"], x, y), value(&field(), x, y));
        assert!(
            (got - want).abs() < 0.005 * range,
            "served risk at ({x}, {y}): {got}, field {want}"
        );
    }

    let scenario = json!({
        "origin": {"lat": ORIGIN.0, "lon": ORIGIN.1},
        "region": {"polygon": [[-100, -100], [100, -100], [100, 100], [-100, 100]]},
        "risk": {"base": 0.5, "objects": []},
        "truth": {"raster": "wgs84.tif", "spacing": 10},
        "vessels": [
            {"id": "a", "x": -50, "y": -50}, {"id": "b", "x": 50, "y": -50},
            {"id": "c", "x": 50, "y": 50}, {"id": "d", "x": -50, "y": 50}
        ]
    });
    let file = d.join("learn.json");
    std::fs::write(&file, scenario.to_string()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["sim", "--duration", "20", "--no-figures", "--scenario"])
        .arg(&file)
        .arg("--out")
        .arg(d.join("sim"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let learning: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("sim/learning.json")).unwrap())
            .unwrap();
    assert!(learning["samples"].as_u64().unwrap() >= 80, "{learning}");
    // `evaluate` takes the same document: its H is that of the fit
    // `risk fit` writes, given inline.
    let evaluate = |doc: &Value, name: &str| -> Value {
        let file = d.join(name);
        std::fs::write(&file, doc.to_string()).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
            .arg("evaluate")
            .arg(&file)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "evaluate {name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let mut plain = scenario.clone();
    plain.as_object_mut().unwrap().remove("truth");
    let plain_file = d.join("plain.json");
    std::fs::write(&plain_file, plain.to_string()).unwrap();
    let fitted = d.join("fitted.json");
    let run = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["risk", "fit"])
        .arg(d.join("wgs84.tif"))
        .arg("--mission")
        .arg(&plain_file)
        .args(["--spacing", "10", "--out"])
        .arg(&fitted)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let mut named = plain.clone();
    named["risk"] = json!({"raster": "wgs84.tif", "spacing": 10});
    let from_raster = evaluate(&named, "evaluate-named.json");
    let mut inline = named.clone();
    inline["risk"] = serde_json::from_str(&std::fs::read_to_string(&fitted).unwrap()).unwrap();
    let from_document = evaluate(&inline, "evaluate-inline.json");
    assert_eq!(
        from_raster["H"], from_document["H"],
        "evaluate of a raster-named risk against the fit given inline"
    );
    // Named but missing: refused in words, naming the file.
    std::fs::remove_file(d.join("wgs84.tif")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["sim", "--duration", "1", "--no-figures", "--scenario"])
        .arg(&file)
        .arg("--out")
        .arg(d.join("sim2"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("wgs84.tif"),
        "{stderr}"
    );
}

/// A PUT of `bytes` to the raster route of the coordinator at `addr`
/// (with `query`): its status and its JSON answer.
async fn put_raster(
    http: &reqwest::Client,
    addr: &str,
    query: &str,
    bytes: Vec<u8>,
) -> (u16, Value) {
    let r = http
        .put(format!("http://{addr}/api/v1/mission/risk/raster{query}"))
        .header("content-type", "image/tiff")
        .body(bytes)
        .send()
        .await
        .unwrap();
    (r.status().as_u16(), r.json().await.unwrap_or(Value::Null))
}

/// The served mission's risk matches the field at points across the region.
fn served_is_the_field(risk: &Value, what: &str) {
    let range = 8.0 + 0.5;
    for (x, y) in [(0.0, 0.0), (-40.0, 30.0), (45.0, -35.0), (-90.0, 90.0)] {
        let (got, want) = (value(risk, x, y), value(&field(), x, y));
        assert!(
            (got - want).abs() < 0.005 * range,
            "{what} at ({x}, {y}): {got}, field {want}"
        );
    }
}

/// The coordinator takes a GeoTIFF over REST (`PUT
/// /api/v1/mission/risk/raster`, what the dashboard's file input sends):
/// the mission's risk becomes its fit, and the answer says how well the
/// fit matches the raster (as `risk fit` does). What cannot be a risk map
/// is refused with the route's codes and changes nothing; a mission
/// without an origin cannot place a raster (409).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_coordinator_takes_a_raster_over_rest() {
    let Some(python) = venv_python("risk_raster", &["rasterio"], "rasterio") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(&python, &d.join("utm.tif"), UTM, 2.0, &[]);
    write(&python, &d.join("bands.tif"), UTM, 2.0, &["--bands", "3"]);
    let mut command = crate::common::server::serve_command(&d.join("data"), &mission(d, true));
    command.arg("--no-record");
    let (child, addr) = crate::common::server::start(command);
    let _server = crate::common::process::KillOnDrop(child);
    let http = reqwest::Client::new();
    let before = crate::common::server::mission(&http, &addr).await;

    let refusals: [(&str, Vec<u8>, u16, &str, &str); 4] = [
        (
            "",
            b"not a tiff".to_vec(),
            400,
            "malformed",
            "the upload: not a readable GeoTIFF",
        ),
        (
            "",
            std::fs::read(d.join("bands.tif")).unwrap(),
            422,
            "unsupported",
            "has 3 bands",
        ),
        (
            "?spacing=-1",
            std::fs::read(d.join("utm.tif")).unwrap(),
            422,
            "invalid",
            "spacing",
        ),
        (
            "?spacing=x",
            std::fs::read(d.join("utm.tif")).unwrap(),
            400,
            "malformed",
            "spacing",
        ),
    ];
    for (query, bytes, status, code, words) in refusals {
        let (got, answer) = put_raster(&http, &addr, query, bytes).await;
        let message = answer["error"]["message"].as_str().unwrap_or_default();
        assert!(
            got == status && answer["error"]["code"] == code && message.contains(words),
            "{query} {words}: {got} {answer}"
        );
    }
    let unchanged = crate::common::server::mission(&http, &addr).await;
    assert_eq!(unchanged, before, "a refused raster changed the mission");

    let (status, answer) =
        put_raster(&http, &addr, "", std::fs::read(d.join("utm.tif")).unwrap()).await;
    assert_eq!(status, 200, "{answer}");
    let fit = &answer["fit"];
    println!("the fit over REST: {fit}");
    assert_eq!(fit["crs"], UTM, "{fit}");
    // As `risk fit` measures the same raster (check_fit's bounds).
    let (rms, worst) = (fit["rms"].as_f64().unwrap(), fit["worst"].as_f64().unwrap());
    assert!(rms < 0.0005 && worst < 0.005, "{fit}");
    let served: Value =
        crate::common::server::get_json(&http, &format!("http://{addr}/api/v1/mission")).await;
    assert_eq!(
        served, answer["mission"],
        "the answer is the mission served"
    );
    served_is_the_field(&served["risk"], "served risk");

    // Without an origin the raster has no place in the mission's plane.
    let mut command = crate::common::server::serve_command(&d.join("data2"), &mission(d, false));
    command.arg("--no-record");
    let (child, local) = crate::common::server::start(command);
    let _local = crate::common::process::KillOnDrop(child);
    let (status, answer) =
        put_raster(&http, &local, "", std::fs::read(d.join("utm.tif")).unwrap()).await;
    assert!(
        status == 409
            && answer["error"]["message"]
                .as_str()
                .unwrap()
                .contains("no origin"),
        "{status} {answer}"
    );
}

/// The dashboard's risk panel takes a GeoTIFF from the operator's disk,
/// in a real browser against the real coordinator: the mission's risk
/// becomes the raster's fit, the panel says how well it fits, and a file
/// that is not a usable raster is refused in the server's words.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_loads_a_raster_as_the_risk() {
    use crate::common::browser::{browser_or_skip, open_browser, screenshot, start_driver, until};
    use fantoccini::Locator;
    let Some(python) = venv_python("risk_raster", &["rasterio"], "rasterio") else {
        return;
    };
    let Some((driver_path, chrome, _heavy)) = browser_or_skip().await else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tif = d.join("harbour-risk.tif");
    write(&python, &tif, "EPSG:4326", 2.0, &[]);
    let bands = d.join("bands.tif");
    write(&python, &bands, UTM, 2.0, &["--bands", "3"]);
    let settings = seacover::server::config::Settings::load(&mission(d, true)).unwrap();
    let server = crate::common::inprocess::Server::start(seacover::server::ServeConfig {
        mission: settings.mission,
        ..seacover::server::ServeConfig::default()
    })
    .await;
    let (_driver, port) = start_driver(&driver_path).await;
    let client = open_browser(port, &chrome).await;
    client.goto(&server.base()).await.unwrap();
    until(
        &client,
        "the page's modules",
        "window.seacover && window.seacover.state.snapshot",
    )
    .await;
    let input = client.find(Locator::Id("raster-input")).await.unwrap();
    input.send_keys(&tif.display().to_string()).await.unwrap();
    until(
        &client,
        "the fit's readout",
        "document.getElementById('raster-readout').textContent.includes('error RMS')",
    )
    .await;
    let shown = client
        .execute(
            "return [document.getElementById('raster-readout').textContent, \
             window.seacover.state.snapshot.mission.risk.objects.length];",
            vec![],
        )
        .await
        .unwrap();
    let readout = shown[0].as_str().unwrap().to_string();
    println!("the dashboard says: {readout}");
    assert!(
        readout.starts_with("harbour-risk.tif (EPSG:4326, "),
        "{readout}"
    );
    let http = reqwest::Client::new();
    let served: Value =
        crate::common::server::get_json(&http, &server.http("/api/v1/mission")).await;
    served_is_the_field(&served["risk"], "the mission after the dashboard's upload");
    let objects = served["risk"]["objects"].as_array().unwrap().len();
    assert!(
        shown[1] == objects && readout.contains(&format!("{objects} Gaussians")),
        "the page holds {} objects, the server {objects}: {readout}",
        shown[1]
    );
    screenshot(&client, "raster-loaded").await;

    let input = client.find(Locator::Id("raster-input")).await.unwrap();
    input.send_keys(&bands.display().to_string()).await.unwrap();
    until(
        &client,
        "the refusal",
        "document.getElementById('raster-readout').textContent.startsWith('bands.tif not loaded')",
    )
    .await;
    let readout = client
        .execute(
            "return document.getElementById('raster-readout').textContent;",
            vec![],
        )
        .await
        .unwrap();
    assert!(
        readout.as_str().unwrap().contains("has 3 bands"),
        "{readout}"
    );
    let still: Value =
        crate::common::server::get_json(&http, &server.http("/api/v1/mission")).await;
    assert_eq!(still, served, "a refused raster changed the mission");
    client.close().await.unwrap();
    server.stop().await;
}
