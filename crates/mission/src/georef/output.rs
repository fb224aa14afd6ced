//! WGS84 out: a partition as a GeoJSON FeatureCollection (RFC 7946) that
//! GIS tools open as it is (`GET /api/v1/coverage.geojson`).
//!
//! What RFC 7946 asks, and how it is kept:
//! - positions are `[lon, lat]` in WGS84 degrees, no `crs` member: the
//!   `geojson` crate writes the objects, and only the members set here;
//! - rings are closed (geo's polygons close them) and follow the
//!   right-hand rule, exterior counter-clockwise and holes clockwise, in
//!   lon/lat (geo's `orient`, after the conversion, whatever the local
//!   rings' orientation: a cell's pieces come from boolean operations);
//! - numbers are written with serde_json's shortest round-trip form, the
//!   full f64 (a nanometre of longitude is 1e-14°), never rounded to a
//!   fixed number of decimals.
//!
//! GeoJSON has no arcs: a curved cell (vessels with different β) is its
//! `polygon` and `pieces`, whose vertices lie on the arcs densely enough
//! that every point of an arc is within 0.1 m of the chords
//! ([`cell_outline`](crate::scenario::cell_outline)); its exact
//! `edges` stay in the local documents.
//!
//! A cell is a `Polygon`, or a `MultiPolygon` when it has several pieces;
//! an empty cell, or a vessel that never reported a pose, has a `null`
//! geometry (allowed by RFC 7946, 3.2), so that every cell and vessel of
//! the snapshot is listed. Each feature's `kind` property says which it
//! is. Longitudes are wrapped to (−180°, 180°]: a mission across the
//! antimeridian gets polygons that cross it the long way round (RFC 7946,
//! 3.1.9 would cut them there; not done).

use geo::orient::{Direction, Orient};
use geo::{Coord, LineString, MultiPolygon, Polygon};
use geojson::{Feature, FeatureCollection, Geometry, GeometryValue, JsonObject};
use serde_json::{Value, json};

use seacover_engine::control::ned::heading_to_ned;
use seacover_engine::geometry::geodesy::LocalFrame;
use seacover_protocol::{CellDocument, RegionDocument, VesselStatusDocument, XY};

/// `[lon, lat]` of a local point.
fn lon_lat(frame: &LocalFrame, [x, y]: XY) -> [f64; 2] {
    let p = frame.to_geodetic(x, y);
    [p.lon, p.lat]
}

fn ring(frame: &LocalFrame, points: &[XY]) -> LineString<f64> {
    points
        .iter()
        .map(|&p| {
            let [x, y] = lon_lat(frame, p);
            Coord { x, y }
        })
        .collect()
}

/// A local polygon with holes in lon/lat, oriented by the right-hand rule.
fn polygon(frame: &LocalFrame, doc: &RegionDocument) -> Polygon<f64> {
    Polygon::new(
        ring(frame, &doc.polygon),
        doc.holes.iter().map(|h| ring(frame, h)).collect(),
    )
    .orient(Direction::Default)
}

fn cell_geometry(frame: &LocalFrame, cell: &CellDocument) -> Option<Geometry> {
    let value = match (cell.pieces.as_slice(), &cell.polygon) {
        ([one], _) => GeometryValue::from(&polygon(frame, one)),
        ([], Some(outline)) => GeometryValue::from(&polygon(
            frame,
            &RegionDocument {
                polygon: outline.clone(),
                holes: Vec::new(),
            },
        )),
        ([], None) => return None,
        (pieces, _) => GeometryValue::from(&MultiPolygon(
            pieces.iter().map(|p| polygon(frame, p)).collect(),
        )),
    };
    Some(Geometry::new(value))
}

fn feature(geometry: Option<Geometry>, properties: Value) -> Feature {
    let Value::Object(properties) = properties else {
        unreachable!("properties are built as an object")
    };
    Feature {
        geometry,
        properties: Some(JsonObject::from_iter(properties)),
        ..Feature::default()
    }
}

