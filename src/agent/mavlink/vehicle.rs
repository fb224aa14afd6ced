//! One autopilot as the bridge sees it: MAVLink telemetry in, seacover poses
//! out; seacover commands in, MAVLink setpoints out. No I/O here: the
//! bridge's tasks feed messages in and send what comes back, so every rule
//! below is testable without a vehicle.
//!
//! Rules (docs/ardupilot.md):
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
//! - with `--station-radius R` (opt-in), a command that says
//!   `station` becomes one position target at that point, sent again only
//!   when the point moves more than R from it: ArduPilot reaches it and
//!   loiters there, still (docs/ardupilot.md, "Quiet arrival");
//! - ages are measured on the vehicle's clock (`time_boot_ms`), so the rules
//!   hold unchanged when a simulator runs faster than real time.

use mavlink::dialects::ardupilotmega::{
    ATTITUDE_DATA, COMMAND_LONG_DATA, EKF_STATUS_REPORT_DATA, EkfStatusFlags,
    GLOBAL_POSITION_INT_DATA, GPS_RAW_INT_DATA, GpsFixType, HEARTBEAT_DATA, MavAutopilot, MavCmd,
    MavFrame, MavMessage, MavModeFlag, MavType, NAMED_VALUE_FLOAT_DATA, PositionTargetTypemask,
    SET_POSITION_TARGET_GLOBAL_INT_DATA, SET_POSITION_TARGET_LOCAL_NED_DATA, SYS_STATUS_DATA,
};

use crate::control::ned;
use crate::geometry::geodesy::{LatLon, LocalFrame};
use crate::protocol::{CommandDocument, FixDocument, LinkSampleDocument, PoseDocument};

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
    /// A sample (NAMED_VALUE_FLOAT of the sample name) whose value is not
    /// finite, or that came before any position.
    InvalidSample,
}

