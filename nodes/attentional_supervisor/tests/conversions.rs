//! Message ↔ library conversions and the node adapter on a mock clock, without a network.

use std::path::PathBuf;

use attentional_supervisor::{
    CommandTracker, Pacer, Params, RobotStreamDecoder, SupervisorNode, action_kind, kind_code, objects_event,
    speech_event, working_memory,
};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{ActionCommand, ActionEvent, ActionSegment, ObjectState, ObjectStream, RobotStream, WmNode};
use cowork_msgs::std_msgs::String as RosString;
use cowork_supervisor::{
    ActionKind, Decision, Event, GripperState, Ltm, RunConfig, SimRobot, Supervisor, SupervisorConfig, parse_jsonl,
    runner,
};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn kitchen() -> Ltm {
    Ltm::load(&root().join("config/tasks/kitchen.schema")).expect("kitchen LTM")
}

fn script(name: &str) -> Vec<cowork_supervisor::TimedEvent> {
    let p = root().join("nodes/lib/supervisor/tests/data").join(name);
    parse_jsonl(&std::fs::read_to_string(&p).expect("script")).expect("valid script")
}

fn obj(name: &str, d: f64, visible: bool) -> ObjectState {
    ObjectState { name: name.into(), robot_distance: d, visible, ..Default::default() }
}

fn objects(list: &[(&str, f64)]) -> ObjectStream {
    ObjectStream { objects: list.iter().map(|(n, d)| obj(n, *d, true)).collect(), ..Default::default() }
}

fn speech(text: &str) -> RosString {
    RosString { data: text.into() }
}

fn robot(gripper_closed_on: Option<&str>, done: &[&str], segments: &[(&str, u8)]) -> RobotStream {
    RobotStream {
        gripper_state: if gripper_closed_on.is_some() {
            RobotStream::GRIPPER_CLOSED
        } else {
            RobotStream::GRIPPER_OPEN
        },
        held_object: gripper_closed_on.unwrap_or("").into(),
        events: done.iter().map(|l| ActionEvent { label: (*l).into(), kind: 0, command_id: 0, done: true, ..Default::default() }).collect(),
        segments: segments
            .iter()
            .map(|(l, k)| ActionSegment { label: (*l).into(), kind: *k, ..Default::default() })
            .collect(),
        ..Default::default()
    }
}

fn t(s: f64) -> Time {
    Time::from_secs_f64(s)
}

#[test]
fn object_stream_becomes_an_objects_event() {
    let msg = ObjectStream {
        objects: vec![obj("water", 0.4, true), obj("cup", f64::NAN, false), obj("coffee", f64::NAN, true)],
        ..Default::default()
    };
    let Event::Objects { objects } = objects_event(&msg) else { panic!("not an objects event") };
    assert_eq!(objects.len(), 3);
    assert_eq!(objects[0].name, "water");
    assert_eq!(objects[0].distance, Some(0.4));
    assert!(objects[0].visible);
    // Unseen with unknown distance: visibility only.
    assert_eq!(objects[1].distance, None);
    assert!(!objects[1].visible);
    // Seen with a NaN distance: passed on for the library to reject.
    assert!(objects[2].distance.is_some_and(f64::is_nan));
    assert_eq!(speech_event(&speech("human add(water)")), Event::Speech { text: "human add(water)".into() });
}

#[test]
fn action_kinds_round_trip() {
    for k in [ActionKind::Noa, ActionKind::Foa, ActionKind::Gripper] {
        assert_eq!(action_kind(kind_code(k)), Some(k));
    }
    assert_eq!(kind_code(ActionKind::Foa), ActionSegment::KIND_FOA);
    assert_eq!(action_kind(3), None);
}

