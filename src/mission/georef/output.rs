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

use crate::control::ned::heading_to_ned;
use crate::geometry::geodesy::LocalFrame;
use crate::protocol::{CellDocument, RegionDocument, VesselStatusDocument, XY};

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
    FeatureCollection::new(cells.chain(boats))
}
