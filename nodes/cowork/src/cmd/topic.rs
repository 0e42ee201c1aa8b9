//! `cowork topic list|echo`: look at live topics over DDS without a ROS installation.

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
    /// Publish a message given as JSON; fields left out keep their ROS defaults.
    Pub {
        /// Topic name, e.g. /lwr/gripper_command.
        topic: String,
        /// Message type, e.g. std_msgs/msg/String.
        #[arg(value_name = "TYPE")]
        type_name: String,
        /// The message as JSON, e.g. '{"data": "close"}'.
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
            for t in discover(&node, wait, |_| false)? {
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
        TopicCommand::Pub { topic, type_name, json, count, rate, wait } => {
            if !(rate.is_finite() && rate > 0.0) {
                bail!("--rate {rate}: must be a positive number of Hz");
            }
            if !(wait.is_finite() && wait >= 0.0) {
                bail!("--wait {wait}: must be a non-negative number of seconds");
            }
            let value: serde_json::Value = serde_json::from_str(&json)
                .with_context(|| format!("the message for {topic} is not valid JSON: {json}"))?;
            let mut node = RosNode::new(&format!("cowork_pub_{}", std::process::id()), &NodeConfig::default())?;
            let period = cowork_ros::duration_s(1.0 / rate);
            with_message_type!(type_name.as_str(), T => publish::<T>(&mut node, &topic, value, count, period, wait))
                .with_context(|| format!("{type_name} is not a type cowork knows (see `cowork topic list`)"))?
        }
    }
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

fn publish<T: RosMessage>(
    node: &mut RosNode,
    topic: &str,
    patch: serde_json::Value,
    count: usize,
    period: Duration,
    wait: f64,
) -> Result<()> {
    let mut value = serde_json::to_value(T::default())?;
    merge(&mut value, patch);
    let msg: T = serde_json::from_value(value)
        .with_context(|| format!("the JSON does not fit {} (fields: {})", T::type_name(), serde_json::to_string(&T::default()).unwrap_or_default()))?;
    let publisher = node.publisher::<T>(topic, &qos::reliable())?;
    let deadline = Instant::now() + cowork_ros::duration_s(wait);
    while publisher.subscription_count(node) == 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut next = Instant::now();
    for _ in 0..count {
        if cowork_ros::shutdown::requested() {
            break;
        }
        publisher.publish(msg.clone())?;
        next += period;
        if let Some(d) = next.checked_duration_since(Instant::now()) {
            std::thread::sleep(d);
        }
    }
    // Let reliable delivery finish before the participant leaves.
    std::thread::sleep(Duration::from_millis(200));
    Ok(())
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
