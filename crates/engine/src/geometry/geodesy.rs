//! WGS84 latitude and longitude ⇄ the mission's local plane (docs/api.md,
//! geo-referenced missions).
//!
//! A geo-referenced mission has an origin (WGS84 degrees); its plane is the
//! East-North-Up tangent plane at that origin, x east and y north in metres,
//! at the ellipsoid's surface (height 0). Points go geodetic → ECEF → ENU on
//! the WGS84 ellipsoid, not on a sphere, and come back the same way.
//!
//! Invariants:
//! - a [`LocalFrame`] is only built by [`LocalFrame::new`], which rejects a
//!   non-finite origin, |lat| ≥ 90° and |lon| > 180°;
//! - [`LocalFrame::to_local`] and [`LocalFrame::to_geodetic`] are inverse to
//!   better than 1 mm within [`LocalFrame::RANGE`] of the origin (tested to
//!   1 µm, from any origin with |lat| < 89.99°, in `tests/it/geodesy.rs`);
//! - longitudes come back wrapped to (−180°, 180°] and latitudes within
//!   [−90°, 90°], also for plane points beyond a pole.
//!
//! Numerics. The forward map is exact: ECEF from the prime-vertical radius
//! N(φ) = a / √(1 − e² sin² φ), then the ENU rotation of the difference from
//! the origin's ECEF point. A point of the plane is not on the ellipsoid: the
//! tangent plane lies above the surface by about d²/2R (0.2 km at 50 km).
//! [`LocalFrame::to_geodetic`] therefore returns the ellipsoid point whose
//! ENU east and north are (x, y), whatever its up, which is what makes the
//! round trip exact. It is in closed form: the line through the plane point
//! along the origin's up meets the ellipsoid where a quadratic in the up
//! offset vanishes (solved without cancellation, see the code), and a point
//! on the ellipsoid has tan φ = Z / ((1 − e²) √(X² + Y²)). No iteration, so
//! nothing to converge, also where the plane reaches over a pole (origins
//! within 50 km of one), where Newton's method on (φ, λ) did not.
//!
//! Distortion: distances measured in the plane are not geodesic distances.
//! A point at geodesic distance s from the origin in azimuth α lies at plane
//! distance s − s³/(6R_α²) (R_α the ellipsoid's radius of curvature in that
//! azimuth): short by a part s²/(6R_α²), 4e-9 at 1 km, 4e-7 at 10 km, 1.0e-5
//! (0.51–0.52 m) at 50 km. Its plane bearing is the normal section's azimuth,
//! off the geodesic's by at most e'² s² / (12 N²), 3.5e-8 rad at 50 km.
//! `tests/it/geodesy.rs` derives both and holds the plane to them against
//! geographiclib's geodesics (an independent implementation of Karney's
//! algorithms); docs/api.md quotes the measured table.

/// WGS84 semi-major axis a [m].
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS84 flattening f.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// First eccentricity squared e² = f (2 − f).
const E2: f64 = WGS84_F * (2.0 - WGS84_F);

/// A WGS84 position in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatLon {
    /// Latitude, north positive [°].
    pub lat: f64,
    /// Longitude, east positive [°].
    pub lon: f64,
}

/// Why an origin or a position cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeoError {
    /// The latitude (given) is not finite, or |lat| ≥ 90°.
    #[error("lat: must be a finite number with |lat| < 90, got {0}")]
    Latitude(f64),
    /// The longitude (given) is not finite, or |lon| > 180°.
    #[error("lon: must be a finite number with |lon| ≤ 180, got {0}")]
    Longitude(f64),
}

impl GeoError {
    /// The coordinate at fault: `lat` or `lon`.
    pub fn coordinate(&self) -> &'static str {
        match self {
            GeoError::Latitude(_) => "lat",
            GeoError::Longitude(_) => "lon",
        }
    }

    /// The message without the coordinate's name, for callers that put the
    /// name in a longer path (`risk.objects[2].lat`).
    pub fn reason(&self) -> String {
        let text = self.to_string();
        text[self.coordinate().len() + 2..].to_string()
    }
}

impl LatLon {
    /// A position with a finite latitude in (−90°, 90°) and longitude in
    /// [−180°, 180°].
    pub fn new(lat: f64, lon: f64) -> Result<LatLon, GeoError> {
        if !(lat.is_finite() && lat.abs() < 90.0) {
            return Err(GeoError::Latitude(lat));
        }
        if !(lon.is_finite() && lon.abs() <= 180.0) {
            return Err(GeoError::Longitude(lon));
        }
        Ok(LatLon { lat, lon })
    }
}

