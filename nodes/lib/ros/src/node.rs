use std::marker::PhantomData;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context as _, Result, bail};
use cowork_msgs::RosMessage;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::rosgraph_msgs::Clock;
use ros2_client::dds::rustdds::{DomainParticipantBuilder, RTPSEntity as _};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, QosProfile,
};

use crate::qos;

/// How a node joins the graph.
#[derive(Debug, Clone)]
pub struct NodeConfig {
    /// ROS namespace, `/` for none, else absolute (`/left`): the node's name and its per-arm
    /// topics ([`cowork_msgs::topics::Scope::Robot`]) live in it.
    pub namespace: String,
    /// Take time from `/clock` instead of the wall clock.
    pub use_sim_time: bool,
    /// DDS domain; `None` reads `ROS_DOMAIN_ID` (0 when unset).
    pub domain_id: Option<u16>,
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self { namespace: "/".into(), use_sim_time: false, domain_id: None }
    }
}

/// A discovered topic and its ROS type.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct TopicInfo {
    /// ROS topic name, e.g. `/joint_states`.
    pub name: String,
    /// ROS type, e.g. `sensor_msgs/msg/JointState`.
    pub type_name: String,
}

/// A ROS 2 node on the domain given by `ROS_DOMAIN_ID` (0 when unset).
pub struct RosNode {
    // Field order matters: the participant stops counting as alive first, then the node
    // drops before its context.
    _live: crate::dds_threads::Live,
    /// The `_cowork_graph_<id>` node that marks this participant as its graph's.
    _graph_marker: Option<Node>,
    pub(crate) node: Node,
    pub(crate) context: Context,
    name: String,
    /// Checked by [`validate_namespace`].
    namespace: String,
    /// The shared hold on the domain's members lock ([`crate::domain`]), released last.
    _membership: Option<crate::domain::Membership>,
    /// Latest `/clock` time, ns; negative until the first tick when `use_sim_time`.
    sim_time_ns: Option<Arc<AtomicI64>>,
    /// The `/clock` follower and its stop flag (raised and joined on drop).
    clock: Option<(Arc<AtomicBool>, std::thread::JoinHandle<()>)>,
}

impl Drop for RosNode {
    fn drop(&mut self) {
        if let Some((stop, handle)) = self.clock.take() {
            stop.store(true, Ordering::SeqCst);
            let _ = handle.join();
        }
    }
}

impl std::fmt::Debug for RosNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RosNode").field("name", &self.name).field("namespace", &self.namespace).finish_non_exhaustive()
    }
}

/// The domain id from `ROS_DOMAIN_ID`, 0 when unset.
pub fn domain_id_from_env() -> Result<u16> {
    match std::env::var("ROS_DOMAIN_ID") {
        Err(_) => Ok(0),
        Ok(s) if s.trim().is_empty() => Ok(0),
        Ok(s) => {
            let id: u16 = s
                .trim()
                .parse()
                .with_context(|| format!("ROS_DOMAIN_ID={s:?} is not a number"))?;
            if id > 232 {
                bail!("ROS_DOMAIN_ID={id} is out of range (0..=232)");
            }
            Ok(id)
        }
    }
}

/// The graph this process's nodes belong to: `COWORK_GRAPH_ID` (set by `cowork_graph` for
/// the nodes it starts), when it is a valid name token.
fn graph_id_from_env() -> Option<String> {
    let id = std::env::var("COWORK_GRAPH_ID").ok()?;
    let id = id.trim();
    if id.is_empty() {
        return None;
    }
    if !id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        tracing::warn!("COWORK_GRAPH_ID={id:?} is not a name token (letters, digits, _); ignored");
        return None;
    }
    Some(id.to_owned())
}

/// The discovery range asked for in the environment: `Some(true)` every interface
/// (`ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET` or `SYSTEM_DEFAULT`, or `ROS_LOCALHOST_ONLY=0`),
/// `Some(false)` loopback by name (`ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, or
/// `ROS_LOCALHOST_ONLY=1`), `None` when neither says.
fn requested_all_networks() -> Option<bool> {
    match std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE") {
        Ok(r) => match r.trim().to_ascii_uppercase().as_str() {
            "SUBNET" | "SYSTEM_DEFAULT" => Some(true),
            "LOCALHOST" => Some(false),
            _ => None,
        },
        Err(_) => match std::env::var("ROS_LOCALHOST_ONLY").as_deref().map(str::trim) {
            Ok("0") => Some(true),
            Ok("1") => Some(false),
            _ => None,
        },
    }
}

