//! The ROS 2 graph as `ros2 node list` / `ros2 topic info -v` see it: the publishers and
//! subscriptions of a topic with their QoS (from DDS discovery) and the node each belongs to
//! (from `ros_discovery_info`, the `rmw_dds_common/msg/ParticipantEntitiesInfo` every ROS 2
//! participant publishes, reliable + transient local, so a late joiner gets the current list).

use std::collections::BTreeMap;

use anyhow::{Context as _, Result};
use ros2_client::dds::rustdds::policy::{Durability, History, Reliability};
use ros2_client::dds::rustdds::{GUID, QosPolicies, RTPSEntity};
use ros2_client::{Gid, MessageTypeName};
use serde::{Deserialize, Serialize};

use crate::node::{RosNode, ros_topic_name, ros_type_name};

/// The DDS topic of the node graph.
const DISCOVERY_TOPIC: &str = "ros_discovery_info";

/// One node's entry in `ros_discovery_info` (rmw_dds_common/msg/NodeEntitiesInfo).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct NodeEntities {
    node_namespace: String,
    node_name: String,
    reader_gid_seq: Vec<Gid>,
    writer_gid_seq: Vec<Gid>,
}

/// One participant's `ros_discovery_info` sample (rmw_dds_common/msg/ParticipantEntitiesInfo).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ParticipantEntities {
    gid: Gid,
    node_entities_info_seq: Vec<NodeEntities>,
}

/// A ROS 2 node seen on the domain.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct GraphNode {
    /// Fully qualified name, e.g. `/ds_controller`.
    pub name: String,
    /// How many publishers / subscriptions the node announced.
    pub writers: usize,
    /// See `writers`.
    pub readers: usize,
}

/// A publisher or subscription of a topic, as discovery reports it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    /// ROS type, `pkg/msg/Name` (the DDS name when it is not a ROS message type).
    pub type_name: String,
    /// The node that announced this endpoint, when its participant published one.
    pub node: Option<String>,
    /// `RELIABLE` or `BEST_EFFORT`.
    pub reliability: &'static str,
    /// `VOLATILE`, `TRANSIENT_LOCAL`, ...
    pub durability: &'static str,
    /// `KEEP_LAST (N)` / `KEEP_ALL`, or `UNKNOWN` (a publisher's history is not announced).
    pub history: String,
    /// The endpoint's DDS GUID, hex.
    pub gid: String,
}

/// Publishers and subscriptions of one topic.
#[derive(Debug, Clone, Default)]
pub struct TopicEndpoints {
    /// Writers of the topic.
    pub publishers: Vec<Endpoint>,
    /// Readers of the topic.
    pub subscriptions: Vec<Endpoint>,
}

/// Follows `ros_discovery_info`: which node owns which endpoint.
pub struct GraphWatch {
    reader: ros2_client::Subscription<ParticipantEntities>,
    participants: BTreeMap<Gid, Vec<NodeEntities>>,
}

impl std::fmt::Debug for GraphWatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GraphWatch").field("participants", &self.participants.len()).finish_non_exhaustive()
    }
}

impl RosNode {
    /// Starts following the node graph (`ros_discovery_info`); give it a moment of discovery
    /// before asking [`GraphWatch::nodes`].
    pub fn graph_watch(&mut self) -> Result<GraphWatch> {
        // Reliable + transient local as every ROS 2 participant writes it (the history of one
        // sample per participant), so the current graph arrives at once.
        let qos = crate::qos::latched();
        let topic = self
            .context
            .create_topic(DISCOVERY_TOPIC.to_owned(), MessageTypeName::new("rmw_dds_common", "ParticipantEntitiesInfo"), &qos)
            .context("cannot create the ros_discovery_info topic")?;
        let inner = self
            .node
            .create_subscription::<ParticipantEntities>(&topic, Some(qos))
            .context("cannot subscribe to ros_discovery_info")?;
        Ok(GraphWatch { reader: inner, participants: BTreeMap::new() })
    }

