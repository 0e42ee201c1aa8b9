//! Checks of single messages before they are replayed or trusted: the type the graph expects
//! on a topic, the schema, that the payload decodes, and image sizes and encodings.

use cowork_msgs::sensor_msgs::Image;
use cowork_msgs::type_name_matches;

use crate::{BagError, RawMessage, Result, check_image};

/// The type the cowork graph expects on `topic`, if it is one of the graph's topics
/// ([`cowork_msgs::topics::all`], SPEC "Graph, topics, messages").
pub fn graph_topic_type(topic: &str) -> Option<String> {
    cowork_msgs::topics::find(topic).map(|(_, ty, _)| ty)
}

/// Whether `a` and `b` name the same ROS type (`pkg/msg/Name`, `pkg/Name` or DDS spelling).
fn same_type(expected: &str, actual: &str) -> bool {
    let mut parts = expected.split('/');
    match (parts.next(), parts.next(), parts.next()) {
        (Some(pkg), Some("msg"), Some(name)) => type_name_matches(pkg, name, actual),
        _ => expected == actual,
    }
}

/// What [`check_message`] concluded about a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// A known type whose schema and payload check out.
    Valid,
    /// A type `cowork_msgs` does not know: carried through untouched, not checked.
    Unknown,
}

/// Checks a message before replay:
///
/// * on a topic of the graph ([`graph_topic_type`]) it must carry the graph's type
///   ([`BagError::TopicType`]);
/// * for a type of `cowork_msgs`: message encoding `cdr`, the bag's schema has our fields, and
///   the payload decodes; a `sensor_msgs/Image` must also pass [`check_image`];
/// * other types are [`Verdict::Unknown`] and not looked into.
///
/// Cost: one decode of the payload (a copy of an image's data).
pub fn check_message(message: &RawMessage) -> Result<Verdict> {
    if let Some(expected) = graph_topic_type(&message.topic)
        && !same_type(&expected, &message.type_name)
    {
        return Err(BagError::TopicType {
            topic: message.topic.to_string(),
            expected,
            actual: message.type_name.to_string(),
        });
    }
    let Some(info) = message.channel.known else {
        return Ok(Verdict::Unknown);
    };
    if info.matches("sensor_msgs/msg/Image") {
        let image: Image = message.decode()?;
        check_image(&message.topic, &image)?;
    } else {
        message.decode_json()?;
    }
    Ok(Verdict::Valid)
}

/// Result of checking every message of one topic with [`check_message`].
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TopicCheck {
    /// Topic name.
    pub topic: String,
    /// ROS type name as the bag spells it.
    pub type_name: String,
    /// Messages looked at.
    pub messages: u64,
    /// Messages that failed a check.
    pub bad: u64,
    /// Whether the type is unknown to `cowork_msgs` (messages carried through unchecked).
    pub unknown_type: bool,
    /// The first failure, naming topic and log time.
    pub first_error: Option<String>,
}

/// Runs [`check_message`] on every readable message of `reader`, per topic (sorted by name).
/// Damage to the file itself is reported by [`crate::BagReader::damage`], not here.
pub fn check_bag(reader: &crate::BagReader) -> Vec<TopicCheck> {
    let mut out: std::collections::BTreeMap<String, TopicCheck> = std::collections::BTreeMap::new();
    for message in reader.messages().flatten() {
        let entry = out.entry(message.topic.to_string()).or_insert_with(|| TopicCheck {
            topic: message.topic.to_string(),
            type_name: message.type_name.to_string(),
            ..Default::default()
        });
        entry.messages += 1;
        match check_message(&message) {
            Ok(Verdict::Valid) => {}
            Ok(Verdict::Unknown) => entry.unknown_type = true,
            Err(e) => {
                entry.bad += 1;
                entry.first_error.get_or_insert_with(|| e.to_string());
            }
        }
    }
    out.into_values().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn graph_topics_name_known_types() {
        for (topic, ty, _) in cowork_msgs::topics::all() {
            assert!(cowork_msgs::find_type(&ty).is_some(), "{topic}: {ty} unknown");
        }
        assert_eq!(graph_topic_type("/joint_states").as_deref(), Some("sensor_msgs/msg/JointState"));
        assert_eq!(graph_topic_type("/nope"), None);
        assert!(same_type("sensor_msgs/msg/Image", "sensor_msgs/Image"));
        assert!(!same_type("sensor_msgs/msg/JointState", "std_msgs/msg/String"));
    }
}
