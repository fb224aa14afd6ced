//! The generated API documents: `api/openapi.json`,
//! `api/vessel-link.schema.json` and `api/peer-wire.schema.json` must be
//! what the code generates today, the server must serve the first, and all
//! must accept what the real server and the real protocol types put on the
//! wire (and reject what serde rejects), as an independent checker says
//! (Python's `jsonschema`, [`Validator`]). The worked beacon example in
//! `docs/peer.md` (its CBOR bytes, byte by byte, and the decoded map) must
//! be what the real encoder makes of it today.
//!
//! After changing the protocol types, the handlers' annotations or the
//! beacon's encoding, refresh the documents with
//! `SEACOVER_BLESS=1 cargo test --test it api_docs::` and commit them.

use std::path::PathBuf;
use std::time::Duration;

use crate::common::inprocess::Server;
use crate::common::schema::Validator;
use futures_util::{SinkExt, StreamExt};
use seacover::protocol::{
    CommandDocument, CoordinatorMessage, FixDocument, PoseDocument, VesselMessage,
};
use seacover::server::ServeConfig;
use seacover::server::openapi;
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

mod peer;

const REFRESH: &str = "SEACOVER_BLESS=1 cargo test --test it api_docs::";

fn blessing() -> bool {
    std::env::var_os("SEACOVER_BLESS").is_some_and(|v| v == "1")
}

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("api")
        .join(name)
}

/// Compares `generated` with the committed file, or rewrites the file when
/// blessing.
fn check_fresh(name: &str, generated: &str) {
    let file = path(name);
    if blessing() {
        std::fs::create_dir_all(file.parent().unwrap()).unwrap();
        std::fs::write(&file, generated).unwrap();
        eprintln!("wrote {}", file.display());
        return;
    }
    let committed = std::fs::read_to_string(&file).unwrap_or_default();
    if committed != generated {
        let line = committed
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| committed.lines().count().min(generated.lines().count()));
        panic!(
            "api/{name} is stale (first difference at line {}): the protocol types or the \
             handlers' #[utoipa::path] annotations changed. Refresh it with `{REFRESH}` \
             and commit the result.",
            line + 1
        );
    }
}

#[test]
fn openapi_document_is_fresh() {
    check_fresh("openapi.json", openapi::json());
}

#[test]
fn vessel_link_schema_is_fresh() {
    check_fresh("vessel-link.schema.json", &openapi::vessel_link_schema());
}

fn link_schema() -> Value {
    serde_json::from_str(&openapi::vessel_link_schema()).unwrap()
}

fn openapi_document() -> Value {
    serde_json::from_str(openapi::json()).unwrap()
}

/// Asserts that `schema` accepts `instance` (an independent checker says).
#[track_caller]
fn assert_valid(checker: &mut Validator, schema: &Value, instance: &Value) {
    let errors = checker.errors(schema, instance);
    assert!(errors.is_empty(), "{instance} was rejected: {errors:#?}");
}

/// Asserts that `schema` accepts each of `cases` exactly when serde does
/// (`serde_accepts`), as an independent checker says.
#[track_caller]
fn assert_agree(
    checker: &mut Validator,
    schema: &Value,
    cases: impl IntoIterator<Item = Value>,
    serde_accepts: impl Fn(&Value) -> bool,
) {
    for case in cases {
        let accepts = serde_accepts(&case);
        let errors = checker.errors(schema, &case);
        assert_eq!(
            errors.is_empty(),
            accepts,
            "{case}: serde {} it, the schema says {errors:?}",
            if accepts { "accepts" } else { "rejects" },
        );
    }
}

/// Whether serde reads `case` as a `T`.
fn reads<T: serde::de::DeserializeOwned>(case: &Value) -> bool {
    serde_json::from_value::<T>(case.clone()).is_ok()
}