#[test]
fn robot_stream_becomes_edge_events_in_order() {
    let mut dec = RobotStreamDecoder::default();
    let mut ev = Vec::new();
    let mut problems = Vec::new();

    dec.decode(&robot(None, &[], &[]), &mut ev, &mut problems);
    assert_eq!(ev, vec![Event::Gripper { arm: None, state: GripperState::Open, object: None }]);
    ev.clear();
    dec.decode(&robot(None, &[], &[]), &mut ev, &mut problems);
    assert!(ev.is_empty(), "an unchanged gripper is not reported again: {ev:?}");

    // A started event carries nothing; done events, then segments, then the new gripper state.
    let mut msg = robot(Some("water"), &["close3(water)"], &[("close3", ActionSegment::KIND_GRIPPER)]);
    msg.events.insert(0, ActionEvent { label: "foa4(cup)".into(), kind: 1, command_id: 4, done: false, ..Default::default() });
    msg.segments[0].object_name = "water".into();
    dec.decode(&msg, &mut ev, &mut problems);
    assert_eq!(
        ev,
        vec![
            Event::ActionDone { arm: None, label: "close3(water)".into() },
            Event::Segment {
                arm: None,
                label: "close3".into(),
                kind: ActionKind::Gripper,
                object: Some("water".into())
            },
            Event::Gripper { arm: None, state: GripperState::Close, object: Some("water".into()) },
        ]
    );
    ev.clear();
    dec.decode(&robot(Some("water"), &[], &[]), &mut ev, &mut problems);
    assert!(ev.is_empty());
    // Closed on nothing, then open.
    dec.decode(&robot(Some(""), &[], &[]), &mut ev, &mut problems);
    dec.decode(&robot(None, &[], &[]), &mut ev, &mut problems);
    assert_eq!(
        ev,
        vec![
            Event::Gripper { arm: None, state: GripperState::Close, object: None },
            Event::Gripper { arm: None, state: GripperState::Open, object: None },
        ]
    );
    assert!(problems.is_empty());

    // Bad kind and bad gripper state: reported, the rest still decoded.
    ev.clear();
    let mut bad = robot(None, &["noa2(water)"], &[("x1", 9), ("foa2", ActionSegment::KIND_FOA)]);
    bad.gripper_state = 7;
    dec.decode(&bad, &mut ev, &mut problems);
    assert_eq!(problems.len(), 2, "{problems:?}");
    assert!(problems[0].contains("unknown kind 9"), "{}", problems[0]);
    assert!(problems[1].contains("gripper_state 7"), "{}", problems[1]);
    assert_eq!(ev.len(), 2, "{ev:?}");
}

#[test]
fn decisions_become_action_commands() {
    let mut tr = CommandTracker::default();
    let action = Decision::Action {
        id: 7,
        arm: None,
        label: "foa1(water)".into(),
        kind: ActionKind::Foa,
        subtask: "subtask(take,water)".into(),
        releaser: "true".into(),
        emphasis: 2.0,
    };
    let c = tr.command(&action, t(1.5)).expect("a command");
    assert_eq!(
        c,
        ActionCommand {
            header: cowork_msgs::std_msgs::Header { stamp: t(1.5), frame_id: String::new() },
            id: 7,
            label: "foa1(water)".into(),
            arm: String::new(),
            stop: false
        }
    );
    let stop = Decision::Stop { arm: None, label: "foa1(water)".into(), reason: "stop".into() };
    let s = tr.command(&stop, t(2.0)).expect("a stop");
    assert!(s.stop);
    assert_eq!((s.id, s.label.as_str(), s.header.stamp), (7, "foa1(water)", t(2.0)));
    // A second stop for the same arm no longer knows the id.
    assert_eq!(tr.command(&stop, t(2.1)).map(|c| c.id), Some(0));
    let dual = Decision::Action {
        id: 9,
        arm: Some("left".into()),
        label: "foa1(dough)".into(),
        kind: ActionKind::Foa,
        subtask: "s".into(),
        releaser: "true".into(),
        emphasis: 1.0,
    };
    assert_eq!(tr.command(&dual, t(3.0)).map(|c| c.arm), Some("left".into()));
    assert!(tr.command(&Decision::HumanAssigned { subtask: "add(water)".into() }, t(3.0)).is_none());
    assert!(tr.command(&Decision::Accomplished { behaviour: "x".into() }, t(3.0)).is_none());
}