    /// The publishers and subscriptions DDS discovery has seen on `topic` (a ROS name such as
    /// `/joint_states`), with their QoS and, through `watch`, their nodes.
    pub fn topic_endpoints(&self, topic: &str, watch: Option<&mut GraphWatch>) -> TopicEndpoints {
        let owners = watch.map(|w| w.owners()).unwrap_or_default();
        let owner = |guid: GUID| owners.get(&Gid::from(guid)).cloned();
        let participant = self.context.domain_participant();
        // Our own endpoints (ros2-client's `/clock` reader, the caller's) are not the graph's.
        let own = participant.guid().prefix;
        let mut out = TopicEndpoints::default();
        for w in participant.discovered_writers() {
            let d = &w.publication_topic_data;
            if d.key.prefix == own || ros_topic_name(&d.topic_name).as_deref() != Some(topic) {
                continue;
            }
            out.publishers.push(Endpoint {
                type_name: ros_type_name(&d.type_name).unwrap_or_else(|| d.type_name.clone()),
                node: owner(d.key),
                reliability: reliability_name(d.reliability),
                durability: durability_name(d.durability),
                history: "UNKNOWN".to_owned(),
                gid: hex(&Gid::from(d.key)),
            });
        }
        for r in participant.discovered_readers() {
            let d = &r.subscription_topic_data;
            if d.key().prefix == own || ros_topic_name(d.topic_name()).as_deref() != Some(topic) {
                continue;
            }
            let qos: QosPolicies = d.qos();
            out.subscriptions.push(Endpoint {
                type_name: ros_type_name(d.type_name()).unwrap_or_else(|| d.type_name().clone()),
                node: owner(d.key()),
                reliability: reliability_name(qos.reliability()),
                durability: durability_name(qos.durability()),
                history: history_name(qos.history()),
                gid: hex(&Gid::from(d.key())),
            });
        }
        out
    }
}

impl GraphWatch {
    fn take_updates(&mut self) {
        // Bounded: undecodable samples (another distribution's layout) are skipped.
        for _ in 0..1024 {
            match self.reader.take() {
                Ok(Some((p, _info))) => {
                    self.participants.insert(p.gid, p.node_entities_info_seq);
                }
                Ok(None) => break,
                Err(e) => tracing::debug!("ros_discovery_info: undecodable sample skipped: {e:?}"),
            }
        }
    }

    /// Nodes announced so far, sorted by name (our own CLI node included).
    pub fn nodes(&mut self) -> Vec<GraphNode> {
        self.take_updates();
        let mut nodes: Vec<GraphNode> = self
            .participants
            .values()
            .flatten()
            .map(|n| GraphNode {
                name: qualified(&n.node_namespace, &n.node_name),
                writers: n.writer_gid_seq.len(),
                readers: n.reader_gid_seq.len(),
            })
            .collect();
        nodes.sort();
        nodes
    }

    /// Endpoint GID → the fully qualified name of the node that announced it.
    fn owners(&mut self) -> BTreeMap<Gid, String> {
        self.take_updates();
        let mut map = BTreeMap::new();
        for n in self.participants.values().flatten() {
            let name = qualified(&n.node_namespace, &n.node_name);
            for g in n.reader_gid_seq.iter().chain(&n.writer_gid_seq) {
                map.insert(*g, name.clone());
            }
        }
        map
    }
}

fn qualified(namespace: &str, name: &str) -> String {
    let ns = namespace.trim_end_matches('/');
    format!("{ns}/{name}")
}

fn hex(gid: &Gid) -> String {
    gid.to_bytes16().iter().map(|b| format!("{b:02x}")).collect()
}

fn reliability_name(r: Option<Reliability>) -> &'static str {
    match r {
        Some(Reliability::Reliable { .. }) => "RELIABLE",
        Some(Reliability::BestEffort) => "BEST_EFFORT",
        None => "UNKNOWN",
    }
}

fn durability_name(d: Option<Durability>) -> &'static str {
    match d {
        Some(Durability::Volatile) => "VOLATILE",
        Some(Durability::TransientLocal) => "TRANSIENT_LOCAL",
        Some(Durability::Transient) => "TRANSIENT",
        Some(Durability::Persistent) => "PERSISTENT",
        None => "UNKNOWN",
    }
}

fn history_name(h: Option<History>) -> String {
    match h {
        Some(History::KeepLast { depth }) => format!("KEEP_LAST ({depth})"),
        Some(History::KeepAll) => "KEEP_ALL".to_owned(),
        None => "UNKNOWN".to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_qualified_like_ros2_node_list() {
        assert_eq!(qualified("/", "ds_controller"), "/ds_controller");
        assert_eq!(qualified("/left", "ds_controller"), "/left/ds_controller");
        assert_eq!(qualified("/left/", "x"), "/left/x");
    }

    #[test]
    fn qos_names_are_those_of_ros2_topic_info() {
        assert_eq!(reliability_name(Some(Reliability::BestEffort)), "BEST_EFFORT");
        assert_eq!(durability_name(Some(Durability::TransientLocal)), "TRANSIENT_LOCAL");
        assert_eq!(history_name(Some(History::KeepLast { depth: 10 })), "KEEP_LAST (10)");
        assert_eq!(history_name(None), "UNKNOWN");
    }
}
