//! The bridge's rules for one autopilot, checked without I/O.

use super::*;

const ORIGIN: LatLon = LatLon {
    lat: -35.363261,
    lon: 149.165230,
};

fn vehicle(arm: bool) -> Vehicle {
    Vehicle::new(3, 1, LocalFrame::new(ORIGIN).unwrap(), arm)
}

fn heartbeat(mode: u32, armed: bool) -> HEARTBEAT_DATA {
    HEARTBEAT_DATA {
        custom_mode: mode,
        mavtype: MavType::MAV_TYPE_SURFACE_BOAT,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: if armed {
            MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        } else {
            MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        },
        ..Default::default()
    }
}

/// 100 m north and 50 m east of the origin (small-offset formulas,
/// good to centimetres here), heading 30° east of north, going 2 m/s
/// along the bow and turning to starboard at 0.1 rad/s.
fn position(time_ms: u32) -> GLOBAL_POSITION_INT_DATA {
    let m_per_deg_lat = 110_944.0; // at 35.36° S, WGS84
    let m_per_deg_lon = 90_870.0;
    let yaw = 30f64.to_radians();
    GLOBAL_POSITION_INT_DATA {
        time_boot_ms: time_ms,
        lat: ((ORIGIN.lat + 100.0 / m_per_deg_lat) * 1e7).round() as i32,
        lon: ((ORIGIN.lon + 50.0 / m_per_deg_lon) * 1e7).round() as i32,
        vx: (200.0 * yaw.cos()).round() as i16,
        vy: (200.0 * yaw.sin()).round() as i16,
        ..Default::default()
    }
}

fn attitude(time_ms: u32) -> ATTITUDE_DATA {
    ATTITUDE_DATA {
        time_boot_ms: time_ms,
        yaw: 30f32.to_radians(),
        yawspeed: 0.1,
        ..Default::default()
    }
}

fn command(u_d: f64, r_d: f64) -> CommandDocument {
    CommandDocument {
        tick: 1,
        u_d,
        r_d,
        u_d_dot: 0.0,
        r_d_dot: 0.0,
        centroid: [0.0, 0.0],
        e: 1.0,
        psi_e: 0.0,
        hold: None,
        station: None,
    }
}

#[test]
fn a_pose_is_in_the_local_plane_and_seacovers_conventions() {
    let mut v = vehicle(false);
    v.on_heartbeat(&heartbeat(GUIDED, true));
    v.on_attitude(&attitude(1000)).unwrap();
    let (pose, _) = v.on_position(&position(1000)).unwrap();
    let pose = pose.unwrap();
    // An attitude 50 ms older than the position: ψ carried forward by
    // r·dt (0.1 rad/s to starboard for 50 ms).
    v.on_attitude(&attitude(1050)).unwrap();
    let (later, _) = v.on_position(&position(1100)).unwrap();
    assert!((later.unwrap().psi - (60f64.to_radians() - 0.005)).abs() < 1e-6);
    assert!(
        (pose.x - 50.0).abs() < 0.2 && (pose.y - 100.0).abs() < 0.2,
        "{pose:?}"
    );
    // 30° east of north is 60° counter-clockwise from east.
    assert!((pose.psi - 60f64.to_radians()).abs() < 1e-6);
    assert!(
        (pose.u - 2.0).abs() < 0.01 && pose.v.abs() < 0.01,
        "{pose:?}"
    );
    assert!((pose.r + 0.1).abs() < 1e-6);
    assert_eq!(pose.t, 1.0);
    assert_eq!(pose.controlled, Some(true));
}

