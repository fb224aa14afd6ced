//! The peer wire (docs/peer.md): its JSON Schema, generated here from the
//! protocol types, and the worked beacon example, made by the real encoder.

use std::path::PathBuf;

use schemars::generate::SchemaSettings;
use seacover::agent::peer::wire;
use seacover::protocol::peer::{
    BeaconDocument, PeerMissionDocument, PeerSampleDocument, PeerStatusDocument,
};
use serde_json::{Value, json};

use super::{
    REFRESH, assert_agree, assert_refs_resolve, assert_valid, blessing, check_fresh, reads,
};
use crate::common::schema::Validator;

/// `api/peer-wire.schema.json`: the three documents of the peer wire, each
/// titled with its key expression.
fn peer_wire_schema() -> String {
    let mut generator = SchemaSettings::draft2020_12().into_generator();
    let beacon = generator.subschema_for::<BeaconDocument>();
    let mission = generator.subschema_for::<PeerMissionDocument>();
    let status = generator.subschema_for::<PeerStatusDocument>();
    let sample = generator.subschema_for::<PeerSampleDocument>();
    let mut defs = generator.take_definitions(true);
    let keyed = [
        (
            "BeaconDocument",
            "seacover/<fleet>/beacon/<id>",
            format!(
                "Put by vessel <id> 5 times a second of its mission time, express and dropped \
                 on congestion. Payload: this map in CBOR (RFC 8949), at most {} bytes; \
                 validated here in its JSON form.",
                wire::MAX_BEACON
            ),
        ),
        (
            "PeerMissionDocument",
            "seacover/<fleet>/mission",
            format!(
                "Put by the member that changes the mission (a coordinator with `serve --peer`) \
                 and the reply of every member to a query on the key. Payload: this document \
                 in JSON, at most {} bytes.",
                wire::MAX_MISSION
            ),
        ),
        (
            "PeerStatusDocument",
            "seacover/<fleet>/status/<id>",
            "The reply of vessel <id>'s node to a query on the key (never put). Payload: \
             this document in JSON."
                .to_string(),
        ),
        (
            "PeerSampleDocument",
            "seacover/<fleet>/sample/<id>",
            format!(
                "Put by vessel <id>, in a fleet that learns (docs/learning.md), for its \
                 measurements of the risk field every {} s, reliable but dropped on \
                 congestion. Payload: a CBOR array of at most {} of these maps (each at most \
                 {} bytes). A query on `seacover/<fleet>/samples/<id>?from=N` is answered by \
                 every member that holds them with such an array, numbered N or more, at most \
                 {} in an answer.",
                seacover::agent::peer::learn::BATCH_EVERY,
                seacover::agent::peer::samples::MAX_BATCH,
                seacover::agent::peer::samples::MAX_SAMPLE,
                seacover::agent::peer::samples::MAX_ANSWER
            ),
        ),
    ];
    for (name, key, lead) in keyed {
        let def = defs
            .get_mut(name)
            .unwrap_or_else(|| panic!("no definition {name}"));
        let own = def["description"].as_str().unwrap_or_default().to_string();
        def["title"] = json!(format!("`{key}`"));
        def["description"] = json!(format!("Key expression `{key}`. {lead} {own}"));
    }
    for def in defs.values_mut() {
        bound_unsigned(def);
    }
    let (_, decoded) = beacon_example();
    defs["BeaconDocument"]["examples"] = json!([decoded]);
    let description = format!(
        "What the members of a peer fleet (docs/peer.md) put on Eclipse Zenoh; \
         `<fleet>` is the fleet's name and `<id>` a vessel's id (each `[A-Za-z0-9_.-]{{1,64}}`). \
         `seacover/<fleet>/beacon/<id>`: a `BeaconDocument` in CBOR. \
         `seacover/<fleet>/alive/<id>`: a liveliness token (no payload), held while vessel <id> \
         runs. `seacover/<fleet>/mission`: a `PeerMissionDocument` in JSON. \
         `seacover/<fleet>/status/<id>`: a `PeerStatusDocument` in JSON, answered to queries. \
         `seacover/<fleet>/sample/<id>`: an array of `PeerSampleDocument` in CBOR (a fleet \
         that learns). \
         The key expression says which document a payload is; a beacon's CBOR map is \
         validated in its JSON form (text, unsigned integers, floats and booleans map one to \
         one). Shapes only: a member refuses, and counts by reason, a beacon over {} bytes, \
         with a non-finite value, a position beyond {} m of the origin, a speed over {} m/s, a \
         yaw rate over {} rad/s, an actuator the engine refuses or an id other than its key's, \
         and a mission document that fails the mission's validation or is not newer than the \
         one it holds.",
        wire::MAX_BEACON,
        wire::MAX_POSITION,
        wire::MAX_SPEED,
        wire::MAX_YAW_RATE,
    );
    let schema = json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "seacover peer wire",
        "description": description,
        "oneOf": [beacon, mission, status, sample],
        "$defs": defs,
    });
    let mut text = serde_json::to_string_pretty(&schema).expect("the schema serializes");
    text.push('\n');
    text
}

