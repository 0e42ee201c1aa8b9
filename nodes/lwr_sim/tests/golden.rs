//! Golden-file tests of the simulation loop ([`lwr_sim::run_loop`], the loop `run` drives over
//! DDS) on a mock clock: a recorded input script through `cowork_testkit::ScriptedSource`,
//! stepped at real-time pace on the script's clock → every output (`/clock`, `/joint_states`,
//! `/tf`, `/lwr/world`, `/lwr/external_wrench`, depth snapshots, gripper events, warnings) as
//! one JSON line, compared with `tests/golden/*.jsonl` (`UPDATE_GOLDEN=1` rewrites them).
//! Publication rates are lowered so the files stay readable; floats are rounded to 1e-6.

use std::path::PathBuf;

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Vector3, Wrench as RosWrench, WrenchStamped};
use cowork_msgs::msg::{Skeleton, WorldObject};
use cowork_msgs::std_msgs::{Float64MultiArray, Header, String as RosString};
use cowork_people::{Action, BodySize, MessageMeta, Performer, Stance};
use cowork_robot::RobotModel;
use cowork_sim::{Scene, Simulator};
use cowork_testkit::{ScriptedSource, assert_golden, json_line};
use lwr_sim::{Input, LwrSim, LwrSimConfig, Output, Pacing, RunSummary, WrenchMode, run_loop};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn golden(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden").join(format!("{name}.jsonl"))
}

