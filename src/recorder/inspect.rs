//! `seacover record info` and `seacover record export`: what MOOS users get
//! from alogscan and alog2csv, for a recording.
//!
//! Both read the whole file (chunk after chunk); the replay is the one
//! that must not.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;

use serde::Serialize;

use super::messages::{self, CommandRecord, CoverageRecord, PoseRecord, SimVesselRecord};
use super::reader::{ReadError, Recording};

/// A silence longer than this on a channel that should tick is a gap [s].
pub const GAP: f64 = 1.0;

/// Why inspection failed.
#[derive(Debug, thiserror::Error)]
pub enum InspectError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("a {topic} message does not read as its schema")]
    Decode {
        topic: String,
        source: serde_json::Error,
    },
    #[error("{0}")]
    Unsupported(String),
    #[error("writing")]
    Io(#[from] std::io::Error),
}

/// `seacover record info`.
#[derive(Debug, Clone, Serialize)]
pub struct Info {
    pub file: String,
    /// The file had no index (cut short) and was read by recovery.
    pub recovered: bool,
    pub chunks: usize,
    /// Mission time of the first and last message [s].
    pub start: f64,
    pub end: f64,
    pub duration: f64,
    pub vessels: Vec<String>,
    pub channels: Vec<ChannelInfo>,
    /// H at the first and the last tick with at least one vessel in the
    /// partition (a live vessel, so a cell): a tick without one has H = 0
    /// (a coordinator waiting for its first pose, or after its last), which
    /// says nothing of the coverage. `null` when no tick had a vessel.
    pub h_start: Option<f64>,
    pub h_end: Option<f64>,
    /// Mission time of those two ticks [s].
    pub h_start_time: Option<f64>,
    pub h_end_time: Option<f64>,
    /// Coverage ticks recorded, and how many of them had no vessel.
    pub ticks: usize,
    pub ticks_without_vessels: usize,
    /// Silences longer than [`GAP`] on the coverage channel (the
    /// coordinator's ticks) and in each vessel's poses.
    pub gaps: Vec<Gap>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ChannelInfo {
    pub topic: String,
    pub schema: String,
    pub messages: u64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Gap {
    /// `coverage`, or the vessel whose poses stopped.
    pub what: String,
    pub from: f64,
    pub to: f64,
}

fn decode<T: serde::de::DeserializeOwned>(topic: &str, data: &[u8]) -> Result<T, InspectError> {
    serde_json::from_slice(data).map_err(|source| InspectError::Decode {
        topic: topic.to_string(),
        source,
    })
}

fn seconds(ns: u64) -> f64 {
    ns as f64 * 1e-9
}

pub fn info(recording: &Recording) -> Result<Info, InspectError> {
    let (start, end) = recording.span().unwrap_or((0, 0));
    let mut vessels = BTreeSet::new();
    // (time, H) of the first and the last tick with vessels.
    let mut h: Option<((f64, f64), (f64, f64))> = None;
    let (mut ticks, mut ticks_without_vessels) = (0, 0);
    let mut gaps = Vec::new();
    let mut last_tick: Option<f64> = None;
    let mut last_pose: BTreeMap<String, f64> = BTreeMap::new();
    let wanted = |t: &str| t == messages::COVERAGE || t == messages::POSE;
    for m in recording.messages(&wanted) {
        let m = m?;
        let t = seconds(m.log_time);
        if &*m.topic == messages::COVERAGE {
            let c: CoverageRecord = decode(&m.topic, &m.data)?;
            vessels.extend(c.vessels.iter().map(|v| v.id.clone()));
            ticks += 1;
            if c.cells.is_empty() {
                ticks_without_vessels += 1;
            } else {
                let now = (c.time, c.h);
                h = Some(h.map_or((now, now), |(first, _)| (first, now)));
            }
            if let Some(prev) = last_tick
                && t - prev > GAP
            {
                gaps.push(Gap {
                    what: "coverage".into(),
                    from: prev,
                    to: t,
                });
            }
            last_tick = Some(t);
        } else {
            let p: PoseRecord = decode(&m.topic, &m.data)?;
            if let Some(prev) = last_pose.get(&p.vessel)
                && t - prev > GAP
            {
                gaps.push(Gap {
                    what: p.vessel.clone(),
                    from: *prev,
                    to: t,
                });
            }
            last_pose.insert(p.vessel.clone(), t);
            vessels.insert(p.vessel);
        }
    }
    gaps.sort_by(|a, b| a.from.total_cmp(&b.from));
    Ok(Info {
        file: recording.path().display().to_string(),
        recovered: recording.recovered(),
        chunks: recording.chunk_count(),
        start: seconds(start),
        end: seconds(end),
        duration: seconds(end.saturating_sub(start)),
        vessels: vessels.into_iter().collect(),
        channels: recording
            .channels()
            .into_iter()
            .map(|(c, n)| ChannelInfo {
                topic: c.topic.to_string(),
                schema: c.schema_name,
                messages: n,
            })
            .collect(),
        h_start: h.map(|h| h.0.1),
        h_end: h.map(|h| h.1.1),
        h_start_time: h.map(|h| h.0.0),
        h_end_time: h.map(|h| h.1.0),
        ticks,
        ticks_without_vessels,
        gaps,
    })
}

/// The text form of [`info`].
pub fn print_info(info: &Info, out: &mut impl Write) -> std::io::Result<()> {
    writeln!(out, "file      {}", info.file)?;
    if info.recovered {
        writeln!(
            out,
            "          no index (the recording was cut short): {} whole chunks recovered",
            info.chunks
        )?;
    }
    writeln!(
        out,
        "duration  {:.1} s (mission time {:.1} – {:.1} s), {} chunks",
        info.duration, info.start, info.end, info.chunks
    )?;
    writeln!(
        out,
        "vessels   {} ({})",
        info.vessels.len(),
        names(&info.vessels)
    )?;
    match (info.h_start, info.h_end, info.h_start_time, info.h_end_time) {
        (Some(h0), Some(h1), Some(t0), Some(t1)) => writeln!(
            out,
            "H         {h0:.6} at {t0:.1} s, {h1:.6} at {t1:.1} s (the first and last of the ticks with vessels: {} of {})",
            info.ticks - info.ticks_without_vessels,
            info.ticks
        )?,
        _ if info.ticks == 0 => writeln!(out, "H         - (no coverage ticks)")?,
        _ => writeln!(
            out,
            "H         - (none of the {} ticks had a vessel)",
            info.ticks
        )?,
    }
    writeln!(out, "channels")?;
    for c in &info.channels {
        writeln!(out, "  {:<32} {:>9}  {}", c.topic, c.messages, c.schema)?;
    }
    if info.gaps.is_empty() {
        writeln!(out, "gaps      none longer than {GAP} s")?;
    } else {
        writeln!(out, "gaps      (silences longer than {GAP} s)")?;
        for g in &info.gaps {
            writeln!(
                out,
                "  {:<16} {:.1} – {:.1} s ({:.1} s)",
                g.what,
                g.from,
                g.to,
                g.to - g.from
            )?;
        }
    }
    Ok(())
}

/// A fleet's ids for one line: all of a small fleet, the first few and the
/// last of a big one (`--json` lists them all).
fn names(ids: &[String]) -> String {
    const SHOWN: usize = 12;
    if ids.len() <= SHOWN {
        return ids.join(", ");
    }
    format!(
        "{}, … {} more …, {}",
        ids[..SHOWN - 1].join(", "),
        ids.len() - SHOWN,
        ids[ids.len() - 1]
    )
}

/// Export formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// One row per message, columns by channel (see [`export`]).
    Csv,
    /// One JSON object per line: `log_time` [ns], `publish_time`, `topic`,
    /// `message`.
    Jsonl,
}

/// `seacover record export`: the messages of `channel` as CSV or JSON
/// lines. CSV columns:
/// - `/seacover/coverage`: `time,tick,H` then one `E:<vessel>` column per
///   vessel (its distance to its centroid, from that tick's command; empty
///   when it had none);
/// - `/seacover/pose`: `time,vessel,t,x,y,psi,u,v,r,controlled`;
/// - `/seacover/command`: `time,vessel,tick,u_d,r_d,u_d_dot,r_d_dot,centroid_x,centroid_y,E,psi_e`;
/// - `/seacover/sim/vessel`: `time,vessel,x,y,psi,u,v,r,d_u,d_v,d_r,dhat_u,dhat_v,dhat_r`.
pub fn export(
    recording: &Recording,
    channel: &str,
    format: Format,
    out: &mut impl Write,
) -> Result<(), InspectError> {
    if !recording
        .channels()
        .iter()
        .any(|(c, _)| &*c.topic == channel)
    {
        let topics: Vec<String> = recording
            .channels()
            .into_iter()
            .map(|(c, _)| c.topic.to_string())
            .collect();
        return Err(InspectError::Unsupported(format!(
            "no channel {channel:?} in this recording (it has {})",
            topics.join(", ")
        )));
    }
    if format == Format::Jsonl {
        for m in recording.messages(&|t| t == channel) {
            let m = m?;
            let message: serde_json::Value = decode(&m.topic, &m.data)?;
            serde_json::to_writer(
                &mut *out,
                &serde_json::json!({
                    "log_time": m.log_time,
                    "publish_time": m.publish_time,
                    "topic": &*m.topic,
                    "message": message,
                }),
            )
            .map_err(std::io::Error::from)?;
            writeln!(out)?;
        }
        return Ok(());
    }
    match channel {
        messages::COVERAGE => coverage_csv(recording, out),
        messages::POSE => {
            writeln!(out, "time,vessel,t,x,y,psi,u,v,r,controlled")?;
            for m in recording.messages(&|t| t == channel) {
                let m = m?;
                let r: PoseRecord = decode(&m.topic, &m.data)?;
                let p = r.pose;
                writeln!(
                    out,
                    "{},{},{},{},{},{},{},{},{},{}",
                    r.time,
                    r.vessel,
                    p.t,
                    p.x,
                    p.y,
                    p.psi,
                    p.u,
                    p.v,
                    p.r,
                    p.controlled.unwrap_or(true)
                )?;
            }
            Ok(())
        }
        messages::COMMAND => {
            writeln!(
                out,
                "time,vessel,tick,u_d,r_d,u_d_dot,r_d_dot,centroid_x,centroid_y,E,psi_e"
            )?;
            for m in recording.messages(&|t| t == channel) {
                let m = m?;
                let r: CommandRecord = decode(&m.topic, &m.data)?;
                let c = r.command;
                writeln!(
                    out,
                    "{},{},{},{},{},{},{},{},{},{},{}",
                    seconds(m.log_time),
                    r.vessel,
                    r.tick,
                    c.u_d,
                    c.r_d,
                    c.u_d_dot,
                    c.r_d_dot,
                    c.centroid[0],
                    c.centroid[1],
                    c.e,
                    c.psi_e
                )?;
            }
            Ok(())
        }
        messages::SIM_VESSEL => {
            writeln!(
                out,
                "time,vessel,x,y,psi,u,v,r,d_u,d_v,d_r,dhat_u,dhat_v,dhat_r"
            )?;
            for m in recording.messages(&|t| t == channel) {
                let m = m?;
                let r: SimVesselRecord = decode(&m.topic, &m.data)?;
                let cols: Vec<String> = r
                    .truth
                    .iter()
                    .chain(&r.disturbance)
                    .chain(&r.estimate)
                    .map(|v| v.to_string())
                    .collect();
                writeln!(out, "{},{},{}", r.time, r.vessel, cols.join(","))?;
            }
            Ok(())
        }
        other => Err(InspectError::Unsupported(format!(
            "{other} has no CSV form; --format jsonl exports any channel"
        ))),
    }
}

/// H over time and each vessel's E, one row per tick.
fn coverage_csv(recording: &Recording, out: &mut impl Write) -> Result<(), InspectError> {
    // Two passes over the file would read it twice; a tick's row needs the
    // set of every vessel first, so rows are kept (a few numbers a tick).
    let mut rows: Vec<(f64, u64, f64, BTreeMap<String, f64>)> = Vec::new();
    let mut vessels = BTreeSet::new();
    let mut by_tick: BTreeMap<u64, usize> = BTreeMap::new();
    let mut pending: Vec<CommandRecord> = Vec::new();
    let wanted = |t: &str| t == messages::COVERAGE || t == messages::COMMAND;
    for m in recording.messages(&wanted) {
        let m = m?;
        if &*m.topic == messages::COVERAGE {
            let c: CoverageRecord = decode(&m.topic, &m.data)?;
            by_tick.insert(c.tick, rows.len());
            rows.push((c.time, c.tick, c.h, BTreeMap::new()));
        } else {
            pending.push(decode(&m.topic, &m.data)?);
        }
    }
    for c in pending {
        if let Some(&i) = by_tick.get(&c.tick) {
            vessels.insert(c.vessel.clone());
            rows[i].3.insert(c.vessel, c.command.e);
        }
    }
    write!(out, "time,tick,H")?;
    for v in &vessels {
        write!(out, ",E:{v}")?;
    }
    writeln!(out)?;
    for (time, tick, h, es) in rows {
        write!(out, "{time},{tick},{h}")?;
        for v in &vessels {
            match es.get(v) {
                Some(e) => write!(out, ",{e}")?,
                None => write!(out, ",")?,
            }
        }
        writeln!(out)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::names;
    use super::{info, print_info};
    use crate::recorder::messages::{self, CellRecord, CoverageRecord, VesselState};
    use crate::recorder::reader::Recording;

    /// A recording of coverage ticks `(time, H, with a vessel)`, written
    /// with the mcap crate as the recorder writes its channels.
    fn coverage_recording(ticks: &[(f64, f64, bool)]) -> Recording {
        let mut w = mcap::Writer::new(std::io::Cursor::new(Vec::new())).expect("a writer");
        let spec = messages::spec::<CoverageRecord>();
        let schema = w
            .add_schema(&spec.schema_name, "jsonschema", &spec.schema)
            .expect("a schema");
        let channel = w
            .add_channel(schema, messages::COVERAGE, "json", &Default::default())
            .expect("a channel");
        for (k, &(time, h, vessel)) in ticks.iter().enumerate() {
            let record = CoverageRecord {
                tick: k as u64,
                time,
                h,
                cells: if vessel {
                    vec![CellRecord {
                        id: "usv-1".into(),
                        mass: h,
                        centroid: [50.0, 50.0],
                        area: 10_000.0,
                        polygon: None,
                        pieces: Vec::new(),
                        edges: Vec::new(),
                    }]
                } else {
                    Vec::new()
                },
                vessels: vec![VesselState {
                    id: "usv-1".into(),
                    connected: vessel,
                    live: vessel,
                    controlled: vessel,
                    last_seen: None,
                    actuator: None,
                }],
            };
            let ns = (time * 1e9).round() as u64;
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: k as u32,
                    log_time: ns,
                    publish_time: ns,
                },
                &serde_json::to_vec(&record).expect("serializes"),
            )
            .expect("written");
        }
        w.finish().expect("finished");
        let bytes = w.into_inner().into_inner();
        Recording::from_bytes(std::path::Path::new("test.mcap"), bytes).expect("reads back")
    }

