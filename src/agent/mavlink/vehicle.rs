//! One autopilot as the bridge sees it: MAVLink telemetry in, seacover poses
//! out; seacover commands in, MAVLink setpoints out. No I/O here: the
//! bridge's tasks feed messages in and send what comes back, so every rule
//! below is testable without a vehicle.
//!
//! Rules (issue 15 §2, docs/ardupilot.md):
//! - a pose is made from each GLOBAL_POSITION_INT with the newest ATTITUDE:
//!   x, y through the mission's origin, ψ, u, v, r converted in
//!   [`crate::control::ned`]; positions that are not finite, out of range or
//!   farther than [`LocalFrame::RANGE`] from the origin are refused, and so
//!   are non-finite attitudes;
//! - the vehicle is **controlled** while its newest HEARTBEAT says armed and
//!   GUIDED; only then does the bridge send it anything that moves it, and it
//!   never changes the mode or arms by itself except once at start with
//!   `--arm`;
//! - while controlled, every fresh command becomes one velocity + yaw-rate
//!   setpoint (SET_POSITION_TARGET_LOCAL_NED, MAV_FRAME_BODY_NED, type mask
//!   1511); once the newest command is more than [`STALE_MS`] old on the
//!   vehicle's own clock (or there has been none, or the coordinator's
//!   link has closed since: [`Vehicle::on_link_lost`]), the vehicle is told to
//!   stop (speed and turn rate zero) and, once below [`SETTLED`], to hold
//!   where it stopped (a position target there, repeated each second):
//!   never an old velocity;
//! - ages are measured on the vehicle's clock (`time_boot_ms`), so the rules
//!   hold unchanged when a simulator runs faster than real time.

use mavlink::dialects::ardupilotmega::{
    ATTITUDE_DATA, COMMAND_LONG_DATA, GLOBAL_POSITION_INT_DATA, GPS_RAW_INT_DATA, HEARTBEAT_DATA,
    MavAutopilot, MavCmd, MavFrame, MavMessage, MavModeFlag, MavType, PositionTargetTypemask,
    SET_POSITION_TARGET_GLOBAL_INT_DATA, SET_POSITION_TARGET_LOCAL_NED_DATA, SYS_STATUS_DATA,
};

use crate::control::ned;
use crate::geometry::geodesy::{LatLon, LocalFrame};
use crate::protocol::{CommandDocument, PoseDocument};

/// ArduPilot Rover's GUIDED custom mode.
pub const GUIDED: u32 = 15;
/// A command older than this on the vehicle's clock is stale [ms].
pub const STALE_MS: u32 = 1000;
/// Velocity and yaw rate only: ignore position (1 | 2 | 4), vz (32),
/// acceleration (64 | 128 | 256) and yaw (1024); vx, vy and yaw_rate used.
pub const VELOCITY_YAW_RATE: u16 = 1511;
/// Below this ground speed [m/s] a braking boat is told to hold where it
/// is.
pub const SETTLED: f64 = 0.3;
/// The longest a boat brakes before it is told to hold anyway [ms].
pub const BRAKE_MS: u32 = 10_000;
/// Position only: ignore velocity (8 | 16 | 32), acceleration
/// (64 | 128 | 256), yaw (1024) and yaw rate (2048).
pub const POSITION_ONLY: u16 = 0b1111_1111_1000;

/// Why a message from a vehicle was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// A position that is not a valid WGS84 position.
    InvalidPosition,
    /// A valid position farther than [`LocalFrame::RANGE`] from the origin.
    FarFromOrigin,
    /// An attitude with a non-finite yaw or yaw rate.
    InvalidAttitude,
}

/// ArduPilot Rover's mode names by custom mode.
pub fn rover_mode(custom_mode: u32) -> &'static str {
    match custom_mode {
        0 => "MANUAL",
        1 => "ACRO",
        3 => "STEERING",
        4 => "HOLD",
        5 => "LOITER",
        6 => "FOLLOW",
        7 => "SIMPLE",
        8 => "DOCK",
        9 => "CIRCLE",
        10 => "AUTO",
        11 => "RTL",
        12 => "SMART_RTL",
        15 => "GUIDED",
        16 => "INITIALISING",
        _ => "UNKNOWN",
    }
}

/// Whether a HEARTBEAT comes from a vehicle (not a ground station or
/// another bridge).
pub fn is_vehicle(hb: &HEARTBEAT_DATA) -> bool {
    hb.mavtype != MavType::MAV_TYPE_GCS && hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
}

#[derive(Debug, Clone, Copy)]
struct Position {
    lat: f64,
    lon: f64,
    /// Ground velocity north and east [m/s].
    v_north: f64,
    v_east: f64,
    time_ms: u32,
}

#[derive(Debug, Clone, Copy)]
struct Attitude {
    yaw: f64,
    yawspeed: f64,
    time_ms: u32,
}