fn node() -> LwrSim {
    let mut config: LwrSimConfig =
        cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("bundled parameters load");
    config.publish.clock_rate_hz = 20.0;
    config.publish.joint_state_rate_hz = 20.0;
    config.publish.tf_rate_hz = 5.0;
    config.publish.world_rate_hz = 5.0;
    config.external_wrench.report_rate_hz = 50.0;
    config.validate("golden").expect("valid");
    let model = RobotModel::from_urdf_file(&root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
    LwrSim::new(Simulator::new(model, scene, config.simulation.clone()).expect("simulator"), config)
}

fn velocity(q: [f64; 7]) -> Input {
    Input::VelocityCommand(0, Float64MultiArray { data: q.to_vec(), ..Default::default() })
}

fn gripper(word: &str) -> Input {
    Input::GripperCommand(0, RosString { data: word.into() })
}

fn push(frame: &str, f: [f64; 3], stamp_s: f64) -> Input {
    Input::Wrench(0, WrenchStamped {
        header: Header { frame_id: frame.into(), stamp: Time::from_nanos((stamp_s * 1e9) as i64) },
        wrench: RosWrench { force: Vector3 { x: f[0], y: f[1], z: f[2] }, torque: Vector3::default() },
    })
}

fn place(name: &str, xyz: [f64; 3], w: f64) -> Input {
    let mut m = WorldObject { name: name.into(), ..Default::default() };
    (m.pose.position.x, m.pose.position.y, m.pose.position.z) = (xyz[0], xyz[1], xyz[2]);
    m.pose.orientation.w = w;
    Input::PlaceObject(m)
}

/// A tall person standing behind the robot, facing the camera.
fn skeleton(t: f64) -> Skeleton {
    let p = Performer::new(7, BodySize::TALL, Stance::new(-0.6, -0.4, 0.0), 3)
        .expect("performer")
        .then(Action::Stand { duration: 5.0 })
        .expect("stand");
    p.pose(t).to_message(&MessageMeta {
        stamp: Time::from_nanos((t * 1e9) as i64),
        frame_id: "lwr_base_link",
        source: Skeleton::SOURCE_XSENS,
        person_id: 7,
        with_velocities: true,
    })
}

/// Runs `script` (s) through the loop at real-time pace for `duration_s` simulated seconds;
/// returns the JSON lines (`{"t": source clock, "out": output}`), the outputs, the summary.
fn play(lwr: &mut LwrSim, script: Vec<(f64, Input)>, duration_s: f64) -> (Vec<String>, Vec<Output>, RunSummary) {
    let mut source = ScriptedSource::new(script, 60.0);
    let clock = source.clock();
    let (mut lines, mut outputs) = (Vec::new(), Vec::new());
    let summary = run_loop(&mut source, lwr, Pacing::Rate(1.0), Some(duration_s), &mut |o| {
        lines.push(json_line(clock.now_s(), &o));
        outputs.push(o);
    });
    (lines, outputs, summary)
}

fn warnings(outputs: &[Output]) -> Vec<&cowork_ros::Warning> {
    outputs.iter().filter_map(|o| if let Output::Warning(w) = o { Some(w) } else { None }).collect()
}

fn joint_positions(outputs: &[Output]) -> Vec<Vec<f64>> {
    outputs.iter().filter_map(|o| if let Output::JointStates(_, m) = o { Some(m.position.clone()) } else { None }).collect()
}

/// Commands move the arm, the gripper closes and opens, a person appears in the depth
/// snapshots, a placement moves the bottle; every topic at its rate, stamped with sim time.
#[test]
fn commands_gripper_person_and_placement_golden() {
    let mut lwr = node();
    let v = [0.3, -0.2, 0.2, 0.4, -0.3, 0.2, 0.5];
    let script = vec![
        (0.0, velocity(v)),
        (0.05, velocity(v)),
        (0.1, Input::Skeleton(skeleton(0.1))),
        (0.2, gripper("close")),
        (0.25, place("bottle", [0.9, 0.0, 0.4], 1.0)),
        (0.3, gripper(" Open ")),
    ];
    let (lines, outputs, summary) = play(&mut lwr, script, 0.5);
    assert_eq!(summary.steps, 500);
    assert_eq!(summary.inputs, 6);
    assert!(warnings(&outputs).is_empty(), "{:?}", warnings(&outputs));
    let clocks: Vec<&Output> = outputs.iter().filter(|o| matches!(o, Output::Clock(_))).collect();
    assert_eq!(clocks.len(), 10, "/clock at 20 Hz of simulated time");
    let q = joint_positions(&outputs);
    assert_eq!(q.len(), 10);
    assert_ne!(q[0], q[2], "the command moves the arm");
    assert_eq!(q[8], q[9], "the arm is held after the command timed out");
    assert!(outputs.iter().any(|o| matches!(o, Output::Gripper { closed: true, .. })));
    assert!(outputs.iter().any(|o| matches!(o, Output::Gripper { closed: false, .. })));
    let people: Vec<usize> = outputs.iter().filter_map(|o| if let Output::Depth(s) = o { Some(s.people.len()) } else { None }).collect();
    assert_eq!(people.first(), Some(&0));
    assert!(people.iter().any(|n| *n > 0), "the person is drawn after the skeleton: {people:?}");
    let bottle_moved = outputs.iter().any(|o| {
        matches!(o, Output::World(_, w) if w.objects.iter().any(|b| b.name == "bottle" && (b.pose.position.x - 0.9).abs() < 1e-9))
    });
    assert!(bottle_moved, "/lwr/world shows the placed bottle");
    assert_golden(&golden("normal"), &lines);
}

/// Bad input of every kind: each is a warning naming the topic and field, none moves the
/// arm or the world, and the loop goes on.
#[test]
fn bad_inputs_golden() {
    let mut lwr = node();
    let script = vec![
        (0.0, velocity([f64::NAN; 7])),
        (0.01, Input::VelocityCommand(0, Float64MultiArray { data: vec![0.1; 3], ..Default::default() })),
        (0.02, gripper("grab it")),
        (0.03, gripper(&"x".repeat(100_000))),
        (0.04, push("no_such_frame", [50.0, 0.0, 0.0], 0.0)),
        (0.05, push("", [f64::INFINITY, 0.0, 0.0], 0.0)),
        (0.06, Input::Skeleton({
            let mut s = skeleton(0.06);
            let head = s.segment_names.iter().position(|n| n == "head").expect("head");
            s.segment_names.remove(head);
            s.poses.remove(head);
            s.velocities.remove(head);
            s
        })),
        (0.07, place("teapot", [0.5, 0.0, 0.3], 1.0)),
        (0.08, place("bottle", [0.5, 0.0, 0.3], 0.0)),
        (0.09, place(&"b".repeat(100_000), [0.5, 0.0, 0.3], 1.0)),
        (0.1, place("bottle", [f64::NAN, 0.0, 0.3], 1.0)),
    ];
    let world_before = lwr.world(0);
    let (lines, outputs, summary) = play(&mut lwr, script, 0.2);
    let kinds: Vec<&str> = warnings(&outputs).iter().map(|w| w.kind.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "/lwr/joint_velocity_command:data",
            "/lwr/joint_velocity_command:data",
            "/lwr/gripper_command:data",
            "/lwr/gripper_command:data",
            "/external_wrench:header.frame_id",
            "/external_wrench:wrench",
            "/human/skeleton:frame",
            "/lwr/place_object:object",
            "/lwr/place_object:pose.orientation",
            "/lwr/place_object:object",
            "/lwr/place_object:object",
        ]
    );
    assert_eq!(summary.warnings, 11);
    assert!(warnings(&outputs).iter().all(|w| w.message.len() < 1000), "peer text is quoted as a prefix");
    let q = joint_positions(&outputs);
    assert!(q.windows(2).all(|w| w[0] == w[1]), "nothing moved the arm");
    let world_after = lwr.world(0);
    for (a, b) in world_before.objects.iter().zip(&world_after.objects) {
        assert_eq!((&a.name, &a.pose), (&b.name, &b.pose), "refused placements change nothing");
    }
    assert_golden(&golden("bad_inputs"), &lines);
}

