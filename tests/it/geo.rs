//! Geo-referenced missions through the real `seacover serve` binary on
//! port 0, as an operator with QGIS or geojson.io would use it: the origin,
//! GeoJSON regions and risk objects at lat, lon in, the partition as
//! GeoJSON out. Positions are placed and read back with geographiclib
//! (`crate::common::geo`), never with the server's own conversion.

use std::process::Child;
use std::time::Duration;

use crate::common::geo::{Origin, at_lat_lon, locate, polygon, ring};
use crate::common::link::hello;
use crate::common::process::signal;
use crate::common::server::{eventually, mission, spawn_server};
use futures_util::{SinkExt, StreamExt};
use geographiclib_rs::{Geodesic, PolygonArea, Winding};
use seacover::protocol::{CoverageDocument, MissionDocument, RegionDocument};
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

/// ArduPilot SITL's home at Canberra: a southern, eastern origin.
const CANBERRA: Origin = (-35.363261, 149.16523);

/// A coordinator from the real binary, killed when dropped.
struct Server {
    child: Child,
    addr: String,
    http: reqwest::Client,
    _dir: tempfile::TempDir,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Room for the tests' writes; the limit itself is tested elsewhere.
const CONFIG: &str = "[server]\nwrite_rate = 10000\nwrite_burst = 10000\n";

fn start() -> Server {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("seacover.toml");
    std::fs::write(&config, CONFIG).unwrap();
    let (child, addr) = spawn_server(&dir.path().join("data"), &config);
    Server {
        child,
        addr,
        http: reqwest::Client::new(),
        _dir: dir,
    }
}

impl Server {
    fn url(&self, path: &str) -> String {
        format!("http://{}{path}", self.addr)
    }

    async fn send(&self, method: reqwest::Method, path: &str, body: &Value) -> (u16, Value) {
        let response = self
            .http
            .request(method, self.url(path))
            .json(body)
            .send()
            .await
            .unwrap();
        let status = response.status().as_u16();
        (status, response.json().await.unwrap_or(Value::Null))
    }

    async fn put(&self, path: &str, body: &Value) -> (u16, Value) {
        self.send(reqwest::Method::PUT, path, body).await
    }

    async fn post(&self, path: &str, body: &Value) -> (u16, Value) {
        self.send(reqwest::Method::POST, path, body).await
    }

    async fn get(&self, path: &str) -> (u16, Value) {
        let response = self.http.get(self.url(path)).send().await.unwrap();
        let status = response.status().as_u16();
        (status, response.json().await.unwrap())
    }

