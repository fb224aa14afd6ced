//! The split plan on ArduPilot's own simulator (docs/peer.md, "What each
//! loss does"): four real `ardurover` boats (the `motorboat` model, with
//! waves and wind) as a peer fleet without a coordinator, as in
//! tests/it/ardupilot_peer.rs, but each boat's autopilot and its bridge
//! (`seacover agent --mavlink tcpout:… --id boat-N --peer --arm --fleet F
//! --mission FILE`) in a network namespace of its own, one host of a radio
//! medium each (tests/it/common/sitl_medium.rs on
//! tests/it/common/netns.rs): the bridges' Zenoh links cross the medium,
//! and the medium cuts them. The mission is the SITL tests' (the 200 m
//! square at SITL's home with two risk objects, `max_speed` 2 m/s).
//!
//! Once the fleet has converged (ardupilot_peer's test a: every boat
//! within 3 m of its centroid and H within 1 % of H at the centroids,
//! within 240 s of ArduPilot's clock after all four are under control),
//! the medium cuts it boat-1, boat-2 | boat-3, boat-4 for 60 s of
//! ArduPilot's clock, then heals it. Checks:
//!
//! - no two boats ever closer than the mission's safety distance, from all
//!   four under control to the end: converging, cut and healed;
//! - each bridge follows the plan both groups compute: while the medium is
//!   cut its log says "fleet split: following the plan both groups
//!   compute" against exactly the other two, never that the plan's way is
//!   not clear and never that the plan ended; healed, that it ended
//!   because the other group is heard again;
//! - healed, the fleet converges again to test a's bound, within its 240 s.
//!
//! What is judged of the boats comes from the autopilots: their own
//! positions (GLOBAL_POSITION_INT on each boat's second MAVLink port, read
//! from inside its namespace) and the library's centralized evaluation of
//! them (`coverage::evaluate`), as in ardupilot_peer. The closest pair is
//! looked for every 50 ms of wall clock among each boat's newest report:
//! reports come 10 times a second of ArduPilot's clock, so two boats'
//! newest are at most 0.1 s of it apart (0.4 m for two boats closing at
//! the mission's 2 m/s each), well inside the margins the plan and the
//! safety filter keep.
//!
//! Durations of the boats' world are on boat-1's ArduPilot clock, at
//! SITL's [`SPEEDUP`]. Each bridge's loop, and with it the plan's ways,
//! runs on its autopilot's clock, but its neighbours' beacons age on the
//! wall clock: a silent neighbour is stale after 3 s of wall clock (12 s
//! of ArduPilot's) and the plan starts 1 s after that, so the cut's first
//! 16 s pass before it and its last 44 s follow it. Needs root (network
//! namespaces) and the SITL binary (skipped with a message otherwise, a
//! failure under CI=true).

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use seacover::mission::Mission;
use serde_json::Value;

use crate::common::netns::{Medium, cleanup_stale, root_or_skip};
use crate::common::paper::Checks;
use crate::common::sitl::{
    Bridge, SPEEDUP, Seen, Standing, Station, ardupilot, mission_file, mission_toml,
    one_sitl_fleet, positions, wait_for,
};
use crate::common::sitl_medium::{peer_bridges_in, scattered_boats_in};

const TEST: &str = "ardupilot_split";
/// Boats, bridges and hosts (boat i + 1 and its bridge in host i).
const N: usize = 4;
/// The distance to its centroid [m] within which a boat has arrived
/// (ardupilot_peer's).
const E_MAX: f64 = 3.0;
/// The largest relative gap between H and H at the centroids.
const H_GAP: f64 = 0.01;
/// Convergence, from the scattered starts and again once healed [s of
/// ArduPilot's clock]: ardupilot_peer's bound for test a. Healed, the
/// boats come back from the plan's places, a shorter way than from the
/// starts 70 m out.
const CONVERGE_S: f64 = 240.0;
/// How long the medium stays cut [s of ArduPilot's clock].
const CUT_S: f64 = 60.0;
/// The groups the cut makes, by host.
const GROUPS: [[usize; 2]; 2] = [[0, 1], [2, 3]];
/// ArduPilot Rover's GUIDED mode.
const GUIDED: u32 = 15;
/// The bridges' log messages of a split (`Change::log` in
/// src/agent/peer/split.rs), and the reason a plan ends on a heal.
const FOLLOWED: &str = "fleet split: following the plan both groups compute";
const REFUSED: &str = "fleet split: the plan's way is not clear";
const ENDED: &str = "fleet split: plan ended";
const HEARD_AGAIN: &str = "the other group is heard again";
/// How often the closest pair is looked for (wall clock).
const LOOK: Duration = Duration::from_millis(50);

