//! Golden-file tests of the whole node loop ([`attentional_supervisor::run_loop`], the loop
//! `run` drives over DDS) on a mock clock: a recorded input script through
//! `cowork_testkit::ScriptedSource` → every output (actions, decisions, warnings, working
//! memory, learned LTM) as one JSON line, compared with `tests/golden/*.jsonl`
//! (`UPDATE_GOLDEN=1` rewrites them). Floats are rounded to 1e-6 so the files do not depend on
//! the last bit of the arithmetic.

use std::path::PathBuf;

use attentional_supervisor::{Input, Output, Params, RunSummary, SupervisorNode, run_loop};
use cowork_msgs::msg::{ActionEvent, ActionSegment, ObjectState, ObjectStream, RobotStream};
use cowork_msgs::std_msgs::String as RosString;
use cowork_supervisor::{Ltm, RunConfig, Supervisor, SupervisorConfig, parse_jsonl, runner};
use cowork_testkit::{ScriptedSource, assert_golden, json_line};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn golden(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden").join(format!("{name}.jsonl"))
}

fn kitchen() -> Ltm {
    Ltm::load(&root().join("config/tasks/kitchen.schema")).expect("kitchen LTM")
}

fn objects(list: &[(&str, f64, bool)]) -> Input {
    Input::ObjectStream(ObjectStream {
        objects: list
            .iter()
            .map(|(n, d, v)| ObjectState { name: (*n).into(), robot_distance: *d, visible: *v, ..Default::default() })
            .collect(),
        ..Default::default()
    })
}

fn speech(text: &str) -> Input {
    Input::Speech(RosString { data: text.into() })
}

fn robot(held: Option<&str>, done: &[&str], segments: &[(&str, u8)]) -> Input {
    Input::RobotStream(RobotStream {
        gripper_state: if held.is_some() { RobotStream::GRIPPER_CLOSED } else { RobotStream::GRIPPER_OPEN },
        held_object: held.unwrap_or("").into(),
        events: done.iter().map(|l| ActionEvent { label: (*l).into(), done: true, ..Default::default() }).collect(),
        segments: segments.iter().map(|(l, k)| ActionSegment { label: (*l).into(), kind: *k, ..Default::default() }).collect(),
        ..Default::default()
    })
}

/// Runs `script` (times in s) through the node loop until `end_s`; returns the JSON lines
/// (`{"t": node clock, "out": output}`), the outputs and the summary.
fn play(node: &mut SupervisorNode, script: Vec<(f64, Input)>, end_s: f64) -> (Vec<String>, Vec<Output>, RunSummary) {
    let mut source = ScriptedSource::new(script, end_s);
    let clock = source.clock();
    let mut lines = Vec::new();
    let mut outputs = Vec::new();
    let summary = run_loop(&mut source, node, &mut |o| {
        lines.push(json_line(clock.now_s(), &o));
        outputs.push(o);
    });
    (lines, outputs, summary)
}

fn actions(outputs: &[Output]) -> Vec<(String, bool)> {
    outputs
        .iter()
        .filter_map(|o| match o {
            Output::Action(c) => Some((c.label.clone(), c.stop)),
            _ => None,
        })
        .collect()
}

fn warnings(outputs: &[Output]) -> Vec<&cowork_ros::Warning> {
    outputs
        .iter()
        .filter_map(|o| match o {
            Output::Warning(w) => Some(w),
            _ => None,
        })
        .collect()
}

/// Pouring taught through `/robot_stream` segments and `/speech_command`, one second apart.
fn pour_teaching_script() -> Vec<(f64, Input)> {
    let (foa, noa, grip) = (ActionSegment::KIND_FOA, ActionSegment::KIND_NOA, ActionSegment::KIND_GRIPPER);
    vec![
        (0.0, objects(&[("water", 0.6, true), ("cup", 0.9, true)])),
        (0.0, robot(None, &[], &[])),
        (0.1, speech("teach")),
        (1.0, objects(&[("water", 0.1, true)])),
        (1.0, robot(None, &[], &[("foa1(water)", foa)])),
        (2.0, robot(None, &[], &[("noa2(water)", noa)])),
        (2.5, speech("gripper close")),
        (2.5, robot(Some("water"), &[], &[("close3(water)", grip)])),
        (3.0, robot(Some("water"), &[], &[("foa4(cup)", foa)])),
        (3.5, robot(Some("water"), &[], &[("noa5(cup)", noa)])),
        (4.0, robot(Some("water"), &[], &[("foa6(world)", foa)])),
        (4.5, robot(Some("water"), &[], &[("noa7(world)", noa)])),
        (5.0, speech("gripper open")),
        (5.0, robot(None, &[], &[("open8(world)", grip)])),
        (5.5, speech("done")),
    ]
}

