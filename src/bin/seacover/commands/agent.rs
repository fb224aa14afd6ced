//! `seacover agent`: simulated vessels, each on its own link to a
//! coordinator; or, with `--mavlink`, a bridge of real autopilots onto it;
//! or, with `--peer`, vessels of a fleet without a coordinator, over Zenoh.

use crate::shell::{self, Preset};

#[derive(clap::Args)]
// One of the two modes, and the error says so when neither is given. A
// flag of one mode conflicts with the other's: `requires = "peer"` alone
// is met by `--server`, a member of the same group (measured), and the
// flag was then ignored.
#[command(group(clap::ArgGroup::new("mode").required(true).args(["server", "peer"])))]
pub(crate) struct Args {
    /// Coordinator base URL, e.g. http://127.0.0.1:8080 (not with --peer).
    #[arg(long, value_name = "URL", conflicts_with = "peer")]
    server: Option<String>,
    /// Be members of a peer fleet instead: every vessel computes its own
    /// cell from its neighbours' beacons over Zenoh; no coordinator needed
    /// (docs/peer.md).
    #[arg(long)]
    peer: bool,
    /// With --peer: the mission, revision 0 (a mission document as `GET
    /// /api/v1/mission` gives it, or a scenario document); without it the
    /// vessels hold station until a member gives them one.
    #[arg(
        long,
        value_name = "FILE",
        requires = "peer",
        conflicts_with = "server"
    )]
    mission: Option<std::path::PathBuf>,
    #[command(flatten)]
    fleet: shell::Fleet,
    /// With --peer: cover even while hearing no other vessel (single-boat
    /// work). Without it a vessel that hears nobody (the only one left, or
    /// one whose credentials the fleet refuses) holds station and says so.
    #[arg(long, requires = "peer", conflicts_with = "server")]
    alone: bool,
    /// With --peer and --id: where the vessel starts, in the mission's
    /// local plane [m] and heading [rad]: X,Y or X,Y,PSI.
    #[arg(long, value_name = "X,Y[,PSI]", requires = "id", value_parser = parse_start)]
    start: Option<(f64, f64, f64)>,
    /// With --peer: the vessels' actuator (f = k·exp(−β‖q − p‖²)), which
    /// each computes its cell with and announces to the fleet. Unless told:
    /// the vessel of the same id in a scenario given as --mission, else
    /// the mission's actuator.
    #[arg(long, value_name = "K,BETA", requires = "peer", conflicts_with = "server", value_parser = parse_actuator)]
    actuator: Option<seacover::protocol::ActuatorDocument>,
    /// With --peer: beacons per second of mission time, in [1, 20]; 5
    /// unless told. Fewer fit a narrower radio or encrypted links into
    /// their budget (docs/peer.md, "Radio budgets"); a neighbour is stale
    /// after 3 s without one.
    #[arg(long, value_name = "HZ", requires = "peer", conflicts_with = "server", value_parser = parse_beacon_hz)]
    beacon_hz: Option<f64>,
    #[command(flatten)]
    zenoh: crate::shell::ZenohArgs,
    #[command(flatten)]
    learn: crate::shell::PeerLearnArgs,
    /// How many vessels (named usv-1 …), 8 unless told; the first eight
    /// start where the paper's do, further ones at random in the paper's
    /// region. With --peer and a scenario as --mission, unless told: the
    /// scenario's vessels, where it starts them.
    #[arg(long, value_name = "N")]
    vessels: Option<usize>,
    /// Run one vessel with this id instead (`[A-Za-z0-9_.-]{1,64}`); with
    /// --mavlink, the id of the one vehicle bridged.
    #[arg(long, value_name = "ID")]
    id: Option<String>,
    /// Vessel preset: `paper` or `otter`.
    #[arg(long, value_enum, default_value = "paper")]
    preset: Preset,
    #[command(flatten)]
    time_warp: shell::Warp,
    /// Seed of the vessels' disturbances and of the starts of vessels past
    /// the eighth.
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    token: shell::Token,
    /// Bridge the autopilots on this MAVLink endpoint instead of
    /// simulating vessels (repeatable): `tcpout:HOST:PORT` (connect, e.g.
    /// to SITL or mavlink-router), `tcpin:ADDR:PORT` (listen),
    /// `udpin:ADDR:PORT` (listen), `udpout:HOST:PORT` (send to),
    /// `serial:DEVICE:BAUD` (a telemetry radio).
    /// Each autopilot becomes the vessel `mav-<sysid>` (or --id when
    /// there is exactly one). The mission must have an origin.
    #[arg(long, value_name = "ENDPOINT", conflicts_with_all = ["vessels", "preset", "time_warp", "seed"])]
    mavlink: Vec<String>,
    /// With --mavlink: switch each vehicle to GUIDED and arm it, once,
    /// at start (simulators and tests; otherwise the operator does).
    #[arg(long, requires = "mavlink")]
    arm: bool,
    /// With --mavlink: the bridge's own MAVLink system id (a ground
    /// station's; ArduPilot's SYSID_MYGCS is 255 by default).
    #[arg(
        long,
        value_name = "SYSID",
        default_value_t = 255,
        requires = "mavlink"
    )]
    mavlink_sysid: u8,
    /// With --mavlink: within this of its goal [m] a boat whose goal has
    /// settled is handed the goal to hold by itself: one position target,
    /// which ArduPilot reaches and keeps by loitering (set LOIT_RADIUS to
    /// how close; docs/ardupilot.md, "Quiet arrival"). 0 (the default,
    /// while it leaves some SITL boats circling): the coordinator steers
    /// it to the end. At most 20.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 0.0,
        requires = "mavlink",
        value_parser = parse_station_radius
    )]
    station_radius: f64,
    /// With --mavlink: NAMED_VALUE_FLOAT messages of this name (at most 10
    /// characters, as a Lua script's `gcs:send_named_float` or a companion
    /// computer sends them) are samples of the risk field at the boat's
    /// position, sent to the coordinator (docs/learning.md).
    #[arg(long, value_name = "NAME", requires_all = ["mavlink", "sample_sd"], value_parser = parse_sample_name)]
    sample_name: Option<String>,
    /// With --sample-name: the sensor's standard deviation, in the value's
    /// units (> 0).
    #[arg(long, value_name = "SD", requires = "sample_name", value_parser = parse_sample_sd)]
    sample_sd: Option<f64>,
}

