//! The split's rules, checked on the paper fleet without I/O.

use super::*;
use crate::agent::peer::table::Silent;

/// The paper fleet's joint optimum (Lloyd's iteration from the paper's
/// starts, `scripts/partition-offsets`), where test c splits it.
const AT: [(f64, f64); 8] = [
    (75.479, 66.674),
    (57.804, 74.267),
    (69.269, 20.328),
    (59.713, 36.028),
    (50.381, 19.942),
    (74.145, 83.567),
    (23.738, 77.795),
    (24.734, 61.582),
];

fn neighbour(i: usize, age: Option<f64>) -> Neighbour {
    let (x, y) = AT[i - 1];
    Neighbour {
        age: age.unwrap_or(0.1),
        beacon: crate::agent::peer::table::tests::doc(&format!("usv-{i}"), 0.0, (x, y), 0.0, 0.0),
        silent: age.map(|a| Silent { radius: 0.2 * a }),
        quarantined: None,
    }
}

fn own(i: usize) -> State {
    let (x, y) = AT[i - 1];
    State {
        x,
        y,
        psi: 0.0,
        vel: Vec3::zeros(),
    }
}

/// What vessel `me` sees when `silent` fell silent `age` s ago (the
/// first of them; the others up to 0.4 s later) and the rest is fresh.
fn seen(me: usize, silent: &[usize], age: f64) -> Vec<Neighbour> {
    (1..=8)
        .filter(|&i| i != me)
        .map(|i| {
            let k = silent.iter().position(|&s| s == i);
            neighbour(i, k.map(|k| age - 0.1 * k as f64))
        })
        .collect()
}

/// Vessel `me`'s tick on the paper mission at `t`.
fn tick<'a>(
    mission: &'a Mission,
    ageing: &'a Ageing,
    me: &'a str,
    own: &'a State,
    neighbours: &'a [Neighbour],
    t: f64,
) -> Tick<'a> {
    Tick {
        mission,
        revision: 0,
        me,
        own,
        actuator: (0.5, 0.001),
        neighbours,
        ageing,
        t,
    }
}

/// Every vessel's planned place, from the orders of one vessel of each
/// group: its own target at the end, and the other group's places.
#[test]
fn both_sides_of_a_split_plan_the_same_places_and_heal() {
    let mission = Mission::paper();
    let ageing = Ageing::default();
    let (a, b) = ([1, 2, 3, 4], [5, 6, 7, 8]);
    let first = ageing.stale_after + TOGETHER + 0.05;
    let late = 1000.0;
    let mut places: [Vec<(String, Point)>; 2] = [Vec::new(), Vec::new()];
    for (side, (me, silent)) in [(1, &b), (6, &a)].into_iter().enumerate() {
        let mut split = Split::default();
        let (id, at) = (format!("usv-{me}"), own(me));
        let tick = |neighbours, t| tick(&mission, &ageing, &id, &at, neighbours, t);
        let neighbours = seen(me, silent, first);
        // Too early: the first has not been silent long enough.
        let early = seen(me, silent, ageing.stale_after + 0.5);
        let (orders, change) = split.update(&tick(&early, 10.0));
        assert_eq!((orders, change), (None, Change::None));
        let (orders, change) = split.update(&tick(&neighbours, 10.0));
        let Change::Started {
            others, closest, ..
        } = change
        else {
            panic!("side {side}: {change:?}");
        };
        assert_eq!(others.len(), 4);
        assert!(closest >= 9.0 - 1e-6, "{closest}");
        assert!(orders.is_some());
        // Long after, every vessel is at its place.
        let (orders, _) = split.update(&tick(&neighbours, late));
        let orders = orders.unwrap();
        places[side].push((id.clone(), orders.target));
        for (id, s) in &orders.others {
            places[side].push((id.clone(), Point { x: s.x, y: s.y }));
        }
        // Healed: one of the other group heard again ends it.
        let mut healed = neighbours.clone();
        let k = healed.iter().position(|n| n.silent.is_some()).unwrap();
        healed[k].silent = None;
        let (orders, change) = split.update(&tick(&healed, late));
        assert_eq!(orders, None);
        assert!(matches!(change, Change::Ended { .. }), "{change:?}");
        // Split again, then one of its own group falls silent: ended too.
        split.update(&tick(&neighbours, 10.0));
        assert!(split.others().is_some());
        let mut lost = neighbours.clone();
        let k = lost.iter().position(|n| n.silent.is_none()).unwrap();
        lost[k].silent = Some(Silent { radius: 1.0 });
        let (orders, change) = split.update(&tick(&lost, 20.0));
        assert_eq!(orders, None);
        assert!(matches!(change, Change::Ended { .. }), "{change:?}");
    }
    // usv-1 knows where usv-5…8 go, usv-6 where usv-1…4 go: each agrees
    // with the other's own target, and both groups' places are apart.
    let find = |side: usize, id: &str| places[side].iter().find(|(i, _)| i == id).unwrap().1;
    for (side, id) in [(0, "usv-1"), (1, "usv-6")] {
        let mine = find(side, id);
        let theirs = find(1 - side, id);
        assert!(
            norm2(mine - theirs).sqrt() < 1e-6,
            "{id}: {mine:?} / {theirs:?}"
        );
    }
    for p in a {
        for q in b {
            let (p, q) = (find(1, &format!("usv-{p}")), find(0, &format!("usv-{q}")));
            assert!(norm2(p - q).sqrt() >= 9.0 - 1e-6);
        }
    }
}