/// `--arm`'s one attempt at start, retried until it takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Arming {
    /// Not asked for, or done: the bridge never touches mode or arming.
    Off,
    /// Asked for; the last request went out at this vehicle time.
    Wanted { last_ms: Option<u32> },
}

/// The bridge's view of one autopilot.
#[derive(Debug)]
pub struct Vehicle {
    sysid: u8,
    compid: u8,
    frame: LocalFrame,
    custom_mode: Option<u32>,
    armed: bool,
    attitude: Option<Attitude>,
    position: Option<Position>,
    gps_fix: Option<u8>,
    battery: Option<(f64, i8)>,
    /// The newest `time_boot_ms` seen.
    clock_ms: u32,
    /// The newest command and the vehicle time it arrived.
    command: Option<(CommandDocument, u32)>,
    /// Where the vehicle was told to hold, and when that was last sent.
    hold: Option<(LatLon, u32)>,
    /// When braking on a stale command began (vehicle time).
    braking_since: Option<u32>,
    arming: Arming,
    setpoints: u64,
}

impl Vehicle {
    pub fn new(sysid: u8, compid: u8, frame: LocalFrame, arm: bool) -> Vehicle {
        Vehicle {
            sysid,
            compid,
            frame,
            custom_mode: None,
            armed: false,
            attitude: None,
            position: None,
            gps_fix: None,
            battery: None,
            clock_ms: 0,
            command: None,
            hold: None,
            braking_since: None,
            arming: if arm {
                Arming::Wanted { last_ms: None }
            } else {
                Arming::Off
            },
            setpoints: 0,
        }
    }

    /// Armed and in GUIDED: the coordinator's commands are followed.
    pub fn controlled(&self) -> bool {
        self.armed && self.custom_mode == Some(GUIDED)
    }