/// The partition of `cells` and the `vessels` as GeoJSON in `frame`'s
/// WGS84 coordinates. Cells: `kind` `cell`, `id`, `mass`, `area` [m²],
/// `centroid` `[lon, lat]`, `E` (the vessel's distance to the centroid
/// [m], `null` without a pose). Vessels: `kind` `vessel`, `id`,
/// `heading_deg` (clockwise from north, [0, 360)), `connected`, `live`,
/// `controlled`.
pub fn coverage(
    frame: &LocalFrame,
    cells: &[CellDocument],
    vessels: &[VesselStatusDocument],
) -> FeatureCollection {
    let poses: std::collections::HashMap<&str, _> = vessels
        .iter()
        .filter_map(|v| Some((v.id.as_str(), v.pose.as_ref()?)))
        .collect();
    let cells = cells.iter().map(|c| {
        let e = poses
            .get(c.id.as_str())
            .map(|p| (c.centroid[0] - p.x).hypot(c.centroid[1] - p.y));
        feature(
            cell_geometry(frame, c),
            json!({
                "kind": "cell",
                "id": c.id,
                "mass": c.mass,
                "area": c.area,
                "centroid": lon_lat(frame, c.centroid),
                "E": e,
            }),
        )
    });
    let boats = vessels.iter().map(|v| {
        let geometry = v
            .pose
            .as_ref()
            .map(|p| Geometry::new(GeometryValue::new_point(lon_lat(frame, [p.x, p.y]))));
        let heading = v
            .pose
            .as_ref()
            .map(|p| heading_to_ned(p.psi).to_degrees().rem_euclid(360.0));
        feature(
            geometry,
            json!({
                "kind": "vessel",
                "id": v.id,
                "heading_deg": heading,
                "connected": v.connected,
                "live": v.live,
                "controlled": v.controlled,
            }),
        )
    });
    // Built, not collected: a collected empty collection carries the bbox
    // `[]`, which is not GeoJSON (RFC 7946 §5: 2 × n numbers). No feature
    // here has a bbox, so the collection has none either.
    FeatureCollection {
        bbox: None,
        features: cells.chain(boats).collect(),
        foreign_members: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::fixtures::{mixed_fleet, piece};
    use seacover_engine::geometry::Point;
    use seacover_engine::geometry::arcs::Piece;
    use seacover_engine::geometry::geodesy::LatLon;

    fn segment_distance(q: Point, a: Point, b: Point) -> f64 {
        Piece::Segment { from: a, to: b }.distance2(q).sqrt()
    }

    /// No cells and no vessels (a mission before its first tick): an
    /// empty collection, with no `bbox` (an empty one is not GeoJSON).
    #[test]
    fn an_empty_partition_is_an_empty_collection_without_a_bbox() {
        let frame = LocalFrame::new(LatLon::new(-35.363261, 149.16523).unwrap()).unwrap();
        let collection = serde_json::to_value(coverage(&frame, &[], &[])).unwrap();
        assert_eq!(
            collection,
            json!({"type": "FeatureCollection", "features": []})
        );
    }

    /// Every polygon of a curved cell in `coverage.geojson`, read back into
    /// the plane: each vertex is on the cell's exact boundary (on its
    /// circle for an arc) and every point of every arc is within 0.1 m of
    /// the outline, while the rings stay closed and right-handed.
    #[test]
    fn curved_cells_are_dense_polygons_within_a_tenth_of_a_metre_of_their_arcs() {
        let (_, doc) = mixed_fleet();
        let frame = LocalFrame::new(LatLon::new(-35.363261, 149.16523).unwrap()).unwrap();
        let collection = serde_json::to_value(coverage(&frame, &doc.cells, &[])).unwrap();
        let features = collection["features"].as_array().unwrap();
        assert_eq!(features.len(), doc.cells.len());
        let mut arcs_checked = 0;
        for (cell, feature) in doc.cells.iter().zip(features) {
            assert_eq!(feature["properties"]["id"], cell.id.as_str());
            if cell.edges.is_empty() {
                continue;
            }
            let geometry = &feature["geometry"];
            let polygons: Vec<&Value> = match geometry["type"].as_str().unwrap() {
                "Polygon" => vec![&geometry["coordinates"]],
                "MultiPolygon" => geometry["coordinates"].as_array().unwrap().iter().collect(),
                other => panic!("{}: a {other}", cell.id),
            };
            // Rings in the plane, closing vertex included.
            let mut rings: Vec<Vec<Point>> = Vec::new();
            for polygon in polygons {
                for (k, ring) in polygon.as_array().unwrap().iter().enumerate() {
                    let lonlat: Vec<[f64; 2]> = serde_json::from_value(ring.clone()).unwrap();
                    assert!(lonlat.len() >= 4);
                    assert_eq!(lonlat.first(), lonlat.last(), "{}: a closed ring", cell.id);
                    let area2: f64 = lonlat
                        .windows(2)
                        .map(|w| w[0][0] * w[1][1] - w[1][0] * w[0][1])
                        .sum();
                    assert_eq!(area2 > 0.0, k == 0, "{}: right-hand rule", cell.id);
                    rings.push(
                        lonlat
                            .iter()
                            .map(|&[lon, lat]| {
                                let (x, y) = frame.to_local(LatLon::new(lat, lon).unwrap());
                                Point { x, y }
                            })
                            .collect(),
                    );
                }
            }
            let pieces: Vec<Piece> = cell.edges.iter().flatten().map(piece).collect();
            let to_boundary = |q: Point| {
                pieces
                    .iter()
                    .map(|p| p.distance2(q))
                    .fold(f64::INFINITY, f64::min)
                    .sqrt()
            };
            for q in rings.iter().flatten() {
                // The geodetic round trip is good to nanometres here.
                assert!(
                    to_boundary(*q) < 1e-6,
                    "{}: a vertex off the boundary by {} m",
                    cell.id,
                    to_boundary(*q)
                );
            }
            let to_outline = |q: Point| {
                rings
                    .iter()
                    .flat_map(|r| r.windows(2))
                    .map(|w| segment_distance(q, w[0], w[1]))
                    .fold(f64::INFINITY, f64::min)
            };
            for p in &pieces {
                let Piece::Arc {
                    centre,
                    radius,
                    start,
                    sweep,
                } = *p
                else {
                    continue;
                };
                arcs_checked += 1;
                // Vertices of this arc are on its circle.
                let on_arc = rings
                    .iter()
                    .flatten()
                    .filter(|q| p.distance2(**q).sqrt() < 1e-6)
                    .count();
                assert!(on_arc >= 2, "{}: an arc with {on_arc} vertices", cell.id);
                for q in rings
                    .iter()
                    .flatten()
                    .filter(|q| p.distance2(**q).sqrt() < 1e-6)
                {
                    let r = ((q.x - centre.x).powi(2) + (q.y - centre.y).powi(2)).sqrt();
                    assert!((r - radius).abs() < 1e-6, "{}: {r} vs {radius}", cell.id);
                }
                // Every point of the arc is within 0.1 m of a chord.
                let worst = (0..=400)
                    .map(|k| {
                        let t = start + sweep * k as f64 / 400.0;
                        to_outline(Point {
                            x: centre.x + radius * t.cos(),
                            y: centre.y + radius * t.sin(),
                        })
                    })
                    .fold(0.0, f64::max);
                assert!(
                    worst <= 0.1 + 1e-6,
                    "{}: an arc {worst} m from the outline",
                    cell.id
                );
            }
        }
        assert!(
            arcs_checked >= 4,
            "the mixed fleet has arcs: {arcs_checked}"
        );
    }
}
