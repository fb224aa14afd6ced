//! What one peer process knows of the others: the newest beacon of every
//! vessel it hears, how old it is, and every input it refused.
//!
//! ## Ages, and clocks that differ
//! A beacon carries its sender's UTC time `t`. Boats' clocks are GPS- or
//! NTP-disciplined, so they agree to milliseconds, not exactly: a
//! receiver never trusts `t` for more than the transit. A beacon's age is
//! the receiver's own monotonic time since it arrived plus its transit,
//! `now_utc − t` at arrival clamped into [0, [`MAX_TRANSIT`]]: a sender
//! whose clock runs ahead cannot make a beacon younger than its arrival,
//! and one whose clock lags (or a beacon stuck in a queue) ages it at most
//! by the clamp (under a time warp, by at most half of `stale_after`).
//! Ordering uses `t` only between beacons of one sender, whose clock is
//! one clock.
//!
//! ## Who is in the partition, and who is still an obstacle
//! - **fresh** (age ≤ `stale_after`, 3 s by default): in the partition,
//!   at its position extrapolated along its ground velocity by its age;
//! - **silent** (older, up to `forget_after`, 120 s by default): no longer
//!   in the partition (the others take its water), but still an obstacle
//!   for the safety filter, at its last position with a radius that grows
//!   with the silence up to the drift allowance ([`Silent::radius`]), and
//!   not trusted to keep its half of any gap. A boat that falls silent is
//!   a wreck, or alive and holding station (a vessel that hears no other
//!   holds, and a group cut off follows the split's plan): either way it
//!   does not go far, so the allowance is bounded;
//! - forgotten after that.
//!
//! ## What a tick costs
//! The table is indexed by place and by arrival ([`super::index`]): a
//! tick looks at the beacons filed near the vessel (within the widest
//! reach of an actuator heard, plus how far a fresh beacon can have been
//! extrapolated) and at the prefix of the arrival order that can be silent
//! or forgotten, so its cost follows the density and the silences, not
//! the size of the fleet.
//!
//! ## Refusals
//! Undecodable, oversized and out-of-range beacons, another fleet's
//! beacons, and a second node claiming an id (a beacon whose id is one of
//! this process's own vessels, or whose motion since the id's previous
//! beacon is faster than [`wire::MAX_SPEED`](super::wire::MAX_SPEED)) are
//! dropped and counted by reason.
//!
//! ## Implausible neighbours
//! Every other beacon is judged by the rules the coordinator judges poses
//! by ([`plausibility`](crate::control::plausibility), with the
//! coordinator's limits, the mission's region once one is held, and the
//! sender's clock scaled by the time warp): a neighbour whose beacons fail
//! them (farther outside the region than the margin, faster than a hull
//! goes, its clock going back) is **quarantined**: kept, at its newest
//! beacon, as traffic the safety filter keeps clear of without trusting it
//! to keep its half of a gap, but never a neighbour of the partition,
//! until its beacons agree again as long as the judge asks. Each failure
//! is counted by the judge's reason, beside the refusals.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use super::index::{Index, Key};
use super::wire::{self, Refusal};
use crate::control::plausibility::{Fault, Fix, Judge, Limits, Sample, Verdict};
use crate::geometry::region::Region;
use crate::protocol::peer::BeaconDocument;

/// The most a beacon's transit counts for in its age [s].
pub const MAX_TRANSIT: f64 = 0.5;

/// How a node judges its neighbours' beacons.
#[derive(Debug, Clone, Copy)]
pub struct Ageing {
    /// A neighbour silent longer leaves the partition [s of mission time].
    pub stale_after: f64,
    /// A silent neighbour is an obstacle this long [s of mission time].
    pub forget_after: f64,
    /// Mission seconds per wall second (the time warp).
    pub warp: f64,
    /// Speed a silent hull is assumed able to drift at, on top of its last
    /// ground speed [m/s].
    pub drift: f64,
    /// The most a silent hull is assumed to have moved from its last
    /// position [m]: a dead hull coasts to a stop within a few metres and
    /// then drifts with the current (5 m is 25 s at 0.2 m/s); a live one
    /// holds station (docs/peer.md, "What each loss does").
    pub allowance: f64,
}

impl Default for Ageing {
    fn default() -> Self {
        Ageing {
            stale_after: 3.0,
            forget_after: 120.0,
            warp: 1.0,
            drift: 0.2,
            allowance: 5.0,
        }
    }
}

#[derive(Debug, Clone)]
struct Heard {
    /// Its newest beacon; `beacon.id` is its id.
    beacon: BeaconDocument,
    arrived: Instant,
    transit: f64,
    /// Where [`Index`] filed it.
    key: Key,
    /// Its beacons judged for plausibility (an own vessel's are not).
    judge: Judge,
}

