//! The coordinate reference systems a raster may be in, and their model
//! coordinates in WGS84.
//!
//! Supported: EPSG:4326 (WGS84 longitude and latitude in degrees) and the
//! WGS84 UTM zones, EPSG:32601–32660 (north) and 32701–32760 (south), in
//! metres: what QGIS and GDAL write for data in degrees and for a local
//! survey. Anything else (another datum, a national grid, Web Mercator, a
//! user-defined CRS) is refused by [`Crs::from_keys`] rather than guessed:
//! a datum shift is metres, as large as the features of a risk map.
//!
//! UTM is inverted by proj4rs (its `utm` is the extended transverse
//! Mercator of Poder and Engsager, as PROJ's, accurate to well under a
//! millimetre within a zone), not by a series of our own.

use proj4rs::proj::Proj;

use crate::geometry::geodesy::LatLon;

/// The GeoKeys that name a CRS (GeoTIFF 1.1, OGC 19-008r4).
const KEY_MODEL: u16 = 1024;
const KEY_RASTER: u16 = 1025;
const KEY_GEOGRAPHIC: u16 = 2048;
const KEY_ANGULAR_UNITS: u16 = 2054;
const KEY_PROJECTED: u16 = 3072;
const KEY_LINEAR_UNITS: u16 = 3076;
/// GTRasterTypeGeoKey's "pixel is point".
const PIXEL_IS_POINT: u16 = 2;
/// GeoTIFF's ModelType codes.
const MODEL_PROJECTED: u16 = 1;
const MODEL_GEOGRAPHIC: u16 = 2;
/// EPSG's code of angular degrees and of the metre (GeoTIFF unit keys).
const DEGREE: u16 = 9102;
const METRE: u16 = 9001;
/// WGS84 longitude and latitude.
const WGS84: u16 = 4326;
/// A GeoKey value meaning "defined by further keys", not by an EPSG code.
const USER_DEFINED: u16 = 32767;

/// The GeoKeys this module reads; every one of them is a SHORT held in
/// the directory itself. Others (citations, ellipsoid parameters) are
/// skipped: a raster is placed by its EPSG codes, not by its prose.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GeoKeys {
    model_type: Option<u16>,
    raster_type: Option<u16>,
    geographic_type: Option<u16>,
    angular_units: Option<u16>,
    projected_type: Option<u16>,
    linear_units: Option<u16>,
}

impl GeoKeys {
    /// The keys of a GeoKeyDirectory tag: a header (version, revision,
    /// minor revision, key count) and four SHORTs a key (id, the tag that
    /// holds the value or 0 for the value itself, count, value). `None`
    /// when the count does not match the data.
    pub fn parse(directory: &[u16]) -> Option<GeoKeys> {
        let count = *directory.get(3)? as usize;
        let entries = directory.get(4..4 + 4 * count)?;
        let mut keys = GeoKeys::default();
        for entry in entries.chunks_exact(4) {
            let &[id, location, _, value] = entry else {
                continue;
            };
            if location != 0 {
                continue;
            }
            let slot = match id {
                KEY_MODEL => &mut keys.model_type,
                KEY_RASTER => &mut keys.raster_type,
                KEY_GEOGRAPHIC => &mut keys.geographic_type,
                KEY_ANGULAR_UNITS => &mut keys.angular_units,
                KEY_PROJECTED => &mut keys.projected_type,
                KEY_LINEAR_UNITS => &mut keys.linear_units,
                _ => continue,
            };
            *slot = Some(value);
        }
        Some(keys)
    }

    /// Whether a pixel's value is at the point of its raster coordinates
    /// rather than over the area that follows it.
    pub fn pixel_is_point(&self) -> bool {
        self.raster_type == Some(PIXEL_IS_POINT)
    }
}

/// A supported coordinate reference system.
#[derive(Debug, Clone)]
pub enum Crs {
    /// EPSG:4326: x is the longitude, y the latitude [°].
    Wgs84,
    /// A WGS84 UTM zone: x easting, y northing [m].
    Utm {
        zone: u8,
        south: bool,
        /// The zone's projection, to invert.
        proj: Box<Proj>,
        /// proj4rs's WGS84 longitude and latitude [rad], the inverse's target.
        geographic: Box<Proj>,
    },
}

impl Crs {
    /// The CRS a raster's GeoKeys name; otherwise what they name, in words,
    /// for the refusal.
    pub fn from_keys(keys: &GeoKeys) -> Result<Crs, String> {
        let code = |c: Option<u16>| match c {
            Some(USER_DEFINED) => "a user-defined one".to_string(),
            Some(c) => format!("EPSG:{c}"),
            None => "an unnamed one".to_string(),
        };
        match keys.model_type {
            Some(MODEL_GEOGRAPHIC) => {
                let units = keys.angular_units.unwrap_or(DEGREE);
                match keys.geographic_type {
                    Some(WGS84) if units == DEGREE => Ok(Crs::Wgs84),
                    Some(WGS84) => Err(format!("EPSG:4326 in angular unit {units}")),
                    other => Err(code(other)),
                }
            }
            Some(MODEL_PROJECTED) => {
                let units = keys.linear_units.unwrap_or(METRE);
                match keys.projected_type {
                    Some(c @ (32601..=32660 | 32701..=32760)) if units == METRE => {
                        Crs::utm((c % 100) as u8, c > 32700).map_err(|e| format!("EPSG:{c} ({e})"))
                    }
                    Some(c @ (32601..=32660 | 32701..=32760)) => {
                        Err(format!("EPSG:{c} in linear unit {units}"))
                    }
                    other => Err(code(other)),
                }
            }
            Some(other) => Err(format!("model type {other}")),
            None => Err("none (no GeoKeys)".to_string()),
        }
    }

