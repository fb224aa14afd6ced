//! ArduPilot Rover SITL boats for the tests that run the MAVLink bridge
//! against ArduPilot's own simulator (`ardupilot_sitl`, `ardupilot_peer`,
//! `sitl_script`): the binary and its parameter files, boats started as
//! processes on free instances, positions placed and read back by
//! geographiclib, `seacover agent --mavlink …` as a process with its JSON log
//! collected, and an operator's ground station on a boat's second MAVLink
//! port ([`Station`]), which is what the tests judge by. The same boats,
//! bridges and stations each in a network namespace of their own are
//! [`super::sitl_medium`]'s.
//!
//! SITL runs at [`SPEEDUP`]; durations of the boats' world are read on
//! ArduPilot's own clock (`time_boot_ms`). Without a binary the tests say so
//! and pass, except under `CI=true`, where they fail ([`ardupilot`]).

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::{
    COMMAND_LONG_DATA, GLOBAL_POSITION_INT_DATA, MavCmd, MavMessage, MavModeFlag,
};
use mavlink::{AsyncMavConnection, MavHeader};

/// The boats' clock against the wall clock (SITL's `--speedup`).
pub(crate) const SPEEDUP: u32 = 4;
/// The mission's origin: ArduPilot's test field at Canberra.
pub(crate) const ORIGIN: (f64, f64) = (-35.363261, 149.165230);
/// One SITL fleet at a time (their ports are fixed), beside at most a
/// peer fleet of eight: a quarter of the machine ([`super::machine`]).
pub(crate) use super::machine::quarter_async as one_sitl_fleet;

pub(crate) struct Ardupilot {
    pub binary: PathBuf,
    pub defaults: String,
}

pub(crate) fn ardupilot() -> Option<Ardupilot> {
    let binary = match std::env::var_os("ARDUPILOT_SITL") {
        Some(p) => PathBuf::from(p),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/ardupilot/ardurover"),
    };
    if !binary.is_file() {
        let why = format!(
            "no ArduPilot SITL binary at {} (set ARDUPILOT_SITL; docs/ardupilot.md says how to build it)",
            binary.display()
        );
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "{why}: required under CI=true"
        );
        eprintln!("skipped: {why}");
        return None;
    }
    let defaults = std::env::var("ARDUPILOT_DEFAULTS").ok().unwrap_or_else(|| {
        let dir = binary.parent().unwrap();
        let beside = [dir.join("rover.parm"), dir.join("motorboat.parm")];
        let tree = dir.join("../../../Tools/autotest/default_params");
        let in_tree = [tree.join("rover.parm"), tree.join("motorboat.parm")];
        let files = if beside.iter().all(|p| p.is_file()) {
            beside
        } else {
            in_tree
        };
        files
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(",")
    });
    // seacover's own settings after ArduPilot's, as scripts/sitl-boats
    // loads them.
    let ours = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/sitl/seacover.parm");
    let defaults = format!("{defaults},{}", ours.display());
    Some(Ardupilot { binary, defaults })
}

/// A running SITL boat.
pub(crate) struct Boat {
    pub child: Child,
    pub sysid: u8,
    /// The bridge's port (SITL's SERIAL0).
    pub primary: u16,
    /// A ground station's port.
    pub second: u16,
    _dir: tempfile::TempDir,
}

