//! Imitation teaching in the two-arm graph (thesis Sec. 4.2, 5.2.4, Fig. 5.24): separate node
//! processes over DDS on a private domain, simulated clock.
//!
//! `cowork bag synth pizza-demo-left` (seed 0): an Xsens demonstrator tops the pizza with the
//! left arm — skeletons at 120 Hz and words addressed to that arm (`left: gripper close`). The
//! test plays them into `lwr_sim` (config/scenes/pizza-teach-left.yaml, no camera, at 4× real
//! time, following the teacher's stamps), one `robot_manager` per arm in its namespace, a
//! `human_observer` in `/left` that retargets the demonstrator's arms onto the robot's (eq. 4.7)
//! and the supervisor on config/tasks/pizza.schema. Checked:
//! - the left robot arm followed the demonstrator: the direction shoulder → wrist of the robot
//!   arm (from `/left/joint_states`) against the demonstrator's (from the skeleton, turned by the
//!   mount), at the same simulated instants;
//! - the left manager cut, per ingredient, the thesis's segments (Fig. 5.24: NOA at the
//!   ingredient, at the pizza and at the ingredient put back, two hand commands, FOA between)
//!   and the supervisor learned take and pour of every ingredient for the left arm;
//! - the right arm, whose demonstrator arm hung still and to whom no word was addressed, cut no
//!   segment and its gripper never closed.
//!
//! Needs the node binaries beside the test (a workspace `cargo test` builds them).

use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

use cowork_graph_tests::{Processes, TeachingFeed, config_set, node_bin_dir, private_domain, repo_root, test_dir};
use cowork_msgs::msg::{RobotStream, Skeleton};
use cowork_msgs::topics::{self, Delivery};
use cowork_people::{Segment, SkeletonPose};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use cowork_ros::{NodeConfig, RosNode};
use nalgebra::UnitQuaternion;

const NODES: [&str; 4] = ["lwr_sim", "robot_manager", "attentional_supervisor", "human_observer"];

fn p(path: &Path) -> &str {
    path.to_str().expect("UTF-8 temp path")
}

