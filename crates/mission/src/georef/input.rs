//! WGS84 in: GeoJSON regions and positions given by `lat`, `lon`, placed in
//! the local plane of an origin, giving the local documents the engine and
//! the store keep.
//!
//! A region's GeoJSON is read as RFC 7946 says and as GIS tools write it:
//! QGIS exports a layer's polygon as a `MultiPolygon` (of one polygon) in a
//! `FeatureCollection`, geojson.io a `Polygon` `Feature` in one, so every
//! wrapping of exactly one polygon is accepted. Rings must be closed (the
//! closing position is dropped, as our rings do not repeat it); their
//! orientation is free (RFC 7946 asks parsers not to reject either, and
//! [`seacover_engine::geometry::Region::new`] orients them). Errors name the JSON path
//! of the position at fault (`region.features[0].geometry.coordinates[0][3]`);
//! once converted, ring 0 is the region's `polygon` and ring i + 1 its
//! `holes[i]`, the names the region's own validation uses.

use geojson::{GeoJson, GeometryValue, PolygonType, Position};

use seacover_engine::coverage::InputError;
use seacover_engine::geometry::geodesy::{LatLon, LocalFrame};
use seacover_protocol::{
    GeoJsonRegion, OriginDocument, RegionDocument, RegionInput, RiskDocument, RiskInput,
    RiskObjectDocument, RiskObjectInput, VesselDocument, VesselInput, XY,
};

/// The plane of an origin, when there is one; `invalid` naming `origin.lat`
/// or `origin.lon`.
pub fn frame(origin: Option<OriginDocument>) -> Result<Option<LocalFrame>, InputError> {
    origin
        .map(|o| {
            LocalFrame::new(LatLon {
                lat: o.lat,
                lon: o.lon,
            })
            .map_err(|e| InputError::invalid(format!("origin.{}", e.coordinate()), e.reason()))
        })
        .transpose()
}

/// `prefix.name`, or `name` at the top of a document.
fn join(prefix: &str, name: &str) -> String {
    if prefix.is_empty() {
        name.to_string()
    } else {
        format!("{prefix}.{name}")
    }
}

/// The error for a geographic input without an origin to place it.
fn needs_origin(what: &str) -> InputError {
    InputError::invalid(
        "origin",
        format!(
            "{what} is given in WGS84 (lat/lon or GeoJSON), which needs an origin, and none is set"
        ),
    )
}

/// (x, y) of a WGS84 position within reach of the origin; `lat` and `lon`
/// name the fields in errors.
fn place(frame: &LocalFrame, lat: f64, lon: f64, field: &str) -> Result<XY, InputError> {
    let p = LatLon::new(lat, lon)
        .map_err(|e| InputError::invalid(join(field, e.coordinate()), e.reason()))?;
    let reach = frame.chord(p);
    if reach > LocalFrame::RANGE {
        return Err(InputError::invalid(
            join(field, "lat"),
            format!(
                "({lat}, {lon}) is {:.1} km from the origin; the local plane is used within {} km of it",
                reach / 1000.0,
                LocalFrame::RANGE / 1000.0
            ),
        ));
    }
    let (x, y) = frame.to_local(p);
    Ok([x, y])
}

/// A region in the local plane: a local one as it is, GeoJSON placed with
/// `frame`.
pub fn region(
    input: &RegionInput,
    frame: Option<&LocalFrame>,
) -> Result<RegionDocument, InputError> {
    match input {
        RegionInput::Local(doc) => Ok(doc.clone()),
        RegionInput::GeoJson(geojson) => {
            let frame = frame.ok_or_else(|| needs_origin("region"))?;
            geojson_region(geojson, frame)
        }
    }
}

