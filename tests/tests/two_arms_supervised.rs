//! Two arms under one attentional supervisor (issue #16's graph check, thesis Sec. 4.3.4,
//! 5.2.4): lwr_sim with the pizza scene, per arm (in its namespace) fded_distance,
//! ds_controller and robot_manager, one human_observer and the attentional_supervisor, as
//! separate processes over DDS on lwr_sim's clock.
//!
//! The LTM is the pizza task's shape (eq. 4.11, `config/tasks/pizza.schema`) with one short
//! subtask learned per arm, as teaching would have left it: the left arm takes the tomato (a
//! FOA over it), pours it (a FOA over the pizza, then back over the tomato); the right arm does
//! the same with the cheese. Each arm's robot_manager has those FOAs in its own primitive
//! database (`lfoa…` / `rfoa…`, goals in the object's frame). The tomato lies in the left
//! area, the cheese in the right one, the pizza in the central area, which only one arm may
//! hold at a time (first come, first served).
//!
//! Judged from the simulated world (each arm's joint states, forward kinematics, its base on
//! `/tf_static`): both arms work, the task completes (each arm's last FOA reported done on its
//! robot stream), the two hands are never in the central area at the same time, and the
//! central area changes hands exactly once.

use std::path::Path;
use std::time::{Duration, Instant};

use cowork_graph_tests::{half_resolution_scene, Processes, config_set, node_bin_dir, private_domain, repo_root};
use cowork_manager::{ActionKind, Database, Primitive, StoredPose};
use cowork_msgs::msg::{ActionCommand, RobotStream};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_robot::{JointVector, RobotModel};
use cowork_ros::{NodeConfig, RosNode, qos};
use cowork_sim::{Scene, SimParams, Simulator};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

const RATE: &str = "0.5";
const ARMS: [&str; 2] = ["left", "right"];
/// The central area of config/attentional_supervisor.yaml: |y| below this, world frame (m).
const CENTRAL_HALF_WIDTH_M: f64 = 0.2;
const WALL_LIMIT_S: f64 = 240.0;

const LTM: &str = "\
arms([left, right]).
objects([tomato, oil, cheese, basil, pizza, world]).
schema(pizza, [
    (add(A,tomato), true),
    (add(A,cheese), true)
], cheese.used & tomato.used).
schema(add(A,O), [
    (subtask(A,take,O), A.hand.free & ~O.used),
    (subtask(A,pour,O), A.O.taken)
], O.used).
schema(subtask(A,take,O), [], A.O.taken).
schema(subtask(A,pour,O), [], O.used).
schema(subtask(left,take,tomato), [(lfoa1(tomato), true)], left.tomato.taken).
schema(lfoa1(tomato), [], lfoa1.done, foa).
schema(subtask(left,pour,tomato), [(lfoa2(pizza), true), (lfoa3(tomato), lfoa2.done)], tomato.used).
schema(lfoa2(pizza), [], lfoa2.done, foa).
schema(lfoa3(tomato), [], lfoa3.done, foa).
schema(subtask(right,take,cheese), [(rfoa1(cheese), true)], right.cheese.taken).
schema(rfoa1(cheese), [], rfoa1.done, foa).
schema(subtask(right,pour,cheese), [(rfoa2(pizza), true), (rfoa3(cheese), rfoa2.done)], cheese.used).
schema(rfoa2(pizza), [], rfoa2.done, foa).
schema(rfoa3(cheese), [], rfoa3.done, foa).
";

