//! `cowork bag play`: republish a bag over DDS on the schedule of `cowork_bag::Player`.

use std::collections::{BTreeMap, BTreeSet};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use cowork_bag::play::{CLOCK_TOPIC, percentile, wait_until};
use cowork_bag::{BagReader, PlayItem, PlayOptions, Player, Rate, Verdict, check_message};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_ros::raw::RawPublisher;
use cowork_ros::{NodeConfig, Publisher, RosNode, qos, shutdown};
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
    /// Publish every message without checking it (graph topic types, schema, payload, image
    /// size and encoding); by default bad messages are skipped with one warning per topic.
    #[arg(long)]
    pub no_check: bool,
    /// No progress bar (it is also hidden when stderr is not a terminal).
    #[arg(long)]
    pub quiet: bool,
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
    /// Wall time from the first due instant to the last publish (s).
    pub elapsed_s: f64,
    /// Lateness of each publish call behind its due instant (ms), not at `--max`.
    pub late_ms: Vec<f64>,
    /// Duration of each publish call (ms).
    pub publish_ms: Vec<f64>,
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

/// QoS a replayed topic is published with: `/clock` as rclcpp's clock QoS, `/tf_static`
/// latched, everything else reliable keep-last 100 (a reliable writer matches reliable and
/// best-effort readers alike).
fn publish_qos(topic: &str) -> qos::QosProfile {
    match topic {
        CLOCK_TOPIC => qos::clock(),
        "/tf_static" => qos::latched(),
        _ => qos::reliable_depth(100),
    }
}

/// Replays `reader` on `node` as `args` say; stops early on Ctrl-C.
pub fn replay(reader: &BagReader, args: &PlayArgs, node: &mut RosNode) -> Result<PlayStats> {
    if !(args.delay.is_finite() && args.delay >= 0.0) {
        bail!("--delay {}: must be ≥ 0 s", args.delay);
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
    let clock: Option<Publisher<Clock>> = if player.generates_clock() {
        Some(node.publisher::<Clock>(CLOCK_TOPIC, &qos::clock())?)
    } else {
        None
    };
    std::thread::sleep(Duration::from_secs_f64(args.delay));

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

    let mut stats = PlayStats::default();
    let mut warned: BTreeSet<String> = BTreeSet::new();
    let start = Instant::now();
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
        if !max && !wait_interruptible(deadline) {
            break;
        }
        match item {
            PlayItem::Clock { time_ns, .. } => {
                if let Some(c) = &clock {
                    let call = Instant::now();
                    c.publish(Clock { clock: Time::from_nanos(time_ns as i64) })?;
                    if !max {
                        stats.late_ms.push(ms(call.saturating_duration_since(deadline)));
                    }
                    stats.clock_ticks += 1;
                }
            }
            PlayItem::Message { message, .. } => {
                let topic = message.topic.to_string();
                let Some(publisher) = publishers.get(&topic) else {
                    continue;
                };
                if !args.no_check
                    && let Err(e) = check_message(&message).map(|_: Verdict| ())
                {
                    *stats.skipped.entry(topic.clone()).or_default() += 1;
                    if warned.insert(topic) {
                        bar.suspend(|| tracing::warn!("skipping bad messages: {e}"));
                    }
                    continue;
                }
                let call = Instant::now();
                if let Err(e) = publisher.publish(&message.data) {
                    *stats.skipped.entry(topic.clone()).or_default() += 1;
                    if warned.insert(topic) {
                        bar.suspend(|| tracing::warn!("{e:#}"));
                    }
                    continue;
                }
                let done = Instant::now();
                if !max {
                    stats.late_ms.push(ms(call.saturating_duration_since(deadline)));
                }
                stats.publish_ms.push(ms(done - call));
                stats.published += 1;
                stats.bytes += message.data.len() as u64;
                bar.inc(1);
                let bag_s = message.log_time_ns as f64 * 1e-9;
                if (bag_s - last_bag_s).abs() >= 0.1 || last_bag_s.is_nan() {
                    last_bag_s = bag_s;
                    bar.set_message(format!("bag time {bag_s:.1} s"));
                }
            }
        }
    }
    stats.elapsed_s = start.elapsed().as_secs_f64();
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
