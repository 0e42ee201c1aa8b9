//! The node's handlers on a mock clock (no network): parameters, the corrupt-database path,
//! message conversions.

use cowork_manager::Stamp;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{ActionCommand, MotionCommand, MotionStatus, RobotStream, WorldObject, WorldState};
use cowork_msgs::std_msgs::{Header, String as RosString};
use cowork_msgs::builtin_interfaces::Time;
use robot_manager::{Outbox, Params, RobotManagerNode};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn params(dir: &std::path::Path) -> Params {
    let mut p: Params = cowork_ros::params::load(&root().join("config/robot_manager.yaml"), "robot_manager").expect("bundled parameters");
    p.validate("robot_manager.yaml").expect("valid");
    assert_eq!(p.manager, cowork_manager::ManagerConfig::default(), "the file states the defaults");
    p.database_dir = dir.display().to_string();
    p
}

fn pose(x: f64, y: f64, z: f64) -> Pose {
    Pose { position: Point { x, y, z }, orientation: Quaternion { x: 1.0, y: 0.0, z: 0.0, w: 0.0 } }
}

fn world(t: f64) -> WorldState {
    WorldState {
        header: Header { stamp: Time::from_secs_f64(t), frame_id: "lwr_base_link".into() },
        gripper_state: WorldState::GRIPPER_OPEN,
        held_object: String::new(),
        tool_pose: pose(0.3, 0.0, 0.5),
        objects: vec![
            WorldObject { name: "bottle".into(), pose: pose(0.45, 0.35, 0.11), tool_distance: 0.3, ..Default::default() },
            WorldObject { name: "sugar".into(), pose: pose(0.3, -0.45, 0.05), tool_distance: 0.5, ..Default::default() },
        ],
    }
}

fn at(t: f64) -> Stamp {
    Stamp { t, unix_s: 1 }
}

#[test]
fn messages_in_and_out() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut n, problem) = RobotManagerNode::new(params(dir.path()), 1);
    assert!(problem.is_none());
    let mut out = Outbox::default();
    n.on_world(&world(1.0), at(1.0), &mut out);
    // Task names on /object_stream; unlisted scene objects (sugar) left out.
    let names: Vec<&str> = out.object_stream[0].objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["water"]);
    assert_eq!(out.robot_stream[0].mode, RobotStream::MODE_EXECUTE);
    out.clear();
    n.on_action(&ActionCommand { id: 4, label: "noa9(water)".into(), ..Default::default() }, at(1.01), &mut out);
    assert_eq!(out.motion[0].kind, MotionCommand::KIND_HOLD, "robot held");
    let ev = &out.robot_stream[0].events[0];
    assert!(ev.failed && !ev.done && ev.command_id == 4 && ev.reason.contains("no primitive `noa9`"), "{ev:?}");
    out.clear();
    n.on_motion_status(&MotionStatus { command_id: 77, state: 9, ..Default::default() }, at(1.02), &mut out);
    n.on_motion_status(&MotionStatus { command_id: 77, state: MotionStatus::STATE_CONVERGED, ..Default::default() }, at(1.02), &mut out);
    assert!(n.warnings() >= 2);
    n.on_speech(&RosString { data: "teach".into() }, at(1.03), &mut out);
    assert_eq!(out.robot_stream.last().map(|r| r.mode), Some(RobotStream::MODE_TEACH));
    n.on_speech(&RosString { data: "gripper close".into() }, at(1.04), &mut out);
    assert_eq!(out.gripper[0].data, "close");
}

#[test]
fn a_corrupt_database_is_moved_aside_and_the_node_starts_empty() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("lwr.primitives.json");
    std::fs::write(&file, b"{\"format\": 1, \"robot\": \"lwr\", \"next_ind").expect("write");
    let (n, problem) = RobotManagerNode::new(params(dir.path()), 42);
    let problem = problem.expect("reported");
    assert!(problem.contains("lwr.primitives.json") && problem.contains("line 1"), "{problem}");
    assert!(n.manager().database().primitives.is_empty());
    assert!(dir.path().join("lwr.primitives.json.corrupt-42").exists(), "kept for inspection");
}

#[test]
fn every_world_report_gives_the_manipulated_objects_with_its_stamp() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut n, _) = RobotManagerNode::new(params(dir.path()), 1);
    let mut out = Outbox::default();
    n.on_world(&world(1.0), at(1.02), &mut out);
    let m = &out.manipulated[0];
    assert!(m.objects.is_empty(), "nothing held, nothing approached: {m:?}");
    assert_eq!(m.header.stamp, Time::from_secs_f64(1.0), "stamped with the pose's time, not the node's");
    assert_eq!(m.header.frame_id, "lwr_base_link");
    out.clear();
    let mut w = world(1.1);
    w.gripper_state = WorldState::GRIPPER_CLOSED;
    w.held_object = "bottle".into();
    w.objects[0].held = true;
    w.objects[0].pose = pose(0.5, 0.1, 0.3);
    n.on_world(&w, at(1.1), &mut out);
    let m = &out.manipulated[0];
    let names: Vec<&str> = m.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["bottle"], "scene names (fded_distance knows the shapes by them)");
    assert_eq!(m.objects[0].pose, w.objects[0].pose);
    // The same with only `held_object` set (the per-object flag is a convenience).
    out.clear();
    w.objects[0].held = false;
    n.on_world(&w, at(1.2), &mut out);
    assert_eq!(out.manipulated[0].objects.len(), 1);
}