/// An actuator as the wire carries it, as a map key: (k, β) bits.
type Actuator = (u64, u64);

fn actuator_of(b: &BeaconDocument) -> Actuator {
    (b.k.to_bits(), b.beta.to_bits())
}

/// A neighbour as the loop on board uses it.
#[derive(Debug, Clone, PartialEq)]
pub struct Neighbour {
    /// Age of its newest beacon [s of mission time].
    pub age: f64,
    /// Its beacon, position moved along its ground velocity by `age` when
    /// fresh.
    pub beacon: BeaconDocument,
    /// `None` when fresh; the obstacle's radius when silent.
    pub silent: Option<Silent>,
    /// Why its beacons are not believed, if they are not: traffic only.
    pub quarantined: Option<Fault>,
}

impl Neighbour {
    /// Whether it is a neighbour of the partition (fresh and believed).
    pub fn in_partition(&self) -> bool {
        self.silent.is_none() && self.quarantined.is_none()
    }
}

/// A silent neighbour's uncertainty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Silent {
    /// How far from its last position it may be [m]: its last ground speed
    /// plus the drift, times the silence, up to the allowance.
    pub radius: f64,
}

/// The beacons heard by one process, and its refusals.
#[derive(Debug, Default)]
pub struct Table {
    fleet: String,
    /// This process's own vessels: nobody else may use their ids.
    own: BTreeSet<String>,
    /// The slot of every vessel heard, in id order.
    ids: BTreeMap<String, usize>,
    /// Every vessel's newest beacon; `None` for a free slot.
    slots: Vec<Option<Heard>>,
    free: Vec<usize>,
    index: Index,
    /// How many vessels heard have each actuator (a query's reach is the
    /// widest of theirs).
    actuators: BTreeMap<Actuator, usize>,
    refused: BTreeMap<Refusal, u64>,
    /// Beacons judged implausible, by the judge's reason.
    implausible: BTreeMap<&'static str, u64>,
    received: u64,
    /// The mission's region, once one is held: how far outside it a
    /// neighbour may be is judged against it.
    region: Option<Region>,
}

impl Table {
    pub fn new(fleet: &str, own: impl IntoIterator<Item = String>) -> Table {
        Table {
            fleet: fleet.to_string(),
            own: own.into_iter().collect(),
            ..Table::default()
        }
    }

    /// The region beacons are judged against (the mission held).
    pub fn set_region(&mut self, region: Option<Region>) {
        self.region = region;
    }

    /// Claims `id` for one of this process's vessels.
    pub fn claim(&mut self, id: &str) {
        self.own.insert(id.to_string());
    }

    pub fn refuse(&mut self, why: Refusal) {
        *self.refused.entry(why).or_default() += 1;
    }

    fn refused_with(&mut self, why: Refusal) -> Option<u32> {
        self.refuse(why);
        None
    }

    /// Refused inputs and implausible beacons, by reason.
    pub fn refused(&self) -> BTreeMap<String, u64> {
        let implausible = self.implausible.iter().map(|(r, n)| (*r, *n));
        self.refused
            .iter()
            .map(|(r, n)| (r.name(), *n))
            .chain(implausible)
            .map(|(r, n)| (r.to_string(), n))
            .collect()
    }

    /// Every vessel heard whose beacons are not believed, and why.
    pub fn quarantined(&self) -> BTreeMap<String, String> {
        self.heard()
            .filter_map(|h| Some((h.beacon.id.clone(), h.judge.quarantined()?.to_string())))
            .collect()
    }

    pub fn received(&self) -> u64 {
        self.received
    }

    /// The highest mission revision a vessel heard now works on.
    pub fn newest_revision(&self) -> Option<u32> {
        self.heard().map(|h| h.beacon.rev).max()
    }

    fn heard(&self) -> impl Iterator<Item = &Heard> {
        self.slots.iter().flatten()
    }

    fn slot(&self, slot: usize) -> &Heard {
        self.slots[slot]
            .as_ref()
            .expect("an indexed slot holds a beacon")
    }

