//! Learning the risk map in a peer fleet (docs/learning.md, "In a peer
//! fleet"): every member publishes its vessels' samples, holds every
//! sample it hears ([`Book`]), asks for the ones it missed, and fits the
//! belief its vessels cover, on a thread beside their loops.
//!
//! Invariants:
//! - the belief is a function of the sample set and the mission revision
//!   alone (the engine's learner sums samples in an order of their own):
//!   members that hold the same samples of the same revision cover the
//!   same belief, which the status shows as the same digest;
//! - nothing waits on the radio: samples go out dropped on congestion
//!   (what is lost is asked for again, from any member that holds it),
//!   answers are bounded ([`super::samples::MAX_ANSWER`]), and a fit runs
//!   off the vessels' loops;
//! - every refused sample is counted by reason (`sample_<reason>`) and
//!   never learned from.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::{Notify, watch};
use tokio_util::sync::CancellationToken;
use zenoh::Wait;
use zenoh::query::ConsolidationMode;

use super::board::Revision;
use super::samples::{self, Book, Offered};
use super::wire::{Keys, Refusal};
use crate::coverage::RiskField;
pub use crate::learning::LearnSettings;
use crate::learning::{Lattice, Learner};
use crate::protocol::peer::{PeerLearningDocument, PeerSampleDocument};

/// A belief fitted by this member.
#[derive(Debug)]
pub struct Belief {
    /// The mission revision whose region and risk (the prior) it was
    /// fitted with; covered only while that revision is.
    pub revision: u32,
    pub density: RiskField,
    /// The digest and size of the sample set it was fitted to.
    pub digest: u64,
    pub fitted: usize,
    /// The samples taken up to this UTC time [s] (the epoch's end).
    pub until: f64,
}

/// A member's learner: its book, its newest belief, its refusals.
#[derive(Debug)]
pub struct Learning {
    pub settings: LearnSettings,
    book: Mutex<Book>,
    belief: Mutex<Option<Arc<Belief>>>,
    fits: Mutex<u64>,
    refused: Mutex<BTreeMap<&'static str, u64>>,
    /// Woken when a sample shows a gap.
    gap: Notify,
}

/// A refusal's counter name.
fn refusal_name(r: Refusal) -> &'static str {
    match r {
        Refusal::Undecodable => "sample_undecodable",
        Refusal::Oversized => "sample_oversized",
        Refusal::IdConflict => "sample_id_conflict",
        _ => "sample_out_of_range",
    }
}

impl Learning {
    pub fn new(settings: LearnSettings) -> Learning {
        Learning {
            settings,
            book: Mutex::new(Book::default()),
            belief: Mutex::new(None),
            fits: Mutex::new(0),
            refused: Mutex::new(BTreeMap::new()),
            gap: Notify::new(),
        }
    }

    /// The density to cover under mission revision `revision`, once a
    /// belief has been fitted for it.
    pub fn belief(&self, revision: u32) -> Option<Arc<Belief>> {
        self.belief
            .lock()
            .expect("belief lock")
            .clone()
            .filter(|b| b.revision == revision)
    }

    /// Offers a sample; counts a refusal.
    pub fn offer(&self, doc: &PeerSampleDocument, now: f64) -> Option<Offered> {
        let mut book = self.book.lock().expect("book lock");
        match book.offer(doc, now) {
            Ok(o) => {
                if o == Offered::New && !book.gaps().is_empty() {
                    self.gap.notify_one();
                }
                Some(o)
            }
            Err(why) => {
                drop(book);
                self.refuse(why);
                None
            }
        }
    }

    fn refuse(&self, why: Refusal) {
        *self
            .refused
            .lock()
            .expect("refused lock")
            .entry(refusal_name(why))
            .or_default() += 1;
    }

    /// A batch of samples received on `key` (a vessel's puts, or an
    /// answer to a query) as `bytes`.
    fn on_samples(&self, key: &str, bytes: &[u8], max: usize) {
        let id = key.rsplit('/').next().unwrap_or_default();
        match samples::decode(bytes, id, max) {
            Ok(docs) => {
                let now = super::wire::utc_now();
                for d in &docs {
                    self.offer(d, now);
                }
            }
            Err(why) => self.refuse(why),
        }
    }

