//! The mission plane (`geometry::geodesy`) against an independent geodesic
//! computation: geographiclib-rs, a port of Karney's algorithms for the
//! WGS84 ellipsoid (accurate to about 15 nm), which shares no code with ours.
//!
//! `cargo test --test it geodesy:: -- --nocapture` prints the table of the
//! plane's distortion that docs/api.md quotes.
//!
//! What the plane should do, derived before measuring. A geodesic leaves
//! the origin tangent to the plane with the normal curvature 1/R_α of the
//! ellipsoid in its azimuth α (Euler: 1/R_α = cos²α/M + sin²α/N, M and N
//! the meridian and prime-vertical radii at the origin). A curve of
//! curvature κ, length s, starting tangent to a plane, projects onto it
//! with length s − κ²s³/6 + …, so a point at geodesic distance s lies at
//! plane distance d = s − s³/(6R_α²): the plane is short by a part
//! s²/(6R_α²) (1.0e-5 at 50 km), whatever the origin, to within a next
//! term of order e²·s/R of that part (the curvature changes along the line
//! only through the flattening). Bearings: the plane through the origin's
//! normal and the point (the normal section) projects onto the plane as a
//! straight line from the origin, so the plane bearing is the normal
//! section's azimuth, which differs from the geodesic's by
//! e'² s² cos²φ sin 2α / (12 N²) (Bomford, Geodesy: the geodesic lies a
//! third of the way between the two reciprocal normal sections), at most
//! 3.5e-8 rad (7 milliarcseconds) at 50 km. The tests hold the plane to
//! both predictions, with the next term and the two libraries' rounding as
//! the only slack.

use geographiclib_rs::{DirectGeodesic, Geodesic, InverseGeodesic};
use proptest::prelude::*;
use seacover::geometry::geodesy::{LatLon, LocalFrame, WGS84_A, WGS84_F};

/// Origins all over the globe: the equator and the prime meridian, both
/// hemispheres' mid and high latitudes, both sides of the antimeridian,
/// and a degree or less from either pole.
const ORIGINS: &[(f64, f64)] = &[
    (0.0, 0.0),
    (-35.363261, 149.165230), // ArduPilot SITL's home, Canberra
    (51.5, -0.12),
    (60.39, 5.32),
    (-33.9, 18.4),
    (64.1, -21.9),
    (1.26, 103.84),
    (-54.8, -68.3),
    (78.2, 15.6),
    (-77.85, 166.67),
    (21.3, -157.9),
    (45.0, 179.95),
    (-45.0, -179.95),
    (89.0, 40.0),
    (-89.5, -120.0),
];

/// The ranges of the table [m].
const RANGES: [f64; 4] = [100.0, 1_000.0, 10_000.0, 50_000.0];

/// Sixteen bearings, every 22.5° from north.
const BEARINGS: usize = 16;

/// What both libraries' rounding may add to a distance [m]: geographiclib
/// is accurate to about 15 nm, and our ECEF differences of 6.4e6 m numbers
/// round at about 1 nm.
const ROUNDING: f64 = 2e-8;

const E2: f64 = WGS84_F * (2.0 - WGS84_F);

fn frame(lat: f64, lon: f64) -> LocalFrame {
    LocalFrame::new(LatLon { lat, lon }).unwrap()
}

/// An angle in degrees wrapped to (−180, 180].
fn wrap180(a: f64) -> f64 {
    let w = (a + 180.0).rem_euclid(360.0) - 180.0;
    if w == -180.0 { 180.0 } else { w }
}

/// The meridian and prime-vertical radii of curvature (M, N) at `lat` [deg].
fn radii(lat: f64) -> (f64, f64) {
    let s = lat.to_radians().sin();
    let w = (1.0 - E2 * s * s).sqrt();
    (WGS84_A * (1.0 - E2) / (w * w * w), WGS84_A / w)
}

/// The predicted shortfall s − d [m] of the plane distance at geodesic
/// distance `s` in azimuth `az` [deg] from an origin at `lat`.
fn predicted_shortfall(lat: f64, az: f64, s: f64) -> f64 {
    let (m, n) = radii(lat);
    let a = az.to_radians();
    let r = 1.0 / (a.cos().powi(2) / m + a.sin().powi(2) / n);
    s * s * s / (6.0 * r * r)
}

