//! `cowork bag play`: republish a bag over DDS on the schedule of `cowork_bag::Player`.

use std::collections::{BTreeMap, BTreeSet};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use cowork_bag::play::{CLOCK_TOPIC, percentile, wait_until};
use cowork_bag::{BagReader, PlayItem, PlayOptions, Player, Rate, Verdict, check_message};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::RosMessage;
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_ros::raw::RawPublisher;
use cowork_ros::{NodeConfig, RosNode, qos, shutdown};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Arguments of `cowork bag play`.
#[derive(Debug, Clone, Args)]
pub struct PlayArgs {
    /// The MCAP file.
    pub file: PathBuf,
    /// Replay speed: bag time runs this many times as fast as the wall clock.
    #[arg(long, default_value_t = 1.0, conflicts_with = "max")]
    pub rate: f64,
    /// As fast as possible (no waiting between messages).
    #[arg(long)]
    pub max: bool,
    /// Start again from the beginning (or --start) after the last message, until Ctrl-C.
    #[arg(long = "loop")]
    pub looped: bool,
    /// Only these topics (all if none).
    #[arg(long, num_args = 1..)]
    pub topics: Vec<String>,
    /// Skip the first SECONDS of the bag.
    #[arg(long, default_value_t = 0.0, value_name = "SECONDS")]
    pub start: f64,
    /// Rate of /clock ticks generated from bag time (Hz) when the bag has no /clock; 0 = none.
    #[arg(long, default_value_t = 100.0)]
    pub clock_hz: f64,
    /// Seconds to wait after creating the publishers before the first message, so that
    /// subscribers discover and match them (DDS discovery is not instant).
    #[arg(long, default_value_t = 1.0)]
    pub delay: f64,
    /// After the delay, also wait (at most this many seconds) until every replayed topic has
    /// a matched subscriber — for a recorder that must not miss a topic's first messages.
    #[arg(long, value_name = "SECONDS")]
    pub wait_readers: Option<f64>,
    /// Publish every message without checking it (graph topic types, schema, payload, image
    /// size and encoding); by default bad messages are skipped with one warning per topic.
    #[arg(long)]
    pub no_check: bool,
    /// No progress bar (it is also hidden when stderr is not a terminal).
    #[arg(long)]
    pub quiet: bool,
}

