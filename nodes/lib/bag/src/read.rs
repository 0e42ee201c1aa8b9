//! [`BagReader`]: MCAP files in log-time order, with damage detection and recovery.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use cowork_msgs::{MessageTypeInfo, RosMessage, find_type, from_cdr, type_name_matches};
use mcap::records::{ChunkHeader, Record};

use crate::{BagError, Result, schema};

const MAGIC_LEN: usize = 8;
/// Opcode (1 byte) + record length (8 bytes).
const RECORD_PREFIX: usize = 9;

/// Largest uncompressed chunk read, bytes. Writers cut chunks at a few MB (ours at the `mcap`
/// crate's default); a chunk header that declares more is damage or a hostile file, and is
/// refused before the decompressor allocates it (a flipped bit there once asked for 7.6 EB and
/// aborted the process).
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// One channel of a bag: a topic, its type and schema.
#[derive(Debug)]
pub struct ChannelInfo {
    /// Topic name.
    pub topic: Arc<str>,
    /// Schema name (the ROS type, e.g. `sensor_msgs/msg/Image`); empty without schema.
    pub type_name: Arc<str>,
    /// Schema encoding (`ros2msg` for ROS 2 bags).
    pub schema_encoding: String,
    /// Message encoding (`cdr` for ROS 2 bags).
    pub message_encoding: String,
    /// The schema text as stored in the bag.
    pub definition: Arc<str>,
    /// The `cowork_msgs` type of this name, if any.
    pub known: Option<&'static MessageTypeInfo>,
    /// For a known type with a `ros2msg` schema: the first field that differs from ours.
    pub schema_mismatch: Option<String>,
}

impl ChannelInfo {
    fn new(topic: &str, schema: Option<&mcap::Schema<'_>>, message_encoding: &str) -> Self {
        let (type_name, encoding, definition) = schema.map_or_else(
            || (String::new(), String::new(), String::new()),
            |s| {
                (
                    s.name.clone(),
                    s.encoding.clone(),
                    String::from_utf8_lossy(&s.data).into_owned(),
                )
            },
        );
        let known = find_type(&type_name);
        let schema_mismatch = match known {
            Some(info) if encoding == "ros2msg" => {
                schema::first_difference(&type_name, &(info.definition)(), &definition)
            }
            _ => None,
        };
        Self {
            topic: topic.into(),
            type_name: type_name.into(),
            schema_encoding: encoding,
            message_encoding: message_encoding.to_owned(),
            definition: definition.into(),
            known,
            schema_mismatch,
        }
    }
}

/// One message as stored: its channel and its serialised payload (CDR with encapsulation
/// header for ROS 2 bags).
#[derive(Clone, Debug)]
pub struct RawMessage {
    /// Topic name.
    pub topic: Arc<str>,
    /// ROS type name as the bag spells it.
    pub type_name: Arc<str>,
    /// Time the message was recorded (ns).
    pub log_time_ns: u64,
    /// Time the message was published (ns).
    pub publish_time_ns: u64,
    /// Per-channel sequence number written by the recorder.
    pub sequence: u32,
    /// The serialised payload, untouched.
    pub data: Vec<u8>,
    /// Channel details (schema text, encodings, known type).
    pub channel: Arc<ChannelInfo>,
}

impl RawMessage {
    fn check_cdr(&self) -> Result<()> {
        if self.channel.message_encoding != "cdr" {
            return Err(BagError::UnsupportedEncoding {
                topic: self.topic.to_string(),
                log_time_ns: self.log_time_ns,
                encoding: self.channel.message_encoding.clone(),
            });
        }
        if let Some(detail) = &self.channel.schema_mismatch {
            return Err(BagError::SchemaMismatch {
                topic: self.topic.to_string(),
                log_time_ns: self.log_time_ns,
                type_name: self.type_name.to_string(),
                detail: detail.clone(),
            });
        }
        Ok(())
    }

    /// Decodes the payload as `T`, after checking the type name, the message encoding and that
    /// the bag's schema has our fields.
    pub fn decode<T: RosMessage>(&self) -> Result<T> {
        if !type_name_matches(T::PACKAGE, T::NAME, &self.type_name) {
            return Err(BagError::TypeMismatch {
                topic: self.topic.to_string(),
                log_time_ns: self.log_time_ns,
                actual: self.type_name.to_string(),
                requested: T::type_name(),
            });
        }
        self.check_cdr()?;
        from_cdr(&self.data).map_err(|source| BagError::Decode {
            topic: self.topic.to_string(),
            log_time_ns: self.log_time_ns,
            source,
        })
    }

