//! A peer fleet that loses part of itself: eight real `seacover agent
//! --peer` processes in network namespaces of their own on one radio
//! medium (tests/it/common/fleet.rs, as in tests/it/peer_fleet.rs), the
//! paper's scenario, and the independent Python observer in host 0 (and in
//! host 9 with the second group while the fleet is cut).
//!
//! - c. Cuts by the medium, then healed: 4 | 4 and 5 | 3 (both sides
//!   follow the split's plan: for 4 | 4 each group covers the region, for
//!   5 | 3, whose ways are not clear, each keeps to its own water), and 7 |
//!   1 (the seven take the lone one's water and keep clear of where it fell
//!   silent; the lone one hears nobody and holds station). Checks: within
//!   stale_after + 2 s every vessel's partition is its own group only (by
//!   the `partition_since` of its statuses, its own clock), and every
//!   status after says so; every group of two or more covers what its
//!   plan gives it (H within 1 % of its own optimum there, Lloyd's
//!   iteration by `seacover evaluate` from where it is, among the other
//!   group held where it was at the cut for its own water);
//!   healed, back at the joint optimum (E_max < 0.5 m, H within 0.5 % of
//!   the centralized run's); never two vessels within the safety distance.
//! - k. Two vessels SIGKILLed 0.3 s of mission time apart, which the
//!   others cannot tell from a 6 | 2 cut: for 120 s of mission time no
//!   living vessel within the safety distance of a wreck's last position
//!   (the vessels keep the safety distance plus the 5 m drift allowance,
//!   docs/peer.md "What each loss does"), and the six re-cover the region
//!   (H within 1 % of H with every vessel at its own cell's centroid).
//!
//! Mission time is read off the beacons (see tests/it/peer_fleet.rs). Needs
//! root and the test venv's Python (skipped with a message otherwise, a
//! failure under CI=true).

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use serde_json::Value;

use crate::common::fleet::*;
use crate::common::paper::*;
use crate::common::peer::now;
use crate::common::process::signal;

/// How long the cut lasts [s of mission time]: a plan's cut as long as the
/// first such test's; a lone vessel's within `forget_after` (120 s), since
/// after that the seven may take the water where it holds (docs/peer.md).
const CUT_PLANNED: f64 = 200.0;
const CUT_LONE: f64 = 100.0;

/// c. 4 | 4.
#[test]
fn c_partition_four_four_and_heal() {
    partition_and_heal("peer_partition c 4|4", "c", [1, 2, 3, 4], CUT_PLANNED);
}

/// c. 5 | 3: no ways clear the groups' own optima for this cut, so each
/// group keeps to its own water (docs/peer.md, "What each loss does").
#[test]
fn c_partition_five_three_and_heal() {
    partition_and_heal("peer_partition c 5|3", "c53", [1, 2, 3, 4, 5], CUT_PLANNED);
}

/// c. 7 | 1.
#[test]
fn c_partition_seven_one_and_heal() {
    partition_and_heal(
        "peer_partition c 7|1",
        "c71",
        [1, 2, 3, 4, 5, 6, 7],
        CUT_LONE,
    );
}

/// What one vessel said of its partition while cut and once healed.
#[derive(Debug, Default)]
struct Said {
    /// Mission seconds after the cut when its partition became its group
    /// only (its status's `partition_since`).
    split_in: Option<f64>,
    /// When it first said it follows a plan against the other group.
    planned_in: Option<f64>,
    /// What that plan had its group cover (`region` or `own`).
    water: Option<String>,
    /// When it first said it hears nobody and holds.
    alone_in: Option<f64>,
    /// Statuses off its group after the first on it, of all while cut.
    wrong: (usize, usize),
    healed_in: Option<f64>,
}

