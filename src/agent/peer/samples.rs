//! The samples a peer member holds (docs/learning.md, "In a peer fleet"):
//! its own vessels' and every one it hears, numbered per source so that
//! what was missed is seen and asked for again.
//!
//! Invariants:
//! - two members that were offered the same samples hold the same set,
//!   whatever the order they came in (each sample is kept by its source
//!   and number; what is dropped to stay bounded is chosen from the set
//!   alone), so their learners fit the same belief;
//! - bounded: at most [`MAX_PER_SOURCE`] samples of one source (its
//!   newest numbers: a flooding source displaces only its own), at most
//!   [`MAX_HELD`] in all (beyond, the source holding most gives up its
//!   oldest), at most [`MAX_SOURCES`] sources;
//! - a sample that fails [`decode`] or a rule of [`Book::offer`] is
//!   refused with its [`Refusal`] and never learned from.

use std::collections::{BTreeMap, BTreeSet};

use super::wire::{MAX_POSITION, Refusal};
use crate::geometry::Point;
use crate::learning::Sample;
use crate::protocol::peer::PeerSampleDocument;

/// Samples of one source held at most (its newest numbers): over an hour
/// at 1 Hz.
pub const MAX_PER_SOURCE: usize = 4_000;
/// Samples held at most, from every source.
pub const MAX_HELD: usize = 20_000;
/// Sources held at most.
pub const MAX_SOURCES: usize = 512;
/// The most bytes one sample takes in a batch.
pub const MAX_SAMPLE: usize = 96;
/// The most samples one put carries: a vessel sends its samples in
/// batches, every [`super::learn::BATCH_EVERY`], which spends the radio's
/// headers once for several.
pub const MAX_BATCH: usize = 16;
/// The most samples one answer to a query carries.
pub const MAX_ANSWER: usize = 256;
/// A sample stamped later than this ahead of the receiver's clock is
/// refused: a sender's clock gone wrong [s].
const MAX_AHEAD: f64 = 5.0;
/// Numbers seen beyond a gap that is not filled: past this many, the gap
/// is given up (its samples are gone from every member that answers).
const MAX_AHEAD_OF_GAP: usize = 1_024;

/// One held sample.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Held {
    t: f64,
    sample: Sample,
}

/// What is known of one source.
#[derive(Debug, Default)]
struct Source {
    held: BTreeMap<u32, Held>,
    /// The lowest number never received.
    next: u32,
    /// Numbers received beyond `next`.
    beyond: BTreeSet<u32>,
}

impl Source {
    /// Marks `n` received; whether it filled or made a gap.
    fn receive(&mut self, n: u32) {
        if n < self.next {
            return;
        }
        self.beyond.insert(n);
        while self.beyond.remove(&self.next) {
            self.next = self.next.saturating_add(1);
        }
        if self.beyond.len() > MAX_AHEAD_OF_GAP
            && let Some(&first) = self.beyond.first()
        {
            // The gap's samples are lost to every member that answers:
            // go on from the numbers received.
            self.next = first;
            while self.beyond.remove(&self.next) {
                self.next = self.next.saturating_add(1);
            }
        }
    }
}

/// What became of an offered sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Offered {
    /// New, and held.
    New,
    /// Held already (an echo, or an answer to a query that another
    /// member's answer filled first).
    Known,
}

/// Every sample a member holds.
#[derive(Debug, Default)]
pub struct Book {
    sources: BTreeMap<String, Source>,
    total: usize,
}

/// A batch of at most `max` samples received as `bytes` on the key of
/// vessel `key_id` (a CBOR array of sample maps), their shape checked, and
/// each one's id the key's (their values are [`Book::offer`]'s to judge).
pub fn decode(bytes: &[u8], key_id: &str, max: usize) -> Result<Vec<PeerSampleDocument>, Refusal> {
    if bytes.len() > max * MAX_SAMPLE {
        return Err(Refusal::Oversized);
    }
    let docs: Vec<PeerSampleDocument> =
        ciborium::from_reader(bytes).map_err(|_| Refusal::Undecodable)?;
    if docs.len() > max {
        return Err(Refusal::Oversized);
    }
    if docs
        .iter()
        .any(|d| d.id != key_id || !super::wire::valid_peer_id(&d.id))
    {
        return Err(Refusal::Undecodable);
    }
    Ok(docs)
}

/// The CBOR bytes of a batch, its floats as 32 bits (time as it is).
pub fn encode(docs: &[PeerSampleDocument]) -> Vec<u8> {
    let docs: Vec<PeerSampleDocument> = docs.iter().map(quantize).collect();
    let mut out = Vec::with_capacity(docs.len() * MAX_SAMPLE);
    ciborium::into_writer(&docs, &mut out).expect("samples always encode");
    out
}