    /// Decodes the payload of a known type into JSON (field names as in the `.msg`).
    pub fn decode_json(&self) -> Result<serde_json::Value> {
        let Some(info) = self.channel.known else {
            return Err(BagError::UnknownType {
                topic: self.topic.to_string(),
                log_time_ns: self.log_time_ns,
                type_name: self.type_name.to_string(),
            });
        };
        self.check_cdr()?;
        (info.cdr_to_json)(&self.data).map_err(|source| BagError::Decode {
            topic: self.topic.to_string(),
            log_time_ns: self.log_time_ns,
            source,
        })
    }
}

/// A top-level record of the data section that holds or defines messages.
#[derive(Clone, Copy, Debug)]
struct Segment {
    /// Byte offset of the record (its opcode).
    offset: usize,
    opcode: u8,
    body_start: usize,
    body_end: usize,
    /// Log-time range of the messages it holds (`None` for schema/channel records).
    times: Option<(u64, u64)>,
}

/// The MCAP file to read for `path`: `path` itself, or for a rosbag2 directory the one storage
/// file its `metadata.yaml` lists under `relative_file_paths` (else the one `*.mcap` file in
/// it). A directory split into several storage files is refused for now, naming them.
pub fn storage_file(path: &Path) -> Result<PathBuf> {
    if !path.is_dir() {
        return Ok(path.to_path_buf());
    }
    let bad = |reason: String| BagError::BagDirectory { path: path.to_path_buf(), reason };
    let sqlite = || BagError::UnsupportedStorage { path: path.to_path_buf(), storage: "sqlite3".into() };
    let metadata = path.join("metadata.yaml");
    let mut files: Vec<PathBuf> = if metadata.is_file() {
        let text = std::fs::read_to_string(&metadata).map_err(|e| bad(format!("metadata.yaml: {e}")))?;
        let yaml: serde_yaml_ng::Value =
            serde_yaml_ng::from_str(&text).map_err(|e| bad(format!("metadata.yaml: {e}")))?;
        let storage = yaml
            .get("rosbag2_bagfile_information")
            .and_then(|i| i.get("storage_identifier"))
            .and_then(|s| s.as_str())
            .unwrap_or("mcap");
        if storage != "mcap" {
            return Err(BagError::UnsupportedStorage { path: path.to_path_buf(), storage: storage.to_owned() });
        }
        yaml.get("rosbag2_bagfile_information")
            .and_then(|i| i.get("relative_file_paths"))
            .and_then(|p| p.as_sequence())
            .map(|p| p.iter().filter_map(|f| f.as_str()).map(|f| path.join(f)).collect())
            .unwrap_or_default()
    } else {
        Vec::new()
    };
    if files.is_empty() {
        let entries = std::fs::read_dir(path).map_err(|e| bad(e.to_string()))?;
        files = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
            .collect();
        files.sort();
        let db3 = std::fs::read_dir(path).into_iter().flatten().flatten().any(|e| e.path().extension().is_some_and(|x| x == "db3"));
        if files.is_empty() && db3 {
            return Err(sqlite());
        }
    }
    match files.as_slice() {
        [one] => Ok(one.clone()),
        [] => Err(bad("no .mcap storage file in it".into())),
        many => Err(bad(format!(
            "{} storage files ({}); only single-file bags are read so far",
            many.len(),
            many.iter().filter_map(|f| f.file_name()).map(|f| f.to_string_lossy()).collect::<Vec<_>>().join(", ")
        ))),
    }
}

/// Per-topic figures of [`BagInfo`].
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct TopicInfo {
    /// Topic name.
    pub topic: String,
    /// ROS type name.
    pub type_name: String,
    /// Messages on the topic.
    pub message_count: u64,
    /// Whether the type is one of `cowork_msgs`'.
    pub known_type: bool,
    /// Schema difference from ours, for known types.
    pub schema_mismatch: Option<String>,
}

/// Summary of a bag: topics, types, counts and time span.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BagInfo {
    /// The bag file.
    pub path: PathBuf,
    /// File size (bytes).
    pub file_size: u64,
    /// MCAP profile (`ros2`).
    pub profile: String,
    /// Topics sorted by name.
    pub topics: Vec<TopicInfo>,
    /// Messages in all.
    pub message_count: u64,
    /// Earliest log time (ns), `None` for an empty bag.
    pub start_ns: Option<u64>,
    /// Latest log time (ns), `None` for an empty bag.
    pub end_ns: Option<u64>,
    /// `end - start` (s).
    pub duration_s: f64,
    /// Whether the figures come from the summary section (else from reading every message).
    pub from_summary: bool,
    /// Damage found while reading, if any (figures then cover the readable part).
    pub damage: Option<String>,
}