    async fn mission(&self) -> MissionDocument {
        mission(&self.http, &self.addr).await
    }
}

fn origin_json(o: Origin) -> Value {
    json!({"lat": o.0, "lon": o.1})
}

/// Asserts a refusal: its status, its code, and the field its message
/// starts with.
fn refused(answer: &(u16, Value), status: u16, code: &str, field: &str) {
    let (s, body) = answer;
    assert_eq!(*s, status, "{body}");
    assert_eq!(body["error"]["code"], code, "{body}");
    let message = body["error"]["message"].as_str().unwrap();
    assert!(message.starts_with(field), "expected {field}: {message}");
}

/// The harbour of `examples/harbour.json`: a 200 m × 140 m basin with three
/// islands.
fn harbour() -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/harbour.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Whether two local rings have the same vertices to within `tolerance`
/// metres, in the same cyclic order.
fn same_ring(a: &[[f64; 2]], b: &[[f64; 2]], tolerance: f64) -> bool {
    a.len() == b.len()
        && (0..b.len()).any(|shift| {
            a.iter().enumerate().all(|(i, p)| {
                let q = b[(i + shift) % b.len()];
                (p[0] - q[0]).hypot(p[1] - q[1]) <= tolerance
            })
        })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_origin_is_set_shown_validated_and_moves_nothing_on_the_plane() {
    let server = start();
    // A mission without one says so with an explicit null.
    let (status, raw) = server.get("/api/v1/mission").await;
    assert_eq!(status, 200);
    assert_eq!(raw.get("origin"), Some(&Value::Null), "{raw}");
    let before = server.mission().await;

    let (status, answer) = server
        .put("/api/v1/mission/origin", &origin_json(CANBERRA))
        .await;
    assert_eq!(status, 200, "{answer}");
    assert_eq!(answer["origin"], origin_json(CANBERRA));
    let after = server.mission().await;
    assert_eq!(
        after.origin.map(|o| (o.lat, o.lon)),
        Some(CANBERRA),
        "GET /api/v1/mission shows the origin"
    );
    // The region and the objects keep their local coordinates.
    assert_eq!(after.region, before.region);
    assert_eq!(after.risk, before.risk);

    // Out of range: refused naming the coordinate, and nothing changes.
    for (body, field) in [
        (json!({"lat": 90, "lon": 0}), "origin.lat"),
        (json!({"lat": -90, "lon": 0}), "origin.lat"),
        (json!({"lat": 91.5, "lon": 10}), "origin.lat"),
        (json!({"lat": 10, "lon": 180.000001}), "origin.lon"),
        (json!({"lat": 10, "lon": -181}), "origin.lon"),
    ] {
        let answer = server.put("/api/v1/mission/origin", &body).await;
        refused(&answer, 422, "invalid", field);
    }
    // JSON has no NaN or infinity: a number beyond f64 is not a number
    // the body can hold (400, as for every body), and a missing one is
    // not the document's shape.
    for text in [r#"{"lat": 1e400, "lon": 0}"#, r#"{"lat": 10}"#] {
        let response = server
            .http
            .put(server.url("/api/v1/mission/origin"))
            .header("content-type", "application/json")
            .body(text)
            .send()
            .await
            .unwrap();
        assert_eq!(response.status(), 400, "{text}");
    }
    // ±180 are both the antimeridian, and accepted.
    let (status, _) = server
        .put("/api/v1/mission/origin", &json!({"lat": 0, "lon": -180}))
        .await;
    assert_eq!(status, 200);
    let (status, _) = server
        .put("/api/v1/mission/origin", &origin_json(CANBERRA))
        .await;
    assert_eq!(status, 200);
    assert_eq!(server.mission().await.origin, after.origin);
}

/// The origin is a write like the region: with `--token` it needs the
/// token, and reading the partition as GeoJSON does not.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn setting_the_origin_needs_the_token() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("seacover.toml");
    std::fs::write(&config, CONFIG).unwrap();
    let mut command = crate::common::server::serve_command(&dir.path().join("data"), &config);
    command
        .args(["--token", "harbour-master"])
        .stderr(std::process::Stdio::null());
    let (mut child, addr) = crate::common::server::start(command);
    let http = reqwest::Client::new();
    let url = format!("http://{addr}/api/v1/mission/origin");
    let response = http
        .put(&url)
        .json(&origin_json(CANBERRA))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 401);
    assert_eq!(mission(&http, &addr).await.origin, None);
    let response = http
        .put(&url)
        .bearer_auth("harbour-master")
        .json(&origin_json(CANBERRA))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let response = http
        .get(format!("http://{addr}/api/v1/coverage.geojson"))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200, "reads stay public");
    let _ = child.kill();
    let _ = child.wait();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_acknowledged_origin_and_geojson_region_survive_sigkill() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("seacover.toml");
    std::fs::write(&config, CONFIG).unwrap();
    let data = dir.path().join("data");
    let http = reqwest::Client::new();
    let (mut child, addr) = spawn_server(&data, &config);
    let url = |p: &str| format!("http://{addr}{p}");
    let response = http
        .put(url("/api/v1/mission/origin"))
        .json(&origin_json(CANBERRA))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let harbour = harbour();
    let response = http
        .put(url("/api/v1/mission/region"))
        .json(&polygon(CANBERRA, &harbour["region"]))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let written = mission(&http, &addr).await;
    // The answer is the acknowledgement: kill at once, no clean shutdown.
    kill_9(&mut child);
    let (mut child, addr) = spawn_server(&data, &config);
    let restored = mission(&http, &addr).await;
    assert_eq!(restored.origin, written.origin);
    assert_eq!(restored.region, written.region);
    let _ = child.kill();
    let _ = child.wait();
}

