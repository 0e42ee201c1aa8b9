//! Two arms in one graph (issue #16): lwr_sim with the pizza scene (two shoulder-mounted LWRs,
//! config/scenes/pizza.yaml) and, per arm, fded_distance and ds_controller started in the arm's
//! namespace (`--ros-args -r __ns:=/left`), plus human_observer, as separate processes over
//! DDS on lwr_sim's clock. The test sends each arm a goal on its own `/<arm>/motion/command`
//! (the left hand over the pizza in the central area, the right hand beside it on the right) and judges from each arm's `/<arm>/lwr/world` (its base frame, turned into the
//! world by the base on `/tf_static`) and `/<arm>/joint_states`:
//!
//! * both hands reach their goals in the world (≤ 1 cm), each from its own command only;
//! * the arms never touch: the link hulls of the two arms ([`cowork_sim::ArmHulls`]) at every
//!   joint state received stay apart;
//! * each fded_distance sees the other arm: some of its links' closest obstacle points lie on
//!   the other arm's links (within 3 cm of their hulls), within 0.6 m (the arm's own links are
//!   removed from the image, the other's are not).
//!
//! The camera renders 320 × 240 (half the pixels per axis), as in the other graph tests.

use std::path::Path;
use std::time::{Duration, Instant};

use cowork_graph_tests::{half_resolution_scene, Processes, config_set, node_bin_dir, private_domain, repo_root};
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{LinkDistances, MotionCommand, MotionStatus, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use cowork_ros::{NodeConfig, RosNode, qos};
use cowork_sim::{ArmHulls, Scene};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};

const RATE: &str = "0.5";
const ARMS: [&str; 2] = ["left", "right"];
/// Goals of the hands, world frame (m): over the pizza, beside it on the right.
const GOALS: [[f64; 3]; 2] = [[0.35, 0.20, 0.30], [0.35, -0.20, 0.30]];
const WALL_LIMIT_S: f64 = 240.0;

fn p(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

fn iso(pose: &Pose) -> Isometry3<f64> {
    let o = &pose.orientation;
    Isometry3::from_parts(
        Translation3::new(pose.position.x, pose.position.y, pose.position.z),
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(o.w, o.x, o.y, o.z)),
    )
}