impl Drop for Boat {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// SITL instance numbers (ports 5760 + 10 I and 5762 + 10 I), taken from a
/// range no default SITL uses, skipping any whose ports are busy.
pub(crate) fn instance() -> u32 {
    static NEXT: AtomicU32 = AtomicU32::new(40);
    loop {
        let i = NEXT.fetch_add(1, Ordering::Relaxed);
        let free = |p: u32| std::net::TcpListener::bind(("127.0.0.1", p as u16)).is_ok();
        if free(5760 + 10 * i) && free(5762 + 10 * i) {
            return i;
        }
    }
}

/// Starts boat `sysid` at `home` (lat, lon) heading `heading_deg`, as
/// `start-boats` does.
pub(crate) fn boat(ap: &Ardupilot, sysid: u8, home: (f64, f64), heading_deg: f64) -> Boat {
    boat_with(ap, sysid, home, heading_deg, None)
}

/// [`boat`], running the Lua `script` (as `script.lua` in the `scripts`
/// folder of its working directory, with `SCR_ENABLE 1`) when one is given.
pub(crate) fn boat_with(
    ap: &Ardupilot,
    sysid: u8,
    home: (f64, f64),
    heading_deg: f64,
    script: Option<&str>,
) -> Boat {
    let command = Command::new(&ap.binary);
    boat_by(command, instance(), ap, sysid, (home, heading_deg), script)
}

/// [`boat_with`] started as `command` (the SITL binary, or a program that
/// runs it: [`super::sitl_medium`] runs it inside a network namespace) on
/// SITL instance `i`.
pub(crate) fn boat_by(
    mut command: Command,
    i: u32,
    ap: &Ardupilot,
    sysid: u8,
    (home, heading_deg): ((f64, f64), f64),
    script: Option<&str>,
) -> Boat {
    let dir = tempfile::tempdir().unwrap();
    let mut defaults = ap.defaults.clone();
    if let Some(lua) = script {
        std::fs::create_dir(dir.path().join("scripts")).unwrap();
        std::fs::write(dir.path().join("scripts/script.lua"), lua).unwrap();
        let parm = dir.path().join("scripting.parm");
        std::fs::write(&parm, "SCR_ENABLE 1\n").unwrap();
        defaults = format!("{defaults},{}", parm.display());
    }
    let child = command
        .args(["--model", "motorboat", "--defaults", &defaults])
        .arg("--home")
        .arg(format!("{:.7},{:.7},0,{heading_deg}", home.0, home.1))
        .arg(format!("-I{i}"))
        .args([
            "--sysid",
            &sysid.to_string(),
            "-w",
            "--speedup",
            &SPEEDUP.to_string(),
        ])
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    Boat {
        child,
        sysid,
        primary: (5760 + 10 * i) as u16,
        second: (5762 + 10 * i) as u16,
        _dir: dir,
    }
}

/// The point `distance` m from the origin on bearing `azimuth` (degrees
/// clockwise from north), by geographiclib.
pub(crate) fn place(distance: f64, azimuth: f64) -> (f64, f64) {
    let a = azimuth.to_radians();
    crate::common::geo::place(ORIGIN, distance * a.sin(), distance * a.cos())
}

/// East and north [m] of a WGS84 position from the origin, by geographiclib.
pub(crate) fn east_north(lat: f64, lon: f64) -> (f64, f64) {
    crate::common::geo::locate(ORIGIN, lat, lon)
}

/// `seacover agent --mavlink …` as a process, its JSON log collected.
pub(crate) struct Bridge {
    pub child: Child,
    pub log: Arc<Mutex<Vec<serde_json::Value>>>,
}

impl Bridge {
    /// A bridge of `endpoints` onto the coordinator at `server`, with
    /// `--arm` and the `extra` arguments.
    pub(crate) fn start(server: &str, endpoints: &[String], extra: &[&str]) -> Bridge {
        let mut args: Vec<String> = ["--server", server, "--arm"].map(String::from).to_vec();
        args.extend(extra.iter().map(|a| a.to_string()));
        for e in endpoints {
            args.extend(["--mavlink".to_string(), e.clone()]);
        }
        Bridge::agent(&args)
    }

    /// [`Bridge::start`] of every boat of `boats`, each on its primary port.
    pub(crate) fn of_boats(server: &str, boats: &[Boat], extra: &[&str]) -> Bridge {
        let endpoints: Vec<String> = boats
            .iter()
            .map(|b| format!("tcpout:127.0.0.1:{}", b.primary))
            .collect();
        Bridge::start(server, &endpoints, extra)
    }

    /// `seacover --log-format json agent ARGS…` at `RUST_LOG=info`.
    pub(crate) fn agent(args: &[String]) -> Bridge {
        Bridge::agent_by(Command::new(env!("CARGO_BIN_EXE_seacover")), args)
    }

