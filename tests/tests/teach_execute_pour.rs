//! Teach → execute in the whole graph (thesis Sec. 4.3.3, 5.2.3, Table 5.4): separate node
//! processes over DDS on a private domain, simulated clock.
//!
//! 1. Teaching: `lwr_sim` (no camera), `robot_manager`, `attentional_supervisor`; the test
//!    plays the teacher — `bags/kinesthetic-pour.mcap`'s wrenches (stamped with their due
//!    simulated time, applied then by lwr_sim) and speech (published when `/clock` reaches it),
//!    so the arm moves under the same forces at the same simulated instants however loaded the
//!    machine is. The manager segments, the supervisor
//!    attaches the segments by Algorithm 4 and saves its LTM; checked: the primitive database
//!    and the learned `take(water)` / `pour(water)` subtasks.
//! 2. Execution: the whole graph (`lwr_sim` with its depth camera, `fded_distance`,
//!    `human_observer`, `ds_controller` with obstacle avoidance on, `robot_manager` with the
//!    taught database, `attentional_supervisor` with the learned LTM) and the bottle where it
//!    never was while taught. Judged from `/lwr/world` only: the bottle was grasped, tilted
//!    more than 90° over the cup, released upright on the table. ds_controller's link damper
//!    is on (the bundled parameters): it keeps links off the coffee jar beside the cup at its
//!    scene distances (the jar is a known scene object) instead of holding the forearm 10–30 cm
//!    away as from a person, which stalled `noa5(cup)` / `foa4(cup)` before.
//!    Chaos on the way: 2 s into the carry of the bottle, robot_manager is killed (SIGKILL) and
//!    started again 3 s later; the new one starts with no action, and the supervisor sends the
//!    running one again when the manager's robot stream comes back, so the task still completes.
//!
//! Overrides of the bundled parameters (all for this machine's speed, none for the result):
//! teaching runs the simulator at 4× real time with `--follow-wrench-stamps` (each of the
//! teacher's wrenches acts at its stamp and the simulator waits for a teacher that is late, so
//! the demonstration replays the same on a loaded machine);
//! execution runs at half real time (the camera → fDED → controller chain of the test profile
//! lags by several 100 ms of wall time on a loaded 2-core machine) with ds_controller's `stale_after_s` 0.5 s and `slow_after_s`
//! 0.3 s (the test profile's renderer and fDED are slower than release).
//!
//! Needs the node binaries beside the test (a workspace `cargo test` builds them).
//! `COWORK_TEACH_OUT=DIR` keeps what was taught (`DIR/primitives/lwr.primitives.json`,
//! `DIR/learned.schema`) for `nodes/robot_manager/scripts/pour_positions.sh`.

use std::path::Path;
use std::time::{Duration, Instant};

use cowork_graph_tests::{Processes, TeachingFeed, config_set, config_with, node_bin_dir, private_domain, repo_root, test_dir};
use cowork_manager::{ActionKind, Database};
use cowork_msgs::msg::{LinkDistances, RobotStream, WorldState};
use cowork_ros::{NodeConfig, RosNode, qos};

const NODES: [&str; 6] = ["lwr_sim", "robot_manager", "attentional_supervisor", "fded_distance", "ds_controller", "human_observer"];
/// Simulated seconds per wall second while teaching (no camera, light).
const TEACH_RATE: &str = "4";
/// Simulated seconds per wall second while executing (camera + fDED + 1 kHz controller).
const EXEC_RATE: &str = "0.5";
/// Where the bottle stands during execution (taught at (0.45, 0.35)), m.
const BOTTLE_AT: [f64; 2] = [0.50, 0.28];
/// Simulated time the execution may take, s (Table 5.4 executes the pour in 46.5 s).
const EXEC_LIMIT_S: f64 = 90.0;
/// When robot_manager is killed: simulated s after the bottle was grasped (the carry to the
/// cup takes about 8 s).
const KILL_AFTER_GRASP_S: f64 = 2.0;
/// How long robot_manager stays killed in the execution (wall; 1.5 s simulated at EXEC_RATE).
const MANAGER_DOWN: Duration = Duration::from_secs(3);

fn p(path: &Path) -> &str {
    path.to_str().expect("UTF-8 temp path")
}