const POUR: [&str; 8] =
    ["foa1(water)", "noa2(water)", "close3(water)", "foa4(cup)", "noa5(cup)", "foa6(world)", "noa7(world)", "open8(world)"];

/// The robot manager's side of executing `labels`: each action reported done `step_s` after
/// the previous one, from `start_s` (the gripper closes / opens with `close*` / `open*`).
fn executed(labels: &[&str], start_s: f64, step_s: f64) -> Vec<(f64, Input)> {
    let mut held: Option<String> = None;
    let mut script = Vec::new();
    for (i, l) in labels.iter().enumerate() {
        if l.starts_with("close") {
            held = l.split(['(', ')']).nth(1).map(str::to_owned);
        } else if l.starts_with("open") {
            held = None;
        }
        script.push((start_s + step_s * (i + 1) as f64, robot(held.as_deref(), &[l], &[])));
    }
    script
}

#[test]
fn teaching_pour_golden() {
    let params = Params { snapshot_rate_hz: 0.2, ..Params::default() };
    let sup = Supervisor::new(kitchen(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    let (lines, outputs, summary) = play(&mut node, pour_teaching_script(), 6.0);
    assert!(actions(&outputs).is_empty(), "nothing is commanded while teaching");
    assert!(warnings(&outputs).is_empty(), "{:?}", warnings(&outputs));
    let learned: Vec<&str> = outputs
        .iter()
        .filter_map(|o| match o {
            Output::Learned { ltm } => Some(ltm.as_str()),
            _ => None,
        })
        .collect();
    assert!(learned.last().is_some_and(|l| l.contains("open8(world)")), "the last learned LTM holds the whole demonstration");
    assert_eq!(summary.inputs, 15);
    assert!((600..=601).contains(&summary.ticks), "100 Hz from 0 to 6 s: {}", summary.ticks);
    // The same LTM as the library learns from the equivalent event script.
    let mut reference = Supervisor::new(kitchen(), "pourDrink", SupervisorConfig::default()).expect("task");
    let script = std::fs::read_to_string(root().join("nodes/lib/supervisor/tests/data/pour_teach.jsonl")).expect("script");
    runner::run(&mut reference, &parse_jsonl(&script).expect("script"), &RunConfig::default(), |_, _, _, _| {});
    assert_eq!(learned.last().copied(), Some(reference.ltm().to_text().as_str()));
    assert_golden(&golden("teach_pour"), &lines);
}

fn taught_pour() -> Ltm {
    let params = Params { snapshot_rate_hz: 0.0, ..Params::default() };
    let sup = Supervisor::new(kitchen(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    play(&mut node, pour_teaching_script(), 6.0);
    node.into_supervisor().ltm().clone()
}

#[test]
fn executing_pour_golden() {
    let params = Params { snapshot_rate_hz: 1.0, ..Params::default() };
    let sup = Supervisor::new(taught_pour(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    let mut script = vec![(0.05, robot(None, &[], &[])), (0.1, objects(&[("water", 0.6, true), ("cup", 0.9, true)]))];
    script.extend(executed(&POUR, 0.1, 0.1));
    let (lines, outputs, _) = play(&mut node, script, 1.2);
    let commanded: Vec<(String, bool)> = actions(&outputs);
    assert_eq!(commanded, POUR.iter().map(|l| ((*l).to_owned(), false)).collect::<Vec<_>>());
    assert!(warnings(&outputs).is_empty(), "{:?}", warnings(&outputs));
    assert!(node.supervisor().task_accomplished());
    // Nothing but working memory before the first /object_stream at 0.1 s.
    let first_action = outputs.iter().position(|o| matches!(o, Output::Action(_))).expect("an action");
    assert!(outputs[..first_action].iter().all(|o| matches!(o, Output::WorkingMemory(_))), "{:?}", &outputs[..first_action]);
    assert_golden(&golden("execute_pour"), &lines);
}

#[test]
fn cooperative_coffee_golden() {
    let mut teacher = Supervisor::new(kitchen(), "prepareCoffee", SupervisorConfig::default()).expect("task");
    let text = std::fs::read_to_string(root().join("nodes/lib/supervisor/tests/data/coffee_teach.jsonl")).expect("script");
    runner::run(&mut teacher, &parse_jsonl(&text).expect("script"), &RunConfig::default(), |_, _, _, _| {});
    let params = Params { snapshot_rate_hz: 0.0, ..Params::default() };
    let sup = Supervisor::new(teacher.ltm().clone(), "prepareCoffee", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    let mut script = vec![
        (0.0, objects(&[("water", 0.4, true), ("coffee", 0.8, true), ("spoon", 1.2, true), ("cup", 0.8, true)])),
        (0.0, robot(None, &[], &[])),
        // The person takes the bottle: it is no longer seen; the robot switches to coffee.
        (0.055, objects(&[("water", f64::NAN, false)])),
        (0.105, speech("human add(water)")),
    ];
    script.extend(executed(
        &["foa9(coffee)", "noa10(coffee)", "close11(coffee)", "foa12(cup)", "noa13(cup)", "foa14(world)", "noa15(world)", "open16(world)"],
        0.105,
        0.1,
    ));
    let (lines, outputs, _) = play(&mut node, script, 1.2);
    let commanded = actions(&outputs);
    assert_eq!(commanded[0], ("foa1(water)".to_owned(), false));
    assert!(commanded.iter().any(|(l, stop)| l == "foa9(coffee)" && !stop), "{commanded:?}");
    assert_eq!(commanded.last().map(|(l, _)| l.as_str()), Some("open16(world)"));
    assert!(
        !commanded.iter().skip(1).any(|(l, stop)| !stop && l.contains("(water)")),
        "the robot is never sent to water after the switch: {commanded:?}"
    );
    assert!(outputs.iter().any(|o| matches!(o, Output::Decision(cowork_supervisor::Decision::HumanAssigned { .. }))));
    assert!(warnings(&outputs).is_empty(), "{:?}", warnings(&outputs));
    assert_golden(&golden("cooperative_coffee"), &lines);
}

/// Bad input of every kind: each is a warning naming the topic / field, the good part of the
/// same messages still drives the decision, `stop` aborts with the command's id, `repeat`
/// resumes, and nothing is decided before the first `/object_stream`.
#[test]
fn bad_inputs_golden() {
    let params = Params { snapshot_rate_hz: 0.0, ..Params::default() };
    let sup = Supervisor::new(taught_pour(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    let mut bad_robot = robot(None, &["foa99(water)"], &[("x1", 9)]);
    if let Input::RobotStream(m) = &mut bad_robot {
        m.gripper_state = 5;
    }
    let script = vec![
        (0.0, speech("make me a sandwich")),
        (0.0, bad_robot),
        (0.02, speech(&"teach ".repeat(200_000))),
        (0.05, objects(&[("water", f64::NAN, true), ("teapot", 0.3, true), ("cup", f64::INFINITY, true)])),
        (0.1, objects(&[("water", 0.6, true), ("cup", 0.9, true)])),
        (0.2, speech("stop")),
        (0.3, speech("repeat")),
        (0.4, robot(None, &["noa2(water)"], &[])),
        (0.5, robot(Some(""), &[], &[])),
        (0.5, speech("")),
    ];
    let (lines, outputs, summary) = play(&mut node, script, 0.6);
    let w = warnings(&outputs);
    let kinds: Vec<&str> = w.iter().map(|w| w.kind.as_str()).collect();
    for kind in [
        "supervisor:unknown_speech",
        "/robot_stream:segments.kind",
        "/robot_stream:gripper_state",
        "supervisor:unexpected_action_event",
        "supervisor:non_finite",
        "supervisor:unknown_object",
    ] {
        assert!(kinds.contains(&kind), "{kind} missing from {kinds:?}");
    }
    assert!(w.iter().all(|w| w.message.len() < 2 * attentional_supervisor::MAX_WARNING_CHARS), "warnings are bounded");
    assert_eq!(summary.warnings as usize, w.len());
    assert_eq!(node.warnings() as usize, w.len());
    let commanded = actions(&outputs);
    assert_eq!(commanded.first(), Some(&("foa1(water)".to_owned(), false)), "{commanded:?}");
    assert!(commanded.contains(&("foa1(water)".to_owned(), true)), "stop aborts: {commanded:?}");
    let ids: Vec<u32> = outputs.iter().filter_map(|o| if let Output::Action(c) = o { Some(c.id) } else { None }).collect();
    assert_eq!(ids[0], ids[1], "the abort names the aborted command's id");
    assert!(ids[2] > ids[0], "a resumed action is a new command");
    assert_golden(&golden("bad_inputs"), &lines);
}

/// A flood of distinct unknown words is one warning kind (the limiter's key never holds peer
/// text), and each message is a bounded prefix.
#[test]
fn a_flood_of_distinct_bad_words_is_one_warning_kind() {
    let params = Params { wait_for_object_stream: false, snapshot_rate_hz: 0.0, ..Params::default() };
    let sup = Supervisor::new(kitchen(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    let big = "x".repeat(100_000);
    let script: Vec<(f64, Input)> = (0..5000).map(|i| (i as f64 * 1e-4, speech(&format!("sandwich {i} {big}")))).collect();
    let (_, outputs, _) = play(&mut node, script, 0.6);
    let w = warnings(&outputs);
    assert_eq!(w.len(), 5000);
    let mut kinds: Vec<&str> = w.iter().map(|w| w.kind.as_str()).collect();
    kinds.dedup();
    assert_eq!(kinds, ["supervisor:unknown_speech"]);
    assert!(w.iter().all(|w| w.message.len() < 2 * attentional_supervisor::MAX_WARNING_CHARS));
}