#[test]
fn commands_go_out_only_while_armed_and_guided() {
    let mut v = vehicle(false);
    v.on_heartbeat(&heartbeat(4, true)); // HOLD
    assert!(v.on_command(command(1.0, 0.2)).is_empty());
    v.on_heartbeat(&heartbeat(GUIDED, false));
    assert!(v.on_command(command(1.0, 0.2)).is_empty());
    v.on_heartbeat(&heartbeat(GUIDED, true));
    let Some(MavMessage::SET_POSITION_TARGET_LOCAL_NED(sp)) = v.on_command(command(1.0, 0.2)).pop()
    else {
        panic!("no setpoint")
    };
    assert_eq!(sp.coordinate_frame as u8, 8); // MAV_FRAME_BODY_NED
    assert_eq!(sp.type_mask.bits(), 1511);
    assert_eq!((sp.target_system, sp.target_component), (3, 1));
    assert_eq!(sp.vx, 1.0);
    // A positive (counter-clockwise) r_d is a negative NED yaw rate.
    assert!((sp.yaw_rate + 0.2).abs() < 1e-7);
    assert_eq!(v.setpoints(), 1);
}

#[test]
fn a_stale_command_brakes_then_holds_and_a_fresh_one_resumes() {
    let mut v = vehicle(false);
    v.on_heartbeat(&heartbeat(GUIDED, true));
    v.on_attitude(&attitude(1000)).unwrap();
    v.on_position(&position(1000)).unwrap();
    assert!(!v.on_command(command(1.5, 0.0)).is_empty());
    // 1.0 s later: still fresh, nothing to send.
    let (_, out) = v.on_position(&position(2000)).unwrap();
    assert!(out.is_empty());
    // 1.1 s, still at 2 m/s: stale, so brake (speed and turn rate 0).
    let (_, out) = v.on_position(&position(2100)).unwrap();
    let [MavMessage::SET_POSITION_TARGET_LOCAL_NED(brake)] = out.as_slice() else {
        panic!("expected a stop, got {out:?}")
    };
    assert_eq!(
        (brake.vx, brake.yaw_rate, brake.type_mask.bits()),
        (0.0, 0.0, 1511)
    );
    // Slowed down: hold where it is now.
    let slow = |t| GLOBAL_POSITION_INT_DATA {
        vx: 10,
        vy: -5,
        ..position(t)
    };
    let (_, out) = v.on_position(&slow(2600)).unwrap();
    let [MavMessage::SET_POSITION_TARGET_GLOBAL_INT(hold)] = out.as_slice() else {
        panic!("expected a hold, got {out:?}")
    };
    let p = slow(2600);
    assert_eq!((hold.lat_int, hold.lon_int), (p.lat, p.lon));
    assert_eq!(hold.type_mask.bits(), POSITION_ONLY);
    // Not repeated within a second, repeated after it, at the same point
    // whatever the boat does meanwhile.
    assert!(v.on_position(&position(3000)).unwrap().1.is_empty());
    let (_, out) = v.on_position(&position(3700)).unwrap();
    let [MavMessage::SET_POSITION_TARGET_GLOBAL_INT(again)] = out.as_slice() else {
        panic!("expected the hold again, got {out:?}")
    };
    assert_eq!((again.lat_int, again.lon_int), (p.lat, p.lon));
    // A new command ends the hold.
    assert!(!v.on_command(command(1.0, 0.1)).is_empty());
    assert!(v.on_position(&position(3800)).unwrap().1.is_empty());
}

#[test]
fn a_lost_link_brakes_at_once() {
    let mut v = vehicle(false);
    v.on_heartbeat(&heartbeat(GUIDED, true));
    v.on_attitude(&attitude(1000)).unwrap();
    v.on_position(&position(1000)).unwrap();
    assert!(!v.on_command(command(1.5, 0.2)).is_empty());
    // 0.1 s after the command, still at 2 m/s: the link drops.
    v.on_position(&position(1100)).unwrap();
    let out = v.on_link_lost();
    let [MavMessage::SET_POSITION_TARGET_LOCAL_NED(brake)] = out.as_slice() else {
        panic!("expected a stop, got {out:?}")
    };
    assert_eq!((brake.vx, brake.yaw_rate), (0.0, 0.0));
    // The next position keeps braking; a second loss adds nothing.
    let (_, out) = v.on_position(&position(1200)).unwrap();
    assert!(matches!(
        out.as_slice(),
        [MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)]
    ));
    assert!(v.on_link_lost().is_empty());
    // Not under control: a loss sends nothing.
    let mut held = vehicle(false);
    held.on_heartbeat(&heartbeat(4, true));
    held.on_attitude(&attitude(1000)).unwrap();
    held.on_position(&position(1000)).unwrap();
    held.on_command(command(1.0, 0.0));
    assert!(held.on_link_lost().is_empty());
}

