//! Reading a recording back: the chunks of an MCAP file, found through its
//! chunk index (the summary section a finished file ends with), or, in a
//! file cut short (`kill -9`), by walking its records and keeping every
//! whole chunk — what MCAP's own readers call recovery.
//!
//! Only the chunks a question needs are decompressed: the state at a moment
//! needs the one or two chunks before it (and, for the mission, the newest
//! chunk that holds a mission message, which the index names without
//! opening anything). A file is held in memory: rotation bounds its size
//! (256 MiB by default).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use mcap::records::{ChunkHeader, Record, op};

/// Why a recording could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("{path}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not an MCAP file")]
    NotMcap { path: PathBuf },
    #[error("{path}")]
    Mcap {
        path: PathBuf,
        source: mcap::McapError,
    },
}

/// One message.
#[derive(Debug, Clone)]
pub struct Message {
    pub topic: Arc<str>,
    pub log_time: u64,
    pub publish_time: u64,
    pub data: Vec<u8>,
}

/// A channel of the recording.
#[derive(Debug, Clone)]
pub struct Channel {
    pub topic: Arc<str>,
    pub schema_name: String,
    pub message_encoding: String,
}

/// Where a chunk is and what it spans.
#[derive(Debug, Clone)]
struct ChunkRef {
    start: u64,
    end: u64,
    /// The chunk record's body (after opcode and length).
    body: std::ops::Range<usize>,
    /// Channels with messages in it, when known.
    channels: Option<BTreeSet<u16>>,
}

/// An opened recording.
pub struct Recording {
    path: PathBuf,
    bytes: Vec<u8>,
    channels: HashMap<u16, Channel>,
    chunks: Vec<ChunkRef>,
    /// Messages per channel, from the summary's statistics or counted
    /// while recovering.
    counts: BTreeMap<u16, u64>,
    recovered: bool,
}

const MAGIC: &[u8] = b"\x89MCAP0\r\n";

impl Recording {
    pub fn open(path: &Path) -> Result<Recording, ReadError> {
        let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Recording::from_bytes(path, bytes)
    }

    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<Recording, ReadError> {
        let path = path.to_path_buf();
        if !bytes.starts_with(MAGIC) {
            return Err(ReadError::NotMcap { path });
        }
        // A finished file: its summary has the chunk index, the channels
        // and the counts.
        let summary = if bytes.ends_with(MAGIC) && bytes.len() >= 2 * MAGIC.len() {
            mcap::read::Summary::read(&bytes).ok().flatten()
        } else {
            None
        };
        if let Some(summary) = summary
            && !summary.chunk_indexes.is_empty()
        {
            let channels = summary
                .channels
                .iter()
                .map(|(id, c)| (*id, channel_of(c)))
                .collect();
            let mut chunks: Vec<ChunkRef> = summary
                .chunk_indexes
                .iter()
                .map(|ix| ChunkRef {
                    start: ix.message_start_time,
                    end: ix.message_end_time,
                    body: (ix.chunk_start_offset as usize + 9)
                        ..(ix.chunk_start_offset + ix.chunk_length) as usize,
                    channels: Some(ix.message_index_offsets.keys().copied().collect()),
                })
                .collect();
            chunks.sort_by_key(|c| (c.start, c.body.start));
            let counts = summary
                .stats
                .map(|s| s.channel_message_counts.into_iter().collect())
                .unwrap_or_default();
            return Ok(Recording {
                path,
                bytes,
                channels,
                chunks,
                counts,
                recovered: false,
            });
        }
        let found = Recovery::walk(&bytes).map_err(|source| ReadError::Mcap {
            path: path.clone(),
            source,
        })?;
        Ok(found.into_recording(path, bytes))
    }
}

/// What a walk over a file without an index (cut short, or written
/// without one) finds: every whole chunk, and the channels and counts read
/// out of them.
#[derive(Default)]
struct Recovery {
    chunks: Vec<ChunkRef>,
    channels: HashMap<u16, Channel>,
    counts: BTreeMap<u16, u64>,
    schema_of: HashMap<u16, u16>,
    schema_names: HashMap<u16, String>,
}

