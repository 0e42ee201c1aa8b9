//! [`BagWriter`]: MCAP files with the ROS 2 profile.

use std::collections::{BTreeMap, HashMap};
use std::io::BufWriter;

use cowork_store::AtomicFile;
use std::path::{Path, PathBuf};

use cowork_msgs::{RosMessage, to_cdr_into};
use mcap::records::MessageHeader;

use crate::{BagError, Result};

/// Handle of a channel (one topic with one type) returned by [`BagWriter::add_channel`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ChannelId(usize);

#[derive(Debug)]
struct ChannelEntry {
    mcap_id: u16,
    topic: String,
    type_name: String,
    definition: String,
    sequence: u32,
}

fn cowork_span_ns(s: f64) -> u64 {
    // Capped at ~292 years (u64 ns): larger spans are "never by time".
    (s * 1e9).min(u64::MAX as f64) as u64
}

/// What [`BagWriter::finish`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WriteSummary {
    /// Messages written.
    pub message_count: u64,
    /// Channels (topics) written.
    pub channel_count: usize,
}

/// Writes an MCAP bag with the ROS 2 profile: profile `ros2`, schema encoding `ros2msg` with
/// the full definition text, message encoding `cdr` (with the 4-byte encapsulation header),
/// zstd-compressed chunks, and a summary section with statistics and indexes.
///
/// The bag appears at its path only when [`finish`](Self::finish) succeeds (written beside it
/// as a temporary, then renamed: [`cowork_store::AtomicFile`]); a writer dropped without it
/// removes its temporary and leaves an existing file at the path untouched, so a command that
/// fails never destroys or half-writes a bag. A process killed mid-recording leaves the
/// temporary ([`partial_path`](Self::partial_path)), readable up to its last closed chunk.
pub struct BagWriter {
    path: PathBuf,
    /// Where the bytes are until `finish`.
    partial: PathBuf,
    inner: mcap::Writer<BufWriter<AtomicFile>>,
    channels: Vec<ChannelEntry>,
    by_topic: HashMap<String, usize>,
    buffer: Vec<u8>,
    message_count: u64,
    /// Close the open chunk once it spans this much log time (ns); `None`: by size only.
    chunk_span_ns: Option<u64>,
    /// Log time of the first message of the open chunk.
    chunk_first_ns: Option<u64>,
    /// Chunks closed by [`chunk_span_ns`](Self::chunk_span_ns) or [`flush`](Self::flush).
    flushes: u64,
}

/// Log time a chunk spans at most before [`BagWriter`] closes and flushes it, s: a recorder
/// killed (`kill -9`, power loss before the page cache is written aside) loses at most the
/// open chunk, i.e. about this much of the recording; the file stays readable up to the last
/// closed chunk (`BagReader::open_recoverable`).
pub const DEFAULT_CHUNK_SPAN_S: f64 = 1.0;

impl std::fmt::Debug for BagWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagWriter")
            .field("path", &self.path)
            .field("channels", &self.channels)
            .field("message_count", &self.message_count)
            .finish_non_exhaustive()
    }
}

