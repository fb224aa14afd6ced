//! The mission recorder: every run as MCAP (issue 16), written on a thread
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
//! it was cut short.
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
//!   same seed gives the same messages.

mod entry;
pub mod inspect;
pub mod messages;
pub mod reader;
pub mod writer;

use std::sync::Arc;
use std::sync::mpsc::{SyncSender, TrySendError};

use crate::protocol::{MissionDocument, PoseDocument};
pub use entry::{ACTIVE, BYTES, DROPPED, ERRORS, Entry, RecorderConfig, Target};
use messages::EventRecord;

/// Entries the hand-over holds: about two seconds of a 1000-vessel fleet's
/// poses (20 Hz) and ticks.
const CAPACITY: usize = 65_536;

/// The hand-over to the writer thread; cheap to clone. A recorder that is
/// off takes everything and does nothing.
#[derive(Debug, Clone)]
pub struct Recorder {
    tx: Option<SyncSender<Entry>>,
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
            writer: None,
            blocking: false,
        }
    }

    /// Starts the writer thread. Entries are dropped rather than waited
    /// for, unless `blocking` (the simulator).
    pub fn start(config: RecorderConfig, blocking: bool) -> (Recorder, RecorderThread) {
        let (tx, rx) = std::sync::mpsc::sync_channel(CAPACITY);
        let thread = std::thread::Builder::new()
            .name("seacover-recorder".into())
            .spawn(move || writer::run(config, rx))
            .expect("a thread can be spawned");
        (
            Recorder {
                tx: Some(tx),
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
        match tx.try_send(entry) {
            Ok(()) => {}
            Err(TrySendError::Full(entry)) if self.blocking => {
                // The simulator waits for the writer rather than drop.
                self.wake();
                let _ = tx.send(entry);
            }
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
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
                pose: pose.clone(),
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

    pub fn event(&self, event: EventRecord) {
        if self.tx.is_some() {
            self.record(Entry::Event(event));
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