/// Every `$ref` in `schema` points at a part of it that exists: the
/// documents stand alone.
fn assert_refs_resolve(name: &str, schema: &Value, node: &Value) {
    match node {
        Value::Object(map) => {
            if let Some(r) = map.get("$ref").and_then(Value::as_str) {
                let pointer = r
                    .strip_prefix('#')
                    .unwrap_or_else(|| panic!("{name}: {r} is not local"));
                assert!(
                    schema.pointer(pointer).is_some(),
                    "{name}: {r} points nowhere"
                );
            }
            map.values()
                .for_each(|v| assert_refs_resolve(name, schema, v));
        }
        Value::Array(items) => items
            .iter()
            .for_each(|v| assert_refs_resolve(name, schema, v)),
        _ => {}
    }
}

/// The OpenAPI component `name` as a stand-alone schema: its `$ref`s point
/// into `#/components/schemas`, which the wrapper carries along.
fn component(doc: &Value, name: &str) -> Value {
    assert!(
        doc["components"]["schemas"].get(name).is_some(),
        "no component {name}"
    );
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$ref": format!("#/components/schemas/{name}"),
        "components": {"schemas": doc["components"]["schemas"]},
    })
}

#[test]
fn the_documents_are_valid_schemas() {
    let Some(mut checker) = Validator::start("api_docs::the_documents_are_valid_schemas") else {
        return;
    };
    let link = link_schema();
    assert_eq!(
        checker.meta_errors(&link),
        Vec::<String>::new(),
        "the link schema"
    );
    assert_refs_resolve("the link schema", &link, &link);
    let doc = openapi_document();
    assert_eq!(doc["openapi"], "3.1.0");
    for name in doc["components"]["schemas"].as_object().unwrap().keys() {
        let schema = component(&doc, name);
        assert_eq!(checker.meta_errors(&schema), Vec::<String>::new(), "{name}");
        assert_refs_resolve(name, &schema, &schema);
    }
}

#[test]
fn the_documents_cover_every_endpoint_of_the_spec() {
    let doc = openapi_document();
    let paths = doc["paths"].as_object().unwrap();
    let expected: &[(&str, &[&str])] = &[
        ("/healthz", &["get"]),
        ("/metrics", &["get"]),
        ("/api/v1/openapi.json", &["get"]),
        ("/api/v1/mission", &["get"]),
        ("/api/v1/mission/origin", &["put"]),
        ("/api/v1/mission/region", &["put"]),
        ("/api/v1/mission/risk/base", &["put"]),
        ("/api/v1/mission/risk/raster", &["put"]),
        ("/api/v1/risk-objects", &["get", "post"]),
        ("/api/v1/risk-objects/{id}", &["get", "put", "delete"]),
        ("/api/v1/vessels", &["get"]),
        ("/api/v1/vessels/{id}", &["get", "delete"]),
        ("/api/v1/vessels/link", &["get"]),
        ("/api/v1/coverage", &["get"]),
        ("/api/v1/coverage.geojson", &["get"]),
        ("/api/v1/coverage/history", &["get"]),
        ("/api/v1/coverage/evaluate", &["post"]),
        ("/api/v1/stream", &["get"]),
        ("/api/v1/samples", &["post"]),
        ("/api/v1/risk", &["get"]),
    ];
    for (path, methods) in expected {
        let item = paths
            .get(*path)
            .unwrap_or_else(|| panic!("{path} is missing"));
        for method in *methods {
            let op = item
                .get(*method)
                .unwrap_or_else(|| panic!("{method} {path} is missing"));
            // The evaluation is a POST but changes nothing: it is public.
            let writes = (*method != "get" && *path != "/api/v1/coverage/evaluate")
                || *path == "/api/v1/vessels/link";
            assert_eq!(
                op.get("security").is_some(),
                writes,
                "{method} {path}: a bearer token guards writes and the link only"
            );
            if writes {
                assert!(op["responses"].get("401").is_some(), "{method} {path}");
            }
        }
    }
    assert_eq!(
        paths.len(),
        expected.len(),
        "undocumented or unexpected paths"
    );
    assert_eq!(
        doc["paths"]["/api/v1/risk-objects"]["post"]["responses"]["201"]["content"]["application/json"]
            ["schema"]["$ref"],
        "#/components/schemas/RiskObjectDocument"
    );
    for name in ["VesselMessage", "CoordinatorMessage", "SnapshotDocument"] {
        assert!(doc["components"]["schemas"].get(name).is_some(), "{name}");
    }
}

