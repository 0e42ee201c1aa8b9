//! The node's handlers on a mock clock (no network): parameters, the corrupt-database path,
//! message conversions.

use cowork_manager::Stamp;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{ActionCommand, MotionCommand, MotionStatus, RobotStream, WorldObject, WorldState};
use cowork_msgs::sensor_msgs::JointState;
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

/// A world with the tool at `tool` (m) and the bottle and cup where the kitchen has them;
/// `with_cup` false: the cup is not in the scene.
fn world_with(t: f64, tool: [f64; 3], with_cup: bool) -> WorldState {
    let dist = |c: [f64; 3], r: f64| (((tool[0] - c[0]).powi(2) + (tool[1] - c[1]).powi(2) + (tool[2] - c[2]).powi(2)).sqrt() - r).max(0.0);
    let mut w = world(t);
    w.tool_pose = pose(tool[0], tool[1], tool[2]);
    w.objects = vec![WorldObject { name: "bottle".into(), pose: pose(0.45, 0.35, 0.11), tool_distance: dist([0.45, 0.35, 0.11], 0.035), ..Default::default() }];
    if with_cup {
        w.objects.push(WorldObject { name: "cup".into(), pose: pose(0.6, 0.0, 0.05), tool_distance: dist([0.6, 0.0, 0.05], 0.04), ..Default::default() });
    }
    w
}

/// The bad inputs of issue #13, one after the other into one node: each is named in a
/// warning or a failed action event, the robot is held (a HOLD `/motion/command`), and the node
/// keeps working (it executes a good action afterwards).
#[test]
fn bad_input_is_named_the_robot_held_and_the_node_keeps_running() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut n, problem) = RobotManagerNode::new(params(dir.path()), 1);
    assert!(problem.is_none());
    let mut out = Outbox::default();
    // Teach foa/noa towards the bottle through the handlers (the tool guided into its sphere).
    let (far, near) = ([0.30, 0.0, 0.50], [0.45, 0.35, 0.24]);
    let mut t = 1.0;
    n.on_world(&world_with(t, far, true), at(t), &mut out);
    n.on_speech(&RosString { data: "teach".into() }, at(t), &mut out);
    for (a, b) in [(far, near), (near, far)] {
        for k in 1..=80 {
            t += 0.01;
            let s = f64::from(k) / 80.0;
            let p = [a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s];
            n.on_world(&world_with(t, p, true), at(t), &mut out);
        }
    }
    n.on_speech(&RosString { data: "done".into() }, at(t), &mut out);
    let learned: Vec<String> = out.robot_stream.iter().flat_map(|r| r.segments.iter().map(|s| s.label.clone())).collect();
    let noa = learned.iter().find(|l| l.starts_with("noa")).cloned().unwrap_or_else(|| panic!("a NOA at the bottle: {learned:?}"));
    let held = |out: &Outbox| out.motion.last().is_some_and(|m| m.kind == MotionCommand::KIND_HOLD);
    let failed = |out: &Outbox, id: u32| -> String {
        out.robot_stream.iter().flat_map(|r| r.events.iter()).find(|e| e.command_id == id && e.failed).map(|e| e.reason.clone()).unwrap_or_default()
    };

    // An action label with no primitive.
    out.clear();
    n.on_action(&ActionCommand { id: 21, label: "noa42(water)".into(), ..Default::default() }, at(t), &mut out);
    assert!(failed(&out, 21).contains("no primitive `noa42`"), "{out:?}");
    assert!(held(&out));
    // A primitive for an object that is not in the scene: the bottle gone from the world.
    t += 0.01;
    let mut w = world_with(t, far, true);
    w.objects.retain(|o| o.name != "bottle");
    n.on_world(&w, at(t), &mut out);
    out.clear();
    n.on_action(&ActionCommand { id: 22, label: noa.clone(), ..Default::default() }, at(t), &mut out);
    let why = failed(&out, 22);
    assert!(why.contains("`water`") && why.contains("not in the scene"), "{why:?} {out:?}");
    assert!(held(&out));
    // A gripper command while holding nothing: the hand is already free — done, with a warning.
    t += 0.01;
    n.on_world(&world_with(t, far, true), at(t), &mut out);
    out.clear();
    n.on_action(&ActionCommand { id: 23, label: "gripper(open)".into(), ..Default::default() }, at(t), &mut out);
    assert!(n.last_warning().is_some_and(|w| w.contains("holds nothing")), "{:?}", n.last_warning());
    assert!(out.robot_stream.iter().flat_map(|r| r.events.iter()).any(|e| e.command_id == 23 && e.done));
    // /motion/status for an unknown command id.
    n.on_motion_status(&MotionStatus { command_id: 9999, state: MotionStatus::STATE_CONVERGED, ..Default::default() }, at(t), &mut out);
    assert!(n.last_warning().is_some_and(|w| w.contains("unknown command id 9999")), "{:?}", n.last_warning());
    // Speech out of the vocabulary.
    n.on_speech(&RosString { data: "make me a sandwich".into() }, at(t), &mut out);
    assert!(n.last_warning().is_some_and(|w| w.contains("make me a sandwich") && w.contains("not in the vocabulary")), "{:?}", n.last_warning());
    // Still working: the taught NOA runs towards the bottle.
    out.clear();
    n.on_action(&ActionCommand { id: 24, label: noa.clone(), ..Default::default() }, at(t), &mut out);
    assert!(failed(&out, 24).is_empty(), "{out:?}");
    assert!(out.motion.last().is_some_and(|m| m.label == noa && m.kind != MotionCommand::KIND_HOLD), "{:?}", out.motion);
}