    pub fn mode(&self) -> &'static str {
        self.custom_mode.map_or("UNKNOWN", rover_mode)
    }

    /// Setpoints sent so far (velocity and hold).
    pub fn setpoints(&self) -> u64 {
        self.setpoints
    }

    /// The mission's origin moved: later poses use the new plane.
    pub fn set_frame(&mut self, frame: LocalFrame) {
        self.frame = frame;
    }

    /// Mode and arming from a HEARTBEAT; returns what to send (arming).
    pub fn on_heartbeat(&mut self, hb: &HEARTBEAT_DATA) -> Vec<MavMessage> {
        self.custom_mode = Some(hb.custom_mode);
        self.armed = hb
            .base_mode
            .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
        if !self.controlled() {
            // The operator (or a failsafe) has it: whatever hold point we
            // had is forgotten, and nothing is sent until GUIDED again.
            self.hold = None;
            self.braking_since = None;
        }
        self.arming_requests()
    }

    pub fn on_attitude(&mut self, a: &ATTITUDE_DATA) -> Result<(), Refusal> {
        let (yaw, yawspeed) = (f64::from(a.yaw), f64::from(a.yawspeed));
        if !(yaw.is_finite() && yawspeed.is_finite()) {
            return Err(Refusal::InvalidAttitude);
        }
        self.advance_clock(a.time_boot_ms);
        self.attitude = Some(Attitude {
            yaw,
            yawspeed,
            time_ms: a.time_boot_ms,
        });
        Ok(())
    }

    pub fn on_gps(&mut self, g: &GPS_RAW_INT_DATA) {
        self.gps_fix = Some(g.fix_type as u8);
    }

    pub fn on_sys_status(&mut self, s: &SYS_STATUS_DATA) {
        self.battery = Some((f64::from(s.voltage_battery) / 1000.0, s.battery_remaining));
    }

    /// A position: the pose to report (once an attitude is known) and what
    /// to send the vehicle (a hold when the newest command is stale).
    pub fn on_position(
        &mut self,
        p: &GLOBAL_POSITION_INT_DATA,
    ) -> Result<(Option<PoseDocument>, Vec<MavMessage>), Refusal> {
        if p.lat == 0 && p.lon == 0 {
            // ArduPilot's way of saying it has no position yet (before the
            // EKF has an origin): nothing to report, nothing refused.
            return Ok((None, Vec::new()));
        }
        let ll = LatLon::new(f64::from(p.lat) * 1e-7, f64::from(p.lon) * 1e-7)
            .map_err(|_| Refusal::InvalidPosition)?;
        // Reach by the straight line through the earth, not by the plane:
        // the plane folds the far side of the globe back near the origin
        // (the antipode lands within 43 km of it).
        if self.frame.chord(ll) > LocalFrame::RANGE {
            return Err(Refusal::FarFromOrigin);
        }
        let (x, y) = self.frame.to_local(ll);
        self.advance_clock(p.time_boot_ms);
        self.position = Some(Position {
            lat: ll.lat,
            lon: ll.lon,
            v_north: f64::from(p.vx) / 100.0,
            v_east: f64::from(p.vy) / 100.0,
            time_ms: p.time_boot_ms,
        });
        let mut out = self.hold_if_stale();
        out.extend(self.arming_requests());
        Ok((self.pose(x, y), out))
    }

    /// A command from the coordinator: the setpoint to send, if the
    /// vehicle is under control.
    pub fn on_command(&mut self, c: CommandDocument) -> Option<MavMessage> {
        let fresh = c.u_d.is_finite() && c.r_d.is_finite();
        self.command = Some((c, self.clock_ms));
        if !(fresh && self.controlled()) {
            return None;
        }
        self.hold = None;
        self.braking_since = None;
        let (c, _) = self.command.as_ref().expect("just set");
        let (u_d, r_d) = (c.u_d, c.r_d);
        Some(self.velocity_setpoint(u_d, r_d))
    }

    /// The coordinator's link closed: the newest command is as good as
    /// stale now, so the boat brakes at once instead of driving on for the
    /// rest of [`STALE_MS`] (a killed coordinator closes its sockets at
    /// once; a silent one is still caught by the age).
    pub fn on_link_lost(&mut self) -> Vec<MavMessage> {
        if self.command.is_none() {
            return Vec::new();
        }
        self.command = None;
        self.hold_if_stale()
    }

    /// Speed `u_d` along the bow and yaw rate `r_d` (seacover's sign).
    fn velocity_setpoint(&mut self, u_d: f64, r_d: f64) -> MavMessage {
        self.setpoints += 1;
        MavMessage::SET_POSITION_TARGET_LOCAL_NED(SET_POSITION_TARGET_LOCAL_NED_DATA {
            time_boot_ms: self.clock_ms,
            target_system: self.sysid,
            target_component: self.compid,
            // Superseded in MAVLink by BODY_FRD, but BODY_NED is the body
            // frame ArduPilot Rover reads for this message.
            #[allow(deprecated)]
            coordinate_frame: MavFrame::MAV_FRAME_BODY_NED,
            type_mask: PositionTargetTypemask::from_bits_truncate(VELOCITY_YAW_RATE),
            // Rover takes |v| as the speed: it cannot be told to go astern
            // this way, so a negative surge becomes a stop.
            vx: u_d.max(0.0) as f32,
            yaw_rate: ned::yaw_rate_to_ned(r_d) as f32,
            ..Default::default()
        })
    }

    fn advance_clock(&mut self, time_ms: u32) {
        // A rebooted autopilot starts its clock again: follow it, and let
        // an old command count as stale.
        if time_ms < self.clock_ms {
            self.command = None;
            self.hold = None;
            self.braking_since = None;
        }
        self.clock_ms = time_ms;
    }

    fn stale(&self) -> bool {
        match &self.command {
            Some((_, at)) => self.clock_ms.saturating_sub(*at) > STALE_MS,
            None => true,
        }
    }

    /// Stale commands: first brake (speed and yaw rate zero) until the
    /// boat is below [`SETTLED`] (or [`BRAKE_MS`] have passed), then hold
    /// where it stopped. Holding the point where the command went stale
    /// instead would send a boat at speed round in a U-turn to come back to
    /// it.
    fn hold_if_stale(&mut self) -> Vec<MavMessage> {
        if !(self.controlled() && self.stale()) {
            return Vec::new();
        }
        let Some(p) = self.position else {
            return Vec::new();
        };
        if self.hold.is_none() {
            let since = *self.braking_since.get_or_insert(self.clock_ms);
            let moving = p.v_north.hypot(p.v_east) >= SETTLED;
            if moving && self.clock_ms.saturating_sub(since) < BRAKE_MS {
                return vec![self.velocity_setpoint(0.0, 0.0)];
            }
        }
        let (point, due) = match self.hold {
            Some((point, sent)) => (point, self.clock_ms.saturating_sub(sent) >= 1000),
            None => (
                LatLon {
                    lat: p.lat,
                    lon: p.lon,
                },
                true,
            ),
        };
        if !due {
            return Vec::new();
        }
        self.hold = Some((point, self.clock_ms));
        self.setpoints += 1;
        vec![MavMessage::SET_POSITION_TARGET_GLOBAL_INT(
            SET_POSITION_TARGET_GLOBAL_INT_DATA {
                time_boot_ms: self.clock_ms,
                target_system: self.sysid,
                target_component: self.compid,
                // The frame every ArduPilot accepts for a global target
                // (MAVLink now prefers its synonym GLOBAL).
                #[allow(deprecated)]
                coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_INT,
                type_mask: PositionTargetTypemask::from_bits_truncate(POSITION_ONLY),
                lat_int: (point.lat * 1e7).round() as i32,
                lon_int: (point.lon * 1e7).round() as i32,
                ..Default::default()
            },
        )]
    }

    /// With `--arm`: GUIDED first, then arm, once a second of vehicle time
    /// until both hold; after that never again.
    fn arming_requests(&mut self) -> Vec<MavMessage> {
        let Arming::Wanted { last_ms } = self.arming else {
            return Vec::new();
        };
        if self.controlled() {
            self.arming = Arming::Off;
            return Vec::new();
        }
        if self.custom_mode.is_none()
            || last_ms.is_some_and(|t| self.clock_ms.saturating_sub(t) < 1000)
        {
            return Vec::new();
        }
        self.arming = Arming::Wanted {
            last_ms: Some(self.clock_ms),
        };
        let command = if self.custom_mode != Some(GUIDED) {
            COMMAND_LONG_DATA {
                command: MavCmd::MAV_CMD_DO_SET_MODE,
                param1: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED.bits() as f32,
                param2: GUIDED as f32,
                ..self.command_to()
            }
        } else {
            COMMAND_LONG_DATA {
                command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                param1: 1.0,
                ..self.command_to()
            }
        };
        vec![MavMessage::COMMAND_LONG(command)]
    }

    fn command_to(&self) -> COMMAND_LONG_DATA {
        COMMAND_LONG_DATA {
            target_system: self.sysid,
            target_component: self.compid,
            ..Default::default()
        }
    }

    /// Asks for GLOBAL_POSITION_INT and ATTITUDE at 10 Hz, HEARTBEAT at
    /// 4 Hz (mode changes seen sooner), SYS_STATUS and GPS_RAW_INT at 1 Hz.
    pub fn stream_requests(&self) -> Vec<MavMessage> {
        [(33u32, 10.0), (30, 10.0), (0, 4.0), (1, 1.0), (24, 1.0)]
            .into_iter()
            .map(|(id, hz)| {
                MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                    command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                    param1: id as f32,
                    param2: (1e6 / hz) as f32,
                    ..self.command_to()
                })
            })
            .collect()
    }

    fn pose(&self, x: f64, y: f64) -> Option<PoseDocument> {
        let a = self.attitude?;
        let p = self.position?;
        // ATTITUDE and GLOBAL_POSITION_INT are sent at different instants
        // (tens of ms apart): carry the heading to the position's instant
        // with the yaw rate, so the pose is of one instant.
        let dt = ((f64::from(p.time_ms) - f64::from(a.time_ms)) / 1000.0).clamp(-0.2, 0.2);
        let psi = ned::heading_from_ned(a.yaw + a.yawspeed * dt);
        let (u, v) = ned::body_velocity(p.v_north, p.v_east, psi);
        Some(PoseDocument {
            t: f64::from(p.time_ms) / 1000.0,
            x,
            y,
            psi,
            u,
            v,
            r: ned::yaw_rate_from_ned(a.yawspeed),
            controlled: Some(self.controlled()),
            telemetry: Some(serde_json::json!({
                "sysid": self.sysid,
                "mode": self.mode(),
                "armed": self.armed,
                "gps_fix": self.gps_fix,
                "battery": self.battery.map(|(volts, remaining)| serde_json::json!({
                    "voltage": volts,
                    "remaining": (remaining >= 0).then_some(remaining),
                })),
                "lat": p.lat,
                "lon": p.lon,
                "setpoints": self.setpoints,
            })),
        })
    }
}