fn pose() -> PoseDocument {
    PoseDocument {
        t: 1.5,
        x: 67.583,
        y: 21.432,
        psi: 2.9884,
        u: 0.4,
        v: -0.01,
        r: 0.02,
        controlled: None,
        telemetry: None,
        fix: None,
    }
}

/// Messages of both directions built from the protocol types, serialized
/// by serde: the schema must accept each, and serde must read each back.
#[test]
fn the_link_schema_accepts_the_real_messages() {
    let Some(mut checker) = Validator::start("api_docs::the_link_schema_accepts_the_real_messages")
    else {
        return;
    };
    let schema = link_schema();
    let vessel = [
        VesselMessage::Hello {
            vessel: "usv-1".into(),
            protocol: 1,
            actuator: None,
            astern: None,
            agility: None,
            mission: None,
            station_radius: None,
        },
        VesselMessage::Hello {
            vessel: "usv-2".into(),
            protocol: 1,
            actuator: Some(seacover::protocol::ActuatorDocument {
                k: 0.5,
                beta: 0.001,
            }),
            astern: Some(false),
            agility: Some(seacover::protocol::AgilityDocument {
                yaw_accel: 0.75,
                surge_accel: 0.5,
            }),
            mission: Some("3f9a0c1de2b47a65".into()),
            station_radius: Some(3.0),
        },
        VesselMessage::Pose(pose()),
        VesselMessage::Pose(PoseDocument {
            telemetry: Some(json!({"battery": 0.93, "thrusters": [1.5, -0.2], "fault": null})),
            fix: None,
            ..pose()
        }),
        VesselMessage::Pose(PoseDocument {
            controlled: Some(false),
            telemetry: Some(json!({"mode": "HOLD", "armed": true})),
            fix: Some(FixDocument::Good),
            ..pose()
        }),
    ];
    for m in &vessel {
        assert_valid(&mut checker, &schema, &serde_json::to_value(m).unwrap());
    }
    let coordinator = [
        CoordinatorMessage::Welcome {
            vessel: "usv-1".into(),
            tick_hz: 10.0,
            mission: Some("3f9a0c1de2b47a65".into()),
        },
        CoordinatorMessage::Mission {
            mission: "0b71c2d4e5f60718".into(),
        },
        CoordinatorMessage::Command(CommandDocument {
            tick: 42,
            u_d: 1.2,
            r_d: -0.05,
            u_d_dot: 0.0,
            r_d_dot: 0.001,
            centroid: [63.67, 24.1],
            e: 3.25,
            psi_e: -0.4,
            hold: None,
            station: None,
        }),
        CoordinatorMessage::Error {
            code: "malformed".into(),
            message: "expected hello".into(),
        },
    ];
    for m in &coordinator {
        assert_valid(&mut checker, &schema, &serde_json::to_value(m).unwrap());
    }
}