/// Teaching the pouring task through messages learns exactly what the library learns from the
/// equivalent JSON-lines script (`pour_teach.jsonl`).
fn teach_pour_through_messages(node: &mut SupervisorNode) {
    let mut out = Vec::new();
    let mut now = 0.0;
    let mut tick = |node: &mut SupervisorNode, out: &mut Vec<ActionCommand>| {
        now += 0.01;
        node.tick(t(now), out);
    };
    node.on_object_stream(&objects(&[("water", 0.6), ("cup", 0.9)]));
    node.on_robot_stream(&robot(None, &[], &[]));
    tick(node, &mut out);
    node.on_speech(&speech("teach"));
    tick(node, &mut out);
    node.on_object_stream(&objects(&[("water", 0.1)]));
    node.on_robot_stream(&robot(None, &[], &[("foa1(water)", ActionSegment::KIND_FOA)]));
    tick(node, &mut out);
    node.on_robot_stream(&robot(None, &[], &[("noa2(water)", ActionSegment::KIND_NOA)]));
    tick(node, &mut out);
    node.on_speech(&speech("gripper close"));
    node.on_robot_stream(&robot(Some("water"), &[], &[("close3(water)", ActionSegment::KIND_GRIPPER)]));
    tick(node, &mut out);
    for (l, k) in [("foa4(cup)", 1), ("noa5(cup)", 0), ("foa6(world)", 1), ("noa7(world)", 0)] {
        node.on_robot_stream(&robot(Some("water"), &[], &[(l, k)]));
        tick(node, &mut out);
    }
    node.on_speech(&speech("gripper open"));
    node.on_robot_stream(&robot(None, &[], &[("open8(world)", ActionSegment::KIND_GRIPPER)]));
    tick(node, &mut out);
    node.on_speech(&speech("done"));
    tick(node, &mut out);
    assert!(out.is_empty(), "nothing is commanded while teaching: {out:?}");
}