/// Test a's bound (ardupilot_peer's).
fn settled(s: &Standing) -> bool {
    s.e_max() <= E_MAX && s.gap().abs() <= H_GAP
}

/// The closest two boats came in one part of the run.
#[derive(Debug, Clone, Copy)]
struct Closest {
    metres: f64,
    pair: (usize, usize),
    /// Seconds of ArduPilot's clock into that part.
    at: f64,
}

impl Closest {
    fn new() -> Closest {
        Closest {
            metres: f64::INFINITY,
            pair: (0, 0),
            at: f64::NAN,
        }
    }
    fn take(&mut self, at: &[(f64, f64)], seconds: f64) {
        for (i, a) in at.iter().enumerate() {
            for (j, b) in at.iter().enumerate().skip(i + 1) {
                let d = (a.0 - b.0).hypot(a.1 - b.1);
                if d < self.metres {
                    *self = Closest {
                        metres: d,
                        pair: (i, j),
                        at: seconds,
                    };
                }
            }
        }
    }
    fn check(&self, checks: &mut Checks, what: &str, safety: f64, ids: &[String]) {
        checks.check(
            self.metres >= safety,
            format!(
                "{what}: no two boats closer than the safety distance {safety} m: closest {}",
                self.text(ids)
            ),
        );
    }
    fn text(&self, ids: &[String]) -> String {
        format!(
            "{:.2} m ({} and {}, {:.1} s in)",
            self.metres, ids[self.pair.0], ids[self.pair.1], self.at
        )
    }
}

/// The boats as the test watches them.
struct Watch {
    mission: Mission,
    stations: Vec<Station>,
    /// A line of each boat every 10 s of ArduPilot's clock, shown when a
    /// check fails.
    trace: Vec<String>,
}

impl Watch {
    /// Boat-1's ArduPilot clock [ms].
    fn clock(&self) -> u32 {
        self.stations[0].seen(Seen::clock_ms)
    }

    /// Waits (90 s of wall clock at most) until each bridge's --arm has its
    /// boat in GUIDED and armed, as ArduPilot reports it; boat-1's clock
    /// then.
    async fn under_control(&self) -> Option<u32> {
        wait_for(Duration::from_secs(90), async || {
            self.stations
                .iter()
                .all(|s| s.seen(|s| s.mode == Some(GUIDED) && s.armed))
                .then(|| self.clock())
        })
        .await
    }

    /// Every boat's newest position (east, north) [m].
    fn here(&self) -> Vec<(f64, f64)> {
        let all: Vec<&Station> = self.stations.iter().collect();
        positions(&all).expect("every boat has reported")
    }