#[test]
fn a_boat_that_does_not_slow_down_is_held_after_ten_seconds_of_braking() {
    let mut v = vehicle(false);
    v.on_heartbeat(&heartbeat(GUIDED, true));
    v.on_attitude(&attitude(1000)).unwrap();
    v.on_position(&position(1000)).unwrap();
    // No command ever: stale from the start; it keeps reporting 2 m/s.
    for t in (1100..11_000).step_by(100) {
        let (_, out) = v.on_position(&position(t)).unwrap();
        assert!(matches!(
            out.as_slice(),
            [MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)]
        ));
    }
    let (_, out) = v.on_position(&position(11_200)).unwrap();
    assert!(matches!(
        out.as_slice(),
        [MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)]
    ));
}

#[test]
fn an_operator_takeover_sends_nothing_and_is_never_undone() {
    let mut v = vehicle(true);
    v.on_heartbeat(&heartbeat(GUIDED, true)); // --arm is satisfied
    v.on_attitude(&attitude(1000)).unwrap();
    v.on_position(&position(1000)).unwrap();
    assert!(v.controlled());
    let out = v.on_heartbeat(&heartbeat(4, true)); // operator: HOLD
    assert!(out.is_empty());
    assert!(!v.controlled());
    for t in (1100..10_000).step_by(100) {
        let (pose, out) = v.on_position(&position(t)).unwrap();
        assert!(out.is_empty(), "sent {out:?} to a boat in HOLD");
        assert_eq!(pose.unwrap().controlled, Some(false));
        assert!(v.on_command(command(1.0, 0.0)).is_empty());
        assert!(v.on_heartbeat(&heartbeat(4, true)).is_empty());
    }
    v.on_heartbeat(&heartbeat(GUIDED, true));
    assert!(!v.on_command(command(1.0, 0.0)).is_empty());
}

#[test]
fn arm_switches_to_guided_then_arms_then_stops_asking() {
    let mut v = vehicle(true);
    let out = v.on_heartbeat(&heartbeat(0, false)); // MANUAL, disarmed
    let [MavMessage::COMMAND_LONG(c)] = out.as_slice() else {
        panic!("{out:?}")
    };
    assert_eq!(c.command, MavCmd::MAV_CMD_DO_SET_MODE);
    assert_eq!(c.param2, 15.0);
    // Not again within a second of vehicle time.
    assert!(v.on_heartbeat(&heartbeat(0, false)).is_empty());
    v.on_attitude(&attitude(1500)).unwrap();
    let out = v.on_heartbeat(&heartbeat(GUIDED, false));
    let [MavMessage::COMMAND_LONG(c)] = out.as_slice() else {
        panic!("{out:?}")
    };
    assert_eq!(c.command, MavCmd::MAV_CMD_COMPONENT_ARM_DISARM);
    assert_eq!(c.param1, 1.0);
    assert!(v.on_heartbeat(&heartbeat(GUIDED, true)).is_empty());
    // Disarmed later by the operator: the bridge does not re-arm.
    v.on_attitude(&attitude(9000)).unwrap();
    assert!(v.on_heartbeat(&heartbeat(GUIDED, false)).is_empty());
}

