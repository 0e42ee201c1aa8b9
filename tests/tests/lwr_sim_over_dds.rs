//! lwr_sim running as a node (its real `run` loop over DDS on loopback), driven by a second
//! node in the same process: commands in, joint states out, bad commands rejected.

use std::time::{Duration, Instant};

use cowork_graph_tests::{private_domain, repo_root};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Float64MultiArray;
use cowork_robot::RobotModel;
use cowork_ros::{NodeConfig, RosNode, qos};
use cowork_sim::{Scene, Simulator};
use lwr_sim::{LwrSim, LwrSimConfig, Pacing};

fn start_sim(domain: u16, seconds: f64) -> std::thread::JoinHandle<anyhow::Result<()>> {
    let root = repo_root();
    let config: LwrSimConfig = cowork_ros::params::load(&root.join("config/lwr_sim.yaml"), "lwr_sim").unwrap();
    let model = RobotModel::from_urdf_file(&root.join("config/robot/lwr4plus.urdf")).unwrap();
    let scene = Scene::from_file(&root.join("config/scenes/kitchen.yaml")).unwrap();
    let sim = Simulator::new(model, scene, config.simulation.clone()).unwrap();
    let node = RosNode::new("lwr_sim", &NodeConfig { domain_id: Some(domain), ..Default::default() }).unwrap();
    std::thread::spawn(move || lwr_sim::run(node, LwrSim::new(sim, config), Pacing::Rate(1.0), Some(seconds)))
}

fn latest(sub: &cowork_ros::Subscription<JointState>, timeout: Duration) -> Option<JointState> {
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(m) = sub.take_latest() {
            return Some(m);
        }
        if Instant::now() > deadline {
            return None;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn velocity_commands_move_the_joints_and_bad_ones_hold_the_robot() {
    let domain = private_domain();
    let sim = start_sim(domain.id(), 8.0);
    let mut client = RosNode::new("test_client", &NodeConfig { domain_id: Some(domain.id()), ..Default::default() }).unwrap();
    let states = client.subscription::<JointState>("/joint_states", &qos::reliable()).unwrap();
    let commands = client
        .publisher::<Float64MultiArray>("/lwr/joint_velocity_command", &qos::reliable())
        .unwrap();

    let first = latest(&states, Duration::from_secs(10)).expect("joint states arrive over DDS");
    assert_eq!(first.name.len(), 7);
    assert_eq!(first.name[0], "lwr_joint_1");
    let q0 = first.position.clone();

    // 0.25 rad/s on joint 2 for about 0.6 s.
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(600) {
        commands
            .publish(Float64MultiArray { data: vec![0.0, 0.25, 0.0, 0.0, 0.0, 0.0, 0.0], ..Default::default() })
            .unwrap();
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    let moved = latest(&states, Duration::from_secs(2)).unwrap();
    let dq1 = moved.position[1] - q0[1];
    assert!((0.08..0.3).contains(&dq1), "joint 2 moved {dq1} rad");
    assert!(moved.velocity.iter().all(|v| *v == 0.0), "held after the command timed out");

    // A command of the wrong length: rejected, robot held, node alive.
    for _ in 0..10 {
        commands.publish(Float64MultiArray { data: vec![1.0; 6], ..Default::default() }).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(200));
    let after = latest(&states, Duration::from_secs(2)).expect("node still publishing");
    assert_eq!(after.position, moved.position);
    sim.join().unwrap().unwrap();
}
