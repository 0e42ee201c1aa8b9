//! Untyped endpoints: publish and receive serialised CDR payloads of any ROS type, named only by
//! its type string. This is what `cowork bag record` / `play` need to carry messages whose type
//! `cowork_msgs` does not know, untouched.
//!
//! Payloads are exchanged as they are stored in a ROS 2 bag: the 4-byte encapsulation header
//! (`00 01 00 00` for little-endian CDR) followed by the CDR body. The endpoints are RustDDS
//! data readers / writers on the node's DDS participant with a pass-through (de)serializer;
//! they match typed ROS 2 endpoints of the same topic and type name like any other. They are
//! not listed in the node's `ros_discovery_info` (ros2-client keeps that list private), so
//! `ros2 node info` does not show them; `ros2 topic info` does.

use anyhow::{Context as _, Result, bail};
use ros2_client::dds::rustdds::{
    self, QosPolicies, RTPSEntity, RepresentationIdentifier, Timestamp, bytes::Bytes, no_key,
};
use ros2_client::{MessageTypeName, Name, QosProfile};

use crate::RosNode;

/// One received sample.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawSample {
    /// Encapsulation header (representation id, options 0) followed by the CDR body.
    pub data: Vec<u8>,
    /// When the DDS stack received it (ns since the Unix epoch, wall clock).
    pub receive_time_ns: u64,
    /// The writer's source timestamp (ns since the Unix epoch), when it sent one.
    pub source_time_ns: Option<u64>,
}

/// The raw sample as the DDS reader hands it over (before the receive metadata is added).
#[derive(Debug)]
struct Payload(Vec<u8>);

/// Pass-through (de)serializer of [`Payload`].
#[derive(Debug)]
struct PassThrough;

const ENCODINGS: [RepresentationIdentifier; 4] = [
    RepresentationIdentifier::CDR_LE,
    RepresentationIdentifier::CDR_BE,
    RepresentationIdentifier::PL_CDR_LE,
    RepresentationIdentifier::PL_CDR_BE,
];

impl no_key::DeserializerAdapter<Payload> for PassThrough {
    type Error = std::convert::Infallible;
    type Decoded = Payload;

    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &ENCODINGS
    }

    fn transform_decoded(decoded: Payload) -> Payload {
        decoded
    }
}

#[derive(Clone, Debug)]
struct PassThroughDecoder;

impl<'de> no_key::Decode<'de, Payload> for PassThroughDecoder {
    type Error = std::convert::Infallible;

    fn decode_bytes(
        self,
        input: &'de [u8],
        encoding: RepresentationIdentifier,
    ) -> std::result::Result<Payload, Self::Error> {
        let mut data = Vec::with_capacity(input.len() + 4);
        data.extend_from_slice(&encoding.to_bytes());
        data.extend_from_slice(&[0, 0]);
        data.extend_from_slice(input);
        Ok(Payload(data))
    }
}

impl no_key::DefaultDecoder<Payload> for PassThrough {
    type Decoder = PassThroughDecoder;
    const DECODER: Self::Decoder = PassThroughDecoder;
}

/// Body of a little-endian CDR payload, already without its encapsulation header.
#[derive(Debug)]
struct Body(Bytes);

impl no_key::SerializerAdapter<Body> for PassThrough {
    type Error = std::convert::Infallible;

    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }

    fn to_bytes(value: &Body) -> std::result::Result<Bytes, Self::Error> {
        Ok(value.0.clone())
    }
}

/// Publishes serialised payloads on one topic (see the module docs).
pub struct RawPublisher {
    writer: no_key::DataWriter<Body, PassThrough>,
    topic: String,
    type_name: String,
}

impl std::fmt::Debug for RawPublisher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "RawPublisher<{}>({})", self.type_name, self.topic)
    }
}

impl RawPublisher {
    /// Publishes one payload: encapsulation header + CDR body. Only little-endian CDR
    /// (`00 01`) is accepted (what every ROS 2 middleware writes); anything else is an error
    /// naming the topic.
    pub fn publish(&self, cdr: &[u8]) -> Result<()> {
        self.publish_stamped(cdr, None)
    }

    /// As [`publish`](Self::publish), with the DDS source timestamp set to `source_time_ns`
    /// (ns since the Unix epoch) instead of now.
    pub fn publish_stamped(&self, cdr: &[u8], source_time_ns: Option<u64>) -> Result<()> {
        if cdr.len() < 4 {
            bail!("{}: payload of {} B has no encapsulation header", self.topic, cdr.len());
        }
        if cdr[..2] != RepresentationIdentifier::CDR_LE.to_bytes() {
            bail!(
                "{}: payload encapsulation {:02x} {:02x} is not little-endian CDR (00 01); \
                 only that is republished",
                self.topic,
                cdr[0],
                cdr[1]
            );
        }
        let stamp = source_time_ns.map(nanos_to_timestamp);
        self.writer
            .write(Body(Bytes::copy_from_slice(&cdr[4..])), stamp)
            .map_err(|e| anyhow::anyhow!("publish on {} failed: {e:?}", self.topic))
    }