fn geojson_region(
    geojson: &GeoJsonRegion,
    frame: &LocalFrame,
) -> Result<RegionDocument, InputError> {
    let (rings, path) = the_polygon(&geojson.0)?;
    let mut local = rings
        .iter()
        .enumerate()
        .map(|(i, ring)| local_ring(ring, frame, &format!("{path}[{i}]")));
    let polygon = local.next().ok_or_else(|| {
        InputError::invalid(path.clone(), "a polygon needs at least its outer ring")
    })??;
    Ok(RegionDocument {
        polygon,
        holes: local.collect::<Result<_, _>>()?,
    })
}

/// The one polygon in a GeoJSON object, with the path of its coordinates.
fn the_polygon(geojson: &GeoJson) -> Result<(&PolygonType, String), InputError> {
    match geojson {
        GeoJson::Geometry(g) => geometry_polygon(&g.value, "region"),
        GeoJson::Feature(f) => feature_polygon(f, "region"),
        GeoJson::FeatureCollection(fc) => match fc.features.as_slice() {
            [one] => feature_polygon(one, "region.features[0]"),
            many => Err(InputError::invalid(
                "region.features",
                format!(
                    "a region is one polygon: give a FeatureCollection of one Feature, not {}",
                    many.len()
                ),
            )),
        },
    }
}

fn feature_polygon<'a>(
    feature: &'a geojson::Feature,
    path: &str,
) -> Result<(&'a PolygonType, String), InputError> {
    let geometry = feature.geometry.as_ref().ok_or_else(|| {
        InputError::invalid(
            join(path, "geometry"),
            "the Feature has no geometry; a region needs a Polygon",
        )
    })?;
    geometry_polygon(&geometry.value, &join(path, "geometry"))
}

fn geometry_polygon<'a>(
    value: &'a GeometryValue,
    path: &str,
) -> Result<(&'a PolygonType, String), InputError> {
    match value {
        GeometryValue::Polygon { coordinates } => Ok((coordinates, join(path, "coordinates"))),
        GeometryValue::MultiPolygon { coordinates } => match coordinates.as_slice() {
            [one] => Ok((one, join(path, "coordinates[0]"))),
            many => Err(InputError::invalid(
                join(path, "coordinates"),
                format!(
                    "a region is one polygon: give a MultiPolygon of one polygon, not {}",
                    many.len()
                ),
            )),
        },
        other => Err(InputError::invalid(
            join(path, "type"),
            format!(
                "a region is a Polygon (or a MultiPolygon of one), not a {}",
                other.type_name()
            ),
        )),
    }
}

/// A closed GeoJSON ring `[[lon, lat], …]` placed in the plane, without its
/// closing position.
fn local_ring(ring: &[Position], frame: &LocalFrame, path: &str) -> Result<Vec<XY>, InputError> {
    if ring.len() < 4 {
        return Err(InputError::invalid(
            path,
            format!(
                "a GeoJSON ring has at least 4 positions, the last repeating the first; got {}",
                ring.len()
            ),
        ));
    }
    let lon_lat = |j: usize| -> Result<(f64, f64), InputError> {
        match ring[j].as_slice() {
            [lon, lat] | [lon, lat, _] => Ok((*lat, *lon)),
            other => Err(InputError::invalid(
                format!("{path}[{j}]"),
                format!(
                    "a position is [lon, lat] or [lon, lat, altitude], got {} numbers",
                    other.len()
                ),
            )),
        }
    };
    let last = ring.len() - 1;
    if lon_lat(0)? != lon_lat(last)? {
        return Err(InputError::invalid(
            format!("{path}[{last}]"),
            "a GeoJSON ring ends where it starts (RFC 7946, 3.1.6)",
        ));
    }
    (0..last)
        .map(|j| {
            let (lat, lon) = lon_lat(j)?;
            place(frame, lat, lon, &format!("{path}[{j}]"))
        })
        .collect()
}

