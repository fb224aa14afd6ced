//! The table's rules, beacon by beacon: who is handed out, when, and
//! which inputs are refused or judged implausible.

use super::*;
use std::time::Duration;

/// A beacon of the paper's actuator at (x, y), heading `psi`, at `u`
/// m/s (the split's tests take theirs from here too).
pub(crate) fn doc(id: &str, t: f64, (x, y): (f64, f64), psi: f64, u: f64) -> BeaconDocument {
    BeaconDocument {
        id: id.into(),
        seq: 1,
        t,
        x,
        y,
        psi,
        u,
        v: 0.0,
        r: 0.0,
        k: 0.5,
        beta: 0.001,
        rev: 0,
        controlled: true,
    }
}

/// Heading east at 1 m/s on y = 0.
fn beacon(id: &str, t: f64, x: f64) -> Vec<u8> {
    wire::encode(&doc(id, t, (x, 0.0), 0.0, 1.0))
}

#[test]
fn only_the_neighbours_that_can_matter_are_handed_out() {
    let ageing = Ageing::default();
    let mut table = Table::new("bay", ["me".to_string()]);
    let t0 = Instant::now();
    let utc = 1.8e9;
    // Beacons at x = 0, 100, 200, 300 m, each moving east at 1 m/s.
    for (i, x) in [0.0, 100.0, 200.0, 300.0].into_iter().enumerate() {
        let id = format!("v{i}");
        table.offer(
            &format!("seacover/bay/beacon/{id}"),
            &beacon(&id, utc, x),
            false,
            t0,
            utc,
            &ageing,
        );
    }
    let ids = |n: Vec<Neighbour>| n.into_iter().map(|n| n.beacon.id).collect::<Vec<_>>();
    let at = |secs| t0 + Duration::from_secs(secs);
    let all = ids(table.neighbours("me", at(1), &ageing));
    assert_eq!(all, ["v0", "v1", "v2", "v3"]);
    // 150 m from x = 0: v0 and v1; v2's beacon (200 m, 1 s old, 1 m/s)
    // is 200 > 150 + 1.
    let near = ids(table.neighbours_near("me", (0.0, 0.0), |_, _| 150.0, at(1), &ageing));
    assert_eq!(near, ["v0", "v1"]);
    // Silent for 10 s its radius (1.2 m/s × 10 s, capped at the 5 m
    // allowance) counts too: 200 ≤ 196 + 5.
    let near = ids(table.neighbours_near("me", (0.0, 0.0), |_, _| 196.0, at(10), &ageing));
    assert_eq!(near, ["v0", "v1", "v2"]);
    // The same as `neighbours` for the ones handed out.
    let near = table.neighbours_near("me", (0.0, 0.0), |_, _| 150.0, at(2), &ageing);
    assert_eq!(near[..], table.neighbours("me", at(2), &ageing)[..2]);
}

