//! When the fleet splits: two or more neighbours that fall silent together
//! are taken as the other side of a radio partition, not as dead boats, and
//! both sides follow one plan ([`coverage::split`](crate::coverage::split))
//! until they hear each other again.
//!
//! Why a plan: each side of a partition covers the whole region by itself,
//! and the two sides' own optima can put vessels of both on the same water
//! (docs/peer.md, "What each loss does"). A vessel cannot keep clear of
//! where a silent one *could* be and still take its water; it can keep
//! clear of where the silent one *will* be, if both compute the same plan.
//!
//! ## When a plan starts
//! At the tick when the first of a set of neighbours has been silent for
//! [`TOGETHER`] s past `stale_after`, if at least two fell silent within
//! those [`TOGETHER`] s and this vessel has at least one fresh neighbour:
//! the silent ones are the other group, this vessel and its fresh
//! neighbours its own. Both sides then see a group of two or more fall
//! silent, so both plan; the plan's clock starts then (τ = 0), which both
//! sides reach at the same mission time to within a beacon's period. A
//! lone silent vessel (a dead boat, or a lone vessel cut off) keeps the
//! rule of [`table`](super::table): its water is taken, it is an obstacle
//! with a growing radius.
//!
//! ## While it lasts
//! The vessel drives to where the plan has it (a little ahead on its way,
//! by the distance its guidance lags a goal moving at its planned speed,
//! so that the hull itself is where the plan has it), not to its cell's
//! centroid; the other group's vessels are obstacles where the plan has
//! them, with [`SLACK`] for how far each may be off its plan, and not
//! trusted to keep their half of a gap; and, until they are forgotten,
//! where they fell silent too, with the table's drift allowance: two boats
//! that die together look like a partition, and wrecks follow no plan.
//! Its cell is still computed among its own group (what it reports as its
//! partition).
//!
//! ## When it ends
//! When any vessel of the other group is heard again (the partition
//! healed: everyone's cell and safety as before), when one of its own group
//! falls silent (the groups are no longer what both sides planned with),
//! or when the mission's revision changes. A plan whose way would bring two
//! vessels of different groups closer than the separation or than they
//! were at the start, or a hull nearer the shore than the safety layer
//! lets it go (an island in the way), is not followed (today's rule then
//! applies).
//!
//! Pure: the mission time comes in, nothing goes out but the plan's
//! orders.

use super::table::{Ageing, Neighbour};
use crate::control::Vec3;
use crate::control::model::State;
use crate::coverage::Vessel;
use crate::coverage::split::{self, SplitParams, SplitPlan, Water};
use crate::geometry::{Point, norm2};
use crate::mission::Mission;

/// Neighbours that fell silent within this many seconds of each other
/// fell silent together [s of mission time]: a cut link loses its last
/// beacons within a beacon period or two, even at 20 % loss.
pub const TOGETHER: f64 = 1.0;

/// How far a vessel following a plan may be off it [m]: added to the
/// safety distance towards each vessel of the other group, and twice to
/// the plan's separation, so that two vessels each this far off their
/// plans still keep the safety distance.
pub const SLACK: f64 = 0.5;

/// Speed of every vessel on its way to the plan's placement [m/s]: slow
/// enough that the hull keeps to its way within [`SLACK`] (the guidance
/// lags a goal moving at 0.25 m/s by 0.74 m, and the lead makes up for it).
pub const SPEED: f64 = 0.25;

/// This tick's orders from a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Orders {
    /// Where the vessel is to steer now.
    pub target: Point,
    /// The other group's vessels where the plan has them now.
    pub others: Vec<(String, State)>,
    /// Room kept around each of them [m].
    pub radius: f64,
}

/// A plan being followed.
#[derive(Debug, Clone)]
struct Active {
    revision: u32,
    /// Both groups' ids in the plan's order.
    ids: [Vec<String>; 2],
    /// This vessel's group and place in it.
    me: (usize, usize),
    plan: SplitPlan,
    /// Mission time of τ = 0.
    origin: f64,
    /// How far ahead on its way this vessel steers [s].
    lead: f64,
}

/// What happened to the plan on this tick, for the log.
#[derive(Debug, Clone, PartialEq)]
pub enum Change {
    None,
    /// A plan started: the other group's ids, the least distance between
    /// the groups along it, its duration.
    Started {
        others: Vec<String>,
        closest: f64,
        duration: f64,
        water: Water,
    },
    /// Groups that fell silent together, but the plan's ways were not clear
    /// of each other or of the shore (`closest`: between the groups).
    Refused {
        others: Vec<String>,
        closest: f64,
    },
    Ended {
        why: &'static str,
    },
}

