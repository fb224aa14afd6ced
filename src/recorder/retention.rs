//! Which recordings a directory keeps (`serve --record-keep`, docs/recording.md):
//! the limits an operator sets ([`Limit`], [`Keep`]) and the writer's list
//! of the files it may delete ([`Shelf`]), oldest first.
//!
//! Invariants:
//! - only files named as the recorder names them
//!   (`YYYY-MM-DDTHH-MM-SSZ.mcap`, `…Z-N.mcap`) are counted or deleted;
//!   anything else in the directory is left alone;
//! - files go oldest first, by the UTC start in their names, and the file
//!   being written is never deleted (it counts towards both limits);
//! - a byte limit is a ceiling on the directory's recordings, the open file
//!   included: after every flush the closed files are deleted oldest first
//!   until they fit (the writer rotates at a quarter of the limit at most,
//!   so the open file alone never fills it);
//! - a time limit counts recorded mission time, not the wall clock: a
//!   closed file is deleted once `keep` of mission time has been recorded
//!   after its last message, in the files after it (this run's and earlier
//!   runs'). What stays spans at most `keep` plus one file
//!   (`--record-max-minutes`), and a coordinator that was down for a day
//!   does not lose a day of recordings to the downtime. A file's span is
//!   read from its summary's statistics; a file cut short (`kill -9`) has
//!   none and counts as no time, so the files before it are kept that
//!   much longer;
//! - the shelf holds one entry per file kept, so its memory is bounded by
//!   the limits themselves.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Duration;

/// Files deleted by the retention.
pub const DELETED: &str = "seacover_recording_files_deleted_total";
/// Bytes of recordings in the directory (closed files and the open one)
/// after the last retention pass.
pub const KEPT_BYTES: &str = "seacover_recording_kept_bytes";

/// The default `--record-keep`: three days of mission time or 5 GB,
/// whichever is reached first (at 8 vessels, about 94 MB per hour: 53 h).
pub const DEFAULT_KEEP: [&str; 2] = ["72h", "5GB"];

/// One limit of `--record-keep`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Limit {
    /// Mission time recorded (`48h`, `90m`, `3d`, `30s`).
    Recorded(Duration),
    /// Bytes on disk (`5GB`, `500MB`, decimal; `2GiB`, binary).
    Bytes(u64),
}

/// A `--record-keep` value that is not a positive time or size.
#[derive(Debug, thiserror::Error)]
#[error(
    "{0:?} is not a positive time (48h, 90m, 3d, 30s) or size (5GB, 500MB, 2GiB) of recordings to keep"
)]
pub struct LimitError(String);

impl FromStr for Limit {
    type Err = LimitError;

    fn from_str(s: &str) -> Result<Limit, LimitError> {
        let bad = || LimitError(s.to_string());
        let text = s.trim();
        let split = text
            .find(|c: char| c.is_ascii_alphabetic())
            .ok_or_else(bad)?;
        let (number, unit) = text.split_at(split);
        let value: f64 = number.trim().parse().map_err(|_| bad())?;
        if !(value.is_finite() && value > 0.0) {
            return Err(bad());
        }
        let seconds = |per: f64| {
            Duration::try_from_secs_f64(value * per)
                .map(Limit::Recorded)
                .map_err(|_| bad())
        };
        let bytes = |per: f64| {
            let b = value * per;
            // Below a byte is no limit anyone means; past u64 is none either.
            if (1.0..1.8e19).contains(&b) {
                Ok(Limit::Bytes(b as u64))
            } else {
                Err(bad())
            }
        };
        match unit.to_ascii_lowercase().as_str() {
            "s" => seconds(1.0),
            "m" | "min" => seconds(60.0),
            "h" => seconds(3600.0),
            "d" => seconds(86_400.0),
            "b" => bytes(1.0),
            "kb" => bytes(1e3),
            "mb" => bytes(1e6),
            "gb" => bytes(1e9),
            "tb" => bytes(1e12),
            "kib" => bytes(1024.0),
            "mib" => bytes(1024.0 * 1024.0),
            "gib" => bytes(1024.0 * 1024.0 * 1024.0),
            "tib" => bytes(1024.0 * 1024.0 * 1024.0 * 1024.0),
            _ => Err(bad()),
        }
    }
}

/// What a recordings directory keeps: the tightest limit of each kind
/// given; both apply (whichever deletes more). `Keep::default()` keeps
/// everything, as the simulator's single file does.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Keep {
    pub recorded: Option<Duration>,
    pub bytes: Option<u64>,
}