    /// Follows the boats from `since` (boat-1's clock) until `done` holds
    /// of their standing and the seconds passed, or `limit` s have passed;
    /// the closest pair goes to `closest`. Gives the seconds it took and
    /// the standing then, or `None` and the standing nearest to
    /// convergence seen. The wall clock is only a safety net (2.5 times
    /// the limit at [`SPEEDUP`]).
    async fn follow(
        &mut self,
        since: u32,
        limit: f64,
        closest: &mut Closest,
        done: impl Fn(&Standing, f64) -> bool,
    ) -> (Option<f64>, Standing) {
        let wall = Instant::now();
        let net = Duration::from_secs_f64(2.5 * limit / f64::from(SPEEDUP));
        let mut nearest: Option<Standing> = None;
        let (mut next_trace, mut looks) = (0.0, 0u32);
        loop {
            tokio::time::sleep(LOOK).await;
            let seconds = f64::from(self.clock().saturating_sub(since)) / 1000.0;
            let all: Vec<&Station> = self.stations.iter().collect();
            let Some(at) = positions(&all) else { continue };
            closest.take(&at, seconds);
            looks += 1;
            // The coverage's evaluation every 200 ms is enough: the bound
            // is on seconds, not on the pair's metres.
            if looks % 4 != 0 {
                continue;
            }
            let standing = Standing::of(&self.mission, &at);
            if seconds >= next_trace {
                next_trace = (seconds / 10.0).floor() * 10.0 + 10.0;
                let boats: Vec<String> = all
                    .iter()
                    .zip(&at)
                    .zip(&standing.e)
                    .map(|((s, p), e)| {
                        let v = s.seen(Seen::speed);
                        format!("({:.1}, {:.1}) {v:.2} m/s E {e:.1}", p.0, p.1)
                    })
                    .collect();
                self.trace
                    .push(format!("{seconds:6.1} s: {}", boats.join("; ")));
            }
            if done(&standing, seconds) {
                return (Some(seconds), standing);
            }
            if nearest
                .as_ref()
                .is_none_or(|n| standing.e_max() < n.e_max())
            {
                nearest = Some(standing);
            }
            if seconds > limit || wall.elapsed() > net {
                return (None, nearest.expect("positions were read"));
            }
        }
    }
}

/// What one bridge logged of the split: between its log's lines `cut`
/// and `heal` (its lengths when the medium was cut and healed), and after
/// `heal`.
#[derive(Debug, Default)]
struct Plan {
    /// The first plan it followed while cut.
    followed: Option<Followed>,
    refused: usize,
    /// Why plans ended while cut, and then once healed.
    ended_cut: Vec<String>,
    ended_healed: Vec<String>,
}

impl Plan {
    fn of(bridge: &Bridge, cut: usize, heal: usize) -> Plan {
        let log = bridge.log.lock().unwrap();
        let message = |l: &Value| l["fields"]["message"].as_str().unwrap_or("").to_string();
        let why = |l: &Value| l["fields"]["why"].as_str().unwrap_or("?").to_string();
        let mut plan = Plan::default();
        for (k, l) in log.iter().enumerate().skip(cut) {
            let m = message(l);
            let f = &l["fields"];
            if k >= heal {
                if m.starts_with(ENDED) {
                    plan.ended_healed.push(why(l));
                }
                continue;
            }
            if m.starts_with(FOLLOWED) && plan.followed.is_none() {
                let number = |k: &str| f[k].as_f64().unwrap_or(f64::NAN);
                plan.followed = Some(Followed {
                    others: ids_in(f["others"].as_str().unwrap_or("")),
                    closest: number("closest"),
                    duration: number("duration"),
                    water: f["water"].as_str().unwrap_or("?").to_string(),
                    t: number("t"),
                });
            } else if m.starts_with(REFUSED) {
                plan.refused += 1;
            } else if m.starts_with(ENDED) {
                plan.ended_cut.push(why(l));
            }
        }
        plan
    }
}

/// A plan a bridge logged it follows.
#[derive(Debug)]
struct Followed {
    /// The other group's ids.
    others: BTreeSet<String>,
    /// The plan's least distance between the groups [m], and its duration
    /// [s of the bridge's loop, its autopilot's clock].
    closest: f64,
    duration: f64,
    /// What the group covers (`Region` or `Own`).
    water: String,
    /// When it started [s of the autopilot's clock].
    t: f64,
}

/// The vessel ids in a logged list (`["boat-3", "boat-4"]`).
fn ids_in(list: &str) -> BTreeSet<String> {
    list.split(|c: char| !(c.is_ascii_alphanumeric() || "-_.".contains(c)))
        .filter(|s| !s.is_empty())
        .map(str::to_string)
        .collect()
}