    /// Refusals by reason, for the status's `refused`.
    pub fn refused(&self) -> BTreeMap<&'static str, u64> {
        self.refused.lock().expect("refused lock").clone()
    }

    /// The status's `learning`, with the belief itself when `with_belief`.
    pub fn document(&self, with_belief: bool) -> PeerLearningDocument {
        let (samples, sources) = {
            let book = self.book.lock().expect("book lock");
            (book.len() as u64, book.sources() as u64)
        };
        let belief = self.belief.lock().expect("belief lock").clone();
        PeerLearningDocument {
            samples,
            sources,
            fits: *self.fits.lock().expect("fits lock"),
            digest: belief.as_ref().map(|b| format!("{:016x}", b.digest)),
            fitted: belief.as_ref().map_or(0, |b| b.fitted as u64),
            until: belief.as_ref().map(|b| b.until),
            belief: belief
                .filter(|_| with_belief)
                .map(|b| crate::mission::belief::risk_document(&b.density)),
        }
    }
}

/// Declares what a learning member shares with the fleet: the subscriber
/// to every vessel's samples and the queryable that answers for the
/// samples it holds; starts the asker of missed samples and the fitter.
pub async fn declare(
    learning: Arc<Learning>,
    session: &zenoh::Session,
    keys: &Keys,
    missions: watch::Receiver<Option<Arc<Revision>>>,
    warp: f64,
    tasks: &tokio_util::task::TaskTracker,
    stop: &CancellationToken,
) -> Result<(), zenoh::Error> {
    let l = learning.clone();
    session
        .declare_subscriber(keys.sample_all())
        .callback(move |s| {
            let bytes = s.payload().to_bytes();
            l.on_samples(s.key_expr().as_str(), &bytes, samples::MAX_BATCH);
        })
        .background()
        .await?;
    let l = learning.clone();
    session
        .declare_queryable(keys.samples_all())
        .callback(move |query| {
            let key = query.key_expr().as_str().to_string();
            let id = key.rsplit('/').next().unwrap_or_default();
            let from = query
                .parameters()
                .get("from")
                .and_then(|f| f.parse::<u32>().ok())
                .unwrap_or(0);
            let answer = l.book.lock().expect("book lock").from(id, from);
            if answer.is_empty() {
                return;
            }
            let _ = query.reply(&key, samples::encode(&answer)).wait();
        })
        .background()
        .await?;
    tasks.spawn(ask_for_gaps(
        learning.clone(),
        session.clone(),
        keys.clone(),
        stop.clone(),
    ));
    tasks.spawn(fit_when_due(learning, missions, warp, stop.clone()));
    Ok(())
}

/// Asks for what a gap lacks, from any member that holds it: at once when
/// a gap shows, then every second while one stays.
async fn ask_for_gaps(l: Arc<Learning>, z: zenoh::Session, keys: Keys, stop: CancellationToken) {
    while !stop.is_cancelled() {
        let gaps = l.book.lock().expect("book lock").gaps();
        for (id, from) in gaps {
            let Ok(replies) = z
                .get(format!("{}?from={from}", keys.samples(&id)))
                .consolidation(ConsolidationMode::None)
                .timeout(Duration::from_secs(1))
                .await
            else {
                continue;
            };
            while let Ok(reply) = replies.recv_async().await {
                if let Ok(sample) = reply.result() {
                    let bytes = sample.payload().to_bytes();
                    l.on_samples(&keys.samples(&id), &bytes, samples::MAX_ANSWER);
                }
            }
        }
        tokio::select! {
            _ = stop.cancelled() => break,
            _ = tokio::time::sleep(Duration::from_secs(1)) => {}
            _ = l.gap.notified() => {}
        }
    }
}

/// How long a vessel's samples wait to go out together [s of UTC].
pub const BATCH_EVERY: f64 = 2.0;
/// How long after an epoch ends its samples are fitted [s of UTC]: time
/// for the last of them to go out in their batch and arrive, or to be
/// asked for again.
const SETTLE: f64 = BATCH_EVERY + 2.0;

