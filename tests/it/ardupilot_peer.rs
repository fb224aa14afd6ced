//! The MAVLink bridge as each boat's peer node (`agent --mavlink … --peer`)
//! on ArduPilot's own simulator, without any coordinator: four real
//! `ardurover` boats (the `motorboat` model, with waves and wind), each
//! with its own `seacover agent --mavlink tcpout:… --id boat-N --peer --arm
//! --fleet F --mission FILE` process, as each boat's companion computer
//! would run it. The bridges find each other over Zenoh on loopback: each
//! listens on a TCP port of its own and dials every bridge started before
//! it, with multicast scouting off, so the links are exactly those and
//! nothing else on the machine joins the fleet. The mission file is the
//! SITL tests' mission ([`mission_toml`]: the origin at SITL's home, the
//! 200 m square, the two risk objects, `max_speed` 2 m/s) as a mission
//! JSON document, revision 0.
//!
//! Everything judged comes from the autopilots: their own positions, read
//! on each boat's second MAVLink port as an operator's ground station would
//! ([`Station`]) and converted by geographiclib, and the cells, centroids
//! and H of those positions from the library's centralized
//! `coverage::evaluate` (a peer's range-limited cell is that cell where it
//! matters: `coverage::range`). The bridges' logs are only read to explain
//! a failure.
//!
//! - a. Convergence: every boat within 3 m of its centroid and H within
//!   1 % of H at the centroids within 240 s of ArduPilot's clock after all
//!   four are under control (ardupilot_sitl's bound for the same fleet
//!   linked to a coordinator).
//! - b. Then the bridge of the boat moving fastest SIGKILLed: its boat
//!   stops (ArduPilot's 3 s GUIDED timeout, then braking), and the three
//!   others take over its water: each within 3 m of its centroid among
//!   the three.
//!
//! Durations of the boats' world are on ArduPilot's clock, at SITL's
//! [`SPEEDUP`] as in ardupilot_sitl. The bridges have no time warp
//! (`--mavlink` takes none): their loop steps once per mission tick of the
//! autopilot's own clock (its poses' time, `Member::link`), so a boat gets
//! a command every 0.1 s of its clock, but beacons age on the wall clock,
//! so a silent neighbour leaves the others' partition after 3 s of wall
//! clock, 12 s of the boats' at speedup 4. The test collects its checks,
//! prints one summary with its numbers, and then fails listing every check
//! that did not hold.

use std::time::{Duration, Instant};

use seacover::mission::Mission;

use crate::common::process::signal;
use crate::common::sitl::{
    Bridge, PeerBridges, SPEEDUP, Seen, Standing, Station, ardupilot, east_north, mission_file,
    mission_toml, one_sitl_fleet, peer_bridges, positions, scattered_boats, wait_for,
};

/// Boats, and bridges.
const N: usize = 4;
/// The distance to its centroid [m] within which a boat has arrived.
const E_MAX: f64 = 3.0;
/// The largest relative gap between H and H at the centroids.
const H_GAP: f64 = 0.01;
/// Convergence from the scattered starts [s of ArduPilot's clock]: the
/// bound ardupilot_sitl sets for the same four boats, starts and mission
/// under a coordinator.
const CONVERGE_S: f64 = 240.0;
/// Re-convergence after a bridge is killed [s of ArduPilot's clock]. The
/// SITL tests allow 240 s for a convergence (from 70 m out, every boat
/// turning round first); taking over a neighbour's water is a shorter
/// move of boats already in their cells, so the same bound holds it, with
/// room for the 12 s (3 s of wall clock at speedup 4) before the killed
/// boat's silence takes it out of the others' partitions.
const RECONVERGE_S: f64 = 240.0;
/// The killed bridge's boat below 0.3 m/s [s of its clock]: ArduPilot
/// Rover drops a GUIDED velocity target 3 s old, then brakes from at most
/// the mission's 2 m/s (ardupilot_sitl's boats brake from it in about 1 s).
const STOP_S: f64 = 6.0;
/// Below this ground speed a boat is stopped [m/s] (ardupilot_sitl's).
const STOPPED: f64 = 0.3;
/// ArduPilot Rover's GUIDED mode.
const GUIDED: u32 = 15;

/// Whether every boat has arrived at its centroid.
fn arrived(s: &Standing) -> bool {
    s.e_max() <= E_MAX
}

/// The closest two boats of `at` are [m].
fn separation(at: &[(f64, f64)]) -> f64 {
    let mut d = f64::INFINITY;
    for (i, a) in at.iter().enumerate() {
        for b in &at[i + 1..] {
            d = d.min((a.0 - b.0).hypot(a.1 - b.1));
        }
    }
    d
}

