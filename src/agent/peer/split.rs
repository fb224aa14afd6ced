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
//! ## Off the tick
//! For a large group the plan takes longer than a tick (docs/performance.md,
//! "The split plan"), so a vessel's loop computes it elsewhere: [`Split::look`]
//! hands out a [`Job`] with owned copies of its inputs, taken when the split
//! is seen, and [`Split::accept`] takes its [`Planned`] result on a later
//! tick. The inputs do not depend on when the result comes, so both groups
//! still compute one plan, and its clock's origin is the silence's, so a
//! late result only finds the vessel behind its way (it steers to where the
//! plan has it by now). Until then no orders: the silent vessels are
//! obstacles where they fell silent, as without a plan. A result is dropped
//! when the situation it was computed for has passed (another silence, the
//! other group heard again, one of its own silent, a new revision). The
//! unit tests check it against the plan computed on the tick.
//!
//! Pure: the mission time comes in, nothing goes out but the plan's
//! orders; the caller decides where a [`Job`] runs.

use super::table::{Ageing, Neighbour};
use crate::control::Vec3;
use crate::control::model::State;
use crate::coverage::split::{SplitParams, SplitPlan, Water, plan};
use crate::coverage::{RiskField, Vessel};
use crate::geometry::{Point, Region, norm2};
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
    key: Key,
    plan: SplitPlan,
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
    /// A plan being computed off the tick for `others` (the situation
    /// passed: `why`) will not be followed.
    Dropped {
        others: Vec<String>,
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
            Change::Dropped { others, why } => tracing::info!(
                vessel = %id, t, ?others, why,
                "fleet split: the plan being computed is dropped"
            ),
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

/// One vessel's split: none, the plan it follows, or the one being
/// computed for it.
#[derive(Debug, Default)]
pub struct Split {
    active: Option<Active>,
    /// The plan handed out as a [`Job`] and not yet accepted.
    pending: Option<Key>,
    /// Jobs handed out so far: a result is taken only for the last.
    serial: u64,
    /// The other group of the last plan not followed: the same silence is
    /// not planned for again on every tick of its window.
    refused: Vec<String>,
}

/// What a plan is for: the situation it was computed in.
#[derive(Debug, Clone, PartialEq)]
struct Key {
    serial: u64,
    revision: u32,
    /// Both groups' ids in the plan's order.
    ids: [Vec<String>; 2],
    /// This vessel's group and place in it.
    me: (usize, usize),
    /// Mission time of τ = 0.
    origin: f64,
}

impl Key {
    fn others(&self) -> &[String] {
        &self.ids[1 - self.me.0]
    }
}

/// A plan to compute, with owned copies of everything it needs: it can be
/// moved to another thread and computed there ([`Job::compute`]).
#[derive(Debug)]
pub struct Job {
    key: Key,
    region: Region,
    risk: RiskField,
    groups: [Vec<Vessel>; 2],
    params: SplitParams,
}

impl Job {
    /// The plan (blocking: for a large group, longer than a tick).
    pub fn compute(self) -> Planned {
        let plan = plan(
            &self.region,
            &self.risk,
            [&self.groups[0], &self.groups[1]],
            &self.params,
        );
        Planned {
            key: self.key,
            plan,
        }
    }
}

/// A [`Job`]'s result, for [`Split::accept`].
#[derive(Debug)]
pub struct Planned {
    key: Key,
    plan: Option<SplitPlan>,
}

impl Split {
    /// The other group's ids while a plan is followed.
    pub fn others(&self) -> Option<Vec<String>> {
        self.active.as_ref().map(|a| a.key.others().to_vec())
    }

    /// What this vessel's group covers while a plan is followed.
    pub fn water(&self) -> Option<Water> {
        self.active.as_ref().map(|a| a.plan.water)
    }

    /// [`look`](Self::look) and [`accept`](Self::accept) in one, any plan
    /// computed on the tick: what the off-tick path is checked against.
    #[cfg(test)]
    fn update(&mut self, tick: &Tick<'_>) -> (Option<Orders>, Change) {
        let (orders, change, job) = self.look(tick);
        match job {
            Some(job) => {
                let change = self.accept(job.compute(), tick);
                (self.orders(tick.t), change)
            }
            None => (orders, change),
        }
    }

    /// Looks at this tick: starts, keeps or ends a plan, and gives the
    /// tick's orders while one is followed. A plan to start is handed out
    /// as a [`Job`] to compute elsewhere and followed once its result is
    /// [`accept`](Self::accept)ed; meanwhile there are no orders.
    pub fn look(&mut self, tick: &Tick<'_>) -> (Option<Orders>, Change, Option<Job>) {
        if let Some(active) = &self.active {
            if let Some(why) = ended(&active.key, tick.revision, tick.neighbours) {
                self.active = None;
                return (None, Change::Ended { why }, None);
            }
            return (self.orders(tick.t), Change::None, None);
        }
        if let Some(key) = &self.pending
            && let Some(why) = ended(key, tick.revision, tick.neighbours)
        {
            let others = key.others().to_vec();
            self.pending = None;
            return (None, Change::Dropped { others, why }, None);
        }
        (None, Change::None, self.start(tick))
    }

    /// Takes a [`Job`]'s result on this tick: follows it, refuses it, or
    /// drops it when it is not the last job handed out or its situation
    /// has passed.
    pub fn accept(&mut self, planned: Planned, tick: &Tick<'_>) -> Change {
        let Planned { key, plan } = planned;
        if self.pending.as_ref() != Some(&key) {
            return Change::None;
        }
        self.pending = None;
        let others = key.others().to_vec();
        if let Some(why) = ended(&key, tick.revision, tick.neighbours) {
            return Change::Dropped { others, why };
        }
        let Some(plan) = plan else {
            return Change::None;
        };
        let closest = plan.closest();
        if ashore(&plan, tick.mission) || !plan.clear {
            self.refused.clone_from(&others);
            return Change::Refused { others, closest };
        }
        let speed = plan.speed;
        let lead = if speed > 0.0 {
            let lag = tick.mission.guidance().lag(speed);
            if lag.is_finite() { lag / speed } else { 0.0 }
        } else {
            0.0
        };
        let (duration, water) = (plan.duration, plan.water);
        self.active = Some(Active { key, plan, lead });
        Change::Started {
            others,
            closest,
            duration,
            water,
        }
    }

    fn orders(&self, t: f64) -> Option<Orders> {
        self.active.as_ref().map(|a| orders(a, t))
    }

    /// The job for a split that starts on this tick, if one does.
    fn start(&mut self, tick: &Tick<'_>) -> Option<Job> {
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
            return None;
        }
        let others: Vec<&Neighbour> = neighbours
            .iter()
            .filter(|n| n.silent.is_some() && first - n.age <= TOGETHER)
            .collect();
        let fresh: Vec<&Neighbour> = neighbours.iter().filter(|n| n.in_partition()).collect();
        if others.len() < 2 || fresh.is_empty() {
            return None;
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
        let same = |ids: &[String]| theirs.iter().map(|(id, _)| id).eq(ids.iter());
        // Refused, or being computed: not again for the same silence.
        if same(&self.refused) || self.pending.as_ref().is_some_and(|k| same(k.others())) {
            return None;
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
        let g = usize::from(!mine_first);
        let i = ids[g]
            .iter()
            .position(|id| id == me)
            .expect("this vessel is in its group");
        self.serial += 1;
        let key = Key {
            serial: self.serial,
            revision,
            ids,
            me: (g, i),
            origin: t - (first - ageing.stale_after - TOGETHER),
        };
        self.pending = Some(key.clone());
        Some(Job {
            key,
            region: mission.region().clone(),
            risk: mission.risk().clone(),
            groups,
            params: params(mission, ageing),
        })
    }
}

/// The plan's parameters for `mission` under `ageing`: what every vessel
/// plans with, so that both groups compute alike.
pub fn params(mission: &Mission, ageing: &Ageing) -> SplitParams {
    let safety = mission.safety().barrier().safety_distance;
    // Until the silent group is forgotten, every way keeps clear of where
    // it fell silent as the filter will (the safety distance and the drift
    // allowance, with the slack): they may be wrecks.
    SplitParams {
        starts_kept: Some((safety + ageing.allowance + SLACK, ageing.forget_after)),
        ..SplitParams::both(safety + 2.0 * SLACK, SPEED)
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

/// Why a plan, followed or being computed, ends on this tick, if it does.
fn ended(key: &Key, revision: u32, neighbours: &[Neighbour]) -> Option<&'static str> {
    if revision != key.revision {
        return Some("a new mission revision");
    }
    let (g, _) = key.me;
    let find = |id: &String| neighbours.iter().find(|n| &n.beacon.id == id);
    if key.ids[1 - g]
        .iter()
        .any(|id| find(id).is_some_and(|n| n.silent.is_none()))
    {
        return Some("the other group is heard again");
    }
    if key.ids[g]
        .iter()
        .any(|id| find(id).is_some_and(|n| n.silent.is_some()))
    {
        return Some("a vessel of its own group fell silent");
    }
    None
}

fn orders(active: &Active, t: f64) -> Orders {
    let tau = t - active.key.origin;
    let (g, i) = active.key.me;
    let plan = &active.plan;
    let o = 1 - g;
    let others = active.key.ids[o]
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
mod tests;
