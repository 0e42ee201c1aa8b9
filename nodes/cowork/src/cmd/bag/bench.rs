//! `cowork bag bench`: replay timing at `--rate 1` and `--max` throughput on a synthetic depth
//! bag (640×480 32FC1 images and camera info at 30 Hz, joint states at 100 Hz) or on a given
//! bag (`--bag`, e.g. one of `bags/`), with an in-process reliable subscriber to every topic on
//! a private DDS domain counting what arrives.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::{Context, Result};
use clap::Args;
use cowork_bag::play::{CLOCK_TOPIC, percentile};
use cowork_bag::{BagReader, BagWriter};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::std_msgs::Header;
use cowork_ros::{NodeConfig, RosNode, qos};

use super::play::{PlayArgs, replay};

/// Arguments of `cowork bag bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Length of the synthetic bag (s of bag time).
    #[arg(long, default_value_t = 5.0)]
    pub seconds: f64,
    /// DDS domain of the benchmark (kept away from a running graph).
    #[arg(long, default_value_t = 211)]
    pub domain: u16,
    /// Replay this bag instead of writing a synthetic one (`--seconds` is then ignored).
    #[arg(long, value_name = "FILE")]
    pub bag: Option<std::path::PathBuf>,
}

const TOPICS: [(&str, &str); 3] = [
    ("/camera/depth/image_raw", "sensor_msgs/msg/Image"),
    ("/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo"),
    ("/joint_states", "sensor_msgs/msg/JointState"),
];

fn write_bag(path: &std::path::Path, seconds: f64) -> Result<u64> {
    let t0: u64 = 1_700_000_000_000_000_000;
    let mut w = BagWriter::create(path)?;
    let img = w.add_channel::<Image>(TOPICS[0].0)?;
    let info = w.add_channel::<CameraInfo>(TOPICS[1].0)?;
    let js = w.add_channel::<JointState>(TOPICS[2].0)?;
    let frames = (seconds * 30.0).round() as u64;
    let mut data = vec![0u8; 640 * 480 * 4];
    for i in 0..frames {
        let t = t0 + i * 1_000_000_000 / 30;
        let header = Header { stamp: Time::from_nanos(t as i64), frame_id: "camera_depth_optical".into() };
        for (k, px) in data.chunks_exact_mut(4).enumerate() {
            let depth = 1.0f32 + ((k % 640) as f32 * 0.003) + (i as f32 * 0.01);
            px.copy_from_slice(&depth.to_le_bytes());
        }
        let image = Image {
            header: header.clone(),
            height: 480,
            width: 640,
            encoding: "32FC1".into(),
            is_bigendian: 0,
            step: 640 * 4,
            data: data.clone(),
        };
        w.write(img, t, t, &image)?;
        let ci = CameraInfo { header, height: 480, width: 640, ..Default::default() };
        w.write(info, t, t, &ci)?;
    }
    let states = (seconds * 100.0).round() as u64;
    for i in 0..states {
        let t = t0 + i * 10_000_000 + 1;
        let msg = JointState {
            header: Header { stamp: Time::from_nanos(t as i64), frame_id: String::new() },
            name: (1..=7).map(|j| format!("lwr_joint_{j}")).collect(),
            position: vec![0.1 * i as f64; 7],
            velocity: vec![0.0; 7],
            effort: vec![0.0; 7],
        };
        w.write(js, t, t, &msg)?;
    }
    Ok(w.finish()?.message_count)
}

/// Receive times (ns) per topic of `topics` (name, type), collected by a subscriber thread
/// until `stop`.
fn subscribe(
    domain: u16,
    topics: &[(String, String)],
    stop: Arc<AtomicBool>,
) -> Result<std::thread::JoinHandle<Result<BTreeMap<String, Vec<u64>>>>> {
    let mut node = RosNode::new("cowork_bag_bench_sub", &NodeConfig { domain_id: Some(domain), ..Default::default() })?;
    let subs = topics
        .iter()
        .map(|(t, ty)| node.raw_subscription(t, ty, &qos::reliable_depth(100)).map(|s| (t.clone(), s)))
        .collect::<Result<Vec<_>>>()?;
    Ok(std::thread::spawn(move || {
        let _node = node;
        let mut got: BTreeMap<String, Vec<u64>> = BTreeMap::new();
        loop {
            let mut n = 0;
            for (t, s) in &subs {
                while let Some(sample) = s.take() {
                    got.entry(t.clone()).or_default().push(sample.receive_time_ns);
                    n += 1;
                }
            }
            if n == 0 {
                if stop.load(Ordering::SeqCst) {
                    return Ok(got);
                }
                std::thread::sleep(Duration::from_micros(200));
            }
        }
    }))
}