/// Whether DDS may use every network interface (`ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET`, or
/// `ROS_LOCALHOST_ONLY=0`). By default cowork keeps all DDS traffic on loopback.
pub fn discovery_on_all_networks() -> bool {
    requested_all_networks() == Some(true)
}

/// Whether a participant keeps to loopback. A secured one uses every interface unless loopback
/// was asked for by name: between loopback-only secured RustDDS 0.15.1 participants the
/// authentication handshake is lost when the peer's handshake reader is matched before any of
/// its packets arrived (the reader keeps a route with no locator and its messages are never sent;
/// about 1 start in 8 under load, every start with `RUST_LOG=rustdds=warn`). Every message of
/// a secured participant is authenticated and encrypted, so the wider range admits nobody.
fn loopback_only(secured: bool) -> bool {
    match requested_all_networks() {
        Some(all) => !all,
        None => !secured,
    }
}

/// Checks a ROS namespace: `/`, or absolute without a trailing slash (`/left`, `/lab/left`)
/// with tokens `[A-Za-z_][A-Za-z0-9_]*`; the error names it.
pub(crate) fn validate_namespace(namespace: &str) -> Result<()> {
    let tokens_ok = || namespace.strip_prefix('/').is_some_and(|rest| rest.split('/').all(is_name_token));
    if namespace == "/" || tokens_ok() {
        Ok(())
    } else {
        bail!(
            "invalid ROS namespace {namespace:?}: expected \"/\" or an absolute name like \"/left\" \
             (tokens of ASCII letters, digits and _, not starting with a digit; no trailing /)"
        )
    }
}