/// Follows `stations` every 200 ms of wall clock until `done` holds of
/// their standing or `limit` s of the first one's clock have passed since
/// `since` (its clock then); gives the seconds it took and the standing
/// then, or `None` and the closest the boats came (the smallest E_max
/// seen). The wall clock is only a safety net (2.5 times the limit at
/// [`SPEEDUP`]): a slow machine makes the run longer, never shorter on the
/// boats' clock. Every 10 s of that clock a line of each boat's position,
/// speed, heading, E and centroid goes to `trace`.
async fn follow(
    m: &Mission,
    stations: &[&Station],
    since: u32,
    limit: f64,
    separations: &mut f64,
    trace: &mut Vec<String>,
    done: impl Fn(&Standing) -> bool,
) -> (Option<f64>, Standing) {
    let wall = Instant::now();
    let net = Duration::from_secs_f64(2.5 * limit / f64::from(SPEEDUP));
    let mut closest: Option<Standing> = None;
    let mut next_trace = 0.0;
    loop {
        tokio::time::sleep(Duration::from_millis(200)).await;
        let seconds = f64::from(stations[0].seen(Seen::clock_ms) - since) / 1000.0;
        let Some(at) = positions(stations) else {
            continue;
        };
        *separations = separations.min(separation(&at));
        let standing = Standing::of(m, &at);
        if seconds >= next_trace {
            next_trace = (seconds / 10.0).floor() * 10.0 + 10.0;
            let boats: Vec<String> = stations
                .iter()
                .zip(&at)
                .zip(standing.e.iter().zip(&standing.centroids))
                .map(|((s, p), (e, c))| {
                    let (speed, yaw) = s.seen(|s| {
                        let yaw = s.attitudes.values().next_back().map_or(f32::NAN, |a| a.0);
                        (s.speed(), f64::from(yaw).to_degrees())
                    });
                    // Where the centroid is from the bow, clockwise [°]:
                    // near ±180 the boat has its stern to it.
                    let bearing = (c.0 - p.0).atan2(c.1 - p.1).to_degrees();
                    let off = (bearing - yaw + 540.0).rem_euclid(360.0) - 180.0;
                    format!(
                        "sysid {}: ({:.1}, {:.1}) {speed:.2} m/s yaw {yaw:.0}° E {e:.1} to ({:.1}, {:.1}) at {off:.0}° off the bow",
                        s.sysid, p.0, p.1, c.0, c.1
                    )
                })
                .collect();
            trace.push(format!("{seconds:6.1} s: {}", boats.join("; ")));
        }
        if done(&standing) {
            return (Some(seconds), standing);
        }
        if closest
            .as_ref()
            .is_none_or(|c| standing.e_max() < c.e_max())
        {
            closest = Some(standing);
        }
        if seconds > limit || wall.elapsed() > net {
            return (None, closest.expect("positions were read"));
        }
    }
}

/// What each bridge says of itself, asked over Zenoh (its status
/// queryable): its partition (neighbours heard within 3 s) and the age of
/// each beacon it heard. Only for the summary: the checks judge by the
/// autopilots.
async fn statuses(session: &zenoh::Session, fleet: &str) -> Vec<String> {
    let mut out = Vec::new();
    let Ok(replies) = session
        .get(format!("seacover/{fleet}/status/*"))
        .timeout(Duration::from_secs(2))
        .await
    else {
        return out;
    };
    while let Ok(reply) = replies.recv_async().await {
        let Ok(sample) = reply.result() else { continue };
        let Ok(doc) = serde_json::from_slice::<serde_json::Value>(&sample.payload().to_bytes())
        else {
            continue;
        };
        out.push(format!(
            "{} partition {} heard {}",
            doc["id"], doc["neighbours"], doc["heard"]
        ));
    }
    out.sort();
    out
}

