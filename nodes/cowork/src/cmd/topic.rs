//! `cowork topic list|echo|pub|hz|info` and `cowork node list`: look at the live graph over DDS
//! without a ROS installation, as `ros2 topic` / `ros2 node` do.

use std::io::Write as _;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Subcommand;
use cowork_msgs::{RosMessage, with_message_type};
use cowork_ros::{NodeConfig, RosNode, TopicInfo, qos};

/// Topic commands.
#[derive(Debug, Subcommand)]
pub enum TopicCommand {
    /// List the topics seen on the domain, with their types.
    List {
        /// How long to listen for discovery, s.
        #[arg(long, default_value_t = 2.0)]
        wait: f64,
    },
    /// Print messages of a topic as JSON, one per line.
    Echo {
        /// Topic name, e.g. /joint_states.
        topic: String,
        /// Stop after this many messages.
        #[arg(long, short = 'n')]
        count: Option<usize>,
        /// Message type (pkg/msg/Name) if discovery should not be waited for.
        #[arg(long = "type")]
        type_name: Option<String>,
        /// How long to wait for the topic to appear, s.
        #[arg(long, default_value_t = 5.0)]
        wait: f64,
        /// Subscribe best effort (matches any publisher; may drop messages).
        #[arg(long)]
        best_effort: bool,
    },
    /// Receive rate of a topic (any type), printed every second as `ros2 topic hz` does.
    Hz {
        /// Topic name, e.g. /joint_states.
        topic: String,
        /// Rate over the last N messages.
        #[arg(long, default_value_t = 10_000)]
        window: usize,
        /// Stop after this many seconds (default: until Ctrl-C).
        #[arg(long)]
        duration: Option<f64>,
        /// How long to wait for the topic to appear, s.
        #[arg(long, default_value_t = 5.0)]
        wait: f64,
    },
    /// Type, publishers and subscriptions of a topic; `-v`: each endpoint's node and QoS.
    Info {
        /// Topic name, e.g. /fded/distances.
        topic: String,
        /// List every endpoint with its node, GID and QoS.
        #[arg(long, short = 'v')]
        verbose: bool,
        /// How long to listen for discovery, s.
        #[arg(long, default_value_t = 2.0)]
        wait: f64,
    },
    /// Publish a message given as YAML or JSON (as `ros2 topic pub` takes it: '{data: close}' or
    /// '{"data": "close"}'); fields left out keep their ROS defaults, a field the type does not
    /// have is refused. Prints each message sent.
    Pub {
        /// Topic name, e.g. /lwr/gripper_command.
        topic: String,
        /// Message type, e.g. std_msgs/msg/String.
        #[arg(value_name = "TYPE")]
        type_name: String,
        /// The message, e.g. '{data: close}' or '{"data": "close"}'.
        #[arg(value_name = "VALUES")]
        json: String,
        /// Publish this many times (default: once).
        #[arg(long, default_value_t = 1)]
        count: usize,
        /// Publication rate, Hz.
        #[arg(long, default_value_t = 10.0)]
        rate: f64,
        /// Wait this long for a subscriber before publishing, s.
        #[arg(long, default_value_t = 2.0)]
        wait: f64,
    },
}

