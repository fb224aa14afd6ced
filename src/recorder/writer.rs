//! The writer thread: entries in, MCAP files out.
//!
//! - A chunk holds at most one second of mission time and is closed at
//!   least once a second of wall time, then flushed to the operating
//!   system: a `kill -9` of the process loses at most that second, and the
//!   chunks before it are whole, so MCAP readers recover the file.
//! - Each file starts with the newest mission, so every file of a rotated
//!   run stands on its own. A directory's files are rotated by size and by
//!   mission time (so a warped run gets the same files as a real one), and
//!   after each flush the oldest are deleted beyond `--record-keep`
//!   ([`super::retention`]).
//! - What the writer holds in memory is bounded by its file: mcap's index
//!   of the open file (a chunk index entry per chunk, about 300 bytes, a
//!   chunk per second of mission time at most: about 1 MB per mission hour
//!   of file) is dropped when the file is rotated.
//! - The first error (an unwritable directory, a full disk) ends the
//!   recording for good: logged, counted, and everything handed over
//!   afterwards is dropped. The thread never panics on I/O.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError};
use std::time::{Duration, Instant};

use serde::Serialize;

use super::messages::{
    self, CommandRecord, EventRecord, FoxgloveTime, GeoJson, LocationFix, MissionRecord,
    PoseRecord, SimVesselRecord, VesselState, ns,
};
use super::retention::Shelf;
use super::{ACTIVE, BYTES, ERRORS, Entry, RecorderConfig, Target};
use crate::protocol::Snapshot;

/// Longest span of mission time in one chunk [ns].
const CHUNK_SPAN: u64 = 1_000_000_000;
/// Longest wall time a chunk stays open.
const CHUNK_WALL: Duration = Duration::from_secs(1);

/// Why a recording stopped.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("recording directory {path}: {source}")]
    Directory {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("recording file {path}: {source}")]
    File {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("writing {path}: {source}")]
    Mcap {
        path: PathBuf,
        source: mcap::McapError,
    },
}

/// The longest the writer waits for a wake-up before it looks anyway.
///
/// The writer does not block on the channel: a receiver blocked on it must
/// be woken by every send, which costs the sender (a link task, 20 000
/// times a second at 1000 vessels) a system call and the writer a context
/// switch per entry. It parks instead, and the coordinator wakes it with
/// each tick's snapshot, which is handed over once that tick's commands are
/// written ([`super::Recorder::record`]): the writer then does a tick's
/// worth of work in the quiet part of the tick period, not beside the
/// command fan-out that the tick → command latency measures. Without ticks
/// (a coordinator that is shutting down, the simulator between blocking
/// hand-overs) it looks every `IDLE_WAKE`.
const IDLE_WAKE: Duration = Duration::from_millis(100);

/// Writes what `rx` brings until the finish; `ticks` counts the tick
/// entries handed over and not yet taken (the hand-over caps them).
pub(super) fn run(config: RecorderConfig, rx: Receiver<Entry>, ticks: &AtomicUsize) {
    if config.wall_clock {
        yield_to_the_coordinator();
    }
    let mut w = Writer::new(config);
    // Open the first file at once, so that an unwritable directory is
    // reported when the coordinator starts, not at its first pose.
    w.guard(|w| w.open());
    'run: loop {
        loop {
            match rx.try_recv() {
                Ok(Entry::Finish) | Err(TryRecvError::Disconnected) => break 'run,
                Ok(entry) => {
                    if matches!(entry, Entry::Tick(_)) {
                        ticks.fetch_sub(1, Ordering::Relaxed);
                    }
                    if w.file.is_some() {
                        w.guard(|w| w.write(entry));
                        w.guard(|w| w.rotate_if_due().map(|_| ()));
                    }
                }
                Err(TryRecvError::Empty) => break,
            }
        }
        w.guard(|w| w.flush_if_due());
        std::thread::park_timeout(IDLE_WAKE);
    }
    w.guard(|w| w.close());
    metrics::gauge!(ACTIVE).set(0.0);
}