/// Whether `token` is one token of a ROS name (a node name, a namespace part): `[A-Za-z_][A-Za-z0-9_]*`.
pub fn is_name_token(token: &str) -> bool {
    let mut chars = token.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_') && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

fn new_context(domain: u16, namespace: &str, name: &str) -> Result<Context> {
    let security = match crate::security::from_env(namespace, name) {
        None => None,
        Some(settings) => secure_root(&settings)?,
    };
    let builder = |secured: bool| {
        let mut builder = DomainParticipantBuilder::new(domain).same_host_loopback(true);
        if loopback_only(secured) {
            builder = builder.with_only_networks([std::net::Ipv4Addr::LOCALHOST]);
        }
        builder
    };
    let participant = match security {
        None => builder(false).build().with_context(|| format!("cannot join DDS domain {domain}"))?,
        Some((settings, dir)) => match secure_participant(builder(true), &dir) {
            Ok(p) => {
                let range = if loopback_only(true) { "loopback only" } else { "every interface" };
                tracing::info!("DDS security on: enclave {} ({}), {range}", settings.enclave, dir.display());
                p
            }
            Err(e) if settings.strategy == crate::security::Strategy::Permissive => {
                tracing::warn!(
                    "DDS security refused enclave {} ({}): {e:#}; ROS_SECURITY_STRATEGY is Permissive, so running WITHOUT security",
                    settings.enclave,
                    dir.display()
                );
                builder(false).build().with_context(|| format!("cannot join DDS domain {domain}"))?
            }
            Err(e) => {
                return Err(e.context(format!(
                    "ROS_SECURITY_STRATEGY=Enforce: cannot join DDS domain {domain} secured with enclave {} ({})",
                    settings.enclave,
                    dir.display()
                )));
            }
        },
    };
    crate::graph::note_own_participant(participant.guid());
    Context::from_domain_participant(participant)
        .with_context(|| format!("cannot create a ROS 2 context on DDS domain {domain}"))
}

/// The enclave directory to secure the participant with, `None` to run unsecured
/// (Permissive without usable credentials, with a warning); Enforce without them is an error.
fn secure_root(
    settings: &crate::security::SecuritySettings,
) -> Result<Option<(crate::security::SecuritySettings, std::path::PathBuf)>> {
    use crate::security::Strategy;
    let found = if crate::security::SUPPORTED {
        settings.enclave_dir()
    } else {
        Err(anyhow::anyhow!(
            "this binary was built without DDS security (rebuild it with `--features cowork_ros/security`)"
        ))
    };
    match (found, settings.strategy) {
        (Ok(dir), _) => Ok(Some((settings.clone(), dir))),
        (Err(e), Strategy::Enforce) => Err(e.context(format!(
            "ROS_SECURITY_ENABLE=true with ROS_SECURITY_STRATEGY=Enforce: no usable credentials for enclave {}",
            settings.enclave
        ))),
        (Err(e), Strategy::Permissive) => {
            tracing::warn!(
                "ROS_SECURITY_ENABLE=true but no usable credentials for enclave {}: {e:#}; ROS_SECURITY_STRATEGY is Permissive, so running WITHOUT security",
                settings.enclave
            );
            Ok(None)
        }
    }
}

#[cfg(feature = "security")]
fn secure_participant(
    builder: DomainParticipantBuilder,
    dir: &std::path::Path,
) -> Result<ros2_client::dds::rustdds::DomainParticipant> {
    use ros2_client::dds::rustdds::DomainParticipantSecurityConfigFiles;
    // Unencrypted key.pem, as sros2 writes it (RustDDS reads no password-protected keys).
    let files = DomainParticipantSecurityConfigFiles::with_ros_default_names(dir, String::new());
    builder
        .builtin_security(files)
        .build()
        .map_err(|e| anyhow::anyhow!("the DDS security plugins refused the credentials: {e}"))
}

#[cfg(not(feature = "security"))]
fn secure_participant(
    _builder: DomainParticipantBuilder,
    _dir: &std::path::Path,
) -> Result<ros2_client::dds::rustdds::DomainParticipant> {
    bail!("this binary was built without DDS security")
}

impl RosNode {
    /// Creates the node, starts its background spinner (discovery, parameter services) and,
    /// with `use_sim_time`, follows `/clock`. An invalid `config.namespace` is an error naming
    /// it (before anything joins the domain).
    pub fn new(name: &str, config: &NodeConfig) -> Result<Self> {
        validate_namespace(&config.namespace)?;
        let domain = match config.domain_id {
            Some(d) => d,
            None => domain_id_from_env()?,
        };
        let membership = crate::domain::join(domain);
        let context = new_context(domain, &config.namespace, name)?;
        let graph_marker = match graph_id_from_env() {
            Some(id) => Some(
                context
                    .new_node(
                        NodeName::new("/", &crate::graph::graph_marker_name(&id)).map_err(|e| anyhow::anyhow!("invalid COWORK_GRAPH_ID {id:?}: {e:?}"))?,
                        NodeOptions::new().enable_rosout(false).start_parameter_services(false),
                    )
                    .context("cannot create the graph marker node")?,
            ),
            None => None,
        };
        let node_name = NodeName::new(&config.namespace, name)
            .map_err(|e| anyhow::anyhow!("invalid node name {name:?} in {:?}: {e:?}", config.namespace))?;
        let mut node = context
            .new_node(
                node_name,
                NodeOptions::new().enable_rosout(true).declare_parameter(
                    "use_sim_time",
                    ros2_client::ParameterValue::Boolean(config.use_sim_time),
                ),
            )
            .with_context(|| format!("cannot create ROS node {name}"))?;
        let spinner = node.spinner().context("cannot create the node spinner")?;
        std::thread::Builder::new()
            .name(format!("{name}-spinner"))
            .spawn(move || {
                if let Err(e) = smol::block_on(spinner.spin()) {
                    tracing::warn!("node spinner stopped: {e:?}");
                }
            })
            .context("cannot start the spinner thread")?;
        let mut this = Self {
            _live: crate::dds_threads::Live::counted(),
            _graph_marker: graph_marker,
            node,
            context,
            name: name.to_owned(),
            namespace: config.namespace.clone(),
            _membership: membership,
            sim_time_ns: None,
            clock: None,
        };
        if config.use_sim_time {
            this.follow_clock()?;
        }
        Ok(this)
    }

    fn follow_clock(&mut self) -> Result<()> {
        let clock = self.subscription::<Clock>("/clock", &qos::clock())?;
        let time = Arc::new(AtomicI64::new(-1));
        let shared = Arc::clone(&time);
        let stop = Arc::new(AtomicBool::new(false));
        let stopped = Arc::clone(&stop);
        let handle = std::thread::Builder::new()
            .name(format!("{}-clock", self.name))
            .spawn(move || {
                while !stopped.load(Ordering::SeqCst) && !crate::shutdown::requested() {
                    match clock.recv_timeout(Duration::from_millis(100)) {
                        Some(c) => {
                            shared.store(c.clock.to_nanos(), Ordering::Release);
                            crate::log::set_sim_time_ns(c.clock.to_nanos());
                        }
                        None => continue,
                    }
                }
            })
            .context("cannot start the clock thread")?;
        self.sim_time_ns = Some(time);
        self.clock = Some((stop, handle));
        Ok(())
    }

    /// The node's name (without its namespace).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The node's namespace: `/`, or absolute like `/left`.
    pub fn namespace(&self) -> &str {
        &self.namespace
    }

    /// The node's fully qualified name: `/ds_controller`, `/left/ds_controller`.
    pub fn fully_qualified_name(&self) -> String {
        self.node.fully_qualified_name()
    }

    /// The prefix of the TF frames of the arm in this node's namespace: `""` in `/`, `left/` in
    /// `/left` ([`cowork_msgs::topics::frame_prefix`]).
    pub fn frame_prefix(&self) -> String {
        cowork_msgs::topics::frame_prefix(&self.namespace)
    }

    /// Current time: `/clock` time with `use_sim_time` (zero before the first tick), else the
    /// wall clock.
    pub fn now(&self) -> Time {
        match &self.sim_time_ns {
            Some(t) => Time::from_nanos(t.load(Ordering::Acquire).max(0)),
            None => {
                let d = SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default();
                Time::from_nanos(d.as_nanos() as i64)
            }
        }
    }

    /// Whether the node's time is `/clock` time (`use_sim_time`).
    pub fn uses_sim_time(&self) -> bool {
        self.sim_time_ns.is_some()
    }

    /// Whether `/clock` has ticked yet (always true without `use_sim_time`).
    pub fn clock_started(&self) -> bool {
        self.sim_time_ns.as_ref().is_none_or(|t| t.load(Ordering::Acquire) >= 0)
    }

    fn topic<T: RosMessage>(&mut self, topic: &str, qos: &QosProfile) -> Result<ros2_client::dds::rustdds::Topic> {
        let name = Name::parse(topic)
            .map_err(|e| anyhow::anyhow!("invalid topic name {topic:?}: {e:?}"))?;
        self.node
            .create_topic(&name, MessageTypeName::new(T::PACKAGE, T::NAME), qos)
            .with_context(|| format!("cannot create topic {topic} ({})", T::type_name()))
    }

    /// A publisher of `T` on `topic` (absolute name, e.g. `/joint_states`).
    pub fn publisher<T: RosMessage>(&mut self, topic: &str, qos: &QosProfile) -> Result<Publisher<T>> {
        let t = self.topic::<T>(topic, qos)?;
        let inner = self
            .node
            .create_publisher::<T>(&t, Some(qos.clone()))
            .with_context(|| format!("cannot publish on {topic}"))?;
        Ok(Publisher { inner, topic: topic.to_owned(), dropped: AtomicU64::new(0) })
    }

    /// A subscription to `T` on `topic`.
    pub fn subscription<T: RosMessage>(
        &mut self,
        topic: &str,
        qos: &QosProfile,
    ) -> Result<Subscription<T>> {
        let t = self.topic::<T>(topic, qos)?;
        let inner = self
            .node
            .create_subscription::<T>(&t, Some(qos.clone()))
            .with_context(|| format!("cannot subscribe to {topic}"))?;
        Ok(Subscription { inner, topic: topic.to_owned(), _type: PhantomData })
    }

    /// A publisher on a graph topic ([`cowork_msgs::topics`]) with the topic's writer delivery,
    /// resolved in the node's namespace ([`Topic::name_in`]: `/left/joint_states` for a node in
    /// `/left`).
    ///
    /// [`Topic::name_in`]: cowork_msgs::topics::Topic::name_in
    pub fn advertise<T: RosMessage>(&mut self, topic: &cowork_msgs::topics::Topic<T>) -> Result<Publisher<T>> {
        let name = topic.name_in(&self.namespace);
        self.publisher::<T>(&name, &qos::of(topic.writer))
    }

    /// A subscription to a graph topic ([`cowork_msgs::topics`]) with the topic's reader
    /// delivery, resolved in the node's namespace (as [`advertise`](Self::advertise)).
    pub fn subscribe<T: RosMessage>(&mut self, topic: &cowork_msgs::topics::Topic<T>) -> Result<Subscription<T>> {
        let name = topic.name_in(&self.namespace);
        self.subscription::<T>(&name, &qos::of(topic.reader))
    }

    /// [`advertise`](Self::advertise) resolved in `namespace` instead of the node's: a node
    /// that serves several arms (the simulator writes `/left/joint_states` and
    /// `/right/joint_states`). A graph-scoped topic keeps its one name. An invalid `namespace`
    /// is an error naming it.
    pub fn advertise_in<T: RosMessage>(&mut self, topic: &cowork_msgs::topics::Topic<T>, namespace: &str) -> Result<Publisher<T>> {
        validate_namespace(namespace)?;
        self.publisher::<T>(&topic.name_in(namespace), &qos::of(topic.writer))
    }

    /// [`subscribe`](Self::subscribe) resolved in `namespace` instead of the node's: a node
    /// that reads several arms (the supervisor reads `/left/robot_stream` and
    /// `/right/robot_stream`). A graph-scoped topic keeps its one name. An invalid `namespace`
    /// is an error naming it.
    pub fn subscribe_in<T: RosMessage>(&mut self, topic: &cowork_msgs::topics::Topic<T>, namespace: &str) -> Result<Subscription<T>> {
        validate_namespace(namespace)?;
        self.subscription::<T>(&topic.name_in(namespace), &qos::of(topic.reader))
    }

    /// Topics seen on the domain so far, with their ROS types (`pkg/msg/Name`); DDS-internal
    /// topics and ros2-client's own `/clock` reader are left out (see [`is_client_internal`]).
    pub fn discovered_topics(&self) -> Vec<TopicInfo> {
        let mut topics: Vec<TopicInfo> = self
            .context
            .discovered_topics()
            .into_iter()
            .filter_map(|t| {
                Some(TopicInfo {
                    name: ros_topic_name(&t.name)?,
                    type_name: ros_type_name(&t.type_name)?,
                })
            })
            .filter(|t| !is_client_internal(t))
            .collect();
        topics.sort();
        topics.dedup();
        topics
    }
}

/// Whether `topic` is ros2-client's own reader of `/clock`: every ros2-client node subscribes
/// `/clock` typed `builtin_interfaces/msg/Time` (its sim-time support), so without this filter
/// `cowork topic list` showed `/clock` twice. The graph's clock is `rosgraph_msgs/msg/Clock`.
fn is_client_internal(topic: &TopicInfo) -> bool {
    topic.name == "/clock" && topic.type_name == "builtin_interfaces/msg/Time"
}

/// `rt/joint_states` → `/joint_states`; non-topic DDS names (services, discovery) → None.
pub(crate) fn ros_topic_name(dds: &str) -> Option<String> {
    dds.strip_prefix("rt/").map(|rest| format!("/{rest}"))
}

/// `sensor_msgs::msg::dds_::JointState_` → `sensor_msgs/msg/JointState`.
pub(crate) fn ros_type_name(dds: &str) -> Option<String> {
    let (pkg, rest) = dds.split_once("::msg::dds_::")?;
    Some(format!("{pkg}/msg/{}", rest.strip_suffix('_').unwrap_or(rest)))
}

/// Publishes `T` on one topic.
pub struct Publisher<T: RosMessage> {
    inner: ros2_client::Publisher<T>,
    topic: String,
    /// Messages dropped because a reliable reader's queue was full.
    dropped: AtomicU64,
}

impl<T: RosMessage> std::fmt::Debug for Publisher<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Publisher<{}>({})", T::type_name(), self.topic)
    }
}