/// Runs a topic subcommand.
pub fn run(cmd: TopicCommand) -> Result<()> {
    cowork_ros::shutdown::install();
    match cmd {
        TopicCommand::List { wait } => {
            let node = RosNode::new(&format!("cowork_topic_{}", std::process::id()), &NodeConfig::default())?;
            let topics = discover(&node, wait, |_| false)?;
            if topics.is_empty() {
                eprintln!("no topics seen on DDS domain {} within {wait} s", cowork_ros::domain_id_from_env().unwrap_or_default());
            }
            for t in topics {
                println!("{} [{}]", t.name, t.type_name);
            }
            Ok(())
        }
        TopicCommand::Echo { topic, count, type_name, wait, best_effort } => {
            let mut node = RosNode::new(&format!("cowork_echo_{}", std::process::id()), &NodeConfig::default())?;
            let type_name = match type_name {
                Some(t) => t,
                None => {
                    let found = discover(&node, wait, |ts| ts.iter().any(|t| t.name == topic))?;
                    match found.into_iter().find(|t| t.name == topic) {
                        Some(t) => t.type_name,
                        None => bail!("topic {topic} not seen within {wait} s (try `cowork topic list`, or give --type)"),
                    }
                }
            };
            let qos = if best_effort { qos::sensor_data() } else { qos::reliable() };
            with_message_type!(type_name.as_str(), T => echo::<T>(&mut node, &topic, &qos, count))
                .with_context(|| format!("{topic}: type {type_name} is not one cowork knows"))?
        }
        TopicCommand::Hz { topic, window, duration, wait } => hz(&topic, window, duration, wait),
        TopicCommand::Info { topic, verbose, wait } => info(&topic, verbose, wait),
        TopicCommand::Pub { topic, type_name, json, count, rate, wait } => {
            if !(rate.is_finite() && rate > 0.0) {
                bail!("--rate {rate}: must be a positive number of Hz");
            }
            if !(wait.is_finite() && wait >= 0.0) {
                bail!("--wait {wait}: must be a non-negative number of seconds");
            }
            let value = parse_values(&json).with_context(|| format!("the message for {topic}"))?;
            let period = cowork_ros::duration_s(1.0 / rate);
            let publish = Publish { topic: &topic, count, period, wait };
            with_message_type!(type_name.as_str(), T => publish.run(message::<T>(value)?))
                .with_context(|| format!("{type_name} is not a type cowork knows (see `cowork topic list`)"))?
        }
    }
}

/// The message text as `ros2 topic pub` takes it: YAML (of which JSON is a subset), e.g.
/// `{data: close}`, `{"data": "close"}` or `data: close`; empty means all defaults.
fn parse_values(text: &str) -> Result<serde_json::Value> {
    if text.trim().is_empty() {
        return Ok(serde_json::Value::Object(Default::default()));
    }
    let value: serde_json::Value =
        serde_yaml_ng::from_str(text).with_context(|| format!("not valid YAML or JSON: {text}"))?;
    if !value.is_object() {
        bail!("expected a mapping of field names to values, e.g. '{{data: close}}'; got: {text}");
    }
    Ok(value)
}

/// Overlays `patch` on `base`, object by object.
fn merge(base: &mut serde_json::Value, patch: serde_json::Value) {
    match (base, patch) {
        (serde_json::Value::Object(b), serde_json::Value::Object(p)) => {
            for (k, v) in p {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (slot, v) => *slot = v,
    }
}

/// The first field of `given` that `known` (the message as it was decoded) does not have, as a
/// path (`goal.positon`, `nodes[2].nme`), with the fields that level has.
fn unknown_field(given: &serde_json::Value, known: &serde_json::Value, at: &str) -> Option<(String, Vec<String>)> {
    use serde_json::Value;
    match (given, known) {
        (Value::Object(g), Value::Object(k)) => g.iter().find_map(|(name, v)| {
            let path = if at.is_empty() { name.clone() } else { format!("{at}.{name}") };
            match k.get(name) {
                Some(kv) => unknown_field(v, kv, &path),
                None => Some((path, k.keys().cloned().collect())),
            }
        }),
        (Value::Array(g), Value::Array(k)) => {
            g.iter().zip(k).enumerate().find_map(|(i, (gv, kv))| unknown_field(gv, kv, &format!("{at}[{i}]")))
        }
        _ => None,
    }
}

/// The message of type `T` that `patch` describes over `T`'s defaults; a field `T` does not
/// have, or a value of the wrong kind, is an error naming the field and the type.
fn message<T: RosMessage>(patch: serde_json::Value) -> Result<T> {
    let mut value = serde_json::to_value(T::default())?;
    merge(&mut value, patch.clone());
    let msg: T = serde_json::from_value(value)
        .with_context(|| format!("the values do not fit {} (its fields, defaults: {})", T::type_name(), serde_json::to_string(&T::default()).unwrap_or_default()))?;
    if let Some((field, known)) = unknown_field(&patch, &serde_json::to_value(&msg)?, "") {
        bail!("{} has no field `{field}` (fields there: {})", T::type_name(), known.join(", "));
    }
    Ok(msg)
}

/// How `cowork topic pub` publishes.
struct Publish<'a> {
    topic: &'a str,
    count: usize,
    period: Duration,
    /// s to wait for a subscriber.
    wait: f64,
}

impl Publish<'_> {
    fn run<T: RosMessage>(&self, msg: T) -> Result<()> {
        let topic = self.topic;
        let mut node = RosNode::new(&format!("cowork_pub_{}", std::process::id()), &NodeConfig::default())?;
        let publisher = node.publisher::<T>(topic, &qos::reliable())?;
        let deadline = Instant::now() + cowork_ros::duration_s(self.wait);
        while publisher.subscription_count(&node) == 0 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        if publisher.subscription_count(&node) == 0 {
            eprintln!("no subscriber on {topic} after {} s; publishing anyway", self.wait);
        }
        let text = serde_json::to_string(&msg)?;
        let mut next = Instant::now();
        for i in 1..=self.count {
            if cowork_ros::shutdown::requested() {
                break;
            }
            publisher.publish(msg.clone())?;
            println!("publishing #{i} on {topic} [{}]: {text}", T::type_name());
            next += self.period;
            if let Some(d) = next.checked_duration_since(Instant::now()) {
                std::thread::sleep(d);
            }
        }
        // Let reliable delivery finish before the participant leaves.
        std::thread::sleep(Duration::from_millis(200));
        Ok(())
    }
}

