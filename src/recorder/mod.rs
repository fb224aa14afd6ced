//! The mission recorder: every run as MCAP (docs/recording.md), written on a thread
//! of its own.
//!
//! The coordinator (and `seacover sim`) hand a [`Recorder`] what happened —
//! poses as received, each tick's snapshot, mission changes, events — and
//! the [`writer`] thread turns them into the channels of [`messages`]:
//! JSON messages with schemas generated from the protocol types, in zstd
//! chunks of at most one second of mission time, so a `kill -9` loses at
//! most the last second and leaves a file that MCAP readers recover.
//! [`reader`] reads recordings back (replay, `seacover record`), through
//! the chunk index when the file has one and by recovering the chunks when
//! it was cut short. A long run is split into files of at most an hour of
//! mission time (or 256 MiB), each standing alone, and [`retention`]
//! deletes the oldest beyond what the operator keeps (`--record-keep`).
//!
//! Invariants:
//! - the coordinator never waits on the disk: [`Recorder`] hands entries
//!   over a bounded channel with `try_send`; what does not fit is dropped
//!   and counted (`seacover_recording_dropped_total`), and everything else
//!   — serialization, compression, writing — happens on the writer thread;
//! - a recording that cannot be written (an unwritable directory, a full
//!   disk) stops with an error in the log and `seacover_recording_errors_total`,
//!   and the coordinator runs on; `seacover_recording_active` says which;
//! - `seacover sim` records with a blocking hand-over instead, so that the
//!   same seed gives the same messages;
//! - memory is bounded whatever the run's length: the hand-over holds at
//!   most `CAPACITY` entries, of them at most `MAX_TICKS_QUEUED` tick
//!   snapshots, the MCAP writer's index (one entry per
//!   chunk, a chunk per second of mission time at most) lives as long as
//!   its file, and [`retention`]'s list holds one entry per file kept.

mod entry;
pub mod inspect;
pub mod messages;
pub mod reader;
pub mod retention;
pub mod writer;

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};

use crate::protocol::{MissionDocument, PoseDocument};
pub use entry::{
    ACTIVE, BYTES, DEFAULT_MAX_BYTES, DEFAULT_MAX_DURATION, DROPPED, ERRORS, Entry, RecorderConfig,
    Target,
};
use messages::EventRecord;

/// Entries the hand-over holds: about two seconds of a 1000-vessel fleet's
/// poses (20 Hz) and ticks. The channel's ring of slots is allocated whole
/// and becomes resident as it is first cycled through, so an [`Entry`] is
/// kept small (its big variants boxed): 65 536 slots of 48 bytes, 3 MB.
const CAPACITY: usize = 65_536;

/// Tick snapshots the hand-over holds at most; beyond, a tick is dropped
/// and counted like any entry that does not fit. Entries are counted, not
/// bytes, and a snapshot is big (every cell's outline: kilobytes at 8
/// vessels, a megabyte at 1000): a writer that fell behind a warped
/// coordinator (4000 ticks a second) held 120 MB of them before this cap.
/// 256 is 25 s of a 10 Hz tick, far more than a writer that keeps up lags.
const MAX_TICKS_QUEUED: usize = 256;

/// The hand-over to the writer thread; cheap to clone. A recorder that is
/// off takes everything and does nothing.
#[derive(Debug, Clone)]
pub struct Recorder {
    tx: Option<SyncSender<Entry>>,
    /// Tick entries handed over and not yet taken by the writer.
    ticks: Arc<AtomicUsize>,
    /// The writer thread, to wake (see [`writer`]'s `IDLE_WAKE`).
    writer: Option<std::thread::Thread>,
    blocking: bool,
}

/// The writer thread, to wait for once the recorder is finished.
pub struct RecorderThread(Option<std::thread::JoinHandle<()>>);

impl RecorderThread {
    /// Waits until the writer has finished its file.
    pub fn join(mut self) {
        if let Some(t) = self.0.take() {
            let _ = t.join();
        }
    }
}

impl Recorder {
    /// A recorder that records nothing (`--record off`).
    pub fn off() -> Recorder {
        Recorder {
            tx: None,
            ticks: Arc::default(),
            writer: None,
            blocking: false,
        }
    }