/// The bundled `preview:` block builds the previewer (the node then reads `/joint_states`); a
/// missing scene file is named with its field; an empty `urdf` turns the preview off; a
/// `/joint_states` without every joint is warned about and dropped.
#[test]
fn the_bundled_preview_loads_and_bad_joint_states_are_dropped() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = params(dir.path());
    let (previewer, names) = robot_manager::preview::load(&p, "robot_manager.yaml").expect("loads").expect("on by default");
    assert_eq!(names.len(), 7);
    assert!(previewer.knows("bottle") && previewer.knows("coffee"), "the kitchen's shapes");
    let mut bad = p.clone();
    bad.preview.scene = "config/scenes/no-such-scene.yaml".into();
    let e = format!("{:#}", robot_manager::preview::load(&bad, "rm.yaml").expect_err("missing scene"));
    assert!(e.contains("rm.yaml") && e.contains("preview.scene") && e.contains("no-such-scene"), "{e}");
    bad.preview.urdf.clear();
    assert!(robot_manager::preview::load(&bad, "rm.yaml").expect("off").is_none());

    let (mut n, _) = RobotManagerNode::new(p, 1);
    assert!(!n.previews());
    n.set_previewer(previewer, names.clone());
    assert!(n.previews());
    let mut out = Outbox::default();
    let js = |names: &[String]| JointState {
        header: Header { stamp: Time::from_secs_f64(1.0), frame_id: String::new() },
        name: names.to_vec(),
        position: vec![0.1; names.len()],
        ..Default::default()
    };
    n.on_joint_state(&js(&names), at(1.0), &mut out);
    assert_eq!(n.warnings(), 0);
    n.on_joint_state(&js(&names[..6]), at(1.0), &mut out);
    assert_eq!(n.warnings(), 1);
    assert!(n.last_warning().is_some_and(|w| w.contains("/joint_states") && w.contains(names[6].as_str())), "{:?}", n.last_warning());
}