/// What a bridge logged, in a few lines: each message's count, its last
/// warnings and errors, and its split lines.
fn digest(id: &str, bridge: &Bridge) -> String {
    let log = bridge.log.lock().unwrap();
    let mut counts = std::collections::BTreeMap::<String, usize>::new();
    for l in log.iter() {
        let m = l["fields"]["message"].as_str().unwrap_or("?");
        *counts.entry(m.chars().take(60).collect()).or_default() += 1;
    }
    let notable: Vec<String> = log
        .iter()
        .filter(|l| {
            matches!(l["level"].as_str(), Some("WARN" | "ERROR"))
                || l["fields"]["message"]
                    .as_str()
                    .is_some_and(|m| m.starts_with("fleet split"))
        })
        .rev()
        .take(8)
        .map(|l| l["fields"].to_string())
        .collect();
    format!("{id}: {counts:?}; last warnings and split lines: {notable:#?}")
}

/// The bridges' log lengths now.
fn lengths(bridges: &[Bridge]) -> Vec<usize> {
    bridges
        .iter()
        .map(|b| b.log.lock().unwrap().len())
        .collect()
}

/// Checks each bridge's [`Plan`] against its group; one line for the
/// summary, with when each plan started after `cut` (each boat's clock
/// when the medium was cut [ms]).
fn check_plans(checks: &mut Checks, ids: &[String], plans: &[Plan], cut: &[u32]) -> String {
    let mut text = Vec::new();
    for (g, group) in GROUPS.iter().enumerate() {
        let others: BTreeSet<String> = GROUPS[1 - g].iter().map(|&i| ids[i].clone()).collect();
        for &i in group {
            let p = &plans[i];
            let against = p.followed.as_ref().map(|f| &f.others);
            checks.check(
                against == Some(&others),
                format!(
                    "{} follows the plan against {others:?} while cut: {against:?}",
                    ids[i]
                ),
            );
            checks.check(
                p.refused == 0 && p.ended_cut.is_empty(),
                format!(
                    "{}: while cut, no plan refused ({}) and none ended ({:?})",
                    ids[i], p.refused, p.ended_cut
                ),
            );
            checks.check(
                p.ended_healed.iter().any(|w| w == HEARD_AGAIN),
                format!(
                    "{}: healed, its plan ended because {HEARD_AGAIN}: {:?}",
                    ids[i], p.ended_healed
                ),
            );
            if let Some(f) = &p.followed {
                text.push(format!(
                    "{} from {:.1} s into the cut, {} (groups {:.1} m apart at closest, {:.0} s \
                     long)",
                    ids[i],
                    f.t - f64::from(cut[i]) / 1000.0,
                    f.water,
                    f.closest,
                    f.duration
                ));
            }
        }
    }
    text.join(", ")
}