/// The East-North-Up plane tangent to the ellipsoid at an origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFrame {
    origin: LatLon,
    /// The origin in ECEF [m].
    o: [f64; 3],
    sin_lat: f64,
    cos_lat: f64,
    sin_lon: f64,
    cos_lon: f64,
}

/// ECEF of a point on the ellipsoid (height 0) at (φ, λ) in radians.
fn ecef(lat: f64, lon: f64) -> [f64; 3] {
    let (s, c) = lat.sin_cos();
    let (sl, cl) = lon.sin_cos();
    let n = WGS84_A / (1.0 - E2 * s * s).sqrt();
    [n * c * cl, n * c * sl, n * (1.0 - E2) * s]
}

impl LocalFrame {
    /// How far from the origin the plane is meant to be used [m]: positions
    /// farther away are refused by the MAVLink bridge, and the round trip is
    /// documented (and tested) to 1 mm within it.
    pub const RANGE: f64 = 50_000.0;

    /// The plane tangent at `origin`, which must be a valid [`LatLon`]
    /// (finite, |lat| < 90°, |lon| ≤ 180°).
    pub fn new(origin: LatLon) -> Result<LocalFrame, GeoError> {
        let origin = LatLon::new(origin.lat, origin.lon)?;
        let (lat, lon) = (origin.lat.to_radians(), origin.lon.to_radians());
        let (sin_lat, cos_lat) = lat.sin_cos();
        let (sin_lon, cos_lon) = lon.sin_cos();
        Ok(LocalFrame {
            origin,
            o: ecef(lat, lon),
            sin_lat,
            cos_lat,
            sin_lon,
            cos_lon,
        })
    }

    /// The origin the plane is tangent at.
    pub fn origin(&self) -> LatLon {
        self.origin
    }

    /// ENU (east, north, up) of an ECEF point.
    fn enu(&self, p: [f64; 3]) -> [f64; 3] {
        let d = [p[0] - self.o[0], p[1] - self.o[1], p[2] - self.o[2]];
        let (sf, cf, sl, cl) = (self.sin_lat, self.cos_lat, self.sin_lon, self.cos_lon);
        [
            -sl * d[0] + cl * d[1],
            -sf * cl * d[0] - sf * sl * d[1] + cf * d[2],
            cf * cl * d[0] + cf * sl * d[1] + sf * d[2],
        ]
    }