/// The indexes change nothing: in a large table of fresh, silent and
/// forgotten beacons, some re-filed after moving, the neighbours handed
/// out are those the module doc's rule picks from every beacon.
#[test]
fn the_indexed_query_hands_out_what_a_walk_over_every_beacon_would() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let ageing = Ageing::default();
    let mut table = Table::new("bay", ["me".to_string()]);
    let t0 = Instant::now();
    let utc = 1.8e9;
    // id → (x, y, ground speed, seconds after t0 its beacon arrived).
    let mut sent = BTreeMap::new();
    let send = |table: &mut Table,
                sent: &mut BTreeMap<String, (f64, f64, f64, f64)>,
                id: String,
                x: f64,
                y: f64,
                speed: f64,
                at: f64| {
        let doc = doc(&id, utc + at, (x, y), 0.3, speed);
        let key = format!("seacover/bay/beacon/{id}");
        let arrived = t0 + Duration::from_secs_f64(at);
        table.offer(&key, &wire::encode(&doc), false, arrived, utc + at, &ageing);
        sent.insert(id, (x, y, speed, at));
    };
    for i in 0..600 {
        // A third heard within the last 4 s, the rest over 80 s.
        let at = if i % 3 == 0 {
            rng.random_range(76.0..80.0)
        } else {
            rng.random_range(0.0..80.0)
        };
        let (x, y) = (rng.random_range(0.0..2000.0), rng.random_range(0.0..2000.0));
        send(
            &mut table,
            &mut sent,
            format!("v{i:03}"),
            x,
            y,
            rng.random_range(0.0..3.0),
            at,
        );
    }
    // Some move on and are heard again (filed in another square).
    for i in (0..600).step_by(7) {
        let id = format!("v{i:03}");
        let (x, y, speed, at) = sent[&id];
        let later = at.max(79.0) + 0.5;
        let step = 3.0 * (later - at);
        send(&mut table, &mut sent, id, x + step, y - step, speed, later);
    }
    let now = t0 + Duration::from_secs(80);
    let mut handed_out = 0;
    for centre in [(1000.0, 1000.0), (40.0, 1900.0), (-300.0, 500.0)] {
        for radius in [50.0, 150.0, 400.0] {
            let got: Vec<String> = table
                .neighbours_near("me", centre, |_, _| radius, now, &ageing)
                .into_iter()
                .map(|n| n.beacon.id)
                .collect();
            let want: Vec<String> = sent
                .iter()
                .filter(|(_, v)| {
                    let &(x, y, speed, at) = *v;
                    let age = 80.0 - at;
                    let moved = if age <= ageing.stale_after {
                        speed * age
                    } else {
                        (speed + ageing.drift) * age
                    };
                    age <= ageing.forget_after
                        && (x - centre.0).hypot(y - centre.1) <= radius + moved
                })
                .map(|(id, _)| id.clone())
                .collect();
            handed_out += want.len();
            assert_eq!(got, want, "about {centre:?} within {radius} m");
        }
    }
    // Not a comparison of empty lists.
    assert!(handed_out > 100, "{handed_out}");
}

/// A table for "me" that has heard vessel "a" at x on y = 0 (heading
/// east at 1 m/s), with the default ageing: the table, the ageing, and the
/// monotonic and UTC times of that beacon.
fn heard_a(x: f64) -> (Table, Ageing, Instant, f64) {
    let ageing = Ageing::default();
    let mut table = Table::new("bay", ["me".to_string()]);
    let t0 = Instant::now();
    let utc = 1.8e9;
    table.offer(
        "seacover/bay/beacon/a",
        &beacon("a", utc, x),
        false,
        t0,
        utc,
        &ageing,
    );
    (table, ageing, t0, utc)
}

#[test]
fn fresh_then_silent_then_forgotten() {
    let (mut table, ageing, t0, _) = heard_a(10.0);
    let n = table.neighbours("me", t0 + Duration::from_secs(1), &ageing);
    assert_eq!(n.len(), 1);
    assert!(n[0].silent.is_none());
    assert!(
        (n[0].beacon.x - 11.0).abs() < 1e-3,
        "extrapolated: {}",
        n[0].beacon.x
    );
    // Silent: (1 m/s + the 0.2 m/s drift) × 4 s, then the allowance.
    let n = table.neighbours("me", t0 + Duration::from_secs(4), &ageing);
    let radius = n[0].silent.unwrap().radius;
    assert!((radius - 4.8).abs() < 1e-3, "{radius}");
    let n = table.neighbours("me", t0 + Duration::from_secs(10), &ageing);
    let radius = n[0].silent.unwrap().radius;
    assert!((radius - 5.0).abs() < 1e-3, "{radius}");
    assert_eq!(n[0].beacon.x, 10.0);
    // Kept two minutes: two boats lost at once are kept clear of while
    // the split's plan has them elsewhere.
    let n = table.neighbours("me", t0 + Duration::from_secs(119), &ageing);
    assert_eq!(n.len(), 1);
    assert!(
        table
            .neighbours("me", t0 + Duration::from_secs(121), &ageing)
            .is_empty()
    );
}

#[test]
fn a_sender_clock_ahead_or_behind_changes_the_age_by_the_clamp_at_most() {
    let ageing = Ageing::default();
    let mut table = Table::new("bay", []);
    let t0 = Instant::now();
    // Stamped 5 s in the future, and 5 s in the past.
    table.offer(
        "seacover/bay/beacon/a",
        &beacon("a", 1.8e9 + 5.0, 0.0),
        false,
        t0,
        1.8e9,
        &ageing,
    );
    table.offer(
        "seacover/bay/beacon/b",
        &beacon("b", 1.8e9 - 5.0, 0.0),
        false,
        t0,
        1.8e9,
        &ageing,
    );
    let ages = table.ages(t0, &ageing);
    assert_eq!(ages["a"], 0.0);
    assert_eq!(ages["b"], MAX_TRANSIT);
    // At a time warp of 10 the clamp would be 5 s of mission time, past
    // stale_after: a lagging clock's beacons count half of stale_after.
    let warped = Ageing {
        warp: 10.0,
        ..Ageing::default()
    };
    let ages = table.ages(t0, &warped);
    assert_eq!(ages["a"], 0.0);
    assert_eq!(ages["b"], warped.stale_after / 2.0);
}