impl Recovery {
    /// Walks the records up to the first one cut short or broken.
    fn walk(bytes: &[u8]) -> Result<Recovery, mcap::McapError> {
        let mut found = Recovery::default();
        let mut at = MAGIC.len();
        while at + 9 <= bytes.len() {
            let opcode = bytes[at];
            let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().expect("8 bytes"));
            let body = at + 9..(at + 9).saturating_add(len as usize);
            if body.end > bytes.len() {
                break; // the record the process was writing when it died
            }
            match opcode {
                op::CHUNK if !found.chunk(bytes, body)? => break,
                op::DATA_END | op::FOOTER => break,
                _ => {}
            }
            at = (at + 9).saturating_add(len as usize);
        }
        Ok(found)
    }

    /// Takes in the chunk at `body`; `false` when it is not whole.
    fn chunk(
        &mut self,
        bytes: &[u8],
        body: std::ops::Range<usize>,
    ) -> Result<bool, mcap::McapError> {
        let Ok(Record::Chunk { header, data }) =
            mcap::read::parse_record(op::CHUNK, &bytes[body.clone()])
        else {
            return Ok(false);
        };
        let mut present = BTreeSet::new();
        for record in mcap::read::ChunkReader::new(header.clone(), &data)? {
            match record {
                Ok(Record::Channel(c)) => {
                    self.channels.entry(c.id).or_insert(Channel {
                        topic: c.topic.as_str().into(),
                        schema_name: String::new(),
                        message_encoding: c.message_encoding.clone(),
                    });
                    self.schema_of.entry(c.id).or_insert(c.schema_id);
                }
                Ok(Record::Schema { header, .. }) => {
                    self.schema_names.insert(header.id, header.name.clone());
                }
                Ok(Record::Message { header, .. }) => {
                    present.insert(header.channel_id);
                    *self.counts.entry(header.channel_id).or_insert(0) += 1;
                }
                Ok(_) => {}
                Err(_) => return Ok(false),
            }
        }
        self.chunks.push(ChunkRef {
            start: header.message_start_time,
            end: header.message_end_time,
            body,
            channels: Some(present),
        });
        Ok(true)
    }

    fn into_recording(mut self, path: PathBuf, bytes: Vec<u8>) -> Recording {
        for (id, channel) in self.channels.iter_mut() {
            if let Some(name) = self
                .schema_of
                .get(id)
                .and_then(|s| self.schema_names.get(s))
            {
                channel.schema_name = name.clone();
            }
        }
        self.chunks.sort_by_key(|c| (c.start, c.body.start));
        Recording {
            path,
            bytes,
            channels: self.channels,
            chunks: self.chunks,
            counts: self.counts,
            recovered: true,
        }
    }
}

impl Recording {
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the file had no index and was read by recovering its whole
    /// chunks (a recording cut short).
    pub fn recovered(&self) -> bool {
        self.recovered
    }

    /// Log time of the first and last message [ns]; `None` when empty.
    pub fn span(&self) -> Option<(u64, u64)> {
        let start = self.chunks.iter().map(|c| c.start).min()?;
        let end = self.chunks.iter().map(|c| c.end).max()?;
        Some((start, end))
    }

    /// Every channel with its message count, by topic.
    pub fn channels(&self) -> Vec<(Channel, u64)> {
        let mut out: Vec<(Channel, u64)> = self
            .channels
            .iter()
            .map(|(id, c)| (c.clone(), self.counts.get(id).copied().unwrap_or(0)))
            .collect();
        out.sort_by(|a, b| a.0.topic.cmp(&b.0.topic));
        out
    }

    pub fn chunk_count(&self) -> usize {
        self.chunks.len()
    }

    /// Each chunk's span [ns], in order.
    pub fn chunk_spans(&self) -> Vec<(u64, u64)> {
        self.chunks.iter().map(|c| (c.start, c.end)).collect()
    }

    fn channel_ids(&self, wanted: &dyn Fn(&str) -> bool) -> BTreeSet<u16> {
        self.channels
            .iter()
            .filter(|(_, c)| wanted(&c.topic))
            .map(|(id, _)| *id)
            .collect()
    }

