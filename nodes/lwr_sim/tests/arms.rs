//! A scene with named arms (config/scenes/pizza.yaml): per-arm inputs and outputs, each arm's
//! messages in its own base frame, the arm bases on /tf_static, both arms in the depth image.

use cowork_msgs::geometry_msgs::{Vector3, Wrench as RosWrench, WrenchStamped};
use cowork_msgs::std_msgs::{Float64MultiArray, Header, String as RosString};
use cowork_robot::RobotModel;
use cowork_sim::{Scene, Simulator};
use lwr_sim::depth::{DepthCamera, DepthConfig, DepthSnapshot, People};
use lwr_sim::{Input, LwrSim, LwrSimConfig, Output};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn pizza() -> LwrSim {
    let config: LwrSimConfig = cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").unwrap();
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).unwrap();
    let scene = Scene::from_file(&root().join("config/scenes/pizza.yaml")).unwrap();
    LwrSim::new(Simulator::new(model, scene, config.simulation.clone()).unwrap(), config)
}

fn iso(p: &cowork_msgs::geometry_msgs::Pose) -> Isometry3<f64> {
    let o = &p.orientation;
    Isometry3::from_parts(
        Translation3::new(p.position.x, p.position.y, p.position.z),
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(o.w, o.x, o.y, o.z)),
    )
}

#[test]
fn each_arm_has_its_namespace_and_its_own_outputs() {
    let mut n = pizza();
    assert_eq!((n.namespace(0), n.namespace(1)), ("/left".to_owned(), "/right".to_owned()));
    let right_before = n.joint_states(1).position;
    n.on_input(&Input::VelocityCommand(0, Float64MultiArray { data: vec![0.0, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0], ..Default::default() }));
    let mut out = Vec::new();
    for _ in 0..50 {
        n.on_step(&mut out);
    }
    let per_arm = |arm: usize| out.iter().filter(|o| matches!(o, Output::JointStates(a, _) if *a == arm)).count();
    assert_eq!((per_arm(0), per_arm(1)), (50, 50), "every step publishes both arms' joint states");
    let left = n.joint_states(0);
    assert_eq!(left.name[0], "lwr_joint_1", "joint names are not prefixed: the namespace tells the arms apart");
    assert!(left.velocity[1] > 0.19);
    assert_eq!(n.joint_states(1).position, right_before, "the right arm did not move");
    // A bad command on one arm is refused naming that arm's topic.
    match n.on_input(&Input::VelocityCommand(1, Float64MultiArray { data: vec![1.0; 3], ..Default::default() })) {
        Some(Output::Warning(w)) => assert!(w.message.contains("/right/lwr/joint_velocity_command"), "{}", w.message),
        other => panic!("{other:?}"),
    }
}

#[test]
fn each_arms_world_is_in_its_base_frame_and_the_bases_are_on_tf_static() {
    let n = pizza();
    let statics = n.tf_static();
    let base = |name: &str| {
        let t = statics.transforms.iter().find(|t| t.child_frame_id == name).unwrap_or_else(|| panic!("{name} on /tf_static"));
        assert_eq!(t.header.frame_id, "world");
        let (p, q) = (&t.transform.translation, &t.transform.rotation);
        Isometry3::from_parts(Translation3::new(p.x, p.y, p.z), UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z)))
    };
    assert!(statics.transforms.iter().any(|t| t.child_frame_id == "camera_depth_optical_frame" && t.header.frame_id == "world"));
    let dynamic = n.tf();
    assert!(dynamic.transforms.iter().all(|t| t.child_frame_id != "left/lwr_base_link"), "the bases are static");
    assert!(dynamic.transforms.iter().any(|t| t.child_frame_id == "right/lwr_link_1" && t.header.frame_id == "right/lwr_base_link"));
    for (arm, name) in [(0, "left"), (1, "right")] {
        let w = n.world(arm);
        assert_eq!(w.header.frame_id, format!("{name}/lwr_base_link"));
        let b = base(&format!("{name}/lwr_base_link"));
        let pizza = w.objects.iter().find(|o| o.name == "pizza").unwrap();
        // Base frame → world gives the scene's pizza position.
        let world = b * iso(&pizza.pose);
        assert!((world.translation.vector - nalgebra::Vector3::new(0.45, 0.0, 0.01)).norm() < 1e-9, "{name}: {world}");
        let tool = b * iso(&w.tool_pose);
        let expected = n.simulator().world_tool_pose(arm);
        assert!((tool.translation.vector - expected.translation.vector).norm() < 1e-9);
    }
    let description = n.robot_description(1).unwrap().data;
    assert!(description.contains("<link name=\"right/lwr_link_3\"") && description.contains("link=\"right/lwr_link_2\""));
    assert!(!description.contains("\"lwr_link_3\""));
}

