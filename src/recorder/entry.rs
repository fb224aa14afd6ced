//! What the coordinator and the simulator hand the recorder ([`Entry`]),
//! where it writes ([`RecorderConfig`], [`Target`]), and the names of its
//! metrics: the vocabulary the handle ([`super::Recorder`]) and the writer
//! thread ([`super::writer`]) share.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use super::messages::{EventRecord, SimVesselRecord};
use super::retention::Keep;
use crate::protocol::{MissionDocument, PoseDocument, Snapshot};

/// Entries dropped because the writer was behind or stopped.
pub const DROPPED: &str = "seacover_recording_dropped_total";
/// Recording errors (each stops the recording).
pub const ERRORS: &str = "seacover_recording_errors_total";
/// 1 while a recording is being written, 0 otherwise.
pub const ACTIVE: &str = "seacover_recording_active";
/// Bytes written to recordings.
pub const BYTES: &str = "seacover_recording_bytes_total";

/// Where and how a recording is written.
#[derive(Debug, Clone)]
pub struct RecorderConfig {
    pub target: Target,
    /// Publish times from the wall clock (the coordinator) or equal to the
    /// log times (the simulator, so that a seed gives the same messages).
    pub wall_clock: bool,
}

/// Where recordings go.
#[derive(Debug, Clone)]
pub enum Target {
    /// `DIR/<UTC start>.mcap`, a new file after `max_bytes` (or a quarter
    /// of `keep`'s byte limit, if smaller) or `max_duration` of mission
    /// time; the oldest files deleted beyond `keep` ([`super::retention`]).
    Directory {
        dir: PathBuf,
        max_bytes: u64,
        max_duration: Duration,
        keep: Keep,
    },
    /// One file, never rotated (`seacover sim --record FILE`).
    File(PathBuf),
}

/// `--record-max-mb`'s default.
pub const DEFAULT_MAX_BYTES: u64 = 256 * 1024 * 1024;
/// `--record-max-minutes`' default: a file per hour of mission time.
pub const DEFAULT_MAX_DURATION: Duration = Duration::from_secs(3600);

impl Target {
    /// `dir` with the defaults of `seacover serve`: a file per mission hour
    /// or 256 MiB, the oldest deleted beyond [`super::retention::DEFAULT_KEEP`].
    pub fn directory(dir: PathBuf) -> Target {
        Target::Directory {
            dir,
            max_bytes: DEFAULT_MAX_BYTES,
            max_duration: DEFAULT_MAX_DURATION,
            keep: Keep::standard(),
        }
    }
}

/// What the recorder is handed. Its variants are at most 32 bytes (what
/// is bigger is boxed): the hand-over's ring holds 65 536 of them.
#[derive(Debug)]
pub enum Entry {
    /// A pose as the coordinator received it, at mission time `time`.
    Pose {
        vessel: Arc<str>,
        time: f64,
        pose: Box<PoseDocument>,
    },
    /// A published snapshot. Each new tick's coverage, commands and, for
    /// geo-referenced missions, map channels are recorded from it; a
    /// snapshot of a tick already recorded (one published by a mission
    /// change) adds nothing.
    Tick(Arc<Snapshot>),
    /// The whole mission, at start and after each accepted change.
    Mission {
        time: f64,
        mission: Box<MissionDocument>,
    },
    Event(Box<EventRecord>),
    /// `seacover sim`: a vessel's truth, disturbance and estimate.
    SimVessel(Box<SimVesselRecord>),
    /// `serve --peer`: a peer fleet's beacon as it arrived.
    Beacon(Box<super::messages::BeaconRecord>),
    /// A sample as judged.
    Sample(Box<super::messages::SampleRecord>),
    /// A belief as taken up.
    Belief(Box<super::messages::BeliefRecord>),
    /// Finish the file and stop.
    Finish,
}

#[cfg(test)]
mod tests {
    /// The hand-over's ring is `CAPACITY` slots of an entry (and a stamp)
    /// each, resident once cycled through: 48 bytes a slot is 3 MB; an
    /// unboxed pose made it 9 MB.
    #[test]
    fn an_entry_is_small() {
        assert!(std::mem::size_of::<super::Entry>() <= 40);
    }
}