fn wait_until(what: &str, limit: Duration, g: &mut Processes, mut f: impl FnMut() -> bool) {
    let until = Instant::now() + limit;
    while !f() {
        if let Err(e) = g.check_alive() {
            panic!("waiting for {what}: {e}");
        }
        assert!(Instant::now() < until, "timed out after {limit:?} waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// What the judge keeps of `/lwr/world`.
#[derive(Debug, Default)]
struct Judge {
    worlds: u64,
    grasped: bool,
    /// Largest bottle tilt while held with its centre within 0.15 m (horizontally) of the
    /// cup's, rad; and the simulated time spent tilted > 90° there, s.
    max_tilt_over_cup: f64,
    tilted_s: f64,
    last: Option<WorldState>,
    last_t: Option<f64>,
    cup: Option<[f64; 2]>,
    /// Tool position of the first report; when it first moved 5 mm; when the bottle was first
    /// held; when it was first free again after that (simulated s): Table 5.4's subtask times
    /// from the world (the first action events can be published before this test's reader
    /// has matched the new robot_manager).
    tool0: Option<[f64; 3]>,
    t_move: Option<f64>,
    t_held: Option<f64>,
    t_free: Option<f64>,
}

impl Judge {
    fn on_world(&mut self, w: WorldState) {
        let t = w.header.stamp.to_secs_f64();
        let dt = self.last_t.map_or(0.0, |l| (t - l).clamp(0.0, 0.1));
        self.last_t = Some(t);
        self.worlds += 1;
        let find = |n: &str| w.objects.iter().find(|o| o.name == n);
        let p = [w.tool_pose.position.x, w.tool_pose.position.y, w.tool_pose.position.z];
        let p0 = *self.tool0.get_or_insert(p);
        if self.t_move.is_none() && (p[0] - p0[0]).hypot(p[1] - p0[1]).hypot(p[2] - p0[2]) > 0.005 {
            self.t_move = Some(t);
        }
        if w.held_object == "bottle" {
            self.t_held.get_or_insert(t);
        } else if self.t_held.is_some() && w.held_object.is_empty() {
            self.t_free.get_or_insert(t);
        }
        if self.cup.is_none() {
            self.cup = find("cup").map(|c| [c.pose.position.x, c.pose.position.y]);
        }
        if w.held_object == "bottle" {
            self.grasped = true;
            if let (Some(b), Some(c)) = (find("bottle"), self.cup) {
                let d = (b.pose.position.x - c[0]).hypot(b.pose.position.y - c[1]);
                if d < 0.15 {
                    self.max_tilt_over_cup = self.max_tilt_over_cup.max(b.tilt);
                    if b.tilt > 90f64.to_radians() {
                        self.tilted_s += dt;
                    }
                }
            }
        }
        self.last = Some(w);
    }

    /// Released upright on the table (bottle centre 0.11 m above the table top).
    fn put_back(&self) -> bool {
        self.last.as_ref().is_some_and(|w| {
            w.held_object.is_empty()
                && w.objects
                    .iter()
                    .find(|o| o.name == "bottle")
                    .is_some_and(|b| b.tilt < 10f64.to_radians() && (b.pose.position.z - 0.11).abs() < 0.02)
        })
    }

    fn success(&self) -> bool {
        self.grasped && self.max_tilt_over_cup > 90f64.to_radians() && self.put_back()
    }
}

#[test]
fn pour_taught_from_the_bag_runs_with_the_bottle_where_it_never_was() {
    let wall = Instant::now();
    let bins = node_bin_dir(&NODES);
    let (_keep, dir) = test_dir("teach_execute_pour");
    let domain = private_domain();
    let db_dir = dir.join("primitives");
    let learned = dir.join("learned.schema");

    // ---- 1. Teaching from the bag.
    let lwr_teach = config_set("lwr_sim.yaml", &[("enabled", "false")], &dir.join("lwr_teach.yaml"));
    let mut g = Processes::new(&domain, &bins, &dir.join("teach"));
    g.spawn("lwr_sim", &["--params", p(&lwr_teach), "--rate", TEACH_RATE, "--follow-wrench-stamps"]);
    g.spawn("robot_manager", &["--use-sim-time", "--database-dir", p(&db_dir)]);
    g.spawn(
        "attentional_supervisor",
        &["--ltm", "config/tasks/kitchen.schema", "--task", "pourDrink", "--use-sim-time", "--save-ltm", p(&learned)],
    );
    let mut node = RosNode::new("teacher", &NodeConfig { domain_id: Some(domain.id()), use_sim_time: true, ..Default::default() })
        .expect("test node");
    let robot = node.subscription::<RobotStream>("/robot_stream", &qos::reliable_depth(100)).expect("sub");
    let feed = TeachingFeed::new(&mut node, &repo_root().join("bags/kinesthetic-pour.mcap")).expect("bag");
    let bag_s = feed.duration_s();
    let mut seen_manager = false;
    wait_until("the teaching graph (manager on /lwr/world, wrench and speech readers)", Duration::from_secs(90), &mut g, || {
        seen_manager |= robot.take().is_some();
        seen_manager && feed.matched(&node, 1, 2) && node.now().to_secs_f64() > 0.0
    });
    let t0 = node.now().to_secs_f64() + 0.5;
    let teach_wall = Instant::now();
    let mut segments: Vec<String> = Vec::new();
    let collect = |g: &mut Processes, segments: &mut Vec<String>| {
        while let Some(r) = robot.take() {
            segments.extend(r.segments.iter().map(|s| s.label.clone()));
        }
        g.check_alive()
    };
    let fed = {
        let g = &mut g;
        let segs = &mut segments;
        // Wrenches 0.2 s ahead; 1 s after the bag for the last segment, the database and the LTM.
        feed.play(&node, t0, 0.2, 1.0, Duration::from_secs(240), &mut || collect(g, segs)).unwrap_or_else(|e| panic!("{e}"))
    };
    collect(&mut g, &mut segments).unwrap_or_else(|e| panic!("{e}"));
    let teach_wall_s = teach_wall.elapsed().as_secs_f64();
    let rm_log = g.log("robot_manager");
    let sup_log = g.log("attentional_supervisor");
    g.stop();
    println!(
        "teaching: {bag_s:.1} s of bag in {teach_wall_s:.1} s wall (rate {TEACH_RATE}, wrenches at their stamps); {} messages, {} words more than 50 ms of sim time late, latest {:.0} ms; segments {segments:?}",
        fed.published,
        fed.late_50ms,
        fed.max_late_s * 1e3
    );
    assert_eq!(fed.dropped, 0, "no wrench or word of the teacher was dropped");

    // The database: the seven actions of take + pour, each with its kind and frame.
    let db = Database::load(&db_dir.join("lwr.primitives.json")).unwrap_or_else(|e| panic!("{e}\n{rm_log}"));
    let want = [
        ("foa1", ActionKind::Foa, "water"),
        ("noa2", ActionKind::Noa, "water"),
        ("close3", ActionKind::Gripper, "water"),
        ("foa4", ActionKind::Foa, "cup"),
        ("noa5", ActionKind::Noa, "cup"),
        ("foa6", ActionKind::Foa, "world"),
        ("open7", ActionKind::Gripper, "water"),
    ];
    for (id, kind, object) in want {
        let prim = db.get(id).unwrap_or_else(|| panic!("no {id} in {:?}\n{rm_log}", db.primitives.keys().collect::<Vec<_>>()));
        assert_eq!((prim.kind, prim.object.as_str()), (kind, object), "{id}");
    }
    assert!(db.get("noa2").is_some_and(|p| p.dmp.is_some() && p.orientation_dmp.is_some()), "the grasp NOA is a DMP");
    // The LTM: take(water) and pour(water) learned by Algorithm 4 from those segments.
    let ltm = cowork_supervisor::Ltm::load(&learned).unwrap_or_else(|e| panic!("{e}\n{sup_log}"));
    let subtask = |head: &str| -> Vec<String> {
        ltm.schemas()
            .find(|(_, s)| s.head.to_string().replace(' ', "") == head)
            .map(|(_, s)| s.list.iter().map(|e| e.term.to_string().replace(' ', "")).collect())
            .unwrap_or_else(|| panic!("no learned {head} in {}\n{sup_log}", learned.display()))
    };
    assert_eq!(subtask("subtask(take,water)"), ["foa1(water)", "noa2(water)", "close3(water)"]);
    // The retreat after the release (noa8) stays with the pour that released the bottle.
    assert_eq!(subtask("subtask(pour,water)"), ["foa4(cup)", "noa5(cup)", "foa6(world)", "open7(water)", "noa8(water)"]);

    // What was taught, kept for `nodes/robot_manager/scripts/pour_positions.sh` when asked.
    if let Some(keep) = std::env::var_os("COWORK_TEACH_OUT") {
        let keep = Path::new(&keep);
        std::fs::create_dir_all(keep.join("primitives")).expect("COWORK_TEACH_OUT");
        std::fs::copy(db_dir.join("lwr.primitives.json"), keep.join("primitives/lwr.primitives.json")).expect("keep the database");
        std::fs::copy(&learned, keep.join("learned.schema")).expect("keep the LTM");
        println!("taught primitives and LTM kept in {}", keep.display());
    }

    // ---- 2. Execution with the bottle moved, obstacle avoidance on.
    let exec = dir.join("exec");
    std::fs::create_dir_all(exec.join("primitives")).expect("dir");
    std::fs::copy(db_dir.join("lwr.primitives.json"), exec.join("primitives/lwr.primitives.json")).expect("copy db");
    let scene = config_with(
        "scenes/kitchen.yaml",
        &[("pose: { position: [0.45, 0.35, 0.11] }", &format!("pose: {{ position: [{}, {}, 0.11] }}", BOTTLE_AT[0], BOTTLE_AT[1]))],
        &exec.join("kitchen.yaml"),
    );
    let ds = config_set("ds_controller.yaml", &[("stale_after_s", "0.5"), ("slow_after_s", "0.3")], &exec.join("ds_controller.yaml"));
    let ds_text = std::fs::read_to_string(&ds).expect("ds params");
    assert!(
        ds_text.contains("        end_effector: true")
            && ds_text.contains("        links: true")
            && ds_text.contains("      safety:\n        enabled: true")
            && ds_text.contains("      scene: config/scenes/kitchen.yaml"),
        "obstacle avoidance (modulation of the end effector and the links) and the link damper, knowing the scene's objects, are on in the bundled parameters"
    );
    let mut g = Processes::new(&domain, &bins, &exec.join("logs"));
    g.spawn("lwr_sim", &["--scene", p(&scene), "--rate", EXEC_RATE]);
    g.spawn("fded_distance", &["--params", "config/fded_distance.yaml", "--use-sim-time", "--backend", "cpu"]);
    g.spawn("human_observer", &["--params", "config/human_observer.yaml", "--use-sim-time"]);
    g.spawn("ds_controller", &["--params", p(&ds), "--use-sim-time"]);
    let world = node.subscription::<WorldState>("/lwr/world", &qos::reliable_depth(100)).expect("sub");
    let distances = node.subscription::<LinkDistances>("/fded/distances", &qos::reliable()).expect("sub");
    wait_until("fDED distances from the rendered camera", Duration::from_secs(90), &mut g, || distances.take().is_some());
    g.spawn("robot_manager", &["--use-sim-time", "--database-dir", p(&exec.join("primitives"))]);
    g.spawn("attentional_supervisor", &["--ltm", p(&learned), "--task", "pourDrink", "--use-sim-time"]);
    let mut judge = Judge::default();
    let mut events: Vec<(f64, String, bool, bool, String)> = Vec::new();
    let mut t_start = None;
    let exec_wall = Instant::now();
    let accomplished = |g: &Processes| g.log("attentional_supervisor").contains("task accomplished");
    // Chaos: robot_manager killed (SIGKILL) once the bottle is held, started again after
    // MANAGER_DOWN; the new one knows nothing of the running action, and the supervisor sends
    // it again when the manager's robot stream comes back.
    let mut manager_down: Option<(Instant, cowork_graph::Killed)> = None;
    let mut manager_restarted = false;
    loop {
        while let Some(w) = world.take() {
            t_start.get_or_insert(w.header.stamp.to_secs_f64());
            judge.on_world(w);
        }
        // Killed in the middle of the carry to the cup (an action it had started and the
        // supervisor had seen start), not between two actions: only the silence rule can then
        // give the new manager the action.
        let carrying = judge.t_held.zip(judge.last_t).is_some_and(|(held, now)| now - held >= KILL_AFTER_GRASP_S);
        if carrying && !manager_restarted && manager_down.is_none() {
            manager_down = Some((Instant::now(), g.graph().kill("robot_manager").expect("robot_manager running")));
        }
        if manager_down.as_ref().is_some_and(|(at, _)| at.elapsed() > MANAGER_DOWN)
            && let Some((_, killed)) = manager_down.take()
        {
            g.graph().restart(killed).expect("robot_manager started again");
            manager_restarted = true;
        }
        while let Some(r) = robot.take() {
            let t = r.header.stamp.to_secs_f64();
            events.extend(r.events.iter().map(|e| (t, e.label.clone(), e.done, e.failed, e.reason.clone())));
        }
        if let Err(e) = g.check_alive() {
            panic!("execution: {e}");
        }
        let elapsed = judge.last_t.zip(t_start).map_or(0.0, |(l, s)| l - s);
        if (judge.success() && accomplished(&g)) || elapsed > EXEC_LIMIT_S || exec_wall.elapsed() > Duration::from_secs(400) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    // The world a moment after the task: still released upright.
    let settle = judge.last_t.unwrap_or(0.0) + 0.5;
    wait_until("0.5 s after the task", Duration::from_secs(20), &mut g, || {
        while let Some(w) = world.take() {
            judge.on_world(w);
        }
        judge.last_t.unwrap_or(0.0) > settle
    });
    let exec_wall_s = exec_wall.elapsed().as_secs_f64();
    let span = |first: &str, last: &str| {
        let t0 = events.iter().find(|e| e.1 == first && !e.2 && !e.3).map(|e| e.0)?;
        let t1 = events.iter().find(|e| e.1 == last && e.2).map(|e| e.0)?;
        Some(t1 - t0)
    };
    let (take_s, pour_s) = (span("foa1(water)", "close3(water)"), span("foa4(cup)", "open7(water)"));
    let world_take_s = judge.t_move.zip(judge.t_held).map(|(a, b)| b - a);
    let world_pour_s = judge.t_held.zip(judge.t_free).map(|(a, b)| b - a);
    let failed: Vec<_> = events.iter().filter(|e| e.3).map(|e| format!("{}: {}", e.1, e.4)).collect();
    let logs = || {
        NODES.iter().map(|n| format!("--- {n}\n{}", tail(&g.log(n), 12))).collect::<Vec<_>>().join("\n")
    };
    println!(
        "execution, bottle at {BOTTLE_AT:?}: success {} (grasped {}, max tilt over the cup {:.1} deg for {:.2} s, put back {}); take {world_take_s:?} s, pour {world_pour_s:?} s of sim time from the world (events: {take_s:?} / {pour_s:?}; Table 5.4: 31.0 / 46.5 s); {:.1} s wall (rate {EXEC_RATE}); failed actions {failed:?}; whole test {:.1} s wall",
        judge.success(),
        judge.grasped,
        judge.max_tilt_over_cup.to_degrees(),
        judge.tilted_s,
        judge.put_back(),
        exec_wall_s,
        wall.elapsed().as_secs_f64()
    );
    assert!(judge.worlds > 100, "the judge saw the world ({} reports)", judge.worlds);
    assert!(judge.grasped, "the bottle was never held\n{}", logs());
    assert!(judge.max_tilt_over_cup > 90f64.to_radians(), "not tilted over the cup: {judge:?}\n{}", logs());
    assert!(judge.put_back(), "not released upright on the table: {:?}\n{}", judge.last, logs());
    assert!(accomplished(&g), "the supervisor did not report the task accomplished\n{}", logs());
    assert!(manager_restarted, "robot_manager was killed and started again during the execution");
    assert!(
        g.log("attentional_supervisor").contains("(robot_manager stopped or restarted?): sent again"),
        "the supervisor sent the running action again to the restarted robot_manager\n{}",
        logs()
    );
    assert!(world_take_s.is_some() && world_pour_s.is_some(), "{judge:?}");
}

fn tail(text: &str, n: usize) -> String {
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}