impl<T: RosMessage> Publisher<T> {
    /// Publishes one message. When a reliable reader does not acknowledge fast enough (a
    /// stalled or vanished `ros2 topic echo`, say) the write would block: the message is
    /// dropped, counted ([`dropped`](Self::dropped)) and logged at the 1st, 2nd, 4th, 8th, …
    /// time — a slow reader never stops a node. Other failures are errors.
    pub fn publish(&self, msg: T) -> Result<()> {
        match self.inner.publish(msg) {
            Ok(()) => Ok(()),
            Err(ros2_client::WriteError::WouldBlock { .. }) => {
                let n = self.dropped.fetch_add(1, Ordering::Relaxed) + 1;
                if n.is_power_of_two() {
                    tracing::warn!("{}: a reliable reader is not keeping up; {n} message(s) dropped so far", self.topic);
                }
                Ok(())
            }
            Err(e) => Err(anyhow::anyhow!("publish on {} failed: {e}", self.topic)),
        }
    }

    /// Publishes `msg`; a failure comes back as a [`crate::Warning`] (kind `publish:<topic>`)
    /// for the node's rate-limited log: a node goes on when one write fails.
    pub fn send(&self, msg: T) -> Option<crate::Warning> {
        self.publish(msg).err().map(|e| crate::Warning::new(format!("publish:{}", self.topic), format!("{e:#}")))
    }