/// The pose channel's message ([`PoseRecord`]), borrowing the pose.
#[derive(Serialize)]
struct PoseOut<'a> {
    vessel: &'a str,
    time: f64,
    pose: &'a crate::protocol::PoseDocument,
}

/// The command channel's message ([`CommandRecord`]), borrowing the command.
#[derive(Serialize)]
struct CommandOut<'a> {
    vessel: &'a str,
    tick: u64,
    command: &'a crate::protocol::CommandDocument,
}

struct OpenFile {
    mcap: mcap::Writer<BufWriter<File>>,
    path: PathBuf,
    /// Channel ids by topic, in this file.
    channels: HashMap<String, u16>,
    /// Earliest and latest log time written since the file was opened
    /// (the mission restated at its start aside): what it spans.
    span: Option<(u64, u64)>,
    /// Earliest and latest log time in the open chunk.
    chunk_first: Option<(u64, u64)>,
    flushed: Instant,
    /// Bytes on disk at the last flush.
    size: u64,
    /// The latest log time written before this file opened: nothing in
    /// the file is logged earlier (see [`Writer::put`]).
    floor: u64,
}

impl OpenFile {
    /// Mission time the file spans so far [ns].
    fn spanned(&self) -> u64 {
        self.span.map_or(0, |(lo, hi)| hi - lo)
    }
}

struct Writer {
    config: RecorderConfig,
    file: Option<OpenFile>,
    /// Set by the first error: nothing more is written.
    failed: bool,
    /// The newest mission, to start each new file with.
    mission: Option<(u64, MissionRecord)>,
    last_tick: Option<u64>,
    /// The last whole second of mission time the map channels were
    /// written in.
    map_second: Option<u64>,
    sequence: u32,
    bytes_total: u64,
    /// The latest log time written, in any file.
    latest: u64,
    /// A directory's closed recordings, for the retention; made when the
    /// first file is open.
    shelf: Option<Shelf>,
}

impl Writer {
    fn new(config: RecorderConfig) -> Writer {
        Writer {
            config,
            file: None,
            failed: false,
            mission: None,
            last_tick: None,
            map_second: None,
            sequence: 0,
            bytes_total: 0,
            latest: 0,
            shelf: None,
        }
    }

    /// Runs `f` unless the recording has failed; its error fails it.
    fn guard(&mut self, f: impl FnOnce(&mut Writer) -> Result<(), RecordError>) {
        if self.failed {
            return;
        }
        if let Err(e) = f(self) {
            tracing::error!(error = %crate::chain::Chain(&e), "recording stopped; the coordinator goes on without it");
            metrics::counter!(ERRORS).increment(1);
            metrics::gauge!(ACTIVE).set(0.0);
            self.failed = true;
            // What was written before stays readable (whole chunks). The
            // failed writer is not dropped: when a chunk fails to start
            // (mcap 0.24, `start_chunk`), mcap drops its file and keeps no
            // state, and its Drop (which finishes the file) then panics
            // ("self.writer should never be None"; the test below hits
            // it). Forgetting leaks only bookkeeping, once per process.
            if let Some(f) = self.file.take() {
                std::mem::forget(f.mcap);
            }
        }
    }

    fn path_for_new_file(&self) -> Result<PathBuf, RecordError> {
        match &self.config.target {
            Target::File(path) => Ok(path.clone()),
            Target::Directory { dir, .. } => {
                std::fs::create_dir_all(dir).map_err(|source| RecordError::Directory {
                    path: dir.clone(),
                    source,
                })?;
                Ok(unused_name(dir, &utc_stamp()))
            }
        }
    }