fn parse_actuator(s: &str) -> Result<seacover::protocol::ActuatorDocument, String> {
    let (k, beta) = s
        .split_once(',')
        .ok_or("expected K,BETA (e.g. 0.5,0.004)")?;
    let a = seacover::protocol::ActuatorDocument {
        k: k.trim().parse().map_err(|e| format!("K: {e}"))?,
        beta: beta.trim().parse().map_err(|e| format!("BETA: {e}"))?,
    };
    seacover::mission::check_actuator(a, "actuator").map_err(|e| e.to_string())?;
    Ok(a)
}

fn parse_sample_name(s: &str) -> Result<String, String> {
    if (1..=10).contains(&s.len()) && s.is_ascii() {
        Ok(s.to_string())
    } else {
        Err("expected 1 to 10 ASCII characters (MAVLink's NAMED_VALUE_FLOAT name)".into())
    }
}

fn parse_sample_sd(s: &str) -> Result<f64, String> {
    let sd: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
    if sd.is_finite() && sd > 0.0 {
        Ok(sd)
    } else {
        Err("expected a finite number > 0".into())
    }
}

/// A number within `range` (which refuses NaN), or what it should be.
fn parse_within(s: &str, range: std::ops::RangeInclusive<f64>, what: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
    if range.contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "expected {what} in [{}, {}]",
            range.start(),
            range.end()
        ))
    }
}

fn parse_beacon_hz(s: &str) -> Result<f64, String> {
    // At least three beacons in the 3 s after which a neighbour is stale,
    // so that two lost in a row do not drop it.
    parse_within(s, 1.0..=20.0, "beacons per second")
}

fn parse_station_radius(s: &str) -> Result<f64, String> {
    parse_within(s, 0.0..=20.0, "a number of metres")
}

pub(crate) async fn run(args: Args) -> anyhow::Result<()> {
    if args.peer && args.mavlink.is_empty() {
        peer(args).await
    } else if args.mavlink.is_empty() {
        simulate(args).await
    } else {
        bridge(args).await
    }
}

fn parse_start(s: &str) -> Result<(f64, f64, f64), String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{e}: expected X,Y or X,Y,PSI"))?;
    match v[..] {
        [x, y] if x.is_finite() && y.is_finite() => Ok((x, y, 0.0)),
        [x, y, psi] if v.iter().all(|c| c.is_finite()) => Ok((x, y, psi)),
        _ => Err("expected X,Y or X,Y,PSI (finite numbers)".into()),
    }
}