/// The slack allowed on the shortfall: the series' next term (order
/// e²·s/R of the first; 2e² s/a leaves room for its coefficient, measured
/// at about 1.2) and rounding.
fn shortfall_slack(lat: f64, az: f64, s: f64) -> f64 {
    2.0 * E2 * s / WGS84_A * predicted_shortfall(lat, az, s) + ROUNDING
}

/// The predicted plane bearing minus the geodesic's azimuth [rad].
fn predicted_bearing_error(lat: f64, az: f64, s: f64) -> f64 {
    let (_, n) = radii(lat);
    let ep2 = E2 / (1.0 - E2);
    let c = lat.to_radians().cos();
    ep2 * s * s * c * c * (2.0 * az.to_radians()).sin() / (12.0 * n * n)
}

/// The slack on the bearing error [rad]: 1 % of the largest predicted one
/// at that range (the next term) and rounding seen across `s`.
fn bearing_slack(s: f64) -> f64 {
    let ep2 = E2 / (1.0 - E2);
    0.01 * ep2 * s * s / (12.0 * WGS84_A * WGS84_A) + ROUNDING / s
}

/// One point of the table: placed by geographiclib at distance `s` and
/// azimuth `az` from the origin, seen in the plane.
struct Placed {
    /// Plane distance minus geodesic distance [m] (negative: short).
    distance_error: f64,
    /// Plane bearing minus geodesic azimuth [rad].
    bearing_error: f64,
    /// From where a flat map would put it, (s sin α, s cos α) [m].
    offset: f64,
    /// Measured minus predicted shortfall, and its slack [m].
    shortfall_deviation: f64,
    shortfall_slack: f64,
    /// Measured minus predicted bearing error [rad].
    bearing_deviation: f64,
}

fn place(g: &Geodesic, lat: f64, lon: f64, az: f64, s: f64) -> Placed {
    let (lat2, lon2): (f64, f64) = g.direct(lat, lon, az, s);
    let (x, y) = frame(lat, lon).to_local(LatLon {
        lat: lat2,
        lon: lon2,
    });
    let d = x.hypot(y);
    let bearing_error = wrap180(x.atan2(y).to_degrees() - az).to_radians();
    let a = az.to_radians();
    Placed {
        distance_error: d - s,
        bearing_error,
        offset: (x - s * a.sin()).hypot(y - s * a.cos()),
        shortfall_deviation: (s - d) - predicted_shortfall(lat, az, s),
        shortfall_slack: shortfall_slack(lat, az, s),
        bearing_deviation: bearing_error - predicted_bearing_error(lat, az, s),
    }
}

fn every_point(g: &Geodesic, s: f64) -> Vec<Placed> {
    ORIGINS
        .iter()
        .flat_map(|&(lat, lon)| {
            (0..BEARINGS).map(move |k| place(g, lat, lon, k as f64 * 360.0 / BEARINGS as f64, s))
        })
        .collect()
}