    fn open(&mut self) -> Result<(), RecordError> {
        let path = self.path_for_new_file()?;
        let file = File::create(&path).map_err(|source| RecordError::File {
            path: path.clone(),
            source,
        })?;
        let options = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .profile("")
            .library(concat!("seacover ", env!("CARGO_PKG_VERSION")))
            // Chunks are closed by time (below) and, in a big fleet, by
            // size: zstd compresses a chunk that fits its window (512 KiB
            // at level 1) in one pass, and a longer one with the slower
            // external-dictionary path once its buffer wraps; at 1000
            // vessels 256 KiB chunks cost the writer ~15 % less CPU for the
            // same file size.
            .chunk_size(Some(256 * 1024))
            // One thread: the recorder's cost is this thread's, measured.
            .compression_threads(0)
            // zstd's level 1: at 1000 vessels (about 10 MB/s of JSON) it
            // costs half the CPU of the default level 3 for files 4 % larger
            // (docs/recording.md).
            .compression_level(1);
        let mcap = options
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(|source| RecordError::Mcap {
                path: path.clone(),
                source,
            })?;
        tracing::info!(path = %path.display(), "recording");
        metrics::gauge!(ACTIVE).set(1.0);
        self.file = Some(OpenFile {
            mcap,
            path,
            channels: HashMap::new(),
            span: None,
            chunk_first: None,
            flushed: Instant::now(),
            size: 0,
            floor: self.latest,
        });
        if let Some((log, mission)) = self.mission.clone() {
            // Restated when the file starts (its record keeps the time of
            // the change), so that the file's log times, and the span a
            // reader sees, begin there and not hours earlier. The file's
            // own span (for the retention) leaves it out.
            self.put(
                messages::MISSION,
                messages::spec::<MissionRecord>,
                log,
                &mission,
            )?;
            if let Some(f) = self.file.as_mut() {
                f.span = None;
            }
        }
        if self.shelf.is_none()
            && let (Target::Directory { dir, keep, .. }, Some(f)) =
                (&self.config.target, &self.file)
        {
            // Earlier runs' files, read once; from here on the writer knows
            // every file it closes.
            let mut shelf = Shelf::scan(dir, &f.path, *keep);
            shelf.prune(0, 0);
            self.shelf = Some(shelf);
        }
        Ok(())
    }

    fn close(&mut self) -> Result<(), RecordError> {
        if let Some(mut f) = self.file.take() {
            f.mcap.finish().map_err(|source| RecordError::Mcap {
                path: f.path.clone(),
                source,
            })?;
            let mut inner = f.mcap.into_inner();
            inner.flush().map_err(|source| RecordError::File {
                path: f.path.clone(),
                source,
            })?;
            tracing::info!(path = %f.path.display(), "recording closed");
            if let Some(shelf) = self.shelf.as_mut() {
                let size = std::fs::metadata(&f.path).map_or(f.size, |m| m.len());
                shelf.closed(f.path, size, f.span.map_or(0, |(lo, hi)| hi - lo));
            }
        }
        Ok(())
    }

    /// Closes the open chunk when it is a second old (wall); rotates the
    /// file when it is too big or spans too much mission time; after a
    /// flush, deletes what the retention no longer keeps.
    fn flush_if_due(&mut self) -> Result<(), RecordError> {
        let due = self
            .file
            .as_ref()
            .is_some_and(|f| f.chunk_first.is_some() && f.flushed.elapsed() >= CHUNK_WALL);
        if due {
            self.flush()?;
        }
        let rotated = self.rotate_if_due()?;
        if due
            && !rotated
            && let (Some(shelf), Some(f)) = (self.shelf.as_mut(), &self.file)
        {
            shelf.prune(f.size, f.spanned());
        }
        Ok(())
    }

