//! `cowork node list`, `cowork topic info -v` and `cowork topic hz` against a live talker on a
//! private domain: the node is listed, the topic's publisher is attributed to it with its QoS,
//! and the measured rate is the talker's.

use std::process::Command;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{NodeConfig, RosNode, qos};

/// A domain for this test run, away from other tests and a running graph.
fn domain() -> u16 {
    cowork_ros::domain::test_domain("cowork introspection test")
}

fn cowork(domain: u16, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_cowork"))
        .args(args)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("RUST_LOG", "warn")
        .output()
        .expect("run cowork");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "cowork {args:?} failed: {}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    stdout
}

#[test]
fn node_list_topic_info_and_hz_see_a_talker() {
    let domain = domain();
    let stop = Arc::new(AtomicBool::new(false));
    let stop_talker = Arc::clone(&stop);
    let talker = std::thread::spawn(move || {
        let mut node = RosNode::new("talker", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("node");
        let chatter = node.publisher::<RosString>("/chatter", &qos::reliable_depth(7)).expect("publisher");
        // 10 Hz on an absolute schedule, so a late tick does not lower the rate.
        let mut next = Instant::now();
        while !stop_talker.load(Ordering::Relaxed) {
            chatter.publish(RosString { data: "hello".into() }).expect("publish");
            next += Duration::from_millis(100);
            if let Some(d) = next.checked_duration_since(Instant::now()) {
                std::thread::sleep(d);
            }
        }
    });

    let nodes = cowork(domain, &["node", "list", "--wait", "3"]);
    assert!(nodes.lines().any(|l| l == "/talker"), "node list: {nodes:?}");
    assert!(!nodes.contains("cowork_nodes_"), "the CLI's own node is not listed: {nodes:?}");

    let info = cowork(domain, &["topic", "info", "/chatter", "-v", "--wait", "3"]);
    assert!(info.contains("Type: std_msgs/msg/String"), "{info}");
    assert!(info.contains("Publisher count: 1"), "{info}");
    assert!(info.contains("Node name: /talker"), "the publisher is attributed to its node: {info}");
    assert!(info.contains("Reliability: RELIABLE") && info.contains("Durability: VOLATILE"), "{info}");

    let hz = cowork(domain, &["topic", "hz", "/chatter", "--duration", "3.5", "--wait", "3"]);
    stop.store(true, Ordering::Relaxed);
    talker.join().expect("talker");
    let rates: Vec<f64> = hz
        .lines()
        .filter_map(|l| l.strip_prefix("average rate: "))
        .filter_map(|r| r.trim().parse().ok())
        .collect();
    let last = rates.last().copied().unwrap_or_else(|| panic!("no rate printed: {hz}"));
    // Generous: a loaded 2-core machine delays single ticks, but not the schedule.
    assert!((7.0..13.0).contains(&last), "rate {last} Hz, talker 10 Hz: {hz}");
}