impl BagInfo {
    /// A table for people: one line per topic, then totals.
    pub fn to_table(&self) -> String {
        let mut out = format!(
            "file:     {} ({} bytes, profile {:?})\n",
            self.path.display(),
            self.file_size,
            self.profile
        );
        out.push_str(&format!(
            "messages: {} in {} topics\nduration: {:.3} s",
            self.message_count,
            self.topics.len(),
            self.duration_s
        ));
        if let (Some(s), Some(e)) = (self.start_ns, self.end_ns) {
            out.push_str(&format!(
                " (start {:.9} s, end {:.9} s)",
                s as f64 * 1e-9,
                e as f64 * 1e-9
            ));
        }
        out.push('\n');
        if let Some(d) = &self.damage {
            out.push_str(&format!("DAMAGED:  {d}\n"));
        }
        let tw = self
            .topics
            .iter()
            .map(|t| t.topic.len())
            .max()
            .unwrap_or(0)
            .max(5);
        let yw = self
            .topics
            .iter()
            .map(|t| t.type_name.len())
            .max()
            .unwrap_or(0)
            .max(4);
        out.push_str(&format!(
            "{:<tw$}  {:<yw$}  {:>9}  note\n",
            "topic", "type", "count"
        ));
        for t in &self.topics {
            let note = match (&t.schema_mismatch, t.known_type) {
                (Some(d), _) => format!("schema differs: {d}"),
                (None, true) => String::new(),
                (None, false) => "unknown type (carried through)".to_owned(),
            };
            out.push_str(&format!(
                "{:<tw$}  {:<yw$}  {:>9}  {note}\n",
                t.topic, t.type_name, t.message_count
            ));
        }
        out
    }
}

/// Reads an MCAP bag held in memory.
///
/// [`open`](Self::open) walks the record structure and refuses a truncated file, a record that
/// does not parse or a bad summary with an error naming the file and the byte offset;
/// [`open_recoverable`](Self::open_recoverable) accepts it, remembers the damage
/// ([`damage`](Self::damage)) and reads every message before it. Chunks are decompressed (and
/// their CRC checked) only while iterating: a damaged chunk is an `Err` item naming its offset,
/// and iteration goes on with the next chunk. [`messages`](Self::messages) yields messages in
/// log-time order. The whole file is held in memory.
#[derive(Debug)]
pub struct BagReader {
    path: PathBuf,
    data: Vec<u8>,
    profile: String,
    segments: Vec<Segment>,
    time_ordered: bool,
    summary: Option<mcap::Summary>,
    damage: Option<BagError>,
}