/// The paper fleet cut 5 | 3 at its joint optimum: no ways clear the
/// groups' own optima, so both sides keep to their own water, where
/// they are, and each knows the other stays.
#[test]
fn a_cut_without_clear_ways_keeps_each_group_to_its_own_water() {
    let mission = Mission::paper();
    let ageing = Ageing::default();
    let first = ageing.stale_after + TOGETHER + 0.05;
    let (a, b) = ([1, 2, 3, 4, 5], [6, 7, 8]);
    for (me, silent) in [(2, &b[..]), (7, &a[..])] {
        let mut split = Split::default();
        let (id, at) = (format!("usv-{me}"), own(me));
        let neighbours = seen(me, silent, first);
        let (orders, change) = split.update(&tick(&mission, &ageing, &id, &at, &neighbours, 10.0));
        let Change::Started { water, closest, .. } = change else {
            panic!("{id}: {change:?}");
        };
        assert_eq!(water, Water::Own, "{id}");
        assert_eq!(split.water(), Some(Water::Own));
        assert!(closest >= 9.0 - 1e-6, "{closest}");
        let (orders_late, _) =
            split.update(&tick(&mission, &ageing, &id, &at, &neighbours, 1000.0));
        for o in [orders.unwrap(), orders_late.unwrap()] {
            assert!(norm2(o.target - Point { x: at.x, y: at.y }).sqrt() < 0.05);
            for (other, s) in &o.others {
                let i: usize = other[4..].parse().unwrap();
                let (x, y) = AT[i - 1];
                assert!((s.x - x).hypot(s.y - y) < 0.05, "{other}");
            }
        }
    }
}

/// An island across the way a vessel would have to take: the plan is
/// refused (once per silence), and today's rule stays.
#[test]
fn an_island_in_the_way_refuses_the_plan() {
    let mut doc = Mission::paper().document();
    doc.region.holes = vec![vec![[38.0, 64.0], [46.0, 64.0], [46.0, 80.0], [38.0, 80.0]]];
    let mission = Mission::from_document(&doc).expect("a valid mission");
    let ageing = Ageing::default();
    let first = ageing.stale_after + TOGETHER + 0.05;
    let mut split = Split::default();
    let at = own(1);
    let neighbours = seen(1, &[5, 6, 7, 8], first);
    let (orders, change) = split.update(&tick(&mission, &ageing, "usv-1", &at, &neighbours, 10.0));
    assert_eq!(orders, None);
    // Refused for the island: the ways keep clear of each other.
    let Change::Refused { closest, .. } = change else {
        panic!("{change:?}");
    };
    assert!(closest >= 9.0 - 1e-6, "{closest}");
    // The same silence on the next tick: not planned for again.
    let (orders, change) = split.update(&tick(&mission, &ageing, "usv-1", &at, &neighbours, 10.1));
    assert_eq!((orders, change), (None, Change::None));
}

/// One silent neighbour is a dead boat, not a group: no plan; nor when
/// this vessel hears nobody else (a lone vessel cut off).
#[test]
fn a_lone_silence_or_a_lone_vessel_makes_no_plan() {
    let mission = Mission::paper();
    let ageing = Ageing::default();
    let first = ageing.stale_after + TOGETHER + 0.05;
    let mut split = Split::default();
    let at = own(1);
    let one = seen(1, &[5], first);
    let (orders, change) = split.update(&tick(&mission, &ageing, "usv-1", &at, &one, 10.0));
    assert_eq!((orders, change), (None, Change::None));
    let alone = seen(1, &[2, 3, 4, 5, 6, 7, 8], first);
    let (orders, change) = split.update(&tick(&mission, &ageing, "usv-1", &at, &alone, 10.0));
    assert_eq!((orders, change), (None, Change::None));
    assert_eq!(split.others(), None);
}