/// schemars bounds an unsigned integer's schema below, and above only up
/// to 16 bits: this adds the upper bound that serde enforces to the wider
/// ones (`rev` is a u32: 2^32 is not a revision).
fn bound_unsigned(schema: &mut Value) {
    match schema {
        Value::Object(map) => {
            let top = match map.get("format").and_then(Value::as_str) {
                Some("uint32") => Some(u64::from(u32::MAX)),
                Some("uint64" | "uint") => Some(u64::MAX),
                _ => None,
            };
            if let Some(top) = top
                && !map.contains_key("maximum")
            {
                map.insert("maximum".into(), json!(top));
            }
            map.values_mut().for_each(bound_unsigned);
        }
        Value::Array(items) => items.iter_mut().for_each(bound_unsigned),
        _ => {}
    }
}

fn peer_wire_schema_value() -> Value {
    serde_json::from_str(&peer_wire_schema()).unwrap()
}

#[test]
fn peer_wire_schema_is_fresh() {
    check_fresh("peer-wire.schema.json", &peer_wire_schema());
}

/// The worked example's beacon: usv-3 of the paper's fleet near its
/// centroid, as its node fills it in.
fn example_beacon() -> BeaconDocument {
    let (k, beta) = wire::wire_actuator(0.5, 0.001);
    BeaconDocument {
        id: "usv-3".into(),
        seq: 123,
        t: 1_795_000_000.25,
        x: 63.67,
        y: 24.1,
        psi: 2.9884,
        u: 0.4,
        v: -0.01,
        r: 0.02,
        k,
        beta,
        rev: 2,
        controlled: true,
    }
}

/// The example's bytes, by the real encoder, and what the real decoder
/// reads back from them.
fn beacon_example() -> (Vec<u8>, BeaconDocument) {
    let bytes = wire::encode(&example_beacon());
    let decoded = wire::decode(&bytes, "usv-3").expect("the example decodes");
    (bytes, decoded)
}