    /// Blocks until every matched reliable reader has acknowledged everything published so
    /// far, or `max_wait` passes: `Ok(false)` on time-out. Returns at once when no reliable
    /// reader is matched. A replay uses it to bound the data in flight and, before it exits,
    /// so that nothing still in the writer's buffer is lost.
    pub fn wait_for_acknowledgments(&self, max_wait: std::time::Duration) -> Result<bool> {
        self.writer
            .wait_for_acknowledgments(max_wait)
            .map_err(|e| anyhow::anyhow!("waiting for acknowledgements on {} failed: {e:?}", self.topic))
    }

    /// Topic name.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// ROS type name given at creation.
    pub fn type_name(&self) -> &str {
        &self.type_name
    }
}

/// Receives serialised payloads from one topic (see the module docs).
pub struct RawSubscription {
    reader: no_key::SimpleDataReader<Payload, PassThrough>,
    topic: String,
    type_name: String,
}

impl std::fmt::Debug for RawSubscription {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "RawSubscription<{}>({})", self.type_name, self.topic)
    }
}

impl RawSubscription {
    /// The next waiting sample, if any; never blocks.
    pub fn take(&self) -> Option<RawSample> {
        self.reader.drain_read_notifications();
        for _ in 0..64 {
            match self.reader.try_take_one() {
                Ok(Some(change)) => {
                    let receive_time_ns = timestamp_to_nanos(change.receive_instant);
                    let source_time_ns = change
                        .write_options
                        .source_timestamp()
                        .filter(|t| *t != Timestamp::INVALID)
                        .map(timestamp_to_nanos);
                    return Some(RawSample {
                        data: change.sample.0,
                        receive_time_ns,
                        source_time_ns,
                    });
                }
                Ok(None) => return None,
                Err(e) => tracing::warn!("{}: dropped a sample: {e:?}", self.topic),
            }
        }
        None
    }

    /// Topic name.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// ROS type name given at creation.
    pub fn type_name(&self) -> &str {
        &self.type_name
    }
}

/// `sensor_msgs/msg/Image` (or `sensor_msgs/Image`, or the DDS spelling) → its DDS type name.
pub fn message_type_name(type_name: &str) -> Result<MessageTypeName> {
    if let Some((pkg, rest)) = type_name.split_once("::msg::dds_::") {
        let name = rest.strip_suffix('_').unwrap_or(rest);
        return Ok(MessageTypeName::new(pkg, name));
    }
    let parts: Vec<&str> = type_name.split('/').collect();
    match parts.as_slice() {
        [pkg, "msg", name] | [pkg, name] if !pkg.is_empty() && !name.is_empty() => {
            Ok(MessageTypeName::new(pkg, name))
        }
        _ => bail!("type name {type_name:?} is not of the form pkg/msg/Name"),
    }
}

fn timestamp_to_nanos(t: Timestamp) -> u64 {
    let ticks = t.to_ticks();
    let secs = ticks >> 32;
    let frac = ticks & 0xffff_ffff;
    secs * 1_000_000_000 + ((frac * 1_000_000_000) >> 32)
}

fn nanos_to_timestamp(ns: u64) -> Timestamp {
    let secs = ns / 1_000_000_000;
    let frac = ((ns % 1_000_000_000) << 32) / 1_000_000_000;
    Timestamp::from_ticks((secs << 32) | frac)
}

impl RosNode {
    fn raw_topic(&mut self, topic: &str, type_name: &str, qos: &QosProfile) -> Result<rustdds::Topic> {
        let name = Name::parse(topic)
            .map_err(|e| anyhow::anyhow!("invalid topic name {topic:?}: {e:?}"))?;
        let ty = message_type_name(type_name)?;
        self.node
            .create_topic(&name, ty, qos)
            .with_context(|| format!("cannot create topic {topic} ({type_name})"))
    }