    /// Rotates the file when it is too big or spans too much mission time,
    /// then deletes what the retention no longer keeps. Checked after every
    /// entry as well as after each batch: a warped run takes in minutes of
    /// mission time at once when the machine is busy, and a file must not
    /// span its batch past `max_duration` (4.3 s past the hour at warp 400
    /// on CI's two cores, with a check per batch).
    fn rotate_if_due(&mut self) -> Result<bool, RecordError> {
        let mut rotated = false;
        if let (
            Some(f),
            Target::Directory {
                max_bytes,
                max_duration,
                keep,
                ..
            },
        ) = (&self.file, &self.config.target)
            // Only a file with something flushed in it is rotated, so that
            // `--record-max-mb 0` means a file a second, not a file a loop.
            && f.size > 0
            && (f.size >= keep.rotation_bytes(*max_bytes)
                || u128::from(f.spanned()) >= max_duration.as_nanos())
        {
            self.close()?;
            self.open()?;
            rotated = true;
        }
        if rotated && let (Some(shelf), Some(f)) = (self.shelf.as_mut(), &self.file) {
            shelf.prune(f.size, f.spanned());
        }
        Ok(rotated)
    }

    fn flush(&mut self) -> Result<(), RecordError> {
        let Some(f) = self.file.as_mut() else {
            return Ok(());
        };
        f.mcap.flush().map_err(|source| RecordError::Mcap {
            path: f.path.clone(),
            source,
        })?;
        f.chunk_first = None;
        f.flushed = Instant::now();
        let size = std::fs::metadata(&f.path).map_or(f.size, |m| m.len());
        self.bytes_total += size.saturating_sub(f.size);
        metrics::counter!(BYTES).increment(size.saturating_sub(f.size));
        f.size = size;
        Ok(())
    }