/// The first CBOR data item of `bytes`, of the kinds a beacon holds: its
/// length (for a map, its header's) and its kind.
fn cbor_item(bytes: &[u8]) -> (usize, String) {
    let (major, info) = (bytes[0] >> 5, bytes[0] & 0x1f);
    let width = match info {
        0..=23 => 0,
        24 => 1,
        25 => 2,
        26 => 4,
        27 => 8,
        _ => panic!("no indefinite lengths in a beacon"),
    };
    let argument = if width == 0 {
        u64::from(info)
    } else {
        bytes[1..=width]
            .iter()
            .fold(0u64, |a, b| (a << 8) | u64::from(*b))
    };
    match (major, info) {
        (0, _) => (1 + width, "unsigned integer".into()),
        (3, _) => (
            1 + width + argument as usize,
            format!("text, {argument} bytes"),
        ),
        (5, _) => (1 + width, format!("map of {argument} pairs")),
        (7, 20) => (1, "false".into()),
        (7, 21) => (1, "true".into()),
        (7, 25) => (3, "float16".into()),
        (7, 26) => (5, "float32".into()),
        (7, 27) => (9, "float64".into()),
        _ => panic!("a beacon holds no CBOR item {:02x}", bytes[0]),
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The generated part of docs/peer.md: the example beacon's bytes, each
/// field's share of them, and the decoded map.
fn beacon_example_markdown() -> String {
    let given = serde_json::to_value(example_beacon()).unwrap();
    let (bytes, decoded) = beacon_example();
    let back = serde_json::to_value(&decoded).unwrap();
    let mut out = String::new();
    out.push_str(&format!(
        "`wire::encode` of `usv-3` at (63.67, 24.1) m, heading 2.9884 rad, 0.4 m/s ahead, \
         on mission revision 2, beacon number 1234, sent at t = 1795000000.25 \
         (2026-11-18T11:06:40.25Z): {} bytes.\n\n```text\n",
        bytes.len()
    ));
    for (i, line) in bytes.chunks(16).enumerate() {
        out.push_str(&format!("{:04x}  {}\n", i * 16, hex(line)));
    }
    out.push_str(
        "```\n\n| key | key bytes | value bytes | value as CBOR | decoded | given to the encoder |\n\
         | --- | --- | --- | --- | ---: | ---: |\n",
    );
    let (header, kind) = cbor_item(&bytes);
    out.push_str(&format!(
        "| | `{}` | | {kind} | | |\n",
        hex(&bytes[..header])
    ));
    let mut at = header;
    while at < bytes.len() {
        let (key_len, _) = cbor_item(&bytes[at..]);
        let key_bytes = &bytes[at..at + key_len];
        let key = std::str::from_utf8(&key_bytes[1..]).unwrap();
        at += key_len;
        let (value_len, kind) = cbor_item(&bytes[at..]);
        let value_bytes = &bytes[at..at + value_len];
        at += value_len;
        out.push_str(&format!(
            "| `{key}` | `{}` | `{}` | {kind} | `{}` | `{}` |\n",
            hex(key_bytes),
            hex(value_bytes),
            back[key],
            given[key],
        ));
    }
    out.push_str(&format!(
        "\n`wire::decode` reads it back as (JSON):\n\n```json\n{}\n```\n",
        serde_json::to_string_pretty(&decoded).unwrap()
    ));
    out
}

const PEER_DOC_BEGIN: &str = "<!-- generated by tests/it/api_docs/peer.rs from wire::encode; SEACOVER_BLESS=1 refreshes -->\n";
const PEER_DOC_END: &str = "<!-- end of the generated example -->";

#[test]
fn the_beacon_example_in_docs_peer_is_fresh() {
    let (bytes, decoded) = beacon_example();
    assert!(bytes.len() <= wire::MAX_BEACON, "{} bytes", bytes.len());
    assert_eq!(decoded, wire::quantize(&example_beacon()));
    let generated = beacon_example_markdown();
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("docs/peer.md");
    let text = std::fs::read_to_string(&file).unwrap();
    let begin = text
        .find(PEER_DOC_BEGIN)
        .expect("docs/peer.md has the generated example's opening marker")
        + PEER_DOC_BEGIN.len();
    let end = begin
        + text[begin..]
            .find(PEER_DOC_END)
            .expect("docs/peer.md has the generated example's closing marker");
    if blessing() {
        let fresh = format!("{}{generated}{}", &text[..begin], &text[end..]);
        std::fs::write(&file, fresh).unwrap();
        eprintln!("wrote {}", file.display());
        return;
    }
    assert!(
        text[begin..end] == generated,
        "the beacon example in docs/peer.md is not what wire::encode makes today; refresh it \
         with `{REFRESH}` and commit the result. Generated:\n{generated}"
    );
}

/// The real documents of the peer wire, each valid against the schema and
/// against its own key's definition only.
#[test]
fn the_peer_wire_schema_accepts_the_real_documents() {
    let Some(mut checker) =
        Validator::start("api_docs::peer::the_peer_wire_schema_accepts_the_real_documents")
    else {
        return;
    };
    let schema = peer_wire_schema_value();
    let errors = checker.meta_errors(&schema);
    assert!(errors.is_empty(), "the peer wire schema: {errors:?}");
    assert_refs_resolve("the peer wire schema", &schema, &schema);
    let only = |name: &str| {
        json!({
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "$ref": format!("#/$defs/{name}"),
            "$defs": schema["$defs"],
        })
    };
    let (bytes, decoded) = beacon_example();
    // The CBOR map in its JSON form, as a generic CBOR reader sees it.
    let value: ciborium::Value = ciborium::from_reader(bytes.as_slice()).unwrap();
    let generic: Value = value.deserialized().unwrap();
    assert_eq!(generic, serde_json::to_value(&decoded).unwrap());
    let mission = serde_json::to_value(PeerMissionDocument {
        revision: 7,
        mission: seacover::mission::Mission::paper().document(),
        by: Some("seacover serve --peer on shore-1: PUT /api/v1/mission/region".into()),
        at: Some("2026-11-27T22:00:00Z".into()),
    })
    .unwrap();
    let status = |revision| {
        serde_json::to_value(PeerStatusDocument {
            id: "usv-1".into(),
            revision,
            controlled: revision.is_some(),
            neighbours: 2,
            partition_since: revision.map(|_| 1_795_000_000.25),
            heard: [("usv-2".to_string(), 0.13), ("usv-9".to_string(), 4.2)].into(),
            refused: [("oversized".to_string(), 1), ("jump".to_string(), 2)].into(),
            quarantined: [(
                "usv-9".to_string(),
                "moved at 31.2 m/s since its last believed pose, beyond the hull's limit"
                    .to_string(),
            )]
            .into(),
            received: 1523,
            split: revision.map(|_| vec!["usv-5".to_string(), "usv-6".to_string()]),
            split_water: revision.map(|_| seacover::protocol::peer::SplitWater::Own),
            alone: revision.is_none(),
            learning: None,
            step_time: revision.map(|_| seacover::protocol::peer::StepTimeDocument {
                steps: 100,
                median_ms: 0.42,
                max_ms: 3.1,
            }),
        })
        .unwrap()
    };
    let sample_bytes = seacover::agent::peer::samples::encode(&[PeerSampleDocument {
        id: "usv-1".into(),
        n: 41,
        t: 1_795_000_000.5,
        x: 61.25,
        y: 24.5,
        value: 7.93,
        sd: 0.65,
    }]);
    let sample_value: ciborium::Value = ciborium::from_reader(sample_bytes.as_slice()).unwrap();
    let batch: Vec<Value> = sample_value.deserialized().unwrap();
    let sample = batch[0].clone();
    let documents = [
        ("BeaconDocument", generic),
        ("PeerSampleDocument", sample),
        ("PeerMissionDocument", mission),
        ("PeerStatusDocument", status(Some(7))),
        ("PeerStatusDocument", status(None)),
    ];
    for (name, document) in &documents {
        assert_valid(&mut checker, &schema, document);
        for other in [
            "BeaconDocument",
            "PeerMissionDocument",
            "PeerStatusDocument",
            "PeerSampleDocument",
        ] {
            let errors = checker.errors(&only(other), document);
            assert_eq!(
                errors.is_empty(),
                other == *name,
                "{name} as {other}: {errors:?}"
            );
        }
    }
}

/// Beacons: what serde rejects, the schema rejects, and the other way round.
#[test]
fn the_peer_wire_schema_agrees_with_serde_on_beacons() {
    let Some(mut checker) =
        Validator::start("api_docs::peer::the_peer_wire_schema_agrees_with_serde_on_beacons")
    else {
        return;
    };
    let schema = peer_wire_schema_value();
    let beacon = serde_json::to_value(beacon_example().1).unwrap();
    let with = |key: &str, value: Value| {
        let mut b = beacon.clone();
        b[key] = value;
        b
    };
    let without = |key: &str| {
        let mut b = beacon.clone();
        b.as_object_mut().unwrap().remove(key);
        b
    };
    let cases = [
        beacon.clone(),
        with("t", json!(1_795_000_000)),
        with("seq", json!(65_535)),
        with("seq", json!(65_536)),
        with("seq", json!(-1)),
        with("rev", json!(4_294_967_295u64)),
        with("rev", json!(4_294_967_296u64)),
        with("rev", json!(2.5)),
        with("rev", json!("2")),
        with("controlled", json!(1)),
        with("x", json!(null)),
        with("extra", json!(true)),
        without("controlled"),
        without("beta"),
    ];
    assert_agree(&mut checker, &schema, cases, reads::<BeaconDocument>);
}