/// `doc` as the wire carries it: what every member holds, so that the
/// sender's own copy is the one its neighbours fit.
pub fn quantize(doc: &PeerSampleDocument) -> PeerSampleDocument {
    let f = |v: f64| v as f32 as f64;
    PeerSampleDocument {
        id: doc.id.clone(),
        n: doc.n,
        t: doc.t,
        x: f(doc.x),
        y: f(doc.y),
        value: f(doc.value),
        sd: f(doc.sd),
    }
}

impl Book {
    /// Offers `doc` (quantized as the wire carries it) at the receiver's UTC
    /// time `now`. Refused: values a sensor cannot give (not finite, σ ≤ 0,
    /// beyond the engine's range), a position farther than [`MAX_POSITION`]
    /// from the origin, a time ahead of `now` by more than [`MAX_AHEAD`],
    /// another sample already held under the same source and number (an id
    /// claimed twice), a new source beyond [`MAX_SOURCES`].
    pub fn offer(&mut self, doc: &PeerSampleDocument, now: f64) -> Result<Offered, Refusal> {
        let doc = quantize(doc);
        let sample = Sample::new(Point { x: doc.x, y: doc.y }, doc.value, doc.sd)
            .map_err(|_| Refusal::OutOfRange)?;
        if !(doc.t.is_finite() && doc.t > 0.0)
            || doc.x.hypot(doc.y) > MAX_POSITION
            || doc.t > now + MAX_AHEAD
        {
            return Err(Refusal::OutOfRange);
        }
        let held = Held { t: doc.t, sample };
        if !self.sources.contains_key(&doc.id) && self.sources.len() >= MAX_SOURCES {
            return Err(Refusal::OutOfRange);
        }
        let source = self.sources.entry(doc.id.clone()).or_default();
        if let Some(old) = source.held.get(&doc.n) {
            return if *old == held {
                Ok(Offered::Known)
            } else {
                Err(Refusal::IdConflict)
            };
        }
        if doc.n < source.next && !source.beyond.contains(&doc.n) {
            // Received once and dropped since to stay bounded: dropped
            // here too, as by every member that held it.
            let oldest = source.held.first_key_value().map(|(&n, _)| n);
            if oldest.is_none_or(|o| doc.n < o) {
                return Ok(Offered::Known);
            }
        }
        source.receive(doc.n);
        source.held.insert(doc.n, held);
        self.total += 1;
        if source.held.len() > MAX_PER_SOURCE {
            source.held.pop_first();
            self.total -= 1;
        }
        self.trim();
        Ok(Offered::New)
    }

    /// Beyond [`MAX_HELD`], the source holding most (the first by id among
    /// equals) gives up its oldest number.
    fn trim(&mut self) {
        while self.total > MAX_HELD {
            let Some(source) = self.sources.values_mut().max_by(|a, b| {
                a.held
                    .len()
                    .cmp(&b.held.len())
                    .then(std::cmp::Ordering::Greater)
            }) else {
                return;
            };
            source.held.pop_first();
            self.total -= 1;
        }
    }

    pub fn len(&self) -> usize {
        self.total
    }

    pub fn is_empty(&self) -> bool {
        self.total == 0
    }

    pub fn sources(&self) -> usize {
        self.sources.len()
    }