/// What serde rejects, the schema rejects; what serde accepts beyond what it
/// emits (omitted optional fields, `null` for them, the tag anywhere, integer
/// numbers), the schema accepts.
#[test]
fn the_link_schema_agrees_with_serde_on_edge_cases() {
    let Some(mut checker) =
        Validator::start("api_docs::the_link_schema_agrees_with_serde_on_edge_cases")
    else {
        return;
    };
    let schema = link_schema();
    let cases = [
        json!({"type": "hello", "vessel": "a", "protocol": 1, "actuator": null}),
        json!({"vessel": "a", "protocol": 1, "type": "hello"}),
        json!({"type": "pose", "t": 0, "x": 1, "y": 2, "psi": 0, "u": 0, "v": 0, "r": 0, "telemetry": null}),
        json!({"type": "pose", "t": 0, "x": 1, "y": 2, "psi": 0, "u": 0, "v": 0, "r": 0, "extra": true}),
        json!({"type": "hello", "protocol": 1}),
        json!({"type": "hello", "vessel": "a", "protocol": "1"}),
        json!({"type": "hello", "vessel": "a", "protocol": -1}),
        json!({"type": "hello", "vessel": "a", "protocol": 1, "actuator": {"k": 1}}),
        json!({"type": "hello", "vessel": "a", "protocol": 1, "agility": {"yaw_accel": 0.5, "surge_accel": 1}}),
        json!({"type": "hello", "vessel": "a", "protocol": 1, "agility": {"yaw_accel": 0.5}}),
        json!({"type": "hello", "vessel": "a", "protocol": 1, "agility": null}),
        json!({"type": "pose", "t": 0, "x": 1, "y": 2, "psi": 0, "u": 0, "v": 0}),
        json!({"type": "pose", "t": 0, "x": "1", "y": 2, "psi": 0, "u": 0, "v": 0, "r": 0}),
        json!({"type": "Pose", "t": 0, "x": 1, "y": 2, "psi": 0, "u": 0, "v": 0, "r": 0}),
        json!({"t": 0, "x": 1, "y": 2, "psi": 0, "u": 0, "v": 0, "r": 0}),
        json!({"type": "command", "tick": 1, "u_d": 0, "r_d": 0, "u_d_dot": 0, "r_d_dot": 0, "centroid": [1, 2], "E": 0, "psi_e": 0}),
        json!({"type": "command", "tick": 1, "u_d": 0, "r_d": 0, "u_d_dot": 0, "r_d_dot": 0, "centroid": [1, 2], "e": 0, "psi_e": 0}),
        json!({"type": "command", "tick": 1, "u_d": 0, "r_d": 0, "u_d_dot": 0, "r_d_dot": 0, "centroid": [1, 2, 3], "E": 0, "psi_e": 0}),
        json!({"type": "command", "tick": 1, "u_d": 0, "r_d": 0, "u_d_dot": 0, "r_d_dot": 0, "centroid": [1], "E": 0, "psi_e": 0}),
        json!({"type": "welcome", "vessel": "a", "tick_hz": 10}),
        json!({"type": "welcome", "vessel": "a"}),
        json!({"type": "error", "code": "invalid", "message": "no"}),
        json!({"type": "error", "code": "invalid"}),
        json!("hello"),
        json!([{"type": "hello", "vessel": "a", "protocol": 1}]),
    ];
    assert_agree(&mut checker, &schema, cases, |case| {
        reads::<VesselMessage>(case) || reads::<CoordinatorMessage>(case)
    });
}

/// A curved cell's edges: the schema accepts exactly what serde accepts.
#[test]
fn the_edge_schema_agrees_with_serde() {
    let Some(mut checker) = Validator::start("api_docs::the_edge_schema_agrees_with_serde") else {
        return;
    };
    use seacover::protocol::EdgeDocument;
    let doc = openapi_document();
    let schema = component(&doc, "EdgeDocument");
    let cases = [
        json!({"kind": "segment", "from": [0, 0], "to": [1.5, 2]}),
        json!({"kind": "arc", "centre": [50, 50], "radius": 20, "start": 0, "sweep": -6.0}),
        json!({"kind": "arc", "centre": [50, 50], "radius": 20, "start": 0}),
        json!({"kind": "arc", "centre": [50], "radius": 20, "start": 0, "sweep": 1}),
        json!({"kind": "segment", "from": [0, 0, 0], "to": [1, 2]}),
        json!({"kind": "circle", "centre": [0, 0], "radius": 1}),
        json!({"from": [0, 0], "to": [1, 2]}),
        json!({"kind": "segment", "from": [0, 0], "to": "here"}),
    ];
    assert_agree(&mut checker, &schema, cases, reads::<EdgeDocument>);
}

