//! A vessel's form is chosen by its keys, read in one pass
//! (`choose::VesselKeys`): what it accepts and refuses, and with which
//! message.

use super::*;

fn vessel(text: &str) -> Result<VesselInput, String> {
    serde_json::from_str(text).map_err(|e| e.to_string())
}

#[test]
fn a_vessel_is_local_or_geographic_by_its_keys() {
    assert_eq!(
        vessel(r#"{"id": "a", "x": 1, "y": 2.5, "beta": 0.004}"#),
        Ok(VesselInput::Local(VesselDocument {
            id: "a".into(),
            x: 1.0,
            y: 2.5,
            psi: None,
            k: None,
            beta: Some(0.004),
        }))
    );
    assert_eq!(
        vessel(r#"{"id": "b", "lat": 59.4, "lon": 10.5, "psi": 0.1, "k": 0.7}"#),
        Ok(VesselInput::Geo(GeoVesselDocument {
            id: "b".into(),
            lat: 59.4,
            lon: 10.5,
            psi: Some(0.1),
            k: Some(0.7),
            beta: None,
        }))
    );
}

#[test]
fn a_vessel_is_refused_against_the_form_it_meant() {
    let refused = |text: &str, expect: &str| {
        let e = vessel(text).expect_err(text);
        assert!(e.contains(expect), "{text}: {e}");
    };
    refused(
        r#"{"id": "a", "x": 1, "y": 2, "lat": 1, "lon": 2}"#,
        "not both",
    );
    refused(r#"{"id": "a", "lat": 1}"#, "missing field `lon`");
    refused(r#"{"id": "a", "x": 1}"#, "missing field `y`");
    refused(r#"{"x": 1, "y": 2}"#, "missing field `id`");
    refused(
        r#"{"id": "a", "x": 1, "y": 2, "lat": 1}"#,
        "unknown field `lat`, expected one of `id`, `x`, `y`, `psi`, `k`, `beta`",
    );
    refused(
        r#"{"id": "a", "lat": 1, "lon": 2, "y": 1}"#,
        "unknown field `y`, expected one of `id`, `lat`, `lon`, `psi`, `k`, `beta`",
    );
    refused(
        r#"{"id": "a", "x": 1, "y": 2, "z": 3}"#,
        "unknown field `z`",
    );
    refused(r#"{"id": "a", "x": "1", "y": 2}"#, "invalid type: string");
    refused(r#"[1, 2]"#, "invalid type");
    refused(
        r#"{"id": "a", "x": 1, "y": 2, "x": 3}"#,
        "duplicate field `x`",
    );
}