/// Fits the belief on a blocking thread at every epoch of `refit` mission
/// seconds (on the UTC clock every member shares, [`SETTLE`] after it
/// ends), to the samples taken up to the epoch's end: members that hold the
/// same samples fit the same set, hence the same belief, whatever came in
/// since. Refitted only when that set or the mission changed.
async fn fit_when_due(
    l: Arc<Learning>,
    missions: watch::Receiver<Option<Arc<Revision>>>,
    warp: f64,
    stop: CancellationToken,
) {
    let period = (l.settings.refit / warp.max(1e-3)).max(0.01);
    let mut fitted: Option<(u32, u64)> = None;
    loop {
        let now = super::wire::utc_now();
        let until = ((now - SETTLE) / period).floor() * period;
        let due = until + period + SETTLE;
        tokio::select! {
            _ = stop.cancelled() => break,
            _ = tokio::time::sleep(Duration::from_secs_f64((due - now).max(0.001))) => {}
        }
        let Some(rev) = missions.borrow().clone() else {
            continue;
        };
        let until = until + period;
        let ((samples, digest), oldest) = {
            let book = l.book.lock().expect("book lock");
            (book.until(until), book.oldest(until))
        };
        if samples.is_empty() || fitted == Some((rev.revision, digest)) {
            continue;
        }
        let settings = l.settings;
        // The optimism fades with the oldest sample's age in mission
        // seconds (docs/learning.md, "Optimism that fades").
        let age = (until - oldest.unwrap_or(until)) * warp;
        let kappa = settings.kappa_at(age);
        let fit = tokio::task::spawn_blocking(move || {
            let (min, max) = rev.mission.region().bounds();
            let lattice = Lattice::over(min, max, settings.lattice).ok()?;
            let mut learner = Learner::new(lattice, rev.mission.risk().clone(), settings.params());
            let fitted = samples.len();
            for s in samples {
                learner.add(s);
            }
            Some(Belief {
                revision: rev.revision,
                density: learner.fit().density(kappa),
                digest,
                fitted,
                until,
            })
        })
        .await;
        if let Ok(Some(belief)) = fit {
            fitted = Some((belief.revision, digest));
            *l.belief.lock().expect("belief lock") = Some(Arc::new(belief));
            *l.fits.lock().expect("fits lock") += 1;
        }
    }
}

/// One vessel's samples on their way out: its publisher, its count and
/// the batch being gathered.
pub struct Outbox {
    id: String,
    publisher: zenoh::pubsub::Publisher<'static>,
    n: u32,
    batch: Vec<PeerSampleDocument>,
}

impl Outbox {
    /// Declares vessel `id`'s sample publisher: reliable but dropped on
    /// congestion, so a slow link never holds the vessel's loop (what is
    /// dropped is asked for again).
    pub async fn declare(
        session: &zenoh::Session,
        keys: &Keys,
        id: &str,
    ) -> Result<Outbox, zenoh::Error> {
        let publisher = session
            .declare_publisher(keys.sample(id))
            .congestion_control(zenoh::qos::CongestionControl::Drop)
            .await?;
        Ok(Outbox {
            id: id.to_string(),
            publisher,
            n: 0,
            batch: Vec::new(),
        })
    }

    /// A measurement of the vessel's: held by this member's learner as its
    /// neighbours will hold it, and published with the others of its batch
    /// once the oldest has waited [`BATCH_EVERY`] (or the batch is full).
    pub async fn measured(&mut self, learning: &Learning, x: f64, y: f64, value: f64, sd: f64) {
        let now = super::wire::utc_now();
        let doc = samples::quantize(&PeerSampleDocument {
            id: self.id.clone(),
            n: self.n,
            t: now,
            x,
            y,
            value,
            sd,
        });
        if learning.offer(&doc, now).is_none() {
            // Refused (and counted) here as it would be everywhere.
            return;
        }
        self.n = self.n.wrapping_add(1);
        self.batch.push(doc);
        if self.batch.len() >= samples::MAX_BATCH {
            self.flush().await;
        } else {
            self.flush_due(now).await;
        }
    }

    /// Sends the batch once its oldest sample has waited [`BATCH_EVERY`]
    /// (called at each beacon too, so that a sensor that falls silent
    /// does not leave its last samples waiting).
    pub async fn flush_due(&mut self, now: f64) {
        if self.batch.first().is_some_and(|d| now - d.t >= BATCH_EVERY) {
            self.flush().await;
        }
    }

    async fn flush(&mut self) {
        let batch = std::mem::take(&mut self.batch);
        if let Err(e) = self.publisher.put(samples::encode(&batch)).await {
            tracing::debug!(vessel = %self.id, error = %e, "samples not sent");
        }
    }
}