/// Waits until every publisher's topic has a subscriber in another participant (discovered,
/// so matched) or `limit` seconds pass; names the topics still without one.
fn wait_for_readers(node: &RosNode, publishers: &BTreeMap<String, RawPublisher>, limit: f64) {
    let until = std::time::Instant::now() + cowork_ros::duration_s(limit);
    loop {
        let missing: Vec<&str> = publishers.keys().filter(|t| node.remote_reader_count(t) == 0).map(String::as_str).collect();
        if missing.is_empty() {
            return;
        }
        if std::time::Instant::now() >= until || shutdown::requested() {
            tracing::warn!("no subscriber matched after {limit} s on: {}", missing.join(", "));
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Figures of one replay.
#[derive(Debug, Default)]
pub struct PlayStats {
    /// Messages published (bag messages, not clock ticks).
    pub published: u64,
    /// Payload bytes published.
    pub bytes: u64,
    /// `/clock` ticks generated and published.
    pub clock_ticks: u64,
    /// Messages skipped by the checks or refused by the publisher, per topic.
    pub skipped: BTreeMap<String, u64>,
    /// Wall time from the first due instant to the last publish or, if later, its
    /// acknowledgement by every reliable subscriber (s).
    pub elapsed_s: f64,
    /// Lateness of each publish call behind its due instant (ms), not at `--max`.
    pub late_ms: Vec<f64>,
    /// Duration of each publish call (ms).
    pub publish_ms: Vec<f64>,
    /// Topics whose reliable subscribers had not acknowledged every message at the end.
    pub unacknowledged: Vec<String>,
}

impl PlayStats {
    /// Prints the summary table.
    pub fn print(&self, max: bool) {
        let mut late = self.late_ms.clone();
        let mut call = self.publish_ms.clone();
        println!(
            "published {} messages ({:.1} MB) and {} /clock ticks in {:.2} s: {:.0} msgs/s, {:.1} MB/s",
            self.published,
            self.bytes as f64 / 1e6,
            self.clock_ticks,
            self.elapsed_s,
            self.published as f64 / self.elapsed_s.max(1e-9),
            self.bytes as f64 / 1e6 / self.elapsed_s.max(1e-9)
        );
        if !max && !late.is_empty() {
            println!(
                "publish-time error (call start − due): p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms",
                percentile(&mut late, 0.5).unwrap_or(0.0),
                percentile(&mut late, 0.99).unwrap_or(0.0),
                percentile(&mut late, 1.0).unwrap_or(0.0)
            );
        }
        if !call.is_empty() {
            println!(
                "publish call: p50 {:.3} ms, p99 {:.3} ms",
                percentile(&mut call, 0.5).unwrap_or(0.0),
                percentile(&mut call, 0.99).unwrap_or(0.0)
            );
        }
        for (topic, n) in &self.skipped {
            println!("skipped {n} messages on {topic}");
        }
        if !self.unacknowledged.is_empty() {
            println!("not acknowledged by every reliable subscriber: {}", self.unacknowledged.join(", "));
        }
    }
}

impl PlayArgs {
    /// The library's options for these arguments.
    pub fn options(&self) -> PlayOptions {
        PlayOptions {
            rate: if self.max { Rate::Max } else { Rate::Factor(self.rate) },
            looped: self.looped,
            start_offset_s: self.start,
            topics: self.topics.clone(),
            clock_hz: self.clock_hz,
        }
    }
}

/// Runs `cowork bag play` on the domain of `ROS_DOMAIN_ID`.
pub fn run(args: &PlayArgs) -> Result<PlayStats> {
    shutdown::install();
    let reader = BagReader::open_recoverable(&args.file)
        .with_context(|| format!("reading bag {}", args.file.display()))?;
    if let Some(damage) = reader.damage() {
        tracing::error!("{damage}; replaying the readable part");
    }
    let mut node = RosNode::new("cowork_bag_player", &NodeConfig::default())?;
    let stats = replay(&reader, args, &mut node)?;
    stats.print(args.max);
    if let Some(damage) = reader.damage() {
        bail!("bag {} is damaged: {damage} (its readable part was replayed)", args.file.display());
    }
    Ok(stats)
}

/// QoS a replayed topic is published with: `/clock` as rclcpp's clock QoS, latched graph
/// topics (`/tf_static`, `/robot_description`) latched, everything else reliable keep-last 100 (a reliable writer matches reliable and
/// best-effort readers alike).
fn publish_qos(topic: &str) -> qos::QosProfile {
    use cowork_msgs::topics::{Delivery, writer_delivery};
    match writer_delivery(topic) {
        _ if topic == CLOCK_TOPIC => qos::clock(),
        Some(Delivery::Latched) => qos::latched(),
        _ => qos::replay(100),
    }
}

/// How long before its due instant the reader hands a message to its topic's publisher
/// thread. Reading the bag (zstd chunks of depth images), checking messages and other topics'
/// publish calls all happen in this margin, never between a due instant and its publish call.
const LOOKAHEAD: Duration = Duration::from_millis(250);

/// Messages queued per topic thread at `--rate` (memory is bounded by [`LOOKAHEAD`] there).
const QUEUE_TIMED: usize = 512;

/// Messages queued per topic thread at `--max` (the queue is the read-ahead; depth images
/// are ~1 MB each).
const QUEUE_MAX: usize = 16;

/// At `--max`, a topic thread waits for its reliable readers' acknowledgements after this
/// many bytes or messages: a bounded window in flight, so that a fast replay does not outrun
/// a subscriber (RustDDS keeps unacknowledged samples for repair; UDP on loopback drops
/// fragments of a burst of megabyte images, which then need repair rounds).
const WINDOW_BYTES: u64 = 4 << 20;
const WINDOW_MESSAGES: u64 = 64;

/// Longest wait for the acknowledgement of one window at `--max`.
const WINDOW_ACK_WAIT: Duration = Duration::from_secs(2);

/// Longest wait at the end of a replay for reliable readers to acknowledge everything, before
/// the writers (and, for `cowork bag play`, the process) go away.
const FINAL_ACK_WAIT: Duration = Duration::from_secs(5);

/// One payload for a topic thread: publish `data` at `deadline`.
struct Job {
    deadline: Instant,
    data: Vec<u8>,
    /// A `/clock` tick generated from bag time (counted apart from bag messages).
    tick: bool,
}

/// What one topic thread did.
#[derive(Debug, Default)]
struct TopicStats {
    published: u64,
    bytes: u64,
    ticks: u64,
    skipped: u64,
    late_ms: Vec<f64>,
    publish_ms: Vec<f64>,
    /// When the last message was published, or, if later, acknowledged by every reliable
    /// reader.
    finished: Option<Instant>,
    /// Reliable readers had not acknowledged everything within [`FINAL_ACK_WAIT`].
    unacknowledged: bool,
}

/// The publisher thread of one topic: waits for each job's deadline (not at `--max`) and
/// publishes it; at `--max` it keeps a bounded window in flight; at the end it waits for the
/// acknowledgements of reliable readers.
fn publish_topic(publisher: &RawPublisher, jobs: Receiver<Job>, max: bool, bar: &ProgressBar) -> TopicStats {
    let mut s = TopicStats::default();
    let mut warned = false;
    let (mut window_bytes, mut window_messages) = (0u64, 0u64);
    for job in jobs {
        if !max && !wait_interruptible(job.deadline) {
            return s;
        }
        if shutdown::requested() {
            return s;
        }
        let call = Instant::now();
        if let Err(e) = publisher.publish(&job.data) {
            s.skipped += 1;
            if !warned {
                warned = true;
                bar.suspend(|| tracing::warn!("{e:#}"));
            }
            continue;
        }
        let done = Instant::now();
        s.finished = Some(done);
        if !max {
            s.late_ms.push(ms(call.saturating_duration_since(job.deadline)));
        }
        if job.tick {
            s.ticks += 1;
            continue;
        }
        s.publish_ms.push(ms(done - call));
        s.published += 1;
        s.bytes += job.data.len() as u64;
        bar.inc(1);
        if max {
            window_bytes += job.data.len() as u64;
            window_messages += 1;
            if window_bytes >= WINDOW_BYTES || window_messages >= WINDOW_MESSAGES {
                (window_bytes, window_messages) = (0, 0);
                if !publisher.wait_for_acknowledgments(WINDOW_ACK_WAIT).unwrap_or(false) && !warned {
                    warned = true;
                    bar.suspend(|| {
                        tracing::warn!(
                            "{}: a reliable reader has not acknowledged within {:?}; going on",
                            publisher.topic(),
                            WINDOW_ACK_WAIT
                        )
                    });
                }
            }
        }
    }
    if !shutdown::requested() {
        s.unacknowledged = !publisher.wait_for_acknowledgments(FINAL_ACK_WAIT).unwrap_or(false);
        if !s.unacknowledged && s.finished.is_some() {
            s.finished = Some(Instant::now());
        }
    }
    s
}

/// Replays `reader` on `node` as `args` say; stops early on Ctrl-C.
///
/// One thread reads the bag, checks each message and hands it to its topic's publisher thread
/// [`LOOKAHEAD`] before it is due; each topic thread publishes its messages at their due
/// instants (bag time mapped to the wall clock by the schedule), so a slow publish call (a
/// megabyte depth image) delays neither other topics nor the reading. Order is kept within a
/// topic; across topics it follows the due instants (at `--max`, roughly: each topic thread
/// runs at its own pace, up to its queue ahead of the others).
pub fn replay(reader: &BagReader, args: &PlayArgs, node: &mut RosNode) -> Result<PlayStats> {
    if !(args.delay.is_finite() && args.delay >= 0.0) {
        bail!("--delay {}: must be ≥ 0 s", args.delay);
    }
    if let Some(w) = args.wait_readers
        && !(w.is_finite() && w >= 0.0)
    {
        bail!("--wait-readers {w}: must be ≥ 0 s");
    }
    let player = Player::new(reader, args.options())
        .with_context(|| format!("replaying {}", reader.path().display()))?;
    let info = reader.info();
    let mut publishers: BTreeMap<String, RawPublisher> = BTreeMap::new();
    for t in &info.topics {
        if !(args.topics.is_empty() || args.topics.contains(&t.topic)) {
            continue;
        }
        if t.type_name.is_empty() {
            tracing::warn!("{}: no schema (type name) in the bag; not replayed", t.topic);
            continue;
        }
        match node.raw_publisher(&t.topic, &t.type_name, &publish_qos(&t.topic)) {
            Ok(p) => {
                publishers.insert(t.topic.clone(), p);
            }
            Err(e) => tracing::warn!("{}: not replayed: {e:#}", t.topic),
        }
    }
    // Generated ticks go through the same kind of thread, serialised here.
    let clock = if player.generates_clock() {
        Some(node.raw_publisher(CLOCK_TOPIC, &Clock::type_name(), &qos::clock())?)
    } else {
        None
    };
    std::thread::sleep(cowork_ros::duration_s(args.delay));
    if let Some(limit) = args.wait_readers {
        wait_for_readers(node, &publishers, limit);
    }

    let max = args.max;
    let bar = if args.quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else if args.looped {
        ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr())
    } else {
        ProgressBar::with_draw_target(Some(player.messages_per_pass()), ProgressDrawTarget::stderr())
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} msgs {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );

    let queue = if max { QUEUE_MAX } else { QUEUE_TIMED };
    // The first messages are due at `start`: the reader gets LOOKAHEAD to queue them.
    let start = if max { Instant::now() } else { Instant::now() + LOOKAHEAD };
    let mut stats = PlayStats::default();
    let per_topic = std::thread::scope(|scope| -> Result<Vec<(String, TopicStats)>> {
        let mut senders: BTreeMap<&str, SyncSender<Job>> = BTreeMap::new();
        let mut threads = Vec::new();
        for (topic, publisher) in publishers.iter().map(|(t, p)| (t.as_str(), p)).chain(clock.iter().map(|c| ("", c))) {
            let (tx, rx) = sync_channel::<Job>(queue);
            let bar = bar.clone();
            let thread = std::thread::Builder::new()
                .name(format!("play{}", if topic.is_empty() { CLOCK_TOPIC } else { topic }))
                .spawn_scoped(scope, move || publish_topic(publisher, rx, max, &bar))
                .context("cannot start a publisher thread")?;
            threads.push((topic.to_owned(), thread));
            senders.insert(topic, tx);
        }
        let mut warned: BTreeSet<String> = BTreeSet::new();
        let mut last_bag_s = f64::NAN;
        for item in player {
            if shutdown::requested() {
                break;
            }
            let item = match item {
                Ok(i) => i,
                Err(e) => {
                    bar.suspend(|| tracing::error!("{e}; going on with what follows"));
                    continue;
                }
            };
            let deadline = start + item.due();
            if !max && !wait_interruptible(deadline.checked_sub(LOOKAHEAD).unwrap_or(deadline)) {
                break;
            }
            let (key, job) = match item {
                PlayItem::Clock { time_ns, .. } => {
                    let tick = Clock { clock: Time::from_nanos(time_ns as i64) };
                    ("", Job { deadline, data: cowork_msgs::to_cdr(&tick), tick: true })
                }
                PlayItem::Message { message, .. } => {
                    let Some((&key, _)) = senders.get_key_value(&*message.topic) else {
                        continue;
                    };
                    if !args.no_check
                        && let Err(e) = check_message(&message).map(|_: Verdict| ())
                    {
                        *stats.skipped.entry(key.to_owned()).or_default() += 1;
                        if warned.insert(key.to_owned()) {
                            bar.suspend(|| tracing::warn!("skipping bad messages: {e}"));
                        }
                        continue;
                    }
                    let bag_s = message.log_time_ns as f64 * 1e-9;
                    if (bag_s - last_bag_s).abs() >= 0.1 || last_bag_s.is_nan() {
                        last_bag_s = bag_s;
                        bar.set_message(format!("bag time {bag_s:.1} s"));
                    }
                    (key, Job { deadline, data: message.data, tick: false })
                }
            };
            if let Some(tx) = senders.get(key) {
                // Blocks while the topic's queue is full (at --max: its window is in flight).
                // An error means the thread has stopped (Ctrl-C).
                let _ = tx.send(job);
            }
        }
        drop(senders);
        threads
            .into_iter()
            .map(|(topic, t)| {
                t.join()
                    .map(|s| (topic.clone(), s))
                    .map_err(|_| anyhow::anyhow!("the publisher thread of {topic} panicked"))
            })
            .collect()
    })?;
    let mut last = None;
    for (topic, s) in per_topic {
        let name = if topic.is_empty() { CLOCK_TOPIC.to_owned() } else { topic };
        stats.published += s.published;
        stats.bytes += s.bytes;
        stats.clock_ticks += s.ticks;
        stats.late_ms.extend(s.late_ms);
        stats.publish_ms.extend(s.publish_ms);
        if s.skipped > 0 {
            *stats.skipped.entry(name.clone()).or_default() += s.skipped;
        }
        if s.unacknowledged {
            tracing::warn!(
                "{name}: not every message was acknowledged by reliable subscribers within {FINAL_ACK_WAIT:?}"
            );
            stats.unacknowledged.push(name);
        }
        last = last.max(s.finished);
    }
    stats.elapsed_s = last.map_or(0.0, |l| l.saturating_duration_since(start).as_secs_f64());
    bar.finish_and_clear();
    Ok(stats)
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// [`wait_until`] in slices of at most 100 ms so that Ctrl-C during a long gap of the bag is
/// seen; `false` when a stop was requested.
fn wait_interruptible(deadline: Instant) -> bool {
    loop {
        if shutdown::requested() {
            return false;
        }
        let now = Instant::now();
        if deadline <= now + Duration::from_millis(100) {
            wait_until(deadline);
            return true;
        }
        std::thread::sleep(Duration::from_millis(90));
    }
}