fn p(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// A FOA of arm `prefix` to `offset` (m) above the centre of `object`, the tool pointing down:
/// the goal in the object's frame (the scene's objects stand upright in the world, so their
/// frame is the world's turned to their position: the tool's world orientation is the goal's).
fn foa(prefix: &str, n: u32, object: &str, offset: [f64; 3], tool_down: UnitQuaternion<f64>, object_in_base: &Isometry3<f64>) -> Primitive {
    let goal = Isometry3::from_parts(Translation3::from(Vector3::from(offset)), tool_down);
    let id = format!("{prefix}foa{n}");
    Primitive {
        label: format!("{id}({object})"),
        id,
        kind: ActionKind::Foa,
        object: object.into(),
        goal: StoredPose::from_isometry(&goal),
        taught_object_pose: StoredPose::from_isometry(object_in_base),
        dmp: None,
        orientation_dmp: None,
        linear_gain: Some(2.0),
        gripper: None,
        home: None,
        source: cowork_manager::Source { demonstration: "two_arms_supervised".into(), start_s: 0.0, end_s: 1.0 },
        samples: 2,
        created_unix_s: 0,
    }
}

#[test]
fn two_arms_share_the_central_area_one_at_a_time() {
    let nodes = ["lwr_sim", "fded_distance", "ds_controller", "human_observer", "robot_manager", "attentional_supervisor"];
    let bins = std::env::var_os("COWORK_GRAPH_BIN_DIR").map_or_else(|| node_bin_dir(&nodes), |d| repo_root().join(d));
    let dir = tempfile::tempdir().expect("tempdir");
    let scene_path = half_resolution_scene("pizza.yaml", &dir.path().join("pizza.yaml"));
    let scene = Scene::from_file(&scene_path).expect("scene");
    let model = RobotModel::from_urdf_file(repo_root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let sim = Simulator::new(model.clone(), scene.clone(), SimParams::default()).expect("simulator");

    // Each arm's primitives, in its own database.
    let db_dir = dir.path().join("primitives");
    std::fs::create_dir_all(&db_dir).expect("database dir");
    let pose_of = |name: &str| scene.objects.iter().find(|o| o.name == name).map(|o| o.pose.isometry()).expect(name);
    for (arm, prefix, own, side) in [(0usize, "l", "tomato", 1.0), (1, "r", "cheese", -1.0)] {
        let base = *sim.arm(arm).base();
        let tool_down = sim.world_tool_pose(arm).rotation;
        let mut db = Database::new(&format!("lwr_{}", ARMS[arm]));
        let own_in_base = base.inverse() * pose_of(own);
        let pizza_in_base = base.inverse() * pose_of("pizza");
        db.insert(foa(prefix, 1, own, [0.0, 0.0, 0.16], tool_down, &own_in_base));
        db.insert(foa(prefix, 2, "pizza", [0.0, side * 0.05, 0.15], tool_down, &pizza_in_base));
        db.insert(foa(prefix, 3, own, [0.0, 0.0, 0.16], tool_down, &own_in_base));
        db.next_index = 4;
        db.save(&Database::path(&db_dir, &db.robot)).expect("save database");
    }
    let ltm = dir.path().join("pizza.schema");
    std::fs::write(&ltm, LTM).expect("write LTM");
    let ds = config_set(
        "ds_controller.yaml",
        &[("stale_after_s", "0.5"), ("slow_after_s", "0.4"), ("future_tolerance_s", "0.05")],
        &dir.path().join("ds_controller.yaml"),
    );

    let domain = private_domain();
    let mut graph = Processes::new(&domain, &bins, &dir.path().join("logs"));
    let wall = format!("{:.0}", WALL_LIMIT_S + 60.0);
    let mut node = RosNode::new("two_arms_supervised_test", &NodeConfig { domain_id: Some(domain.id()), use_sim_time: true, ..Default::default() }).expect("node");
    let statics = node.subscription::<TFMessage>("/tf_static", &qos::latched()).expect("sub");
    let actions = node.subscription::<ActionCommand>("/supervisor/action", &qos::reliable_depth(100)).expect("sub");
    let mut joints = Vec::new();
    let mut streams = Vec::new();
    for arm in ARMS {
        joints.push(node.subscription::<JointState>(&format!("/{arm}/joint_states"), &qos::reliable_depth(2000)).expect("sub"));
        streams.push(node.subscription::<RobotStream>(&format!("/{arm}/robot_stream"), &qos::reliable_depth(2000)).expect("sub"));
    }
    for arm in ARMS {
        graph.spawn_in("ds_controller", arm, &["--params", p(&ds), "--use-sim-time", "--duration", &wall]);
        graph.spawn_in("fded_distance", arm, &["--use-sim-time", "--backend", "cpu", "--duration", &wall]);
        graph.spawn_in("robot_manager", arm, &["--use-sim-time", "--database-dir", p(&db_dir), "--duration", &wall]);
    }
    graph.spawn("human_observer", &["--use-sim-time", "--duration", &wall, "--ros-args", "-r", "__ns:=/left"]);
    graph.spawn("lwr_sim", &["--scene", p(&scene_path), "--rate", RATE, "--duration", "200"]);
    graph.spawn("attentional_supervisor", &["--ltm", p(&ltm), "--task", "pizza", "--use-sim-time", "--duration", &wall]);

    let deadline = Instant::now() + Duration::from_secs_f64(WALL_LIMIT_S);
    let names = [
        "lwr_sim", "attentional_supervisor", "robot_manager_left", "robot_manager_right", "ds_controller_left",
        "ds_controller_right", "fded_distance_left", "fded_distance_right", "human_observer",
    ];
    let logs = |graph: &Processes| -> String {
        names
            .iter()
            .map(|n| format!("--- {n}\n{}\n", graph.log(n).lines().rev().take(12).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n")))
            .collect()
    };

    let mut bases: [Option<Isometry3<f64>>; 2] = [None, None];
    let mut q: [Option<JointVector>; 2] = [None, None];
    let mut inside = [false; 2];
    let (mut both_inside, mut occupants): (u32, Vec<usize>) = (0, Vec::new());
    let mut done: Vec<(usize, String)> = Vec::new();
    let mut commanded: Vec<(String, String)> = Vec::new();
    loop {
        if let Err(e) = graph.check_alive() {
            panic!("{e}\n{}", logs(&graph));
        }
        assert!(Instant::now() < deadline, "the task did not complete in {WALL_LIMIT_S} s: done {done:?}, commanded {commanded:?}\n{}", logs(&graph));
        while let Some(m) = statics.take() {
            for t in &m.transforms {
                if let Some(i) = ARMS.iter().position(|a| t.child_frame_id == format!("{a}/lwr_base_link")) {
                    let (v, r) = (&t.transform.translation, &t.transform.rotation);
                    bases[i] = Some(Isometry3::from_parts(
                        Translation3::new(v.x, v.y, v.z),
                        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(r.w, r.x, r.y, r.z)),
                    ));
                }
            }
        }
        while let Some(a) = actions.take() {
            if !a.stop {
                commanded.push((a.arm.clone(), a.label.clone()));
            }
        }
        for i in 0..2 {
            while let Some(s) = streams[i].take() {
                for e in s.events.iter().filter(|e| e.done) {
                    done.push((i, e.label.clone()));
                }
            }
            while let Some(js) = joints[i].take() {
                q[i] = Some(JointVector::from_iterator(js.position.iter().copied()));
                if let (Some(b), Some(qi)) = (bases[i], q[i]) {
                    let tool = b * model.link_pose(&qi, model.tip_link());
                    inside[i] = tool.translation.vector.y.abs() < CENTRAL_HALF_WIDTH_M;
                    if inside[i] && occupants.last() != Some(&i) {
                        occupants.push(i);
                    }
                }
                if inside[0] && inside[1] {
                    both_inside += 1;
                }
            }
        }
        let finished = |arm: usize, label: &str| done.iter().any(|(a, l)| *a == arm && l == label);
        if finished(0, "lfoa3(tomato)") && finished(1, "rfoa3(cheese)") {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    // The supervisor logs the accomplished task in the tick after the last event.
    let waited = Instant::now();
    while !graph.log("attentional_supervisor").contains("task accomplished: pizza") && waited.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(20));
    }
    let supervisor_log = graph.log("attentional_supervisor");
    drop(graph);
    println!("actions commanded: {commanded:?}\ndone: {done:?}\ncentral area occupants in turn: {occupants:?}");
    assert_eq!(both_inside, 0, "both hands were in the central area at once ({both_inside} joint states)");
    assert_eq!(occupants.len(), 2, "the central area changes hands exactly once: occupants {occupants:?}");
    assert_ne!(occupants[0], occupants[1]);
    for (arm, label) in &commanded {
        let prefix = if arm == "left" { 'l' } else if arm == "right" { 'r' } else { panic!("a command for arm {arm:?}: {label}") };
        assert!(label.starts_with(prefix), "{label} sent to the {arm} arm");
    }
    assert!(supervisor_log.contains("task accomplished: pizza"), "the supervisor accomplished the task:\n{supervisor_log}");
}