/// Which NAMED_VALUE_FLOAT is a sample of the risk field, and its σ
/// (`agent --sample-name`, `--sample-sd`; docs/learning.md).
#[derive(Debug, Clone, PartialEq)]
pub struct SampleSource {
    /// The message's `name` (at most 10 characters, as MAVLink carries it).
    pub name: String,
    /// The sensor's standard deviation, in the value's units.
    pub sd: f64,
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
    /// EKF_STATUS_REPORT's flags, once one has come.
    ekf_flags: Option<EkfStatusFlags>,
    battery: Option<(f64, i8)>,
    /// The newest `time_boot_ms` seen.
    clock_ms: u32,
    /// The newest command and the vehicle time it arrived.
    command: Option<(CommandDocument, u32)>,
    /// Where the vehicle was told to hold, and when that was last sent.
    hold: Option<(LatLon, u32)>,
    /// When braking on a stale command began (vehicle time).
    braking_since: Option<u32>,
    /// Station keeping is handed to the autopilot's own loiter (the bridge
    /// declared this `station_radius`).
    holds_station: Option<f64>,
    /// The point (x, y in the mission's plane) the vehicle was last told
    /// to keep station at.
    station: Option<(f64, f64)>,
    /// Which NAMED_VALUE_FLOAT is a sample.
    sample: Option<SampleSource>,
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
            ekf_flags: None,
            battery: None,
            clock_ms: 0,
            command: None,
            hold: None,
            braking_since: None,
            holds_station: None,
            station: None,
            sample: None,
            arming: if arm {
                Arming::Wanted { last_ms: None }
            } else {
                Arming::Off
            },
            setpoints: 0,
        }
    }

    /// Station keeping on arrival is left to the autopilot: a command's
    /// `station` point becomes one position target, which ArduPilot's
    /// GUIDED mode reaches and then holds by loitering (`LOIT_RADIUS`).
    pub fn holding_station(mut self, radius: Option<f64>) -> Vehicle {
        self.holds_station = radius;
        self
    }

    /// NAMED_VALUE_FLOATs named `source.name` are samples of the risk
    /// field, taken where the vehicle last said it was.
    pub fn sampling(mut self, source: Option<SampleSource>) -> Vehicle {
        self.sample = source;
        self
    }

    /// A NAMED_VALUE_FLOAT: a sample at the vehicle's newest position when
    /// it carries the sample name, else nothing.
    pub fn on_named_value(
        &self,
        d: &NAMED_VALUE_FLOAT_DATA,
    ) -> Result<Option<LinkSampleDocument>, Refusal> {
        let Some(source) = &self.sample else {
            return Ok(None);
        };
        // MAVLink pads the name with NULs; a name of all ten characters has none.
        let name = d.name.to_str().unwrap_or_default().trim_end_matches('\0');
        if name != source.name {
            return Ok(None);
        }
        let value = f64::from(d.value);
        let Some(p) = self.position.filter(|_| value.is_finite()) else {
            return Err(Refusal::InvalidSample);
        };
        let (x, y) = self.frame.to_local(LatLon {
            lat: p.lat,
            lon: p.lon,
        });
        Ok(Some(LinkSampleDocument {
            x,
            y,
            value,
            sd: source.sd,
        }))
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
        self.station = None;
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
            self.station = None;
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

    pub fn on_ekf_status(&mut self, e: &EKF_STATUS_REPORT_DATA) {
        self.ekf_flags = Some(e.flags);
    }

    /// The position fix as GPS_RAW_INT and EKF_STATUS_REPORT tell it:
    /// unreported until a GPS_RAW_INT has come; no fix below a 3-D one;
    /// the estimator's word when it has no absolute horizontal position
    /// or flags a GPS glitch.
    fn fix(&self) -> Option<FixDocument> {
        let gps = self.gps_fix?;
        if gps < GpsFixType::GPS_FIX_TYPE_3D_FIX as u8 {
            return Some(FixDocument::NoFix);
        }
        match self.ekf_flags {
            Some(f)
                if !f.contains(EkfStatusFlags::EKF_POS_HORIZ_ABS)
                    || f.contains(EkfStatusFlags::EKF_GPS_GLITCHING) =>
            {
                Some(FixDocument::Estimator)
            }
            _ => Some(FixDocument::Good),
        }
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
    /// vehicle is under control. A command to hold (the coordinator
    /// refuses this boat's poses) is a stale command at once: brake, then
    /// hold where the boat stopped, in ArduPilot's own position loop.
    pub fn on_command(&mut self, c: CommandDocument) -> Vec<MavMessage> {
        if c.hold.is_some() {
            self.command = None;
            return self.hold_if_stale();
        }
        let fresh = c.u_d.is_finite() && c.r_d.is_finite();
        let station = c.station.filter(|_| self.holds_station.is_some());
        self.command = Some((c, self.clock_ms));
        if !(fresh && self.controlled()) {
            return Vec::new();
        }
        self.hold = None;
        self.braking_since = None;
        if let Some([x, y]) = station {
            return self.keep_station((x, y));
        }
        self.station = None;
        let (c, _) = self.command.as_ref().expect("just set");
        let (u_d, r_d) = (c.u_d, c.r_d);
        vec![self.velocity_setpoint(u_d, r_d)]
    }

    /// Keeps station at `point` by the autopilot's loiter: one position
    /// target, and another only once the point has moved farther than the
    /// station radius (as far as keeping starts from). Each target
    /// restarts ArduPilot's navigation to it, and a boat that turns only
    /// under way then circles the point (measured on SITL: one target a
    /// second kept it circling 2 m out at 0.5 m/s; one target, then
    /// nothing, left it still within 0.4 m; one each time the goal moved a
    /// metre kept four boats nudging each other's goals, and moving).
    fn keep_station(&mut self, (x, y): (f64, f64)) -> Vec<MavMessage> {
        let gate = self.holds_station.unwrap_or_default();
        if self
            .station
            .is_some_and(|(hx, hy)| (x - hx).hypot(y - hy) <= gate)
        {
            return Vec::new();
        }
        self.station = Some((x, y));
        let point = self.frame.to_geodetic(x, y);
        vec![self.position_target(point)]
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
            self.station = None;
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
        self.station = None;
        vec![self.position_target(point)]
    }

    /// A position target at `point`, for ArduPilot's own position loop.
    fn position_target(&mut self, point: LatLon) -> MavMessage {
        self.setpoints += 1;
        MavMessage::SET_POSITION_TARGET_GLOBAL_INT(SET_POSITION_TARGET_GLOBAL_INT_DATA {
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
        })
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
    /// 4 Hz (mode changes seen sooner), SYS_STATUS, GPS_RAW_INT and
    /// EKF_STATUS_REPORT at 1 Hz.
    pub fn stream_requests(&self) -> Vec<MavMessage> {
        [
            (33u32, 10.0),
            (30, 10.0),
            (0, 4.0),
            (1, 1.0),
            (24, 1.0),
            (193, 1.0),
        ]
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
            fix: self.fix(),
        })
    }
}

#[cfg(test)]
mod tests;
