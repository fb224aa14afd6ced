//! The peer wire's encoding and its value rules: beacons as compact CBOR
//! maps, mission documents as JSON, and every reason an input is refused.
//!
//! Invariants:
//! - [`encode`] gives at most [`MAX_BEACON`] bytes for an id of up to
//!   [`MAX_ID`] characters and a revision below 256, or 6 characters and
//!   below 65 536 (the tests check the worst cases): floats go out in the
//!   shortest CBOR float that keeps the precision each field documents
//!   (`protocol::peer::BeaconDocument`), and `seq` counts modulo 256;
//! - [`decode`] accepts only what [`encode`] could have made of a real
//!   vessel: a map with exactly the beacon's keys, finite values, a
//!   position within [`MAX_POSITION`] of the origin, speeds up to
//!   [`MAX_SPEED`], an actuator the engine accepts, an id that is valid and
//!   the key's own; anything else is a [`Refusal`], which the node counts.

use crate::control::model::State;
use crate::coverage::fleet::{MAX_BETA, MAX_K};
use crate::protocol::peer::{BeaconDocument, PeerMissionDocument};

/// The largest beacon payload accepted (and the most [`encode`] makes for
/// the ids the fleet names its vessels by).
pub const MAX_BEACON: usize = 96;
/// The longest id of a peer fleet's vessel (the beacon's size bound).
pub const MAX_ID: usize = 7;

/// Seconds since 1970 by this machine's (disciplined) clock.
pub fn utc_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Whether `id` can name a vessel of a peer fleet.
pub fn valid_peer_id(id: &str) -> bool {
    id.len() <= MAX_ID && crate::mission::scenario::valid_id(id)
}

/// The largest mission document accepted [bytes].
pub const MAX_MISSION: usize = 1 << 20;
/// No vessel of a mission is farther than this from its origin [m].
pub const MAX_POSITION: f64 = 50_000.0;
/// No surface vessel of ours is faster [m/s].
pub const MAX_SPEED: f64 = 20.0;
/// No hull turns faster [rad/s].
pub const MAX_YAW_RATE: f64 = 10.0;

/// Why an input was refused; [`Refusal::name`] is the counter's label.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Refusal {
    Undecodable,
    Oversized,
    OutOfRange,
    IdConflict,
    OtherFleet,
    MissionInvalid,
    MissionOlder,
}

impl Refusal {
    pub fn name(self) -> &'static str {
        match self {
            Refusal::Undecodable => "undecodable",
            Refusal::Oversized => "oversized",
            Refusal::OutOfRange => "out_of_range",
            Refusal::IdConflict => "id_conflict",
            Refusal::OtherFleet => "other_fleet",
            Refusal::MissionInvalid => "mission_invalid",
            Refusal::MissionOlder => "mission_older",
        }
    }
}

/// The key expressions of one fleet.
#[derive(Debug, Clone)]
pub struct Keys {
    pub fleet: String,
}

impl Keys {
    pub fn beacon(&self, id: &str) -> String {
        format!("seacover/{}/beacon/{id}", self.fleet)
    }
    /// The fleet's own beacons. Subscribed to apart from every fleet's:
    /// a link then names a beacon by the fleet's declared prefix and the
    /// id alone (`/usv-1`), not by its whole key, ~20 bytes of a ~120-byte
    /// frame (docs/peer.md, "Radio budgets").
    pub fn beacons(&self) -> String {
        format!("seacover/{}/beacon/*", self.fleet)
    }
    /// Every fleet's beacons: a node hears them all so that it can count
    /// (and ignore) another fleet's.
    pub fn all_beacons() -> &'static str {
        "seacover/*/beacon/*"
    }
    pub fn alive(&self, id: &str) -> String {
        format!("seacover/{}/alive/{id}", self.fleet)
    }
    pub fn alive_all(&self) -> String {
        format!("seacover/{}/alive/*", self.fleet)
    }
    pub fn mission(&self) -> String {
        format!("seacover/{}/mission", self.fleet)
    }
    pub fn status(&self, id: &str) -> String {
        format!("seacover/{}/status/{id}", self.fleet)
    }
    pub fn status_all(&self) -> String {
        format!("seacover/{}/status/*", self.fleet)
    }
    /// Vessel `id`'s samples as it takes them.
    pub fn sample(&self, id: &str) -> String {
        format!("seacover/{}/sample/{id}", self.fleet)
    }
    pub fn sample_all(&self) -> String {
        format!("seacover/{}/sample/*", self.fleet)
    }
    /// The queryable of vessel `id`'s samples (`?from=N`), answered by any
    /// member that holds them.
    pub fn samples(&self, id: &str) -> String {
        format!("seacover/{}/samples/{id}", self.fleet)
    }
    pub fn samples_all(&self) -> String {
        format!("seacover/{}/samples/*", self.fleet)
    }
    /// The fleet and the id of a beacon key, if it is one.
    pub fn parse_beacon(key: &str) -> Option<(&str, &str)> {
        let rest = key.strip_prefix("seacover/")?;
        let (fleet, rest) = rest.split_once('/')?;
        let id = rest.strip_prefix("beacon/")?;
        (!id.contains('/')).then_some((fleet, id))
    }
}