    /// Takes one sample from the beacon key `key`, received at `now` (and
    /// `now_utc`, s since 1970) from the network (`local` false), or from
    /// one of this process's own vessels.
    pub fn offer(
        &mut self,
        key: &str,
        payload: &[u8],
        local: bool,
        now: Instant,
        now_utc: f64,
        ageing: &Ageing,
    ) -> Option<u32> {
        self.received += 1;
        let Some((fleet, key_id)) = wire::Keys::parse_beacon(key) else {
            return self.refused_with(Refusal::Undecodable);
        };
        if fleet != self.fleet {
            return self.refused_with(Refusal::OtherFleet);
        }
        let beacon = match wire::decode(payload, key_id) {
            Ok(b) => b,
            Err(why) => return self.refused_with(why),
        };
        if self.own.contains(&beacon.id) && !local {
            return self.refused_with(Refusal::IdConflict);
        }
        let known = self.ids.get(&beacon.id).copied();
        if let Some(prev) = known.map(|slot| self.slot(slot)) {
            let fresh = age(prev, now, ageing) <= ageing.stale_after;
            let dt = beacon.t - prev.beacon.t;
            if fresh && dt <= 0.0 {
                // Late or repeated: the newer one is already here.
                return None;
            }
            let moved = (beacon.x - prev.beacon.x).hypot(beacon.y - prev.beacon.y);
            // Sender seconds are wall seconds: the hull covers warp × as much.
            if fresh && moved > wire::MAX_SPEED * dt * ageing.warp + 5.0 {
                return self.refused_with(Refusal::IdConflict);
            }
        }
        let transit = (now_utc - beacon.t).clamp(0.0, MAX_TRANSIT);
        let mut judge = known.map_or_else(Judge::new, |slot| self.slot(slot).judge.clone());
        if !local {
            self.judge(&mut judge, &beacon, ageing);
        }
        *self.actuators.entry(actuator_of(&beacon)).or_default() += 1;
        let (slot, old) = match known {
            Some(slot) => {
                let prev = self.slots[slot].take().expect("a known id has a slot");
                self.drop_actuator(&prev.beacon);
                (slot, Some(prev.key))
            }
            None => {
                let slot = self.free.pop().unwrap_or_else(|| {
                    self.slots.push(None);
                    self.slots.len() - 1
                });
                self.ids.insert(beacon.id.clone(), slot);
                (slot, None)
            }
        };
        let key = self.index.place(slot, old, (beacon.x, beacon.y), now);
        let rev = beacon.rev;
        self.slots[slot] = Some(Heard {
            beacon,
            arrived: now,
            transit,
            key,
            judge,
        });
        Some(rev)
    }

    /// Judges `beacon` with its sender's `judge`, counting a failure. The
    /// sender's seconds are wall seconds: the hull covers warp × as much.
    fn judge(&mut self, judge: &mut Judge, beacon: &BeaconDocument, ageing: &Ageing) {
        let b = beacon;
        let sample = Sample {
            t: b.t * ageing.warp,
            x: b.x,
            y: b.y,
            psi: b.psi,
            u: b.u,
            v: b.v,
            r: b.r,
        };
        // The coordinator's limits (docs/api.md): one judgement for both.
        let limits = Limits::default();
        let verdict = judge.judge(&sample, Fix::Unreported, &limits, self.region.as_ref());
        if let Verdict::Refused(fault) = verdict {
            *self.implausible.entry(fault.code()).or_default() += 1;
        }
    }

    fn drop_actuator(&mut self, b: &BeaconDocument) {
        let a = actuator_of(b);
        if let Some(n) = self.actuators.get_mut(&a) {
            *n -= 1;
            if *n == 0 {
                self.actuators.remove(&a);
            }
        }
    }

    /// Forgets every vessel silent longer than `forget_after`: a prefix of
    /// the arrival order.
    fn forget(&mut self, now: Instant, ageing: &Ageing) {
        let gone: Vec<usize> = self
            .index
            .oldest()
            .take_while(|&(arrived, _)| may_be_older(arrived, now, ageing, ageing.forget_after))
            .map(|(_, slot)| slot)
            .filter(|&slot| age(self.slot(slot), now, ageing) > ageing.forget_after)
            .collect();
        for slot in gone {
            let h = self.slots[slot]
                .take()
                .expect("an indexed slot holds a beacon");
            self.ids.remove(&h.beacon.id);
            self.index.remove(slot, h.key);
            self.drop_actuator(&h.beacon);
            self.free.push(slot);
        }
    }

    /// Everybody but `me` not yet forgotten, in id order (forgetting the
    /// rest).
    pub fn neighbours(&mut self, me: &str, now: Instant, ageing: &Ageing) -> Vec<Neighbour> {
        self.neighbours_near(me, (0.0, 0.0), |_, _| f64::INFINITY, now, ageing)
    }

