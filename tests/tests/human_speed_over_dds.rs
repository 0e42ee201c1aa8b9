//! The robot's speed follows the person (thesis Sec. 5.1.3, issue #12's graph check): lwr_sim,
//! fded_distance, ds_controller and human_observer as separate processes over DDS on a private
//! domain, on lwr_sim's simulated clock. The test
//!
//! * commands a constant-speed shuttle between two points on `/motion/command` (0.3 m/s
//!   nominal, orientation held),
//! * replays the person of `bags/stacking-human.mcap` (walking in and reaching towards the
//!   arm), then, after that person has left, the `stop` and the `come` performances of
//!   `bags/gestures.mcap` on `/human/skeleton`,
//! * reads `/human/state`, `/human/gesture`, `/motion/status` and the tool pose of
//!   `/lwr/world`, and judges the tool speed the simulated robot actually had: ≈ 0.3 m/s while
//!   α_h is the far speed, ≈ 0.1 m/s while it is the interaction speed, both seen in one run
//!   (the person comes and goes), at rest (< 1 cm/s) from 0.5 s after the stop gesture's report
//!   until the come gesture's report, moving again after it.
//!
//! The bags' skeletons are re-stamped onto the simulated clock as they are published:
//! ds_controller accepts `/human/state` (stamped with the skeleton's stamp) only within its
//! watchdog bounds of its own `/clock`, and `cowork bag play` would stamp them with bag time
//! and drive a second `/clock` beside lwr_sim's.
//!
//! What the test sets apart from the bundled parameter files (in a temporary copy): the depth
//! camera renders 320 × 240 instead of 640 × 480 (the same pin-hole camera, half the pixels per
//! axis: fDED only has to keep ds_controller's distance watchdog fed here); ds_controller's
//! modulation and link safety are off (they reshape the velocity near the person, and this
//! test judges α_h alone; avoidance has its own tests) and its watchdog bounds are widened so
//! that a loaded 2-core machine does not hold the robot on late frames. Everything else is the
//! bundled configuration, including `config/gestures.json`.
//!
//! Needs the node binaries beside the test, built with the test profile as a workspace
//! `cargo test` builds them (or `cargo build --profile test --bins -p lwr_sim -p fded_distance
//! -p ds_controller -p human_observer`; unoptimised `dev` binaries are too slow for the gesture
//! recognition to keep up). `COWORK_GRAPH_BIN_DIR=target/release` runs release binaries;
//! `HUMAN_SPEED_DEBUG=1` prints the α_h changes and the end of human_observer's log.
//!
//! Measured here (2 cores, load average 5–8, test-profile binaries): 42.9 s wall; tool speed
//! median 0.299 m/s over 483 far windows and 0.100 m/s over 430 interaction windows, stop
//! reported 11.88 s, at rest until the come at 17.12 s, moving again after it.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use cowork_bag::BagReader;
use cowork_graph_tests::{half_resolution_scene, Processes, config_set, node_bin_dir, private_domain, repo_root};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{Gesture, HumanState, MotionCommand, MotionStatus, Skeleton, WorldState};
use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{NodeConfig, RosNode, qos};

/// Simulated seconds per wall second (lwr_sim `--rate`).
const RATE: f64 = 0.5;
/// Far and interaction speeds of `config/human_observer.yaml` and `config/ds_controller.yaml`
/// (m/s).
const FAR: f64 = 0.3;
const INTERACTION: f64 = 0.1;
/// Half the shuttle's length along y (m).
const SHUTTLE_HALF_M: f64 = 0.2;
/// Tool speed is measured over windows of this length (s of simulated time).
const WINDOW_S: f64 = 0.1;
/// α_h must have been the same for this long before a window for it to count (s): the
/// controller's response and one period of `/human/state` lie within it.
const SETTLE_S: f64 = 0.4;
/// Windows with the tool this close to a shuttle end are left out (m): it slows down there
/// (smoothing radius 1 cm) and turns.
const END_ZONE_M: f64 = 0.04;
/// Wall-clock limit of the whole test once the graph is up (s): generous, the test waits on
/// simulated time, never on the wall clock.
const WALL_LIMIT_S: f64 = 300.0;

/// A labelled performance of a bag (`/human/gesture_label`: label, start and end in bag s).
#[derive(Debug, Clone)]
struct BagLabel {
    label: String,
    start: f64,
    end: f64,
}

