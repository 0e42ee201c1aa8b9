//! The ROS 2 graph as `ros2 node list` / `ros2 topic info -v` see it: the publishers and
//! subscriptions of a topic with their QoS (from DDS discovery) and the node each belongs to
//! (from `ros_discovery_info`, the `rmw_dds_common/msg/ParticipantEntitiesInfo` every ROS 2
//! participant publishes, reliable + transient local, so a late joiner gets the current list).

use std::collections::{BTreeMap, HashMap};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result};
use ros2_client::dds::rustdds::policy::{Durability, History, Reliability};
use ros2_client::dds::rustdds::{GUID, QosPolicies, RTPSEntity};

/// A DDS participant's GUID prefix (RustDDS does not export its type).
type Prefix = [u8; 12];

fn prefix_of(gid: Gid) -> Prefix {
    let b = gid.to_bytes16();
    let mut p = [0; 12];
    p.copy_from_slice(&b[..12]);
    p
}
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

/// The hidden node (`ros2 node list` hides names starting with `_`) that marks a participant as
/// one of graph `id`'s: every node started with `COWORK_GRAPH_ID=<id>` adds it.
pub fn graph_marker_name(id: &str) -> String {
    format!("{GRAPH_MARKER}{id}")
}

const GRAPH_MARKER: &str = "_cowork_graph_";

/// The DDS participants created by this process: its in-process nodes are its graph's.
static OWN_PARTICIPANTS: Mutex<Vec<Prefix>> = Mutex::new(Vec::new());

pub(crate) fn note_own_participant(participant: GUID) {
    OWN_PARTICIPANTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(prefix_of(Gid::from(participant)));
}

fn own_participant(prefix: &Prefix) -> bool {
    OWN_PARTICIPANTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).contains(prefix)
}

/// A DDS participant on the graph's domain that the graph does not own and that writes on one of
/// the graph's topics (a second graph on the same domain, a node started by hand, a
/// `ros2 topic pub`). Readers only (`ros2 topic echo`, a viewer) are not strangers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Stranger {
    /// Its ROS nodes (from `ros_discovery_info`), hidden markers left out; empty for a plain
    /// DDS participant.
    pub nodes: Vec<String>,
    /// The cowork graph it belongs to, when it carries a graph marker.
    pub graph: Option<String>,
    /// The ROS topics it writes.
    pub topics: Vec<String>,
    /// Its GUID prefix, hex.
    pub participant: String,
}

impl std::fmt::Display for Stranger {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.nodes.is_empty() {
            write!(f, "a DDS participant with no ROS node ({})", self.participant)?;
        } else {
            write!(f, "node {}", self.nodes.join(", "))?;
        }
        match &self.graph {
            Some(g) => write!(f, " of another cowork graph ({g})")?,
            None => write!(f, " that no cowork graph started")?,
        }
        write!(f, " writing {}", self.topics.join(", "))
    }
}

/// Finds [`Stranger`]s on a graph's domain: participants neither created by this process nor
/// marked with the graph's id, seen writing graph topics for longer than a grace period (a node
/// of the graph announces its marker a moment after its first endpoints).
pub struct StrangerWatch {
    watch: GraphWatch,
    marker: String,
    grace: Duration,
    unowned_since: HashMap<Prefix, Instant>,
}

impl std::fmt::Debug for StrangerWatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StrangerWatch").field("marker", &self.marker).finish_non_exhaustive()
    }
}

/// Seconds a participant may write graph topics before its graph marker is seen.
pub const STRANGER_GRACE_S: f64 = 5.0;

impl RosNode {
    /// Starts watching this node's domain for participants that do not belong to graph
    /// `graph_id` (see [`StrangerWatch`]).
    pub fn stranger_watch(&mut self, graph_id: &str) -> Result<StrangerWatch> {
        Ok(StrangerWatch {
            watch: self.graph_watch()?,
            marker: format!("/{}", graph_marker_name(graph_id)),
            grace: Duration::from_secs_f64(STRANGER_GRACE_S),
            unowned_since: HashMap::new(),
        })
    }
}

impl StrangerWatch {
    /// The strangers seen now (each unowned for longer than the grace period).
    pub fn strangers(&mut self, node: &RosNode) -> Vec<Stranger> {
        self.watch.take_updates();
        let participant = node.context.domain_participant();
        let mut writes: BTreeMap<Prefix, Vec<String>> = BTreeMap::new();
        for w in participant.discovered_writers() {
            let d = &w.publication_topic_data;
            let name = &d.topic_name;
            if !name.starts_with("rt/") || name == "rt/rosout" || name == "rt/parameter_events" {
                continue;
            }
            let topics = writes.entry(prefix_of(Gid::from(d.key))).or_default();
            let topic = ros_topic_name(name).unwrap_or_else(|| name.clone());
            if !topics.contains(&topic) {
                topics.push(topic);
            }
        }
        let now = Instant::now();
        let mut out = Vec::new();
        let mut still = HashMap::new();
        for (prefix, topics) in writes {
            if own_participant(&prefix) {
                continue;
            }
            let nodes = self.watch.participants.iter().find(|(gid, _)| prefix_of(**gid) == prefix).map(|(_, ns)| ns);
            let names: Vec<String> = nodes.map(|ns| ns.iter().map(|n| qualified(&n.node_namespace, &n.node_name)).collect()).unwrap_or_default();
            if names.contains(&self.marker) {
                continue;
            }
            let since = *self.unowned_since.get(&prefix).unwrap_or(&now);
            still.insert(prefix, since);
            if now.duration_since(since) < self.grace {
                continue;
            }
            let graph = names.iter().find_map(|n| n.strip_prefix('/').and_then(|n| n.strip_prefix(GRAPH_MARKER)).map(str::to_owned));
            let nodes = names.into_iter().filter(|n| !n.starts_with(&format!("/{GRAPH_MARKER}"))).collect();
            let participant = prefix.iter().map(|b| format!("{b:02x}")).collect();
            out.push(Stranger { nodes, graph, topics, participant });
        }
        self.unowned_since = still;
        out
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
