//! Bag I/O for cowork: MCAP files with the ROS 2 profile, readable by other MCAP / ROS 2 tools
//! (`ros2 bag`, Foxglove, the `mcap` Python packages) and able to read the bags they write.
//!
//! * schema encoding `ros2msg` with the full definition text of
//!   [`cowork_msgs::RosMessage::ros2msg_definition`], message encoding `cdr` with the 4-byte
//!   encapsulation header, zstd-compressed chunks, profile `ros2`;
//! * [`BagWriter`] registers each schema and channel once and writes typed messages
//!   ([`BagWriter::write`]) or untouched payloads of any type ([`BagWriter::write_raw`]);
//! * [`BagReader`] yields [`RawMessage`]s in log-time order; [`RawMessage::decode`] checks the
//!   type name, encoding and schema fields before decoding, so a wrong schema for a known type
//!   is a per-message error naming topic and time, never a crash;
//! * damaged files: [`BagReader::open`] names the file and byte offset of the damage;
//!   [`BagReader::open_recoverable`] reads everything readable around it;
//! * [`check_image`] validates `sensor_msgs/Image` encodings and sizes; [`check_message`] /
//!   [`check_bag`] check topic types of the graph, schemas, payloads and images per message;
//! * [`Player`] schedules replay (rate, loop, start offset, topic filter, `/clock` ticks) with
//!   no ROS dependency; the `cowork bag play` command publishes what it yields.
//!
//! No ROS dependency: this is a plain library used by the `cowork bag` commands and tests.
//!
//! ```
//! use cowork_bag::{BagReader, BagWriter};
//! use cowork_msgs::std_msgs::String as RosString;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("speech.mcap");
//! let mut writer = BagWriter::create(&path)?;
//! let speech = writer.add_channel::<RosString>("/speech_command")?;
//! writer.write(speech, 1_000_000_000, 1_000_000_000, &RosString { data: "teach".into() })?;
//! writer.finish()?;
//!
//! let reader = BagReader::open(&path)?;
//! assert_eq!(reader.info().message_count, 1);
//! for message in reader.messages() {
//!     let message = message?;
//!     assert_eq!(&*message.topic, "/speech_command");
//!     assert_eq!(message.decode::<RosString>()?.data, "teach");
//! }
//! # Ok(())
//! # }
//! ```

mod check;
mod error;
mod image;
pub mod play;
mod read;
mod rosbag2;
pub mod schema;
mod write;

pub use check::{TopicCheck, Verdict, check_bag, check_message, graph_topic_type};
pub use error::{BagError, Result};
pub use image::{bytes_per_pixel, check_image};
pub use read::{BagInfo, BagReader, ChannelInfo, Messages, RawMessage, TopicInfo, storage_file};
pub use rosbag2::{Rosbag2Metadata, Rosbag2Topic, rosbag2_storage_path};
pub use play::{PlayItem, PlayOptions, Player, Rate, Schedule};
pub use write::{BagWriter, ChannelId, DEFAULT_CHUNK_SPAN_S, WriteSummary};
