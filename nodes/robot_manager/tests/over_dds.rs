//! `lwr_sim` + `robot_manager` over DDS on loopback (a private domain), on `/clock` time; a
//! client plays the supervisor and the person: the wiring of every topic in one short trial.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cowork_msgs::msg::{ActionCommand, MotionCommand, MotionStatus, ObjectStream, RobotStream};
use cowork_msgs::std_msgs::String as RosString;
use cowork_robot::RobotModel;
use cowork_ros::{NodeConfig, RosNode, qos};
use cowork_sim::{Scene, Simulator};
use lwr_sim::{LwrSim, LwrSimConfig, Pacing};
use robot_manager::{Params, RobotManagerNode, RunOptions};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn every_topic_is_wired() {
    let domain = cowork_ros::domain::test_domain("robot_manager test");
    let dir = tempfile::tempdir().expect("tempdir");
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let mut sim_config: LwrSimConfig = cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("params");
    sim_config.depth.enabled = false;
    let scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
    let sim = Simulator::new(model, scene, sim_config.simulation.clone()).expect("simulator");
    let sim_node = RosNode::new("lwr_sim", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("node");
    let lwr = LwrSim::new(sim, sim_config);
    let sim = std::thread::spawn(move || lwr_sim::run(sim_node, lwr, Pacing::Rate(1.0), Some(60.0)));

    let mut params: Params = cowork_ros::params::load(&root().join("config/robot_manager.yaml"), "robot_manager").expect("params");
    params.use_sim_time = true;
    params.database_dir = dir.path().display().to_string();
    let (rm, _) = RobotManagerNode::new(params.clone(), 1);
    let rm_node = RosNode::new("robot_manager", &NodeConfig { domain_id: Some(domain), use_sim_time: true, ..Default::default() })
        .expect("node");
    let stop = Arc::new(AtomicBool::new(false));
    let options = RunOptions { duration_s: Some(120.0), stop: Some(Arc::clone(&stop)) };
    let manager = std::thread::spawn(move || robot_manager::run(rm_node, rm, params.tick_rate_hz, &options));

    let mut node = RosNode::new("client", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("client");
    let action = node.publisher::<ActionCommand>("/supervisor/action", &qos::reliable()).expect("pub");
    let speech = node.publisher::<RosString>("/speech_command", &qos::reliable()).expect("pub");
    let status = node.publisher::<MotionStatus>("/motion/status", &qos::reliable_depth(10)).expect("pub");
    let robot = node.subscription::<RobotStream>("/robot_stream", &qos::reliable_depth(100)).expect("sub");
    let objects = node.subscription::<ObjectStream>("/object_stream", &qos::reliable()).expect("sub");
    let motion = node.subscription::<MotionCommand>("/motion/command", &qos::reliable_depth(10)).expect("sub");
    let gripper = node.subscription::<RosString>("/lwr/gripper_command", &qos::reliable()).expect("sub");

    let deadline = Instant::now() + Duration::from_secs(60);
    let wait = |what: &str, f: &mut dyn FnMut() -> bool| {
        while !f() {
            assert!(Instant::now() < deadline, "timed out waiting for {what}");
            std::thread::sleep(Duration::from_millis(5));
        }
    };
    // The world reaches the manager, which reports task names.
    wait("/object_stream", &mut || objects.take().is_some_and(|o| o.objects.iter().any(|o| o.name == "water")));
    wait("subscribers", &mut || {
        action.subscription_count(&node) > 0 && speech.subscription_count(&node) > 0 && status.subscription_count(&node) > 0
    });
    // A label with no primitive: failed event naming it, the arm held.
    action.publish(ActionCommand { id: 5, label: "noa9(water)".into(), ..Default::default() }).expect("publish");
    let mut failed = None;
    wait("failed event", &mut || {
        while let Some(r) = robot.take() {
            if let Some(e) = r.events.iter().find(|e| e.failed) {
                failed = Some(e.clone());
            }
        }
        failed.is_some()
    });
    let e = failed.expect("event");
    assert!(e.command_id == 5 && e.reason.contains("no primitive `noa9`"), "{e:?}");
    wait("hold", &mut || motion.take().is_some_and(|m| m.kind == MotionCommand::KIND_HOLD));
    // A status for a command nobody sent: the node keeps running.
    status.publish(MotionStatus { command_id: 999, state: MotionStatus::STATE_CONVERGED, ..Default::default() }).expect("publish");
    // Gripper: closing far from every object reaches lwr_sim, which reports closed on nothing;
    // the action fails at the gripper timeout with that reason.
    action.publish(ActionCommand { id: 6, label: "gripper(close)".into(), ..Default::default() }).expect("publish");
    wait("gripper command", &mut || gripper.take().is_some_and(|g| g.data == "close"));
    let mut reason = String::new();
    wait("gripper failure", &mut || {
        while let Some(r) = robot.take() {
            if let Some(e) = r.events.iter().find(|e| e.failed && e.command_id == 6) {
                reason.clone_from(&e.reason);
            }
            if r.gripper_state == RobotStream::GRIPPER_CLOSED && !r.held_object.is_empty() {
                panic!("the hand holds {} far from every object", r.held_object);
            }
        }
        !reason.is_empty()
    });
    assert!(reason.contains("closed on nothing"), "{reason}");
    // Teach: the mode flips on /robot_stream.
    speech.publish(RosString { data: "teach".into() }).expect("publish");
    wait("teach mode", &mut || robot.take().is_some_and(|r| r.mode == RobotStream::MODE_TEACH));
    speech.publish(RosString { data: "done".into() }).expect("publish");
    wait("execute mode", &mut || robot.take().is_some_and(|r| r.mode == RobotStream::MODE_EXECUTE));

    stop.store(true, Ordering::SeqCst);
    let rm = manager.join().expect("manager thread").expect("manager ran");
    assert!(rm.warnings() >= 1, "the unknown status id was warned about");
    drop(node);
    // lwr_sim stops at its 60 s of simulated time; the test process ends before that.
    assert!(!sim.is_finished(), "lwr_sim ran for the whole trial");
}
