//! rosbag2 bag directories (what `ros2 bag record -s mcap -o NAME` writes): a directory `NAME/`
//! holding the storage file `NAME_0.mcap` and a `metadata.yaml` that `ros2 bag info|play` and
//! the `rosbags` library read. Reading one is [`storage_file`](crate::storage_file); this module
//! writes the metadata.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::{BagError, Result};

/// One recorded topic of a rosbag2 directory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rosbag2Topic {
    /// Topic name, e.g. `/joint_states`.
    pub name: String,
    /// ROS type, e.g. `sensor_msgs/msg/JointState`.
    pub type_name: String,
    /// Messages written.
    pub message_count: u64,
}

/// What `metadata.yaml` says about a finished single-file bag.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rosbag2Metadata {
    /// The storage file, relative to the directory (e.g. `run_0.mcap`).
    pub storage_file: String,
    /// Log time of the first message, ns since the Unix epoch (0 when empty).
    pub start_ns: u64,
    /// Log time of the last message, ns since the Unix epoch.
    pub end_ns: u64,
    /// Every recorded topic.
    pub topics: Vec<Rosbag2Topic>,
}

/// The storage file of a new rosbag2 directory `dir`: `dir/<name of dir>_0.mcap`.
pub fn rosbag2_storage_path(dir: &Path) -> PathBuf {
    let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "bag".into());
    dir.join(format!("{name}_0.mcap"))
}

#[derive(Serialize)]
struct Doc<'a> {
    rosbag2_bagfile_information: Info<'a>,
}

#[derive(Serialize)]
struct Info<'a> {
    version: u32,
    storage_identifier: &'a str,
    duration: Nanos,
    starting_time: SinceEpoch,
    message_count: u64,
    topics_with_message_count: Vec<TopicCount<'a>>,
    compression_format: &'a str,
    compression_mode: &'a str,
    relative_file_paths: Vec<&'a str>,
    files: Vec<File<'a>>,
}

#[derive(Serialize)]
struct Nanos {
    nanoseconds: u64,
}

#[derive(Serialize)]
struct SinceEpoch {
    nanoseconds_since_epoch: u64,
}

#[derive(Serialize)]
struct TopicCount<'a> {
    topic_metadata: TopicMetadata<'a>,
    message_count: u64,
}

#[derive(Serialize)]
struct TopicMetadata<'a> {
    name: &'a str,
    #[serde(rename = "type")]
    type_name: &'a str,
    serialization_format: &'a str,
    /// rosbag2 keeps the writers' QoS here as a YAML string; empty lets a player use defaults.
    offered_qos_profiles: &'a str,
}

#[derive(Serialize)]
struct File<'a> {
    path: &'a str,
    starting_time: SinceEpoch,
    duration: Nanos,
    message_count: u64,
}

impl Rosbag2Metadata {
    /// The `metadata.yaml` text (rosbag2 format version 5, as ROS 2 Humble writes it; later
    /// distributions and `rosbags` read it too). Messages are CDR, the bag uncompressed at the
    /// rosbag2 level (our chunks are zstd inside MCAP, which is the storage plugin's business).
    pub fn to_yaml(&self) -> std::result::Result<String, serde_yaml_ng::Error> {
        let total: u64 = self.topics.iter().map(|t| t.message_count).sum();
        let duration = Nanos { nanoseconds: self.end_ns.saturating_sub(self.start_ns) };
        let doc = Doc {
            rosbag2_bagfile_information: Info {
                version: 5,
                storage_identifier: "mcap",
                duration: Nanos { nanoseconds: duration.nanoseconds },
                starting_time: SinceEpoch { nanoseconds_since_epoch: self.start_ns },
                message_count: total,
                topics_with_message_count: self
                    .topics
                    .iter()
                    .map(|t| TopicCount {
                        topic_metadata: TopicMetadata {
                            name: &t.name,
                            type_name: &t.type_name,
                            serialization_format: "cdr",
                            offered_qos_profiles: "",
                        },
                        message_count: t.message_count,
                    })
                    .collect(),
                compression_format: "",
                compression_mode: "",
                relative_file_paths: vec![&self.storage_file],
                files: vec![File {
                    path: &self.storage_file,
                    starting_time: SinceEpoch { nanoseconds_since_epoch: self.start_ns },
                    duration,
                    message_count: total,
                }],
            },
        };
        serde_yaml_ng::to_string(&doc)
    }

    /// Writes `dir/metadata.yaml` with [`cowork_store::write_atomic`] (temporary file, fsync,
    /// rename, directory fsync): a crash leaves no metadata or all of it, never half.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let path = dir.join("metadata.yaml");
        let io = |source| BagError::Io { path: path.clone(), source };
        let text = self.to_yaml().map_err(|e| io(std::io::Error::other(e)))?;
        cowork_store::write_atomic(&path, text.as_bytes()).map_err(io)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metadata_names_the_storage_file_that_storage_file_then_opens() {
        let dir = tempfile::tempdir().expect("tempdir");
        let bag = dir.path().join("run");
        std::fs::create_dir(&bag).expect("mkdir");
        let storage = rosbag2_storage_path(&bag);
        assert_eq!(storage.file_name().and_then(|n| n.to_str()), Some("run_0.mcap"));
        std::fs::write(&storage, b"x").expect("storage");
        std::fs::write(bag.join("decoy.mcap"), b"x").expect("decoy");
        let meta = Rosbag2Metadata {
            storage_file: "run_0.mcap".into(),
            start_ns: 1_000,
            end_ns: 5_000,
            topics: vec![
                Rosbag2Topic { name: "/joint_states".into(), type_name: "sensor_msgs/msg/JointState".into(), message_count: 3 },
                Rosbag2Topic { name: "/clock".into(), type_name: "rosgraph_msgs/msg/Clock".into(), message_count: 4 },
            ],
        };
        meta.write(&bag).expect("write");
        // Two .mcap files: only metadata.yaml says which one is the bag.
        assert_eq!(crate::storage_file(&bag).expect("storage file"), storage);
        let yaml: serde_yaml_ng::Value =
            serde_yaml_ng::from_str(&std::fs::read_to_string(bag.join("metadata.yaml")).expect("read")).expect("yaml");
        let info = &yaml["rosbag2_bagfile_information"];
        assert_eq!(info["message_count"].as_u64(), Some(7));
        assert_eq!(info["duration"]["nanoseconds"].as_u64(), Some(4_000));
        assert_eq!(info["storage_identifier"].as_str(), Some("mcap"));
        assert_eq!(info["topics_with_message_count"][1]["topic_metadata"]["type"].as_str(), Some("rosgraph_msgs/msg/Clock"));
        assert_eq!(info["files"][0]["message_count"].as_u64(), Some(7));
    }
}
