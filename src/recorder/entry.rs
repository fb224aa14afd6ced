//! What the coordinator and the simulator hand the recorder ([`Entry`]),
//! where it writes ([`RecorderConfig`], [`Target`]), and the names of its
//! metrics: the vocabulary the handle ([`super::Recorder`]) and the writer
//! thread ([`super::writer`]) share.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use super::messages::{EventRecord, SimVesselRecord};
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
    /// `DIR/<UTC start>.mcap`, a new file after `max_bytes` or `max_duration`
    /// (wall clock).
    Directory {
        dir: PathBuf,
        max_bytes: u64,
        max_duration: Duration,
    },
    /// One file, never rotated (`seacover sim --record FILE`).
    File(PathBuf),
}

/// What the recorder is handed.
#[derive(Debug)]
pub enum Entry {
    /// A pose as the coordinator received it, at mission time `time`.
    Pose {
        vessel: Arc<str>,
        time: f64,
        pose: PoseDocument,
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
    Event(EventRecord),
    /// `seacover sim`: a vessel's truth, disturbance and estimate.
    SimVessel(SimVesselRecord),
    /// `serve --peer`: a peer fleet's beacon as it arrived.
    Beacon(Box<super::messages::BeaconRecord>),
    /// Finish the file and stop.
    Finish,
}