    /// Writes one message on `topic` (its channel added to this file on
    /// first use).
    fn put<T: Serialize>(
        &mut self,
        topic: &str,
        spec: fn() -> messages::ChannelSpec,
        stamp: u64,
        message: &T,
    ) -> Result<(), RecordError> {
        // Logged no earlier than the file opened: an event stamped on a
        // link's thread just before the tick that rotated the file reaches
        // the writer after it, and would otherwise precede the restated
        // mission in log-time order. Its stamp stays its publish time (and
        // in the record itself).
        let log_time = self.file.as_ref().map_or(stamp, |f| stamp.max(f.floor));
        // A chunk spans at most a second of mission time.
        if self
            .file
            .as_ref()
            .and_then(|f| f.chunk_first)
            .is_some_and(|(lo, hi)| log_time.max(hi) - log_time.min(lo) >= CHUNK_SPAN)
        {
            self.flush()?;
        }
        let publish_time = if self.config.wall_clock {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos() as u64)
        } else {
            stamp
        };
        let sequence = self.sequence;
        self.sequence = self.sequence.wrapping_add(1);
        let Some(f) = self.file.as_mut() else {
            return Ok(());
        };
        let mcap_error = |path: &Path| {
            let path = path.to_path_buf();
            move |source| RecordError::Mcap { path, source }
        };
        let channel = match f.channels.get(topic) {
            Some(id) => *id,
            None => {
                let spec = spec();
                let schema = f
                    .mcap
                    .add_schema(&spec.schema_name, "jsonschema", &spec.schema)
                    .map_err(mcap_error(&f.path))?;
                let id = f
                    .mcap
                    .add_channel(schema, topic, "json", &Default::default())
                    .map_err(mcap_error(&f.path))?;
                f.channels.insert(topic.to_string(), id);
                id
            }
        };
        let data = serde_json::to_vec(message).expect("records serialize");
        f.mcap
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence,
                    log_time,
                    publish_time,
                },
                &data,
            )
            .map_err(mcap_error(&f.path))?;
        let widen = |span: Option<(u64, u64)>| {
            Some(match span {
                Some((lo, hi)) => (lo.min(log_time), hi.max(log_time)),
                None => (log_time, log_time),
            })
        };
        f.chunk_first = widen(f.chunk_first);
        f.span = widen(f.span);
        self.latest = self.latest.max(log_time);
        Ok(())
    }

    fn write(&mut self, entry: Entry) -> Result<(), RecordError> {
        match entry {
            Entry::Pose { vessel, time, pose } => {
                let record = PoseOut {
                    vessel: &vessel,
                    time,
                    pose: &pose,
                };
                self.put(
                    messages::POSE,
                    messages::spec::<PoseRecord>,
                    ns(time),
                    &record,
                )
            }
            Entry::Tick(snapshot) => self.tick(&snapshot),
            Entry::Mission { time, mission } => {
                let record = MissionRecord {
                    time,
                    mission: *mission,
                };
                let log = ns(time);
                self.put(
                    messages::MISSION,
                    messages::spec::<MissionRecord>,
                    log,
                    &record,
                )?;
                self.mission = Some((log, record));
                Ok(())
            }
            Entry::Event(event) => {
                let log = ns(event.time);
                self.put(
                    messages::EVENTS,
                    messages::spec::<EventRecord>,
                    log,
                    &*event,
                )
            }
            Entry::SimVessel(record) => {
                let log = ns(record.time);
                self.put(
                    messages::SIM_VESSEL,
                    messages::spec::<SimVesselRecord>,
                    log,
                    &*record,
                )
            }
            Entry::Beacon(record) => self.put(
                messages::PEER_BEACON,
                messages::spec::<messages::BeaconRecord>,
                ns(record.time),
                &*record,
            ),
            Entry::Sample(record) => self.put(
                messages::SAMPLE,
                messages::spec::<messages::SampleRecord>,
                ns(record.time),
                &*record,
            ),
            Entry::Belief(record) => self.put(
                messages::BELIEF,
                messages::spec::<messages::BeliefRecord>,
                ns(record.time),
                &*record,
            ),
            Entry::Finish => Ok(()),
        }
    }

    fn tick(&mut self, snapshot: &Snapshot) -> Result<(), RecordError> {
        let doc = &snapshot.document;
        if self.last_tick.is_some_and(|t| t >= doc.tick) {
            return Ok(());
        }
        self.last_tick = Some(doc.tick);
        let log = ns(doc.time);
        for v in &doc.vessels {
            if let Some(c) = &v.last_command
                && v.connected
                && c.tick == doc.tick
            {
                let out = CommandOut {
                    vessel: &v.id,
                    tick: doc.tick,
                    command: c,
                };
                self.put(
                    messages::COMMAND,
                    messages::spec::<CommandRecord>,
                    log,
                    &out,
                )?;
            }
        }
        let coverage = messages::CoverageRecord {
            tick: doc.tick,
            time: doc.time,
            h: doc.h,
            cells: snapshot
                .coverage
                .cells
                .iter()
                .map(messages::CellRecord::of)
                .collect(),
            vessels: doc
                .vessels
                .iter()
                .map(|v| VesselState {
                    id: v.id.clone(),
                    connected: v.connected,
                    live: v.live,
                    controlled: v.controlled,
                    last_seen: v.last_seen,
                    actuator: (v.actuator != doc.mission.actuator).then_some(v.actuator),
                })
                .collect(),
        };
        self.put(
            messages::COVERAGE,
            messages::spec::<messages::CoverageRecord>,
            log,
            &coverage,
        )?;
        self.map(snapshot, log)
    }

    /// Foxglove's map channels, once per second of mission time, for a
    /// geo-referenced mission.
    fn map(&mut self, snapshot: &Snapshot, log: u64) -> Result<(), RecordError> {
        let doc = &snapshot.document;
        let Some(frame) = doc
            .mission
            .origin
            .and_then(|o| crate::mission::origin_frame(o).ok())
        else {
            return Ok(());
        };
        let second = log / 1_000_000_000;
        if self.map_second.is_some_and(|s| s >= second) {
            return Ok(());
        }
        self.map_second = Some(second);
        for v in &doc.vessels {
            let Some(p) = &v.pose else { continue };
            let ll = frame.to_geodetic(p.x, p.y);
            let fix = LocationFix {
                timestamp: FoxgloveTime::from_ns(log),
                frame_id: v.id.clone(),
                latitude: ll.lat,
                longitude: ll.lon,
                altitude: 0.0,
                position_covariance: [0.0; 9],
                position_covariance_type: 0,
            };
            let topic = format!("{}{}", messages::MAP_FIX_PREFIX, v.id);
            self.put(&topic, messages::spec::<LocationFix>, log, &fix)?;
        }
        let collection = crate::mission::georef::output::coverage(
            &frame,
            &snapshot.coverage.cells,
            &doc.vessels,
        );
        let geojson = GeoJson {
            geojson: collection.to_string(),
        };
        self.put(
            messages::MAP_CELLS,
            messages::spec::<GeoJson>,
            log,
            &geojson,
        )
    }
}