impl BagWriter {
    /// Starts the bag at `path` (which it replaces, whole, on [`finish`](Self::finish)).
    pub fn create(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let file = AtomicFile::create(&path).map_err(|source| BagError::Io {
            path: path.clone(),
            source,
        })?;
        let partial = file.partial_path().to_path_buf();
        let inner = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("cowork_bag/", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .create(BufWriter::new(file))
            .map_err(|source| BagError::Write {
                path: path.clone(),
                source,
            })?;
        Ok(Self {
            path,
            partial,
            inner,
            channels: Vec::new(),
            by_topic: HashMap::new(),
            buffer: Vec::new(),
            message_count: 0,
            chunk_span_ns: Some((DEFAULT_CHUNK_SPAN_S * 1e9) as u64),
            chunk_first_ns: None,
            flushes: 0,
        })
    }

    /// Closes and flushes the open chunk once it spans `span_s` seconds of log time
    /// (default [`DEFAULT_CHUNK_SPAN_S`]); `None` closes chunks by size only (the `mcap`
    /// crate's 5.8 MB of uncompressed records). Log time, not wall time, so that a bag written
    /// from a seed (`cowork bag synth`) has the same bytes however fast it is written, while
    /// a live recorder (log time = receive time) loses at most about `span_s` to a crash.
    /// Non-finite or non-positive spans are refused.
    pub fn set_chunk_span(&mut self, span_s: Option<f64>) -> Result<()> {
        self.chunk_span_ns = match span_s {
            None => None,
            Some(s) if s.is_finite() && s > 0.0 => Some(cowork_span_ns(s)),
            Some(s) => {
                return Err(BagError::Io {
                    path: self.path.clone(),
                    source: std::io::Error::new(
                        std::io::ErrorKind::InvalidInput,
                        format!("chunk span {s} s: must be a finite number of seconds > 0"),
                    ),
                });
            }
        };
        Ok(())
    }

    /// Closes the open chunk (if any) and flushes the file, so that everything written so far
    /// survives a crash of this process (e.g. a recorder with a stream that went quiet).
    pub fn flush(&mut self) -> Result<()> {
        self.inner.flush().map_err(|source| self.write_error(source))?;
        self.chunk_first_ns = None;
        self.flushes += 1;
        Ok(())
    }

    /// Chunks closed early so far by the time bound or [`flush`](Self::flush).
    pub fn flushes(&self) -> u64 {
        self.flushes
    }

    /// The bag's path (written by [`finish`](Self::finish)).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Where the bag's bytes are until [`finish`](Self::finish) moves them to
    /// [`path`](Self::path): what a killed recorder leaves behind.
    pub fn partial_path(&self) -> &Path {
        &self.partial
    }

    /// Registers `topic` carrying `T` (schema once per type, channel once per topic) and
    /// returns its handle. Adding the same topic with the same type again returns the same id.
    pub fn add_channel<T: RosMessage>(&mut self, topic: &str) -> Result<ChannelId> {
        self.channel_for(topic, &T::type_name(), None::<&str>, T::ros2msg_definition)
    }

    fn channel_for(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: Option<&str>,
        our_definition: impl FnOnce() -> String,
    ) -> Result<ChannelId> {
        if let Some(&i) = self.by_topic.get(topic) {
            let entry = &self.channels[i];
            let same_definition = definition.is_none_or(|d| d == entry.definition);
            if entry.type_name != type_name || !same_definition {
                return Err(BagError::TopicTypeConflict {
                    path: self.path.clone(),
                    topic: topic.to_owned(),
                    existing: entry.type_name.clone(),
                    requested: type_name.to_owned(),
                });
            }
            return Ok(ChannelId(i));
        }
        let definition = definition.map_or_else(our_definition, str::to_owned);
        // mcap coalesces identical schema records, so a type is stored once.
        let schema_id = self
            .inner
            .add_schema(type_name, "ros2msg", definition.as_bytes())
            .map_err(|source| self.write_error(source))?;
        let mcap_id = self
            .inner
            .add_channel(schema_id, topic, "cdr", &BTreeMap::new())
            .map_err(|source| self.write_error(source))?;
        self.channels.push(ChannelEntry {
            mcap_id,
            topic: topic.to_owned(),
            type_name: type_name.to_owned(),
            definition,
            sequence: 0,
        });
        let id = self.channels.len() - 1;
        self.by_topic.insert(topic.to_owned(), id);
        Ok(ChannelId(id))
    }

    fn write_error(&self, source: mcap::McapError) -> BagError {
        BagError::Write {
            path: self.path.clone(),
            source,
        }
    }

    /// Writes `msg` on `channel` as CDR. Times are ns on the bag's clock (sim or wall time):
    /// `log_time_ns` when it was recorded, `publish_time_ns` when it was published.
    pub fn write<T: RosMessage>(
        &mut self,
        channel: ChannelId,
        log_time_ns: u64,
        publish_time_ns: u64,
        msg: &T,
    ) -> Result<()> {
        let entry = self
            .channels
            .get(channel.0)
            .ok_or_else(|| BagError::UnknownChannel {
                path: self.path.clone(),
                channel: channel.0,
            })?;
        if !cowork_msgs::type_name_matches(T::PACKAGE, T::NAME, &entry.type_name) {
            return Err(BagError::ChannelTypeMismatch {
                path: self.path.clone(),
                topic: entry.topic.clone(),
                channel_type: entry.type_name.clone(),
                message_type: T::type_name(),
            });
        }
        let mut buffer = std::mem::take(&mut self.buffer);
        to_cdr_into(msg, &mut buffer);
        let result = self.write_bytes(channel.0, log_time_ns, publish_time_ns, &buffer);
        self.buffer = buffer;
        result
    }

    /// Writes an already serialised CDR payload on `topic` with the given type name and full
    /// `ros2msg` definition, unchanged: this is how messages of types we do not know are carried
    /// from one bag (or the wire) to another.
    pub fn write_raw(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: &str,
        log_time_ns: u64,
        publish_time_ns: u64,
        data: &[u8],
    ) -> Result<()> {
        let ChannelId(i) = self.channel_for(topic, type_name, Some(definition), String::new)?;
        self.write_bytes(i, log_time_ns, publish_time_ns, data)
    }

    fn write_bytes(
        &mut self,
        index: usize,
        log_time_ns: u64,
        publish_time_ns: u64,
        data: &[u8],
    ) -> Result<()> {
        let Some(entry) = self.channels.get_mut(index) else {
            return Err(BagError::UnknownChannel {
                path: self.path.clone(),
                channel: index,
            });
        };
        let header = MessageHeader {
            channel_id: entry.mcap_id,
            sequence: entry.sequence,
            log_time: log_time_ns,
            publish_time: publish_time_ns,
        };
        entry.sequence = entry.sequence.wrapping_add(1);
        self.inner
            .write_to_known_channel(&header, data)
            .map_err(|source| BagError::Write {
                path: self.path.clone(),
                source,
            })?;
        self.message_count += 1;
        if let Some(span) = self.chunk_span_ns {
            let first = *self.chunk_first_ns.get_or_insert(log_time_ns);
            // Either direction: a clock that jumped back must not keep a chunk open forever.
            if log_time_ns.abs_diff(first) >= span {
                self.flush()?;
            }
        }
        Ok(())
    }

    /// Writes the last chunk, the summary section and the footer, syncs the file and moves it
    /// to its path.
    pub fn finish(mut self) -> Result<WriteSummary> {
        self.inner
            .finish()
            .map_err(|source| self.write_error(source))?;
        let path = self.path.clone();
        let io = |source| BagError::Io { path: path.clone(), source };
        let file = self.inner.into_inner();
        file.into_inner().map_err(|e| io(e.into_error()))?.commit().map_err(io)?;
        Ok(WriteSummary {
            message_count: self.message_count,
            channel_count: self.channels.len(),
        })
    }
}