#[test]
fn bad_positions_and_attitudes_are_refused_and_change_nothing() {
    let mut v = vehicle(false);
    v.on_heartbeat(&heartbeat(GUIDED, true));
    v.on_attitude(&attitude(1000)).unwrap();
    let (good, _) = v.on_position(&position(1000)).unwrap();
    let far = GLOBAL_POSITION_INT_DATA {
        lat: 10_000_000,
        lon: 10_000_000,
        ..position(1100)
    };
    assert_eq!(v.on_position(&far).unwrap_err(), Refusal::FarFromOrigin);
    // The antipode: near the origin in the plane, not on the globe.
    let antipode = GLOBAL_POSITION_INT_DATA {
        lat: (-ORIGIN.lat * 1e7).round() as i32,
        lon: ((ORIGIN.lon - 180.0) * 1e7).round() as i32,
        ..position(1100)
    };
    assert_eq!(
        v.on_position(&antipode).unwrap_err(),
        Refusal::FarFromOrigin
    );
    let wild = GLOBAL_POSITION_INT_DATA {
        lat: 95 * 10_000_000,
        ..position(1100)
    };
    assert_eq!(v.on_position(&wild).unwrap_err(), Refusal::InvalidPosition);
    let nan = ATTITUDE_DATA {
        yaw: f32::NAN,
        ..attitude(1100)
    };
    assert_eq!(v.on_attitude(&nan).unwrap_err(), Refusal::InvalidAttitude);
    let inf = ATTITUDE_DATA {
        yawspeed: f32::INFINITY,
        ..attitude(1100)
    };
    assert_eq!(v.on_attitude(&inf).unwrap_err(), Refusal::InvalidAttitude);
    let (again, _) = v.on_position(&position(1000)).unwrap();
    let state = |p: Option<PoseDocument>| p.map(|p| (p.t, p.x, p.y, p.psi, p.u, p.v, p.r));
    assert_eq!(state(good), state(again));
}

#[test]
fn ground_stations_are_not_vehicles() {
    let gcs = HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        ..Default::default()
    };
    assert!(!is_vehicle(&gcs));
    assert!(is_vehicle(&heartbeat(GUIDED, true)));
}

/// The fix as ArduPilot's SITL reports it (measured with pymavlink): fix
/// type 0 for its first seconds, then 6 (RTK fixed); the EKF without an
/// absolute horizontal position (flags 0xa7) until about 42 s of simulated
/// time, then 0x33f.
#[test]
fn the_fix_follows_gps_raw_int_and_the_ekf() {
    use mavlink::dialects::ardupilotmega::{EKF_STATUS_REPORT_DATA, EkfStatusFlags, GpsFixType};
    let mut v = vehicle(true);
    assert_eq!(v.fix(), None);
    let gps = |fix_type| GPS_RAW_INT_DATA {
        fix_type,
        ..GPS_RAW_INT_DATA::DEFAULT
    };
    let ekf = |bits| EKF_STATUS_REPORT_DATA {
        flags: EkfStatusFlags::from_bits_truncate(bits),
        ..EKF_STATUS_REPORT_DATA::DEFAULT
    };
    v.on_gps(&gps(GpsFixType::GPS_FIX_TYPE_NO_FIX));
    assert_eq!(v.fix(), Some(FixDocument::NoFix));
    v.on_gps(&gps(GpsFixType::GPS_FIX_TYPE_RTK_FIXED));
    assert_eq!(v.fix(), Some(FixDocument::Good));
    v.on_ekf_status(&ekf(0xa7));
    assert_eq!(v.fix(), Some(FixDocument::Estimator));
    v.on_ekf_status(&ekf(0x33f));
    assert_eq!(v.fix(), Some(FixDocument::Good));
    // A GPS glitch flagged by the estimator.
    v.on_ekf_status(&ekf(0x33f | EkfStatusFlags::EKF_GPS_GLITCHING.bits()));
    assert_eq!(v.fix(), Some(FixDocument::Estimator));
}