impl Change {
    /// What vessel `id`'s log says of its split plan at mission time `t`.
    pub fn log(&self, id: &str, t: f64) {
        match self {
            Change::None => {}
            Change::Started {
                others,
                closest,
                duration,
                water,
            } => tracing::info!(
                vessel = %id, t, ?others, closest, duration, ?water,
                "fleet split: following the plan both groups compute"
            ),
            Change::Refused { others, closest } => tracing::warn!(
                vessel = %id, t, ?others, closest,
                "fleet split: the plan's way is not clear, keeping clear of the silent vessels instead"
            ),
            Change::Ended { why } => {
                tracing::info!(vessel = %id, t, why, "fleet split: plan ended")
            }
        }
    }
}

/// What a vessel's tick hands its split.
#[derive(Debug, Clone, Copy)]
pub struct Tick<'a> {
    pub mission: &'a Mission,
    /// The mission's revision.
    pub revision: u32,
    /// This vessel's id, state and actuator (k, β as the wire carries them).
    pub me: &'a str,
    pub own: &'a State,
    pub actuator: (f64, f64),
    /// Its neighbours, fresh and silent, in id order.
    pub neighbours: &'a [Neighbour],
    pub ageing: &'a Ageing,
    /// Mission time.
    pub t: f64,
}

/// One vessel's split: none, or the plan it follows.
#[derive(Debug, Default)]
pub struct Split {
    active: Option<Active>,
    /// The other group of the last plan not followed: the same silence is
    /// not planned for again on every tick of its window.
    refused: Vec<String>,
}

impl Split {
    /// The other group's ids while a plan is followed.
    pub fn others(&self) -> Option<Vec<String>> {
        self.active.as_ref().map(|a| a.ids[1 - a.me.0].clone())
    }

    /// What this vessel's group covers while a plan is followed.
    pub fn water(&self) -> Option<Water> {
        self.active.as_ref().map(|a| a.plan.water)
    }

    /// Looks at this tick: starts, keeps or ends a plan, and gives the
    /// tick's orders while one is followed.
    pub fn update(&mut self, tick: &Tick<'_>) -> (Option<Orders>, Change) {
        let mut change = Change::None;
        if let Some(active) = &self.active {
            if let Some(why) = ended(active, tick.revision, tick.neighbours) {
                self.active = None;
                change = Change::Ended { why };
            }
        } else {
            change = self.start(tick);
        }
        let orders = self.active.as_ref().map(|a| orders(a, tick.t));
        (orders, change)
    }

    fn start(&mut self, tick: &Tick<'_>) -> Change {
        let Tick {
            mission,
            revision,
            me,
            own,
            actuator,
            neighbours,
            ageing,
            t,
        } = *tick;
        let recent =
            |n: &&Neighbour| n.silent.is_some() && n.age <= ageing.stale_after + 2.0 * TOGETHER;
        let first = neighbours
            .iter()
            .filter(recent)
            .map(|n| n.age)
            .fold(0.0, f64::max);
        // Not yet: the first has not been silent long enough for the rest
        // of its group to be silent too; or long past (not a new split).
        if first < ageing.stale_after + TOGETHER || first > ageing.stale_after + 2.0 * TOGETHER {
            self.refused.clear();
            return Change::None;
        }
        let others: Vec<&Neighbour> = neighbours
            .iter()
            .filter(|n| n.silent.is_some() && first - n.age <= TOGETHER)
            .collect();
        let fresh: Vec<&Neighbour> = neighbours.iter().filter(|n| n.in_partition()).collect();
        if others.len() < 2 || fresh.is_empty() {
            return Change::None;
        }
        // Own group in id order, this vessel among them.
        let mut mine: Vec<(String, Vessel)> = fresh.iter().map(|n| as_vessel(n)).collect();
        mine.push((
            me.to_string(),
            Vessel {
                position: Point { x: own.x, y: own.y },
                k: actuator.0,
                beta: actuator.1,
            },
        ));
        mine.sort_by(|a, b| a.0.cmp(&b.0));
        let theirs: Vec<(String, Vessel)> = others.iter().map(|n| as_vessel(n)).collect();
        if theirs.iter().map(|(id, _)| id).eq(self.refused.iter()) {
            return Change::None;
        }
        // The group holding the least id first: both sides agree on it.
        let mine_first = mine[0].0 < theirs[0].0;
        let (first_group, second_group) = if mine_first {
            (&mine, &theirs)
        } else {
            (&theirs, &mine)
        };
        let ids = [first_group, second_group]
            .map(|g| g.iter().map(|(id, _)| id.clone()).collect::<Vec<_>>());
        let groups =
            [first_group, second_group].map(|g| g.iter().map(|(_, v)| *v).collect::<Vec<_>>());
        let safety = mission.safety().barrier().safety_distance;
        // Until the silent group is forgotten, every way keeps clear of
        // where it fell silent as the filter will (the safety distance and
        // the drift allowance, with the slack): they may be wrecks.
        let params = SplitParams {
            starts_kept: Some((safety + ageing.allowance + SLACK, ageing.forget_after)),
            ..SplitParams::both(safety + 2.0 * SLACK, SPEED)
        };
        let Some(plan) = split::plan(
            mission.region(),
            mission.risk(),
            [&groups[0], &groups[1]],
            &params,
        ) else {
            return Change::None;
        };
        let closest = plan.closest();
        let other_ids: Vec<String> = theirs.iter().map(|(id, _)| id.clone()).collect();
        if ashore(&plan, mission) || !plan.clear {
            self.refused.clone_from(&other_ids);
            return Change::Refused {
                others: other_ids,
                closest,
            };
        }
        let g = usize::from(!mine_first);
        let i = ids[g]
            .iter()
            .position(|id| id == me)
            .expect("this vessel is in its group");
        let speed = plan.speed;
        let lead = if speed > 0.0 {
            let lag = mission.guidance().lag(speed);
            if lag.is_finite() { lag / speed } else { 0.0 }
        } else {
            0.0
        };
        let (duration, water) = (plan.duration, plan.water);
        self.active = Some(Active {
            revision,
            ids,
            me: (g, i),
            plan,
            origin: t - (first - ageing.stale_after - TOGETHER),
            lead,
        });
        Change::Started {
            others: other_ids,
            closest,
            duration,
            water,
        }
    }
}

