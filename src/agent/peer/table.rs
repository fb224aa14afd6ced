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
//! by the clamp. Ordering uses `t` only between beacons of one sender,
//! whose clock is one clock.
//!
//! ## Who is in the partition, and who is still an obstacle
//! - **fresh** (age ≤ `stale_after`, 3 s by default): in the partition,
//!   at its position extrapolated along its ground velocity by its age;
//! - **silent** (older, up to `forget_after`, at least 60 s): no longer in
//!   the partition (the others take its water), but still an obstacle for
//!   the safety filter, at its last position with a radius that grows
//!   with the silence ([`Silent::radius`]), and not trusted to keep its
//!   half of any gap;
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

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use super::index::{Index, Key};
use super::wire::{self, Refusal};
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
}

impl Default for Ageing {
    fn default() -> Self {
        Ageing {
            stale_after: 3.0,
            forget_after: 60.0,
            warp: 1.0,
            drift: 0.2,
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
}

/// A silent neighbour's uncertainty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Silent {
    /// How far from its last position it may be [m]: its last ground speed
    /// plus the drift, times the silence.
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
    received: u64,
}

impl Table {
    pub fn new(fleet: &str, own: impl IntoIterator<Item = String>) -> Table {
        Table {
            fleet: fleet.to_string(),
            own: own.into_iter().collect(),
            ..Table::default()
        }
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

    pub fn refused(&self) -> BTreeMap<String, u64> {
        self.refused
            .iter()
            .map(|(r, n)| (r.name().to_string(), *n))
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
        });
        Some(rev)
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
        }
    } else {
        Neighbour {
            age,
            beacon: b.clone(),
            silent: Some(Silent {
                radius: (vx.hypot(vy) + ageing.drift) * age,
            }),
        }
    }
}

/// Whether a beacon that arrived at `arrived` can be older than `limit` at
/// `now` (its transit counts for at most [`MAX_TRANSIT`]).
fn may_be_older(arrived: Instant, now: Instant, ageing: &Ageing, limit: f64) -> bool {
    (now.saturating_duration_since(arrived).as_secs_f64() + MAX_TRANSIT) * ageing.warp > limit
}

/// A beacon's age in mission seconds (see the module doc).
fn age(h: &Heard, now: Instant, ageing: &Ageing) -> f64 {
    (now.saturating_duration_since(h.arrived).as_secs_f64() + h.transit) * ageing.warp
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// A beacon of the paper's actuator at (x, y), heading `psi`, at `u`
    /// m/s.
    fn doc(id: &str, t: f64, (x, y): (f64, f64), psi: f64, u: f64) -> BeaconDocument {
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
        // Silent for 10 s its radius (1.2 m/s × 10 s = 12 m) counts too:
        // 200 ≤ 190 + 12.
        let near = ids(table.neighbours_near("me", (0.0, 0.0), |_, _| 190.0, at(10), &ageing));
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

    #[test]
    fn fresh_then_silent_then_forgotten() {
        let ageing = Ageing::default();
        let mut table = Table::new("bay", ["me".to_string()]);
        let t0 = Instant::now();
        let utc = 1.8e9;
        table.offer(
            "seacover/bay/beacon/a",
            &beacon("a", utc, 10.0),
            false,
            t0,
            utc,
            &ageing,
        );
        let n = table.neighbours("me", t0 + Duration::from_secs(1), &ageing);
        assert_eq!(n.len(), 1);
        assert!(n[0].silent.is_none());
        assert!(
            (n[0].beacon.x - 11.0).abs() < 1e-3,
            "extrapolated: {}",
            n[0].beacon.x
        );
        let n = table.neighbours("me", t0 + Duration::from_secs(10), &ageing);
        let radius = n[0].silent.unwrap().radius;
        assert!((radius - 12.0).abs() < 1e-3, "{radius}");
        assert_eq!(n[0].beacon.x, 10.0);
        assert!(
            table
                .neighbours("me", t0 + Duration::from_secs(61), &ageing)
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
    }

    #[test]
    fn refusals_are_counted_and_change_nothing() {
        let ageing = Ageing::default();
        let mut table = Table::new("bay", ["me".to_string()]);
        let t0 = Instant::now();
        let utc = 1.8e9;
        table.offer(
            "seacover/bay/beacon/a",
            &beacon("a", utc, 0.0),
            false,
            t0,
            utc,
            &ageing,
        );
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
}