/// Whether `name` can be a fleet's name: one key segment of Zenoh
/// (`[A-Za-z0-9_.-]{1,64}`, as ids).
pub fn valid_fleet(name: &str) -> bool {
    crate::mission::scenario::valid_id(name)
}

/// `v` at 16 bits when that keeps it within `rel` (or within `abs`),
/// else at 32, else as it is: CBOR encoders send a float in the shortest
/// form that holds it exactly, so rounding first is what makes it short.
fn compact(v: f64, rel: f64, abs: f64) -> f64 {
    let h = half::f16::from_f64(v).to_f64();
    let tolerance = (rel * v.abs()).max(abs);
    if h.is_finite() && (h - v).abs() <= tolerance {
        return h;
    }
    let s = v as f32 as f64;
    if s.is_finite() && (s - v).abs() <= tolerance.max(1e-6 * v.abs()) {
        s
    } else {
        v
    }
}

/// What a beacon carries beside its hull's state: who sends it, its
/// number, its sender's time, its actuator `(k, β)`, the mission revision
/// and whether the vessel is under control.
pub struct Said<'a> {
    pub id: &'a str,
    pub seq: u8,
    /// The sender's UTC time [s].
    pub t: f64,
    pub actuator: (f64, f64),
    pub rev: u32,
    pub controlled: bool,
}

/// The beacon of a hull in state `s`: its position, heading and
/// body-frame velocities (u, v, r), with what `said` adds.
pub fn beacon_of(s: &State, said: Said<'_>) -> BeaconDocument {
    BeaconDocument {
        id: said.id.to_string(),
        seq: said.seq,
        t: said.t,
        x: s.x,
        y: s.y,
        psi: s.psi,
        u: s.vel.x,
        v: s.vel.y,
        r: s.vel.z,
        k: said.actuator.0,
        beta: said.actuator.1,
        rev: said.rev,
        controlled: said.controlled,
    }
}

/// The beacon as it goes on the wire: each float rounded to its field's
/// precision (see `BeaconDocument`).
pub fn quantize(b: &BeaconDocument) -> BeaconDocument {
    BeaconDocument {
        id: b.id.clone(),
        seq: b.seq,
        t: b.t,
        x: b.x as f32 as f64,
        y: b.y as f32 as f64,
        psi: compact(b.psi, 0.0, 2e-3),
        u: compact(b.u, 1e-3, 1e-3),
        v: compact(b.v, 1e-3, 1e-3),
        r: compact(b.r, 1e-3, 1e-4),
        k: compact(b.k, 1e-3, 0.0),
        beta: compact(b.beta, 1e-3, 0.0),
        rev: b.rev,
        controlled: b.controlled,
    }
}

/// The actuator every member puts in its beacons and uses in its own
/// partition: what the wire can carry, so that a vessel and its neighbours
/// compute with the same numbers.
pub fn wire_actuator(k: f64, beta: f64) -> (f64, f64) {
    (compact(k, 1e-3, 0.0), compact(beta, 1e-3, 0.0))
}

/// The beacon's CBOR bytes ([`quantize`]d).
pub fn encode(b: &BeaconDocument) -> Vec<u8> {
    let mut out = Vec::with_capacity(MAX_BEACON);
    ciborium::into_writer(&quantize(b), &mut out).expect("a beacon always encodes");
    out
}

/// A beacon received on `key_id`'s key, checked (see the module doc).
pub fn decode(bytes: &[u8], key_id: &str) -> Result<BeaconDocument, Refusal> {
    if bytes.len() > MAX_BEACON {
        return Err(Refusal::Oversized);
    }
    let b: BeaconDocument = ciborium::from_reader(bytes).map_err(|_| Refusal::Undecodable)?;
    if b.id != key_id || !crate::mission::scenario::valid_id(&b.id) {
        return Err(Refusal::Undecodable);
    }
    let finite = [b.t, b.x, b.y, b.psi, b.u, b.v, b.r, b.k, b.beta]
        .iter()
        .all(|v| v.is_finite());
    let in_range = finite
        && b.t > 0.0
        && b.x.hypot(b.y) <= MAX_POSITION
        && b.u.hypot(b.v) <= MAX_SPEED
        && b.r.abs() <= MAX_YAW_RATE
        && b.k > 0.0
        && b.k <= MAX_K
        && b.beta > 0.0
        && b.beta <= MAX_BETA;
    if !in_range {
        return Err(Refusal::OutOfRange);
    }
    Ok(b)
}