/// What a bridge logged, in a few lines: each message's count, and its
/// last warnings and errors.
fn digest(id: &str, bridge: &Bridge) -> String {
    let log = bridge.log.lock().unwrap();
    let mut counts = std::collections::BTreeMap::<String, usize>::new();
    for l in log.iter() {
        let m = l["fields"]["message"].as_str().unwrap_or("?");
        let m: String = m.chars().take(60).collect();
        *counts.entry(m).or_default() += 1;
    }
    let warnings: Vec<String> = log
        .iter()
        .filter(|l| matches!(l["level"].as_str(), Some("WARN" | "ERROR")))
        .rev()
        .take(5)
        .map(|l| l["fields"].to_string())
        .collect();
    format!("{id}: {counts:?}; last warnings: {warnings:#?}")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn four_peer_bridges_converge_without_a_coordinator_and_take_over_a_killed_ones_water() {
    let Some(ap) = ardupilot() else { return };
    let _one = one_sitl_fleet().await;
    let began = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let (mission_path, mission) = mission_file(dir.path(), &mission_toml());
    let boats = scattered_boats(&ap, None);
    let PeerBridges {
        mut bridges,
        ids,
        ports,
        zenoh,
        fleet,
    } = peer_bridges(dir.path(), &boats, &mission_path, &[]);
    let stations = Station::open_all(&boats).await;
    let all: Vec<&Station> = stations.iter().collect();
    // The test's own Zenoh member, to ask the bridges what they believe.
    let observer = seacover::agent::peer::session::ZenohOptions {
        connect: ports.iter().map(|p| format!("tcp/127.0.0.1:{p}")).collect(),
        config: Some(zenoh.clone()),
        ..Default::default()
    };
    let observer = zenoh::open(observer.config().unwrap()).await.unwrap();
    let mut failures: Vec<String> = Vec::new();
    let mut closest = f64::INFINITY;
    let mut trace = Vec::new();

    // Under control once the EKF has a position (about 42 s of the boats'
    // clock) and each bridge's --arm has switched its boat to GUIDED and
    // armed it: as ArduPilot reports it.
    let controlled = wait_for(Duration::from_secs(90), async || {
        stations
            .iter()
            .all(|s| s.seen(|s| s.mode == Some(GUIDED) && s.armed))
            .then(|| stations[0].seen(Seen::clock_ms))
    })
    .await;
    let Some(controlled) = controlled else {
        for (id, b) in ids.iter().zip(&bridges) {
            eprintln!("{}", digest(id, b));
        }
        panic!("the four boats in GUIDED and armed within 90 s of wall clock");
    };
    let under_control = began.elapsed();

    // a. Convergence.
    trace.push("a. from all four under control, on boat-1's clock:".to_string());
    let (converged, a) = follow(
        &mission,
        &all,
        controlled,
        CONVERGE_S,
        &mut closest,
        &mut trace,
        |s| arrived(s) && s.gap().abs() <= H_GAP,
    )
    .await;
    let a_line = match converged {
        Some(t) => format!(
            "a. converged {t:.1} s (ArduPilot's clock) after all four were under control: \
             E {:.2?} m, H {:.2} vs {:.2} at the centroids ({:+.3} %)",
            a.e,
            a.h,
            a.ideal,
            100.0 * a.gap()
        ),
        None => {
            failures.push(format!(
                "a. not converged within {CONVERGE_S} s of ArduPilot's clock: closest E {:.2?} m \
                 (H {:+.3} % off)",
                a.e,
                100.0 * a.gap()
            ));
            format!(
                "a. NOT converged: closest E {:.2?} m, H {:+.3} %",
                a.e,
                100.0 * a.gap()
            )
        }
    };
    println!("{a_line}");
    println!(
        "a. the bridges say: {:?}",
        statuses(&observer, &fleet).await
    );

    // b. Kill a bridge at once: the one whose boat is the fastest now (at
    // convergence the boats are still arriving), so that its stopping
    // means something.
    let victim = (0..N)
        .max_by(|&i, &j| {
            stations[i]
                .seen(Seen::speed)
                .total_cmp(&stations[j].seen(Seen::speed))
        })
        .unwrap();
    let killed: Vec<u32> = stations.iter().map(|s| s.seen(Seen::clock_ms)).collect();
    let speed_at_kill = stations[victim].seen(Seen::speed);
    let survivors: Vec<&Station> = stations
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != victim)
        .map(|(_, s)| s)
        .collect();
    let before = positions(&survivors).map(|at| Standing::of(&mission, &at));
    signal(bridges[victim].child.id(), "-KILL");
    let _ = bridges[victim].child.wait();

    // Its boat: the first moment after the kill its autopilot reported
    // below 0.3 m/s, and when ArduPilot said the target was too old.
    let k = killed[victim];
    wait_for(Duration::from_secs(20), async || {
        (stations[victim].seen(Seen::clock_ms) > k + 20_000).then_some(())
    })
    .await;
    let (stopped, timeout, fastest_after, drift) = stations[victim].seen(|s| {
        let speed = |p: &mavlink::dialects::ardupilotmega::GLOBAL_POSITION_INT_DATA| {
            f64::from(p.vx).hypot(f64::from(p.vy)) / 100.0
        };
        let rest = s.positions.range(k..).find(|(_, p)| speed(p) < STOPPED);
        let stopped = rest.map(|(t, _)| f64::from(t - k) / 1000.0);
        let timeout = s
            .texts
            .iter()
            .find(|(t, text)| *t >= k && text.contains("target not received"))
            .map(|(t, _)| f64::from(t - k) / 1000.0);
        let (fastest, drift) = match rest {
            Some((t0, p0)) => {
                let en = |p: &mavlink::dialects::ardupilotmega::GLOBAL_POSITION_INT_DATA| {
                    east_north(f64::from(p.lat) * 1e-7, f64::from(p.lon) * 1e-7)
                };
                let (e0, n0) = en(p0);
                let after: Vec<_> = s
                    .positions
                    .range(*t0..=k + 20_000)
                    .map(|(_, p)| p)
                    .collect();
                (
                    after.iter().map(|p| speed(p)).fold(0.0, f64::max),
                    after
                        .iter()
                        .map(|p| {
                            let (e, n) = en(p);
                            (e - e0).hypot(n - n0)
                        })
                        .fold(0.0, f64::max),
                )
            }
            None => (f64::NAN, f64::NAN),
        };
        (stopped, timeout, fastest, drift)
    });
    let b_stop = format!(
        "b. {}'s bridge SIGKILLed with its boat at {speed_at_kill:.2} m/s: below {STOPPED} m/s \
         {} s after (its clock); ArduPilot's \"target not received\" at {} s; until 20 s after the \
         kill at most {fastest_after:.2} m/s and {drift:.2} m from where it came to rest",
        ids[victim],
        stopped.map_or("never".into(), |t| format!("{t:.1}")),
        timeout.map_or("—".into(), |t| format!("{t:.1}")),
    );
    println!("{b_stop}");
    match stopped {
        Some(t) if t <= STOP_S => {}
        _ => failures.push(format!(
            "b. the killed bridge's boat not stopped within {STOP_S} s: {stopped:?}"
        )),
    }

    // The three others take over its water: their cells among the three.
    trace.push(format!("b. from the kill of {}'s bridge:", ids[victim]));
    let (reconverged, b) = follow(
        &mission,
        &survivors,
        killed[usize::from(victim == 0)],
        RECONVERGE_S,
        &mut closest,
        &mut trace,
        arrived,
    )
    .await;
    let moved = before.map_or("?".into(), |s| {
        // Where the three stood at the kill against their new cells.
        format!("{:.2?}", s.e)
    });
    let b_line = match reconverged {
        Some(t) => format!(
            "b. the three others within {E_MAX} m of their new centroids {t:.1} s (ArduPilot's \
             clock) after the kill (E at the kill {moved} m, now {:.2?} m; H {:+.3} % off H at \
             their centroids)",
            b.e,
            100.0 * b.gap()
        ),
        None => {
            failures.push(format!(
                "b. the three others not within {E_MAX} m of their new centroids within \
                 {RECONVERGE_S} s of ArduPilot's clock: closest E {:.2?} m (E at the kill {moved} m)",
                b.e
            ));
            format!(
                "b. NOT re-converged: closest E {:.2?} m (at the kill {moved} m)",
                b.e
            )
        }
    };
    println!("{b_line}");
    println!(
        "b. the bridges say: {:?}",
        statuses(&observer, &fleet).await
    );

    // Times ArduPilot dropped a live bridge's target as 3 s old (a bridge
    // that stalled), per boat.
    let dropped: Vec<usize> = stations
        .iter()
        .enumerate()
        .map(|(i, s)| {
            s.seen(|s| {
                s.texts
                    .iter()
                    .filter(|(t, text)| {
                        text.contains("target not received") && (i != victim || *t < k)
                    })
                    .count()
            })
        })
        .collect();
    println!(
        "ardupilot_peer: 4 SITL boats at speedup {SPEEDUP}, 4 peer bridges, no coordinator: \
         under control after {:.1} s of wall clock; closest two boats {closest:.1} m apart; \
         targets dropped as stale by live bridges' autopilots {dropped:?}; wall time {:.0} s",
        under_control.as_secs_f64(),
        began.elapsed().as_secs_f64()
    );
    if !failures.is_empty() {
        for line in &trace {
            eprintln!("{line}");
        }
        for (id, b) in ids.iter().zip(&bridges) {
            eprintln!("{}", digest(id, b));
        }
    }
    bridges.clear();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
