//! Errors of bag reading and writing.

use std::path::PathBuf;

use cowork_msgs::CdrError;

/// `Result` with [`BagError`].
pub type Result<T, E = BagError> = std::result::Result<T, E>;

/// Why a bag could not be read or written, or one of its messages not decoded.
///
/// File-level variants name the file and the byte offset of the damaged record; message-level
/// variants name the topic and the message's log time (ns since the epoch of the bag's clock).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BagError {
    /// Opening, reading or writing the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The bag file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A rosbag2 directory (`metadata.yaml` + storage files) that cannot be read as one bag.
    #[error("{}: rosbag2 directory: {reason}", path.display())]
    BagDirectory {
        /// The directory.
        path: PathBuf,
        /// What is wrong (no storage file, several of them, an unreadable metadata.yaml).
        reason: String,
    },
    /// A rosbag2 bag in a storage format other than MCAP (the default `sqlite3` of `ros2 bag
    /// record` before Iron): named, with how to convert it.
    #[error(
        "{}: {storage} storage is not supported, only MCAP (convert it: `ros2 bag convert -i BAG -o out.yaml` \
         with `storage_id: mcap`, or record with `ros2 bag record -s mcap`)",
        path.display()
    )]
    UnsupportedStorage {
        /// The bag file or directory.
        path: PathBuf,
        /// The storage it uses, e.g. `sqlite3`.
        storage: String,
    },
    /// The file does not start with the MCAP magic bytes.
    #[error("{}: not an MCAP file (no MCAP magic at byte offset 0)", path.display())]
    NotMcap {
        /// The bag file.
        path: PathBuf,
    },
    /// The file ends in the middle of a record, or before its footer.
    #[error("{}: truncated at byte offset {offset} of {len}: {reason}", path.display())]
    Truncated {
        /// The bag file.
        path: PathBuf,
        /// Byte offset of the first record that is incomplete.
        offset: u64,
        /// File length (bytes).
        len: u64,
        /// What is missing.
        reason: String,
    },
    /// A record is complete but its content does not parse (bad bytes, CRC mismatch, bad
    /// compressed data).
    #[error("{}: corrupt record at byte offset {offset}: {reason}", path.display())]
    Corrupt {
        /// The bag file.
        path: PathBuf,
        /// Byte offset of the damaged record (of the chunk for records inside a chunk).
        offset: u64,
        /// The parser's complaint.
        reason: String,
    },
    /// The MCAP writer failed.
    #[error("{}: writing MCAP failed: {source}", path.display())]
    Write {
        /// The bag file.
        path: PathBuf,
        /// mcap's error.
        source: mcap::McapError,
    },
    /// A topic was added twice with different types.
    #[error("{}: topic {topic} already carries {existing}, cannot also carry {requested}", path.display())]
    TopicTypeConflict {
        /// The bag file.
        path: PathBuf,
        /// Topic name.
        topic: String,
        /// Type already registered for the topic.
        existing: String,
        /// Type asked for now.
        requested: String,
    },
    /// A message was written to a channel of another type.
    #[error("{}: channel of topic {topic} carries {channel_type}, not {message_type}", path.display())]
    ChannelTypeMismatch {
        /// The bag file.
        path: PathBuf,
        /// Topic of the channel.
        topic: String,
        /// Type of the channel.
        channel_type: String,
        /// Type of the message written.
        message_type: String,
    },
    /// A `ChannelId` that this writer did not hand out.
    #[error("{}: channel id {channel} was not created by this writer", path.display())]
    UnknownChannel {
        /// The bag file.
        path: PathBuf,
        /// The id given.
        channel: usize,
    },
    /// The message is of another type than the one asked for.
    #[error("topic {topic} at {log_time_ns} ns: message is {actual}, not {requested}")]
    TypeMismatch {
        /// Topic name.
        topic: String,
        /// Log time (ns).
        log_time_ns: u64,
        /// Type in the bag.
        actual: String,
        /// Type asked for.
        requested: String,
    },
    /// The bag's schema text for a known type has other fields than ours.
    #[error(
        "topic {topic} at {log_time_ns} ns: schema of {type_name} differs from cowork_msgs: {detail}"
    )]
    SchemaMismatch {
        /// Topic name.
        topic: String,
        /// Log time (ns).
        log_time_ns: u64,
        /// ROS type name.
        type_name: String,
        /// First difference found.
        detail: String,
    },
    /// The channel's message encoding is not `cdr`.
    #[error("topic {topic} at {log_time_ns} ns: message encoding {encoding:?} is not cdr")]
    UnsupportedEncoding {
        /// Topic name.
        topic: String,
        /// Log time (ns).
        log_time_ns: u64,
        /// Encoding in the bag.
        encoding: String,
    },
    /// The type is not one of `cowork_msgs::known_types()`.
    #[error("topic {topic} at {log_time_ns} ns: type {type_name:?} is not known to cowork_msgs")]
    UnknownType {
        /// Topic name.
        topic: String,
        /// Log time (ns).
        log_time_ns: u64,
        /// Type in the bag.
        type_name: String,
    },
    /// The CDR payload does not decode as its type.
    #[error("topic {topic} at {log_time_ns} ns: {source}")]
    Decode {
        /// Topic name.
        topic: String,
        /// Log time (ns).
        log_time_ns: u64,
        /// The CDR decoder's error.
        source: CdrError,
    },
    /// `sensor_msgs/Image` with an encoding we do not know.
    #[error("topic {topic}: image encoding {encoding:?} is not supported (known: {known})")]
    ImageEncoding {
        /// Topic name.
        topic: String,
        /// Encoding in the message.
        encoding: String,
        /// Encodings supported, comma separated.
        known: String,
    },
    /// `sensor_msgs/Image` whose row length cannot hold `width` pixels.
    #[error(
        "topic {topic}: image step {step} B is less than width {width} × {bytes_per_pixel} B ({encoding})"
    )]
    ImageStep {
        /// Topic name.
        topic: String,
        /// Row length (bytes).
        step: u32,
        /// Columns (pixels).
        width: u32,
        /// Bytes per pixel of the encoding.
        bytes_per_pixel: usize,
        /// Encoding.
        encoding: String,
    },
    /// `sensor_msgs/Image` whose data length is not `step × height`.
    #[error(
        "topic {topic}: image data has {len} B, expected step {step} × height {height} = {expected} B"
    )]
    ImageSize {
        /// Topic name.
        topic: String,
        /// Row length (bytes).
        step: u32,
        /// Rows (pixels).
        height: u32,
        /// `step × height` (bytes).
        expected: u64,
        /// Actual data length (bytes).
        len: usize,
    },
    /// A playback option out of range.
    #[error("option --{name} = {value}: {reason}")]
    InvalidOption {
        /// Option name.
        name: String,
        /// The value given.
        value: String,
        /// What is allowed.
        reason: String,
    },
    /// A topic asked for is not in the bag.
    #[error("{}: no topic {topic} in the bag (it has: {available})", path.display())]
    UnknownTopic {
        /// The bag file.
        path: PathBuf,
        /// The topic asked for.
        topic: String,
        /// The bag's topics, comma separated.
        available: String,
    },
    /// A topic of the cowork graph carries another type than the graph's.
    #[error("topic {topic} carries {actual}, but the cowork graph expects {expected} there")]
    TopicType {
        /// Topic name.
        topic: String,
        /// Type the graph expects.
        expected: String,
        /// Type in the bag.
        actual: String,
    },
}