/// Execute mode: a push on lwr_link_4 renewed every 10 ms for 0.1 s does not move the arm and
/// is reported on `/lwr/external_wrench` (link frame) at 50 Hz until `wrench_timeout_s` after
/// the last one.
#[test]
fn execute_mode_reports_the_push_golden() {
    let mut lwr = node();
    lwr.set_wrench_mode(WrenchMode::Execute);
    let script: Vec<(f64, Input)> = (0..10).map(|k| (0.01 * k as f64, push("lwr_link_4", [0.0, 0.0, 20.0], 0.0))).collect();
    let (lines, outputs, _) = play(&mut lwr, script, 0.3);
    let reports: Vec<&WrenchStamped> =
        outputs.iter().filter_map(|o| if let Output::ExternalWrench(_, w) = o { Some(w) } else { None }).collect();
    assert!(reports.iter().all(|w| w.header.frame_id == "lwr_link_4"));
    let last = reports.last().expect("reports").header.stamp.to_secs_f64();
    assert!((0.18..=0.2).contains(&last), "reports end wrench_timeout_s after the last push: {last}");
    assert!((9..=10).contains(&reports.len()), "50 Hz for about 0.19 s: {}", reports.len());
    let q = joint_positions(&outputs);
    assert!(q.windows(2).all(|w| w[0] == w[1]), "the push does not move the arm in execute mode");
    assert_golden(&golden("execute_wrench"), &lines);
}

/// Following wrench stamps: simulated time never passes the newest stamp received; the
/// simulator holds until the next wrench arrives, then goes on at the same pace.
#[test]
fn following_wrench_stamps_holds_simulated_time() {
    let mut lwr = node();
    lwr.follow_wrench_stamps();
    let script = vec![(0.0, push("", [0.0, 0.0, 1.0], 0.1)), (0.3, push("", [0.0, 0.0, 1.0], 0.2))];
    let (lines, outputs, summary) = play(&mut lwr, script, 0.2);
    let clocks: Vec<(f64, f64)> = lines
        .iter()
        .zip(&outputs)
        .filter_map(|(l, o)| {
            let Output::Clock(c) = o else { return None };
            let t = serde_json::from_str::<serde_json::Value>(l).expect("json")["t"].as_f64().expect("t");
            Some((t, c.clock.to_secs_f64()))
        })
        .collect();
    // Until 0.1 s of sim time the sim runs at real time; then it holds until the second
    // wrench at 0.3 s of source time, and runs on at real time 0.2 s behind.
    for (t, sim) in &clocks {
        let lag = if *sim <= 0.1 + 1e-9 { 0.0 } else { 0.2 };
        assert!((t - sim - lag).abs() < 0.0015, "source {t} s, sim {sim} s: lag should be {lag} s");
    }
    assert_eq!(summary.steps, 200);
    assert_golden(&golden("follow_wrench_stamps"), &lines);
}