/// A mission document received on the mission key: its shape (validation
/// of its content is the mission layer's, `Mission::from_document`).
/// `what` on this host: who made a mission revision
/// ([`PeerMissionDocument::by`]).
pub fn author(what: &str) -> String {
    let mut name = [0u8; 256];
    // SAFETY: the buffer is writable for its whole length, which is passed.
    let ok = unsafe { libc::gethostname(name.as_mut_ptr().cast(), name.len()) } == 0;
    let end = name.iter().position(|&b| b == 0).unwrap_or(name.len());
    match std::str::from_utf8(&name[..end]) {
        Ok(host) if ok && !host.is_empty() => format!("{what} on {host}"),
        _ => what.to_string(),
    }
}

/// The UTC time now, RFC 3339, for [`PeerMissionDocument::at`].
pub fn now_utc() -> String {
    time::OffsetDateTime::now_utc()
        .format(&time::format_description::well_known::Rfc3339)
        .unwrap_or_default()
}

pub fn decode_mission(bytes: &[u8]) -> Result<PeerMissionDocument, Refusal> {
    if bytes.len() > MAX_MISSION {
        return Err(Refusal::Oversized);
    }
    serde_json::from_slice(bytes).map_err(|_| Refusal::MissionInvalid)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn worst(id: &str) -> BeaconDocument {
        // Values that need the widest floats each field allows.
        BeaconDocument {
            id: id.into(),
            seq: 255,
            t: 1_795_000_000.123_456,
            x: -39_999.123_456_7,
            y: 29_999.926_535,
            psi: -3.091_592_653,
            u: 17.987_654,
            v: -7.654_321,
            r: 0.987_654_3,
            k: 123_456.789,
            beta: 0.000_123_456_7,
            rev: u32::MAX,
            controlled: true,
        }
    }

    #[test]
    fn a_beacon_fits_96_bytes_for_ids_of_up_to_7_characters() {
        let mut paper = worst("mav-255");
        paper.k = 0.5;
        paper.beta = 0.001;
        paper.rev = 255;
        let bytes = encode(&paper);
        assert!(bytes.len() <= MAX_BEACON, "{} bytes", bytes.len());
        // Revisions up to 65535 fit with a 6-character id.
        let mut any = worst("usv-99");
        any.k = 0.5;
        any.beta = 0.001;
        any.rev = 65_535;
        assert!(
            encode(&any).len() <= MAX_BEACON,
            "{} bytes",
            encode(&any).len()
        );
    }

    #[test]
    fn a_beacon_comes_back_within_the_documented_precision() {
        let b = BeaconDocument {
            k: 123.456,
            rev: 7,
            ..worst("usv-1")
        };
        let bytes = encode(&b);
        let back =
            decode(&bytes, "usv-1").unwrap_or_else(|e| panic!("{e:?}, {} bytes", bytes.len()));
        assert_eq!(back.t, b.t);
        assert!((back.x - b.x).abs() < 4e-3 && (back.y - b.y).abs() < 4e-3);
        assert!((back.psi - b.psi).abs() <= 2e-3);
        assert!((back.u - b.u).abs() <= 1e-3 * 20.0);
        assert!((back.k - b.k).abs() <= 1e-3 * b.k);
        assert!((back.beta - b.beta).abs() <= 1e-3 * b.beta);
        assert_eq!(
            (back.seq, back.rev, back.controlled),
            (b.seq, b.rev, b.controlled)
        );
    }

    #[test]
    fn bad_beacons_are_refused_with_their_reason() {
        let good = BeaconDocument {
            rev: 7,
            k: 0.5,
            ..worst("usv-1")
        };
        assert_eq!(decode(&[0xff; 97], "usv-1"), Err(Refusal::Oversized));
        assert_eq!(decode(b"\x01\x02", "usv-1"), Err(Refusal::Undecodable));
        assert_eq!(decode(&encode(&good), "usv-2"), Err(Refusal::Undecodable));
        for bad in [
            BeaconDocument {
                x: 60_000.0,
                ..good.clone()
            },
            BeaconDocument {
                u: 25.0,
                ..good.clone()
            },
            BeaconDocument {
                y: f64::NAN,
                ..good.clone()
            },
            BeaconDocument {
                beta: -1.0,
                ..good.clone()
            },
        ] {
            assert_eq!(
                decode(&encode(&bad), "usv-1"),
                Err(Refusal::OutOfRange),
                "{bad:?}"
            );
        }
        // A map with a key more is not a beacon.
        let mut extra = Vec::new();
        let mut value = ciborium::Value::serialized(&good).unwrap();
        if let ciborium::Value::Map(m) = &mut value {
            m.push(("extra".into(), 1.into()));
        }
        ciborium::into_writer(&value, &mut extra).unwrap();
        assert_eq!(
            decode(&extra, "usv-1").unwrap_err(),
            if extra.len() > MAX_BEACON {
                Refusal::Oversized
            } else {
                Refusal::Undecodable
            }
        );
    }

    #[test]
    fn beacon_keys_parse() {
        assert_eq!(
            Keys::parse_beacon("seacover/bay/beacon/usv-1"),
            Some(("bay", "usv-1"))
        );
        assert_eq!(Keys::parse_beacon("seacover/bay/alive/usv-1"), None);
    }
}