#[test]
fn grippers_and_pushes_go_to_the_arm_they_were_sent_to() {
    let mut n = pizza();
    match n.on_input(&Input::GripperCommand(1, RosString { data: "close".into() })) {
        Some(Output::Gripper { arm: 1, closed: true, object: None }) => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(n.world(1).gripper_state, cowork_msgs::msg::WorldState::GRIPPER_CLOSED);
    assert_eq!(n.world(0).gripper_state, cowork_msgs::msg::WorldState::GRIPPER_OPEN);
    // A push named by the arm's tf frame or by the bare link name moves that arm only.
    let q_right = n.joint_states(1).position;
    for frame in ["left/lwr_link_7", "lwr_link_7"] {
        let push = WrenchStamped {
            header: Header { frame_id: frame.into(), ..Default::default() },
            wrench: RosWrench { force: Vector3 { x: 0.0, y: 0.0, z: 20.0 }, torque: Vector3::default() },
        };
        assert!(n.on_input(&Input::Wrench(0, push)).is_none(), "{frame} accepted");
    }
    let q_left = n.joint_states(0).position;
    for _ in 0..50 {
        n.step();
    }
    assert_ne!(n.joint_states(0).position, q_left, "the left arm yields to the push");
    assert_eq!(n.joint_states(1).position, q_right);
    let bad = WrenchStamped { header: Header { frame_id: "right/lwr_link_7".into(), ..Default::default() }, ..Default::default() };
    match n.on_input(&Input::Wrench(0, bad)) {
        Some(Output::Warning(w)) => assert!(w.message.contains("/left/external_wrench") && w.message.contains("unknown frame")),
        other => panic!("the other arm's frame on the left arm's topic: {other:?}"),
    }
}

#[test]
fn the_depth_camera_sees_both_arms() {
    let n = pizza();
    let config = DepthConfig { noise: false, floor: false, ..Default::default() };
    let mut camera = DepthCamera::new(n.simulator(), &config).unwrap();
    let mut snap = DepthSnapshot::default();
    snap.capture(n.simulator(), &People::new(0.0, 1.0));
    assert_eq!(snap.arms.len(), 2);
    let robot_pixels = |camera: &mut DepthCamera, snap: &DepthSnapshot| {
        let (mut image, mut info) = Default::default();
        camera.render(snap, &mut image, &mut info).unwrap();
        camera.renderer().labels().iter().filter(|l| l.is_robot()).count()
    };
    let both = robot_pixels(&mut camera, &snap);
    let left_only = {
        let mut one = snap.clone();
        one.arms.truncate(1);
        robot_pixels(&mut camera, &one)
    };
    assert!(left_only > 2000, "the left arm is in view ({left_only} px)");
    assert!(both > left_only + 2000, "the right arm adds its pixels ({both} vs {left_only} px)");
}

fn follow(stamp_ns: i64, names: Vec<String>, position: Vec<f64>) -> cowork_msgs::sensor_msgs::JointState {
    cowork_msgs::sensor_msgs::JointState {
        header: Header { stamp: cowork_msgs::builtin_interfaces::Time::from_nanos(stamp_ns), frame_id: String::new() },
        name: names,
        position,
        ..Default::default()
    }
}

#[test]
fn an_arm_follows_its_retargeted_joints_at_their_stamps_and_refuses_bad_ones() {
    let mut n = pizza();
    n.follow_wrench_stamps();
    let names = n.joint_states(1).name.clone();
    let start = n.joint_states(1).position;
    let left_start = n.joint_states(0).position;
    let mut target = start.clone();
    target[1] += 0.2;
    // Stamped 0.5 s ahead: queued, the arm keeps still until then; the clock holds at the newest stamp.
    assert!(n.on_input(&Input::FollowJoints(1, follow(500_000_000, names.clone(), target.clone()))).is_none());
    let mut out = Vec::new();
    while !n.waiting_for_wrench() {
        n.on_step(&mut out);
        if n.time_s() < 0.499 {
            assert_eq!(n.joint_states(1).position, start, "moved before the stamp at {} s", n.time_s());
        }
    }
    assert!((n.time_s() - 0.5).abs() < 1e-9, "held at the newest stamp, not {} s", n.time_s());
    // Refreshed every 8 ms (a 120 Hz suit) for 1 s: the arm reaches the target.
    for k in 1..=125 {
        n.on_input(&Input::FollowJoints(1, follow(500_000_000 + k * 8_000_000, names.clone(), target.clone())));
        while !n.waiting_for_wrench() {
            n.on_step(&mut out);
        }
    }
    let reached = n.joint_states(1).position;
    assert!((reached[1] - target[1]).abs() < 1e-3, "{reached:?} vs {target:?}");
    assert_eq!(n.joint_states(0).position, left_start, "the other arm did not move");
    // Names in another order, a target outside the limits: refused naming the arm's topic.
    let mut shuffled = names.clone();
    shuffled.swap(0, 1);
    let stamp = (n.time_s() * 1e9) as i64;
    for (msg, field) in [
        (follow(stamp, shuffled, target.clone()), "/right/lwr/follow_joints:name"),
        (follow(stamp, names.clone(), vec![0.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0]), "/right/lwr/follow_joints:position"),
        (follow(stamp, Vec::new(), vec![0.0; 4]), "/right/lwr/follow_joints:position"),
    ] {
        match n.on_input(&Input::FollowJoints(1, msg)) {
            Some(Output::Warning(w)) => assert_eq!(w.kind, field, "{}", w.message),
            other => panic!("{other:?}"),
        }
    }
}