impl Keep {
    pub fn new(limits: &[Limit]) -> Keep {
        let mut keep = Keep::default();
        for limit in limits {
            match *limit {
                Limit::Recorded(d) => keep.recorded = Some(keep.recorded.map_or(d, |k| k.min(d))),
                Limit::Bytes(b) => keep.bytes = Some(keep.bytes.map_or(b, |k| k.min(b))),
            }
        }
        keep
    }

    /// [`DEFAULT_KEEP`].
    pub fn standard() -> Keep {
        let limits: Vec<Limit> = DEFAULT_KEEP
            .iter()
            .map(|s| s.parse().expect("the default parses"))
            .collect();
        Keep::new(&limits)
    }

    /// The size at which the writer rotates: `max_bytes`, or a quarter of
    /// the byte limit if that is smaller, so that the open file leaves room
    /// for older ones and never fills the limit by itself.
    pub fn rotation_bytes(&self, max_bytes: u64) -> u64 {
        self.bytes.map_or(max_bytes, |b| max_bytes.min(b / 4))
    }
}

/// A closed recording the shelf may delete.
#[derive(Debug)]
struct Kept {
    path: PathBuf,
    bytes: u64,
    /// Mission time it records [ns].
    span: u64,
}

/// The closed recordings of a directory, oldest first, with their totals.
#[derive(Debug)]
pub(super) struct Shelf {
    keep: Keep,
    files: VecDeque<Kept>,
    bytes: u64,
    span: u64,
}

impl Shelf {
    /// The recordings already in `dir` (earlier runs), except `open`, the
    /// file being written.
    pub(super) fn scan(dir: &Path, open: &Path, keep: Keep) -> Shelf {
        let mut found: Vec<((String, u32), PathBuf)> = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .filter_map(Result::ok)
            .filter_map(|e| {
                let path = e.path();
                let order = recording_order(path.file_name()?.to_str()?)?;
                (path != open).then_some((order, path))
            })
            .collect();
        found.sort();
        let mut shelf = Shelf {
            keep,
            files: VecDeque::new(),
            bytes: 0,
            span: 0,
        };
        for (_, path) in found {
            let Ok(meta) = std::fs::metadata(&path) else {
                continue;
            };
            let span = recorded_span(&path).unwrap_or(0);
            shelf.closed(path, meta.len(), span);
        }
        shelf
    }

    /// A file the writer has just closed, the newest.
    pub(super) fn closed(&mut self, path: PathBuf, bytes: u64, span: u64) {
        self.bytes += bytes;
        self.span += span;
        self.files.push_back(Kept { path, bytes, span });
    }

    /// Deletes the oldest closed files while the limits are exceeded, the
    /// open file having `open_bytes` and recording `open_span` [ns];
    /// returns the bytes of recordings left.
    pub(super) fn prune(&mut self, open_bytes: u64, open_span: u64) -> u64 {
        while let Some(oldest) = self.files.front() {
            let over_bytes = self.keep.bytes.is_some_and(|b| self.bytes + open_bytes > b);
            // Mission time recorded after the oldest file's last message.
            let after = self.span - oldest.span + open_span;
            let over_time = self
                .keep
                .recorded
                .is_some_and(|k| u128::from(after) >= k.as_nanos());
            if !(over_bytes || over_time) {
                break;
            }
            let oldest = self.files.pop_front().expect("a front");
            self.bytes -= oldest.bytes;
            self.span -= oldest.span;
            match std::fs::remove_file(&oldest.path) {
                Ok(()) => {
                    tracing::info!(path = %oldest.path.display(), "recording deleted (--record-keep)");
                    metrics::counter!(DELETED).increment(1);
                }
                // Already gone (an operator cleaning up) is what we wanted.
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                // Not fatal: the recording goes on; the file is forgotten
                // rather than retried every flush.
                Err(e) => {
                    tracing::warn!(path = %oldest.path.display(), error = %e, "an old recording could not be deleted");
                }
            }
        }
        let kept = self.bytes + open_bytes;
        metrics::gauge!(KEPT_BYTES).set(kept as f64);
        kept
    }

    #[cfg(test)]
    fn paths(&self) -> Vec<&Path> {
        self.files.iter().map(|f| f.path.as_path()).collect()
    }
}

/// The order of a file named as the recorder names them
/// (`2026-11-23T10-00-00Z.mcap`, then `…Z-1.mcap`, `…Z-2.mcap` for files
/// started in the same second), or `None` for any other name.
fn recording_order(name: &str) -> Option<(String, u32)> {
    let stem = name.strip_suffix(".mcap")?;
    let (stamp, n) = match stem.get(20..) {
        Some("") => (stem, 0),
        Some(rest) => (&stem[..20], rest.strip_prefix('-')?.parse().ok()?),
        None => return None,
    };
    let shape = stamp.bytes().enumerate().all(|(i, b)| match i {
        4 | 7 | 13 | 16 => b == b'-',
        10 => b == b'T',
        19 => b == b'Z',
        _ => b.is_ascii_digit(),
    });
    (shape && stamp.len() == 20).then(|| (stamp.to_string(), n))
}

