//! A fleet with different actuator reaches β through the real `seacover
//! serve` binary: vessels declare their own actuator in their
//! hello, the coordinator partitions them together, and every output that
//! carries a cell — `GET /api/v1/coverage`, `GET /api/v1/vessels`, the
//! dashboard stream, the stateless evaluation and `coverage.geojson` —
//! carries the curved cells: their exact `edges` (arcs and segments), and
//! outlines whose vertices lie on those edges and stay within 0.1 m of
//! every arc. The run's recording keeps them, valid against its schemas.

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::Duration;

use crate::common::link::next_json;
use crate::common::process::{signal, venv_python};
use crate::common::server::{eventually, spawn_server};
use futures_util::{SinkExt, StreamExt};
use seacover::recorder::messages;
use seacover::recorder::reader::Recording;
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

/// The paper's square with an island, geo-referenced at Canberra; vessels
/// stay in the partition for 30 s of silence, so a slow machine cannot
/// drop one between two reads.
const CONFIG: &str = r#"
origin = { lat = -35.363261, lon = 149.16523 }
[server]
liveness = 30.0
write_rate = 10000
write_burst = 10000
[region]
polygon = [[0, 0], [100, 0], [100, 100], [0, 100]]
holes = [[[44, 44], [56, 44], [56, 56], [44, 56]]]
"#;

const REGION_AREA: f64 = 1e4 - 144.0;

/// Four vessels with the paper's β = 0.001 at the corners, four with
/// β = 0.004 between them: each of those wins a disc round itself.
const FLEET: [(&str, f64, f64, f64); 8] = [
    ("wide-1", 20.0, 20.0, 0.001),
    ("wide-2", 80.0, 20.0, 0.001),
    ("wide-3", 80.0, 80.0, 0.001),
    ("wide-4", 20.0, 80.0, 0.001),
    ("near-1", 50.0, 25.0, 0.004),
    ("near-2", 75.0, 50.0, 0.004),
    ("near-3", 50.0, 75.0, 0.004),
    ("near-4", 25.0, 50.0, 0.004),
];