    /// [`Bridge::agent`] started as `command` (the binary, or a program
    /// that runs it: [`super::sitl_medium`] runs it inside a network
    /// namespace).
    pub(crate) fn agent_by(mut command: Command, args: &[String]) -> Bridge {
        command
            .args(["--log-format", "json", "agent"])
            .args(args)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        let mut child = command.spawn().unwrap();
        let log = Arc::new(Mutex::new(Vec::new()));
        let stderr = child.stderr.take().unwrap();
        let sink = log.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                if let Ok(v) = serde_json::from_str(&line) {
                    sink.lock().unwrap().push(v);
                }
            }
        });
        Bridge { child, log }
    }

    /// SIGTERM, then the log's last "bridge stopped" line's fields.
    pub(crate) fn stop(mut self) -> serde_json::Value {
        crate::common::process::signal(self.child.id(), "-TERM");
        let exit = self.child.wait().unwrap();
        assert!(exit.success(), "the bridge exited with {exit}");
        std::thread::sleep(Duration::from_millis(200));
        let log = self.log.lock().unwrap();
        log.iter()
            .rev()
            .find(|l| {
                l["fields"]["message"]
                    .as_str()
                    .is_some_and(|m| m.starts_with("bridge stopped"))
            })
            .map(|l| l["fields"].clone())
            .expect("the bridge logs its refusals when it stops")
    }

    /// The log lines whose message starts with `prefix`.
    pub(crate) fn logged(&self, prefix: &str) -> Vec<serde_json::Value> {
        self.log
            .lock()
            .unwrap()
            .iter()
            .filter(|l| {
                l["fields"]["message"]
                    .as_str()
                    .is_some_and(|m| m.starts_with(prefix))
            })
            .cloned()
            .collect()
    }
}

impl Drop for Bridge {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[derive(Default)]
pub(crate) struct Seen {
    pub mode: Option<u32>,
    pub armed: bool,
    /// GLOBAL_POSITION_INT by time_boot_ms.
    pub positions: BTreeMap<u32, GLOBAL_POSITION_INT_DATA>,
    /// (yaw, yawspeed) by time_boot_ms.
    pub attitudes: BTreeMap<u32, (f32, f32)>,
    /// STATUSTEXT messages, with the newest position's time_boot_ms when
    /// each arrived (the message has no time of its own).
    pub texts: Vec<(u32, String)>,
}

impl Seen {
    pub(crate) fn latest(&self) -> Option<&GLOBAL_POSITION_INT_DATA> {
        self.positions.values().next_back()
    }
    pub(crate) fn clock_ms(&self) -> u32 {
        self.positions.keys().next_back().copied().unwrap_or(0)
    }
    pub(crate) fn speed(&self) -> f64 {
        self.latest()
            .map_or(0.0, |p| f64::from(p.vx).hypot(f64::from(p.vy)) / 100.0)
    }
}

/// An operator's ground station on a boat's second MAVLink port.
pub(crate) struct Station {
    pub sysid: u8,
    connection: Arc<mavlink::AsyncConnection<MavMessage>>,
    seen: Arc<Mutex<Seen>>,
}

pub(crate) const STATION_SYSID: u8 = 250;

impl Station {
    /// [`Station::open`] on each of `boats`, in their order.
    pub(crate) async fn open_all(boats: &[Boat]) -> Vec<Station> {
        let mut stations = Vec::new();
        for b in boats {
            stations.push(Station::open(b).await);
        }
        stations
    }

    pub(crate) async fn open(boat: &Boat) -> Station {
        let address = format!("tcpout:127.0.0.1:{}", boat.second);
        let began = Instant::now();
        let connection = loop {
            match mavlink::connect_async::<MavMessage>(&address).await {
                Ok(c) => break Arc::new(c),
                Err(e) if began.elapsed() < Duration::from_secs(20) => {
                    let _ = e;
                    tokio::time::sleep(Duration::from_millis(200)).await;
                }
                Err(e) => panic!("{address}: {e}"),
            }
        };
        Station::watch(connection, boat.sysid).await
    }

    /// A ground station on `connection`, open to boat `sysid`'s second
    /// port: what it reports is collected from now on, at the bridge's
    /// rates.
    pub(crate) async fn watch(
        connection: Arc<mavlink::AsyncConnection<MavMessage>>,
        sysid: u8,
    ) -> Station {
        let seen = Arc::new(Mutex::new(Seen::default()));
        let (reader, sink) = (connection.clone(), seen.clone());
        tokio::spawn(async move {
            while let Ok((header, message)) = reader.recv().await {
                if header.system_id != u32::from(sysid) || header.component_id != 1 {
                    continue;
                }
                let mut s = sink.lock().unwrap();
                match message {
                    MavMessage::HEARTBEAT(hb) => {
                        s.mode = Some(hb.custom_mode);
                        s.armed = hb
                            .base_mode
                            .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
                    }
                    MavMessage::GLOBAL_POSITION_INT(p) if p.lat != 0 => {
                        s.positions.insert(p.time_boot_ms, p);
                    }
                    MavMessage::ATTITUDE(a) => {
                        s.attitudes.insert(a.time_boot_ms, (a.yaw, a.yawspeed));
                    }
                    MavMessage::STATUSTEXT(t) => {
                        let end = t.text.iter().position(|&c| c == 0).unwrap_or(t.text.len());
                        let text = String::from_utf8_lossy(&t.text[..end]).into_owned();
                        let at = s.clock_ms();
                        s.texts.push((at, text));
                    }
                    _ => {}
                }
            }
        });
        let station = Station {
            sysid,
            connection,
            seen,
        };
        // The same rates the bridge asks for on its own link.
        for id in [33.0, 30.0] {
            station
                .command(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, id, 100_000.0)
                .await;
        }
        station
    }