#[test]
fn refusals_are_counted_and_change_nothing() {
    let (mut table, ageing, t0, utc) = heard_a(0.0);
    // Someone else claims "a" 500 m away a second later; another claims "me".
    table.offer(
        "seacover/bay/beacon/a",
        &beacon("a", utc + 1.0, 500.0),
        false,
        t0,
        utc,
        &ageing,
    );
    table.offer(
        "seacover/bay/beacon/me",
        &beacon("me", utc, 0.0),
        false,
        t0,
        utc,
        &ageing,
    );
    table.offer(
        "seacover/sea/beacon/b",
        &beacon("b", utc, 0.0),
        false,
        t0,
        utc,
        &ageing,
    );
    table.offer(
        "seacover/bay/beacon/c",
        b"not cbor",
        false,
        t0,
        utc,
        &ageing,
    );
    let refused = table.refused();
    assert_eq!(refused["id_conflict"], 2);
    assert_eq!(refused["other_fleet"], 1);
    assert_eq!(refused["undecodable"], 1);
    let n = table.neighbours("me", t0, &ageing);
    assert_eq!(n.len(), 1);
    assert_eq!(n[0].beacon.x, 0.0);
}

/// A neighbour whose beacons are implausible (a jump faster than a
/// hull goes, then a place far outside the region) is handed out as
/// traffic, never as a neighbour of the partition, and counted; ten
/// beacons that agree over 2 s of mission time bring it back.
#[test]
fn an_implausible_neighbour_is_traffic_until_its_beacons_agree() {
    use crate::geometry::Point;
    let ageing = Ageing::default();
    let mut table = Table::new("bay", ["me".to_string()]);
    let square = [(0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (0.0, 100.0)];
    let shell = square.iter().map(|&(x, y)| Point { x, y }).collect();
    table.set_region(Some(Region::new(shell, vec![]).unwrap()));
    let t0 = Instant::now();
    let utc = 1.8e9;
    let send = |table: &mut Table, dt: f64, x: f64| {
        let at = t0 + Duration::from_secs_f64(dt);
        let bytes = wire::encode(&doc("v", utc + dt, (x, 50.0), 0.0, 1.0));
        table.offer(
            "seacover/bay/beacon/v",
            &bytes,
            false,
            at,
            utc + dt,
            &ageing,
        );
        table.neighbours("me", at, &ageing).remove(0)
    };
    assert!(send(&mut table, 0.0, 10.0).in_partition());
    assert!(send(&mut table, 0.2, 10.2).in_partition());
    // 3 m in 0.2 s beyond the 5 m of noise: 15 m/s, under the wire's
    // 20 m/s (not a second node with its id), over a hull's 10.
    let n = send(&mut table, 0.4, 18.2);
    assert!(matches!(n.quarantined, Some(Fault::Jump(_))), "{n:?}");
    assert!(!n.in_partition() && n.silent.is_none());
    assert!(
        (n.beacon.x - 18.2).abs() < 1e-5,
        "kept at its newest beacon: {n:?}"
    );
    assert_eq!(table.refused()["jump"], 1);
    assert_eq!(table.quarantined().len(), 1);
    assert_eq!(
        table.others_heard("me", t0 + Duration::from_secs_f64(0.4), &ageing),
        0
    );
    // Consistent again: 1 m/s for 2 s at 5 Hz.
    let mut last = None;
    for i in 1..=11 {
        last = Some(send(
            &mut table,
            0.4 + 0.2 * i as f64,
            18.2 + 0.2 * i as f64,
        ));
    }
    assert!(last.unwrap().in_partition());
    assert!(table.quarantined().is_empty());
    // 600 m east of the square, beyond the 500 m margin (at a speed a
    // hull could not have, too: the first reason counts).
    let n = send(&mut table, 40.0, 700.0);
    assert!(n.quarantined.is_some() && !n.in_partition(), "{n:?}");
    assert_eq!(table.refused()["outside_region"], 1);
}