#[test]
fn teaching_through_messages_learns_what_the_script_teaches() {
    let params = Params::default();
    let sup = Supervisor::new(kitchen(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    teach_pour_through_messages(&mut node);
    assert_eq!(node.warnings(), 0);
    let learned = node.into_supervisor();

    let mut reference = Supervisor::new(kitchen(), "pourDrink", SupervisorConfig::default()).expect("task");
    runner::run(&mut reference, &script("pour_teach.jsonl"), &RunConfig::default(), |_, _, _, _| {});
    assert!(learned.ltm_changed());
    assert_eq!(learned.ltm().to_text(), reference.ltm().to_text());
    assert!(learned.ltm().to_text().contains("open8(world)"));
}

/// Plays the robot manager: completes every commanded action one tick after it was commanded
/// (gripper actions `close*`/`open*` also close/open the gripper). Returns the commands.
/// `running` is an action commanded before.
fn execute(node: &mut SupervisorNode, running: Option<&str>, start_s: f64, ticks: usize) -> Vec<ActionCommand> {
    let mut all = Vec::new();
    let mut out = Vec::new();
    let mut held: Option<String> = None;
    let mut done: Vec<String> = running.map(str::to_owned).into_iter().collect();
    for k in 0..ticks {
        let label = done.pop();
        if let Some(l) = &label {
            if l.starts_with("close") {
                held = l.split(['(', ')']).nth(1).map(str::to_owned);
            } else if l.starts_with("open") {
                held = None;
            }
        }
        let labels: Vec<&str> = label.iter().map(String::as_str).collect();
        node.on_robot_stream(&robot(held.as_deref(), &labels, &[]));
        out.clear();
        node.tick(t(start_s + k as f64 * 0.01), &mut out);
        for c in &out {
            if !c.stop {
                done.push(c.label.clone());
            }
        }
        all.extend(out.iter().cloned());
    }
    all
}

/// The LTM after pourDrink was taught through messages.
fn taught_pour(params: &Params) -> Ltm {
    let sup = Supervisor::new(kitchen(), "pourDrink", params.attention.clone()).expect("task");
    let mut teacher = SupervisorNode::new(sup, params);
    teach_pour_through_messages(&mut teacher);
    teacher.into_supervisor().ltm().clone()
}

#[test]
fn executing_the_taught_pouring_commands_the_demonstrated_sequence() {
    let params = Params::default();
    let ltm = taught_pour(&params);

    let sup = Supervisor::new(ltm.clone(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    let mut out = Vec::new();
    node.tick(t(0.0), &mut out);
    assert!(!node.ready() && out.is_empty(), "waits for the first /object_stream");
    node.on_object_stream(&objects(&[("water", 0.6), ("cup", 0.9)]));
    let cmds = execute(&mut node, None, 0.01, 40);
    let labels: Vec<&str> = cmds.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "foa1(water)",
            "noa2(water)",
            "close3(water)",
            "foa4(cup)",
            "noa5(cup)",
            "foa6(world)",
            "noa7(world)",
            "open8(world)"
        ]
    );
    assert!(cmds.iter().all(|c| !c.stop));
    let ids: Vec<u32> = cmds.iter().map(|c| c.id).collect();
    assert_eq!(ids, (1..=8).collect::<Vec<_>>());
    assert!(node.supervisor().task_accomplished());
    assert_eq!(node.warnings(), 0);

    // Same sequence as the library's script runner with a simulated robot manager.
    let mut reference = Supervisor::new(ltm, "pourDrink", SupervisorConfig::default()).expect("task");
    let cfg = RunConfig { robot: Some(SimRobot { action_duration_s: 0.05 }), ..RunConfig::default() };
    let rep = runner::run(&mut reference, &script("pour_execute.jsonl"), &cfg, |_, _, _, _| {});
    assert_eq!(rep.actions(), labels);
}

#[test]
fn cooperative_coffee_replans_in_the_tick_of_the_stimulus() {
    let mut teacher = Supervisor::new(kitchen(), "prepareCoffee", SupervisorConfig::default()).expect("task");
    runner::run(&mut teacher, &script("coffee_teach.jsonl"), &RunConfig::default(), |_, _, _, _| {});
    let params = Params::default();
    let sup = Supervisor::new(teacher.ltm().clone(), "prepareCoffee", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    node.on_object_stream(&objects(&[("water", 0.4), ("coffee", 0.8), ("spoon", 1.2), ("cup", 0.8)]));
    node.on_robot_stream(&robot(None, &[], &[]));
    let mut out = Vec::new();
    node.tick(t(0.0), &mut out);
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].label, "foa1(water)");
    // The person takes the bottle: the next tick aborts/replaces the water action.
    out.clear();
    node.on_object_stream(&ObjectStream { objects: vec![obj("water", f64::NAN, false)], ..Default::default() });
    node.tick(t(0.01), &mut out);
    let labels: Vec<(&str, bool)> = out.iter().map(|c| (c.label.as_str(), c.stop)).collect();
    assert_eq!(labels.last(), Some(&("foa9(coffee)", false)), "{labels:?}");
    node.on_speech(&speech("human add(water)"));
    out.clear();
    node.tick(t(0.02), &mut out);
    assert!(out.is_empty(), "{out:?}");
    assert!(node.decisions().iter().any(|d| matches!(d, Decision::HumanAssigned { .. })));
    let wm = node.working_memory(t(0.02));
    let water = wm.nodes.iter().find(|n| n.name == "add(water)").expect("add(water) allocated");
    assert_eq!(water.assigned_to, WmNode::ASSIGNED_HUMAN);
    let running = wm.nodes.iter().find(|n| n.name == "foa9(coffee)").expect("foa9 allocated");
    assert_eq!(running.assigned_to, WmNode::ASSIGNED_ROBOT);
    assert_eq!(wm.header.stamp, t(0.02));
    // The rest of add(coffee) runs; use(spoon) waits for water.added (the person's part).
    let rest = execute(&mut node, Some("foa9(coffee)"), 0.03, 60);
    let labels: Vec<&str> = rest.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "noa10(coffee)",
            "close11(coffee)",
            "foa12(cup)",
            "noa13(cup)",
            "foa14(world)",
            "noa15(world)",
            "open16(world)"
        ]
    );
    assert!(!node.supervisor().task_accomplished());
}

#[test]
fn working_memory_message_mirrors_the_snapshot() {
    let params = Params::default();
    let sup = Supervisor::new(kitchen(), "prepareCoffee", params.attention.clone()).expect("task");
    let snap = sup.snapshot();
    let msg = working_memory(&snap, t(4.0));
    assert_eq!(msg.nodes.len(), snap.nodes.len());
    assert_eq!(msg.nodes[0].parent, -1);
    for (m, s) in msg.nodes.iter().zip(&snap.nodes) {
        assert_eq!((m.id, m.parent, &m.name, m.emphasis, m.period), (s.id, s.parent, &s.name, s.emphasis, s.period));
        assert!(m.parent < msg.nodes.len() as i32);
    }
    assert!(msg.nodes.iter().any(|n| n.name == "prepareCoffee"));
    assert!(msg.true_variables.contains(&"hand.free".to_owned()));
}