/// Converged (or not) as a check and a line for the summary.
fn check_converged(checks: &mut Checks, what: &str, took: Option<f64>, s: &Standing) -> String {
    let line = format!(
        "{what} {}: E_max {:.2} m (E {:.2?} m), H {:+.3} % off H at the centroids",
        took.map_or("NOT within the bound".into(), |t| format!("after {t:.1} s")),
        s.e_max(),
        s.e,
        100.0 * s.gap()
    );
    checks.check(
        took.is_some(),
        format!(
            "{what}: every boat within {E_MAX} m of its centroid and H within {} % of H at the \
             centroids within {CONVERGE_S} s of ArduPilot's clock ({line})",
            100.0 * H_GAP
        ),
    );
    line
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn four_boats_cut_two_two_follow_the_split_plan_and_converge_again() {
    let Some(ap) = ardupilot() else { return };
    if !root_or_skip(TEST) {
        return;
    }
    let _one = one_sitl_fleet().await;
    cleanup_stale();
    let began = Instant::now();
    // Declared first, dropped last: the processes end before their
    // namespaces go.
    let medium = Medium::new(N);
    let dir = tempfile::tempdir().unwrap();
    let (mission_path, mission) = mission_file(dir.path(), &mission_toml());
    let safety = mission.safety().barrier().safety_distance;
    let boats = scattered_boats_in(&ap, &medium);
    let fleet = format!("sitlsplit{}", std::process::id());
    let (mut bridges, ids) = peer_bridges_in(&medium, &boats, &mission_path, &fleet);
    let stations = Station::open_all_in(&medium, &boats).await;
    let mut w = Watch {
        mission,
        stations,
        trace: Vec::new(),
    };
    let mut checks = Checks::new(TEST);

    let Some(controlled) = w.under_control().await else {
        for (id, b) in ids.iter().zip(&bridges) {
            eprintln!("{}", digest(id, b));
        }
        panic!("the four boats in GUIDED and armed within 90 s of wall clock");
    };
    let mut closest = [Closest::new(); 3];

    w.trace.push("converging, on boat-1's clock:".into());
    let (took, s) = w
        .follow(controlled, CONVERGE_S, &mut closest[0], |s, _| settled(s))
        .await;
    let converged = check_converged(&mut checks, "converged", took, &s);

    let (at_cut, from) = (lengths(&bridges), w.here());
    medium.partition(&GROUPS.map(|g| g.to_vec()));
    let cut_wall = Instant::now();
    let cuts: Vec<u32> = w.stations.iter().map(|s| s.seen(Seen::clock_ms)).collect();
    let cut = cuts[0];
    w.trace.push("cut:".into());
    let (lasted, _) = w
        .follow(cut, CUT_S + 10.0, &mut closest[1], |_, t| t >= CUT_S)
        .await;
    let (at_heal, to) = (lengths(&bridges), w.here());
    medium.heal();
    let cut_wall = cut_wall.elapsed().as_secs_f64();
    let heal = w.clock();
    w.trace.push("healed:".into());
    let (took, s) = w
        .follow(heal, CONVERGE_S, &mut closest[2], |s, _| settled(s))
        .await;
    let healed = check_converged(&mut checks, "healed, converged again", took, &s);

    checks.check(
        lasted.is_some(),
        format!(
            "the cut lasted {CUT_S} s of ArduPilot's clock within the wall clock's safety net: \
             {lasted:?}"
        ),
    );
    // How far each boat went while cut: covering as before until the
    // plan starts, then along the plan's way.
    let moved: Vec<f64> = from
        .iter()
        .zip(&to)
        .map(|(a, b)| (a.0 - b.0).hypot(a.1 - b.1))
        .collect();
    let plans: Vec<Plan> = (0..N)
        .map(|i| Plan::of(&bridges[i], at_cut[i], at_heal[i]))
        .collect();
    let planned = check_plans(&mut checks, &ids, &plans, &cuts);
    for (what, c) in ["converging", "cut", "healed"].iter().zip(&closest) {
        c.check(&mut checks, what, safety, &ids);
    }
    eprintln!(
        "SUMMARY {TEST}: 4 SITL boats at speedup {SPEEDUP}, each with its peer bridge in a \
         network namespace of its own; {converged}; cut {} | {} for {:.1} s of ArduPilot's clock \
         ({cut_wall:.1} s of wall clock), plans: {planned}; moved while cut {moved:.2?} m; \
         {healed}; closest pair converging {}, cut {}, healed {} (safety distance {safety} m); \
         wall time {:.0} s",
        GROUPS[0].map(|i| ids[i].as_str()).join(", "),
        GROUPS[1].map(|i| ids[i].as_str()).join(", "),
        lasted.unwrap_or(f64::NAN),
        closest[0].text(&ids),
        closest[1].text(&ids),
        closest[2].text(&ids),
        began.elapsed().as_secs_f64()
    );
    if !checks.failed.is_empty() {
        for line in &w.trace {
            eprintln!("{line}");
        }
        for (id, b) in ids.iter().zip(&bridges) {
            eprintln!("{}", digest(id, b));
        }
    }
    bridges.clear();
    checks.finish();
}