#[test]
fn two_arms_each_follow_their_own_commands_and_never_touch() {
    let nodes = ["lwr_sim", "fded_distance", "ds_controller", "human_observer"];
    let bins = std::env::var_os("COWORK_GRAPH_BIN_DIR").map_or_else(|| node_bin_dir(&nodes), |d| repo_root().join(d));
    let dir = tempfile::tempdir().expect("tempdir");
    let scene_path = half_resolution_scene("pizza.yaml", &dir.path().join("pizza.yaml"));
    let scene = Scene::from_file(&scene_path).expect("scene");
    // The bundled files with their per-arm blocks (`/left/ds_controller`: the pizza scene, the
    // arm's posture); only the watchdog bounds are widened for a loaded machine.
    let ds = config_set(
        "ds_controller.yaml",
        &[("stale_after_s", "0.5"), ("slow_after_s", "0.4"), ("future_tolerance_s", "0.05")],
        &dir.path().join("ds_controller.yaml"),
    );
    let fded = repo_root().join("config/fded_distance.yaml");

    let domain = private_domain();
    let mut graph = Processes::new(&domain, &bins, &dir.path().join("logs"));
    let wall = format!("{:.0}", WALL_LIMIT_S + 60.0);
    let mut node = RosNode::new("two_arms_test", &NodeConfig { domain_id: Some(domain.id()), use_sim_time: true, ..Default::default() }).expect("node");
    let statics = node.subscription::<TFMessage>("/tf_static", &qos::latched()).expect("sub");
    let mut worlds = Vec::new();
    let mut joints = Vec::new();
    let mut statuses = Vec::new();
    let mut distances = Vec::new();
    let mut motions = Vec::new();
    for arm in ARMS {
        worlds.push(node.subscription::<WorldState>(&format!("/{arm}/lwr/world"), &qos::reliable_depth(200)).expect("sub"));
        joints.push(node.subscription::<JointState>(&format!("/{arm}/joint_states"), &qos::reliable_depth(2000)).expect("sub"));
        statuses.push(node.subscription::<MotionStatus>(&format!("/{arm}/motion/status"), &qos::reliable_depth(100)).expect("sub"));
        distances.push(node.subscription::<LinkDistances>(&format!("/{arm}/fded/distances"), &qos::reliable_depth(100)).expect("sub"));
        motions.push(node.publisher::<MotionCommand>(&format!("/{arm}/motion/command"), &qos::reliable_depth(10)).expect("pub"));
    }
    for arm in ARMS {
        graph.spawn_in("ds_controller", arm, &["--params", p(&ds), "--use-sim-time", "--duration", &wall]);
        graph.spawn_in("fded_distance", arm, &["--params", p(&fded), "--use-sim-time", "--backend", "cpu", "--duration", &wall]);
    }
    graph.spawn("human_observer", &["--params", "config/human_observer.yaml", "--use-sim-time", "--duration", &wall, "--ros-args", "-r", "__ns:=/left"]);
    graph.spawn("lwr_sim", &["--scene", p(&scene_path), "--rate", RATE, "--duration", "120"]);

    let deadline = Instant::now() + Duration::from_secs_f64(WALL_LIMIT_S);
    let logs = |graph: &Processes| -> String {
        ["lwr_sim", "ds_controller_left", "ds_controller_right", "fded_distance_left", "fded_distance_right", "human_observer"]
            .iter()
            .map(|n| format!("--- {n}\n{}\n", graph.log(n).lines().rev().take(8).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n")))
            .collect()
    };
    let check = |what: &str, graph: &mut Processes| {
        if let Err(e) = graph.check_alive() {
            panic!("while waiting for {what}: {e}");
        }
        assert!(Instant::now() < deadline, "timed out waiting for {what}\n{}", logs(graph));
        std::thread::sleep(Duration::from_millis(2));
    };

    // Up: the bases on /tf_static, both worlds, both controllers and both fDEDs speak.
    let mut bases: [Option<Isometry3<f64>>; 2] = [None, None];
    let mut heard = [[false; 3]; 2];
    while !(bases.iter().all(Option::is_some) && heard.iter().flatten().all(|h| *h) && motions.iter().all(|m| m.subscription_count(&node) >= 1)) {
        while let Some(m) = statics.take() {
            for t in &m.transforms {
                if let Some(i) = ARMS.iter().position(|a| t.child_frame_id == format!("{a}/lwr_base_link")) {
                    assert_eq!(t.header.frame_id, "world");
                    let (v, q) = (&t.transform.translation, &t.transform.rotation);
                    bases[i] = Some(Isometry3::from_parts(Translation3::new(v.x, v.y, v.z), UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z))));
                }
            }
        }
        for i in 0..2 {
            heard[i][0] |= worlds[i].take_latest().is_some();
            heard[i][1] |= statuses[i].take_latest().is_some();
            heard[i][2] |= distances[i].take_latest().is_some();
        }
        check("the two-arm graph to come up", &mut graph);
    }
    let bases = bases.map(Option::unwrap);
    for (i, setup) in scene.arms.iter().enumerate() {
        assert!((bases[i].translation.vector - setup.base.isometry().translation.vector).norm() < 1e-9, "{} base", setup.name);
    }

    // Each arm gets its goal, in its own base frame, tool orientation held.
    let command = |i: usize, id: u32| {
        let g = bases[i].inverse() * Point3::from(GOALS[i]);
        MotionCommand {
            id,
            kind: MotionCommand::KIND_LINEAR,
            label: format!("{} to its goal", ARMS[i]),
            goal: Pose { position: Point { x: g.x, y: g.y, z: g.z }, orientation: Quaternion { w: 1.0, ..Default::default() } },
            nominal_speed: 0.3,
            hold_orientation: true,
            ..Default::default()
        }
    };
    let model = RobotModel::from_urdf_file(repo_root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let hulls = ArmHulls::new(&model);
    let mut q: [Option<JointVector>; 2] = [None, None];
    let mut poses = [LinkPoses::new(), LinkPoses::new()];
    let mut min_clearance = f64::INFINITY;
    let mut other_arm_seen = [f64::INFINITY; 2];
    let mut converged = [false; 2];
    let mut tool = [None; 2];
    let (mut sent_at, mut acked) = ([f64::NEG_INFINITY; 2], [false; 2]);
    let t0 = node.now().to_secs_f64();
    loop {
        let now = node.now().to_secs_f64();
        for i in 0..2 {
            if !acked[i] && now - sent_at[i] > 1.0 {
                motions[i].publish(command(i, 1)).expect("publish");
                sent_at[i] = now;
            }
            while let Some(s) = statuses[i].take() {
                if s.command_id == 1 {
                    acked[i] = true;
                    assert_ne!(s.state, MotionStatus::STATE_ABORTED, "{} aborted: {}", ARMS[i], s.reason);
                    converged[i] |= s.state == MotionStatus::STATE_CONVERGED;
                }
            }
            while let Some(w) = worlds[i].take() {
                tool[i] = Some((bases[i] * iso(&w.tool_pose)).translation.vector);
            }
            while let Some(js) = joints[i].take() {
                q[i] = Some(JointVector::from_iterator(js.position.iter().copied()));
                if let [Some(a), Some(b)] = &q {
                    model.forward_kinematics(a, &mut poses[0]);
                    model.forward_kinematics(b, &mut poses[1]);
                    let c = hulls.clearance([(bases[0], &poses[0]), (bases[1], &poses[1])]).expect("two arms");
                    min_clearance = min_clearance.min(c.distance_m);
                }
            }
            // fDED's obstacle points (this arm's base frame) that lie on the other arm.
            let other = 1 - i;
            while let Some(d) = distances[i].take() {
                let Some(q_other) = q[other] else { continue };
                model.forward_kinematics(&q_other, &mut poses[other]);
                for l in d.links.iter().filter(|l| l.valid) {
                    let o = &l.obstacle_point;
                    let world = bases[i] * Point3::new(o.x, o.y, o.z);
                    if std::env::var_os("TWO_ARMS_DEBUG").is_some() {
                        println!("{} {} d={:.3} obstacle world {:.3?} from other arm {:.3}", ARMS[i], l.link_name, l.distance, world.coords.as_slice(), hulls.distance_to_point(&bases[other], &poses[other], &world));
                    }
                    if hulls.distance_to_point(&bases[other], &poses[other], &world) < 0.03 {
                        other_arm_seen[i] = other_arm_seen[i].min(l.distance);
                    }
                }
            }
        }
        let reached = |i: usize| tool[i].is_some_and(|t: nalgebra::Vector3<f64>| (t - nalgebra::Vector3::from(GOALS[i])).norm() < 0.01);
        if converged.iter().all(|c| *c) && reached(0) && reached(1) && now - t0 > 2.0 {
            break;
        }
        assert!(now - t0 < 60.0, "not converged in 60 s of simulated time: converged {converged:?}, tools {tool:?}\n{}", logs(&graph));
        check("both arms to reach their goals", &mut graph);
    }
    let elapsed = node.now().to_secs_f64() - t0;
    println!(
        "both hands at their goals after {elapsed:.1} s (simulated); closest the arms came: {min_clearance:.3} m; \
         closest point of the other arm fDED saw: left {:.3} m, right {:.3} m",
        other_arm_seen[0], other_arm_seen[1]
    );
    assert!(min_clearance > 0.02, "the arms came within {min_clearance:.3} m of each other");
    for i in 0..2 {
        assert!(other_arm_seen[i] < 0.6, "{}'s fded_distance never saw the other arm within 0.6 m ({:.3} m)", ARMS[i], other_arm_seen[i]);
    }
}
