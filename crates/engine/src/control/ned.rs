//! MAVLink's frames ⇄ seacover's, in one place (`docs/ardupilot.md`, "The
//! bridge").
//!
//! MAVLink (and ArduPilot) use north-east-down: yaw ψ_NED clockwise from
//! north, yaw rate positive turning to starboard, body y to starboard.
//! seacover uses the mission's East-North-Up plane: ψ counter-clockwise from
//! east, r positive turning to port, body y to port (paper eq. 1). Hence
//! - ψ = wrap(π/2 − ψ_NED) and back ψ_NED = wrap(π/2 − ψ);
//! - r = −yawspeed_NED, and the same for a commanded yaw rate;
//! - surge is the same in both; sway v = −v_NED;
//! - a ground velocity (v_north, v_east) is rotated into the body by ψ.
//!
//! Every conversion the MAVLink bridge does goes through these functions;
//! each is tested both ways.

use super::wrap;
use std::f64::consts::FRAC_PI_2;

/// seacover heading ψ [rad] from a MAVLink yaw (clockwise from north).
pub fn heading_from_ned(yaw_ned: f64) -> f64 {
    wrap(FRAC_PI_2 - yaw_ned)
}

/// MAVLink yaw (clockwise from north, wrapped to (−π, π]) from seacover's ψ.
pub fn heading_to_ned(psi: f64) -> f64 {
    wrap(FRAC_PI_2 - psi)
}

/// seacover yaw rate r from MAVLink's (and back: the map is its own inverse).
pub fn yaw_rate_from_ned(yawspeed_ned: f64) -> f64 {
    -yawspeed_ned
}

/// MAVLink yaw rate from seacover's r.
pub fn yaw_rate_to_ned(r: f64) -> f64 {
    -r
}

/// Body (surge u, sway v) in seacover's convention from a ground velocity
/// given north and east [m/s] and seacover's heading ψ.
pub fn body_velocity(v_north: f64, v_east: f64, psi: f64) -> (f64, f64) {
    let (s, c) = psi.sin_cos();
    // World ENU (v_east, v_north) rotated by −ψ: u along the bow, v to port.
    (v_east * c + v_north * s, -v_east * s + v_north * c)
}

/// Ground velocity (north, east) from body (u, v) and ψ, seacover's
/// convention: the inverse of [`body_velocity`].
pub fn ground_velocity(u: f64, v: f64, psi: f64) -> (f64, f64) {
    let (s, c) = psi.sin_cos();
    let east = u * c - v * s;
    let north = u * s + v * c;
    (north, east)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn close(a: f64, b: f64) -> bool {
        wrap(a - b).abs() < 1e-12
    }

    #[test]
    fn compass_points_map_to_their_enu_headings() {
        // (MAVLink yaw, seacover ψ): north, east, south, west.
        for (ned, enu) in [
            (0.0, PI / 2.0),
            (PI / 2.0, 0.0),
            (PI, -PI / 2.0),
            (-PI / 2.0, PI),
        ] {
            assert!(close(heading_from_ned(ned), enu), "{ned} → {enu}");
            assert!(close(heading_to_ned(enu), ned), "{enu} → {ned}");
        }
    }

    #[test]
    fn headings_round_trip_both_ways() {
        for k in -40..=40 {
            let a = k as f64 * 0.17;
            assert!(close(heading_to_ned(heading_from_ned(a)), a));
            assert!(close(heading_from_ned(heading_to_ned(a)), a));
            assert!(heading_from_ned(a) > -PI && heading_from_ned(a) <= PI);
        }
    }

    #[test]
    fn a_starboard_turn_is_a_negative_yaw_rate() {
        // Turning to starboard increases MAVLink yaw and decreases ψ.
        let (yaw, rate_ned, dt) = (0.3, 0.2, 0.01);
        let psi0 = heading_from_ned(yaw);
        let psi1 = heading_from_ned(yaw + rate_ned * dt);
        let r = yaw_rate_from_ned(rate_ned);
        assert!(r < 0.0);
        assert!(((psi1 - psi0) / dt - r).abs() < 1e-9);
        assert_eq!(yaw_rate_to_ned(yaw_rate_from_ned(0.7)), 0.7);
    }

    #[test]
    fn ground_velocity_rotates_into_the_body() {
        // Bow north (ψ = π/2), sailing north at 2 m/s: pure surge.
        let (u, v) = body_velocity(2.0, 0.0, PI / 2.0);
        assert!((u - 2.0).abs() < 1e-12 && v.abs() < 1e-12);
        // Bow north, drifting west (to port): positive sway.
        let (u, v) = body_velocity(0.0, -1.0, PI / 2.0);
        assert!(u.abs() < 1e-12 && (v - 1.0).abs() < 1e-12);
        for k in 0..20 {
            let psi = -3.0 + 0.3 * k as f64;
            let (n, e) = ground_velocity(1.3, -0.4, psi);
            let (u, v) = body_velocity(n, e, psi);
            assert!((u - 1.3).abs() < 1e-12 && (v + 0.4).abs() < 1e-12);
        }
    }
}
