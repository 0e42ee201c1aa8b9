//! Message in → answer out over loopback DDS (issue #20 "Must show"): a client sends
//! `/motion/command`s the node must refuse (unknown kind) and times the ABORTED
//! `/motion/status` that answers each, waiting on a `cowork_ros::WaitSet` (no polling on
//! either side). The node runs on wall time without a simulator: the refusal is the ROS side's
//! own path (DDS input thread → queue → `serve` → publish), no control step involved.
//!
//! `cargo test -p ds_controller --release --test latency_over_dds -- --nocapture` prints the
//! median and p99.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cowork_msgs::msg::{MotionCommand, MotionStatus};
use cowork_msgs::topics;
use cowork_robot::RobotModel;
use cowork_ros::{NodeConfig, RosNode, RunOptions, WaitSet};
use ds_controller::Params;

// A bench, not a CI test (timings on a shared 2-core machine are noise): run it with
// `cargo test --release -p ds_controller --test latency_over_dds -- --ignored --nocapture`.
#[test]
#[ignore = "latency bench; run with --ignored --nocapture"]
fn a_refused_command_is_answered_within_milliseconds() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let model = RobotModel::from_urdf_file(root.join("config/robot/lwr4plus.urdf")).expect("URDF");
    let domain = cowork_ros::domain::test_domain("ds_controller latency test");
    let config = NodeConfig { domain_id: Some(domain), ..Default::default() };
    let stop = Arc::new(AtomicBool::new(false));
    let options = RunOptions { duration_s: Some(120.0), stop: Some(Arc::clone(&stop)) };
    let node = RosNode::new("ds_controller", &config).expect("node");
    let controller = std::thread::spawn(move || ds_controller::run(node, model, &Params::default(), &options));

    let mut client = RosNode::new("latency_client", &config).expect("client");
    let commands = client.advertise(&topics::MOTION_COMMAND).expect("pub");
    let mut statuses = client.subscribe(&topics::MOTION_STATUS).expect("sub");
    let mut waits = WaitSet::new().expect("wait set");
    waits.add(&mut statuses).expect("wait on statuses");
    let deadline = Instant::now() + Duration::from_secs(20);
    while !(commands.subscription_count(&client) > 0 && statuses.publisher_count(&client) > 0) {
        assert!(Instant::now() < deadline, "ds_controller not discovered within 20 s");
        std::thread::sleep(Duration::from_millis(10));
    }
    // The node's first statuses (waiting for /joint_states) are not answers.
    std::thread::sleep(Duration::from_millis(500));
    while statuses.take().is_some() {}

    let n = 200u32;
    let mut latencies = Vec::new();
    for id in 1..=n {
        let sent = Instant::now();
        commands.publish(MotionCommand { id, kind: 99, ..Default::default() }).expect("publish");
        let give_up = sent + Duration::from_secs(2);
        'answer: while Instant::now() < give_up {
            waits.wait(Duration::from_millis(50));
            while let Some(s) = statuses.take() {
                if s.command_id == id && s.state == MotionStatus::STATE_ABORTED {
                    latencies.push(sent.elapsed().as_secs_f64() * 1e3);
                    break 'answer;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    stop.store(true, Ordering::SeqCst);
    controller.join().expect("controller thread").expect("ds_controller run");
    assert_eq!(latencies.len(), n as usize, "commands answered");
    latencies.sort_by(f64::total_cmp);
    let pct = |p: f64| latencies[((latencies.len() - 1) as f64 * p).round() as usize];
    eprintln!(
        "/motion/command (refused) -> ABORTED /motion/status over loopback DDS, {n} commands: median {:.3} ms, p99 {:.3} ms, max {:.3} ms",
        pct(0.5),
        pct(0.99),
        latencies[latencies.len() - 1]
    );
    assert!(pct(0.5) < 20.0, "median {} ms", pct(0.5));
}