impl BagReader {
    /// Opens `path`, failing on any damage (truncation, corrupt record, bad summary).
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let mut reader = Self::open_recoverable(path)?;
        match reader.damage.take() {
            Some(e) => Err(e),
            None => Ok(reader),
        }
    }

    /// Opens `path`, tolerating damage after the MCAP magic: see [`damage`](Self::damage).
    /// `path` may also be a rosbag2 directory (what `ros2 bag record` and `rosbags` write):
    /// its storage file is read (see [`storage_file`]).
    pub fn open_recoverable(path: impl AsRef<Path>) -> Result<Self> {
        let path = storage_file(path.as_ref())?;
        let data = std::fs::read(&path).map_err(|source| BagError::Io {
            path: path.clone(),
            source,
        })?;
        if data.starts_with(b"SQLite format 3\0") {
            return Err(BagError::UnsupportedStorage { path, storage: "sqlite3".into() });
        }
        if data.len() < MAGIC_LEN || &data[..MAGIC_LEN] != mcap::MAGIC {
            return Err(BagError::NotMcap { path });
        }
        let mut reader = Self {
            path,
            data,
            profile: String::new(),
            segments: Vec::new(),
            time_ordered: true,
            summary: None,
            damage: None,
        };
        reader.scan();
        Ok(reader)
    }

    /// The first damage found when the file was opened, if any.
    pub fn damage(&self) -> Option<&BagError> {
        self.damage.as_ref()
    }

    /// The bag's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn truncated(&self, offset: usize, reason: String) -> BagError {
        BagError::Truncated {
            path: self.path.clone(),
            offset: offset as u64,
            len: self.data.len() as u64,
            reason,
        }
    }

    fn corrupt(&self, offset: usize, reason: String) -> BagError {
        BagError::Corrupt {
            path: self.path.clone(),
            offset: offset as u64,
            reason,
        }
    }

    /// Walks the data section's top-level records (chunks are not decompressed here).
    fn scan(&mut self) {
        let len = self.data.len();
        let mut pos = MAGIC_LEN;
        let mut last_end = 0u64;
        let mut data_end_seen = false;
        loop {
            if pos == len {
                self.damage =
                    Some(self.truncated(pos, "file ends before the data end record".into()));
                break;
            }
            if len - pos < RECORD_PREFIX {
                self.damage = Some(self.truncated(pos, "file ends inside a record header".into()));
                break;
            }
            let opcode = self.data[pos];
            let mut len_bytes = [0u8; 8];
            len_bytes.copy_from_slice(&self.data[pos + 1..pos + RECORD_PREFIX]);
            let body_len = u64::from_le_bytes(len_bytes);
            let body_start = pos + RECORD_PREFIX;
            let Some(body_end) = usize::try_from(body_len)
                .ok()
                .and_then(|l| body_start.checked_add(l))
                .filter(|&e| e <= len)
            else {
                self.damage = Some(self.truncated(
                    pos,
                    format!("record (opcode {opcode:#04x}) of {body_len} bytes runs past the end of the file"),
                ));
                break;
            };
            let body = &self.data[body_start..body_end];
            let times = match mcap::parse_record(opcode, body) {
                Err(e) => {
                    let err = self.corrupt(pos, format!("record (opcode {opcode:#04x}): {e}"));
                    self.damage.get_or_insert(err);
                    pos = body_end;
                    continue;
                }
                Ok(Record::Header(h)) => {
                    self.profile = h.profile;
                    None
                }
                Ok(Record::DataEnd(_)) => {
                    data_end_seen = true;
                    break;
                }
                Ok(Record::Footer(_)) => break,
                Ok(Record::Chunk { header, .. }) => {
                    Some((header.message_start_time, header.message_end_time))
                }
                Ok(Record::Message { header, .. }) => Some((header.log_time, header.log_time)),
                Ok(Record::Schema { .. } | Record::Channel(_)) => None,
                Ok(_) => {
                    pos = body_end;
                    continue;
                }
            };
            if let Some((start, end)) = times {
                if start < last_end {
                    self.time_ordered = false;
                }
                last_end = last_end.max(end);
            }
            self.segments.push(Segment {
                offset: pos,
                opcode,
                body_start,
                body_end,
                times,
            });
            pos = body_end;
        }
        if data_end_seen {
            match mcap::Summary::read(&self.data) {
                Ok(summary) => self.summary = summary,
                Err(e) => {
                    let err = self.corrupt(pos, format!("summary section or footer: {e}"));
                    self.damage.get_or_insert(err);
                }
            }
        }
    }

    /// Messages in log-time order (ties in file order).
    ///
    /// Items are `Err` for a damaged chunk or record (naming the file and offset; reading goes
    /// on with the next chunk) and for a message on an unknown channel.
    pub fn messages(&self) -> Messages<'_> {
        let mut channels = HashMap::new();
        let mut schemas = HashMap::new();
        // Channels of the summary let messages after a damaged chunk still be read.
        if let Some(summary) = &self.summary {
            for (id, s) in &summary.schemas {
                schemas.insert(*id, Arc::clone(s));
            }
            for (id, c) in &summary.channels {
                channels.insert(
                    *id,
                    Arc::new(ChannelInfo::new(
                        &c.topic,
                        c.schema.as_deref(),
                        &c.message_encoding,
                    )),
                );
            }
        }
        let mut it = Messages {
            reader: self,
            next_segment: 0,
            pending: VecDeque::new(),
            channels,
            schemas,
        };
        if !self.time_ordered {
            // Overlapping chunks: read everything, then sort (stable, errors first).
            let mut all = Vec::new();
            while it.next_segment < self.segments.len() {
                it.read_segment();
                all.extend(it.pending.drain(..));
            }
            all.sort_by_key(|m| m.as_ref().map_or(0, |m| m.log_time_ns));
            it.pending = all.into();
        }
        it
    }

    /// Topics, types, counts and time span: from the summary when the file has one and is
    /// undamaged, else by reading every message.
    pub fn info(&self) -> BagInfo {
        let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
        let mut count = 0u64;
        let mut span: Option<(u64, u64)> = None;
        let stats = self
            .summary
            .as_ref()
            .and_then(|s| s.stats.as_ref().map(|st| (s, st)));
        let from_summary = self.damage.is_none() && stats.is_some();
        match stats {
            Some((summary, stats)) if from_summary => {
                for (id, c) in &summary.channels {
                    let info = ChannelInfo::new(&c.topic, c.schema.as_deref(), &c.message_encoding);
                    let n = stats.channel_message_counts.get(id).copied().unwrap_or(0);
                    add_topic(&mut topics, &info, n);
                }
                count = stats.message_count;
                if count > 0 {
                    span = Some((stats.message_start_time, stats.message_end_time));
                }
            }
            _ => {
                for m in self.messages().flatten() {
                    add_topic(&mut topics, &m.channel, 1);
                    count += 1;
                    span = Some(span.map_or((m.log_time_ns, m.log_time_ns), |(s, e)| {
                        (s.min(m.log_time_ns), e.max(m.log_time_ns))
                    }));
                }
            }
        }
        BagInfo {
            path: self.path.clone(),
            file_size: self.data.len() as u64,
            profile: self.profile.clone(),
            topics: topics.into_values().collect(),
            message_count: count,
            start_ns: span.map(|s| s.0),
            end_ns: span.map(|s| s.1),
            duration_s: span.map_or(0.0, |(s, e)| e.saturating_sub(s) as f64 * 1e-9),
            from_summary,
            damage: self.damage.as_ref().map(ToString::to_string),
        }
    }
}