async fn peer(args: Args) -> anyhow::Result<()> {
    shell::check_warp(args.time_warp.factor)?;
    let scenario = match &args.mission {
        Some(path) => Some(std::fs::read_to_string(path)?),
        None => None,
    };
    let mut vessels = seacover::agent::peer_fleet(
        scenario.as_deref(),
        args.vessels,
        args.id.clone(),
        args.preset.params(),
        args.seed,
    )?;
    if let Some(v) = vessels
        .iter()
        .find(|v| !seacover::agent::peer::wire::valid_peer_id(&v.id))
    {
        return Err(seacover::agent::peer::PeerError::Id(v.id.clone()).into());
    }
    if let Some((x, y, psi)) = args.start {
        vessels[0].start.x = x;
        vessels[0].start.y = y;
        vessels[0].start.psi = psi;
    }
    let mut config = member_config(&args)?;
    config.time_warp = args.time_warp.factor;
    config.seed = args.seed;
    // Beacons are aged in mission seconds.
    config.ageing.warp = args.time_warp.factor;
    seacover::agent::peer::node::run(config, vessels, shell::stop_on_signal()).await?;
    Ok(())
}

/// A fleet member's settings, simulated hulls or bridged boats alike.
fn member_config(args: &Args) -> anyhow::Result<seacover::agent::peer::PeerConfig> {
    let mut config =
        seacover::agent::peer::PeerConfig::new(args.fleet.name.clone(), args.zenoh.options())?;
    config.alone = args.alone;
    args.learn.apply(&mut config)?;
    if let Some(path) = &args.mission {
        config.load_mission(path)?;
    }
    config.actuators.given = args.actuator;
    if let Some(hz) = args.beacon_hz {
        config.beacon_hz = hz;
    }
    Ok(config)
}

async fn bridge(args: Args) -> anyhow::Result<()> {
    if let Some(id) = &args.id {
        anyhow::ensure!(
            seacover::mission::scenario::valid_id(id),
            "--id must match [A-Za-z0-9_.-]{{1,64}}"
        );
    }
    let stop = shell::stop_on_signal();
    let tasks = tokio_util::task::TaskTracker::new();
    // With --peer the bridge is each boat's peer node: one membership of
    // the fleet for all the boats it bridges.
    let peer = if args.peer {
        if let Some(id) = args
            .id
            .as_ref()
            .filter(|id| !seacover::agent::peer::wire::valid_peer_id(id))
        {
            return Err(seacover::agent::peer::PeerError::Id(id.clone()).into());
        }
        Some(
            seacover::agent::peer::node::Member::join(
                member_config(&args)?,
                args.id.clone(),
                &tasks,
                &stop,
            )
            .await?,
        )
    } else {
        None
    };
    let config = seacover::agent::mavlink::BridgeConfig {
        server: args.server.unwrap_or_default(),
        endpoints: args.mavlink,
        arm: args.arm,
        station_radius: (args.station_radius > 0.0).then_some(args.station_radius),
        sample: args
            .sample_name
            .zip(args.sample_sd)
            .map(|(name, sd)| seacover::agent::mavlink::SampleSource { name, sd }),
        token: args.token.value,
        id: args.id,
        sysid: args.mavlink_sysid,
        origin_poll: std::time::Duration::from_secs(2),
        peer: peer.clone(),
    };
    let result = seacover::agent::mavlink::run(config, stop.clone()).await;
    stop.cancel();
    tasks.close();
    tasks.wait().await;
    if let Some(member) = peer {
        member.close().await;
    }
    result?;
    Ok(())
}

async fn simulate(args: Args) -> anyhow::Result<()> {
    shell::check_warp(args.time_warp.factor)?;
    let n = args.vessels.unwrap_or(seacover::agent::DEFAULT_VESSELS);
    let vessels = seacover::agent::fleet(n, args.id, args.preset.params(), args.seed)?;
    let server = args.server.unwrap_or_default();
    let url = seacover::agent::link::link_url(&server).ok_or_else(|| {
        anyhow::anyhow!("--server must be an http:// or ws:// URL, got {:?}", server)
    })?;
    let config = seacover::agent::AgentConfig {
        url,
        time_warp: args.time_warp.factor,
        pose_hz: 20.0,
        seed: args.seed,
        token: args.token.value,
    };
    seacover::agent::run_fleet(config, vessels, shell::stop_on_signal()).await?;
    Ok(())
}