/// The distortion table: for each range, over every origin and bearing,
/// how much shorter the plane distance is (absolute and relative), the
/// largest bearing error, and how far the point lands from where a flat
/// map would put it. Every point is held to the predictions above.
#[test]
fn the_planes_distortion_is_the_predicted_one() {
    let g = Geodesic::wgs84();
    println!(
        "Distortion of the local plane against WGS84 geodesics (geographiclib), over {} origins × {BEARINGS} bearings:\n",
        ORIGINS.len()
    );
    println!(
        "| geodesic distance s | plane distance d − s | relative (s − d)/s | predicted s²/6R_α² | largest bearing error | largest offset from (s sin α, s cos α) |"
    );
    println!("|---:|---:|---:|---:|---:|---:|");
    for s in RANGES {
        let points = every_point(&g, s);
        let (short_min, short_max) = points
            .iter()
            .map(|p| -p.distance_error)
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
        let bearing = points
            .iter()
            .map(|p| p.bearing_error.abs())
            .fold(0.0, f64::max);
        let offset = points.iter().map(|p| p.offset).fold(0.0, f64::max);
        let (pmin, pmax) = ORIGINS
            .iter()
            .flat_map(|&(lat, _)| {
                (0..BEARINGS).map(move |k| {
                    predicted_shortfall(lat, k as f64 * 360.0 / BEARINGS as f64, s) / s
                })
            })
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
        println!(
            "| {} | −{} … −{} | {:.2e} … {:.2e} | {:.2e} … {:.2e} | {:.1e} rad ({:.2e}″) | {} |",
            metres(s),
            metres(short_min),
            metres(short_max),
            short_min / s,
            short_max / s,
            pmin,
            pmax,
            bearing,
            bearing.to_degrees() * 3600.0,
            metres(offset),
        );
        for (i, p) in points.iter().enumerate() {
            let (lat, lon) = ORIGINS[i / BEARINGS];
            let az = (i % BEARINGS) as f64 * 360.0 / BEARINGS as f64;
            assert!(
                p.shortfall_deviation.abs() <= p.shortfall_slack,
                "origin {lat},{lon}, {s} m at {az}°: the plane is short by {} m, predicted {} m (slack {} m)",
                -p.distance_error,
                predicted_shortfall(lat, az, s),
                p.shortfall_slack
            );
            assert!(
                p.bearing_deviation.abs() <= bearing_slack(s),
                "origin {lat},{lon}, {s} m at {az}°: bearing error {} rad, predicted {} rad",
                p.bearing_error,
                predicted_bearing_error(lat, az, s)
            );
        }
    }
}

/// The plane's scale away from the origin: a short length (10 m) at
/// distance s, measured in the plane against geographiclib. Along the
/// radius the surface tilts away from the plane by s/R, so lengths shrink
/// by cos(s/R) ≈ 1 − s²/(2R_α²) (3.1e-5 at 50 km: 3 mm in 100 m); across
/// it, the plane keeps lengths: on a sphere the circle of the points at
/// distance s lies in a plane parallel to the tangent plane and projects
/// onto itself (on the ellipsoid, measured: 1 to within the rounding of a
/// 10 m step, 5e-10, out to 50 km). Printed as the second table of the
/// docs/api.md.
#[test]
fn the_planes_scale_shrinks_along_the_radius_only() {
    let g = Geodesic::wgs84();
    let step = 10.0;
    println!(
        "\nLocal scale of the plane: a {step} m length at distance s, plane length / geodesic length − 1:\n"
    );
    println!("| distance s from the origin | along the radius | predicted −s²/2R_α² | across it |");
    println!("|---:|---:|---:|---:|");
    for s in RANGES {
        let (mut along, mut across) = ((f64::MAX, f64::MIN), (f64::MAX, f64::MIN));
        let mut p_along = (f64::MAX, f64::MIN);
        let span = |(a, b): (f64, f64), v: f64| (a.min(v), b.max(v));
        for &(lat, lon) in ORIGINS {
            let f = frame(lat, lon);
            for k in 0..BEARINGS {
                let az = k as f64 * 360.0 / BEARINGS as f64;
                let (lat1, lon1, az1): (f64, f64, f64) = g.direct(lat, lon, az, s);
                let (lat2, lon2): (f64, f64) = g.direct(lat1, lon1, az1, step);
                let (lat3, lon3): (f64, f64) = g.direct(lat1, lon1, az1 + 90.0, step);
                let p = f.to_local(LatLon {
                    lat: lat1,
                    lon: lon1,
                });
                let q = f.to_local(LatLon {
                    lat: lat2,
                    lon: lon2,
                });
                let r = f.to_local(LatLon {
                    lat: lat3,
                    lon: lon3,
                });
                let radial = (q.0 - p.0).hypot(q.1 - p.1) / step - 1.0;
                let tangential = (r.0 - p.0).hypot(r.1 - p.1) / step - 1.0;
                // The radius of curvature along the line, at its start.
                let (m, n) = radii(lat);
                let a = az.to_radians();
                let r2 = (1.0 / (a.cos().powi(2) / m + a.sin().powi(2) / n)).powi(2);
                let want_along = -s * s / (2.0 * r2);
                along = span(along, radial);
                across = span(across, tangential);
                p_along = span(p_along, want_along);
                // The next terms (the ellipsoid's e² s/R, the 10 m step's
                // own curvature) and rounding over 10 m.
                let slack = |want: f64| 0.05 * want.abs() + 2.0 * ROUNDING / step;
                assert!(
                    (radial - want_along).abs() <= slack(want_along),
                    "{lat},{lon}, {s} m at {az}°: along {radial:e}, predicted {want_along:e}"
                );
                assert!(
                    tangential.abs() <= 2.0 * ROUNDING / step,
                    "{lat},{lon}, {s} m at {az}°: across {tangential:e}"
                );
            }
        }
        println!(
            "| {} | {:.2e} … {:.2e} | {:.2e} … {:.2e} | {:.2e} … {:.2e} |",
            metres(s),
            along.0,
            along.1,
            p_along.0,
            p_along.1,
            across.0,
            across.1,
        );
    }
}