/// The mission time a finished recording spans [ns], from its summary's
/// statistics: the footer (the last 37 bytes) says where the summary is,
/// and only the summary (a few hundred kB at most) is read.
fn recorded_span(path: &Path) -> Option<u64> {
    const FOOTER: u64 = 1 + 8 + 8 + 8 + 4 + 8;
    let mut file = File::open(path).ok()?;
    let len = file.metadata().ok()?.len();
    if len < FOOTER + 8 {
        return None;
    }
    let mut footer = [0u8; FOOTER as usize];
    file.seek(SeekFrom::Start(len - FOOTER)).ok()?;
    file.read_exact(&mut footer).ok()?;
    let u64_at = |b: &[u8], i: usize| u64::from_le_bytes(b[i..i + 8].try_into().expect("8 bytes"));
    if footer[0] != mcap::records::op::FOOTER || &footer[29..] != b"\x89MCAP0\r\n" {
        return None;
    }
    let start = u64_at(&footer, 9);
    let offsets = u64_at(&footer, 17);
    let end = if offsets > 0 { offsets } else { len - FOOTER };
    if start == 0 || start >= end || end - start > 64 << 20 {
        return None;
    }
    let mut summary = vec![0u8; (end - start) as usize];
    file.seek(SeekFrom::Start(start)).ok()?;
    file.read_exact(&mut summary).ok()?;
    let mut at = 0;
    while at + 9 <= summary.len() {
        let op = summary[at];
        let body_len = usize::try_from(u64_at(&summary, at + 1)).ok()?;
        let body = summary.get(at + 9..at + 9 + body_len)?;
        if op == mcap::records::op::STATISTICS
            && let Ok(mcap::records::Record::Statistics(s)) = mcap::parse_record(op, body)
        {
            return Some(s.message_end_time.saturating_sub(s.message_start_time));
        }
        at += 9 + body_len;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_parse_as_an_operator_writes_them() {
        let h = |x: u64| Limit::Recorded(Duration::from_secs(x * 3600));
        assert_eq!("48h".parse::<Limit>().unwrap(), h(48));
        assert_eq!("3d".parse::<Limit>().unwrap(), h(72));
        assert_eq!(
            " 1.5H ".parse::<Limit>().unwrap(),
            Limit::Recorded(Duration::from_secs(5400))
        );
        assert_eq!(
            "90m".parse::<Limit>().unwrap(),
            Limit::Recorded(Duration::from_secs(5400))
        );
        assert_eq!("5GB".parse::<Limit>().unwrap(), Limit::Bytes(5_000_000_000));
        assert_eq!(
            "500 mb".parse::<Limit>().unwrap(),
            Limit::Bytes(500_000_000)
        );
        assert_eq!("2GiB".parse::<Limit>().unwrap(), Limit::Bytes(2 << 30));
        for bad in [
            "",
            "48",
            "h",
            "0h",
            "-5GB",
            "5 parsecs",
            "NaNh",
            "infh",
            "1e30TB",
        ] {
            assert!(bad.parse::<Limit>().is_err(), "{bad:?}");
        }
        let keep = Keep::new(&[h(48), Limit::Bytes(9), h(24), Limit::Bytes(7)]);
        assert_eq!(keep.recorded, Some(Duration::from_secs(24 * 3600)));
        assert_eq!(keep.bytes, Some(7));
        let standard = Keep::standard();
        assert_eq!(standard.recorded, Some(Duration::from_secs(72 * 3600)));
        assert_eq!(standard.bytes, Some(5_000_000_000));
        assert_eq!(standard.rotation_bytes(256 << 20), 256 << 20);
        assert_eq!(
            Keep::new(&[Limit::Bytes(400)]).rotation_bytes(256 << 20),
            100
        );
    }

    #[test]
    fn only_the_recorders_names_count() {
        let order = |n: &str| recording_order(n);
        assert_eq!(
            order("2026-11-23T10-00-00Z.mcap"),
            Some(("2026-11-23T10-00-00Z".into(), 0))
        );
        assert_eq!(
            order("2026-11-23T10-00-00Z-12.mcap"),
            Some(("2026-11-23T10-00-00Z".into(), 12))
        );
        // The plain name goes before its -1, -2 (which a byte sort of the
        // names would not do: '-' < '.').
        assert!(order("2026-11-23T10-00-00Z.mcap") < order("2026-11-23T10-00-00Z-1.mcap"));
        assert!(order("2026-11-23T10-00-00Z-9.mcap") < order("2026-11-23T10-00-00Z-10.mcap"));
        for other in [
            "notes.txt",
            "mine.mcap",
            "2026-11-23T10-00-00Z.mcap.bak",
            "2026-11-23 10-00-00Z.mcap",
            "2026-11-23T10-00-00Z-.mcap",
            "2026-11-23T10-00-00Zx.mcap",
            "2026-11-23T10-00-0Z.mcap",
        ] {
            assert_eq!(order(other), None, "{other}");
        }
    }

    /// Files of `span` seconds, `bytes` each, named a second apart.
    fn shelf_of(dir: &Path, n: usize, bytes: usize, keep: Keep) -> Shelf {
        let mut shelf = Shelf::scan(dir, Path::new(""), keep);
        for i in 0..n {
            let path = dir.join(format!("2026-11-23T10-00-{i:02}Z.mcap"));
            std::fs::write(&path, vec![0u8; bytes]).unwrap();
            shelf.closed(path, bytes as u64, 3_600_000_000_000);
        }
        shelf
    }

    fn names(shelf: &Shelf) -> Vec<String> {
        shelf
            .paths()
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy()[17..19].to_string())
            .collect()
    }

    #[test]
    fn a_byte_limit_is_a_ceiling_with_the_open_file_in_it() {
        let dir = tempfile::tempdir().unwrap();
        let mut shelf = shelf_of(dir.path(), 5, 100, Keep::new(&[Limit::Bytes(350)]));
        std::fs::write(dir.path().join("notes.txt"), b"kept").unwrap();
        // 500 closed + 40 open: the two oldest go (340 left).
        assert_eq!(shelf.prune(40, 0), 340);
        assert_eq!(names(&shelf), ["02", "03", "04"]);
        assert!(!dir.path().join("2026-11-23T10-00-01Z.mcap").exists());
        assert!(dir.path().join("2026-11-23T10-00-02Z.mcap").exists());
        // The open file grows past what is left: one more goes.
        assert_eq!(shelf.prune(60, 0), 260);
        assert_eq!(names(&shelf), ["03", "04"]);
        // Another directory scan finds the same, and leaves other names.
        let again = Shelf::scan(dir.path(), Path::new(""), Keep::default());
        assert_eq!(names(&again), ["03", "04"]);
        assert!(dir.path().join("notes.txt").exists());
    }

    #[test]
    fn a_time_limit_counts_what_was_recorded_after_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let keep = Keep::new(&[Limit::Recorded(Duration::from_secs(3 * 3600))]);
        // Five closed files of an hour each and an open one of 30 min.
        let mut shelf = shelf_of(dir.path(), 5, 10, keep);
        let half_hour = 1_800_000_000_000;
        shelf.prune(1, half_hour);
        // After 01 come 3.5 h (02, 03, 04, open): it goes, as 00 did;
        // after 02, 2.5 h.
        assert_eq!(names(&shelf), ["02", "03", "04"]);
        // The open file reaches an hour: 3 h after 02's end, and it goes.
        shelf.prune(1, 2 * half_hour);
        assert_eq!(names(&shelf), ["03", "04"]);
    }

    #[test]
    fn a_finished_files_span_is_read_from_its_summary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("2026-11-23T10-00-00Z.mcap");
        let mut w = mcap::WriteOptions::new()
            .create(std::io::BufWriter::new(File::create(&path).unwrap()))
            .unwrap();
        let channel = w.add_channel(0, "/t", "json", &Default::default()).unwrap();
        for (i, t) in [5_000_000_000u64, 6_000_000_000, 9_500_000_000]
            .into_iter()
            .enumerate()
        {
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence: i as u32,
                log_time: t,
                publish_time: t,
            };
            w.write_to_known_channel(&header, b"{}").unwrap();
        }
        w.finish().unwrap();
        drop(w);
        assert_eq!(recorded_span(&path), Some(4_500_000_000));
        // Cut short: no summary, no span.
        let bytes = std::fs::read(&path).unwrap();
        let cut = dir.path().join("2026-11-23T10-00-01Z.mcap");
        std::fs::write(&cut, &bytes[..bytes.len() - 40]).unwrap();
        assert_eq!(recorded_span(&cut), None);
        let shelf = Shelf::scan(dir.path(), &cut, Keep::default());
        assert_eq!((shelf.span, shelf.files.len()), (4_500_000_000, 1));
    }
}