/// What vessel `i` of group `mine` said, from the observers' statuses.
fn said(fleet: &Fleet, mine: &[usize], i: usize, t: [f64; 3]) -> Said {
    let [t_split, t_healing, t_heal] = t;
    let id = format!("usv-{i}");
    let mates: BTreeSet<String> = mine
        .iter()
        .filter(|&&j| j != i)
        .map(|j| format!("usv-{j}"))
        .collect();
    let statuses: Vec<&Value> = fleet
        .statuses
        .iter()
        .filter(|s| s["status"]["id"] == id.as_str())
        .collect();
    // A status asked for before the heal may be answered after it: only
    // those answered before the heal began count as "cut".
    let during: Vec<&&Value> = statuses
        .iter()
        .filter(|s| {
            s["sent"].as_f64().unwrap() >= t_split && s["recv"].as_f64().unwrap() < t_healing
        })
        .collect();
    let after = |s: &Value, from: f64| (s["recv"].as_f64().unwrap() - from) * WARP;
    let group = mates.len() as u64;
    let first = during
        .iter()
        .position(|s| s["status"]["neighbours"].as_u64() == Some(group) && fresh(s) == mates);
    let others: Vec<Value> = (1..=N)
        .filter(|j| !mine.contains(j))
        .map(|j| Value::from(format!("usv-{j}")))
        .collect();
    let wrong = first.map_or(0, |k| {
        during[k..]
            .iter()
            .filter(|s| s["status"]["neighbours"].as_u64() != Some(group))
            .count()
    });
    Said {
        // When its partition became its group, by its own clock to the
        // tick (the observer asks every second of mission time).
        split_in: first.map(|k| {
            let s = during[k];
            let since = s["status"]["partition_since"].as_f64();
            since.map_or_else(|| after(s, t_split), |at| (at - t_split).max(0.0) * WARP)
        }),
        planned_in: during
            .iter()
            .find(|s| s["status"]["split"].as_array() == Some(&others))
            .map(|s| after(s, t_split)),
        water: during
            .iter()
            .find(|s| s["status"]["split"].as_array() == Some(&others))
            .and_then(|s| s["status"]["split_water"].as_str())
            .map(str::to_string),
        alone_in: during
            .iter()
            .find(|s| s["status"]["alone"] == true)
            .map(|s| after(s, t_split)),
        wrong: (wrong, during.len()),
        healed_in: statuses
            .iter()
            .find(|s| {
                s["sent"].as_f64().unwrap() >= t_heal
                    && s["status"]["neighbours"].as_u64() == Some(N as u64 - 1)
            })
            .map(|s| after(s, t_heal)),
    }
}

/// Vessels `first` (with observer A in host 0) cut from the rest (with
/// observer B in host N + 1) after 150 s of mission time joint, for `cut`
/// s, then healed for 200 s.
fn partition_and_heal<const K: usize>(test: &str, tag: &str, first: [usize; K], cut: f64) {
    let Some(python) = skip(test) else { return };
    let mut checks = Checks::new(test);
    let h_central = centralized_h();
    let (joint, healed) = (150.0, 200.0);
    let wall = Instant::now();
    let mut setup = Setup::new(tag, WARP).status_every(0.1);
    setup.observers = 2;
    let mut fleet = Fleet::new(setup, &python);
    fleet.launch();
    fleet.wait_heard_all();
    fleet.run_until(joint, |_| {});
    let groups: [Vec<usize>; 2] = [
        first.to_vec(),
        (1..=N).filter(|i| !first.contains(i)).collect(),
    ];
    let hosts = [
        [vec![0], groups[0].clone()].concat(),
        [groups[1].clone(), vec![N + 1]].concat(),
    ];
    let at_cut = fleet.positions();
    fleet.medium.partition(&hosts);
    let t_split = now();
    let m_split = fleet.mission_time();
    fleet.run_until(m_split + cut, |_| {});
    let at = fleet.positions();
    let t_healing = now();
    fleet.medium.heal();
    let t_heal = now();
    let m_heal = fleet.mission_time();
    let rejoined =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| fleet.wait_formed(40.0)))
            .ok()
            .map(|_| (now() - t_heal) * WARP);
    fleet.run_until(fleet.mission_time() + healed, |_| {});
    let (h_end, e_end) = coverage(&fleet.positions());
    let e_end_max = max_of(&e_end);
    let ratio_end = h_end / h_central;
    let safety = fleet.safety_distance();
    let closest = check_safety(&mut checks, &fleet, safety);
    check_wire(&mut checks, &fleet);
    let mut said_by = BTreeMap::new();
    for group in &groups {
        for &i in group {
            let s = said(&fleet, group, i, [t_split, t_healing, t_heal]);
            said_by.insert(format!("usv-{i}"), (group.len(), s));
        }
    }
    fleet.shutdown(&mut checks);
    let (ratios, group_text) = groups_covered(&groups, &said_by, &at_cut, &at);
    let worst = said_by
        .values()
        .map(|(_, s)| s.split_in.unwrap_or(f64::INFINITY))
        .fold(0.0, f64::max);
    eprintln!(
        "SUMMARY {test}: time warp {WARP}; cut {:?} | {:?} at {m_split:.0} s for {cut} s: \
         {}; what each said {said_by:.1?}; healed at {m_heal:.0} s, all 7 in every partition \
         after {rejoined:.1?} s; {healed} s after: H {h_end:.1} / centralized {h_central:.1} = \
         {ratio_end:.5}, E_max {e_end_max:.3} m; closest pair over the run {closest:.2} m \
         (safety {safety} m); {:.0} s wall",
        groups[0],
        groups[1],
        group_text.join("; "),
        wall.elapsed().as_secs_f64(),
    );
    checks.check(
        worst <= STALE_AFTER + 2.0,
        format!(
            "within stale_after + 2 s = {} s of mission time every vessel's partition is its own \
             group only: worst {worst:.1} s",
            STALE_AFTER + 2.0
        ),
    );
    let planned = groups.iter().all(|g| g.len() > 1);
    for (id, (size, s)) in &said_by {
        if planned {
            checks.check(
                s.planned_in.is_some(),
                format!("{id} follows the split's plan against the other group"),
            );
        } else if *size == 1 {
            checks.check(
                s.alone_in.is_some(),
                format!("{id}, cut off alone, says it hears nobody and holds"),
            );
        }
        checks.check(
            s.healed_in.is_some(),
            format!("{id}: healed, a status shows the 7 others"),
        );
        checks.check(
            s.wrong.0 == 0,
            format!(
                "{id}: once down to its group, no status shows another: {:?}",
                s.wrong
            ),
        );
    }
    for (group, what, ratio) in &ratios {
        checks.check(
            *ratio >= 0.99,
            format!("group {group:?} covers {what}: H / its own optimum {ratio:.4} ≥ 0.99"),
        );
    }
    checks.check(
        rejoined.is_some(),
        format!("healed, every vessel hears the 7 others within 40 s of wall time: {rejoined:.1?}"),
    );
    checks.check(
        e_end_max < 0.5,
        format!("healed, back to the joint optimum: E_max {e_end_max:.3} m < 0.5 m"),
    );
    checks.check(
        (ratio_end - 1.0).abs() <= 0.005,
        format!(
            "healed, H {h_end:.1} within 0.5 % of the centralized {h_central:.1} ({ratio_end:.5})"
        ),
    );
    checks.finish();
}