struct Server {
    child: Child,
    addr: String,
    http: reqwest::Client,
    data: PathBuf,
    _dir: tempfile::TempDir,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Server {
    fn start() -> Server {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("seacover.toml");
        std::fs::write(&config, CONFIG).unwrap();
        let data = dir.path().join("data");
        let (child, addr) = spawn_server(&data, &config);
        Server {
            child,
            addr,
            http: reqwest::Client::new(),
            data,
            _dir: dir,
        }
    }

    fn url(&self, path: &str) -> String {
        format!("http://{}{path}", self.addr)
    }

    async fn get(&self, path: &str) -> Value {
        let response = self.http.get(self.url(path)).send().await.unwrap();
        assert_eq!(response.status(), 200, "GET {path}");
        response.json().await.unwrap()
    }
}

fn hello(id: &str, beta: f64) -> Message {
    Message::text(
        json!({"type": "hello", "vessel": id, "protocol": 1, "actuator": {"k": 0.5, "beta": beta}})
            .to_string(),
    )
}

/// Opens a link as `id` with actuator β = `beta`; the link repeats its pose
/// and reads (and drops) its commands until the test ends.
async fn link(server: &Server, id: &'static str, x: f64, y: f64, beta: f64) {
    let url = format!("ws://{}/api/v1/vessels/link", server.addr);
    let (socket, _) = tokio_tungstenite::connect_async(url.as_str())
        .await
        .unwrap();
    let (mut sink, mut stream) = socket.split();
    sink.send(hello(id, beta)).await.unwrap();
    let welcome = next_json(&mut stream).await;
    assert_eq!(welcome["type"], "welcome", "{id}: {welcome}");
    let pose =
        json!({"type": "pose", "t": 0.0, "x": x, "y": y, "psi": 0.0, "u": 0.0, "v": 0.0, "r": 0.0})
            .to_string();
    tokio::spawn(async move {
        let mut every = tokio::time::interval(Duration::from_millis(500));
        loop {
            tokio::select! {
                _ = every.tick() => {
                    if sink.send(Message::text(pose.clone())).await.is_err() {
                        return;
                    }
                }
                frame = stream.next() => if frame.is_none() {
                    return;
                },
            }
        }
    });
}

fn xy(v: &Value) -> [f64; 2] {
    [v[0].as_f64().unwrap(), v[1].as_f64().unwrap()]
}

fn distance_to_segment(q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((q[0] - a[0]) * dx + (q[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (q[0] - a[0] - t * dx).hypot(q[1] - a[1] - t * dy)
}

/// The point of an arc edge at parameter `u` in [0, 1].
fn on_arc(e: &Value, u: f64) -> [f64; 2] {
    let c = xy(&e["centre"]);
    let r = e["radius"].as_f64().unwrap();
    let t = e["start"].as_f64().unwrap() + u * e["sweep"].as_f64().unwrap();
    [c[0] + r * t.cos(), c[1] + r * t.sin()]
}

/// Distance from `q` to one edge, independently of the server's code.
fn distance_to_edge(q: [f64; 2], e: &Value) -> f64 {
    match e["kind"].as_str().unwrap() {
        "segment" => distance_to_segment(q, xy(&e["from"]), xy(&e["to"])),
        "arc" => {
            let c = xy(&e["centre"]);
            let r = e["radius"].as_f64().unwrap();
            let (start, sweep) = (e["start"].as_f64().unwrap(), e["sweep"].as_f64().unwrap());
            let (lo, span) = if sweep >= 0.0 {
                (start, sweep)
            } else {
                (start + sweep, -sweep)
            };
            let theta = (q[1] - c[1]).atan2(q[0] - c[0]);
            if (theta - lo).rem_euclid(std::f64::consts::TAU) <= span {
                ((q[0] - c[0]).hypot(q[1] - c[1]) - r).abs()
            } else {
                let [a, b] = [on_arc(e, 0.0), on_arc(e, 1.0)];
                (q[0] - a[0])
                    .hypot(q[1] - a[1])
                    .min((q[0] - b[0]).hypot(q[1] - b[1]))
            }
        }
        other => panic!("an edge of kind {other}"),
    }
}

/// The rings a cell document draws: its pieces' rings, or its polygon.
fn outline(cell: &Value) -> Vec<Vec<[f64; 2]>> {
    match cell["pieces"].as_array() {
        Some(pieces) => pieces
            .iter()
            .flat_map(|p| {
                std::iter::once(&p["polygon"]).chain(p["holes"].as_array().unwrap().iter())
            })
            .map(|r| r.as_array().unwrap().iter().map(xy).collect())
            .collect(),
        None => vec![cell["polygon"].as_array().unwrap().iter().map(xy).collect()],
    }
}

/// A cell's `edges` are closed loops; its outline's vertices lie on them
/// and every point of every arc is within 0.1 m of the outline. Returns
/// the cell's arcs.
fn check_curved(cell: &Value) -> usize {
    let id = &cell["id"];
    let loops = cell["edges"].as_array().unwrap();
    let edges: Vec<&Value> = loops.iter().flat_map(|l| l.as_array().unwrap()).collect();
    let end = |e: &Value| match e["kind"].as_str().unwrap() {
        "arc" => on_arc(e, 1.0),
        _ => xy(&e["to"]),
    };
    let start = |e: &Value| match e["kind"].as_str().unwrap() {
        "arc" => on_arc(e, 0.0),
        _ => xy(&e["from"]),
    };
    for l in loops {
        let l = l.as_array().unwrap();
        for (k, e) in l.iter().enumerate() {
            let (a, b) = (end(e), start(&l[(k + 1) % l.len()]));
            assert!(
                (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-6,
                "{id}: an open loop"
            );
        }
    }
    let rings = outline(cell);
    for q in rings.iter().flatten() {
        let d = edges
            .iter()
            .map(|e| distance_to_edge(*q, e))
            .fold(f64::INFINITY, f64::min);
        assert!(d < 1e-9, "{id}: the vertex {q:?} is {d} m off the boundary");
    }
    let arcs: Vec<&&Value> = edges.iter().filter(|e| e["kind"] == "arc").collect();
    for arc in &arcs {
        for k in 0..=200 {
            let q = on_arc(arc, k as f64 / 200.0);
            let d = rings
                .iter()
                .flat_map(|r| (0..r.len()).map(move |i| (r[i], r[(i + 1) % r.len()])))
                .map(|(a, b)| distance_to_segment(q, a, b))
                .fold(f64::INFINITY, f64::min);
            assert!(
                d <= 0.1 + 1e-9,
                "{id}: a point of an arc {d} m from the outline"
            );
        }
    }
    arcs.len()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_fleet_with_different_beta_gets_curved_cells_everywhere() {
    let server = Server::start();
    // A hello with a β the engine cannot take is refused, naming it.
    let url = format!("ws://{}/api/v1/vessels/link", server.addr);
    let (mut socket, _) = tokio_tungstenite::connect_async(url.as_str())
        .await
        .unwrap();
    socket.send(hello("bad", 0.0)).await.unwrap();
    let refusal = next_json(&mut socket).await;
    assert_eq!(refusal["type"], "error", "{refusal}");
    assert_eq!(refusal["code"], "invalid", "{refusal}");
    assert!(
        refusal["message"]
            .as_str()
            .unwrap()
            .starts_with("actuator.beta"),
        "{refusal}"
    );

    for (id, x, y, beta) in FLEET {
        link(&server, id, x, y, beta).await;
    }
    eventually(10, "eight vessels with cells", || async {
        let c = server.get("/api/v1/coverage").await;
        c["cells"].as_array().is_some_and(|c| c.len() == 8)
    })
    .await;

    // The coverage: the cells tile the region, and curved ones carry their
    // arcs beside outlines within 0.1 m of them.
    let coverage = server.get("/api/v1/coverage").await;
    let cells = coverage["cells"].as_array().unwrap();
    let area: f64 = cells.iter().map(|c| c["area"].as_f64().unwrap()).sum();
    assert!(
        (area - REGION_AREA).abs() < 1e-6 * REGION_AREA,
        "the cells' areas sum to {area}, the region's is {REGION_AREA}"
    );
    let mut arcs = 0;
    for cell in cells {
        if cell.get("edges").is_some() {
            arcs += check_curved(cell);
        }
    }
    let curved: Vec<&str> = cells
        .iter()
        .filter(|c| c.get("edges").is_some())
        .map(|c| c["id"].as_str().unwrap())
        .collect();
    for (id, ..) in FLEET.iter().filter(|v| v.3 > 0.001) {
        assert!(curved.contains(id), "{id} wins a disc: {curved:?}");
    }
    assert!(arcs >= 4, "{arcs} arcs");

    // The vessels as the REST API and the dashboard stream show them: each
    // with the actuator it declared, and its cell's edges.
    let by_id = |id: &str| cells.iter().find(|c| c["id"] == id).unwrap();
    let vessels = server.get("/api/v1/vessels").await;
    for v in vessels.as_array().unwrap() {
        let id = v["id"].as_str().unwrap();
        let beta = FLEET.iter().find(|f| f.0 == id).unwrap().3;
        assert_eq!(v["actuator"]["beta"], beta, "{id}");
        assert_eq!(v.get("edges"), by_id(id).get("edges"), "{id}");
        assert_eq!(v["polygon"], by_id(id)["polygon"], "{id}");
    }
    let stream_url = format!("ws://{}/api/v1/stream", server.addr);
    let (mut stream, _) = tokio_tungstenite::connect_async(stream_url.as_str())
        .await
        .unwrap();
    let snapshot = next_json(&mut stream).await;
    let shown: Vec<&Value> = snapshot["vessels"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|v| v.get("edges").is_some())
        .collect();
    assert_eq!(shown.len(), curved.len(), "{snapshot}");
    for v in shown {
        let arcs = check_curved(v);
        assert!(arcs > 0);
    }

    // The stateless evaluation of the same fleet (region and risk from the
    // mission): the same curved cells.
    let vessels: Vec<Value> = FLEET
        .iter()
        .map(|(id, x, y, beta)| json!({"id": id, "x": x, "y": y, "beta": beta}))
        .collect();
    let response = server
        .http
        .post(server.url("/api/v1/coverage/evaluate"))
        .json(&json!({"vessels": vessels}))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let evaluation: Value = response.json().await.unwrap();
    for cell in evaluation["cells"].as_array().unwrap() {
        let id = cell["id"].as_str().unwrap();
        let live = by_id(id);
        assert_eq!(cell.get("edges"), live.get("edges"), "{id}");
        let (a, b) = (
            cell["mass"].as_f64().unwrap(),
            live["mass"].as_f64().unwrap(),
        );
        assert!((a - b).abs() <= 1e-12 * a.max(b), "{id}: {a} vs {b}");
    }

    // coverage.geojson: one feature per cell and per vessel, curved cells
    // as closed lon/lat rings with as many vertices as their outline.
    let response = server
        .http
        .get(server.url("/api/v1/coverage.geojson"))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let geojson: Value = response.json().await.unwrap();
    assert_eq!(geojson["type"], "FeatureCollection");
    let features = geojson["features"].as_array().unwrap();
    assert_eq!(features.len(), 16);
    for cell in cells.iter().filter(|c| c.get("edges").is_some()) {
        let feature = features
            .iter()
            .find(|f| f["properties"]["kind"] == "cell" && f["properties"]["id"] == cell["id"])
            .unwrap();
        let geometry = &feature["geometry"];
        let polygons: Vec<&Value> = match geometry["type"].as_str().unwrap() {
            "Polygon" => vec![&geometry["coordinates"]],
            "MultiPolygon" => geometry["coordinates"].as_array().unwrap().iter().collect(),
            other => panic!("a {other}"),
        };
        let vertices: usize = polygons
            .iter()
            .flat_map(|p| p.as_array().unwrap())
            .map(|ring| {
                let ring = ring.as_array().unwrap();
                assert_eq!(ring.first(), ring.last(), "a closed ring");
                for p in ring {
                    let [lon, lat] = xy(p);
                    assert!((lon - 149.16523).abs() < 0.01 && (lat + 35.363261).abs() < 0.01);
                }
                ring.len() - 1
            })
            .sum();
        let local: usize = outline(cell).iter().map(Vec::len).sum();
        assert_eq!(vertices, local, "{}", cell["id"]);
    }

    // The recording of the run (serve records by default): every tick's
    // curved cells with their edges, the vessels with their own β, and
    // every message valid against its channel's schema, read by seacover's
    // reader and, where the test venv is, by Foxglove's.
    let mut server = server;
    signal(server.child.id(), "-TERM");
    server.child.wait().unwrap();
    let file = recording(&server.data.join("recordings"));
    let recording = Recording::open(&file).unwrap();
    let ticks: Vec<Value> = recording
        .messages(&|t| t == messages::COVERAGE)
        .map(|m| serde_json::from_slice(&m.unwrap().data).unwrap())
        .collect();
    let last = ticks
        .iter()
        .rev()
        .find(|t| t["cells"].as_array().unwrap().len() == 8)
        .expect("a tick of the whole fleet");
    for cell in last["cells"].as_array().unwrap() {
        assert_eq!(
            cell.get("edges"),
            by_id(cell["id"].as_str().unwrap()).get("edges")
        );
    }
    for v in last["vessels"].as_array().unwrap() {
        let beta = FLEET.iter().find(|f| f.0 == v["id"]).unwrap().3;
        let recorded = v.get("actuator").map(|a| a["beta"].clone());
        assert_eq!(recorded, (beta != 0.001).then(|| json!(beta)), "{v}");
    }
    if let Some(python) = venv_python(
        "curved",
        &["mcap", "jsonschema"],
        "Python with Foxglove's mcap package and jsonschema",
    ) {
        let out = Command::new(python)
            .arg(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/tests/python/check_recording.py"
            ))
            .arg(&file)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let report: Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(report["invalid"], 0, "{report}");
        assert!(report["counts"][messages::COVERAGE].as_u64().unwrap() > 0);
    }
}

/// The one recording in `dir`.
fn recording(dir: &Path) -> PathBuf {
    let files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    files[0].clone()
}