/// Quiet arrival: a command that says `station` becomes one position
/// target there, not repeated while the point stays within the station
/// radius nor while the command stays fresh; a point moved past it is
/// sent again; a command without `station` is a velocity again. A bridge
/// that did not declare a radius follows the velocity as always.
#[test]
fn a_station_point_is_sent_once_and_again_only_when_it_moves() {
    const GATE: f64 = 3.0;
    let keeping = |x: f64, y: f64| CommandDocument {
        station: Some([x, y]),
        ..command(0.05, 0.0)
    };
    let mut plain = vehicle(false);
    plain.on_heartbeat(&heartbeat(GUIDED, true));
    assert!(matches!(
        plain.on_command(keeping(50.0, 100.0)).as_slice(),
        [MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)]
    ));

    let mut v = vehicle(false).holding_station(Some(GATE));
    v.on_heartbeat(&heartbeat(GUIDED, true));
    v.on_attitude(&attitude(1000)).unwrap();
    v.on_position(&position(1000)).unwrap();
    let out = v.on_command(keeping(50.0, 100.0));
    let [MavMessage::SET_POSITION_TARGET_GLOBAL_INT(target)] = out.as_slice() else {
        panic!("expected a position target, got {out:?}")
    };
    assert_eq!(target.type_mask.bits(), POSITION_ONLY);
    let frame = LocalFrame::new(ORIGIN).unwrap();
    let there = LatLon {
        lat: f64::from(target.lat_int) * 1e-7,
        lon: f64::from(target.lon_int) * 1e-7,
    };
    let (x, y) = frame.to_local(there);
    assert!(
        (x - 50.0).abs() < 0.02 && (y - 100.0).abs() < 0.02,
        "{x} {y}"
    );
    // Ten seconds of fresh commands at a point that wanders within the
    // gate: nothing more is sent, and the command never goes stale.
    for k in 1..=100u32 {
        let t = 1000 + 100 * k;
        v.on_position(&position(t)).unwrap();
        let wander = 0.5 * GATE * (f64::from(k) * 0.3).sin();
        assert!(
            v.on_command(keeping(50.0 + wander, 100.0)).is_empty(),
            "{k}"
        );
        assert!(v.on_position(&position(t + 50)).unwrap().1.is_empty());
    }
    let moved = v.on_command(keeping(50.0 + 1.5 * GATE, 100.0));
    assert!(matches!(
        moved.as_slice(),
        [MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)]
    ));
    // Keeping over: a velocity again; keeping again: a target again.
    assert!(matches!(
        v.on_command(command(1.0, 0.1)).as_slice(),
        [MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)]
    ));
    assert!(matches!(
        v.on_command(keeping(50.0, 100.0)).as_slice(),
        [MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)]
    ));
    // An operator's takeover forgets it: back in GUIDED, it is sent again.
    v.on_heartbeat(&heartbeat(4, true));
    assert!(v.on_command(keeping(50.0, 100.0)).is_empty());
    v.on_heartbeat(&heartbeat(GUIDED, true));
    assert!(matches!(
        v.on_command(keeping(50.0, 100.0)).as_slice(),
        [MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)]
    ));
}

/// A NAMED_VALUE_FLOAT of the sample name is a sample where the boat last
/// was (the name NUL-padded as MAVLink carries it); other names are not
/// samples; a non-finite value, or one before any position, is refused.
#[test]
fn a_named_float_of_the_sample_name_is_a_sample_at_the_boat() {
    let source = SampleSource {
        name: "RISK".into(),
        sd: 0.05,
    };
    let mut v = vehicle(false).sampling(Some(source));
    let named = |name: &str, value: f32| NAMED_VALUE_FLOAT_DATA {
        time_boot_ms: 10,
        value,
        name: name.into(),
    };
    assert_eq!(
        v.on_named_value(&named("RISK", 2.5)),
        Err(Refusal::InvalidSample),
        "before any position"
    );
    v.on_attitude(&attitude(100)).unwrap();
    v.on_position(&position(100)).unwrap();
    let s = v.on_named_value(&named("RISK", 2.5)).unwrap().unwrap();
    assert!(
        (s.x - 50.0).abs() < 0.1 && (s.y - 100.0).abs() < 0.1,
        "{s:?}"
    );
    assert_eq!((s.value, s.sd), (2.5, 0.05));
    assert_eq!(v.on_named_value(&named("DEPTH", 2.5)), Ok(None));
    assert_eq!(v.on_named_value(&named("RISKY", 2.5)), Ok(None));
    assert_eq!(
        v.on_named_value(&named("RISK", f32::NAN)),
        Err(Refusal::InvalidSample)
    );
    // Without --sample-name nothing is a sample.
    assert_eq!(vehicle(false).on_named_value(&named("RISK", 1.0)), Ok(None));
}
