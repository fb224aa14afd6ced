//! Positions placed on the globe by geographiclib (Karney's geodesics,
//! independent of `seacover::geometry::geodesy`), so that a test compares
//! the server's plane with a computation it does not share.
//!
//! Placing the local point (x, y) at geodesic distance s = hypot(x, y) in
//! azimuth atan2(x, y) from the origin differs from the plane's own
//! placement by s³/(6R²) in distance (tests/it/geodesy.rs: 33 nm at 200 m,
//! 4 µm at 1 km), far below what any of these tests compares.

use geographiclib_rs::{DirectGeodesic, Geodesic, InverseGeodesic};
use serde_json::{Value, json};

/// An origin (lat, lon) in WGS84 degrees.
pub(crate) type Origin = (f64, f64);

/// (lat, lon) of the local point (x, y) of the plane at `origin`.
pub(crate) fn place(origin: Origin, x: f64, y: f64) -> (f64, f64) {
    let s = x.hypot(y);
    if s == 0.0 {
        return origin;
    }
    Geodesic::wgs84().direct(origin.0, origin.1, x.atan2(y).to_degrees(), s)
}

/// (x, y) of a WGS84 position in the plane at `origin`: the inverse of
/// [`place`].
pub(crate) fn locate(origin: Origin, lat: f64, lon: f64) -> (f64, f64) {
    let (s, azimuth, _, _): (f64, f64, f64, f64) =
        Geodesic::wgs84().inverse(origin.0, origin.1, lat, lon);
    let a = azimuth.to_radians();
    (s * a.sin(), s * a.cos())
}

/// A local ring `[[x, y], …]` (not closed) as a closed GeoJSON ring of
/// `[lon, lat]`.
pub(crate) fn ring(origin: Origin, points: &Value) -> Value {
    let mut out: Vec<Value> = points
        .as_array()
        .expect("a ring")
        .iter()
        .map(|p| {
            let (lat, lon) = place(origin, p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
            json!([lon, lat])
        })
        .collect();
    out.push(out[0].clone());
    Value::Array(out)
}

/// A local region document `{polygon, holes}` as a GeoJSON Polygon
/// geometry placed at `origin`.
pub(crate) fn polygon(origin: Origin, region: &Value) -> Value {
    let mut rings = vec![ring(origin, &region["polygon"])];
    for hole in region["holes"].as_array().into_iter().flatten() {
        rings.push(ring(origin, hole));
    }
    json!({"type": "Polygon", "coordinates": rings})
}

/// A local object or vessel `{x, y, …}` placed at `lat`, `lon` instead.
pub(crate) fn at_lat_lon(origin: Origin, item: &Value) -> Value {
    let mut item = item.clone();
    let map = item.as_object_mut().expect("an object");
    let x = map.remove("x").unwrap().as_f64().unwrap();
    let y = map.remove("y").unwrap().as_f64().unwrap();
    let (lat, lon) = place(origin, x, y);
    map.insert("lat".into(), json!(lat));
    map.insert("lon".into(), json!(lon));
    item
}