    fn utm(zone: u8, south: bool) -> Result<Crs, proj4rs::errors::Error> {
        let hemisphere = if south { " +south" } else { "" };
        let proj = Proj::from_proj_string(&format!(
            "+proj=utm +zone={zone}{hemisphere} +datum=WGS84 +units=m +no_defs"
        ))?;
        let geographic = Proj::from_proj_string("+proj=longlat +datum=WGS84 +no_defs")?;
        Ok(Crs::Utm {
            zone,
            south,
            proj: Box::new(proj),
            geographic: Box::new(geographic),
        })
    }

    /// The WGS84 position of model coordinates (x, y), which need not be a
    /// valid [`LatLon`] (a raster may reach past the poles' limits; the
    /// caller checks).
    pub fn to_wgs84(&self, x: f64, y: f64) -> Result<LatLon, proj4rs::errors::Error> {
        match self {
            Crs::Wgs84 => Ok(LatLon { lat: y, lon: x }),
            Crs::Utm {
                proj, geographic, ..
            } => {
                let mut p = (x, y, 0.0);
                proj4rs::transform::transform(proj, geographic, &mut p)?;
                Ok(LatLon {
                    lat: p.1.to_degrees(),
                    lon: p.0.to_degrees(),
                })
            }
        }
    }

    /// Its name, as a person would look it up (`EPSG:32755`).
    pub fn name(&self) -> String {
        match self {
            Crs::Wgs84 => "EPSG:4326".to_string(),
            Crs::Utm { zone, south, .. } => {
                format!("EPSG:{}", if *south { 32700 } else { 32600 } + *zone as u32)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(model: u16, geographic: Option<u16>, projected: Option<u16>) -> GeoKeys {
        GeoKeys {
            model_type: Some(model),
            geographic_type: geographic,
            projected_type: projected,
            ..Default::default()
        }
    }

    /// GDAL's directory for EPSG:32755, pixels as areas: model type,
    /// raster type, a citation in the ASCII params (skipped), the
    /// projected CRS and the linear unit.
    #[test]
    fn a_directory_parses() {
        let directory = [
            1, 1, 0, 5, //
            1024, 0, 1, 1, //
            1025, 0, 1, 1, //
            1026, 34737, 22, 0, //
            3072, 0, 1, 32755, //
            3076, 0, 1, 9001,
        ];
        let keys = GeoKeys::parse(&directory).unwrap();
        assert!(!keys.pixel_is_point());
        assert_eq!(Crs::from_keys(&keys).unwrap().name(), "EPSG:32755");
        assert_eq!(GeoKeys::parse(&directory[..20]), None);
        assert_eq!(GeoKeys::parse(&[1, 1]), None);
    }

    /// The UTM inverse against a point worked out independently: the
    /// central meridian of zone 55 (147° E) at the equator is easting
    /// 500 000 m, northing 0 (north) or 10 000 000 m (south).
    #[test]
    fn utm_zones_invert() {
        let north = Crs::from_keys(&keys(1, None, Some(32655))).unwrap();
        let p = north.to_wgs84(500_000.0, 0.0).unwrap();
        assert!((p.lon - 147.0).abs() < 1e-9 && p.lat.abs() < 1e-9, "{p:?}");
        let south = Crs::from_keys(&keys(1, None, Some(32755))).unwrap();
        assert_eq!(south.name(), "EPSG:32755");
        let p = south.to_wgs84(500_000.0, 10_000_000.0).unwrap();
        assert!((p.lon - 147.0).abs() < 1e-9 && p.lat.abs() < 1e-9, "{p:?}");
        // 1° of latitude north of the equator on the central meridian is
        // the meridian arc times k0 = 0.9996: 110 574.389 m × 0.9996.
        let p = north.to_wgs84(500_000.0, 110_574.389 * 0.9996).unwrap();
        assert!((p.lat - 1.0).abs() < 1e-6, "{p:?}");
    }

    #[test]
    fn other_systems_are_named_in_the_refusal() {
        let e = Crs::from_keys(&keys(1, None, Some(3857))).unwrap_err();
        assert_eq!(e, "EPSG:3857");
        let e = Crs::from_keys(&keys(2, Some(4258), None)).unwrap_err();
        assert_eq!(e, "EPSG:4258");
        let e = Crs::from_keys(&keys(1, None, Some(USER_DEFINED))).unwrap_err();
        assert_eq!(e, "a user-defined one");
        let e = Crs::from_keys(&GeoKeys::default()).unwrap_err();
        assert!(e.contains("no GeoKeys"), "{e}");
        assert!(matches!(
            Crs::from_keys(&keys(2, Some(4326), None)),
            Ok(Crs::Wgs84)
        ));
    }
}