/// A length for the table, in the unit that reads best.
fn metres(v: f64) -> String {
    let a = v.abs();
    if a >= 1000.0 {
        format!("{} km", v / 1000.0)
    } else if a >= 1.0 {
        format!("{v} m")
    } else if a >= 1e-3 {
        format!("{:.2} mm", v * 1e3)
    } else if a >= 1e-6 {
        format!("{:.2} µm", v * 1e6)
    } else {
        format!("{:.1} nm", v * 1e9)
    }
}

/// At short range the plane is the flat map a surveyor would draw: a point
/// placed by geographiclib 100 m away lands within 0.1 µm of
/// (s sin α, s cos α), and 1 km away within the predicted 4.2 µm shortfall
/// (plus rounding).
#[test]
fn a_point_placed_by_geographiclib_lands_where_a_flat_map_puts_it() {
    let g = Geodesic::wgs84();
    for p in every_point(&g, 100.0) {
        assert!(p.offset < 1e-7, "100 m: {} m off", p.offset);
    }
    for p in every_point(&g, 1_000.0) {
        assert!(p.offset < 4.2e-6 + ROUNDING, "1 km: {} m off", p.offset);
    }
}

/// The origin's own coordinates and geographiclib agree on the directions:
/// 1 km due east is +x, due north is +y, at every origin.
#[test]
fn north_is_y_and_east_is_x_everywhere() {
    let g = Geodesic::wgs84();
    for &(lat, lon) in ORIGINS {
        let f = frame(lat, lon);
        let at = |az: f64| {
            let (la, lo): (f64, f64) = g.direct(lat, lon, az, 1000.0);
            f.to_local(LatLon { lat: la, lon: lo })
        };
        let (x, y) = at(0.0);
        assert!(
            x.abs() < 1e-6 && (y - 1000.0).abs() < 1e-5,
            "{lat},{lon}: north is ({x}, {y})"
        );
        let (x, y) = at(90.0);
        assert!(
            y.abs() < 1e-3 && (x - 1000.0).abs() < 1e-5,
            "{lat},{lon}: east is ({x}, {y})"
        );
    }
}

/// The chord that decides whether a position is within reach: shorter
/// than the geodesic by s³/(24R²) (a chord of a circle of radius R, with R
/// between the smallest and largest radius of curvature of WGS84), and the
/// antipode, which the plane puts within its reach, is a diameter away.
#[test]
fn the_chord_is_the_geodesic_distance_up_close_and_the_diameter_across() {
    let g = Geodesic::wgs84();
    let (r_min, _) = radii(0.0);
    let (_, r_max) = radii(90.0);
    for &(lat, lon) in ORIGINS {
        let f = frame(lat, lon);
        for s in RANGES {
            for k in 0..BEARINGS {
                let (la, lo): (f64, f64) = g.direct(lat, lon, k as f64 * 22.5, s);
                let short = s - f.chord(LatLon { lat: la, lon: lo });
                let (low, high) = (
                    s.powi(3) / (24.0 * r_max * r_max),
                    s.powi(3) / (24.0 * r_min * r_min),
                );
                // With room for the next term, a part in 1e-4 of it.
                assert!(
                    short >= low * (1.0 - 1e-4) - ROUNDING
                        && short <= high * (1.0 + 1e-4) + ROUNDING,
                    "{lat},{lon}: {s} m, chord short by {short} m, not in [{low}, {high}]"
                );
            }
        }
        let antipode = LatLon {
            lat: -lat,
            lon: if lon > 0.0 { lon - 180.0 } else { lon + 180.0 },
        };
        // The line to the antipode passes through the centre, off the
        // origin's up by the angle between the geodetic and geocentric
        // latitudes: the plane puts the antipode 2N e² sin φ cos φ away,
        // under 43 km, inside its 50 km reach, so only the chord can tell.
        let (x, y) = f.to_local(antipode);
        let (_, n) = radii(lat);
        let (sin, cos) = lat.to_radians().sin_cos();
        let expected = 2.0 * n * E2 * (sin * cos).abs();
        assert!(
            (x.hypot(y) - expected).abs() < 1e-3 * expected + 1e-6
                && x.hypot(y) < LocalFrame::RANGE,
            "{lat},{lon}: the antipode at ({x}, {y}), expected {expected} m away"
        );
        assert!(f.chord(antipode) > 12_700_000.0, "{lat},{lon}");
    }
}