    /// A publisher of serialised `type_name` payloads on `topic` (see [`crate::raw`]).
    pub fn raw_publisher(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: &QosProfile,
    ) -> Result<RawPublisher> {
        let t = self.raw_topic(topic, type_name, qos)?;
        let dds_qos = QosPolicies::from(qos.clone());
        let writer = self
            .context
            .domain_participant()
            .create_publisher(&dds_qos)
            .and_then(|p| p.create_datawriter_no_key::<Body, PassThrough>(&t, Some(dds_qos)))
            .map_err(|e| anyhow::anyhow!("cannot publish on {topic} ({type_name}): {e:?}"))?;
        Ok(RawPublisher { writer, topic: topic.to_owned(), type_name: type_name.to_owned() })
    }

    /// A subscription to serialised `type_name` payloads on `topic` (see [`crate::raw`]).
    pub fn raw_subscription(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: &QosProfile,
    ) -> Result<RawSubscription> {
        let t = self.raw_topic(topic, type_name, qos)?;
        let dds_qos = QosPolicies::from(qos.clone());
        let reader = self
            .context
            .domain_participant()
            .create_subscriber(&dds_qos)
            .and_then(|s| s.create_simple_datareader_no_key::<Payload, PassThrough>(&t, Some(dds_qos)))
            .map_err(|e| anyhow::anyhow!("cannot subscribe to {topic} ({type_name}): {e:?}"))?;
        Ok(RawSubscription { reader, topic: topic.to_owned(), type_name: type_name.to_owned() })
    }

    /// Readers of other participants discovered so far on `topic` (ROS name): once one is,
    /// a writer of ours on the topic matches it.
    pub fn remote_reader_count(&self, topic: &str) -> usize {
        let dds_name = format!("rt{topic}");
        let participant = self.context.domain_participant();
        let own = participant.guid().prefix;
        participant
            .discovered_readers()
            .into_iter()
            .filter(|r| r.subscription_topic_data.topic_name() == &dds_name && r.reader_proxy.remote_reader_guid.prefix != own)
            .count()
    }

    /// ROS types (`pkg/msg/Name`) of the writers discovered so far on `topic` (ROS name),
    /// sorted, without repeats. Readers do not count: every ros2-client node has a `/clock`
    /// reader of its own type, which is no reason to record `/clock` with that type.
    pub fn writer_type_names(&self, topic: &str) -> Vec<String> {
        let dds_name = format!("rt{topic}");
        let mut types: Vec<String> = self
            .context
            .domain_participant()
            .discovered_writers()
            .into_iter()
            .filter(|w| w.publication_topic_data.topic_name == dds_name)
            .filter_map(|w| crate::node::ros_type_name(&w.publication_topic_data.type_name))
            .collect();
        types.sort();
        types.dedup();
        types
    }

    /// The QoS that matches every writer discovered so far on `topic` (ROS name), the way
    /// `ros2 bag record` adapts: reliable only if all writers are reliable, transient-local
    /// only if all are; keep last `depth`. `None` when no writer is known yet.
    pub fn offered_qos(&self, topic: &str, depth: usize) -> Option<QosProfile> {
        use ros2_client::qos::{Durability, History, Reliability, WhenFull};
        let dds_name = format!("rt{topic}");
        let writers: Vec<_> = self
            .context
            .domain_participant()
            .discovered_writers()
            .into_iter()
            .filter(|w| w.publication_topic_data.topic_name == dds_name)
            .collect();
        if writers.is_empty() {
            return None;
        }
        let all_reliable = writers.iter().all(|w| {
            matches!(
                w.publication_topic_data.reliability,
                Some(rustdds::policy::Reliability::Reliable { .. })
            )
        });
        let all_latched = writers.iter().all(|w| {
            matches!(
                w.publication_topic_data.durability,
                Some(rustdds::policy::Durability::TransientLocal)
            )
        });
        Some(QosProfile {
            reliability: if all_reliable {
                Reliability::Reliable { when_full: WhenFull::DEFAULT }
            } else {
                Reliability::BestEffort
            },
            durability: if all_latched { Durability::TransientLocal } else { Durability::Volatile },
            history: History::KeepLast { depth },
            ..QosProfile::subscription_default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_names_in_all_spellings() {
        for s in ["sensor_msgs/msg/Image", "sensor_msgs/Image", "sensor_msgs::msg::dds_::Image_"] {
            let t = message_type_name(s).unwrap();
            assert_eq!(t.dds_msg_type(), "sensor_msgs::msg::dds_::Image_", "{s}");
        }
        assert!(message_type_name("Image").is_err());
        assert!(message_type_name("a/b/c/d").is_err());
    }

    #[test]
    fn timestamps_round_trip_to_the_nanosecond_scale() {
        for ns in [0u64, 1_700_000_000_123_456_789, 999_999_999] {
            let back = timestamp_to_nanos(nanos_to_timestamp(ns));
            assert!(back.abs_diff(ns) <= 1, "{ns} -> {back}");
        }
    }
}
