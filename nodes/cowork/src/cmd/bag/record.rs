//! `cowork bag record`: live topics over DDS → MCAP bag, payloads untouched. `-o run.mcap`
//! writes one MCAP file; `-o run` (no `.mcap`) writes a rosbag2 directory `run/` with
//! `run_0.mcap` and, when the recording ends, `metadata.yaml`, as `ros2 bag record -s mcap -o
//! run` does (a directory left without metadata by a crash still opens: its one `.mcap` is read).

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use cowork_bag::{BagWriter, WriteSummary};
use cowork_ros::raw::RawSubscription;
use cowork_ros::{NodeConfig, RosNode, qos, shutdown};

/// Topics never recorded unless named: ROS 2 infrastructure, not data.
const INFRASTRUCTURE: &[&str] = &["/rosout", "/parameter_events"];

/// Arguments of `cowork bag record`.
#[derive(Debug, Args)]
pub struct RecordArgs {
    /// The MCAP file to write (`NAME.mcap`, replaced if it exists), or a rosbag2 directory to
    /// create (`NAME` without `.mcap`: `NAME/NAME_0.mcap` + `metadata.yaml`; refused if it
    /// exists, as `ros2 bag record` does).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Topics to record; all discovered topics (except /rosout, /parameter_events) if none.
    pub topics: Vec<String>,
    /// Stop after this many seconds (wall clock); default: until Ctrl-C.
    #[arg(long)]
    pub duration: Option<f64>,
    /// How often to look for new topics and publishers (s).
    #[arg(long, default_value_t = 0.5)]
    pub discovery_interval: f64,
    /// History depth of each subscription (samples buffered per topic between polls). Deep
    /// enough for a `cowork bag play --max` burst while a zstd chunk of depth images is being
    /// compressed (a cap, not an allocation: the recorder takes samples as they come).
    #[arg(long, default_value_t = 1000)]
    pub depth: usize,
}

struct Recorded {
    sub: RawSubscription,
    topic: Arc<str>,
    type_name: Arc<str>,
    definition: Arc<str>,
    /// Samples taken from DDS (queued for or written to the bag).
    messages: u64,
    bytes: u64,
}

/// One sample on its way from the recorder loop to the writer thread.
struct Taken {
    topic: Arc<str>,
    type_name: Arc<str>,
    definition: Arc<str>,
    /// When DDS received it (ns since the Unix epoch): the MCAP log time.
    receive_time_ns: u64,
    /// The writer's source timestamp, else the receive time (ns since the Unix epoch).
    publish_time_ns: u64,
    data: Vec<u8>,
}

/// What the writer thread reports when it ends.
struct Written {
    /// The finish result.
    summary: cowork_bag::Result<WriteSummary>,
    /// The write error that stopped it, if any.
    error: Option<cowork_bag::BagError>,
    /// Messages written per topic.
    per_topic: BTreeMap<Arc<str>, (Arc<str>, u64)>,
    /// Log times of the first and last message written (ns since the Unix epoch).
    span_ns: Option<(u64, u64)>,
}

/// The writer thread: writes every queued sample until the recorder hangs up or a write fails,
/// then finishes the bag either way (what was written stays readable).
fn write_all(mut writer: BagWriter, queue: std::sync::mpsc::Receiver<Taken>) -> Written {
    let mut error = None;
    let mut per_topic: BTreeMap<Arc<str>, (Arc<str>, u64)> = BTreeMap::new();
    let mut span_ns: Option<(u64, u64)> = None;
    for t in queue {
        if let Err(e) =
            writer.write_raw(&t.topic, &t.type_name, &t.definition, t.receive_time_ns, t.publish_time_ns, &t.data)
        {
            error = Some(e);
            break;
        }
        per_topic.entry(Arc::clone(&t.topic)).or_insert_with(|| (Arc::clone(&t.type_name), 0)).1 += 1;
        let (first, last) = span_ns.get_or_insert((t.receive_time_ns, t.receive_time_ns));
        *first = (*first).min(t.receive_time_ns);
        *last = (*last).max(t.receive_time_ns);
    }
    Written { summary: writer.finish(), error, per_topic, span_ns }
}