/// How well each group of two or more covered what its plan gave it, at
/// the cut's end (`at`): the whole region (against the group's own optimum,
/// Lloyd's iteration from where it is), or, when its members said their
/// plan keeps them to their own water, that water (against Lloyd's
/// iteration among the other group held where it was at the cut,
/// `at_cut`). (group, what, H / optimum) and a line for the summary.
type Covered = (Vec<usize>, &'static str, f64);
fn groups_covered(
    groups: &[Vec<usize>; 2],
    said_by: &BTreeMap<String, (usize, Said)>,
    at_cut: &[Pos],
    at: &[Pos],
) -> (Vec<Covered>, Vec<String>) {
    let (mut ratios, mut text) = (Vec::new(), Vec::new());
    for (g, group) in groups.iter().enumerate().filter(|(_, g)| g.len() > 1) {
        let mine: Vec<Pos> = group.iter().map(|&i| at[i - 1].clone()).collect();
        let own = group
            .iter()
            .all(|i| said_by[&format!("usv-{i}")].1.water.as_deref() == Some("own"));
        let (what, h, h_opt, steps, e) = if own {
            let held: Vec<Pos> = groups[1 - g]
                .iter()
                .map(|&i| at_cut[i - 1].clone())
                .collect();
            let (h, e) = coverage(&[&mine[..], &held[..]].concat());
            let e: BTreeMap<String, f64> = e
                .into_iter()
                .filter(|(id, _)| mine.iter().any(|p| &p.id == id))
                .collect();
            let (h_opt, steps, _) = lloyd_among(&mine, &held);
            ("its own water", h, h_opt, steps, e)
        } else {
            let (h, e) = coverage(&mine);
            let (h_opt, steps, _) = lloyd(&mine);
            ("the region by itself", h, h_opt, steps, e)
        };
        ratios.push((group.clone(), what, h / h_opt));
        text.push(format!(
            "group {group:?} covers {what}: H {h:.1}, its optimum {h_opt:.1} (Lloyd, {steps} \
             steps), ratio {:.4}, E_max {:.2} m",
            h / h_opt,
            max_of(&e)
        ));
    }
    (ratios, text)
}

/// The least distance from any beacon of a vessel not in `dead` to the
/// position `wreck`, over beacons sent from `from` to `to` (sender UTC).
fn nearest_to(
    fleet: &Fleet,
    dead: &[&str],
    wreck: (f64, f64),
    from: f64,
    to: f64,
) -> (f64, String) {
    let mut best = (f64::INFINITY, String::new());
    for r in fleet.unique_beacons() {
        let b = &r["beacon"];
        let (Some(id), Some(t), Some(x), Some(y)) = (
            b["id"].as_str(),
            b["t"].as_f64(),
            b["x"].as_f64(),
            b["y"].as_f64(),
        ) else {
            continue;
        };
        if dead.contains(&id) || t < from || t > to {
            continue;
        }
        let d = (x - wreck.0).hypot(y - wreck.1);
        if d < best.0 {
            best = (d, format!("{id} at {:.1} s", (t - from) * WARP));
        }
    }
    best
}

/// k. Two boats lost at once: usv-1 and usv-3, on the east side (a
/// living vessel came within 6.80 m of usv-3's last position when the
/// plan's obstacles were only where the plan had the wrecks).
#[test]
fn k_two_boats_killed_at_once_east() {
    two_killed("peer_partition k east", "k13", ["usv-1", "usv-3"]);
}

/// k. usv-4 and usv-8, on the west side (7.07 m from usv-4's, the same
/// way).
#[test]
fn k_two_boats_killed_at_once_west() {
    two_killed("peer_partition k west", "k48", ["usv-4", "usv-8"]);
}

/// Kills `dead` 0.3 s of mission time apart after 150 s.
fn two_killed(test: &str, tag: &str, dead: [&str; 2]) {
    let Some(python) = skip(test) else { return };
    let mut checks = Checks::new(test);
    let (joint, after) = (150.0, 200.0);
    let wall = Instant::now();
    let mut fleet = Fleet::new(Setup::new(tag, WARP), &python);
    fleet.launch();
    fleet.wait_heard_all();
    fleet.run_until(joint, |_| {});

    let t_kill = now();
    for (k, id) in dead.iter().enumerate() {
        let v = fleet
            .vessels
            .iter()
            .position(|v| v.id == *id)
            .expect("a vessel of the fleet");
        let mut v = fleet.vessels.remove(v);
        signal(v.child.0.id(), "-KILL");
        v.child.0.wait().unwrap();
        if k == 0 {
            std::thread::sleep(std::time::Duration::from_secs_f64(0.3 / WARP));
        }
    }
    let m_kill = fleet.mission_time();
    fleet.run_until(m_kill + after, |_| {});
    let safety = fleet.safety_distance();
    let window = t_kill + 120.0 / WARP;
    let mut wrecks = Vec::new();
    for id in dead {
        let b = &fleet.latest[id]["beacon"];
        let wreck = (num(&b["x"], "x"), num(&b["y"], "y"));
        let (d, who) = nearest_to(&fleet, &dead, wreck, t_kill, window);
        wrecks.push(format!(
            "{id} last at ({:.1}, {:.1}): nearest {d:.2} m ({who})",
            wreck.0, wreck.1
        ));
        checks.check(
            d >= safety,
            format!("for 120 s no living vessel within {safety} m of {id}'s last position: {d:.2} m ({who})"),
        );
    }
    let living: Vec<Pos> = fleet
        .positions()
        .into_iter()
        .filter(|p| !dead.contains(&p.id.as_str()))
        .collect();
    let eval = evaluate(&living);
    let at_centroids: Vec<Pos> = living
        .iter()
        .map(|p| {
            let (x, y) = eval.centroids[&p.id];
            Pos { x, y, ..p.clone() }
        })
        .collect();
    let h_centroids = evaluate(&at_centroids).h;
    let ratio = eval.h / h_centroids;
    let e: Vec<f64> = living
        .iter()
        .map(|p| {
            let (x, y) = eval.centroids[&p.id];
            (p.x - x).hypot(p.y - y)
        })
        .collect();
    let closest = check_safety(&mut checks, &fleet, safety);
    fleet.shutdown(&mut checks);
    eprintln!(
        "SUMMARY {test}: time warp {WARP}; {dead:?} SIGKILLed 0.3 s of mission time apart at \
         {m_kill:.0} s; over the next 120 s: {}; {after} s after: the six at H {:.1}, at their \
         centroids {h_centroids:.1} (ratio {ratio:.5}), E {e:.2?} m; closest living pair {closest:.2} m \
         (safety {safety} m); {:.0} s wall",
        wrecks.join("; "),
        eval.h,
        wall.elapsed().as_secs_f64(),
    );
    checks.check(
        (ratio - 1.0).abs() <= 0.01,
        format!("the six re-cover the region: H within 1 % of H at their centroids ({ratio:.5})"),
    );
    checks.finish();
}