    #[test]
    fn h_is_reported_over_the_ticks_with_vessels() {
        // A bridge's recording: no vessel at the first tick (waiting for
        // the first pose) nor at the last two (the link gone).
        let recording = coverage_recording(&[
            (0.0, 0.0, false),
            (0.1, 6500.25, true),
            (0.2, 6480.0, true),
            (0.3, 6512.5, true),
            (0.4, 0.0, false),
            (0.5, 0.0, false),
        ]);
        let i = info(&recording).expect("info");
        assert_eq!((i.h_start, i.h_end), (Some(6500.25), Some(6512.5)));
        assert_eq!((i.h_start_time, i.h_end_time), (Some(0.1), Some(0.3)));
        assert_eq!((i.ticks, i.ticks_without_vessels), (6, 3));
        let mut text = Vec::new();
        print_info(&i, &mut text).expect("printed");
        let text = String::from_utf8(text).expect("UTF-8");
        assert!(
            text.contains(
                "H         6500.250000 at 0.1 s, 6512.500000 at 0.3 s (the first and last of the ticks with vessels: 3 of 6)"
            ),
            "{text}"
        );
        // No tick with a vessel: no H, and the line says why.
        let empty =
            info(&coverage_recording(&[(0.0, 0.0, false), (0.1, 0.0, false)])).expect("info");
        assert_eq!((empty.h_start, empty.h_end), (None, None));
        let mut text = Vec::new();
        print_info(&empty, &mut text).expect("printed");
        let text = String::from_utf8(text).expect("UTF-8");
        assert!(
            text.contains("H         - (none of the 2 ticks had a vessel)"),
            "{text}"
        );
    }

    #[test]
    fn a_big_fleet_is_named_in_one_short_line() {
        let few: Vec<String> = (1..=3).map(|i| format!("usv-{i}")).collect();
        assert_eq!(names(&few), "usv-1, usv-2, usv-3");
        let many: Vec<String> = (1..=1000).map(|i| format!("v{i:04}")).collect();
        let line = names(&many);
        assert!(
            line.starts_with("v0001, v0002,") && line.ends_with(", v1000"),
            "{line}"
        );
        assert!(line.contains("… 988 more …") && line.len() < 120, "{line}");
    }
}
