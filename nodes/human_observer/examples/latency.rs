//! Latency of the node over DDS on loopback (a bench, not a test): skeleton frame in →
//! `/human/state` out, and end of a labelled gesture → `/human/gesture` out, median and p99.
//!
//! `cargo run --release -p human_observer --example latency [-- GESTURES]`
//!
//! The node runs in this process on a private domain with `/clock` time; a client publishes
//! a synthetic labelled gesture stream (30 Hz depth tracker) in real time with its joint states
//! and clock, and times the answers (wall clock, same process).

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cowork_msgs::msg::{Gesture, HumanState, Skeleton};
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Header;
use cowork_observer::GestureModel;
use cowork_observer::eval::gesture_stream;
use cowork_people::SensorConfig;
use cowork_robot::RobotModel;
use cowork_ros::{NodeConfig, RosNode, qos};
use human_observer::{ObserverNode, Params, RunOptions};

fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { f64::NAN } else { v[((v.len() - 1) as f64 * q).round() as usize] }
}

fn main() -> anyhow::Result<()> {
    let count: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(6);
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut params: Params = cowork_ros::params::load(&root.join("config/human_observer.yaml"), "human_observer")?;
    params.urdf = root.join("config/robot/lwr4plus.urdf").display().to_string();
    let model = RobotModel::from_urdf_file(&params.urdf)?;
    let gestures = GestureModel::from_file(&root.join("config/gestures.json"))?;
    let domain = 150 + (std::process::id() % 80) as u16;
    let config = NodeConfig { domain_id: Some(domain), ..Default::default() };
    let stop = Arc::new(AtomicBool::new(false));
    let node = RosNode::new("human_observer", &NodeConfig { use_sim_time: true, ..config.clone() })?;
    let observer = ObserverNode::new(model, params, Some(gestures))?;
    let options = RunOptions { duration_s: Some(600.0), stop: Some(Arc::clone(&stop)) };
    let handle = std::thread::spawn(move || human_observer::run(node, observer, &options));

    let mut client = RosNode::new("latency_client", &config)?;
    let clock = client.publisher::<Clock>("/clock", &qos::clock())?;
    let joints = client.publisher::<JointState>("/joint_states", &qos::reliable())?;
    let skeletons = client.publisher::<Skeleton>("/human/skeleton", &qos::reliable())?;
    let states = client.subscription::<HumanState>("/human/state", &qos::reliable())?;
    let gesture = client.subscription::<Gesture>("/human/gesture", &qos::reliable())?;
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(20) && (skeletons.subscription_count(&client) == 0 || states.publisher_count(&client) == 0 || gesture.publisher_count(&client) == 0) {
        std::thread::sleep(Duration::from_millis(50));
    }
    let stream = gesture_stream(77, count, &SensorConfig::depth_tracker(), false)?;
    let start = Instant::now();
    let t0 = stream.frames.first().map_or(0.0, |m| m.header.stamp.to_secs_f64());
    let mut sent: HashMap<(i32, u32), Instant> = HashMap::new();
    let (mut state_lat, mut gesture_lat) = (Vec::new(), Vec::new());
    let mut got_gestures = Vec::new();
    let drain = |sent: &mut HashMap<(i32, u32), Instant>, state_lat: &mut Vec<f64>, got: &mut Vec<(String, f64)>| {
        while let Some(s) = states.take() {
            if let Some(at) = sent.remove(&(s.header.stamp.sec, s.header.stamp.nanosec)) {
                state_lat.push(at.elapsed().as_secs_f64());
            }
        }
        while let Some(g) = gesture.take() {
            got.push((g.label, start.elapsed().as_secs_f64()));
        }
    };
    for m in &stream.frames {
        let due = Duration::from_secs_f64((m.header.stamp.to_secs_f64() - t0).max(0.0));
        while start.elapsed() < due {
            drain(&mut sent, &mut state_lat, &mut got_gestures);
            std::thread::sleep(Duration::from_micros(500));
        }
        let stamp = m.header.stamp;
        clock.publish(Clock { clock: stamp })?;
        joints.publish(JointState {
            header: Header { stamp, frame_id: String::new() },
            name: (1..=7).map(|i| format!("lwr_joint_{i}")).collect(),
            position: vec![0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0],
            ..Default::default()
        })?;
        sent.insert((stamp.sec, stamp.nanosec), Instant::now());
        skeletons.publish(m.clone())?;
    }
    let end = Instant::now() + Duration::from_secs(2);
    while Instant::now() < end {
        drain(&mut sent, &mut state_lat, &mut got_gestures);
        std::thread::sleep(Duration::from_millis(5));
    }
    stop.store(true, Ordering::SeqCst);
    let _ = handle.join();
    // Gesture latency: arrival minus the wall time of the labelled end (frames were sent in
    // real time from t0); negative when recognised before the labelled end.
    for l in &stream.labels {
        if let Some((_, at)) = got_gestures.iter().find(|(g, at)| *g == l.label && *at >= l.start - t0 && *at <= l.end - t0 + 2.0) {
            gesture_lat.push(at - (l.end - t0));
        }
    }
    let n = state_lat.len();
    let (m, p99) = (percentile(&mut state_lat, 0.5), percentile(&mut state_lat, 0.99));
    println!("skeleton -> /human/state over DDS: {n} of {} frames, median {:.2} ms, p99 {:.2} ms", stream.frames.len(), m * 1e3, p99 * 1e3);
    let k = gesture_lat.len();
    let (gm, gp) = (percentile(&mut gesture_lat, 0.5), percentile(&mut gesture_lat, 0.99));
    println!("labelled gesture end -> /human/gesture: {k} of {} gestures, median {:.0} ms, p99 {:.0} ms (negative: before the labelled end)", stream.labels.len(), gm * 1e3, gp * 1e3);
    Ok(())
}
