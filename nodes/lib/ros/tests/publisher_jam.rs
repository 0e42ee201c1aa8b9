//! A frozen reliable reader (its process SIGSTOPped, as a stalled `ros2 topic echo` or a node
//! under a debugger) must never block a publishing node: `Publisher::publish` returns at once,
//! dropping and counting what the reader's window cannot take. Measured: the slowest
//! `publish` call over 2 s at 1 kHz with the reader frozen, the samples dropped, and how many
//! a healthy reliable reader in a third process still received meanwhile (see
//! tests/reliability/README.md for the jam seen in the graph).

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{NodeConfig, RosNode, qos};

const ROLE: &str = "COWORK_JAM_TEST_ROLE";
const TOPIC: &str = "/jam_test";

fn domain() -> u16 {
    cowork_ros::domain::test_domain("cowork_ros publisher jam test")
}

/// Child: a reliable reader that reports `READY`, then counts for `secs` s and prints `GOT n`.
#[test]
#[ignore = "run by the test below as a child process"]
fn reader_child() {
    let Ok(secs) = std::env::var(ROLE) else { return };
    let secs: u64 = secs.parse().expect("seconds");
    let d: u16 = std::env::var("ROS_DOMAIN_ID").expect("domain").parse().expect("number");
    let mut node = RosNode::new("jam_reader", &NodeConfig { domain_id: Some(d), ..Default::default() }).expect("node");
    let sub = node.subscription::<RosString>(TOPIC, &qos::reliable()).expect("subscription");
    println!("READY");
    let end = Instant::now() + Duration::from_secs(secs);
    let mut got = 0u64;
    while Instant::now() < end {
        if sub.recv_timeout(Duration::from_millis(20)).is_some() {
            got += 1;
        }
    }
    println!("GOT {got}");
}

fn spawn_reader(d: u16, secs: u64) -> std::process::Child {
    Command::new(std::env::current_exe().expect("test binary"))
        .args(["reader_child", "--exact", "--ignored", "--nocapture", "--test-threads=1"])
        .env(ROLE, secs.to_string())
        .env("ROS_DOMAIN_ID", d.to_string())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("reader child")
}

#[test]
fn a_frozen_reliable_reader_never_blocks_the_writer() {
    let d = domain();
    let mut frozen = spawn_reader(d, 30);
    let healthy = spawn_reader(d, 9);
    let mut node = RosNode::new("jam_writer", &NodeConfig { domain_id: Some(d), ..Default::default() }).expect("node");
    let publisher = node.publisher::<RosString>(TOPIC, &qos::reliable()).expect("publisher");
    let t0 = Instant::now();
    while publisher.subscription_count(&node) < 2 {
        assert!(t0.elapsed() < Duration::from_secs(20), "readers never matched");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    // Warm: both readers acknowledge.
    for i in 0..200 {
        publisher.publish(RosString { data: format!("warm {i}") }).expect("publish");
        std::thread::sleep(Duration::from_millis(1));
    }
    let stop = Command::new("kill").args(["-STOP", &frozen.id().to_string()]).status().expect("kill -STOP");
    assert!(stop.success());
    let (mut slowest, mut sent) = (Duration::ZERO, 0u64);
    let dropped_before = publisher.dropped();
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(2) {
        let t = Instant::now();
        publisher.publish(RosString { data: format!("m {sent}") }).expect("publish never fails on a slow reader");
        slowest = slowest.max(t.elapsed());
        sent += 1;
        std::thread::sleep(Duration::from_millis(1));
    }
    let dropped = publisher.dropped() - dropped_before;
    let _ = Command::new("kill").args(["-KILL", &frozen.id().to_string()]).status();
    let _ = frozen.wait();
    let out = healthy.wait_with_output().expect("healthy reader");
    let got: u64 = String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("GOT ").map(|n| n.trim().parse().expect("count")))
        .expect("healthy reader's count");
    eprintln!(
        "frozen reliable reader: {sent} publishes in 2 s, slowest {:.3} ms, {dropped} dropped; healthy reliable reader got {got} messages in all (200 warm-up + {sent})",
        slowest.as_secs_f64() * 1e3
    );
    assert!(sent > 500, "the writer loop was held back: {sent} publishes in 2 s");
    assert!(slowest < Duration::from_millis(50), "a publish blocked for {slowest:?}");
    // Whatever the frozen reader does to the others (RustDDS's window: figures printed above),
    // a sample is either delivered to the healthy reader or counted as dropped.
    assert!(got + dropped >= sent, "{sent} sent, {got} received, {dropped} counted as dropped");
}