fn origin() -> impl Strategy<Value = (f64, f64)> {
    (-89.99f64..89.99, -180.0f64..=180.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(5000))]

    /// Plane → WGS84 → plane comes back within a micrometre (the module
    /// promises a millimetre) anywhere within 50 km of any origin, and the
    /// longitude is wrapped to (−180°, 180°].
    #[test]
    fn the_round_trip_from_the_plane_is_exact(
        (lat, lon) in origin(),
        r in 0.0f64..=LocalFrame::RANGE,
        theta in 0.0f64..std::f64::consts::TAU,
    ) {
        let f = frame(lat, lon);
        let (x, y) = (r * theta.cos(), r * theta.sin());
        let p = f.to_geodetic(x, y);
        prop_assert!(p.lon > -180.0 && p.lon <= 180.0 && p.lat.abs() <= 90.0, "{p:?}");
        let (x2, y2) = f.to_local(p);
        let err = (x2 - x).hypot(y2 - y);
        prop_assert!(err < 1e-6, "({x}, {y}) came back {err} m off");
    }

    /// WGS84 → plane → WGS84: a point placed by geographiclib up to 50 km
    /// away comes back to within a micrometre, measured by geographiclib
    /// (so that longitudes near a pole, where they mean little, count by
    /// the distance they make).
    #[test]
    fn the_round_trip_from_wgs84_is_exact(
        (lat, lon) in origin(),
        s in 0.0f64..=LocalFrame::RANGE,
        az in -180.0f64..180.0,
    ) {
        let g = Geodesic::wgs84();
        let (lat2, lon2): (f64, f64) = g.direct(lat, lon, az, s);
        let f = frame(lat, lon);
        let (x, y) = f.to_local(LatLon { lat: lat2, lon: lon2 });
        let back = f.to_geodetic(x, y);
        let miss: f64 = g.inverse(lat2, lon2, back.lat, back.lon);
        prop_assert!(miss < 1e-6, "{lat2},{lon2} came back {miss} m away, at {back:?}");
    }

    /// The other way round, through geographiclib's inverse problem: a
    /// plane point at distance d is at geodesic distance d + d³/(6R_α²)
    /// from the origin, in azimuth atan2(x, y) to within the normal
    /// section's offset.
    #[test]
    fn plane_points_are_where_the_prediction_says(
        (lat, lon) in origin(),
        d in 1.0f64..=LocalFrame::RANGE,
        theta in 0.0f64..std::f64::consts::TAU,
    ) {
        let g = Geodesic::wgs84();
        let (x, y) = (d * theta.sin(), d * theta.cos());
        let p = frame(lat, lon).to_geodetic(x, y);
        let (s, az, _, _): (f64, f64, f64, f64) = g.inverse(lat, lon, p.lat, p.lon);
        let bearing = theta.to_degrees();
        let excess = s - d;
        prop_assert!(
            (excess - predicted_shortfall(lat, bearing, s)).abs() <= shortfall_slack(lat, bearing, s),
            "{d} m at {bearing}°: geodesic {s} m"
        );
        let error = wrap180(bearing - az).to_radians();
        prop_assert!(
            (error - predicted_bearing_error(lat, az, s)).abs() <= bearing_slack(s),
            "{d} m at {bearing}°: geodesic azimuth {az}°"
        );
    }
}