/// Lowers this thread's scheduling priority to the least (Linux nice 19):
/// the coordinator's tick and links then run first whenever the cores are
/// busy, and the writer catches up from the hand-over's buffer (seconds of
/// entries) when they are idle. Without it a 1000-vessel recording moved the
/// command p99 by about a millisecond (docs/recording.md). Elsewhere, and where the call is refused, the thread keeps
/// its priority.
fn yield_to_the_coordinator() {
    #[cfg(target_os = "linux")]
    // SAFETY: gettid and setpriority take and return plain integers; the
    // who argument is this thread's own id.
    unsafe {
        let tid = libc::gettid();
        if libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, 19) != 0 {
            tracing::debug!("the recorder thread keeps its priority");
        }
    }
}

/// `2026-11-23T10-00-00Z`: the UTC time now, in a file name every file
/// system takes.
fn utc_stamp() -> String {
    let format =
        time::macros::format_description!("[year]-[month]-[day]T[hour]-[minute]-[second]Z");
    time::OffsetDateTime::now_utc()
        .format(&format)
        .unwrap_or_else(|_| "recording".into())
}

/// A new recording's file in `dir`, named by the UTC time now, as every
/// process that records names its files.
pub fn new_file(dir: &Path) -> PathBuf {
    unused_name(dir, &utc_stamp())
}

/// `dir/stamp.mcap`, or `dir/stamp-N.mcap` when that exists (two files
/// started within one second: a rotation right after a start).
fn unused_name(dir: &Path, stamp: &str) -> PathBuf {
    let first = dir.join(format!("{stamp}.mcap"));
    if !first.exists() {
        return first;
    }
    (1..)
        .map(|n| dir.join(format!("{stamp}-{n}.mcap")))
        .find(|p| !p.exists())
        .expect("some name is free")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_do_not_collide() {
        let dir = tempfile::tempdir().unwrap();
        let a = unused_name(dir.path(), "2026-11-23T10-00-00Z");
        std::fs::write(&a, b"").unwrap();
        let b = unused_name(dir.path(), "2026-11-23T10-00-00Z");
        assert_eq!(b.file_name().unwrap(), "2026-11-23T10-00-00Z-1.mcap");
        assert!(utc_stamp().ends_with('Z'));
    }

    /// A full disk (Linux's /dev/full answers every write with ENOSPC)
    /// stops the recording at its first flush, and nothing panics or
    /// writes on: the writer is dropped without finishing the file.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_full_disk_stops_the_recording() {
        let mut w = Writer::new(RecorderConfig {
            target: Target::File("/dev/full".into()),
            wall_clock: false,
        });
        w.guard(|w| w.open());
        assert!(
            !w.failed && w.file.is_some(),
            "opening buffers, writes nothing"
        );
        for i in 0..100 {
            let event = EventRecord::new(f64::from(i) * 0.1, messages::EventKind::LinkUp);
            w.guard(|w| w.write(Entry::Event(Box::new(event))));
        }
        w.guard(|w| w.flush());
        assert!(w.failed, "ENOSPC fails the recording");
        assert!(w.file.is_none());
        // Whatever comes after is dropped, not written.
        w.guard(|w| {
            w.write(Entry::Event(Box::new(EventRecord::new(
                11.0,
                messages::EventKind::Shutdown,
            ))))
        });
        w.guard(|w| w.close());
        assert!(w.failed && w.file.is_none());
    }
}
