//! The node's message handling, driven step by step without a network.

use cowork_msgs::geometry_msgs::{Vector3, Wrench as RosWrench, WrenchStamped};
use cowork_msgs::std_msgs::{Float64MultiArray, Header, String as RosString};
use cowork_robot::RobotModel;
use cowork_sim::{Scene, Simulator};
use lwr_sim::{LwrSim, LwrSimConfig};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn config() -> LwrSimConfig {
    cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("bundled parameters load")
}

fn node() -> LwrSim {
    let config = config();
    config.validate("lwr_sim.yaml").unwrap();
    let model = RobotModel::from_urdf_file(&root().join("config/robot/lwr4plus.urdf")).unwrap();
    let scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).unwrap();
    LwrSim::new(Simulator::new(model, scene, config.simulation.clone()).unwrap(), config)
}

#[test]
fn topics_are_due_at_their_rates_and_stamped_with_sim_time() {
    let mut n = node();
    let mut clock = 0;
    let mut joints = 0;
    let mut tf = 0;
    for _ in 0..1000 {
        let due = n.step();
        clock += due.clock as u32;
        joints += due.joint_states as u32;
        tf += due.tf as u32;
    }
    assert_eq!((clock, joints, tf), (1000, 1000, 50));
    let c = n.clock();
    assert_eq!((c.clock.sec, c.clock.nanosec), (1, 0));
    let js = n.joint_states(0);
    assert_eq!(js.header.stamp, c.clock);
    assert_eq!(js.name.len(), 7);
}

#[test]
fn tf_is_the_link_tree_plus_objects_and_the_camera_is_static() {
    let mut n = node();
    // Move every joint so a wrong parent or an inverted transform shows.
    n.on_velocity_command(0, &Float64MultiArray { data: vec![0.3, -0.2, 0.4, 0.3, -0.5, 0.2, 0.6], ..Default::default() });
    for _ in 0..200 {
        n.step();
    }
    let tf = n.tf();
    let edge = |child: &str| tf.transforms.iter().find(|t| t.child_frame_id == child);
    for want in ["lwr_link_1", "lwr_link_7", "bottle", "cup", "coffee"] {
        assert!(edge(want).is_some(), "{want} missing from /tf");
    }
    // Every link of the URDF reaches the base through /tf, parent by parent, and the composed
    // transform is the link's pose in the base frame.
    let model = n.simulator().model().clone();
    let poses = *n.simulator().link_poses();
    let iso = |t: &cowork_msgs::geometry_msgs::TransformStamped| {
        let (p, q) = (&t.transform.translation, &t.transform.rotation);
        nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(p.x, p.y, p.z),
            nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z)),
        )
    };
    let names = model.link_names();
    for (i, name) in names.iter().enumerate().skip(1) {
        let t = edge(name).unwrap_or_else(|| panic!("{name} has no transform"));
        assert_eq!(t.header.frame_id, names[i - 1], "{name}'s parent is the previous link of the chain");
        let (mut pose, mut frame) = (iso(t), t.header.frame_id.clone());
        for _ in 0..names.len() {
            if frame == "lwr_base_link" {
                break;
            }
            let up = edge(&frame).unwrap_or_else(|| panic!("{frame} does not reach the base"));
            pose = iso(up) * pose;
            frame = up.header.frame_id.clone();
        }
        assert_eq!(frame, "lwr_base_link", "{name} reaches the base");
        let err = (pose.translation.vector - poses.get(i).translation.vector).norm();
        let ang = pose.rotation.angle_to(&poses.get(i).rotation);
        assert!(err < 1e-9 && ang < 1e-9, "{name}: composed /tf is off by {err} m, {ang} rad");
    }
    for object in ["bottle", "cup", "coffee"] {
        assert_eq!(edge(object).map(|t| t.header.frame_id.as_str()), Some("lwr_base_link"));
    }
    let st = n.tf_static();
    assert_eq!(st.transforms[0].child_frame_id, "camera_depth_optical_frame");
    let q = &st.transforms[0].transform.rotation;
    assert!(((q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) - 1.0).abs() < 1e-12);
}

#[test]
fn bad_messages_are_ignored_and_the_robot_is_held() {
    let mut n = node();
    let q0 = *n.simulator().joint_positions();
    n.on_velocity_command(0, &Float64MultiArray { data: vec![0.5; 7], ..Default::default() });
    n.on_velocity_command(0, &Float64MultiArray { data: vec![f64::NAN; 7], ..Default::default() });
    n.on_gripper_command(0, &RosString { data: "grab it".into() });
    n.on_wrench(0, &WrenchStamped {
        header: Header { frame_id: "no_such_frame".into(), ..Default::default() },
        wrench: RosWrench { force: Vector3 { x: 50.0, y: 0.0, z: 0.0 }, ..Default::default() },
    });
    n.on_wrench(0, &WrenchStamped {
        wrench: RosWrench { force: Vector3 { x: f64::INFINITY, y: 0.0, z: 0.0 }, ..Default::default() },
        ..Default::default()
    });
    for _ in 0..100 {
        n.step();
    }
    assert_eq!(*n.simulator().joint_positions(), q0, "nothing moved the robot");
}