    /// The messages of chunk `i` on the channels `ids`, by log time.
    fn chunk_messages(&self, i: usize, ids: &BTreeSet<u16>) -> Result<Vec<Message>, ReadError> {
        let chunk = &self.chunks[i];
        let mcap_error = |source| ReadError::Mcap {
            path: self.path.clone(),
            source,
        };
        let Record::Chunk { header, data } =
            mcap::read::parse_record(op::CHUNK, &self.bytes[chunk.body.clone()])
                .map_err(mcap_error)?
        else {
            return Err(mcap_error(mcap::McapError::BadIndex));
        };
        let header: ChunkHeader = header;
        let mut out = Vec::new();
        for record in mcap::read::ChunkReader::new(header, &data).map_err(mcap_error)? {
            if let Record::Message { header, data } = record.map_err(mcap_error)?
                && ids.contains(&header.channel_id)
                && let Some(channel) = self.channels.get(&header.channel_id)
            {
                out.push(Message {
                    topic: channel.topic.clone(),
                    log_time: header.log_time,
                    publish_time: header.publish_time,
                    data: data.into_owned(),
                });
            }
        }
        out.sort_by_key(|m| m.log_time);
        Ok(out)
    }

    fn holds(chunk: &ChunkRef, ids: &BTreeSet<u16>) -> bool {
        chunk
            .channels
            .as_ref()
            .is_none_or(|present| present.iter().any(|c| ids.contains(c)))
    }

    /// Every message on the topics `wanted` accepts, in chunk order and by
    /// log time within a chunk.
    pub fn messages(
        &self,
        wanted: &dyn Fn(&str) -> bool,
    ) -> impl Iterator<Item = Result<Message, ReadError>> + '_ {
        let ids = self.channel_ids(wanted);
        (0..self.chunks.len()).flat_map(move |i| {
            if !Self::holds(&self.chunks[i], &ids) {
                return Vec::new();
            }
            match self.chunk_messages(i, &ids) {
                Ok(ms) => ms.into_iter().map(Ok).collect(),
                Err(e) => vec![Err(e)],
            }
        })
    }

    /// The messages with log times in `[from, to]` on the topics `wanted`
    /// accepts, by log time: only chunks that overlap the window are read.
    pub fn window(
        &self,
        from: u64,
        to: u64,
        wanted: &dyn Fn(&str) -> bool,
    ) -> Result<Vec<Message>, ReadError> {
        let ids = self.channel_ids(wanted);
        let mut out = Vec::new();
        for (i, chunk) in self.chunks.iter().enumerate() {
            if chunk.start <= to && chunk.end >= from && Self::holds(chunk, &ids) {
                out.extend(
                    self.chunk_messages(i, &ids)?
                        .into_iter()
                        .filter(|m| (from..=to).contains(&m.log_time)),
                );
            }
        }
        out.sort_by_key(|m| m.log_time);
        Ok(out)
    }

    /// The newest message on `topic` logged at or before `at`: the chunk
    /// index says which chunks hold the channel, so only the newest of them
    /// that started by `at` is opened (and older ones only when its
    /// messages on `topic` are all later than `at`).
    pub fn latest(&self, topic: &str, at: u64) -> Result<Option<Message>, ReadError> {
        let ids = self.channel_ids(&|t| t == topic);
        if ids.is_empty() {
            return Ok(None);
        }
        let mut candidates: Vec<usize> = (0..self.chunks.len())
            .filter(|&i| self.chunks[i].start <= at && Self::holds(&self.chunks[i], &ids))
            .collect();
        // Newest end first: chunks overlap in time only at their edges.
        candidates.sort_by_key(|&i| std::cmp::Reverse(self.chunks[i].end));
        let mut best: Option<Message> = None;
        for i in candidates {
            if best
                .as_ref()
                .is_some_and(|b| b.log_time >= self.chunks[i].end)
            {
                break;
            }
            if let Some(m) = self
                .chunk_messages(i, &ids)?
                .into_iter()
                .rfind(|m| m.log_time <= at)
                && best.as_ref().is_none_or(|b| m.log_time > b.log_time)
            {
                best = Some(m);
            }
        }
        Ok(best)
    }
}

fn channel_of(c: &mcap::Channel<'_>) -> Channel {
    Channel {
        topic: c.topic.as_str().into(),
        schema_name: c.schema.as_ref().map_or(String::new(), |s| s.name.clone()),
        message_encoding: c.message_encoding.clone(),
    }
}