fn kill_9(child: &mut Child) {
    signal(child.id(), "-KILL");
    let _ = child.wait();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn geojson_regions_and_lat_lon_objects_are_placed_in_the_plane() {
    let server = start();
    let harbour = harbour();
    let local: RegionDocument = serde_json::from_value(harbour["region"].clone()).unwrap();
    let geometry = polygon(CANBERRA, &harbour["region"]);
    let object = json!({"id": "wreck", "x": 93.0, "y": 62.0, "alpha": 10, "sigma": 10});

    // Without an origin, WGS84 inputs are refused naming it, and nothing
    // changes.
    let before = server.mission().await;
    let answer = server.put("/api/v1/mission/region", &geometry).await;
    refused(&answer, 422, "invalid", "origin");
    let answer = server
        .post("/api/v1/risk-objects", &at_lat_lon(CANBERRA, &object))
        .await;
    refused(&answer, 422, "invalid", "origin");
    let answer = server
        .put(
            "/api/v1/risk-objects/object-1",
            &at_lat_lon(CANBERRA, &object),
        )
        .await;
    refused(&answer, 422, "invalid", "origin");
    assert_eq!(server.mission().await, before);

    let (status, _) = server
        .put("/api/v1/mission/origin", &origin_json(CANBERRA))
        .await;
    assert_eq!(status, 200);

    // The same harbour as a bare Polygon, as a Feature (geojson.io) and as
    // a FeatureCollection of a MultiPolygon (QGIS's export): each lands on
    // the local harbour, islands and all, within the plane's distortion
    // (33 nm at 250 m; tests/it/geodesy.rs).
    let feature =
        json!({"type": "Feature", "properties": {"name": "harbour"}, "geometry": geometry});
    let qgis = json!({"type": "FeatureCollection", "name": "harbour", "features": [{
        "type": "Feature", "properties": {"fid": 1},
        "geometry": {"type": "MultiPolygon", "coordinates": [geometry["coordinates"]]},
    }]});
    for body in [&geometry, &feature, &qgis] {
        // Start from another region, so that each write shows.
        let (status, answer) = server
            .put(
                "/api/v1/mission/region",
                &json!({"polygon": [[0, 0], [100, 0], [100, 100], [0, 100]]}),
            )
            .await;
        assert_eq!(status, 200, "{answer}");
        let (status, answer) = server.put("/api/v1/mission/region", body).await;
        assert_eq!(status, 200, "{answer}");
        let stored = server.mission().await.region;
        assert_eq!(stored.holes.len(), 3);
        assert!(
            same_ring(&stored.polygon, &local.polygon, 1e-6),
            "{stored:?}"
        );
        for (got, want) in stored.holes.iter().zip(&local.holes) {
            assert!(same_ring(got, want, 1e-6), "{got:?} vs {want:?}");
        }
    }

    // A ring that does not close, an island outside the basin, a region
    // beyond 50 km: refused naming where, and nothing changes.
    let kept = server.mission().await;
    let mut open = geometry.clone();
    open["coordinates"][0].as_array_mut().unwrap().pop();
    let answer = server.put("/api/v1/mission/region", &open).await;
    refused(&answer, 422, "invalid", "region.coordinates[0][7]");
    let mut outside = geometry.clone();
    outside["coordinates"][1] = ring(CANBERRA, &json!([[300, 300], [310, 300], [310, 310]]));
    let answer = server.put("/api/v1/mission/region", &outside).await;
    refused(&answer, 422, "invalid", "region.holes[0]");
    let far = polygon(
        (CANBERRA.0 + 0.5, CANBERRA.1),
        &json!({"polygon": [[0, 0], [100, 0], [100, 100]]}),
    );
    let answer = server.put("/api/v1/mission/region", &far).await;
    refused(&answer, 422, "invalid", "region.coordinates[0][0].lat");
    let answer = server
        .put(
            "/api/v1/mission/region",
            &json!({"type": "LineString", "coordinates": [[149, -35], [149.1, -35]]}),
        )
        .await;
    refused(&answer, 422, "invalid", "region.type");
    assert_eq!(server.mission().await, kept);

    // Risk objects at lat, lon are stored, and answered, at x, y.
    let (status, created) = server
        .post("/api/v1/risk-objects", &at_lat_lon(CANBERRA, &object))
        .await;
    assert_eq!(status, 201, "{created}");
    assert_eq!(created["id"], "wreck");
    assert!(created.get("lat").is_none(), "{created}");
    let xy = |v: &Value| (v["x"].as_f64().unwrap(), v["y"].as_f64().unwrap());
    let (x, y) = xy(&created);
    assert!((x - 93.0).hypot(y - 62.0) < 1e-6, "({x}, {y})");
    let moved = json!({"x": 150.0, "y": 65.0, "alpha": 12, "sigma": 12});
    let (status, replaced) = server
        .put("/api/v1/risk-objects/wreck", &at_lat_lon(CANBERRA, &moved))
        .await;
    assert_eq!(status, 200, "{replaced}");
    let (x, y) = xy(&replaced);
    assert!((x - 150.0).hypot(y - 65.0) < 1e-6, "({x}, {y})");
    let (_, listed) = server.get("/api/v1/risk-objects/wreck").await;
    assert_eq!(listed, replaced);
    // Both positions at once is neither form.
    let (status, _) = server
        .post(
            "/api/v1/risk-objects",
            &json!({"x": 1, "y": 2, "lat": -35.36, "lon": 149.16, "alpha": 1, "sigma": 1}),
        )
        .await;
    assert_eq!(status, 400);
    let answer = server
        .post(
            "/api/v1/risk-objects",
            &json!({"lat": -35.36, "lon": 200, "alpha": 1, "sigma": 1}),
        )
        .await;
    refused(&answer, 422, "invalid", "lon");
}

/// A pose frame at (x, y) heading ψ, under the coordinator's control or not.
fn pose(x: f64, y: f64, psi: f64, controlled: bool) -> Message {
    Message::text(
        json!({"type": "pose", "t": 0.0, "x": x, "y": y, "psi": psi, "u": 0.0, "v": 0.0,
               "r": 0.0, "controlled": controlled})
        .to_string(),
    )
}

/// The signed geodesic area [m²] of a GeoJSON ring (counter-clockwise
/// positive), by geographiclib.
fn geodesic_area(ring: &[Value]) -> f64 {
    let g = Geodesic::wgs84();
    let mut area = PolygonArea::new(&g, Winding::CounterClockwise);
    for p in &ring[..ring.len() - 1] {
        area.add_point(p[1].as_f64().unwrap(), p[0].as_f64().unwrap());
    }
    area.compute(true).1
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_partition_opens_as_rfc_7946_geojson() {
    let server = start();
    let response = server
        .http
        .get(server.url("/api/v1/coverage.geojson"))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 404);
    let body: Value = response.json().await.unwrap();
    assert_eq!(body["error"]["code"], "not_found");
    assert!(
        body["error"]["message"]
            .as_str()
            .unwrap()
            .contains("PUT /api/v1/mission/origin"),
        "{body}"
    );

    let (status, _) = server
        .put("/api/v1/mission/origin", &origin_json(CANBERRA))
        .await;
    assert_eq!(status, 200);
    let (status, _) = server
        .put(
            "/api/v1/mission/region",
            &polygon(CANBERRA, &harbour()["region"]),
        )
        .await;
    assert_eq!(status, 200);

    // Four vessels on real links, placed so that cells have islands in
    // them and pieces on both sides of the pier; one taken over by its
    // operator. Headings: east, north, west, south-west.
    let ws = format!("ws://{}/api/v1/vessels/link", server.addr);
    let boats = [
        ("usv-a", 20.0, 20.0, 0.0, true),
        ("usv-b", 60.0, 100.0, std::f64::consts::FRAC_PI_2, true),
        ("usv-c", 150.0, 60.0, std::f64::consts::PI, false),
        (
            "usv-d",
            180.0,
            130.0,
            -3.0 * std::f64::consts::FRAC_PI_4,
            true,
        ),
    ];
    // Each link repeats its pose (a vessel silent for 3 s leaves the
    // partition) and reads its commands (a link must keep up).
    let mut links = Vec::new();
    for (id, x, y, psi, controlled) in boats {
        let (mut sink, mut stream) = hello(ws.clone(), id).await;
        links.push(tokio::spawn(async move {
            let mut every = tokio::time::interval(Duration::from_millis(200));
            loop {
                tokio::select! {
                    _ = every.tick() => {
                        if sink.send(pose(x, y, psi, controlled)).await.is_err() {
                            return;
                        }
                    }
                    frame = stream.next() => if frame.is_none() {
                        return;
                    },
                }
            }
        }));
    }
    eventually(10, "four live vessels with cells", || async {
        let (_, c) = server.get("/api/v1/coverage").await;
        c["cells"].as_array().is_some_and(|c| c.len() == 4)
    })
    .await;

    // One snapshot seen both ways: the local partition and its GeoJSON,
    // taken while nothing moves (the poses are fixed).
    let (_, local) = server.get("/api/v1/coverage").await;
    let response = server
        .http
        .get(server.url("/api/v1/coverage.geojson"))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    assert_eq!(
        response.headers()["content-type"].to_str().unwrap(),
        "application/geo+json"
    );
    let text = response.text().await.unwrap();
    let coverage: CoverageDocument = serde_json::from_value(local).unwrap();
    let (_, again) = server.get("/api/v1/coverage").await;
    assert_eq!(
        serde_json::from_value::<CoverageDocument>(again)
            .unwrap()
            .cells,
        coverage.cells,
        "the partition moved while it was read"
    );

    // RFC 7946 as the geojson crate reads it, and as the RFC writes it.
    let parsed: geojson::GeoJson = text.parse().expect("GeoJSON");
    let geojson::GeoJson::FeatureCollection(collection) = parsed else {
        panic!("not a FeatureCollection: {text}");
    };
    let raw: Value = serde_json::from_str(&text).unwrap();
    assert!(raw.get("crs").is_none(), "RFC 7946 has no crs member");
    assert_eq!(raw["type"], "FeatureCollection");
    assert_eq!(collection.features.len(), 8, "four cells and four vessels");

    let features = raw["features"].as_array().unwrap();
    let of_kind = |kind: &str| -> Vec<&Value> {
        features
            .iter()
            .filter(|f| f["properties"]["kind"] == kind)
            .collect()
    };
    let g = Geodesic::wgs84();
    for cell in of_kind("cell") {
        let p = &cell["properties"];
        let id = p["id"].as_str().unwrap();
        let expected = coverage.cells.iter().find(|c| c.id == id).unwrap();
        assert_eq!(p["mass"].as_f64().unwrap(), expected.mass);
        // The centroid and E, read back through geographiclib.
        let c = &p["centroid"];
        let (x, y) = locate(CANBERRA, c[1].as_f64().unwrap(), c[0].as_f64().unwrap());
        assert!(
            (x - expected.centroid[0]).hypot(y - expected.centroid[1]) < 1e-6,
            "{id}: centroid"
        );
        let boat = boats.iter().find(|b| b.0 == id).unwrap();
        let e = (expected.centroid[0] - boat.1).hypot(expected.centroid[1] - boat.2);
        assert!((p["E"].as_f64().unwrap() - e).abs() < 1e-9, "{id}: E");

        // Polygons: closed rings, exterior counter-clockwise and holes
        // clockwise (geographiclib's signed geodesic area), the rings'
        // areas adding up to the cell's, and every vertex back on the
        // local partition's.
        let geometry = &cell["geometry"];
        let polygons: Vec<&Value> = match geometry["type"].as_str().unwrap() {
            "Polygon" => vec![&geometry["coordinates"]],
            "MultiPolygon" => geometry["coordinates"].as_array().unwrap().iter().collect(),
            other => panic!("{id}: a {other}"),
        };
        let pieces: Vec<RegionDocument> = if expected.pieces.is_empty() {
            vec![RegionDocument {
                polygon: expected.polygon.clone().unwrap(),
                holes: Vec::new(),
            }]
        } else {
            expected.pieces.clone()
        };
        assert_eq!(polygons.len(), pieces.len(), "{id}: pieces");
        let mut area = 0.0;
        for polygon in &polygons {
            let polygon_rings = polygon.as_array().unwrap();
            for (k, ring) in polygon_rings.iter().enumerate() {
                let ring = ring.as_array().unwrap();
                assert!(ring.len() >= 4, "{id}: a ring of {}", ring.len());
                assert_eq!(ring.first(), ring.last(), "{id}: an open ring");
                let signed = geodesic_area(ring);
                assert!(
                    if k == 0 { signed > 0.0 } else { signed < 0.0 },
                    "{id}: ring {k} turns the wrong way ({signed} m²)"
                );
                area += signed;
                // Back in the plane, the ring is one of the local cell's.
                let back: Vec<[f64; 2]> = ring[..ring.len() - 1]
                    .iter()
                    .map(|p| {
                        let (x, y) =
                            locate(CANBERRA, p[1].as_f64().unwrap(), p[0].as_f64().unwrap());
                        [x, y]
                    })
                    .collect();
                let reversed: Vec<[f64; 2]> = back.iter().rev().copied().collect();
                let known = pieces.iter().any(|piece| {
                    std::iter::once(&piece.polygon)
                        .chain(&piece.holes)
                        .any(|r| same_ring(&back, r, 1e-6) || same_ring(&reversed, r, 1e-6))
                });
                assert!(known, "{id}: ring {k} is none of the cell's: {back:?}");
            }
        }
        // Geodesic edges against straight ones over 200 m: a part in 1e-9.
        assert!(
            (area - expected.area).abs() < 1e-6 * expected.area,
            "{id}: geodesic area {area} m², cell {} m²",
            expected.area
        );
    }
    // The harbour's islands show as holes in cells and as cuts between a
    // cell's pieces: the test has both.
    assert!(
        coverage.cells.iter().any(|c| c.pieces.len() > 1),
        "no cell of several pieces: {:?}",
        coverage.cells
    );
    assert!(
        coverage
            .cells
            .iter()
            .any(|c| c.pieces.iter().any(|p| !p.holes.is_empty())),
        "no cell with a hole: {:?}",
        coverage.cells
    );

    for vessel in of_kind("vessel") {
        let p = &vessel["properties"];
        let id = p["id"].as_str().unwrap();
        let boat = boats.iter().find(|b| b.0 == id).unwrap();
        assert_eq!(vessel["geometry"]["type"], "Point");
        let c = &vessel["geometry"]["coordinates"];
        let (x, y) = locate(CANBERRA, c[1].as_f64().unwrap(), c[0].as_f64().unwrap());
        assert!((x - boat.1).hypot(y - boat.2) < 1e-6, "{id}: position");
        // ψ counter-clockwise from east is a compass heading of 90° − ψ.
        let compass = (90.0 - boat.3.to_degrees()).rem_euclid(360.0);
        assert!(
            (p["heading_deg"].as_f64().unwrap() - compass).abs() < 1e-9,
            "{id}: heading {} for ψ = {}",
            p["heading_deg"],
            boat.3
        );
        assert_eq!(p["connected"], true);
        assert_eq!(p["live"], true);
        assert_eq!(p["controlled"], boat.4, "{id}");
    }
    // East is +lon and north is +lat, and the distance between two points
    // is the plane's (to its distortion, far below a micrometre here).
    let at = |id: &str| -> (f64, f64) {
        let v = of_kind("vessel")
            .into_iter()
            .find(|v| v["properties"]["id"] == id)
            .unwrap();
        let c = &v["geometry"]["coordinates"];
        (c[0].as_f64().unwrap(), c[1].as_f64().unwrap())
    };
    let (a, d) = (at("usv-a"), at("usv-d"));
    assert!(
        d.0 > a.0 && d.1 > a.1,
        "east is +lon and north is +lat: {a:?} {d:?}"
    );
    let (s, _, _, _): (f64, f64, f64, f64) =
        geographiclib_rs::InverseGeodesic::inverse(&g, a.1, a.0, d.1, d.0);
    assert!(
        (s - (160.0f64).hypot(110.0)).abs() < 1e-6,
        "usv-a to usv-d: {s} m"
    );
    for link in links {
        link.abort();
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_what_if_evaluation_takes_wgs84_like_the_cli() {
    let server = start();
    let local = harbour();
    let mut geo = local.clone();
    geo["region"] = polygon(CANBERRA, &local["region"]);
    for o in geo["risk"]["objects"].as_array_mut().unwrap() {
        *o = at_lat_lon(CANBERRA, o);
    }
    for v in geo["vessels"].as_array_mut().unwrap() {
        *v = at_lat_lon(CANBERRA, v);
    }
    // Without any origin: refused naming it.
    let answer = server.post("/api/v1/coverage/evaluate", &geo).await;
    refused(&answer, 422, "invalid", "origin");
    // With the document's own origin, or with the mission's.
    let (status, expected) = server.post("/api/v1/coverage/evaluate", &local).await;
    assert_eq!(status, 200);
    let mut own = geo.clone();
    own["origin"] = origin_json(CANBERRA);
    let (status, with_own) = server.post("/api/v1/coverage/evaluate", &own).await;
    assert_eq!(status, 200, "{with_own}");
    let (status, _) = server
        .put("/api/v1/mission/origin", &origin_json(CANBERRA))
        .await;
    assert_eq!(status, 200);
    let (status, with_mission) = server.post("/api/v1/coverage/evaluate", &geo).await;
    assert_eq!(status, 200, "{with_mission}");
    assert_eq!(with_own, with_mission);
    let h = |v: &Value| v["H"].as_f64().unwrap();
    assert!(((h(&with_own) - h(&expected)) / h(&expected)).abs() < 1e-9);
    // Vessels at lat, lon in the mission's own region and risk.
    let only_vessels =
        json!({"vessels": [at_lat_lon(CANBERRA, &json!({"id": "a", "x": 30, "y": 40}))]});
    let (status, answer) = server
        .post("/api/v1/coverage/evaluate", &only_vessels)
        .await;
    assert_eq!(status, 200, "{answer}");
    // Another origin with the mission's region would mix two planes.
    let mut elsewhere = only_vessels.clone();
    elsewhere["origin"] = json!({"lat": 0, "lon": 0});
    let answer = server.post("/api/v1/coverage/evaluate", &elsewhere).await;
    refused(&answer, 422, "invalid", "origin");
    // An origin out of range names its coordinate.
    own["origin"] = json!({"lat": -95, "lon": 0});
    let answer = server.post("/api/v1/coverage/evaluate", &own).await;
    refused(&answer, 422, "invalid", "origin.lat");
}