/// Where the bag goes: the MCAP file to write and, for a rosbag2 directory, the directory.
fn output_paths(output: &std::path::Path) -> Result<(PathBuf, Option<PathBuf>)> {
    if output.extension().is_some_and(|e| e == "mcap") {
        return Ok((output.to_path_buf(), None));
    }
    if output.exists() {
        bail!(
            "{}: exists; a rosbag2 directory is created new (give another name, or NAME.mcap for a single file)",
            output.display()
        );
    }
    std::fs::create_dir_all(output).with_context(|| format!("creating bag directory {}", output.display()))?;
    Ok((cowork_bag::rosbag2_storage_path(output), Some(output.to_path_buf())))
}

/// QoS for a topic nobody has offered yet (named on the command line before discovery).
fn fallback_qos(topic: &str, depth: usize) -> qos::QosProfile {
    use cowork_msgs::topics::{Delivery, writer_delivery};
    match writer_delivery(topic) {
        Some(Delivery::Clock) => qos::sensor_data(),
        Some(Delivery::Latched) => qos::latched(),
        _ => qos::best_effort_depth(depth),
    }
}

/// Records until `--duration` or Ctrl-C, then finishes the bag and prints counts per topic.
pub fn run(args: &RecordArgs) -> Result<()> {
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration {d}: must be a finite number of seconds > 0");
    }
    if !(args.discovery_interval.is_finite() && args.discovery_interval > 0.0) {
        bail!("--discovery-interval {}: must be > 0 s", args.discovery_interval);
    }
    let depth = args.depth.max(1);
    shutdown::install();
    let mut node = RosNode::new("cowork_bag_recorder", &NodeConfig::default())?;
    let (file, rosbag2_dir) = output_paths(&args.output)?;
    let writer = BagWriter::create(&file).with_context(|| format!("creating bag {}", file.display()))?;
    // Compressing and writing chunks happens on its own thread so taking samples never waits
    // on it: a burst (`cowork bag play --max`) queues here instead of overflowing the DDS
    // reader caches. The queue is unbounded on purpose: memory is the price of losing nothing.
    let (to_writer, from_recorder) = std::sync::mpsc::channel::<Taken>();
    let writer_thread = std::thread::Builder::new()
        .name("bag-writer".into())
        .spawn(move || write_all(writer, from_recorder))
        .context("starting the bag writer thread")?;
    let named: BTreeSet<String> = args.topics.iter().cloned().collect();
    let mut recorded: BTreeMap<String, Recorded> = BTreeMap::new();
    let mut warned: BTreeSet<String> = BTreeSet::new();
    let start = Instant::now();
    let end = args.duration.map(|d| start + cowork_ros::duration_s(d));
    let interval = cowork_ros::duration_s(args.discovery_interval);
    let mut next_discovery = start;
    tracing::info!(
        "recording {} to {} (Ctrl-C to stop)",
        if named.is_empty() { "all topics".to_owned() } else { named.iter().cloned().collect::<Vec<_>>().join(" ") },
        args.output.display()
    );
    let bar = crate::cmd::observe::spinner("recording");
    loop {
        let now = Instant::now();
        let stopping = shutdown::requested() || end.is_some_and(|e| now >= e);
        if now >= next_discovery && !stopping {
            bar.suspend(|| discover(&mut node, &named, depth, &mut recorded, &mut warned));
            next_discovery = now + interval;
            let (messages, bytes) = recorded.values().fold((0, 0), |(m, b), r| (m + r.messages, b + r.bytes));
            bar.set_message(format!("{} topics, {messages} messages, {:.1} MB", recorded.len(), bytes as f64 / 1e6));
        }
        let mut got = 0usize;
        let mut writer_gone = false;
        for (topic, r) in &mut recorded {
            while let Some(sample) = r.sub.take() {
                got += 1;
                r.messages += 1;
                r.bytes += sample.data.len() as u64;
                let taken = Taken {
                    topic: Arc::clone(&r.topic),
                    type_name: Arc::clone(&r.type_name),
                    definition: Arc::clone(&r.definition),
                    receive_time_ns: sample.receive_time_ns,
                    publish_time_ns: sample.source_time_ns.unwrap_or(sample.receive_time_ns),
                    data: sample.data,
                };
                if to_writer.send(taken).is_err() {
                    // The writer stopped on an error; it is reported below.
                    tracing::error!("bag writer stopped; no longer recording ({topic})");
                    writer_gone = true;
                    break;
                }
            }
            if writer_gone {
                break;
            }
        }
        if writer_gone || (stopping && got == 0) {
            break;
        }
        if got == 0 {
            std::thread::sleep(Duration::from_micros(500));
        }
    }
    bar.finish_and_clear();
    drop(to_writer);
    let elapsed = start.elapsed().as_secs_f64();
    let written = writer_thread
        .join()
        .map_err(|_| anyhow::anyhow!("the bag writer thread panicked"))?;
    let write_error = written.error;
    let summary = written.summary.with_context(|| format!("finishing bag {}", file.display()))?;
    if let Some(dir) = &rosbag2_dir {
        let (start_ns, end_ns) = written.span_ns.unwrap_or((0, 0));
        let metadata = cowork_bag::Rosbag2Metadata {
            storage_file: file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            start_ns,
            end_ns,
            topics: written
                .per_topic
                .iter()
                .map(|(topic, (type_name, n))| cowork_bag::Rosbag2Topic {
                    name: topic.to_string(),
                    type_name: type_name.to_string(),
                    message_count: *n,
                })
                .collect(),
        };
        metadata.write(dir).with_context(|| format!("writing {}/metadata.yaml", dir.display()))?;
    }
    println!("{:<40}  {:<36}  {:>9}  {:>12}", "topic", "type", "messages", "MB");
    for (topic, r) in &recorded {
        println!(
            "{topic:<40}  {:<36}  {:>9}  {:>12.3}",
            r.type_name,
            r.messages,
            r.bytes as f64 / 1e6
        );
    }
    for t in named.iter().filter(|t| !recorded.contains_key(*t)) {
        println!("{t:<40}  (never seen on the graph)");
    }
    println!(
        "wrote {} messages on {} topics in {elapsed:.1} s to {}",
        summary.message_count,
        summary.channel_count,
        args.output.display()
    );
    if let Some(e) = write_error {
        return Err(e).with_context(|| format!("writing bag {}", args.output.display()));
    }
    Ok(())
}