fn add_topic(topics: &mut BTreeMap<String, TopicInfo>, c: &ChannelInfo, n: u64) {
    topics
        .entry(c.topic.to_string())
        .or_insert_with(|| TopicInfo {
            topic: c.topic.to_string(),
            type_name: c.type_name.to_string(),
            message_count: 0,
            known_type: c.known.is_some(),
            schema_mismatch: c.schema_mismatch.clone(),
        })
        .message_count += n;
}

/// Iterator of [`BagReader::messages`].
#[derive(Debug)]
pub struct Messages<'a> {
    reader: &'a BagReader,
    next_segment: usize,
    pending: VecDeque<Result<RawMessage>>,
    channels: HashMap<u16, Arc<ChannelInfo>>,
    schemas: HashMap<u16, Arc<mcap::Schema<'static>>>,
}

impl Messages<'_> {
    /// Decodes the next segment into `pending` (one chunk's messages sorted by log time).
    fn read_segment(&mut self) {
        let Some(seg) = self.reader.segments.get(self.next_segment).copied() else {
            return;
        };
        self.next_segment += 1;
        let body = &self.reader.data[seg.body_start..seg.body_end];
        let record = match mcap::parse_record(seg.opcode, body) {
            Ok(r) => r,
            Err(e) => {
                let reason = format!("record (opcode {:#04x}): {e}", seg.opcode);
                self.pending
                    .push_back(Err(self.reader.corrupt(seg.offset, reason)));
                return;
            }
        };
        let mut batch = Vec::new();
        match record {
            Record::Chunk { header, .. } if header.uncompressed_size > MAX_CHUNK_BYTES => {
                let reason = format!(
                    "chunk declares {} bytes uncompressed (more than the {} MiB a chunk may hold)",
                    header.uncompressed_size,
                    MAX_CHUNK_BYTES >> 20
                );
                self.pending.push_back(Err(self.reader.corrupt(seg.offset, reason)));
                return;
            }
            Record::Chunk { header, data } => {
                let records = match read_chunk(header, &data) {
                    Ok(r) => r,
                    Err(e) => {
                        let reason = format!("chunk: {e}");
                        self.pending
                            .push_back(Err(self.reader.corrupt(seg.offset, reason)));
                        return;
                    }
                };
                for r in records {
                    self.take_record(seg, r, &mut batch);
                }
            }
            other => self.take_record(seg, other, &mut batch),
        }
        if seg.times.is_some() {
            batch.sort_by_key(|m| m.as_ref().map_or(0, |m| m.log_time_ns));
        }
        self.pending.extend(batch);
    }

    fn take_record(
        &mut self,
        seg: Segment,
        record: Record<'_>,
        batch: &mut Vec<Result<RawMessage>>,
    ) {
        match record {
            Record::Schema { header, data } => {
                let schema = mcap::Schema {
                    id: header.id,
                    name: header.name,
                    encoding: header.encoding,
                    data: std::borrow::Cow::Owned(data.into_owned()),
                };
                self.schemas.insert(header.id, Arc::new(schema));
            }
            Record::Channel(c) => {
                let schema = self.schemas.get(&c.schema_id).cloned();
                if c.schema_id != 0 && schema.is_none() {
                    let reason = format!(
                        "channel {} ({}) refers to unknown schema {}",
                        c.id, c.topic, c.schema_id
                    );
                    batch.push(Err(self.reader.corrupt(seg.offset, reason)));
                    return;
                }
                let info = ChannelInfo::new(&c.topic, schema.as_deref(), &c.message_encoding);
                self.channels.insert(c.id, Arc::new(info));
            }
            Record::Message { header, data } => {
                let Some(channel) = self.channels.get(&header.channel_id) else {
                    let reason = format!(
                        "message at {} ns refers to unknown channel {}",
                        header.log_time, header.channel_id
                    );
                    batch.push(Err(self.reader.corrupt(seg.offset, reason)));
                    return;
                };
                batch.push(Ok(RawMessage {
                    topic: Arc::clone(&channel.topic),
                    type_name: Arc::clone(&channel.type_name),
                    log_time_ns: header.log_time,
                    publish_time_ns: header.publish_time,
                    sequence: header.sequence,
                    data: data.into_owned(),
                    channel: Arc::clone(channel),
                }));
            }
            _ => {}
        }
    }
}