#[test]
fn the_left_arm_follows_an_xsens_demonstrator_and_learns_the_pizza_task_over_dds() {
    let bins = node_bin_dir(&NODES);
    let (_keep, dir) = test_dir("imitation_teaching");
    let bag = dir.join("pizza-demo-left.mcap");
    let options = cowork_synth::SynthOptions { seed: 0, depth: false, config_dir: repo_root().join("config"), ..Default::default() };
    cowork_synth::synthesize(cowork_synth::Scenario::PizzaDemoLeft, &options, &bag, &mut |_| {}).expect("synthesised");

    let domain = private_domain();
    let sim_params = config_set("lwr_sim.yaml", &[("enabled", "false")], &dir.join("lwr_teach.yaml"));
    let learned = dir.join("learned.schema");
    let db_dir = dir.join("primitives");
    let mut g = Processes::new(&domain, &bins, &dir.join("logs"));
    g.spawn(
        "lwr_sim",
        &["--scene", p(&repo_root().join("config/scenes/pizza-teach-left.yaml")), "--params", p(&sim_params), "--rate", "4", "--follow-wrench-stamps"],
    );
    for arm in ["left", "right"] {
        g.spawn_in("robot_manager", arm, &["--use-sim-time", "--database-dir", p(&db_dir)]);
    }
    g.spawn_in("human_observer", "left", &["--use-sim-time", "--gestures", ""]);
    g.spawn("attentional_supervisor", &["--ltm", "config/tasks/pizza.schema", "--task", "pizza", "--use-sim-time", "--save-ltm", p(&learned)]);

    let mut node = RosNode::new("teacher", &NodeConfig { domain_id: Some(domain.id()), use_sim_time: true, ..Default::default() }).expect("node");
    let robots: Vec<_> = ["/left", "/right"].iter().map(|ns| node.subscribe_in(&topics::ROBOT_STREAM, ns).expect("sub")).collect();
    let joints = node.subscribe_in(&topics::JOINT_STATES.reading(Delivery::BestEffort { depth: 5000 }), "/left").expect("sub");
    let feed = TeachingFeed::from_bags_in(&mut node, &[&bag], "/left").expect("bag");
    assert!(feed.is_imitation());
    let until = Instant::now() + Duration::from_secs(90);
    let mut heard = [false; 2];
    while !(heard.iter().all(|h| *h) && feed.matched(&node, 1, 4) && node.now().to_secs_f64() > 0.0) {
        for (k, r) in robots.iter().enumerate() {
            heard[k] |= r.take().is_some();
        }
        g.check_alive().unwrap_or_else(|e| panic!("{e}"));
        assert!(Instant::now() < until, "the teaching graph was not up within 90 s (managers heard: {heard:?})");
        std::thread::sleep(Duration::from_millis(10));
    }
    let t0 = node.now().to_secs_f64() + 0.5;
    let wall = Instant::now();
    let mut segments: Vec<Vec<(String, u8)>> = vec![Vec::new(), Vec::new()];
    let mut stamps = [None::<f64>; 2];
    let mut right_closed = false;
    let mut arm_joints: Vec<(f64, Vec<f64>)> = Vec::new();
    let mut collect = |g: &mut Processes| -> Result<Option<f64>, String> {
        for (k, r) in robots.iter().enumerate() {
            while let Some(m) = r.take() {
                stamps[k] = Some(m.header.stamp.to_secs_f64());
                segments[k].extend(m.segments.iter().map(|s| (s.label.clone(), s.kind)));
                right_closed |= k == 1 && m.gripper_state == RobotStream::GRIPPER_CLOSED;
            }
        }
        while let Some(j) = joints.take() {
            arm_joints.push((j.header.stamp.to_secs_f64(), j.position.clone()));
        }
        g.check_alive()?;
        Ok(stamps.iter().copied().collect::<Option<Vec<f64>>>().map(|v| v.into_iter().fold(f64::INFINITY, f64::min)))
    };
    let fed = {
        let g = &mut g;
        feed.play_paced(&node, t0, 0.2, 1.5, Duration::from_secs(300), 0.3, &mut || collect(g)).unwrap_or_else(|e| panic!("{e}"))
    };
    std::thread::sleep(Duration::from_millis(500));
    collect(&mut g).unwrap_or_else(|e| panic!("{e}"));
    let wall_s = wall.elapsed().as_secs_f64();
    g.stop();
    assert_eq!(fed.dropped, 0);

    // 1. The robot arm followed the demonstrator's arm direction (shoulder → wrist).
    let model = RobotModel::from_urdf_file(repo_root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let mount = UnitQuaternion::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, 0.0);
    let reader = cowork_bag::BagReader::open(&bag).expect("bag");
    let mut errors_deg = Vec::new();
    let mut poses = LinkPoses::new();
    arm_joints.sort_by(|a, b| a.0.total_cmp(&b.0));
    for m in reader.messages() {
        let m = m.expect("message");
        if &*m.topic != "/human/skeleton" {
            continue;
        }
        let k: Skeleton = m.decode().expect("skeleton");
        // The robot, 0.1 s after the frame (the retargeting and the follower's lag).
        let t = t0 + m.log_time_ns as f64 * 1e-9 + 0.1;
        let Some((_, q)) = arm_joints.iter().find(|(s, _)| *s >= t) else { continue };
        let pose = SkeletonPose::from_message_measured(&k, -0.75).expect("pose");
        let body = mount * pose.segment(Segment::Sternum).orientation.inverse();
        let human = |a: Segment, b: Segment| body * (pose.position(b) - pose.position(a)).normalize();
        model.forward_kinematics(&JointVector::from_column_slice(q), &mut poses);
        let at = |l: usize| poses.get(model.joint_link(l)).translation.vector;
        let angle = |h: nalgebra::Vector3<f64>, r: nalgebra::Vector3<f64>| h.dot(&r.normalize()).clamp(-1.0, 1.0).acos().to_degrees();
        // Eq. 4.7 keeps the directions of the upper arm and of the forearm (their lengths are
        // the robot's): the worse of the two.
        let upper = angle(human(Segment::LeftShoulder, Segment::LeftElbow), at(3) - at(1));
        let fore = angle(human(Segment::LeftElbow, Segment::LeftWrist), at(5) - at(3));
        errors_deg.push(upper.max(fore));
    }
    errors_deg.sort_by(f64::total_cmp);
    let median = errors_deg[errors_deg.len() / 2];
    let p95 = errors_deg[errors_deg.len() * 95 / 100];
    let max = errors_deg[errors_deg.len() - 1];
    println!(
        "imitation teaching: {:.1} s of demonstration in {wall_s:.1} s wall; robot vs demonstrator upper-arm and forearm directions (the worse) over {} frames: median {median:.2}°, 95 % {p95:.2}°, max {max:.2}°",
        feed_len(&bag),
        errors_deg.len()
    );
    assert!(errors_deg.len() > 5000, "{} frames compared", errors_deg.len());
    assert!(median < 2.0 && p95 < 5.0 && max < 15.0, "median {median:.2}° 95 % {p95:.2}° max {max:.2}°");

    // 2. Per ingredient: NOA at it, at the pizza and when put back; close and open; the FOA
    //    between (Fig. 5.24: 3 NOA, 2 hand commands; the FOA from one ingredient to the next
    //    opens the next one's take).
    let left = &segments[0];
    println!("left segments: {}", left.iter().map(|s| s.0.as_str()).collect::<Vec<_>>().join(" "));
    let mut per: BTreeMap<&str, [usize; 3]> = BTreeMap::new();
    let mut current = "";
    // The last segment is the free motion after the last action, cut at `done`.
    assert!(left.last().is_some_and(|s| s.0.ends_with("(world)") && s.1 == 1), "{left:?}");
    for (label, kind) in &left[..left.len() - 1] {
        let object = label.split('(').nth(1).map_or("", |r| r.trim_end_matches(')'));
        if ["tomato", "cheese", "oil", "basil"].contains(&object) {
            current = ["tomato", "cheese", "oil", "basil"].into_iter().find(|o| *o == object).unwrap_or("");
        }
        if !current.is_empty() {
            per.entry(current).or_default()[usize::from(*kind)] += 1;
        }
    }
    for ingredient in ["tomato", "cheese", "oil", "basil"] {
        // [NOA, FOA, gripper] by ActionSegment kind codes 0, 1, 2.
        assert_eq!(per.get(ingredient).copied(), Some([3, 3, 2]), "{ingredient}: {left:?}");
    }
    assert!(segments[1].is_empty(), "the right arm cut segments: {:?}", segments[1]);
    assert!(!right_closed, "the right gripper closed");
    let ltm = cowork_supervisor::Ltm::load(&learned).expect("learned LTM saved");
    let text = ltm.to_text();
    for ingredient in ["tomato", "cheese", "oil", "basil"] {
        for sub in ["take", "pour"] {
            assert!(text.contains(&format!("subtask(left, {sub}, {ingredient})")) || text.contains(&format!("subtask(left,{sub},{ingredient})")), "{sub}({ingredient}) not learned:\n{text}");
        }
    }
    let db = cowork_manager::Database::load(&db_dir.join("lwr_left.primitives.json")).expect("the left arm's database");
    assert_eq!(db.primitives.len(), left.len());
    assert!(!db_dir.join("lwr_right.primitives.json").is_file() || cowork_manager::Database::load(&db_dir.join("lwr_right.primitives.json")).is_ok_and(|d| d.primitives.is_empty()));
}

fn feed_len(bag: &Path) -> f64 {
    cowork_bag::BagReader::open(bag).map_or(0.0, |r| r.messages().filter_map(Result::ok).map(|m| m.log_time_ns as f64 * 1e-9).fold(0.0, f64::max))
}