#[test]
fn bad_messages_warn_and_the_loop_goes_on() {
    let mut teacher = Supervisor::new(kitchen(), "prepareCoffee", SupervisorConfig::default()).expect("task");
    runner::run(&mut teacher, &script("coffee_teach.jsonl"), &RunConfig::default(), |_, _, _, _| {});
    let params = Params::default();
    let sup = Supervisor::new(teacher.ltm().clone(), "prepareCoffee", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    let mut out = Vec::new();
    node.on_speech(&speech("make me a sandwich"));
    node.on_object_stream(&ObjectStream {
        objects: vec![obj("water", f64::NAN, true), obj("teapot", 0.3, true), obj("coffee", 0.3, true)],
        ..Default::default()
    });
    let mut bad = robot(None, &["foa99(water)"], &[]);
    bad.gripper_state = 5;
    node.on_robot_stream(&bad);
    node.tick(t(0.0), &mut out);
    let warnings: Vec<String> = node
        .decisions()
        .iter()
        .filter_map(|d| match d {
            Decision::Warning { message, .. } => Some(message.clone()),
            _ => None,
        })
        .collect();
    assert!(warnings.iter().any(|w| w.contains("sandwich")), "{warnings:?}");
    assert!(warnings.iter().any(|w| w.contains("non-finite")), "{warnings:?}");
    assert!(warnings.iter().any(|w| w.contains("teapot")), "{warnings:?}");
    assert!(warnings.iter().any(|w| w.contains("foa99(water)")), "{warnings:?}");
    assert_eq!(node.problems().len(), 1, "{:?}", node.problems());
    assert_eq!(node.warnings(), 5);
    // The good part of the same messages still drives the decision: coffee is the only
    // object with a distance, so add(coffee) starts.
    assert_eq!(out.iter().map(|c| c.label.as_str()).collect::<Vec<_>>(), ["foa9(coffee)"]);
}

#[test]
fn shutdown_aborts_the_running_action() {
    let mut teacher = Supervisor::new(kitchen(), "pourDrink", SupervisorConfig::default()).expect("task");
    runner::run(&mut teacher, &script("pour_teach.jsonl"), &RunConfig::default(), |_, _, _, _| {});
    let params = Params { wait_for_object_stream: false, ..Params::default() };
    let sup = Supervisor::new(teacher.ltm().clone(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    assert!(node.ready());
    let mut out = Vec::new();
    node.tick(t(0.0), &mut out);
    assert_eq!(out.len(), 1);
    let stops = node.shutdown_commands(t(0.5));
    assert_eq!(stops.len(), 1);
    assert!(stops[0].stop);
    assert_eq!((stops[0].id, stops[0].label.as_str()), (out[0].id, "foa1(water)"));
}

#[test]
fn learned_ltm_is_saved_only_when_changed() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("learned.schema");
    let params = Params::default();
    let sup = Supervisor::new(kitchen(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    assert!(!node.save_ltm_if_changed(&path).expect("nothing to save"));
    assert!(!path.exists());
    teach_pour_through_messages(&mut node);
    assert!(node.save_ltm_if_changed(&path).expect("saved"));
    assert!(!node.save_ltm_if_changed(&path).expect("already saved"));
    let back = Ltm::load(&path).expect("reload");
    assert_eq!(back.to_text(), node.supervisor().ltm().to_text());
}

#[test]
fn parameter_file_holds_the_defaults_and_bad_values_are_rejected() {
    let file = root().join("config/attentional_supervisor.yaml");
    let p: Params = cowork_ros::params::load(&file, "attentional_supervisor").expect("parameter file");
    assert_eq!(p, Params::default());
    p.validate("file").expect("defaults are valid");
    assert_eq!(p.attention, SupervisorConfig::default());
    assert_eq!((p.tick_rate_hz, p.snapshot_rate_hz), (100.0, 10.0));

    let unknown = "attentional_supervisor:\n  ros__parameters:\n    tick_rate: 100.0\n";
    let e =
        cowork_ros::params::from_str::<Params>(unknown, "attentional_supervisor", "x.yaml").expect_err("unknown key");
    assert!(e.to_string().contains("tick_rate"), "{e}");
    let nested = "attentional_supervisor:\n  ros__parameters:\n    attention:\n      lambda_mn_s: 0.1\n";
    assert!(cowork_ros::params::from_str::<Params>(nested, "attentional_supervisor", "x.yaml").is_err());

    for bad in [
        Params { tick_rate_hz: f64::NAN, ..Params::default() },
        Params { tick_rate_hz: 0.0, ..Params::default() },
        Params { snapshot_rate_hz: 200.0, ..Params::default() },
        Params { snapshot_rate_hz: -1.0, ..Params::default() },
        Params {
            attention: SupervisorConfig { lambda_min_s: f64::NAN, ..SupervisorConfig::default() },
            ..Params::default()
        },
        Params { attention: SupervisorConfig { r_max_m: -1.0, ..SupervisorConfig::default() }, ..Params::default() },
    ] {
        let e = bad.validate("cfg.yaml").expect_err("rejected");
        assert!(e.to_string().starts_with("cfg.yaml:"), "{e}");
    }
    assert!(Params { snapshot_rate_hz: 0.0, ..Params::default() }.validate("x").is_ok());
}

#[test]
fn pacer_keeps_a_steady_grid_and_restarts_on_jumps() {
    let mut p = Pacer::new(0.01);
    assert!(p.due(5.0));
    assert!(!p.due(5.004));
    assert!((p.wait_s(5.004) - 0.006).abs() < 1e-9);
    assert!(p.due(5.0105)); // late by 0.5 ms: the grid stays at 5.02
    assert!(!p.due(5.0199));
    assert!(p.due(5.02));
    // Sim time leaps 1 s ahead: one tick, not a burst of 100.
    assert!(p.due(6.03));
    assert!(!p.due(6.031));
    assert!(p.due(6.04));
    // Time goes back (a looped bag): restart at once.
    assert!(p.due(1.0));
    assert!(!p.due(1.001));
    assert!(p.due(1.01));
}

#[test]
fn stop_aborts_with_the_command_id_and_repeat_resumes() {
    let mut teacher = Supervisor::new(kitchen(), "pourDrink", SupervisorConfig::default()).expect("task");
    runner::run(&mut teacher, &script("pour_teach.jsonl"), &RunConfig::default(), |_, _, _, _| {});
    let params = Params::default();
    let sup = Supervisor::new(teacher.ltm().clone(), "pourDrink", params.attention.clone()).expect("task");
    let mut node = SupervisorNode::new(sup, &params);
    node.on_object_stream(&objects(&[("water", 0.6), ("cup", 0.9)]));
    let mut out = Vec::new();
    node.tick(t(0.0), &mut out);
    assert_eq!(out.len(), 1);
    let first = out[0].clone();
    out.clear();
    node.on_speech(&speech("stop"));
    node.tick(t(0.01), &mut out);
    assert_eq!(out.len(), 1, "{out:?}");
    assert!(out[0].stop);
    assert_eq!((out[0].id, out[0].label.as_str()), (first.id, "foa1(water)"));
    out.clear();
    node.tick(t(0.02), &mut out);
    assert!(out.is_empty(), "stopped: nothing new is commanded: {out:?}");
    assert!(node.shutdown_commands(t(0.02)).is_empty(), "nothing running after a stop");
    node.on_speech(&speech("repeat"));
    node.tick(t(0.03), &mut out);
    assert_eq!(out.len(), 1, "{out:?}");
    assert!(!out[0].stop);
    assert_eq!(out[0].label, "foa1(water)");
    assert!(out[0].id > first.id, "a resumed action is a new command");
}

#[test]
fn a_failed_action_event_becomes_action_failed_with_its_reason() {
    let mut msg = robot(None, &[], &[]);
    msg.events.push(ActionEvent {
        label: "foa9(water)".into(),
        kind: 1,
        command_id: 3,
        failed: true,
        reason: "no primitive `foa9`".into(),
        ..Default::default()
    });
    let (mut events, mut problems) = (Vec::new(), Vec::new());
    RobotStreamDecoder::default().decode(&msg, &mut events, &mut problems);
    assert!(problems.is_empty(), "{problems:?}");
    assert_eq!(
        events[0],
        Event::ActionFailed { arm: None, label: "foa9(water)".into(), reason: "no primitive `foa9`".into() }
    );
}

/// A command the robot manager never answers (its reader matched after it was sent) is sent
/// again every `action_resend_s` with a warning, at most 5 times; a "started" event of its id
/// ends that.
#[test]
fn an_unanswered_action_command_is_sent_again() {
    let params = Params::default();
    let ltm = taught_pour(&params);
    let executing = || {
        let mut node = SupervisorNode::new(Supervisor::new(ltm.clone(), "pourDrink", params.attention.clone()).expect("task"), &params);
        node.on_object_stream(&objects(&[("water", 0.6), ("cup", 0.9)]));
        node
    };
    let mut node = executing();
    let mut all = Vec::new();
    let mut out = Vec::new();
    for k in 0..1000 {
        out.clear();
        node.tick(t(k as f64 * 0.01), &mut out);
        all.extend(out.iter().cloned());
    }
    let first = all.first().cloned().expect("an action is commanded");
    assert!(all.iter().all(|c| c.id == first.id && c.label == first.label && !c.stop), "the same command: {all:?}");
    assert_eq!(all.len(), 6, "sent once and again 5 times, 1 s apart: {all:?}");
    assert_eq!(node.warnings(), 6, "each resend and the giving up warned");

    // Answered by a started event of its id: not sent again.
    let mut node = executing();
    let mut all = Vec::new();
    for k in 0..500 {
        out.clear();
        node.tick(t(k as f64 * 0.01), &mut out);
        if let Some(c) = out.first() {
            let started = ActionEvent { label: c.label.clone(), command_id: c.id, ..Default::default() };
            node.on_robot_stream(&RobotStream { events: vec![started], ..Default::default() });
        }
        all.extend(out.iter().cloned());
    }
    assert_eq!(all.len(), 1, "{all:?}");
    assert_eq!(node.warnings(), 0);
}

/// A robot manager killed and restarted (or stopped and continued) in the middle of an action
/// starts over without it: when its robot stream comes back after a silence longer than
/// `action_resend_s`, the running action is sent again, once, with a warning. A stream that
/// never paused, or a silence after the action was done, sends nothing.
#[test]
fn the_running_action_is_sent_again_when_the_robot_stream_comes_back() {
    let params = Params::default();
    let ltm = taught_pour(&params);
    let mut node = SupervisorNode::new(Supervisor::new(ltm, "pourDrink", params.attention.clone()).expect("task"), &params);
    node.on_object_stream(&objects(&[("water", 0.6), ("cup", 0.9)]));
    let mut out = Vec::new();
    let mut sent = Vec::new();
    // The manager starts the first action and streams at 30 Hz for 2 s.
    let mut first = None;
    for k in 0..200 {
        let now = k as f64 * 0.01;
        out.clear();
        node.tick(t(now), &mut out);
        if let Some(c) = out.first() {
            first.get_or_insert_with(|| c.clone());
        }
        sent.extend(out.iter().cloned());
        if let Some(c) = &first
            && k % 3 == 0
        {
            let started = if k < 5 { vec![ActionEvent { label: c.label.clone(), command_id: c.id, ..Default::default() }] } else { vec![] };
            node.on_robot_stream(&RobotStream { events: started, ..Default::default() });
        }
    }
    let first = first.expect("an action is commanded");
    assert_eq!(sent.len(), 1, "{sent:?}");
    assert_eq!(node.warnings(), 0);
    // Killed: 2.5 s without a stream, then the restarted manager streams again, idle.
    for k in 200..450 {
        out.clear();
        node.tick(t(k as f64 * 0.01), &mut out);
        assert!(out.is_empty(), "nothing while the manager is gone: {out:?}");
    }
    node.on_robot_stream(&RobotStream::default());
    out.clear();
    node.tick(t(4.5), &mut out);
    assert_eq!(out.len(), 1, "{out:?}");
    assert_eq!((out[0].id, out[0].label.as_str(), out[0].stop), (first.id, first.label.as_str(), false));
    assert_eq!(node.warnings(), 1);
    // It streams on and starts the action: nothing more.
    let started = ActionEvent { label: first.label.clone(), command_id: first.id, ..Default::default() };
    node.on_robot_stream(&RobotStream { events: vec![started], ..Default::default() });
    for k in 451..700 {
        out.clear();
        node.tick(t(k as f64 * 0.01), &mut out);
        assert!(out.is_empty(), "{out:?}");
        if k % 3 == 0 {
            node.on_robot_stream(&RobotStream::default());
        }
    }
    // The action is done; the next one starts. A silence after a done action sends nothing
    // again but what the supervisor decides next.
    let done = ActionEvent { label: first.label.clone(), command_id: first.id, done: true, ..Default::default() };
    node.on_robot_stream(&RobotStream { events: vec![done], ..Default::default() });
    out.clear();
    node.tick(t(7.0), &mut out);
    assert_eq!(out.len(), 1, "the next action: {out:?}");
    assert_ne!(out[0].label, first.label);
    assert_eq!(node.warnings(), 1);
}