    /// Every sample held that was taken at `until` (sender's UTC) or
    /// before, and a digest of them (FNV-1a over each one's source, number
    /// and bits, in order): equal sets, equal digests.
    pub fn until(&self, until: f64) -> (Vec<Sample>, u64) {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        };
        let mut out = Vec::new();
        for (id, source) in &self.sources {
            for (n, held) in source.held.iter().filter(|(_, h)| h.t <= until) {
                eat(id.as_bytes());
                eat(&n.to_le_bytes());
                let s = held.sample;
                for v in [held.t, s.position.x, s.position.y, s.value, s.sd] {
                    eat(&v.to_bits().to_le_bytes());
                }
                out.push(s);
            }
        }
        (out, h)
    }

    /// When the oldest sample held that was taken at `until` or before
    /// was taken (sender's UTC): members that hold the same samples agree
    /// on it, as on [`Book::until`]'s set.
    pub fn oldest(&self, until: f64) -> Option<f64> {
        self.sources
            .values()
            .flat_map(|source| source.held.values())
            .map(|held| held.t)
            .filter(|&t| t <= until)
            .reduce(f64::min)
    }

    /// Each source with a gap, and the first number missing.
    pub fn gaps(&self) -> Vec<(String, u32)> {
        self.sources
            .iter()
            .filter(|(_, s)| !s.beyond.is_empty())
            .map(|(id, s)| (id.clone(), s.next))
            .collect()
    }

    /// The samples of `id` numbered `from` or more, at most
    /// [`MAX_ANSWER`], as documents (an answer to a query).
    pub fn from(&self, id: &str, from: u32) -> Vec<PeerSampleDocument> {
        let Some(source) = self.sources.get(id) else {
            return Vec::new();
        };
        source
            .held
            .range(from..)
            .take(MAX_ANSWER)
            .map(|(&n, h)| PeerSampleDocument {
                id: id.to_string(),
                n,
                t: h.t,
                x: h.sample.position.x,
                y: h.sample.position.y,
                value: h.sample.value,
                sd: h.sample.sd,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc(id: &str, n: u32, x: f64) -> PeerSampleDocument {
        PeerSampleDocument {
            id: id.into(),
            n,
            t: 1.7e9 + f64::from(n),
            x,
            y: 10.0,
            value: 1.5,
            sd: 0.1,
        }
    }

    const NOW: f64 = 1.8e9;

    #[test]
    fn the_same_samples_in_any_order_make_the_same_book() {
        let docs: Vec<_> = (0..50)
            .flat_map(|n| ["a", "b", "c"].map(|id| doc(id, n, f64::from(n))))
            .collect();
        let (mut one, mut two) = (Book::default(), Book::default());
        for d in &docs {
            assert_eq!(one.offer(d, NOW), Ok(Offered::New));
        }
        for d in docs.iter().rev() {
            two.offer(d, NOW).unwrap();
        }
        assert_eq!(one.until(f64::MAX).1, two.until(f64::MAX).1);
        // Up to a time: the samples taken by then, whatever came after.
        let (early, digest) = one.until(1.7e9 + 9.5);
        assert_eq!(early.len(), 30);
        two.offer(&doc("d", 20, 1.0), NOW).unwrap();
        assert_eq!(two.until(1.7e9 + 9.5).1, digest);
        assert_eq!(one.len(), 150);
        assert_eq!(one.offer(&docs[7], NOW), Ok(Offered::Known));
        // The oldest sample (the optimism's age) is the books' common one.
        assert_eq!(one.oldest(f64::MAX), Some(1.7e9));
        assert_eq!(two.oldest(1.7e9 + 9.5), one.oldest(1.7e9 + 9.5));
        assert_eq!(one.oldest(1.7e9 - 1.0), None);
    }

    #[test]
    fn a_gap_is_seen_until_filled() {
        let mut book = Book::default();
        for n in [0, 1, 4, 5] {
            book.offer(&doc("a", n, 1.0), NOW).unwrap();
        }
        assert_eq!(book.gaps(), vec![("a".to_string(), 2)]);
        let answer: Vec<u32> = book.from("a", 1).iter().map(|d| d.n).collect();
        assert_eq!(answer, [1, 4, 5]);
        for n in [2, 3] {
            book.offer(&doc("a", n, 1.0), NOW).unwrap();
        }
        assert!(book.gaps().is_empty());
    }

    #[test]
    fn bad_samples_are_refused() {
        let mut book = Book::default();
        let mut far = doc("a", 0, 60_000.0);
        assert_eq!(book.offer(&far, NOW), Err(Refusal::OutOfRange));
        far.x = 1.0;
        far.sd = 0.0;
        assert_eq!(book.offer(&far, NOW), Err(Refusal::OutOfRange));
        let mut ahead = doc("a", 0, 1.0);
        ahead.t = NOW + 60.0;
        assert_eq!(book.offer(&ahead, NOW), Err(Refusal::OutOfRange));
        book.offer(&doc("a", 0, 1.0), NOW).unwrap();
        assert_eq!(book.offer(&doc("a", 0, 2.0), NOW), Err(Refusal::IdConflict));
        assert!(decode(&[0xff; 200], "a", MAX_BATCH).is_err());
        let batch: Vec<_> = (0..MAX_BATCH as u32)
            .map(|n| doc("usv-100", n, 1.0))
            .collect();
        let bytes = encode(&batch);
        assert!(
            bytes.len() <= MAX_BATCH * MAX_SAMPLE,
            "{} bytes",
            bytes.len()
        );
        assert_eq!(decode(&bytes, "b", MAX_BATCH), Err(Refusal::Undecodable));
        assert_eq!(decode(&bytes, "usv-100", MAX_BATCH).unwrap()[3].n, 3);
        assert_eq!(decode(&bytes, "usv-100", 4), Err(Refusal::Oversized));
    }

    #[test]
    fn a_flood_displaces_only_its_own() {
        let mut book = Book::default();
        book.offer(&doc("quiet", 0, 1.0), NOW).unwrap();
        for n in 0..(MAX_PER_SOURCE as u32 + 10) {
            book.offer(&doc("loud", n, 1.0), NOW).unwrap();
        }
        assert_eq!(book.len(), MAX_PER_SOURCE + 1);
        assert_eq!(book.from("quiet", 0).len(), 1);
        assert_eq!(book.from("loud", 0)[0].n, 10);
        // A dropped number offered again stays dropped.
        assert_eq!(book.offer(&doc("loud", 3, 1.0), NOW), Ok(Offered::Known));
        assert_eq!(book.len(), MAX_PER_SOURCE + 1);
    }
}