#[cfg(test)]
mod tests {
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
                MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED
                    | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
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
        assert!(v.on_command(command(1.0, 0.2)).is_none());
        v.on_heartbeat(&heartbeat(GUIDED, false));
        assert!(v.on_command(command(1.0, 0.2)).is_none());
        v.on_heartbeat(&heartbeat(GUIDED, true));
        let Some(MavMessage::SET_POSITION_TARGET_LOCAL_NED(sp)) = v.on_command(command(1.0, 0.2))
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
        assert!(v.on_command(command(1.5, 0.0)).is_some());
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
        assert!(v.on_command(command(1.0, 0.1)).is_some());
        assert!(v.on_position(&position(3800)).unwrap().1.is_empty());
    }

    #[test]
    fn a_lost_link_brakes_at_once() {
        let mut v = vehicle(false);
        v.on_heartbeat(&heartbeat(GUIDED, true));
        v.on_attitude(&attitude(1000)).unwrap();
        v.on_position(&position(1000)).unwrap();
        assert!(v.on_command(command(1.5, 0.2)).is_some());
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
            assert!(v.on_command(command(1.0, 0.0)).is_none());
            assert!(v.on_heartbeat(&heartbeat(4, true)).is_empty());
        }
        v.on_heartbeat(&heartbeat(GUIDED, true));
        assert!(v.on_command(command(1.0, 0.0)).is_some());
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
}