fn discover(node: &RosNode, wait: f64, done: impl Fn(&[TopicInfo]) -> bool) -> Result<Vec<TopicInfo>> {
    if !(wait.is_finite() && wait >= 0.0) {
        bail!("--wait {wait}: must be a non-negative number of seconds");
    }
    let deadline = Instant::now() + cowork_ros::duration_s(wait);
    loop {
        let topics: Vec<TopicInfo> = node
            .discovered_topics()
            .into_iter()
            .filter(|t| !t.name.starts_with("/ros_discovery_info") && t.name != "/rosout" && t.name != "/parameter_events")
            .collect();
        if done(&topics) || Instant::now() >= deadline || cowork_ros::shutdown::requested() {
            return Ok(topics);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn echo<T: RosMessage>(node: &mut RosNode, topic: &str, qos: &qos::QosProfile, count: Option<usize>) -> Result<()> {
    let sub = node.subscription::<T>(topic, qos)?;
    let mut seen = 0;
    let mut out = std::io::stdout().lock();
    while !cowork_ros::shutdown::requested() && count.is_none_or(|c| seen < c) {
        if let Some(msg) = sub.recv_timeout(Duration::from_millis(200)) {
            let line = serde_json::to_string(&msg)?;
            // A closed pipe (`cowork topic echo ... | head`) ends the echo quietly.
            match writeln!(out, "{line}").and_then(|()| out.flush()) {
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
                other => other?,
            }
            seen += 1;
        }
    }
    Ok(())
}

/// The writers' type of `topic`, waiting up to `wait` s for discovery.
fn writer_type(node: &RosNode, topic: &str, wait: f64) -> Result<String> {
    let found = discover(node, wait, |ts| ts.iter().any(|t| t.name == topic))?;
    let types = node.writer_type_names(topic);
    match (types.as_slice(), found.into_iter().find(|t| t.name == topic)) {
        ([one], _) => Ok(one.clone()),
        ([], Some(t)) => Ok(t.type_name),
        ([], None) => bail!("topic {topic} not seen within {wait} s (try `cowork topic list`)"),
        (many, _) => bail!("{topic} has publishers of different types: {}", many.join(", ")),
    }
}

/// Rate statistics of arrival times (s), as `ros2 topic hz` prints them.
#[derive(Debug, Clone, PartialEq)]
struct RateStats {
    /// Messages per second over the window.
    rate_hz: f64,
    /// Shortest, longest gap and the gaps' standard deviation, s.
    min_s: f64,
    max_s: f64,
    std_s: f64,
    /// Gaps in the window.
    window: usize,
}

fn rate_stats(arrivals: &std::collections::VecDeque<f64>) -> Option<RateStats> {
    if arrivals.len() < 2 {
        return None;
    }
    let gaps: Vec<f64> = arrivals.iter().zip(arrivals.iter().skip(1)).map(|(a, b)| b - a).collect();
    let n = gaps.len() as f64;
    let mean = gaps.iter().sum::<f64>() / n;
    if !(mean > 0.0) {
        return None;
    }
    let var = gaps.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / n;
    Some(RateStats {
        rate_hz: 1.0 / mean,
        min_s: gaps.iter().copied().fold(f64::INFINITY, f64::min),
        max_s: gaps.iter().copied().fold(0.0, f64::max),
        std_s: var.sqrt(),
        window: gaps.len(),
    })
}

fn hz(topic: &str, window: usize, duration: Option<f64>, wait: f64) -> Result<()> {
    if window < 2 {
        bail!("--window {window}: needs at least 2 messages");
    }
    if let Some(d) = duration
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration {d}: must be a positive number of seconds");
    }
    let mut node = RosNode::new(&format!("cowork_hz_{}", std::process::id()), &NodeConfig::default())?;
    let type_name = writer_type(&node, topic, wait)?;
    // Matches every writer (a reliable reader would not match a best-effort camera).
    let qos = node.offered_qos(topic, 100).unwrap_or_else(qos::sensor_data);
    let sub = node.raw_subscription(topic, &type_name, &qos)?;
    let start = Instant::now();
    let mut arrivals = std::collections::VecDeque::with_capacity(window.min(100_000));
    let mut next_print = Instant::now() + Duration::from_secs(1);
    let mut out = std::io::stdout().lock();
    while !cowork_ros::shutdown::requested() && duration.is_none_or(|d| start.elapsed().as_secs_f64() < d) {
        let mut got = false;
        while let Some(sample) = sub.take() {
            got = true;
            arrivals.push_back(sample.receive_time_ns as f64 * 1e-9);
            if arrivals.len() > window {
                arrivals.pop_front();
            }
        }
        if Instant::now() >= next_print {
            next_print += Duration::from_secs(1);
            let text = match rate_stats(&arrivals) {
                Some(r) => format!(
                    "average rate: {:.3}\n\tmin: {:.3}s max: {:.3}s std dev: {:.5}s window: {}",
                    r.rate_hz, r.min_s, r.max_s, r.std_s, r.window
                ),
                None => format!("no new messages on {topic} [{type_name}]"),
            };
            match writeln!(out, "{text}").and_then(|()| out.flush()) {
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
                other => other?,
            }
        }
        if !got {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    Ok(())
}

fn info(topic: &str, verbose: bool, wait: f64) -> Result<()> {
    let mut node = RosNode::new(&format!("cowork_info_{}", std::process::id()), &NodeConfig::default())?;
    let mut watch = node.graph_watch()?;
    let found = discover(&node, wait, |ts| ts.iter().any(|t| t.name == topic))?;
    if !found.iter().any(|t| t.name == topic) {
        bail!("topic {topic} not seen within {wait} s (try `cowork topic list`)");
    }
    // ros_discovery_info arrives with discovery; give the owners a moment more.
    std::thread::sleep(Duration::from_millis(300));
    let ends = node.topic_endpoints(topic, Some(&mut watch));
    let mut types: Vec<&str> = ends.publishers.iter().chain(&ends.subscriptions).map(|e| e.type_name.as_str()).collect();
    types.sort_unstable();
    types.dedup();
    println!("Type: {}", types.join(", "));
    println!("Publisher count: {}", ends.publishers.len());
    println!("Subscription count: {}", ends.subscriptions.len());
    if verbose {
        for (kind, list) in [("PUBLISHER", &ends.publishers), ("SUBSCRIPTION", &ends.subscriptions)] {
            for e in list {
                println!();
                println!("Node name: {}", e.node.as_deref().unwrap_or("_NODE_NAME_UNKNOWN_"));
                println!("Topic type: {}", e.type_name);
                println!("Endpoint type: {kind}");
                println!("GID: {}", e.gid);
                println!("QoS profile:");
                println!("  Reliability: {}", e.reliability);
                println!("  History (Depth): {}", e.history);
                println!("  Durability: {}", e.durability);
            }
        }
    }
    Ok(())
}

/// `cowork node list`: the ROS 2 nodes on the domain, one per line, as `ros2 node list`.
pub fn node_list(wait: f64) -> Result<()> {
    if !(wait.is_finite() && wait >= 0.0) {
        bail!("--wait {wait}: must be a non-negative number of seconds");
    }
    cowork_ros::shutdown::install();
    let own = format!("cowork_nodes_{}", std::process::id());
    let mut node = RosNode::new(&own, &NodeConfig::default())?;
    let mut watch = node.graph_watch()?;
    let deadline = Instant::now() + cowork_ros::duration_s(wait);
    while Instant::now() < deadline && !cowork_ros::shutdown::requested() {
        std::thread::sleep(Duration::from_millis(50));
    }
    // Hidden nodes (a name starting with `_`, e.g. a graph's `_cowork_graph_<id>` marker) are
    // left out, as `ros2 node list` does.
    let hidden = |n: &str| n.rsplit('/').next().is_some_and(|last| last.starts_with('_'));
    let mut names: Vec<String> =
        watch.nodes().into_iter().map(|n| n.name).filter(|n| *n != format!("/{own}") && !hidden(n)).collect();
    names.dedup();
    if names.is_empty() {
        eprintln!("no nodes seen on DDS domain {} within {wait} s", cowork_ros::domain_id_from_env().unwrap_or_default());
    }
    for n in names {
        println!("{n}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros2_yaml_and_json_give_the_same_message() {
        let yaml = message::<cowork_msgs::std_msgs::String>(parse_values("{data: close}").expect("yaml")).expect("msg");
        let json = message::<cowork_msgs::std_msgs::String>(parse_values(r#"{"data": "close"}"#).expect("json")).expect("msg");
        assert_eq!(yaml.data, "close");
        assert_eq!(yaml, json);
        assert!(parse_values("[1, 2]").is_err() && parse_values("{data: [}").is_err());
    }

    #[test]
    fn a_misspelt_field_is_refused_naming_it_and_the_type() {
        use cowork_msgs::msg::MotionCommand;
        let e = message::<MotionCommand>(parse_values(r#"{"goal":{"positon":{"x":0.5}},"nominal_speed":0.3}"#).expect("json"))
            .expect_err("positon");
        let text = e.to_string();
        assert!(text.contains("`goal.positon`") && text.contains("MotionCommand") && text.contains("position"), "{text}");
        let e = message::<MotionCommand>(parse_values("{nominal_sped: 0.3}").expect("yaml")).expect_err("sped");
        assert!(e.to_string().contains("`nominal_sped`"), "{e}");
        let ok = message::<MotionCommand>(parse_values("{goal: {position: {x: 0.5}}, nominal_speed: 0.3}").expect("yaml")).expect("ok");
        assert_eq!((ok.goal.position.x, ok.nominal_speed), (0.5, 0.3));
        let e = message::<MotionCommand>(parse_values("{nominal_speed: fast}").expect("yaml")).expect_err("kind");
        assert!(format!("{e:#}").contains("MotionCommand"), "{e:#}");
    }

    #[test]
    fn rate_of_evenly_spaced_arrivals() {
        let arrivals: std::collections::VecDeque<f64> = (0..11).map(|i| f64::from(i) * 0.1).collect();
        let r = rate_stats(&arrivals).expect("stats");
        assert!((r.rate_hz - 10.0).abs() < 1e-9, "{r:?}");
        assert_eq!(r.window, 10);
        assert!(r.std_s < 1e-9 && (r.min_s - 0.1).abs() < 1e-9 && (r.max_s - 0.1).abs() < 1e-9);
    }

    #[test]
    fn no_rate_from_fewer_than_two_messages_or_one_instant() {
        assert_eq!(rate_stats(&[1.0].into_iter().collect()), None);
        assert_eq!(rate_stats(&[1.0, 1.0].into_iter().collect()), None);
    }
}
