//! Bad input to the running graph (issue #15; SPEC "Quality bar": a clear report naming the
//! thing, fail closed, a peer never crashes a node): node processes over DDS on a private
//! domain, simulated clock. One graph per phase, the cases in sequence on it:
//!
//! 1. Teaching graph (`lwr_sim` without its camera, `robot_manager`, `attentional_supervisor`
//!    with the bundled kitchen LTM, nothing learned):
//!    (a) `done` on `/speech_command` without `teach`: both listeners say "not teaching";
//!    (b) a second supervisor started with `--task noSuchTask`: its contract (README, main.rs)
//!        is to refuse at start with one line naming the task and the LTM, exit status 1, no
//!        panic, publishing nothing — the graph it would have joined carries on;
//!    (c) a kinesthetic demonstration that never closes the gripper (`bags/kinesthetic-pour.mcap`
//!        with its `gripper close|open` words removed): nothing is grasped, `take(water)` is not
//!        accomplished, and at `done` the supervisor warns that its demonstration is unfinished
//!        (water.taken never held) and forgets its actions: it stays open.
//! 2. Execution graph (all six nodes, camera and fDED; pourDrink with `config/learned`):
//!    (d) the bottle is carried out of the workspace (`/lwr/place_object`) while the robot
//!        approaches it (`foa1(water)`): the manager reports `water` not visible on
//!        `/object_stream`, the supervisor stops the action ("stop foa1(water): no enabled
//!        action": take(water) is no longer enabled), the manager interrupts it ("arm held"), and
//!        the robot holds.
//!
//! After each case: the robot is held (no `/motion/command` with a goal since the case started,
//! joint velocities ~0 on `/joint_states`) and every node process is alive.
//!
//! Needs the node binaries beside the test (a workspace `cargo test` builds them).
//! `COWORK_TEST_DIR=DIR` keeps the logs in `DIR/graph_bad_inputs/`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use cowork_graph_tests::{Processes, TeachingFeed, config_set, node_bin_dir, private_domain, repo_root, test_dir};
use cowork_msgs::msg::{ActionCommand, MotionCommand, RobotStream, WorldObject, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::topics;
use cowork_ros::{NodeConfig, Publisher, RosNode, Subscription};

const NODES: [&str; 6] = ["lwr_sim", "robot_manager", "attentional_supervisor", "fded_distance", "ds_controller", "human_observer"];
/// Simulated seconds per wall second while teaching (no camera).
const TEACH_RATE: &str = "4";
/// Simulated seconds per wall second while executing (camera + fDED in the test profile).
const EXEC_RATE: &str = "0.5";
/// Joint speed below which the arm counts as held, rad/s.
const HELD_RAD_S: f64 = 1e-3;
/// Where the person puts the bottle: outside robot_manager's workspace (x ≤ 1.0 m), base frame.
const AWAY: [f64; 3] = [1.15, 0.45, 0.35];

fn p(path: &Path) -> &str {
    path.to_str().expect("UTF-8 temp path")
}

/// The test's own DDS participant: what it publishes and what it watches.
struct Probe {
    node: RosNode,
    speech: Publisher<RosString>,
    place: Publisher<WorldObject>,
    joints: Subscription<JointState>,
    motion: Subscription<MotionCommand>,
    actions: Subscription<ActionCommand>,
    robot: Subscription<RobotStream>,
    world: Subscription<WorldState>,
}

impl Probe {
    fn new(domain: u16) -> Self {
        let mut node = RosNode::new("bad_input_probe", &NodeConfig { domain_id: Some(domain), use_sim_time: true, ..Default::default() })
            .expect("test node");
        Self {
            speech: node.advertise(&topics::SPEECH_COMMAND).expect("pub"),
            place: node.advertise(&topics::PLACE_OBJECT).expect("pub"),
            joints: node.subscribe(&topics::JOINT_STATES).expect("sub"),
            motion: node.subscribe(&topics::MOTION_COMMAND).expect("sub"),
            actions: node.subscribe(&topics::SUPERVISOR_ACTION).expect("sub"),
            robot: node.subscribe(&topics::ROBOT_STREAM).expect("sub"),
            world: node.subscribe(&topics::WORLD).expect("sub"),
            node,
        }
    }

    /// Motion commands that move the arm (anything but `KIND_HOLD`) received so far.
    fn moving_commands(&self) -> Vec<String> {
        let mut out = Vec::new();
        while let Some(m) = self.motion.take() {
            if m.kind != MotionCommand::KIND_HOLD {
                out.push(format!("{} (kind {})", m.label, m.kind));
            }
        }
        out
    }

    fn drain(&self) {
        while self.joints.take().is_some() {}
        while self.motion.take().is_some() {}
        while self.actions.take().is_some() {}
        while self.robot.take().is_some() {}
        while self.world.take().is_some() {}
    }

    fn say(&self, words: &str) {
        self.speech.publish(RosString { data: words.into() }).expect("publish speech");
    }
}

fn wait_until(what: &str, limit: Duration, g: &mut Processes, mut f: impl FnMut(&mut Processes) -> bool) {
    let until = Instant::now() + limit;
    while !f(g) {
        if let Err(e) = g.check_alive() {
            panic!("waiting for {what}: {e}");
        }
        assert!(Instant::now() < until, "timed out after {limit:?} waiting for {what}\n{}", logs(g));
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn logs(g: &Processes) -> String {
    NODES.iter().map(|n| format!("--- {n}\n{}", cowork_graph::tail(&g.log(n), 15))).collect::<Vec<_>>().join("\n")
}

/// The robot is held: in the second half of `window_s` of simulated time (the first lets a
/// brake finish and what was in flight arrive) no joint moves faster than [`HELD_RAD_S`], and
/// since the case began no motion command with a goal went out. Every node is alive.
fn assert_held(case: &str, probe: &Probe, g: &mut Processes, window_s: f64) {
    while probe.joints.take().is_some() {}
    let mut states = Vec::new();
    wait_until(&format!("{case}: {window_s} s of /joint_states"), Duration::from_secs(30), g, |_| {
        while let Some(js) = probe.joints.take() {
            states.push(js);
        }
        states.first().zip(states.last()).is_some_and(|(a, b)| b.header.stamp.to_secs_f64() - a.header.stamp.to_secs_f64() >= window_s)
    });
    let last = states.last().map_or(0.0, |js| js.header.stamp.to_secs_f64());
    states.retain(|js| js.header.stamp.to_secs_f64() >= last - window_s / 2.0);
    assert_still(case, probe, g, &states);
}

/// [`assert_held`] on joint states already received.
fn assert_still(case: &str, probe: &Probe, g: &mut Processes, states: &[JointState]) {
    let max_v = states.iter().flat_map(|js| js.velocity.iter()).fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(states.len() > 10, "{case}: only {} joint states", states.len());
    assert!(max_v < HELD_RAD_S, "{case}: the arm moved, joint speed up to {max_v:.4} rad/s\n{}", logs(g));
    let moving = probe.moving_commands();
    assert!(moving.is_empty(), "{case}: motion commands with a goal: {moving:?}\n{}", logs(g));
    g.check_alive().unwrap_or_else(|e| panic!("{case}: {e}"));
}

/// `bags/kinesthetic-pour.mcap` without its `gripper close|open` words, at `out`.
fn pour_without_gripper(out: &Path) -> PathBuf {
    let bag = repo_root().join("bags/kinesthetic-pour.mcap");
    let reader = cowork_bag::BagReader::open(&bag).expect("the pour bag");
    let mut w = cowork_bag::BagWriter::create(out).expect("bag writer");
    let mut dropped = Vec::new();
    for m in reader.messages() {
        let m = m.expect("bag message");
        if &*m.topic == "/speech_command" {
            let s: RosString = m.decode().expect("speech");
            if s.data.trim().starts_with("gripper") {
                dropped.push(s.data);
                continue;
            }
        }
        w.write_raw(&m.topic, &m.type_name, &m.channel.definition, m.log_time_ns, m.publish_time_ns, &m.data).expect("write");
    }
    w.finish().expect("finish the bag");
    assert_eq!(dropped, ["gripper close", "gripper open"], "the pour bag's gripper words");
    out.to_owned()
}

/// The teaching graph of phase 1 (`lwr_sim` without camera following the teacher's wrench
/// stamps, `robot_manager`, `attentional_supervisor` with the bundled kitchen LTM, pourDrink,
/// learning into `learned`), up and waiting for a demonstration; the feed of the pour bag
/// without its gripper words, ready on `probe`'s participant.
fn teaching_graph(dir: &Path, domain: &cowork_graph::DomainLease, bins: &Path, probe: &mut Probe, learned: &Path) -> (Processes, TeachingFeed) {
    let lwr_teach = config_set("lwr_sim.yaml", &[("enabled", "false")], &dir.join("lwr_teach.yaml"));
    let mut g = Processes::new(domain, bins, &dir.join("teach"));
    g.spawn("lwr_sim", &["--params", p(&lwr_teach), "--rate", TEACH_RATE, "--follow-wrench-stamps"]);
    g.spawn("robot_manager", &["--use-sim-time", "--database-dir", p(&dir.join("primitives"))]);
    g.spawn(
        "attentional_supervisor",
        &["--ltm", "config/tasks/kitchen.schema", "--task", "pourDrink", "--use-sim-time", "--save-ltm", p(learned)],
    );
    let feed = TeachingFeed::new(&mut probe.node, &pour_without_gripper(&dir.join("pour-no-gripper.mcap"))).expect("feed");
    wait_until("the teaching graph", Duration::from_secs(60), &mut g, |g| {
        probe.robot.take().is_some()
            && probe.speech.subscription_count(&probe.node) >= 2
            && g.log("attentional_supervisor").contains("waiting for a demonstration")
    });
    (g, feed)
}

/// Case (c): plays the demonstration without gripper words (`teach` … `done`); checks nothing
/// was grasped, no gripper segment was cut, the arm rests afterwards, no motion was commanded
/// and every node is alive. Returns the segments cut.
fn teach_without_gripper(g: &mut Processes, probe: &Probe, feed: TeachingFeed) -> Vec<String> {
    wait_until("(c) the feed's readers", Duration::from_secs(20), g, |_| feed.matched(&probe.node, 1, 2));
    probe.drain();
    let t0 = probe.node.now().to_secs_f64() + 0.5;
    let (mut segments, mut held, mut states) = (Vec::<String>::new(), Vec::<String>::new(), Vec::<JointState>::new());
    let fed = {
        let (g, segments, held, states, probe) = (&mut *g, &mut segments, &mut held, &mut states, &probe);
        let mut alive = || {
            while let Some(js) = probe.joints.take() {
                states.push(js);
            }
            while let Some(r) = probe.robot.take() {
                segments.extend(r.segments.iter().map(|s| s.label.clone()));
            }
            while let Some(w) = probe.world.take() {
                if !w.held_object.is_empty() && !held.contains(&w.held_object) {
                    held.push(w.held_object.clone());
                }
            }
            g.check_alive()
        };
        feed.play(&probe.node, t0, 0.2, 1.0, Duration::from_secs(120), &mut alive).unwrap_or_else(|e| panic!("(c) the feed: {e}"))
    };
    assert_eq!(fed.dropped, 0, "(c) no wrench or word of the teacher was dropped");
    wait_until("(c) the manager back in execute mode", Duration::from_secs(20), g, |g| g.log("robot_manager").contains("mode: Execute"));
    std::thread::sleep(Duration::from_millis(500));
    while let Some(r) = probe.robot.take() {
        segments.extend(r.segments.iter().map(|s| s.label.clone()));
    }
    println!("(c) segments {segments:?}; held {held:?}");
    assert!(held.is_empty(), "(c) nothing is grasped without `gripper close`: held {held:?}");
    assert!(!segments.iter().any(|s| s.starts_with("close") || s.starts_with("open")), "(c) no gripper segment: {segments:?}");
    // lwr_sim follows the teacher's wrench stamps: its clock stops with the feed, after 1 s of
    // zero wrench past the last message; its last 0.3 s show the arm let go at rest.
    while let Some(js) = probe.joints.take() {
        states.push(js);
    }
    let last = states.last().map_or(0.0, |js| js.header.stamp.to_secs_f64());
    assert!(last >= fed.last_s + 0.8, "(c) the simulator ran on after the feed: last joint state at {last:.3} s, feed ended {:.3} s", fed.last_s);
    states.retain(|js| js.header.stamp.to_secs_f64() >= last - 0.3);
    assert_still("(c) demonstration without the gripper", probe, g, &states);
    segments
}

#[test]
fn bad_inputs_are_named_and_hold_the_robot_with_every_node_alive() {
    let wall = Instant::now();
    let bins = node_bin_dir(&NODES);
    let (_keep, dir) = test_dir("graph_bad_inputs");
    let domain = private_domain();
    let mut probe = Probe::new(domain.id());

    // ---- 1. Teaching graph.
    let learned = dir.join("learned.schema");
    let (mut g, feed) = teaching_graph(&dir, &domain, &bins, &mut probe, &learned);
    probe.drain();
    let t_ready = wall.elapsed().as_secs_f64();

    // (a) `done` without `teach`.
    probe.say("done");
    wait_until("(a) both listeners refuse `done`", Duration::from_secs(20), &mut g, |g| {
        g.log("robot_manager").contains("speech `done`: not teaching; ignored")
            && g.log("attentional_supervisor").contains("speech 'done' ignored: not teaching")
    });
    assert_held("(a) done without teach", &probe, &mut g, 1.0);

    // (b) A task the LTM does not have (a node of this graph: its graph id).
    let graph_id = g.graph().id().to_owned();
    let out = Command::new(bins.join("attentional_supervisor"))
        .args(["--ltm", "config/tasks/kitchen.schema", "--task", "noSuchTask", "--use-sim-time"])
        .current_dir(repo_root())
        .env("ROS_DOMAIN_ID", domain.id().to_string())
        .env("COWORK_GRAPH_ID", graph_id)
        .env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE")
        .output()
        .expect("start a second supervisor");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(1), "(b) refused with exit status 1, not a crash: {text}");
    // e.g. "error: cannot allocate task noSuchTask from config/tasks/kitchen.schema: unknown
    // task 'noSuchTask': no schema in the LTM matches it"
    let text = text.trim();
    assert!(
        text.lines().count() == 1 && text.starts_with("error: ") && text.contains("noSuchTask") && text.contains("config/tasks/kitchen.schema"),
        "(b) one error line naming the task and the LTM: {text}"
    );
    assert!(probe.actions.take().is_none(), "(b) no action was published");
    assert_held("(b) unknown task", &probe, &mut g, 1.0);

    // (c) A demonstration that never closes the gripper: take(water) is neither accomplished
    // nor learned (its post-condition water.taken never held), and a warning names it.
    teach_without_gripper(&mut g, &probe, feed);
    let sup = g.log("attentional_supervisor");
    assert!(
        !sup.contains("accomplished: subtask(take,water)"),
        "(c) take(water) accomplished although nothing was grasped\n{}",
        cowork_graph::tail(&sup, 20)
    );
    assert!(
        sup.lines().any(|l| l.contains("WARN") && l.contains("subtask(take,water) unfinished")),
        "(c) no warning names take(water)\n{}",
        cowork_graph::tail(&sup, 20)
    );
    let t_teach = wall.elapsed().as_secs_f64();
    g.stop();

    // ---- 2. Execution graph: pourDrink with what config/learned holds.
    let exec = dir.join("exec");
    std::fs::create_dir_all(exec.join("primitives")).expect("dir");
    let learned_dir = repo_root().join("config/learned");
    std::fs::copy(learned_dir.join("primitives/lwr.primitives.json"), exec.join("primitives/lwr.primitives.json")).expect("copy db");
    let ds = config_set("ds_controller.yaml", &[("stale_after_s", "0.5"), ("slow_after_s", "0.3")], &exec.join("ds_controller.yaml"));
    let mut g = Processes::new(&domain, &bins, &exec.join("logs"));
    g.spawn("lwr_sim", &["--rate", EXEC_RATE]);
    g.spawn("fded_distance", &["--params", "config/fded_distance.yaml", "--use-sim-time", "--backend", "cpu"]);
    g.spawn("human_observer", &["--params", "config/human_observer.yaml", "--use-sim-time"]);
    g.spawn("ds_controller", &["--params", p(&ds), "--use-sim-time"]);
    // The supervisor decides its first action once and publishes it only then (volatile): start
    // it after the camera → fDED → controller chain runs and the manager streams, so the
    // manager's /supervisor/action reader is matched when it decides.
    let distances = probe.node.subscribe(&topics::FDED_DISTANCES).expect("sub");
    wait_until("(d) fDED distances from the rendered camera", Duration::from_secs(60), &mut g, |_| distances.take().is_some());
    g.spawn("robot_manager", &["--use-sim-time", "--database-dir", p(&exec.join("primitives"))]);
    wait_until("(d) the manager's /robot_stream", Duration::from_secs(30), &mut g, |_| probe.robot.take().is_some());
    std::thread::sleep(Duration::from_millis(500));
    g.spawn(
        "attentional_supervisor",
        &["--ltm", p(&learned_dir.join("kitchen.learned.schema")), "--task", "pourDrink", "--use-sim-time"],
    );

    // (d) The bottle carried out of the workspace while the robot goes for it.
    let (mut tool0, mut moved, mut first_action) = (None::<[f64; 3]>, false, None::<String>);
    wait_until("(d) the robot on its way to the bottle", Duration::from_secs(60), &mut g, |_| {
        while let Some(a) = probe.actions.take() {
            first_action.get_or_insert(a.label);
        }
        while let Some(w) = probe.world.take() {
            let p = [w.tool_pose.position.x, w.tool_pose.position.y, w.tool_pose.position.z];
            let p0 = *tool0.get_or_insert(p);
            moved |= (p[0] - p0[0]).hypot(p[1] - p0[1]).hypot(p[2] - p0[2]) > 0.01;
        }
        moved && first_action.is_some()
    });
    assert_eq!(first_action.as_deref(), Some("foa1(water)"), "(d) the first action approaches the bottle");
    let mut away = WorldObject { name: "bottle".into(), ..Default::default() };
    (away.pose.position.x, away.pose.position.y, away.pose.position.z) = (AWAY[0], AWAY[1], AWAY[2]);
    away.pose.orientation.w = 1.0;
    probe.place.publish(away).expect("publish /lwr/place_object");
    let t_removed = wall.elapsed().as_secs_f64();
    let objects = probe.node.subscribe(&topics::OBJECT_STREAM).expect("sub");
    let (mut bottle_away, mut water_hidden) = (false, false);
    wait_until("(d) the manager and the supervisor react", Duration::from_secs(30), &mut g, |g| {
        while let Some(w) = probe.world.take() {
            bottle_away |= w.objects.iter().any(|o| o.name == "bottle" && (o.pose.position.x - AWAY[0]).abs() < 1e-3);
        }
        while let Some(o) = objects.take() {
            water_hidden |= o.objects.iter().any(|o| o.name == "water" && !o.visible);
        }
        bottle_away
            && water_hidden
            && g.log("attentional_supervisor").contains("stop foa1(water): no enabled action")
            && g.log("robot_manager").contains("supervisor stop: foa1(water) interrupted, arm held")
    });
    std::thread::sleep(Duration::from_millis(500));
    let _ = probe.moving_commands();
    assert_held("(d) object removed mid-task", &probe, &mut g, 1.0);
    println!(
        "graph ready {t_ready:.1} s, teaching cases done {t_teach:.1} s, bottle removed {t_removed:.1} s; whole test {:.1} s wall",
        wall.elapsed().as_secs_f64()
    );
}