/// The request bodies' schemas in the OpenAPI document accept exactly what
/// serde accepts.
#[test]
fn the_openapi_request_schemas_agree_with_serde() {
    let Some(mut checker) =
        Validator::start("api_docs::the_openapi_request_schemas_agree_with_serde")
    else {
        return;
    };
    use seacover::protocol::{
        RegionDocument, RegionInput, RiskObjectDocument, RiskObjectInput, ScenarioDocument,
    };
    let doc = openapi_document();
    let square = json!([[0, 0], [10, 0], [10, 10], [0, 10]]);
    let vessel = json!({"id": "a", "x": 1, "y": 2});
    let geo_vessel = json!({"id": "b", "lat": 1.001, "lon": 2});
    let geojson =
        json!({"type": "Polygon", "coordinates": [[[2, 1], [2.001, 1], [2, 1.001], [2, 1]]]});
    let scenarios = [
        json!({"vessels": [vessel]}),
        json!({"name": "n", "region": {"polygon": square}, "risk": {"base": 0.1}, "vessels": []}),
        json!({"region": {"polygon": square, "holes": [[[1, 1], [2, 1], [2, 2]]]}, "vessels": [vessel]}),
        json!({"region": null, "risk": null, "vessels": [vessel]}),
        json!({"vessels": [{"id": "a", "x": 1, "y": 2, "psi": 0.5, "k": 1, "beta": 0.001}]}),
        json!({"vessels": [{"id": "a", "x": 1, "y": 2, "psi": null}]}),
        json!({"region": {"polygon": square}}),
        json!({"region": {"polygon": [[0, 0, 0], [1, 0], [1, 1]]}, "vessels": []}),
        json!({"region": {"polygon": [[0], [1, 0], [1, 1]]}, "vessels": []}),
        json!({"region": {"holes": []}, "vessels": []}),
        json!({"risk": {"objects": []}, "vessels": []}),
        json!({"risk": {"base": 1, "objects": [{"x": 1, "y": 1, "alpha": 1}]}, "vessels": []}),
        json!({"vessels": [{"id": 7, "x": 1, "y": 2}]}),
        json!({"vessels": [{"x": 1, "y": 2}]}),
        json!({"vessels": {}}),
        // Geo-referenced: GeoJSON regions, objects and vessels at lat, lon.
        json!({"origin": {"lat": 1, "lon": 2}, "region": geojson, "vessels": [geo_vessel]}),
        json!({"origin": {"lat": 1}, "vessels": []}),
        json!({"region": {"type": "Feature", "geometry": null, "properties": {}}, "vessels": []}),
        json!({"region": {"type": "Polygon"}, "vessels": []}),
        json!({"region": {"type": "Polygon", "coordinates": [[[1, 2], [3, 4]]], "polygon": square}, "vessels": []}),
        json!({"risk": {"base": 1, "objects": [{"lat": 1, "lon": 2, "alpha": 1, "sigma": 1}]}, "vessels": []}),
        json!({"risk": {"base": 1, "objects": [{"lat": 1, "alpha": 1, "sigma": 1}]}, "vessels": []}),
        json!({"vessels": [{"id": "a", "lat": 1, "lon": 2, "psi": 0.5}]}),
        json!({"vessels": [{"id": "a", "x": 1, "y": 2, "lat": 1, "lon": 2}]}),
        json!({"vessels": [{"id": "a", "x": 1, "y": 2, "lat": 1}]}),
        json!({"vessels": [{"id": "a", "x": 1, "lat": 1, "lon": 2}]}),
        json!({"vessels": [{"id": "a", "lat": "1", "lon": 2}]}),
    ];
    let schema = component(&doc, "ScenarioDocument");
    assert_agree(&mut checker, &schema, scenarios, reads::<ScenarioDocument>);
    let objects = [
        json!({"x": 1, "y": 2, "alpha": 3, "sigma": 4}),
        json!({"id": "o", "x": 1, "y": 2, "alpha": 3, "sigma": 4}),
        json!({"id": null, "x": 1, "y": 2, "alpha": 3, "sigma": 4}),
        json!({"x": 1, "y": 2, "alpha": 3}),
        json!({"x": "1", "y": 2, "alpha": 3, "sigma": 4}),
    ];
    let schema = component(&doc, "RiskObjectDocument");
    assert_agree(&mut checker, &schema, objects, reads::<RiskObjectDocument>);
    let regions = [
        json!({"polygon": square}),
        json!({"polygon": square, "holes": []}),
        json!({"holes": []}),
        json!({"polygon": [[1, 2], [3]]}),
    ];
    let schema = component(&doc, "RegionDocument");
    assert_agree(
        &mut checker,
        &schema,
        regions.iter().cloned(),
        reads::<RegionDocument>,
    );
    // What PUT /api/v1/mission/region reads: those, or GeoJSON.
    let inputs = regions.iter().cloned().chain([
        geojson.clone(),
        json!({"type": "Feature", "properties": {"name": "bay"}, "geometry": geojson}),
        json!({"type": "FeatureCollection", "features": []}),
        json!({"type": "LineString", "coordinates": [[1, 2], [3, 4]]}),
        json!({"type": "Polygon"}),
        json!({"type": "Polygon", "coordinates": [[[1, 2], [3, 4]]], "polygon": square}),
        json!({"type": "Circle", "coordinates": [1, 2]}),
        json!({"type": 7}),
    ]);
    let schema = component(&doc, "RegionInput");
    assert_agree(&mut checker, &schema, inputs, reads::<RegionInput>);
    // What the risk-object writes read: at x, y or at lat, lon.
    let objects = [
        json!({"x": 1, "y": 2, "alpha": 3, "sigma": 4}),
        json!({"id": "o", "lat": 1, "lon": 2, "alpha": 3, "sigma": 4}),
        json!({"lat": 1, "lon": 2, "alpha": 3}),
        json!({"lat": 1, "alpha": 3, "sigma": 4}),
        json!({"x": 1, "y": 2, "lat": 1, "lon": 2, "alpha": 3, "sigma": 4}),
        json!({"x": 1, "y": 2, "lat": 1, "alpha": 3, "sigma": 4}),
        json!({"x": 1, "lat": 1, "lon": 2, "alpha": 3, "sigma": 4}),
        json!({"lat": "1", "lon": 2, "alpha": 3, "sigma": 4}),
        json!([1, 2]),
    ];
    let schema = component(&doc, "RiskObjectInput");
    assert_agree(&mut checker, &schema, objects, reads::<RiskObjectInput>);
}