/// A risk object in the local plane. `field` prefixes the names in errors
/// (`risk.objects[2]`; empty for a request's body).
pub fn risk_object(
    input: &RiskObjectInput,
    frame: Option<&LocalFrame>,
    field: &str,
) -> Result<RiskObjectDocument, InputError> {
    match input {
        RiskObjectInput::Local(doc) => Ok(doc.clone()),
        RiskObjectInput::Geo(g) => {
            let what = if field.is_empty() {
                "the risk object"
            } else {
                field
            };
            let frame = frame.ok_or_else(|| needs_origin(what))?;
            let [x, y] = place(frame, g.lat, g.lon, field)?;
            Ok(RiskObjectDocument {
                id: g.id.clone(),
                x,
                y,
                alpha: g.alpha,
                sigma: g.sigma,
            })
        }
    }
}

/// A scenario's risk density (or its truth: `field` names which) in the
/// local plane.
pub fn risk(
    input: &RiskInput,
    frame: Option<&LocalFrame>,
    field: &str,
) -> Result<RiskDocument, InputError> {
    Ok(RiskDocument {
        base: input.base,
        objects: input
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| risk_object(o, frame, &format!("{field}.objects[{i}]")))
            .collect::<Result<_, _>>()?,
    })
}

/// A scenario's vessel in the local plane (`field`: `vessels[3]`).
pub fn vessel(
    input: &VesselInput,
    frame: Option<&LocalFrame>,
    field: &str,
) -> Result<VesselDocument, InputError> {
    match input {
        VesselInput::Local(doc) => Ok(doc.clone()),
        VesselInput::Geo(g) => {
            let frame = frame.ok_or_else(|| needs_origin(field))?;
            let [x, y] = place(frame, g.lat, g.lon, field)?;
            Ok(VesselDocument {
                id: g.id.clone(),
                x,
                y,
                psi: g.psi,
                k: g.k,
                beta: g.beta,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn frame_at(lat: f64, lon: f64) -> LocalFrame {
        LocalFrame::new(LatLon { lat, lon }).unwrap()
    }

    fn region_of(value: serde_json::Value) -> Result<RegionDocument, InputError> {
        let input: RegionInput = serde_json::from_value(value).unwrap();
        region(&input, Some(&frame_at(-35.0, 149.0)))
    }

    /// A square of about 111 m × 91 m north-east of the origin, closed.
    fn square() -> serde_json::Value {
        json!([
            [149.0, -35.0],
            [149.001, -35.0],
            [149.001, -34.999],
            [149.0, -34.999],
            [149.0, -35.0]
        ])
    }

    #[test]
    fn every_wrapping_of_one_polygon_gives_the_same_region() {
        let polygon = json!({"type": "Polygon", "coordinates": [square()]});
        let feature =
            json!({"type": "Feature", "properties": {"name": "bay"}, "geometry": polygon});
        let multi = json!({"type": "MultiPolygon", "coordinates": [[square()]]});
        let collection = json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": null, "geometry": multi}
        ]});
        let expected = region_of(polygon.clone()).unwrap();
        assert_eq!(expected.polygon.len(), 4, "the closing position is dropped");
        assert_eq!(expected.polygon[0], [0.0, 0.0]);
        for value in [feature, multi, collection] {
            assert_eq!(region_of(value.clone()).unwrap(), expected, "{value}");
        }
    }

    #[test]
    fn what_is_not_one_closed_polygon_is_refused_naming_the_path() {
        let open = json!([
            [149.0, -35.0],
            [149.001, -35.0],
            [149.001, -34.999],
            [149.0, -34.999]
        ]);
        let cases = [
            (
                json!({"type": "Point", "coordinates": [149.0, -35.0]}),
                "region.type",
            ),
            (
                json!({"type": "Polygon", "coordinates": [open]}),
                "region.coordinates[0][3]",
            ),
            (
                json!({"type": "Feature", "properties": {}, "geometry": null}),
                "region.geometry",
            ),
            (
                json!({"type": "MultiPolygon", "coordinates": [[square()], [square()]]}),
                "region.coordinates",
            ),
            (
                json!({"type": "FeatureCollection", "features": []}),
                "region.features",
            ),
            (
                json!({"type": "Polygon", "coordinates": [[[149.0, -35.0], [149.001], [149.0, -34.999], [149.0, -35.0]]]}),
                "region.coordinates[0][1]",
            ),
            (
                json!({"type": "Polygon", "coordinates": [[[149.0, -35.0], [149.9, -35.0], [149.0, -34.9], [149.0, -35.0]]]}),
                "region.coordinates[0][1].lat",
            ),
            (
                json!({"type": "Polygon", "coordinates": [[[149.0, -35.0], [149.0, -95.0], [149.1, -34.9], [149.0, -35.0]]]}),
                "region.coordinates[0][1].lat",
            ),
        ];
        for (value, field) in cases {
            let err = region_of(value.clone()).unwrap_err().to_string();
            assert!(err.starts_with(&format!("{field}:")), "{value}: {err}");
        }
    }

    #[test]
    fn geographic_inputs_without_an_origin_name_the_origin() {
        let region: RegionInput =
            serde_json::from_value(json!({"type": "Polygon", "coordinates": [square()]})).unwrap();
        let object: RiskObjectInput =
            serde_json::from_value(json!({"lat": -35.0, "lon": 149.0, "alpha": 1, "sigma": 2}))
                .unwrap();
        let vessel_input: VesselInput =
            serde_json::from_value(json!({"id": "a", "lat": -35.0, "lon": 149.0})).unwrap();
        for err in [
            super::region(&region, None).unwrap_err(),
            risk_object(&object, None, "").unwrap_err(),
            vessel(&vessel_input, None, "vessels[0]").unwrap_err(),
        ] {
            assert!(err.to_string().starts_with("origin: "), "{err}");
        }
    }

    #[test]
    fn positions_are_placed_and_named_by_their_path() {
        let f = frame_at(-35.0, 149.0);
        let object: RiskObjectInput = serde_json::from_value(
            json!({"id": "w", "lat": -34.999, "lon": 149.0, "alpha": 1, "sigma": 2}),
        )
        .unwrap();
        let placed = risk_object(&object, Some(&f), "").unwrap();
        // A thousandth of a degree of latitude at 35° S is about 110.9 m.
        assert!(
            placed.x.abs() < 1e-6 && (placed.y - 110.9).abs() < 0.1,
            "{placed:?}"
        );
        assert_eq!(placed.id.as_deref(), Some("w"));
        let far: RiskObjectInput =
            serde_json::from_value(json!({"lat": -35.0, "lon": 150.0, "alpha": 1, "sigma": 2}))
                .unwrap();
        // A degree of longitude at 35° S: N(35°) cos 35° π/180 = 91.29 km.
        let err = risk_object(&far, Some(&f), "risk.objects[4]")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("risk.objects[4].lat: (-35, 150) is 91.3 km"),
            "{err}"
        );
        // The antipode, which the plane itself puts 40 km away, is refused.
        let antipode: RiskObjectInput =
            serde_json::from_value(json!({"lat": 35.0, "lon": -31.0, "alpha": 1, "sigma": 2}))
                .unwrap();
        let err = risk_object(&antipode, Some(&f), "")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("lat: (35, -31) is 127"), "{err}");
        let bad: RiskObjectInput =
            serde_json::from_value(json!({"lat": -35.0, "lon": 181.0, "alpha": 1, "sigma": 2}))
                .unwrap();
        let err = risk_object(&bad, Some(&f), "").unwrap_err().to_string();
        assert!(err.starts_with("lon: must be"), "{err}");
    }

    #[test]
    fn an_origin_out_of_range_is_named() {
        let err = frame(Some(OriginDocument {
            lat: 90.0,
            lon: 0.0,
        }))
        .unwrap_err();
        assert!(err.to_string().starts_with("origin.lat: must be"), "{err}");
        let err = frame(Some(OriginDocument {
            lat: 0.0,
            lon: f64::NAN,
        }))
        .unwrap_err();
        assert!(err.to_string().starts_with("origin.lon: must be"), "{err}");
        assert_eq!(frame(None).unwrap(), None);
    }
}