/// A neighbour as the vessel its last beacon shows, with its id.
fn as_vessel(n: &Neighbour) -> (String, Vessel) {
    let vessel = Vessel {
        position: Point {
            x: n.beacon.x,
            y: n.beacon.y,
        },
        k: n.beacon.k,
        beta: n.beacon.beta,
    };
    (n.beacon.id.clone(), vessel)
}

/// Whether a way of `plan` crosses an island or passes nearer the shore
/// than the filter lets a hull go: the hull would leave it, so the plan is
/// refused.
fn ashore(plan: &SplitPlan, mission: &Mission) -> bool {
    let barrier = mission.safety().barrier();
    let shore = mission.layer().shore();
    (0..2).any(|g| {
        plan.start[g]
            .iter()
            .zip(&plan.end[g])
            .any(|(a, b)| !shore.segment_clear(*a, *b, barrier.shore_distance))
    })
}

/// Why an active plan ends on this tick, if it does.
fn ended(active: &Active, revision: u32, neighbours: &[Neighbour]) -> Option<&'static str> {
    if revision != active.revision {
        return Some("a new mission revision");
    }
    let (g, _) = active.me;
    let find = |id: &String| neighbours.iter().find(|n| &n.beacon.id == id);
    if active.ids[1 - g]
        .iter()
        .any(|id| find(id).is_some_and(|n| n.silent.is_none()))
    {
        return Some("the other group is heard again");
    }
    if active.ids[g]
        .iter()
        .any(|id| find(id).is_some_and(|n| n.silent.is_some()))
    {
        return Some("a vessel of its own group fell silent");
    }
    None
}

fn orders(active: &Active, t: f64) -> Orders {
    let tau = t - active.origin;
    let (g, i) = active.me;
    let plan = &active.plan;
    let o = 1 - g;
    let others = active.ids[o]
        .iter()
        .enumerate()
        .map(|(j, id)| {
            let p = plan.at(o, j, tau);
            let w = plan.velocity(o, j, tau);
            let speed = norm2(w).sqrt();
            let psi = if speed > 0.0 { w.y.atan2(w.x) } else { 0.0 };
            let state = State {
                x: p.x,
                y: p.y,
                psi,
                vel: Vec3::new(speed, 0.0, 0.0),
            };
            (id.clone(), state)
        })
        .collect();
    Orders {
        target: plan.at(g, i, tau + active.lead),
        others,
        radius: SLACK,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agent::peer::table::Silent;
    use crate::protocol::peer::BeaconDocument;

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
            beacon: BeaconDocument {
                id: format!("usv-{i}"),
                seq: 0,
                t: 0.0,
                x,
                y,
                psi: 0.0,
                u: 0.0,
                v: 0.0,
                r: 0.0,
                k: 0.5,
                beta: 0.001,
                rev: 0,
                controlled: true,
            },
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
            let (orders, change) =
                split.update(&tick(&mission, &ageing, &id, &at, &neighbours, 10.0));
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
        let (orders, change) =
            split.update(&tick(&mission, &ageing, "usv-1", &at, &neighbours, 10.0));
        assert_eq!(orders, None);
        // Refused for the island: the ways keep clear of each other.
        let Change::Refused { closest, .. } = change else {
            panic!("{change:?}");
        };
        assert!(closest >= 9.0 - 1e-6, "{closest}");
        // The same silence on the next tick: not planned for again.
        let (orders, change) =
            split.update(&tick(&mission, &ageing, "usv-1", &at, &neighbours, 10.1));
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
}