    /// Messages dropped so far because a reliable reader's queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Number of matched subscriptions (all participants on the domain).
    pub fn subscription_count(&self, node: &RosNode) -> usize {
        self.inner.get_subscription_count(&node.node)
    }

    /// Topic name.
    pub fn topic(&self) -> &str {
        &self.topic
    }
}

/// Receives `T` from one topic. Messages that cannot be decoded are logged and skipped: a bad
/// message never stops a node.
pub struct Subscription<T: RosMessage> {
    inner: ros2_client::Subscription<T>,
    topic: String,
    _type: PhantomData<T>,
}

impl<T: RosMessage> std::fmt::Debug for Subscription<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Subscription<{}>({})", T::type_name(), self.topic)
    }
}

impl<T: RosMessage> Subscription<T> {
    /// The next waiting message, if any; never blocks.
    pub fn take(&self) -> Option<T> {
        // Bounded: a burst of undecodable samples cannot trap the caller.
        for _ in 0..64 {
            match self.inner.take() {
                Ok(Some((msg, _info))) => return Some(msg),
                Ok(None) => return None,
                Err(e) => tracing::warn!(
                    "{}: dropped a message that is not a valid {}: {e:?}",
                    self.topic,
                    T::type_name()
                ),
            }
        }
        None
    }