/// Decompresses a whole chunk (checking its CRC) before any of its records is used, so a
/// damaged chunk yields nothing rather than half-trusted messages.
///
/// Decompression is bounded by the header's `uncompressed_size` (itself at most
/// [`MAX_CHUNK_BYTES`]) and the records inside are walked here, each length checked against
/// what is left: the `mcap` crate's chunk reader reserves whatever a record's length field
/// says, and a damaged one (found by the reliability fuzzer) aborted the process.
fn read_chunk(header: ChunkHeader, data: &[u8]) -> std::result::Result<Vec<Record<'static>>, String> {
    let size = usize::try_from(header.uncompressed_size).map_err(|_| "uncompressed size overflows".to_owned())?;
    let plain: std::borrow::Cow<'_, [u8]> = match header.compression.as_str() {
        "" => std::borrow::Cow::Borrowed(data),
        "zstd" => std::borrow::Cow::Owned(
            zstd::bulk::decompress(data, size).map_err(|e| format!("zstd: {e}"))?,
        ),
        "lz4" => {
            use std::io::Read as _;
            let mut out = Vec::with_capacity(size);
            lz4::Decoder::new(data)
                .map_err(|e| format!("lz4: {e}"))?
                .take(header.uncompressed_size.saturating_add(1))
                .read_to_end(&mut out)
                .map_err(|e| format!("lz4: {e}"))?;
            std::borrow::Cow::Owned(out)
        }
        other => return Err(format!("unsupported compression {other:?}")),
    };
    if plain.len() != size {
        return Err(format!("{} bytes uncompressed, header says {size}", plain.len()));
    }
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(&plain);
        if crc != header.uncompressed_crc {
            return Err(format!("CRC {crc:#010x}, header says {:#010x}", header.uncompressed_crc));
        }
    }
    let mut records = Vec::new();
    let mut rest: &[u8] = &plain;
    while !rest.is_empty() {
        let (Some(&opcode), Some(len)) = (rest.first(), rest.get(1..9)) else {
            return Err(format!("record header cut off, {} bytes before the chunk's end", rest.len()));
        };
        let len = u64::from_le_bytes(len.try_into().map_err(|_| "record length".to_owned())?);
        let body = usize::try_from(len)
            .ok()
            .and_then(|len| rest.get(9..9usize.checked_add(len)?))
            .ok_or_else(|| format!("record (opcode {opcode:#04x}) of {len} bytes overruns the chunk ({} left)", rest.len() - 9))?;
        let record = mcap::parse_record(opcode, body).map_err(|e| format!("record (opcode {opcode:#04x}): {e}"))?;
        records.push(record.into_owned());
        rest = &rest[9 + body.len()..];
    }
    Ok(records)
}

impl Iterator for Messages<'_> {
    type Item = Result<RawMessage>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(m) = self.pending.pop_front() {
                return Some(m);
            }
            if self.next_segment >= self.reader.segments.len() {
                return None;
            }
            self.read_segment();
        }
    }
}