/// Runs the benchmark and prints its table.
pub fn run(args: &BenchArgs) -> Result<()> {
    if let Some(bag) = &args.bag {
        let n = BagReader::open(bag).with_context(|| format!("reading bag {}", bag.display()))?.info().message_count;
        return bench(args, bag, n);
    }
    let path = std::env::temp_dir().join(format!("cowork_bag_bench_{}.mcap", std::process::id()));
    let n = write_bag(&path, args.seconds).with_context(|| format!("writing {}", path.display()))?;
    let result = bench(args, &path, n);
    let _ = std::fs::remove_file(&path);
    result
}

fn bench(args: &BenchArgs, path: &std::path::Path, n: u64) -> Result<()> {
    let reader = BagReader::open(path)?;
    let mut log_times: BTreeMap<String, Vec<u64>> = BTreeMap::new();
    for m in reader.messages() {
        let m = m?;
        log_times.entry(m.topic.to_string()).or_default().push(m.log_time_ns);
    }
    let size_mb = std::fs::metadata(path).map(|m| m.len() as f64 / 1e6).unwrap_or(0.0);
    let info = reader.info();
    let span_s = info.end_ns.unwrap_or(0).saturating_sub(info.start_ns.unwrap_or(0)) as f64 * 1e-9;
    println!("bag {}: {n} messages, {span_s:.1} s, {size_mb:.1} MB on disk (zstd)", path.display());
    // /clock is best effort (its publisher QoS): not counted.
    let topics: Vec<(String, String)> = info
        .topics
        .iter()
        .filter(|t| t.topic != CLOCK_TOPIC && !t.type_name.is_empty())
        .map(|t| (t.topic.clone(), t.type_name.clone()))
        .collect();

    let mut player = RosNode::new("cowork_bag_player", &NodeConfig { domain_id: Some(args.domain), ..Default::default() })?;
    for (label, max) in [("--rate 1", false), ("--max", true)] {
        let stop = Arc::new(AtomicBool::new(false));
        let sub = subscribe(args.domain, &topics, Arc::clone(&stop))?;
        let play = PlayArgs {
            file: path.to_path_buf(),
            rate: 1.0,
            max,
            looped: false,
            topics: Vec::new(),
            start: 0.0,
            clock_hz: 0.0,
            wait_readers: None,
            delay: 2.0,
            no_check: max,
            quiet: true,
        };
        let stats = replay(&reader, &play, &mut player)?;
        std::thread::sleep(Duration::from_millis(500));
        stop.store(true, Ordering::SeqCst);
        let got = sub.join().map_err(|_| anyhow::anyhow!("subscriber thread panicked"))??;
        println!("== {label}");
        stats.print(max);
        let received: usize = got.values().map(Vec::len).sum();
        let sent: usize = topics.iter().map(|(t, _)| log_times.get(t).map_or(0, Vec::len)).sum();
        println!("received {received} of the {sent} messages of the subscribed topics");
        if !max {
            // Receive-side timing: (receive − log time) minus its median, over all messages
            // that arrived in order on each topic.
            let mut offsets = Vec::new();
            for (topic, recv) in &got {
                if let Some(logs) = log_times.get(topic) {
                    for (r, l) in recv.iter().zip(logs) {
                        offsets.push(*r as f64 * 1e-6 - *l as f64 * 1e-6);
                    }
                }
            }
            let median = percentile(&mut offsets.clone(), 0.5).unwrap_or(0.0);
            let mut err: Vec<f64> = offsets.iter().map(|o| (o - median).abs()).collect();
            println!(
                "receive-time error vs bag timing: p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms",
                percentile(&mut err, 0.5).unwrap_or(0.0),
                percentile(&mut err, 0.99).unwrap_or(0.0),
                percentile(&mut err, 1.0).unwrap_or(0.0)
            );
        }
    }
    Ok(())
}