    /// The newest waiting message, discarding older ones.
    pub fn take_latest(&self) -> Option<T> {
        let mut latest = None;
        while let Some(m) = self.take() {
            latest = Some(m);
        }
        latest
    }

    /// Waits up to `timeout` for a message.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<T> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(m) = self.take() {
                return Some(m);
            }
            if Instant::now() >= deadline || crate::shutdown::requested() {
                return None;
            }
            std::thread::sleep(Duration::from_micros(500));
        }
    }

    /// Registers this subscription with `registry` under `token`: the poll wakes when a message
    /// arrives ([`crate::input::WaitSet`]). [`take`](Self::take) clears the wake-up.
    pub(crate) fn register(&mut self, registry: &ros2_client::dds::rustdds::mio1::Registry, token: ros2_client::dds::rustdds::mio1::Token) -> std::io::Result<()> {
        ros2_client::dds::rustdds::mio1::event::Source::register(&mut self.inner, registry, token, ros2_client::dds::rustdds::mio1::Interest::READABLE)
    }

    /// Number of matched publishers.
    pub fn publisher_count(&self, node: &RosNode) -> usize {
        self.inner.get_publisher_count(&node.node)
    }

    /// Topic name.
    pub fn topic(&self) -> &str {
        &self.topic
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_names_map_to_ros_names() {
        assert_eq!(ros_topic_name("rt/lwr/joint_velocity_command").as_deref(), Some("/lwr/joint_velocity_command"));
        assert_eq!(ros_topic_name("rq/foo/get_parametersRequest"), None);
        assert_eq!(
            ros_type_name("sensor_msgs::msg::dds_::JointState_").as_deref(),
            Some("sensor_msgs/msg/JointState")
        );
        assert_eq!(ros_type_name("rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_").as_deref(),
            Some("rmw_dds_common/msg/ParticipantEntitiesInfo"));
    }

    #[test]
    fn namespaces_are_root_or_absolute_ros_names() {
        for ok in ["/", "/left", "/right_arm", "/lab/left", "/_x9"] {
            assert!(validate_namespace(ok).is_ok(), "{ok}");
        }
        for bad in ["", "left", "/left/", "//left", "/lab//left", "/9left", "/le-ft", "/left arm", "/é"] {
            let e = validate_namespace(bad).expect_err(bad).to_string();
            assert!(e.contains(&format!("{bad:?}")), "{e}");
        }
    }

    #[test]
    fn a_node_in_a_bad_namespace_is_refused_before_joining() {
        let config = NodeConfig { namespace: "left/".into(), domain_id: Some(0), ..NodeConfig::default() };
        let e = RosNode::new("ds_controller", &config).expect_err("a bad namespace").to_string();
        assert!(e.contains("invalid ROS namespace \"left/\""), "{e}");
    }

    #[test]
    fn only_the_clients_own_clock_reader_is_hidden() {
        let topic = |name: &str, type_name: &str| TopicInfo { name: name.into(), type_name: type_name.into() };
        assert!(is_client_internal(&topic("/clock", "builtin_interfaces/msg/Time")));
        assert!(!is_client_internal(&topic("/clock", "rosgraph_msgs/msg/Clock")));
        assert!(!is_client_internal(&topic("/stamp", "builtin_interfaces/msg/Time")));
    }
}