    /// [`Table::neighbours`], only those that can matter to a vessel at
    /// `centre`: a neighbour whose beacon is farther than `radius(k, β)`
    /// (of its actuator) plus how far it can have gone since (extrapolated,
    /// or its silent radius) is not copied out. The fresh ones are looked
    /// for near `centre` only, the silent ones in the oldest arrivals only
    /// (see the module doc): what a node pays follows the density.
    pub fn neighbours_near(
        &mut self,
        me: &str,
        centre: (f64, f64),
        radius: impl Fn(f64, f64) -> f64,
        now: Instant,
        ageing: &Ageing,
    ) -> Vec<Neighbour> {
        self.forget(now, ageing);
        let mut out = Vec::new();
        let mut consider = |h: &Heard, age: f64| {
            if h.beacon.id == me {
                return;
            }
            let b = &h.beacon;
            let speed = b.u.hypot(b.v);
            let moved = if age <= ageing.stale_after {
                speed * age
            } else {
                (speed + ageing.drift) * age
            };
            let (dx, dy) = (b.x - centre.0, b.y - centre.1);
            let reach = radius(b.k, b.beta) + moved;
            if dx * dx + dy * dy <= reach * reach {
                out.push(neighbour(h, age, ageing));
            }
        };
        for (arrived, slot) in self.index.oldest() {
            if !may_be_older(arrived, now, ageing, ageing.stale_after) {
                break;
            }
            let h = self.slot(slot);
            let age = age(h, now, ageing);
            if age > ageing.stale_after {
                consider(h, age);
            }
        }
        // A fresh beacon counts from at most its actuator's radius plus
        // the top speed times stale_after away.
        let widest = self
            .actuators
            .keys()
            .map(|&(k, beta)| radius(f64::from_bits(k), f64::from_bits(beta)))
            .fold(0.0, f64::max);
        let bound = widest + wire::MAX_SPEED * ageing.stale_after;
        let mut fresh = |h: &Heard| {
            let age = age(h, now, ageing);
            if age <= ageing.stale_after {
                consider(h, age);
            }
        };
        match self.index.near(centre, bound, self.ids.len()) {
            Some(near) => near.for_each(|slot| fresh(self.slot(slot))),
            None => self.heard().for_each(fresh),
        }
        out.sort_unstable_by(|a, b| a.beacon.id.cmp(&b.beacon.id));
        out
    }

    /// How many vessels but `me` have a fresh beacon (within
    /// `stale_after`) that is believed: one that hears none is alone.
    pub fn others_heard(&self, me: &str, now: Instant, ageing: &Ageing) -> usize {
        self.ids
            .iter()
            .filter(|&(id, &slot)| {
                let h = self.slot(slot);
                id != me
                    && age(h, now, ageing) <= ageing.stale_after
                    && h.judge.quarantined().is_none()
            })
            .count()
    }

    /// Every vessel heard (own ones included) and its beacon's age [s of
    /// mission time].
    pub fn ages(&self, now: Instant, ageing: &Ageing) -> BTreeMap<String, f64> {
        self.ids
            .iter()
            .map(|(id, &slot)| (id.clone(), age(self.slot(slot), now, ageing)))
            .collect()
    }
}

/// `h` as the loop on board sees it at `age`: moved along its ground
/// velocity while fresh, at its last position with its uncertainty radius
/// once silent.
fn neighbour(h: &Heard, age: f64, ageing: &Ageing) -> Neighbour {
    let b = &h.beacon;
    let (s, c) = b.psi.sin_cos();
    let (vx, vy) = (b.u * c - b.v * s, b.u * s + b.v * c);
    if age <= ageing.stale_after {
        let mut beacon = b.clone();
        beacon.x += vx * age;
        beacon.y += vy * age;
        beacon.psi += b.r * age;
        Neighbour {
            age,
            beacon,
            silent: None,
            quarantined: h.judge.quarantined(),
        }
    } else {
        Neighbour {
            age,
            beacon: b.clone(),
            silent: Some(Silent {
                radius: ((vx.hypot(vy) + ageing.drift) * age).min(ageing.allowance),
            }),
            quarantined: h.judge.quarantined(),
        }
    }
}

/// Whether a beacon that arrived at `arrived` can be older than `limit` at
/// `now` (its transit counts for at most [`MAX_TRANSIT`]).
fn may_be_older(arrived: Instant, now: Instant, ageing: &Ageing, limit: f64) -> bool {
    (now.saturating_duration_since(arrived).as_secs_f64() + MAX_TRANSIT) * ageing.warp > limit
}

/// A beacon's age in mission seconds (see the module doc).
///
/// Under a time warp the transit's share is at most half of `stale_after`
/// of mission time: the clamp is a fraction of a second of wall time, and
/// at warp 10 a neighbour whose clock lags by that much would otherwise be
/// stale on arrival, which at warp 1 it is not.
fn age(h: &Heard, now: Instant, ageing: &Ageing) -> f64 {
    now.saturating_duration_since(h.arrived).as_secs_f64() * ageing.warp
        + (h.transit * ageing.warp).min(ageing.stale_after / 2.0)
}

#[cfg(test)]
pub(crate) mod tests;