#[test]
fn wrench_in_a_link_frame_is_rotated_into_the_base_frame() {
    // Push the tool along its own z axis (pointing down at the start pose): the tool moves down.
    let mut n = node();
    let p0 = n.simulator().tool_pose().translation.vector;
    let tool_link = n.simulator().model().link_names()[n.simulator().model().tip_link()].clone();
    for _ in 0..100 {
        n.on_wrench(0, &WrenchStamped {
            header: Header { frame_id: tool_link.clone(), ..Default::default() },
            wrench: RosWrench { force: Vector3 { x: 0.0, y: 0.0, z: 10.0 }, ..Default::default() },
        });
        n.step();
    }
    let dp = n.simulator().tool_pose().translation.vector - p0;
    let axis = n.simulator().tool_pose().rotation * nalgebra::Vector3::z();
    assert!(dp.dot(&axis) > 0.004, "moved {dp} along the tool axis {axis}");
}

#[test]
fn parameter_errors_name_the_file_and_key() {
    let text = "lwr_sim:\n  ros__parameters:\n    simulation:\n      step_s: .nan\n";
    let cfg: LwrSimConfig = cowork_ros::params::from_str(text, "lwr_sim", "bad.yaml").unwrap();
    let e = cfg.validate("bad.yaml").unwrap_err().to_string();
    assert!(e.contains("bad.yaml") && e.contains("step_s"), "{e}");
    let text = "lwr_sim:\n  ros__parameters:\n    publish:\n      tf_hz: 5\n";
    let e = cowork_ros::params::from_str::<LwrSimConfig>(text, "lwr_sim", "bad.yaml").unwrap_err().to_string();
    assert!(e.contains("bad.yaml") && e.contains("tf_hz"), "{e}");
}

#[test]
fn world_reports_what_the_simulator_holds_and_where_objects_are() {
    let mut n = node();
    let mut world = 0;
    for _ in 0..1000 {
        world += n.step().world as u32;
    }
    assert_eq!(world, 100, "/lwr/world at 100 Hz of simulated time");
    let w = n.world(0);
    assert_eq!(w.header.frame_id, "lwr_base_link");
    assert_eq!((w.header.stamp.sec, w.header.stamp.nanosec), (1, 0));
    assert_eq!(w.gripper_state, cowork_msgs::msg::WorldState::GRIPPER_OPEN);
    assert!(w.held_object.is_empty());
    let names: Vec<&str> = w.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["bottle", "cup", "coffee", "sugar", "spoon", "tea"]);
    let bottle = &w.objects[0];
    assert!((bottle.pose.position.y - 0.35).abs() < 1e-12 && bottle.tilt.abs() < 1e-9 && !bottle.held);
    // The tool point's distance to the bottle's surface, as the simulator measures it.
    let sim = n.simulator();
    let tool = nalgebra::Point3::from(sim.tool_pose().translation.vector);
    assert!((bottle.tool_distance - sim.objects()[0].distance_to(&tool)).abs() < 1e-12);
    assert!((w.tool_pose.position.x - tool.x).abs() < 1e-12);
    // Closing the gripper far from everything holds nothing: the state says closed, no object.
    n.on_gripper_command(0, &RosString { data: "close".into() });
    let w = n.world(0);
    assert_eq!(w.gripper_state, cowork_msgs::msg::WorldState::GRIPPER_CLOSED);
    assert!(w.held_object.is_empty() && w.objects.iter().all(|o| !o.held));
}

#[test]
fn following_wrench_stamps_applies_each_at_its_time_and_waits_for_the_teacher() {
    let push = |t: f64, z: f64| WrenchStamped {
        header: Header { stamp: cowork_msgs::builtin_interfaces::Time::from_secs_f64(t), frame_id: String::new() },
        wrench: RosWrench { force: Vector3 { x: 0.0, y: 0.0, z }, ..Default::default() },
    };
    let mut n = node();
    assert!(!n.waiting_for_wrench(), "off by default");
    n.follow_wrench_stamps();
    assert!(!n.waiting_for_wrench(), "free until the first wrench");
    let z0 = n.simulator().tool_pose().translation.z;
    // A push up stamped 0.05 s ahead waits: nothing moves before its time.
    n.on_wrench(0, &push(0.05, 20.0));
    n.on_wrench(0, &push(0.10, 20.0));
    for _ in 0..49 {
        n.step();
    }
    assert!((n.simulator().tool_pose().translation.z - z0).abs() < 1e-9, "no force before 0.05 s");
    while !n.waiting_for_wrench() {
        n.step();
    }
    // The clock stops at the newest stamp (0.10 s) until the teacher sends more.
    assert_eq!(n.simulator().time_ns(), 100_000_000);
    assert!(n.simulator().tool_pose().translation.z > z0 + 1e-4, "pushed up from 0.05 s");
    n.on_wrench(0, &push(0.2, 0.0));
    assert!(!n.waiting_for_wrench());
}

#[test]
fn robot_description_is_the_urdf_with_meshes_a_viewer_can_open() {
    let n = node();
    let urdf = n.robot_description(0).expect("robot description").data;
    assert!(urdf.contains("<robot") && urdf.contains("lwr_link_7"), "the URDF text");
    let meshes: Vec<&str> = urdf.split("filename=\"").skip(1).filter_map(|t| t.split('"').next()).collect();
    assert!(meshes.len() >= 8, "{meshes:?}");
    for uri in meshes {
        let path = uri.strip_prefix("file://").unwrap_or_else(|| panic!("{uri} is not a file:// URI"));
        assert!(std::path::Path::new(path).is_file(), "{uri} does not exist");
    }
}