    /// Starts the writer thread. Entries are dropped rather than waited
    /// for, unless `blocking` (the simulator).
    pub fn start(config: RecorderConfig, blocking: bool) -> (Recorder, RecorderThread) {
        let (tx, rx) = std::sync::mpsc::sync_channel(CAPACITY);
        let ticks = Arc::new(AtomicUsize::new(0));
        let taken = ticks.clone();
        let thread = std::thread::Builder::new()
            .name("seacover-recorder".into())
            .spawn(move || writer::run(config, rx, &taken))
            .expect("a thread can be spawned");
        (
            Recorder {
                tx: Some(tx),
                ticks,
                writer: Some(thread.thread().clone()),
                blocking,
            },
            RecorderThread(Some(thread)),
        )
    }

    pub fn is_on(&self) -> bool {
        self.tx.is_some()
    }

    /// Hands `entry` over. A tick (handed over once its commands are
    /// written) or the finish wakes the writer; other entries wait for it.
    pub fn record(&self, entry: Entry) {
        let Some(tx) = &self.tx else { return };
        let wake = matches!(entry, Entry::Tick(_) | Entry::Finish);
        let tick = matches!(entry, Entry::Tick(_));
        if tick {
            if !self.blocking && self.ticks.load(Ordering::Relaxed) >= MAX_TICKS_QUEUED {
                metrics::counter!(DROPPED).increment(1);
                self.wake();
                return;
            }
            self.ticks.fetch_add(1, Ordering::Relaxed);
        }
        match tx.try_send(entry) {
            Ok(()) => {}
            Err(TrySendError::Full(entry)) if self.blocking => {
                // The simulator waits for the writer rather than drop.
                self.wake();
                let _ = tx.send(entry);
            }
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                if tick {
                    self.ticks.fetch_sub(1, Ordering::Relaxed);
                }
                metrics::counter!(DROPPED).increment(1);
            }
        }
        if wake {
            self.wake();
        }
    }

    fn wake(&self) {
        if let Some(w) = &self.writer {
            w.unpark();
        }
    }

    pub fn pose(&self, vessel: &Arc<str>, time: f64, pose: &PoseDocument) {
        if self.tx.is_some() {
            self.record(Entry::Pose {
                vessel: vessel.clone(),
                time,
                pose: Box::new(pose.clone()),
            });
        }
    }

    /// A peer fleet's beacon, received at mission time `time`.
    pub fn beacon(&self, time: f64, beacon: &crate::protocol::peer::BeaconDocument) {
        if self.tx.is_some() {
            self.record(Entry::Beacon(Box::new(messages::BeaconRecord {
                time,
                beacon: beacon.clone(),
            })));
        }
    }

    /// A sample received at mission time `time`, and what became of it.
    pub fn sample(&self, time: f64, sample: &crate::protocol::SampleDocument, outcome: &str) {
        if self.tx.is_some() {
            self.record(Entry::Sample(Box::new(messages::SampleRecord {
                time,
                sample: sample.clone(),
                outcome: outcome.to_string(),
            })));
        }
    }

    /// The belief taken up at mission time `time`.
    pub fn belief(&self, time: f64, belief: crate::protocol::BeliefDocument) {
        if self.tx.is_some() {
            self.record(Entry::Belief(Box::new(messages::BeliefRecord {
                time,
                belief,
            })));
        }
    }

    pub fn event(&self, event: EventRecord) {
        if self.tx.is_some() {
            self.record(Entry::Event(Box::new(event)));
        }
    }

    pub fn mission(&self, time: f64, mission: MissionDocument) {
        if self.tx.is_some() {
            self.record(Entry::Mission {
                time,
                mission: Box::new(mission),
            });
        }
    }

    /// Asks the writer to finish its file (it has everything handed over
    /// before); the caller then joins the [`RecorderThread`].
    pub fn finish(&self) {
        if let Some(tx) = &self.tx {
            // Blocking: the end of the file must not be dropped.
            self.wake();
            let _ = tx.send(Entry::Finish);
            self.wake();
        }
    }
}