/// The raw value of `key` in the flat JSON object of a `cowork bag synth gestures` label
/// (`{"label": "stop", "start": 12.3, "end": 14.1, ...}`).
fn label_field<'a>(text: &'a str, key: &str) -> &'a str {
    let pat = format!("\"{key}\":");
    let at = text.find(&pat).unwrap_or_else(|| panic!("label {text:?} has no `{key}`")) + pat.len();
    let rest = &text[at..];
    rest[..rest.find([',', '}']).unwrap_or(rest.len())].trim()
}

/// The `/human/skeleton` frames and `/human/gesture_label` labels of a bundled bag.
fn bag_skeletons(name: &str) -> (Vec<Skeleton>, Vec<BagLabel>) {
    let path = repo_root().join("bags").join(name);
    let reader = BagReader::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (mut frames, mut labels) = (Vec::new(), Vec::new());
    for m in reader.messages() {
        let m = m.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        match &*m.topic {
            "/human/skeleton" => frames.push(m.decode::<Skeleton>().unwrap_or_else(|e| panic!("{name}: /human/skeleton: {e}"))),
            "/human/gesture_label" => {
                let text = m.decode::<RosString>().unwrap_or_else(|e| panic!("{name}: /human/gesture_label: {e}")).data;
                let num = |k: &str| label_field(&text, k).parse::<f64>().unwrap_or_else(|e| panic!("{name}: label {text:?}: `{k}`: {e}"));
                labels.push(BagLabel { label: label_field(&text, "label").trim_matches('"').to_owned(), start: num("start"), end: num("end") });
            }
            _ => {}
        }
    }
    (frames, labels)
}

/// A skeleton frame to publish at `t` (s after the trial start, simulated time).
struct Due {
    t: f64,
    frame: Skeleton,
}

/// The frames of `frames` with stamps in `[from, to)` (bag s), moved to start at `at` (trial s).
fn segment(frames: &[Skeleton], from: f64, to: f64, at: f64, out: &mut Vec<Due>) -> f64 {
    for f in frames {
        let b = f.header.stamp.to_secs_f64();
        if b >= from && b < to {
            out.push(Due { t: at + (b - from), frame: f.clone() });
        }
    }
    at + (to - from)
}

/// The test's copies of the scene and of ds_controller's parameters (see the module docs):
/// (scene, ds_controller parameters).
fn write_configs(dir: &Path) -> (PathBuf, PathBuf) {
    let scene = half_resolution_scene("stacking-hri.yaml", &dir.join("scene.yaml"));
    let text = std::fs::read_to_string(repo_root().join("config/ds_controller.yaml")).expect("config/ds_controller.yaml");
    // Modulation's `end_effector` and `links` come first in the file.
    let mut values = vec![("stale_after_s", "0.5"), ("future_tolerance_s", "0.05"), ("end_effector", "false"), ("links", "false")];
    // The soft watchdog (α_h faded by the data's age) and the link safety layer, where the
    // controller has them: they must not change the speed this test measures either.
    if text.contains("slow_after_s:") {
        values.push(("slow_after_s", "0.4"));
    }
    if text.contains("safety:") {
        values.push(("enabled", "false"));
    }
    let ds = config_set("ds_controller.yaml", &values, &dir.join("ds_controller.yaml"));
    (scene, ds)
}

fn constant_speed(id: u32, goal: [f64; 3]) -> MotionCommand {
    MotionCommand {
        id,
        kind: MotionCommand::KIND_CONSTANT_SPEED,
        label: format!("shuttle {id}"),
        goal: Pose { position: Point { x: goal[0], y: goal[1], z: goal[2] }, orientation: Quaternion { w: 1.0, ..Default::default() } },
        nominal_speed: FAR,
        hold_orientation: true,
        ..Default::default()
    }
}

/// α_h in force at `t` from the states sorted by stamp (`None` before the first).
fn alpha_at(states: &[(f64, f64)], t: f64) -> Option<f64> {
    states.partition_point(|s| s.0 <= t).checked_sub(1).map(|i| states[i].1)
}

/// α_h was `a` throughout `[t0, t1]`.
fn alpha_steady(states: &[(f64, f64)], t0: f64, t1: f64) -> Option<f64> {
    let a = alpha_at(states, t0)?;
    let i0 = states.partition_point(|s| s.0 <= t0);
    let i1 = states.partition_point(|s| s.0 <= t1);
    states[i0..i1].iter().all(|s| (s.1 - a).abs() < 1e-9).then_some(a)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { f64::NAN } else { v[v.len() / 2] }
}