/// A plan computed off the tick, on another thread, and accepted 2 s
/// later is the plan computed on the tick, with the same clock: the same
/// orders at every time; until it comes there are no orders and no second
/// job for the same silence.
#[test]
fn a_plan_computed_off_the_tick_is_the_one_computed_on_it() {
    let mission = Mission::paper();
    let ageing = Ageing::default();
    let first = ageing.stale_after + TOGETHER + 0.05;
    let (a, b) = ([1, 2, 3, 4], [5, 6, 7, 8]);
    for (me, silent) in [(1, &b), (6, &a)] {
        let (id, at) = (format!("usv-{me}"), own(me));
        let steps = [0.1, 0.5, 1.0];
        let later = steps.map(|dt| seen(me, silent, first + dt));
        let tick = |neighbours, t| tick(&mission, &ageing, &id, &at, neighbours, t);
        let at_split = seen(me, silent, first);
        let mut inline = Split::default();
        let (_, started) = inline.update(&tick(&at_split, 10.0));
        assert!(matches!(started, Change::Started { .. }), "{started:?}");

        let mut off = Split::default();
        let (orders, change, job) = off.look(&tick(&at_split, 10.0));
        assert_eq!((orders, change), (None, Change::None));
        let job = job.expect("a job for the split");
        // While it is computed: no orders (today's rule), no second job.
        for (dt, later) in steps.into_iter().zip(&later) {
            let (orders, change, again) = off.look(&tick(later, 10.0 + dt));
            assert_eq!((orders, change), (None, Change::None), "{id} at +{dt}");
            assert!(again.is_none(), "{id} at +{dt}");
        }
        let planned = std::thread::spawn(move || job.compute())
            .join()
            .expect("the job computes");
        let late = seen(me, silent, first + 2.0);
        assert_eq!(off.accept(planned, &tick(&late, 12.0)), started, "{id}");
        let (on, by) = (inline.active.as_ref(), off.active.as_ref());
        assert_eq!(
            on.map(|a| (&a.key.ids, a.key.me, a.key.origin, &a.plan)),
            by.map(|a| (&a.key.ids, a.key.me, a.key.origin, &a.plan))
        );
        for t in [12.0, 30.0, 60.0, 1000.0] {
            let (on, _) = inline.update(&tick(&late, t));
            let (by, change, job) = off.look(&tick(&late, t));
            assert_eq!((&change, job.is_none()), (&Change::None, true));
            assert_eq!(by, on, "{id} at {t}");
            assert!(by.is_some());
        }
    }
}

/// A plan whose situation passed while it was computed is not followed:
/// the other group heard again (seen before or when it comes), a new
/// mission revision, or a newer job for the same vessel.
#[test]
fn a_plan_arriving_after_the_heal_is_dropped() {
    let mission = Mission::paper();
    let ageing = Ageing::default();
    let first = ageing.stale_after + TOGETHER + 0.05;
    let (id, at) = ("usv-1", own(1));
    let tick = |neighbours, t| tick(&mission, &ageing, id, &at, neighbours, t);
    let at_split = seen(1, &[5, 6, 7, 8], first);
    let mut healed = seen(1, &[5, 6, 7, 8], first + 2.0);
    let k = healed.iter().position(|n| n.silent.is_some()).unwrap();
    healed[k].silent = None;
    let job = |split: &mut Split| split.look(&tick(&at_split, 10.0)).2.expect("a job");
    let dropped =
        |change: &Change| matches!(change, Change::Dropped { others, .. } if others.len() == 4);

    // Healed while it is computed: dropped then, and its result ignored.
    let mut split = Split::default();
    let planned = job(&mut split).compute();
    let (orders, change, again) = split.look(&tick(&healed, 11.0));
    assert!(dropped(&change), "{change:?}");
    assert_eq!((orders, again.is_none()), (None, true));
    assert_eq!(split.accept(planned, &tick(&healed, 12.0)), Change::None);
    assert_eq!(split.look(&tick(&healed, 12.1)).0, None);
    assert_eq!(split.others(), None);

    // Healed on the tick it comes: dropped.
    let mut split = Split::default();
    let planned = job(&mut split).compute();
    assert!(dropped(&split.accept(planned, &tick(&healed, 12.0))));
    assert_eq!(split.look(&tick(&healed, 12.1)).0, None);
    assert_eq!(split.others(), None);

    // A new revision meanwhile: dropped.
    let mut split = Split::default();
    let planned = job(&mut split).compute();
    let mut revised = tick(&at_split, 12.0);
    revised.revision = 1;
    assert!(dropped(&split.accept(planned, &revised)));
    assert_eq!(split.others(), None);

    // Dropped for a new revision, then a job for the same silence under
    // it: only the newer job's result is taken.
    let mut split = Split::default();
    let old = job(&mut split).compute();
    let mut revised = tick(&at_split, 10.1);
    revised.revision = 1;
    let (_, change, newer) = split.look(&revised);
    assert!(dropped(&change), "{change:?}");
    assert!(newer.is_none());
    let (_, _, newer) = split.look(&revised);
    let newer = newer.expect("a job under the new revision").compute();
    assert_eq!(split.accept(old, &revised), Change::None);
    assert!(matches!(
        split.accept(newer, &revised),
        Change::Started { .. }
    ));
}