/// Subscribes to every wanted topic seen on the graph that has a writer and no subscription
/// yet.
///
/// The type recorded is the type of the topic's writers, never of its readers: every
/// ros2-client node reads `/clock` as `builtin_interfaces/msg/Time` by itself (its spinner's
/// sim-time reader), and recording that reader's type would make `/clock` undecodable. A topic
/// with readers only is subscribed once a writer shows up.
fn discover(
    node: &mut RosNode,
    named: &BTreeSet<String>,
    depth: usize,
    recorded: &mut BTreeMap<String, Recorded>,
    warned: &mut BTreeSet<String>,
) {
    let topics: BTreeSet<String> = node.discovered_topics().into_iter().map(|t| t.name).collect();
    for topic in topics {
        let wanted = if named.is_empty() {
            !INFRASTRUCTURE.contains(&topic.as_str())
        } else {
            named.contains(&topic)
        };
        if !wanted || recorded.contains_key(&topic) {
            continue;
        }
        let mut type_names = node.writer_type_names(&topic);
        if type_names.is_empty() {
            continue;
        }
        if type_names.len() > 1 && warned.insert(format!("types {topic}")) {
            tracing::warn!("{topic} is published with several types ({}); recording {}", type_names.join(", "), type_names[0]);
        }
        let type_name = type_names.swap_remove(0);
        let definition = match cowork_msgs::find_type(&type_name) {
            Some(info) => (info.definition)(),
            None => {
                if warned.insert(format!("unknown {topic}")) {
                    tracing::warn!(
                        "{topic}: type {type_name} is not known to cowork_msgs; recording its payloads \
                         untouched with an empty schema text"
                    );
                }
                String::new()
            }
        };
        let qos = node.offered_qos(&topic, depth).unwrap_or_else(|| fallback_qos(&topic, depth));
        match node.raw_subscription(&topic, &type_name, &qos) {
            Ok(sub) => {
                tracing::info!("recording {topic} ({type_name})");
                recorded.insert(
                    topic.clone(),
                    Recorded {
                        sub,
                        topic: topic.into(),
                        type_name: type_name.into(),
                        definition: definition.into(),
                        messages: 0,
                        bytes: 0,
                    },
                );
            }
            Err(e) => {
                if warned.insert(format!("sub {topic}")) {
                    tracing::warn!("cannot record {topic}: {e:#}");
                }
            }
        }
    }
}