#[test]
fn tool_speed_follows_the_person_and_the_stop_and_come_gestures() {
    let nodes = ["lwr_sim", "fded_distance", "ds_controller", "human_observer"];
    // COWORK_GRAPH_BIN_DIR=target/release runs the graph of release binaries.
    let bins = std::env::var_os("COWORK_GRAPH_BIN_DIR").map_or_else(|| node_bin_dir(&nodes), |d| repo_root().join(d));
    // The person: stacking-human.mcap from 3.5 s (walking in) to 8.5 s (reaching towards the
    // arm); then nobody for 2 s; then a stop and a come of gestures.mcap.
    let (stacking, _) = bag_skeletons("stacking-human.mcap");
    let (gestures, labels) = bag_skeletons("gestures.mcap");
    let label = |l: &str| -> BagLabel { labels.iter().rev().find(|x| x.label == l).cloned().unwrap_or_else(|| panic!("no `{l}` label in gestures.mcap")) };
    // The last performance of each (the gesture window, 1.7 s, fills before it starts).
    let (stop, come) = (label("stop"), label("come"));
    let mut due = Vec::new();
    let left = segment(&stacking, 3.5, 8.5, 1.5, &mut due);
    let stop_at = left + 2.0;
    let come_at = segment(&gestures, stop.start - 2.0, stop.end + 0.5, stop_at, &mut due);
    let end = segment(&gestures, come.start - 2.0, come.end + 0.5, come_at, &mut due) + 2.0;
    due.sort_by(|a, b| a.t.total_cmp(&b.t));
    assert!(due.len() > 500, "{} frames to replay", due.len());

    let dir = tempfile::tempdir().expect("tempdir");
    let (scene, ds_params) = write_configs(dir.path());
    let domain = private_domain();
    let mut graph = Processes::new(&domain, &bins, &dir.path().join("logs"));
    let sim_limit = format!("{:.0}", end + 60.0);
    let wall_limit = format!("{:.0}", WALL_LIMIT_S + 120.0);
    // The test's node first, so that it misses nothing of the graph's.
    let mut node = RosNode::new("human_speed_test", &NodeConfig { domain_id: Some(domain.id()), use_sim_time: true, ..Default::default() }).expect("node");
    let states = node.subscription::<HumanState>("/human/state", &qos::reliable_depth(500)).expect("sub");
    let gesture_sub = node.subscription::<Gesture>("/human/gesture", &qos::reliable_depth(20)).expect("sub");
    let world = node.subscription::<WorldState>("/lwr/world", &qos::reliable_depth(500)).expect("sub");
    let status = node.subscription::<MotionStatus>("/motion/status", &qos::reliable_depth(100)).expect("sub");
    let motion = node.publisher::<MotionCommand>("/motion/command", &qos::reliable_depth(10)).expect("pub");
    let skeleton = node.publisher::<Skeleton>("/human/skeleton", &qos::reliable_depth(100)).expect("pub");
    let (scene, ds_params) = (scene.display().to_string(), ds_params.display().to_string());
    graph.spawn("human_observer", &["--params", "config/human_observer.yaml", "--use-sim-time", "--duration", &wall_limit]);
    graph.spawn("ds_controller", &["--params", &ds_params, "--use-sim-time", "--duration", &wall_limit]);
    graph.spawn("fded_distance", &["--params", "config/fded_distance.yaml", "--use-sim-time", "--duration", &wall_limit]);
    graph.spawn("lwr_sim", &["--scene", &scene, "--params", "config/lwr_sim.yaml", "--rate", &RATE.to_string(), "--duration", &sim_limit]);

    // Up: the clock runs, every node has spoken, our writers are matched.
    let wall_deadline = Instant::now() + Duration::from_secs_f64(WALL_LIMIT_S);
    let check = |what: &str, graph: &mut Processes| {
        if let Err(e) = graph.check_alive() {
            panic!("while waiting for {what}: {e}");
        }
        if Instant::now() > wall_deadline {
            let logs: String = ["lwr_sim", "fded_distance", "ds_controller", "human_observer"]
                .iter()
                .map(|n| format!("--- {n}\n{}\n", graph.log(n).lines().rev().take(10).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n")))
                .collect();
            panic!("timed out waiting for {what}\n{logs}");
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let mut tool0 = None;
    let (mut heard_state, mut heard_status) = (false, false);
    while !(node.clock_started() && tool0.is_some() && heard_state && heard_status && motion.subscription_count(&node) >= 1 && skeleton.subscription_count(&node) >= 2) {
        if let Some(w) = world.take_latest() {
            tool0 = Some(w.tool_pose.position);
        }
        heard_state |= states.take_latest().is_some();
        heard_status |= status.take_latest().is_some();
        check("the graph to come up", &mut graph);
    }
    let p0 = tool0.expect("tool pose");
    let goals = [[p0.x, p0.y - SHUTTLE_HALF_M, p0.z], [p0.x, p0.y + SHUTTLE_HALF_M, p0.z]];
    let t0 = node.now().to_secs_f64();
    let mut id = 1u32;
    motion.publish(constant_speed(id, goals[0])).expect("publish");
    let (mut sent_at, mut acked) = (t0, false);

    // The trial, on simulated time.
    let (mut alpha, mut tool, mut held, mut reports) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut next = 0usize;
    let mut stopped_seen = false;
    loop {
        let now = node.now().to_secs_f64();
        let t = now - t0;
        while next < due.len() && due[next].t <= t {
            let mut f = due[next].frame.clone();
            f.header.stamp = Time::from_secs_f64(t0 + due[next].t);
            skeleton.publish(f).expect("publish skeleton");
            next += 1;
        }
        while let Some(s) = states.take() {
            stopped_seen |= s.stopped;
            alpha.push((s.header.stamp.to_secs_f64() - t0, s.speed_scale, s.mode, s.present));
        }
        while let Some(w) = world.take() {
            let p = w.tool_pose.position;
            tool.push((w.header.stamp.to_secs_f64() - t0, [p.x, p.y, p.z]));
        }
        while let Some(g) = gesture_sub.take() {
            reports.push((g.header.stamp.to_secs_f64() - t0, g.label.clone()));
        }
        while let Some(s) = status.take() {
            let ts = s.header.stamp.to_secs_f64() - t0;
            acked |= s.command_id == id;
            if s.command_id == id && s.state != MotionStatus::STATE_RUNNING {
                held.push((ts, s.state, s.reason.clone()));
            }
            if s.command_id == id && s.state == MotionStatus::STATE_CONVERGED {
                id += 1;
                motion.publish(constant_speed(id, goals[(id as usize + 1) % 2])).expect("publish");
                (sent_at, acked) = (now, false);
            }
            if s.command_id == id && s.state == MotionStatus::STATE_ABORTED {
                panic!("shuttle command {id} aborted: {}", s.reason);
            }
        }
        // A command ds_controller has not reported on within 1 s is sent again.
        if !acked && now - sent_at > 1.0 {
            motion.publish(constant_speed(id, goals[(id as usize + 1) % 2])).expect("publish");
            sent_at = now;
        }
        if t > end {
            break;
        }
        check("the trial's simulated time to pass", &mut graph);
    }
    let observer_log = graph.log("human_observer");
    drop(graph);

    // Judge from the simulated world.
    alpha.sort_by(|a, b| a.0.total_cmp(&b.0));
    let steps: Vec<(f64, f64)> = alpha.iter().map(|s| (s.0, s.1)).collect();
    tool.sort_by(|a, b| a.0.total_cmp(&b.0));
    let near_end = |p: &[f64; 3]| goals.iter().any(|g| ((p[0] - g[0]).powi(2) + (p[1] - g[1]).powi(2) + (p[2] - g[2]).powi(2)).sqrt() < END_ZONE_M);
    // Not running (held on stale data, converged) at some time in [a, b]?
    let interrupted = |a: f64, b: f64| held.iter().any(|h| h.0 >= a - 0.3 && h.0 <= b);
    let mut speeds = Vec::new(); // (t, speed m/s)
    let mut j = 0;
    for i in 0..tool.len() {
        while j < tool.len() && tool[j].0 < tool[i].0 + WINDOW_S {
            j += 1;
        }
        if j >= tool.len() {
            break;
        }
        let (a, b) = (&tool[i], &tool[j]);
        let d = ((b.1[0] - a.1[0]).powi(2) + (b.1[1] - a.1[1]).powi(2) + (b.1[2] - a.1[2]).powi(2)).sqrt();
        speeds.push((a.0, d / (b.0 - a.0), near_end(&a.1) || near_end(&b.1), b.0));
    }
    let mut far = Vec::new();
    let mut close = Vec::new();
    for &(ta, v, ends, tb) in &speeds {
        if ends || interrupted(ta, tb) || ta < 0.5 {
            continue;
        }
        match alpha_steady(&steps, ta - SETTLE_S, tb) {
            Some(a) if (a - FAR).abs() < 1e-9 => far.push(v),
            Some(a) if (a - INTERACTION).abs() < 1e-9 => close.push(v),
            _ => {}
        }
    }
    let mut switches = 0;
    let mut sequence = Vec::new();
    let mut changes = Vec::new();
    for s in &steps {
        if sequence.last() != Some(&s.1) {
            sequence.push(s.1);
            changes.push(format!("{:.2}:{}", s.0, s.1));
            switches += 1;
        }
    }
    if std::env::var_os("HUMAN_SPEED_DEBUG").is_some() {
        eprintln!("α_h changes (s: m/s): {}\nfirst frames at {:.2}, stop segment at {stop_at:.2}, come segment at {come_at:.2}, end {end:.2}", changes.join(" "), due[0].t);
        eprintln!("human_observer log:\n{}", observer_log.lines().rev().take(40).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n"));
        for a in alpha.iter().filter(|a| a.0 > 5.0 && a.0 < 9.0).step_by(5) {
            eprintln!("  {:.3} α {} mode {} present {}", a.0, a.1, a.2, a.3);
        }
    }
    let summary = format!(
        "far: {} windows, median {:.3} m/s; interaction: {} windows, median {:.3} m/s; α_h sequence {:?} ({} changes); gestures {:?}; holds {}",
        far.len(),
        median(&mut far.clone()),
        close.len(),
        median(&mut close.clone()),
        sequence,
        switches,
        reports,
        held.len()
    );
    eprintln!("{summary}");
    // Comes and goes: far, then interaction, then far again, before the gestures.
    let before_stop: Vec<f64> = steps.iter().filter(|s| s.0 < stop_at).map(|s| s.1).collect();
    let first_close = before_stop.iter().position(|a| (a - INTERACTION).abs() < 1e-9);
    assert!(before_stop.first().is_some_and(|a| (a - FAR).abs() < 1e-9), "α_h far before the person came: {summary}");
    let back_far = first_close.and_then(|i| before_stop[i..].iter().position(|a| (a - FAR).abs() < 1e-9));
    assert!(first_close.is_some() && back_far.is_some(), "α_h 0.3 → 0.1 → 0.3 as the person came and went: {summary}");
    assert!(far.len() >= 10 && close.len() >= 10, "enough cruising windows at each speed: {summary}");
    let (vf, vc) = (median(&mut far), median(&mut close));
    assert!((vf - FAR).abs() < 0.03, "tool speed far {vf:.3} m/s: {summary}");
    assert!((vc - INTERACTION).abs() < 0.015, "tool speed in interaction {vc:.3} m/s: {summary}");

    // Stop, then come.
    let ts = reports.iter().find(|r| r.1 == "stop").map(|r| r.0).unwrap_or_else(|| panic!("no stop gesture reported: {summary}"));
    let tc = reports.iter().find(|r| r.1 == "come" && r.0 > ts).map(|r| r.0).unwrap_or_else(|| panic!("no come gesture after the stop: {summary}"));
    assert!(stopped_seen, "/human/state never said stopped: {summary}");
    assert!(tc - ts > 1.0, "stop at {ts:.2} s and come at {tc:.2} s leave too little time to see the robot at rest");
    let resting: Vec<f64> = speeds.iter().filter(|s| s.0 >= ts + 0.5 && s.3 <= tc).map(|s| s.1).collect();
    assert!(resting.len() >= 20, "windows between stop + 0.5 s and come: {}", resting.len());
    let fastest = resting.iter().copied().fold(0.0, f64::max);
    assert!(fastest < 0.01, "tool at {fastest:.4} m/s between 0.5 s after the stop and the come: {summary}");
    let moving = speeds.iter().filter(|s| s.0 >= tc && s.0 <= tc + 1.5).any(|s| s.1 > 0.05);
    assert!(moving, "the tool moves again within 1.5 s of the come gesture: {summary}");
}