async fn start() -> Server {
    Server::start(ServeConfig {
        time_warp: 10.0,
        ..Default::default()
    })
    .await
}

async fn get(server: &Server, path: &str) -> (u16, Value) {
    let response = reqwest::get(server.http(path)).await.unwrap();
    let status = response.status().as_u16();
    (status, response.json().await.unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_server_serves_the_committed_document() {
    let server = start().await;
    let response = reqwest::get(server.http("/api/v1/openapi.json"))
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    assert_eq!(
        response.headers()["content-type"].to_str().unwrap(),
        "application/json"
    );
    let served = response.text().await.unwrap();
    // While blessing the file is being rewritten by another test.
    let expected = if blessing() {
        openapi::json().to_string()
    } else {
        std::fs::read_to_string(path("openapi.json")).unwrap()
    };
    assert!(
        served == expected,
        "GET /api/v1/openapi.json differs from api/openapi.json; refresh it with `{REFRESH}`"
    );
    server.stop().await;
}

/// A real vessel link and real REST answers, each checked against the
/// documents: the frames against the link schema, the bodies against the
/// OpenAPI components their operations name.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_real_server_speaks_as_documented() {
    let Some(mut checker) = Validator::start("api_docs::the_real_server_speaks_as_documented")
    else {
        return;
    };
    let link = link_schema();
    let doc = openapi_document();
    let server = start().await;

    let url = server.ws();
    let (socket, _) = tokio_tungstenite::connect_async(url.as_str())
        .await
        .unwrap();
    let (mut sink, mut stream) = socket.split();
    let mut next = async || loop {
        match tokio::time::timeout(Duration::from_secs(5), stream.next())
            .await
            .expect("a frame in time")
        {
            Some(Ok(Message::Text(t))) => return serde_json::from_str::<Value>(&t).unwrap(),
            Some(Ok(_)) => continue,
            other => panic!("the link ended: {other:?}"),
        }
    };
    let hello = json!({"type": "hello", "vessel": "usv-1", "protocol": 1});
    assert_valid(&mut checker, &link, &hello);
    sink.send(Message::text(hello.to_string())).await.unwrap();
    let welcome = next().await;
    assert_eq!(welcome["type"], "welcome");
    assert_valid(&mut checker, &link, &welcome);

    let pose = serde_json::to_value(VesselMessage::Pose(PoseDocument {
        x: 30.0,
        y: 40.0,
        ..pose()
    }))
    .unwrap();
    assert_valid(&mut checker, &link, &pose);
    sink.send(Message::text(pose.to_string())).await.unwrap();
    let command = loop {
        let frame = next().await;
        assert_valid(&mut checker, &link, &frame);
        if frame["type"] == "command" {
            break frame;
        }
    };
    assert!(command["E"].is_number(), "{command}");

    sink.send(Message::text("{\"type\": \"pose\"}"))
        .await
        .unwrap();
    let error = loop {
        let frame = next().await;
        assert_valid(&mut checker, &link, &frame);
        if frame["type"] == "error" {
            break frame;
        }
    };
    assert_eq!(error["code"], "malformed", "{error}");

    // REST reads, with the vessel in the partition.
    for (path, name, array) in [
        ("/api/v1/mission", "MissionDocument", false),
        ("/api/v1/coverage", "CoverageDocument", false),
        ("/api/v1/vessels", "VesselStatusDocument", true),
        ("/api/v1/vessels/usv-1", "VesselStatusDocument", false),
        ("/api/v1/risk-objects", "RiskObjectDocument", true),
    ] {
        let (status, body) = get(&server, path).await;
        assert_eq!(status, 200, "{path}: {body}");
        let schema = component(&doc, name);
        if array {
            let items = body.as_array().unwrap();
            assert!(!items.is_empty(), "{path}");
            for item in items {
                assert_valid(&mut checker, &schema, item);
            }
        } else {
            assert_valid(&mut checker, &schema, &body);
        }
    }
    let (status, body) = get(&server, "/api/v1/vessels/nobody").await;
    assert_eq!(status, 404);
    assert_valid(&mut checker, &component(&doc, "ErrorDocument"), &body);

    // The what-if evaluation: request and answer.
    let scenario: Value = serde_json::from_str(
        &std::fs::read_to_string(
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/paper.json"),
        )
        .unwrap(),
    )
    .unwrap();
    assert_valid(
        &mut checker,
        &component(&doc, "ScenarioDocument"),
        &scenario,
    );
    let client = reqwest::Client::new();
    let response = client
        .post(server.http("/api/v1/coverage/evaluate"))
        .json(&scenario)
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let evaluation: Value = response.json().await.unwrap();
    assert_valid(
        &mut checker,
        &component(&doc, "EvaluationDocument"),
        &evaluation,
    );
    // A fleet with different β: curved cells with their `edges`.
    let mut mixed = scenario.clone();
    mixed["vessels"][6]["beta"] = json!(0.004);
    let response = client
        .post(server.http("/api/v1/coverage/evaluate"))
        .json(&mixed)
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let evaluation: Value = response.json().await.unwrap();
    assert!(evaluation["cells"][6]["edges"].is_array(), "{evaluation}");
    assert_valid(
        &mut checker,
        &component(&doc, "EvaluationDocument"),
        &evaluation,
    );
    let response = client
        .post(server.http("/api/v1/coverage/evaluate"))
        .body("{\"vessels\": 3}")
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 400);
    let error: Value = response.json().await.unwrap();
    assert_valid(&mut checker, &component(&doc, "ErrorDocument"), &error);

    // A write, answered as documented (201 and the stored object).
    let object = json!({"x": 10, "y": 20, "alpha": 3, "sigma": 5});
    assert_valid(
        &mut checker,
        &component(&doc, "RiskObjectDocument"),
        &object,
    );
    let response = client
        .post(server.http("/api/v1/risk-objects"))
        .json(&object)
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 201);
    let stored: Value = response.json().await.unwrap();
    assert_valid(
        &mut checker,
        &component(&doc, "RiskObjectDocument"),
        &stored,
    );
    assert!(stored["id"].is_string(), "{stored}");

    // The base density's body, documented as RiskBaseDocument.
    let base = json!({"value": 0.2});
    assert_valid(&mut checker, &component(&doc, "RiskBaseDocument"), &base);
    let response = client
        .put(server.http("/api/v1/mission/risk/base"))
        .json(&base)
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let mission: Value = response.json().await.unwrap();
    assert_valid(&mut checker, &component(&doc, "MissionDocument"), &mission);

    // Geo-referenced writes: the origin, a GeoJSON region and an object at
    // lat, lon, each body valid against its operation's request schema and
    // each answer against its response's.
    let origin = json!({"lat": -35.363261, "lon": 149.16523});
    assert_valid(&mut checker, &component(&doc, "OriginDocument"), &origin);
    let response = client
        .put(server.http("/api/v1/mission/origin"))
        .json(&origin)
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let mission: Value = response.json().await.unwrap();
    assert_valid(&mut checker, &component(&doc, "MissionDocument"), &mission);
    assert_eq!(mission["origin"], origin);
    let ring = json!([
        [149.16523, -35.363261],
        [149.1664, -35.363261],
        [149.1664, -35.3623],
        [149.16523, -35.3623],
        [149.16523, -35.363261]
    ]);
    let region = json!({"type": "Feature", "properties": {"name": "bay"},
                        "geometry": {"type": "Polygon", "coordinates": [ring]}});
    assert_valid(&mut checker, &component(&doc, "RegionInput"), &region);
    let response = client
        .put(server.http("/api/v1/mission/region"))
        .json(&region)
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    let mission: Value = response.json().await.unwrap();
    assert_valid(&mut checker, &component(&doc, "MissionDocument"), &mission);
    let object = json!({"lat": -35.3628, "lon": 149.1658, "alpha": 3, "sigma": 5});
    assert_valid(&mut checker, &component(&doc, "RiskObjectInput"), &object);
    let response = client
        .post(server.http("/api/v1/risk-objects"))
        .json(&object)
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 201);
    let stored: Value = response.json().await.unwrap();
    assert_valid(
        &mut checker,
        &component(&doc, "RiskObjectDocument"),
        &stored,
    );
    let response = reqwest::get(server.http("/api/v1/coverage.geojson"))
        .await
        .unwrap();
    assert_eq!(response.status(), 200);
    assert_eq!(
        response.headers()["content-type"].to_str().unwrap(),
        "application/geo+json"
    );

    drop(sink);
    server.stop().await;
}
