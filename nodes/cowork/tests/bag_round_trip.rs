//! Round trip over DDS: lwr_sim (in-process, its real `run` loop) plus a depth-image and an
//! unknown-type publisher on one domain → `cowork bag record` → `cowork bag play --rate 1` on a
//! second domain while `cowork bag record` records again, into a rosbag2 directory → the same
//! messages (payload bytes equal) with the same relative timing, counted in its metadata.yaml.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use cowork_bag::BagReader;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::sensor_msgs::Image;
use cowork_msgs::std_msgs::Header;
use cowork_robot::RobotModel;
use cowork_ros::{NodeConfig, RosNode, qos};
use cowork_sim::{Scene, Simulator};
use lwr_sim::{LwrSim, LwrSimConfig, Pacing};

type TestResult = anyhow::Result<()>;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A domain for this test run, away from other tests and a running graph.
fn domain() -> u16 {
    cowork_ros::domain::test_domain("cowork bag round-trip test")
}

fn cowork(domain: u16, args: &[&str]) -> anyhow::Result<Child> {
    Ok(Command::new(env!("CARGO_BIN_EXE_cowork"))
        .args(args)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("RUST_LOG", "warn")
        .spawn()?)
}

fn wait(mut child: Child, what: &str) -> TestResult {
    let status = child.wait()?;
    anyhow::ensure!(status.success(), "{what} failed: {status}");
    Ok(())
}

/// Payloads and log times per topic.
fn read(path: &Path) -> anyhow::Result<BTreeMap<String, Vec<(u64, Vec<u8>, String)>>> {
    let reader = BagReader::open(path)?;
    let mut out: BTreeMap<String, Vec<(u64, Vec<u8>, String)>> = BTreeMap::new();
    for m in reader.messages() {
        let m = m?;
        out.entry(m.topic.to_string()).or_default().push((m.log_time_ns, m.data, m.type_name.to_string()));
    }
    Ok(out)
}

/// Publishes a small depth image at 30 Hz and an unknown-type payload at 10 Hz for `seconds`.
fn extra_publishers(domain: u16, seconds: f64) -> anyhow::Result<std::thread::JoinHandle<anyhow::Result<()>>> {
    let mut node = RosNode::new("test_camera", &NodeConfig { domain_id: Some(domain), ..Default::default() })?;
    let image = node.publisher::<Image>("/camera/depth/image_raw", &qos::reliable())?;
    let thing = node.raw_publisher("/acme/thing", "acme_msgs/msg/Thing", &qos::reliable())?;
    Ok(std::thread::spawn(move || {
        // The node must outlive its publishers: dropping it takes the DDS participant away.
        let _node = node;
        let start = Instant::now();
        let mut k = 0u32;
        while start.elapsed().as_secs_f64() < seconds {
            let data: Vec<u8> = (0..64 * 48 * 2).map(|i| (i as u32 ^ k) as u8).collect();
            image.publish(Image {
                header: Header { stamp: Time::from_nanos(k as i64 * 33_000_000), frame_id: "camera".into() },
                height: 48,
                width: 64,
                encoding: "16UC1".into(),
                is_bigendian: 0,
                step: 128,
                data,
            })?;
            if k % 3 == 0 {
                thing.publish(&[0, 1, 0, 0, k as u8, 0xab, 0xcd, 0xef])?;
            }
            k += 1;
            std::thread::sleep(Duration::from_millis(33));
        }
        Ok(())
    }))
}