    /// The straight-line distance [m] from the origin to a WGS84 position
    /// at the ellipsoid's surface: shorter than the geodesic by a part
    /// s²/(24R²) (2.6e-6 at 50 km), and unlike the plane distance it grows
    /// all the way round the globe. (The plane puts the antipode
    /// 2N e² sin φ cos φ from the origin, up to 43 km: within its reach, so
    /// whether a position is near enough to use is decided by the chord.)
    pub fn chord(&self, p: LatLon) -> f64 {
        let e = self.enu(ecef(p.lat.to_radians(), p.lon.to_radians()));
        (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
    }

    /// (x east, y north) [m] of a WGS84 position at the ellipsoid's surface.
    /// Any finite input gives a finite result; callers that take positions
    /// from outside check [`LatLon::new`] first.
    pub fn to_local(&self, p: LatLon) -> (f64, f64) {
        let e = self.enu(ecef(p.lat.to_radians(), p.lon.to_radians()));
        (e[0], e[1])
    }

    /// The WGS84 position whose local east and north are (x, y): the exact
    /// inverse of [`LocalFrame::to_local`] (see the module's numerics).
    pub fn to_geodetic(&self, x: f64, y: f64) -> LatLon {
        let (sf, cf, sl, cl) = (self.sin_lat, self.cos_lat, self.sin_lon, self.cos_lon);
        // The plane point's offset w from the origin and the origin's up U,
        // in ECEF.
        let w = [-sl * x - sf * cl * y, cl * x - sf * sl * y, cf * y];
        let up = [cf * cl, cf * sl, sf];
        // The ellipsoid is ⟨P, P⟩ = a² in the metric ⟨p, q⟩ = p₀q₀ + p₁q₁
        // + p₂q₂/(1 − e²); along P = O + w + uU the equation is
        // A u² + 2B u + C = 0 with A = ⟨U, U⟩, B = ⟨O + w, U⟩ and
        // C = ⟨O + w, O + w⟩ − a². Two identities keep it free of
        // cancellation: ⟨O, ·⟩ is the ellipsoid's normal at O, so ⟨O, U⟩ = N
        // and ⟨O, w⟩ = 0 (w lies in the tangent plane), and ⟨O, O⟩ = a²,
        // leaving C = ⟨w, w⟩.
        let k = 1.0 / (1.0 - E2);
        let dot = |p: [f64; 3], q: [f64; 3]| p[0] * q[0] + p[1] * q[1] + k * p[2] * q[2];
        let n = WGS84_A / (1.0 - E2 * sf * sf).sqrt();
        let a = dot(up, up);
        let b = n + dot(w, up);
        let c = dot(w, w);
        // The root nearer the plane (the other is across the Earth), in the
        // form without cancellation.
        let u = -c / (b + (b * b - a * c).max(0.0).sqrt());
        let p: [f64; 3] = std::array::from_fn(|i| self.o[i] + w[i] + u * up[i]);
        // A point on the ellipsoid: tan φ = Z / ((1 − e²) √(X² + Y²)),
        // exact, and well defined up to the poles.
        let lat = p[2].atan2((1.0 - E2) * p[0].hypot(p[1]));
        let lon = p[1].atan2(p[0]);
        LatLon {
            lat: lat.to_degrees(),
            lon: wrap_degrees(lon.to_degrees()),
        }
    }
}

/// Wraps a longitude to (−180°, 180°].
fn wrap_degrees(lon: f64) -> f64 {
    let w = (lon + 180.0).rem_euclid(360.0) - 180.0;
    if w == -180.0 { 180.0 } else { w }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(lat: f64, lon: f64) -> LocalFrame {
        LocalFrame::new(LatLon { lat, lon }).unwrap()
    }

    #[test]
    fn the_origin_is_the_planes_zero() {
        let f = frame(-35.363261, 149.165230);
        let (x, y) = f.to_local(f.origin());
        assert!(x.abs() < 1e-9 && y.abs() < 1e-9, "{x} {y}");
    }

    #[test]
    fn east_is_x_and_north_is_y() {
        let f = frame(47.0, 8.0);
        let (x, y) = f.to_local(LatLon {
            lat: 47.0,
            lon: 8.001,
        });
        assert!(x > 75.0 && x < 77.0 && y.abs() < 0.01, "{x} {y}");
        let (x, y) = f.to_local(LatLon {
            lat: 47.001,
            lon: 8.0,
        });
        // One thousandth of a degree of latitude is about 111.2 m at 47°.
        assert!(y > 111.0 && y < 111.3 && x.abs() < 1e-6, "{x} {y}");
    }

    #[test]
    fn the_round_trip_is_exact_to_a_micrometre_within_50_km() {
        for &(lat, lon) in &[
            (0.0, 0.0),
            (-35.363261, 149.165230),
            (60.0, -179.9),
            (-75.0, 179.99),
            (89.0, 10.0),
        ] {
            let f = frame(lat, lon);
            for k in 0..64 {
                let a = k as f64 * 0.7;
                let r = 50_000.0 * ((k % 8) as f64 + 1.0) / 8.0;
                let (x, y) = (r * a.cos(), r * a.sin());
                let g = f.to_geodetic(x, y);
                assert!(g.lon > -180.0 && g.lon <= 180.0);
                let (x2, y2) = f.to_local(g);
                let err = (x2 - x).hypot(y2 - y);
                assert!(
                    err < 1e-6,
                    "origin {lat},{lon}: ({x},{y}) came back {err} m off"
                );
            }
        }
    }

    #[test]
    fn plane_points_beyond_a_pole_come_back_as_themselves() {
        // 11 km from the pole: the plane's 50 km reach over it.
        for lat in [89.9, -89.9] {
            let f = frame(lat, 30.0);
            for (x, y) in [(0.0, 30_000.0), (0.0, -30_000.0), (5_000.0, 11_100.0)] {
                let g = f.to_geodetic(x, y);
                assert!(
                    g.lat.abs() <= 90.0 && g.lon > -180.0 && g.lon <= 180.0,
                    "{g:?}"
                );
                let (x2, y2) = f.to_local(g);
                assert!(
                    (x2 - x).hypot(y2 - y) < 1e-6,
                    "({x}, {y}) → {g:?} → ({x2}, {y2})"
                );
            }
        }
    }

    #[test]
    fn origins_out_of_range_are_refused() {
        for (lat, lon) in [
            (90.0, 0.0),
            (-90.0, 0.0),
            (f64::NAN, 0.0),
            (0.0, 180.5),
            (0.0, f64::INFINITY),
        ] {
            assert!(LocalFrame::new(LatLon { lat, lon }).is_err(), "{lat} {lon}");
        }
        assert!(
            LocalFrame::new(LatLon {
                lat: 0.0,
                lon: -180.0
            })
            .is_ok()
        );
    }

    #[test]
    fn longitudes_wrap_half_open() {
        assert_eq!(wrap_degrees(180.0), 180.0);
        assert_eq!(wrap_degrees(-180.0), 180.0);
        assert!((wrap_degrees(190.0) + 170.0).abs() < 1e-12);
    }
}