    pub(crate) async fn command(&self, command: MavCmd, param1: f32, param2: f32) {
        let header = MavHeader {
            system_id: u32::from(STATION_SYSID),
            component_id: 190,
            sequence: 0,
        };
        let message = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            command,
            param1,
            param2,
            target_system: self.sysid,
            target_component: 1,
            ..Default::default()
        });
        self.connection.send(&header, &message).await.unwrap();
    }

    pub(crate) async fn set_mode(&self, mode: u32) {
        let flag = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED.bits() as f32;
        self.command(MavCmd::MAV_CMD_DO_SET_MODE, flag, mode as f32)
            .await;
    }

    pub(crate) fn seen<T>(&self, f: impl FnOnce(&Seen) -> T) -> T {
        f(&self.seen.lock().unwrap())
    }
}

/// Polls `check` every 50 ms until it holds or `limit` passes.
pub(crate) async fn wait_for<T>(
    limit: Duration,
    mut check: impl AsyncFnMut() -> Option<T>,
) -> Option<T> {
    let began = Instant::now();
    loop {
        if let Some(t) = check().await {
            return Some(t);
        }
        if began.elapsed() > limit {
            return None;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Waits (10 s at most) until every boat reports below 0.3 m/s, then says
/// when that was, from ArduPilot's own record rather than from when this
/// loop looked (at speedup 4 a late look is four times as late): the first
/// moment after `since` (each boat's clock) at which every boat's newest
/// report said below 0.3 m/s [s].
pub(crate) async fn all_stopped(stations: &[Station], since: &[u32]) -> f64 {
    wait_for(Duration::from_secs(10), async || {
        stations
            .iter()
            .all(|s| s.seen(Seen::speed) < 0.3)
            .then_some(())
    })
    .await
    .expect("every boat below 0.3 m/s");
    let records: Vec<BTreeMap<u32, f64>> = stations
        .iter()
        .zip(since)
        .map(|(s, k)| {
            s.seen(|s| {
                s.positions
                    .range(*k..)
                    .map(|(t, p)| (t - k, f64::from(p.vx).hypot(f64::from(p.vy)) / 100.0))
                    .collect()
            })
        })
        .collect();
    let mut moments: Vec<u32> = records.iter().flat_map(|r| r.keys().copied()).collect();
    moments.sort_unstable();
    moments
        .into_iter()
        .find(|&after| {
            records
                .iter()
                .all(|r| r.range(..=after).next_back().is_some_and(|(_, v)| *v < 0.3))
        })
        .map(|after| f64::from(after) / 1000.0)
        .expect("every boat's record shows it below 0.3 m/s")
}

/// Waits (20 s at most) until some boat goes faster than `speed` [m/s].
pub(crate) async fn under_way(stations: &[Station], speed: f64, what: &str) {
    wait_for(Duration::from_secs(20), async || {
        stations
            .iter()
            .any(|s| s.seen(Seen::speed) > speed)
            .then_some(())
    })
    .await
    .expect(what);
}

/// The SITL mission's risk objects: (id, east, north, α, σ) [m], on a
/// base of [`BASE`].
pub(crate) const OBJECTS: [(&str, f64, f64, f64, f64); 2] = [
    ("wreck", -50.0, 40.0, 10.0, 20.0),
    ("reef", 45.0, -35.0, 8.0, 25.0),
];
pub(crate) const BASE: f64 = 0.1;

/// The mission of the SITL tests, as a `seacover serve --config` TOML: the
/// origin, a 200 m square round it, the two risk [`OBJECTS`], and the
/// guidance's speed below the boats' `WP_SPEED`.
pub(crate) fn mission_toml() -> String {
    mission_toml_with(&OBJECTS)
}

/// [`mission_toml`] with `objects` as its risk's (none: a flat map).
pub(crate) fn mission_toml_with(objects: &[(&str, f64, f64, f64, f64)]) -> String {
    let objects: Vec<String> = objects
        .iter()
        .map(|(id, x, y, alpha, sigma)| {
            format!(
                "    {{ id = \"{id}\", x = {x}, y = {y}, alpha = {alpha}, sigma = {sigma} }},\n"
            )
        })
        .collect();
    format!(
        r#"tick_hz = 10.0
origin = {{ lat = {}, lon = {} }}
[region]
polygon = [[-100, -100], [100, -100], [100, 100], [-100, 100]]
[risk]
base = {BASE}
objects = [
{}]
[guidance]
max_speed = 2.0
"#,
        ORIGIN.0,
        ORIGIN.1,
        objects.concat()
    )
}

/// [`mission_toml`] written to `dir/mission.toml`.
pub(crate) fn mission(dir: &Path) -> PathBuf {
    let path = dir.join("mission.toml");
    std::fs::write(&path, mission_toml()).unwrap();
    path
}

/// `seacover serve` as a process, at the boats' time warp, on a data
/// directory and a mission file.
pub(crate) struct Coordinator {
    pub child: Child,
    pub addr: String,
    pub data: PathBuf,
    pub config: PathBuf,
}

impl Coordinator {
    pub(crate) fn start(data: &Path, config: &Path, bind: &str) -> Coordinator {
        let mut command = Command::new(env!("CARGO_BIN_EXE_seacover"));
        command
            .args(["serve", "--bind", bind, "--time-warp", &SPEEDUP.to_string()])
            .arg("--data-dir")
            .arg(data)
            .arg("--config")
            .arg(config)
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        let (child, addr) = crate::common::server::start(command);
        Coordinator {
            child,
            addr,
            data: data.to_path_buf(),
            config: config.to_path_buf(),
        }
    }

    pub(crate) fn url(&self, path: &str) -> String {
        format!("http://{}{path}", self.addr)
    }

    pub(crate) async fn vessels(
        &self,
        http: &reqwest::Client,
    ) -> Vec<seacover::protocol::VesselStatusDocument> {
        match http.get(self.url("/api/v1/vessels")).send().await {
            Ok(r) => r.json().await.unwrap_or_default(),
            Err(_) => Vec::new(),
        }
    }
}

impl Drop for Coordinator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The SITL mission `toml` as a mission JSON document (what peer bridges
/// read, written to `dir/mission.json`), and the mission the same file
/// makes (what a test evaluates with).
pub(crate) fn mission_file(dir: &Path, toml: &str) -> (PathBuf, seacover::mission::Mission) {
    let settings =
        seacover::server::config::Settings::parse(toml).expect("the SITL tests' mission");
    let path = dir.join("mission.json");
    let json = serde_json::to_vec_pretty(&settings.mission.document()).unwrap();
    std::fs::write(&path, json).unwrap();
    let mission = seacover::mission::Mission::from_text(&std::fs::read_to_string(&path).unwrap())
        .expect("the mission file reads back");
    assert!(
        mission.origin().is_some(),
        "the mission has the boats' origin"
    );
    (path, mission)
}

/// A boat's newest position as its autopilot reports it [m east, north].
pub(crate) fn here(s: &Station) -> Option<(f64, f64)> {
    s.seen(|s| {
        s.latest()
            .map(|p| east_north(f64::from(p.lat) * 1e-7, f64::from(p.lon) * 1e-7))
    })
}

/// Every boat's [`here`], once each has reported.
pub(crate) fn positions(stations: &[&Station]) -> Option<Vec<(f64, f64)>> {
    stations.iter().map(|s| here(s)).collect()
}

/// The library's centralized evaluation of boats at `at` on mission `m`'s
/// region and risk, each boat with the mission's actuator.
pub(crate) fn evaluate_at(
    m: &seacover::mission::Mission,
    at: &[(f64, f64)],
) -> seacover::coverage::Evaluation {
    use seacover::coverage::{Fleet, Options, Vessel, evaluate};
    let vessels = at
        .iter()
        .map(|&(x, y)| Vessel {
            position: seacover::geometry::Point { x, y },
            k: m.actuator().k,
            beta: m.actuator().beta,
        })
        .collect();
    let fleet = Fleet::new(vessels).expect("boats in the region make a fleet");
    evaluate(m.region(), m.risk(), &fleet, &Options::default())
}

/// Four boats at the SITL tests' scattered starts: 70 m from the origin at
/// 30°, 120°, 210° and 300°, each heading somewhere else; each running
/// `script` when one is given ([`boat_with`]).
pub(crate) fn scattered_boats(ap: &Ardupilot, script: Option<&str>) -> Vec<Boat> {
    (0..4u8)
        .map(|i| {
            let (home, heading) = scattered_start(i);
            boat_with(ap, i + 1, home, heading, script)
        })
        .collect()
}

/// Where [`scattered_boats`] starts boat `i` (0 to 3): its home (lat, lon)
/// and heading [°].
pub(crate) fn scattered_start(i: u8) -> ((f64, f64), f64) {
    let home = place(70.0, 30.0 + 90.0 * f64::from(i));
    (home, 45.0 + 100.0 * f64::from(i))
}

/// Peer bridges, one per boat, and how to reach them.
pub(crate) struct PeerBridges {
    pub bridges: Vec<Bridge>,
    /// `boat-1` …
    pub ids: Vec<String>,
    /// Each bridge's Zenoh TCP port on loopback.
    pub ports: Vec<u16>,
    /// The Zenoh configuration they share (multicast scouting off).
    pub zenoh: PathBuf,
    pub fleet: String,
}

/// Each of `boats` its own `agent --mavlink … --peer --arm` on the mission
/// file `mission`, with `extra` arguments: each listens on a loopback TCP
/// port of its own and dials every bridge started before it, with
/// multicast scouting off, so the links are exactly those and nothing else
/// on the machine joins the fleet.
pub(crate) fn peer_bridges(
    dir: &Path,
    boats: &[Boat],
    mission: &Path,
    extra: &[&str],
) -> PeerBridges {
    let zenoh = dir.join("zenoh.json5");
    std::fs::write(&zenoh, "{ scouting: { multicast: { enabled: false } } }\n").unwrap();
    let fleet = format!("sitlpeer{}", std::process::id());
    let ports: Vec<u16> = {
        let held: Vec<_> = boats
            .iter()
            .map(|_| std::net::TcpListener::bind("127.0.0.1:0").unwrap())
            .collect();
        held.iter()
            .map(|l| l.local_addr().unwrap().port())
            .collect()
    };
    let ids: Vec<String> = (1..=boats.len()).map(|i| format!("boat-{i}")).collect();
    let bridges = boats
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let mut args = peer_bridge_args(b, &ids[i], &fleet, mission);
            args.extend([
                "--zenoh-config".into(),
                zenoh.display().to_string(),
                "--zenoh-listen".into(),
                format!("tcp/127.0.0.1:{}", ports[i]),
            ]);
            args.extend(extra.iter().map(|a| a.to_string()));
            for p in &ports[..i] {
                args.extend(["--zenoh-connect".into(), format!("tcp/127.0.0.1:{p}")]);
            }
            Bridge::agent(&args)
        })
        .collect();
    PeerBridges {
        bridges,
        ids,
        ports,
        zenoh,
        fleet,
    }
}

/// The flags of `boat`'s bridge as its peer node `id` of `fleet`, with
/// `mission` as revision 0 and arming it.
pub(crate) fn peer_bridge_args(boat: &Boat, id: &str, fleet: &str, mission: &Path) -> Vec<String> {
    [
        "--mavlink",
        &format!("tcpout:127.0.0.1:{}", boat.primary),
        "--id",
        id,
        "--peer",
        "--arm",
        "--fleet",
        fleet,
        "--mission",
        &mission.display().to_string(),
    ]
    .map(String::from)
    .to_vec()
}

/// Where a fleet stands: each boat's distance to its centroid (E), H, and
/// H with every boat at its centroid, by the library's centralized
/// evaluation of `at` ([`evaluate_at`]).
#[derive(Debug, Clone)]
pub(crate) struct Standing {
    pub e: Vec<f64>,
    pub centroids: Vec<(f64, f64)>,
    pub h: f64,
    pub ideal: f64,
}

impl Standing {
    pub(crate) fn of(m: &seacover::mission::Mission, at: &[(f64, f64)]) -> Standing {
        let now = evaluate_at(m, at);
        let centroids: Vec<(f64, f64)> = now
            .cells
            .iter()
            .map(|c| (c.centroid.x, c.centroid.y))
            .collect();
        let e = at
            .iter()
            .zip(&centroids)
            .map(|(p, c)| (p.0 - c.0).hypot(p.1 - c.1))
            .collect();
        Standing {
            e,
            h: now.h,
            ideal: evaluate_at(m, &centroids).h,
            centroids,
        }
    }

    pub(crate) fn e_max(&self) -> f64 {
        self.e.iter().copied().fold(0.0, f64::max)
    }

    /// (H − H at the centroids) / H at the centroids.
    pub(crate) fn gap(&self) -> f64 {
        (self.h - self.ideal) / self.ideal
    }
}