#[test]
fn record_play_record_gives_the_same_messages_and_timing() -> TestResult {
    let root = repo_root();
    let dir = tempfile::tempdir()?;
    let first = dir.path().join("first.mcap");
    // The second recording is a rosbag2 directory (`-o NAME` without .mcap).
    let second = dir.path().join("second");
    let (a, b) = (domain(), domain());

    // The graph on domain a: lwr_sim at 1x (joint states at 1 kHz would make a large bag in a
    // debug build; 100 Hz keeps the test light), a camera, an unknown type. lwr_sim's own
    // 640x480 camera is off: its frames are best effort (sensor-data QoS), so a loaded machine
    // may lose some in the first recording, and sharing the topic with the reliable test
    // camera would make the recorder's reader best effort for both; replay of large depth
    // images is measured by `cowork bag bench`.
    let mut config: LwrSimConfig = cowork_ros::params::load(&root.join("config/lwr_sim.yaml"), "lwr_sim")?;
    config.publish.joint_state_rate_hz = 100.0;
    config.publish.clock_rate_hz = 100.0;
    config.depth.enabled = false;
    let model = RobotModel::from_urdf_file(&root.join("config/robot/lwr4plus.urdf"))?;
    let scene = Scene::from_file(&root.join("config/scenes/kitchen.yaml"))?;
    let sim = Simulator::new(model, scene, config.simulation.clone())?;
    let node = RosNode::new("lwr_sim", &NodeConfig { domain_id: Some(a), ..Default::default() })?;
    let lwr = std::thread::spawn(move || lwr_sim::run(node, LwrSim::new(sim, config), Pacing::Rate(1.0), Some(9.0)));
    let extra = extra_publishers(a, 9.0)?;

    let rec = cowork(a, &["bag", "record", "-o", first.to_str().unwrap_or_default(), "--duration", "6", "--discovery-interval", "0.2"])?;
    wait(rec, "first record")?;
    lwr.join().map_err(|_| anyhow::anyhow!("lwr_sim panicked"))??;
    extra.join().map_err(|_| anyhow::anyhow!("publisher panicked"))??;

    let recorded = read(&first)?;
    for t in ["/joint_states", "/tf", "/tf_static", "/camera/depth/image_raw", "/acme/thing"] {
        let n = recorded.get(t).map_or(0, Vec::len);
        assert!(n > 0, "first bag has no {t}: {:?}", recorded.keys().collect::<Vec<_>>());
    }
    assert_eq!(recorded["/acme/thing"][0].2, "acme_msgs/msg/Thing");
    // /clock is lwr_sim's rosgraph_msgs/Clock, not the builtin_interfaces/Time reader every
    // ros2-client node has on /clock.
    if let Some(clock) = recorded.get("/clock") {
        assert_eq!(clock[0].2, "rosgraph_msgs/msg/Clock");
    }

    // Replay on domain b while recording it again.
    let rec = cowork(b, &["bag", "record", "-o", second.to_str().unwrap_or_default(), "--duration", "13", "--discovery-interval", "0.2"])?;
    std::thread::sleep(Duration::from_secs(1));
    let play = cowork(b, &["bag", "play", first.to_str().unwrap_or_default(), "--rate", "1", "--delay", "3", "--quiet"])?;
    wait(play, "play")?;
    wait(rec, "second record")?;
    let replayed = read(&second)?;
    // metadata.yaml names the storage file and counts what is in it, per topic.
    let meta: serde_yaml_ng::Value = serde_yaml_ng::from_str(&std::fs::read_to_string(second.join("metadata.yaml"))?)?;
    let info = &meta["rosbag2_bagfile_information"];
    assert_eq!(info["relative_file_paths"][0].as_str(), Some("second_0.mcap"));
    let listed = info["topics_with_message_count"].as_sequence().cloned().unwrap_or_default();
    assert_eq!(listed.len(), replayed.len(), "topics in metadata.yaml vs in the bag");
    for t in &listed {
        let name = t["topic_metadata"]["name"].as_str().unwrap_or_default();
        let n = replayed.get(name).map_or(0, Vec::len) as u64;
        assert_eq!(t["message_count"].as_u64(), Some(n), "{name}: metadata.yaml count");
        assert_eq!(t["topic_metadata"]["type"].as_str(), replayed.get(name).map(|m| m[0].2.as_str()), "{name}: type");
    }

    // Reliable topics: every message again, bytes equal. /clock is best effort (may drop).
    let mut offsets = Vec::new();
    for topic in ["/joint_states", "/tf", "/tf_static", "/camera/depth/image_raw", "/acme/thing"] {
        let want = &recorded[topic];
        let got = replayed.get(topic).ok_or_else(|| anyhow::anyhow!("replay lacks {topic}"))?;
        assert_eq!(got.len(), want.len(), "{topic}: message count");
        for (i, (w, g)) in want.iter().zip(got).enumerate() {
            assert!(w.1 == g.1, "{topic} message {i}: payload differs");
            assert_eq!(w.2, g.2, "{topic}: type");
            if topic != "/tf_static" {
                offsets.push(g.0 as i64 - w.0 as i64);
            }
        }
    }
    let mut sorted = offsets.clone();
    sorted.sort_unstable();
    let median = sorted[sorted.len() / 2];
    let mut err: Vec<f64> = offsets.iter().map(|o| (o - median).unsigned_abs() as f64 * 1e-6).collect();
    err.sort_by(f64::total_cmp);
    let p50 = err[err.len() / 2];
    let p99 = err[(err.len() * 99 / 100).min(err.len() - 1)];
    println!("timing error of the replay vs the first recording over {} messages: p50 {p50:.3} ms, p99 {p99:.3} ms, max {:.3} ms", err.len(), err[err.len() - 1]);
    assert!(p50 <= 1.0, "median timing error {p50} ms > 1 ms");
    // Two recordings and a replay on a shared 2-core machine: the tail is loose on purpose
    // (a rehearsal on a clean clone, 2026-12-03, load average 2: p99 11.5 ms, max 17.9 ms, with
    // the publisher's own call-start error p99 8.8 ms; the median is the check that matters).
    assert!(p99 <= 20.0, "p99 timing error {p99} ms > 20 ms");
    Ok(())
}