#[test]
fn an_arms_manager_runs_its_arms_commands_only() {
    let dir = tempfile::tempdir().expect("tempdir");
    // The per-arm block of the bundled file, as a manager started in /left reads it.
    let text = std::fs::read_to_string(root().join("config/robot_manager.yaml")).unwrap();
    let mut p: Params = cowork_ros::params::from_str_in(&text, "robot_manager", Some("/left"), "robot_manager.yaml").expect("/left block");
    p.validate("robot_manager.yaml /left").expect("valid");
    assert_eq!(p.manager.robot, "lwr_left", "each arm has its own primitive database");
    assert!(p.manager.objects.contains_key("tomato") && p.preview.scene.ends_with("pizza.yaml"));
    p.database_dir = dir.path().display().to_string();
    let (mut n, _) = RobotManagerNode::new(p, 1);
    n.set_arm("left");
    let mut out = Outbox::default();
    let mut w = world(1.0);
    w.header.frame_id = "left/lwr_base_link".into();
    n.on_world(&w, at(1.0), &mut out);
    out.clear();
    let command = |arm: &str| ActionCommand { id: 5, label: "noa9(tomato)".into(), arm: arm.into(), ..Default::default() };
    // The right arm's command: not this manager's business, nothing happens.
    n.on_action(&command("right"), at(1.01), &mut out);
    assert!(out.motion.is_empty() && out.robot_stream.iter().all(|r| r.events.is_empty()), "{out:?}");
    assert_eq!(n.warnings(), 0);
    // A command naming no arm: refused with a warning.
    n.on_action(&command(""), at(1.02), &mut out);
    assert!(out.motion.is_empty());
    assert_eq!(n.warnings(), 1);
    // Its own: executed (here it fails: the database is empty, and the event says so).
    n.on_action(&command("left"), at(1.03), &mut out);
    let ev = out.robot_stream.iter().flat_map(|r| &r.events).next().expect("an event for the left arm's command");
    assert!(ev.failed && ev.command_id == 5, "{ev:?}");

    // A single-arm manager refuses a command for a named arm.
    let (mut single, _) = RobotManagerNode::new(params(dir.path()), 1);
    let mut out = Outbox::default();
    single.on_action(&command("left"), at(1.0), &mut out);
    assert!(out.motion.is_empty());
    assert_eq!(single.warnings(), 1);
}

#[test]
fn speech_addressed_to_an_arm_reaches_only_that_arms_manager() {
    let dir = tempfile::tempdir().expect("tempdir");
    let managers = ["left", "right"].map(|arm| {
        let (mut n, _) = RobotManagerNode::new(params(dir.path()), 1);
        n.set_arm(arm);
        let mut out = Outbox::default();
        n.on_world(&world(1.0), at(1.0), &mut out);
        n
    });
    let [mut left, mut right] = managers;
    let say = |n: &mut RobotManagerNode, words: &str, t: f64| {
        let mut out = Outbox::default();
        n.on_speech(&RosString::new(words), at(t), &mut out);
        out
    };
    for (words, t) in [("left: teach", 1.1), (" left :  gripper close ", 1.2)] {
        let l = say(&mut left, words, t);
        let r = say(&mut right, words, t);
        assert!(r.gripper.is_empty() && r.robot_stream.is_empty() && r.motion.is_empty(), "{words:?} reached the right arm: {r:?}");
        if words.contains("gripper") {
            assert_eq!(l.gripper.iter().map(|g| g.data.as_str()).collect::<Vec<_>>(), ["close"], "{words:?}");
        }
    }
    assert_eq!(left.mode(), cowork_manager::Mode::Teach);
    assert_eq!(right.mode(), cowork_manager::Mode::Execute);
    assert_eq!((left.warnings(), right.warnings()), (0, 0));
    // Unaddressed words reach every arm.
    say(&mut right, "teach", 1.3);
    assert_eq!(right.mode(), cowork_manager::Mode::Teach);
    // Addressed words on a single-arm robot: refused with a warning, nothing done.
    let (mut single, _) = RobotManagerNode::new(params(dir.path()), 1);
    let out = say(&mut single, "left: gripper close", 1.0);
    assert!(out.gripper.is_empty());
    assert_eq!(single.warnings(), 1);
    assert_eq!(robot_manager::addressed("human: add(water)"), Some(("human", "add(water)")));
    assert_eq!(robot_manager::addressed("human add(water)"), None);
}
