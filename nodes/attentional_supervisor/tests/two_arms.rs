//! The node driving two arms (thesis Sec. 4.3.4, 5.2.4) message by message, without a
//! network: each arm's `/<arm>/robot_stream` and `/<arm>/object_stream` (poses in that arm's
//! base frame), the arm bases on `/tf_static` as lwr_sim publishes them for
//! `config/scenes/pizza.yaml`, and the bundled `config/tasks/pizza.schema`.

mod common;

use attentional_supervisor::{
    AreaParams, CommandTracker, Input, Output, Params, RobotStreamDecoder, Side, SupervisorNode,
};
use common::*;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{ActionCommand, ActionEvent, ActionSegment, ObjectStream, RobotStream};
use cowork_ros::Warning;
use cowork_supervisor::{ActionKind, Decision, Event, GripperState, Supervisor};

fn t(s: f64) -> Time {
    Time::from_secs_f64(s)
}

fn node(ltm: cowork_supervisor::Ltm, params: &Params) -> SupervisorNode {
    SupervisorNode::new(Supervisor::new(ltm, "pizza", params.attention.clone()).expect("task"), params)
}

fn closed_on(object: &str) -> RobotStream {
    RobotStream { gripper_state: RobotStream::GRIPPER_CLOSED, held_object: object.into(), ..Default::default() }
}

fn done(label: &str, held: Option<&str>) -> RobotStream {
    RobotStream {
        gripper_state: if held.is_some() { RobotStream::GRIPPER_CLOSED } else { RobotStream::GRIPPER_OPEN },
        held_object: held.unwrap_or("").into(),
        events: vec![ActionEvent { label: label.into(), done: true, ..Default::default() }],
        ..Default::default()
    }
}

fn kinds(w: &[Warning]) -> Vec<&str> {
    w.iter().map(|w| w.kind.as_str()).collect()
}

/// The outputs of one tick, split into commands and warnings.
fn tick(node: &mut SupervisorNode, now_s: f64) -> (Vec<ActionCommand>, Vec<Warning>) {
    let mut out = Vec::new();
    node.on_tick(t(now_s), &mut out);
    let mut commands = Vec::new();
    let mut warnings = Vec::new();
    for o in out {
        match o {
            Output::Action(c) => commands.push(c),
            Output::Warning(w) => warnings.push(w),
            _ => {}
        }
    }
    (commands, warnings)
}

#[test]
fn per_arm_robot_streams_produce_arm_tagged_events() {
    let mut left = RobotStreamDecoder::for_arm("left");
    assert_eq!(left.topic(), "/left/robot_stream");
    let mut msg = closed_on("tomato");
    msg.events.push(ActionEvent { label: "lclose3(tomato)".into(), done: true, ..Default::default() });
    msg.events.push(ActionEvent { label: "lfoa4(pizza)".into(), failed: true, reason: "blocked".into(), ..Default::default() });
    msg.segments.push(ActionSegment { label: "lfoa1".into(), kind: ActionSegment::KIND_FOA, object_name: "tomato".into(), ..Default::default() });
    msg.segments.push(ActionSegment { label: "x".into(), kind: 9, ..Default::default() });
    let (mut events, mut problems) = (Vec::new(), Vec::new());
    left.decode_warnings(&msg, &mut events, &mut problems);
    let arm = Some("left".to_owned());
    assert_eq!(
        events,
        vec![
            Event::ActionDone { arm: arm.clone(), label: "lclose3(tomato)".into() },
            Event::ActionFailed { arm: arm.clone(), label: "lfoa4(pizza)".into(), reason: "blocked".into() },
            Event::Segment { arm: arm.clone(), label: "lfoa1".into(), kind: ActionKind::Foa, object: Some("tomato".into()) },
            Event::Gripper { arm: arm.clone(), state: GripperState::Close, object: Some("tomato".into()) },
        ]
    );
    assert_eq!(kinds(&problems), ["/left/robot_stream:segments.kind"], "the warning names the arm's topic");
    assert!(problems[0].message.starts_with("/left/robot_stream:"), "{}", problems[0].message);

    // Through the node: each arm's gripper is its own, and each arm keeps its own last state
    // (the same report on the other arm is news there).
    let params = Params::default();
    let mut n = node(pizza_ltm(), &params);
    assert_eq!(n.dual_arms(), ["left", "right"]);
    n.on_input(&Input::ArmRobotStream { arm: "left".into(), msg: closed_on("tomato") });
    n.on_input(&Input::ArmRobotStream { arm: "right".into(), msg: RobotStream::default() });
    tick(&mut n, 0.01);
    let s = n.supervisor().state();
    assert!(s.get("left.tomato.taken") && !s.get("left.hand.free"), "left closed on the tomato");
    assert!(s.get("right.hand.free") && !s.get("right.tomato.taken"), "right untouched");
    n.on_input(&Input::ArmRobotStream { arm: "right".into(), msg: closed_on("cheese") });
    n.on_input(&Input::ArmRobotStream { arm: "left".into(), msg: closed_on("tomato") });
    tick(&mut n, 0.02);
    let s = n.supervisor().state();
    assert!(s.get("left.tomato.taken") && s.get("right.cheese.taken"));
    assert_eq!((s.held(0), s.held(1)), (Some("tomato"), Some("cheese")));
    n.on_input(&Input::ArmRobotStream { arm: "left".into(), msg: RobotStream::default() });
    tick(&mut n, 0.03);
    let s = n.supervisor().state();
    assert!(s.get("left.hand.free") && !s.get("left.tomato.taken") && s.get("right.cheese.taken"), "only left opened");
    assert_eq!(n.warnings(), 0);

    // The root topics carry no arm, and an arm the LTM does not declare is no arm: dropped.
    n.on_input(&Input::RobotStream(closed_on("basil")));
    n.on_input(&Input::ObjectStream(ObjectStream::default()));
    n.on_input(&Input::ArmRobotStream { arm: "middle".into(), msg: closed_on("basil") });
    let (_, w) = tick(&mut n, 0.04);
    assert_eq!(kinds(&w), ["/robot_stream:arms", "/object_stream:arms", "supervisor:undeclared_arm"], "{w:?}");
    assert!(w[2].message.contains("/middle/robot_stream") && w[2].message.contains("left, right"), "{}", w[2].message);
    assert!(!n.supervisor().state().get("basil.taken"));
}

#[test]
fn the_side_rule_of_the_areas() {
    let a = AreaParams::default();
    assert_eq!((a.central.x, a.central.y), ([0.2, 0.7], [-0.2, 0.2]));
    assert_eq!(a.classify(0.45, 0.0), Some(Side::Central));
    assert_eq!(a.classify(0.2, 0.2), Some(Side::Central), "bounds are inside");
    assert_eq!(a.classify(0.7, -0.2), Some(Side::Central));
    assert_eq!(a.classify(0.45, 0.2001), Some(Side::Left));
    assert_eq!(a.classify(0.45, -0.2001), Some(Side::Right));
    assert_eq!(a.classify(5.0, 3.0), Some(Side::Left), "x does not matter beside the band");
    assert_eq!(a.classify(0.1, 0.0), Some(Side::BetweenOutsideBox));
    assert_eq!(a.classify(f64::NAN, 0.0), None);
    assert_eq!(a.base_frame("left"), "left/lwr_base_link");
}

/// The helper's independent frame arithmetic, checked by hand: the left base's z axis points
/// to the world's +y (out of the left shoulder).
#[test]
fn poses_in_the_arm_base_frames_of_the_pizza_scene() {
    let p = in_base(&LEFT, [0.45, 0.0, 0.01]);
    for (a, b) in [p.x, p.y, p.z].iter().zip([0.6, 0.54, -0.12]) {
        assert!((a - b).abs() < 1e-12, "{p:?}");
    }
    let p = in_base(&RIGHT, [0.45, 0.0, 0.01]);
    for (a, b) in [p.x, p.y, p.z].iter().zip([0.6, -0.54, -0.12]) {
        assert!((a - b).abs() < 1e-12, "{p:?}");
    }
}

#[test]
fn object_areas_come_from_poses_in_each_arm_base_frame() {
    let params = Params::default();
    let mut n = node(pizza_ltm(), &params);
    n.on_tf_static(&tf_static(&BASES));
    // Each arm sees every object, in its own base frame.
    for b in &BASES {
        n.on_arm_object_stream(b.arm, &object_stream(b, &OBJECTS));
    }
    let (_, w) = tick(&mut n, 0.01);
    assert!(w.is_empty(), "{w:?}");
    let s = n.supervisor().state();
    for (name, area) in [("pizza", "central"), ("tomato", "left"), ("oil", "left"), ("cheese", "right"), ("basil", "right")] {
        let o = s.object(name).unwrap_or_else(|| panic!("{name} observed"));
        assert_eq!(o.area.as_deref(), Some(area), "{name}");
        assert!(o.visible, "{name}");
        assert_eq!(o.distance_m, None, "{name}: per-arm distances only");
        let p = OBJECTS.iter().find(|(n, _)| *n == name).expect("scene object").1;
        for (i, b) in BASES.iter().enumerate() {
            let d = o.arm_distance_m[i].unwrap_or_else(|| panic!("{name}: {} distance", b.arm));
            assert!((d - reach(b, p)).abs() < 1e-12, "{name} from {}", b.arm);
        }
    }
    assert!(s.accessible("tomato", Some(0)) && !s.accessible("tomato", Some(1)), "the tomato is the left arm's");
    assert!(!s.accessible("cheese", Some(0)) && s.accessible("cheese", Some(1)), "the cheese is the right arm's");
    assert!(s.accessible("pizza", Some(0)) && s.accessible("pizza", Some(1)), "the pizza is shared");

    // Where the arms that see an object disagree (a boundary), it is central; beside the box
    // along x, central with a warning.
    let mut left_view = object_stream(&LEFT, &[("oil", [0.45, 0.19, 0.08]), ("basil", [0.1, 0.0, 0.08])]);
    let right_view = object_stream(&RIGHT, &[("oil", [0.45, 0.21, 0.08])]);
    n.on_arm_object_stream("right", &right_view);
    n.on_arm_object_stream("left", &left_view);
    let (_, w) = tick(&mut n, 0.02);
    assert_eq!(kinds(&w), ["supervisor:area_outside_box"], "{w:?}");
    assert!(w[0].message.contains("basil"), "{}", w[0].message);
    let s = n.supervisor().state();
    assert_eq!(s.area("oil"), Some("central"));
    assert_eq!(s.area("basil"), Some("central"));
    // Only reports that see the object decide.
    left_view.objects[0].visible = false;
    n.on_arm_object_stream("left", &left_view);
    tick(&mut n, 0.03);
    assert_eq!(n.supervisor().state().area("oil"), Some("left"), "the right arm alone sees it at y = 0.21");
}

/// Until an arm's base is on `/tf_static`, objects only it sees have no area and the library
/// is told they are not seen (it would take an object with no area as every arm's, outside
/// the central area): no arm acts on them, and a warning says why.
#[test]
fn objects_of_an_arm_whose_base_is_unknown_are_not_acted_on() {
    let params = Params::default();
    let mut n = node(taught_pizza(), &params);
    let pick = |names: &[&str]| -> Vec<(&'static str, [f64; 3])> { OBJECTS.iter().filter(|(n, _)| names.contains(n)).copied().collect() };
    // Left sees its bottles and the pizza, right its bottles and the pizza.
    let left = object_stream(&LEFT, &pick(&["tomato", "oil", "pizza"]));
    let right = object_stream(&RIGHT, &pick(&["cheese", "basil", "pizza"]));
    n.on_arm_object_stream("left", &left);
    assert!(!n.ready(), "waits for every arm's first object stream");
    n.on_arm_object_stream("right", &right);
    assert!(n.ready());
    let (commands, w) = tick(&mut n, 0.01);
    assert!(commands.is_empty(), "no area known: nothing commanded: {commands:?}");
    let unknown: Vec<&Warning> = w.iter().filter(|w| w.kind == "supervisor:area_unknown").collect();
    for (frame, object) in [("left/lwr_base_link", "tomato"), ("right/lwr_base_link", "cheese")] {
        assert!(unknown.iter().any(|w| w.message.contains(frame) && w.message.contains(object)), "{frame}: {w:?}");
    }
    for name in ["tomato", "pizza", "cheese"] {
        let s = n.supervisor().state();
        assert!(!s.object(name).expect("observed").visible, "{name} is reported as not seen");
        assert_eq!(s.area(name), None);
        assert!(!s.accessible(name, Some(0)) && !s.accessible(name, Some(1)), "{name}: no arm may act on it");
    }

    // The left base arrives: what the left arm sees is placed at once (no new object stream
    // needed); the right arm's bottles still wait.
    n.on_tf_static(&tf_static(&[LEFT]));
    let (commands, w) = tick(&mut n, 0.02);
    let s = n.supervisor().state();
    assert_eq!((s.area("tomato"), s.area("oil"), s.area("pizza")), (Some("left"), Some("left"), Some("central")));
    assert!(!s.object("cheese").expect("observed").visible && s.area("cheese").is_none());
    assert!(w.iter().any(|w| w.kind == "supervisor:area_unknown" && w.message.contains("right/lwr_base_link") && w.message.contains("cheese")), "{w:?}");
    assert_eq!(commands.len(), 1, "{commands:?}");
    assert_eq!((commands[0].arm.as_str(), commands[0].label.as_str()), ("left", "lfoa1(tomato)"));

    // The right base: its bottles are placed and seen.
    n.on_tf_static(&tf_static(&BASES));
    let (_, w) = tick(&mut n, 0.03);
    assert!(w.is_empty(), "{w:?}");
    let s = n.supervisor().state();
    assert_eq!((s.area("cheese"), s.area("basil")), (Some("right"), Some("right")));
    assert!(s.object("cheese").expect("observed").visible);
}

/// Two fake robot managers, one per arm, each completing its arm's commands after
/// `ACTION_S` on its own `/<arm>/robot_stream`.
#[derive(Debug, Default)]
struct FakeArm {
    held: Option<String>,
    running: Option<(String, f64)>,
}

const ACTION_S: f64 = 0.3;

#[test]
fn commands_name_their_arm_and_the_central_area_is_one_arm_at_a_time() {
    let params = Params { snapshot_rate_hz: 0.0, ..Params::default() };
    let mut n = node(taught_pizza(), &params);
    n.on_input(&Input::TfStatic(tf_static(&BASES)));
    for b in &BASES {
        n.on_input(&Input::ArmObjectStream { arm: b.arm.into(), msg: object_stream(b, &OBJECTS) });
        n.on_input(&Input::ArmRobotStream { arm: b.arm.into(), msg: RobotStream::default() });
    }
    let mut arms = [FakeArm::default(), FakeArm::default()];
    // (time, arm, label, is a command (else a done event))
    let mut log: Vec<(f64, usize, String, bool)> = Vec::new();
    let mut waited_for_central = [0usize; 2];
    for k in 0..3000 {
        let now = k as f64 * 0.01;
        for (i, a) in arms.iter_mut().enumerate() {
            if let Some((label, due)) = a.running.clone()
                && now >= due
            {
                if label.contains("close") {
                    a.held = label.split(['(', ')']).nth(1).map(str::to_owned);
                } else if label.contains("open") {
                    a.held = None;
                }
                a.running = None;
                n.on_arm_robot_stream(BASES[i].arm, &done(&label, a.held.as_deref()));
                log.push((now, i, label, false));
            }
        }
        let (commands, w) = tick(&mut n, now);
        assert!(w.is_empty(), "{w:?}");
        for c in commands {
            let i = BASES.iter().position(|b| b.arm == c.arm).unwrap_or_else(|| panic!("a command for an undeclared arm: {c:?}"));
            assert_eq!(c.label.chars().next(), Some(c.arm.chars().next().expect("named")), "{c:?}: taught on that arm");
            if c.stop {
                if arms[i].running.as_ref().is_some_and(|(l, _)| *l == c.label) {
                    arms[i].running = None;
                }
            } else {
                arms[i].running = Some((c.label.clone(), now + ACTION_S));
                log.push((now, i, c.label.clone(), true));
            }
        }
        let on_pizza = |a: &FakeArm| a.running.as_ref().is_some_and(|(l, _)| l.contains("(pizza)"));
        assert!(!(on_pizza(&arms[0]) && on_pizza(&arms[1])), "both arms on the pizza at {now}");
        for i in 0..2 {
            if on_pizza(&arms[i]) {
                assert_eq!(n.supervisor().central_holder(), Some(BASES[i].arm), "{} on the pizza without the grant at {now}", BASES[i].arm);
                let other = &arms[1 - i];
                if other.running.is_none() && other.held.is_some() {
                    waited_for_central[1 - i] += 1;
                }
            }
        }
        if n.supervisor().task_accomplished() {
            break;
        }
    }
    assert!(n.supervisor().task_accomplished(), "{log:?}");
    assert_eq!(n.warnings(), 0);
    for (i, b) in BASES.iter().enumerate() {
        assert!(log.iter().any(|(_, a, _, cmd)| *a == i && *cmd), "{} commanded", b.arm);
    }
    // Both arms hold an ingredient and want the pizza: the arm on it keeps the central area
    // until it completes an action outside it (on `world`); the other waits until then and gets
    // its pizza action in that very tick.
    let b = (0..2).find(|&i| waited_for_central[i] > 0).unwrap_or_else(|| panic!("no arm ever waited for the central area: {log:?}"));
    let a = 1 - b;
    let pizza_cmd = |e: &&(f64, usize, String, bool)| e.3 && e.2.contains("(pizza)");
    let tb = log.iter().filter(pizza_cmd).find(|e| e.1 == b).map(|e| e.0).expect("the waiting arm pours");
    let ta = log.iter().filter(pizza_cmd).filter(|e| e.1 == a && e.0 < tb).map(|e| e.0).next_back().expect("the other arm held the pizza first");
    let released = log
        .iter()
        .find(|(t, arm, l, cmd)| *arm == a && !cmd && *t > ta && l.contains("(world)"))
        .map(|e| e.0)
        .expect("the first arm leaves the central area");
    assert!(tb >= released && tb - released < 0.015, "{} poured at {tb}, the central area was released at {released}: {log:?}", BASES[b].arm);
    // The tomato (left area) was the left arm's, the cheese (right area) the right arm's.
    assert!(log.iter().any(|(_, a, l, cmd)| *a == 0 && *cmd && l.ends_with("(tomato)")));
    assert!(log.iter().any(|(_, a, l, cmd)| *a == 1 && *cmd && l.ends_with("(cheese)")));
    assert!(!log.iter().any(|(_, a, l, _)| *a == 1 && l.ends_with("(tomato)")));
}

/// A command for an arm is answered only by that arm's robot stream: an event on the other
/// arm's does not stop the resends, and the warning names the arm's topic.
#[test]
fn resends_are_tracked_per_arm() {
    let params = Params::default();
    let mut n = node(taught_pizza(), &params);
    n.on_tf_static(&tf_static(&BASES));
    for b in &BASES {
        n.on_arm_object_stream(b.arm, &object_stream(b, &OBJECTS));
    }
    let (first, _) = tick(&mut n, 0.0);
    assert_eq!(first.len(), 1);
    let c = first[0].clone();
    assert_eq!((c.arm.as_str(), c.label.as_str()), ("left", "lfoa1(tomato)"));
    // The right manager reports an event with the same id and label: not the left arm's answer.
    let echo = RobotStream { events: vec![ActionEvent { label: c.label.clone(), command_id: c.id, ..Default::default() }], ..Default::default() };
    n.on_arm_robot_stream("right", &echo);
    let mut resent = Vec::new();
    let mut warnings = Vec::new();
    for k in 1..=150 {
        let (cs, w) = tick(&mut n, k as f64 * 0.01);
        resent.extend(cs);
        warnings.extend(w);
    }
    assert_eq!(resent, vec![ActionCommand { header: resent[0].header.clone(), ..c.clone() }], "sent again once after 1 s");
    assert!(warnings.iter().any(|w| w.kind == "supervisor:action_resent" && w.message.contains("/left/robot_stream")), "{warnings:?}");
    // The left manager's started event answers it.
    n.on_arm_robot_stream("left", &echo);
    for k in 151..=400 {
        let (cs, _) = tick(&mut n, k as f64 * 0.01);
        assert!(cs.is_empty(), "{cs:?}");
    }
}

#[test]
fn a_command_for_an_undeclared_arm_is_never_made() {
    let action = |arm: Option<&str>| Decision::Action {
        id: 3,
        arm: arm.map(str::to_owned),
        label: "lfoa1(tomato)".into(),
        kind: ActionKind::Foa,
        subtask: "s".into(),
        releaser: "true".into(),
        emphasis: 1.0,
    };
    let stop = |arm: Option<&str>| Decision::Stop { arm: arm.map(str::to_owned), label: "lfoa1(tomato)".into(), reason: "x".into() };
    let mut dual = CommandTracker::for_arms(&["left".into(), "right".into()]);
    assert!(dual.declares("left") && !dual.declares("middle") && !dual.declares(""));
    assert_eq!(dual.command(&action(Some("left")), t(0.0)).map(|c| c.arm), Some("left".into()));
    for arm in [Some("middle"), None] {
        assert!(dual.command(&action(arm), t(0.0)).is_none(), "{arm:?}");
        assert!(dual.command(&stop(arm), t(0.0)).is_none(), "{arm:?}");
    }
    let mut single = CommandTracker::for_arms(&[String::new()]);
    assert!(single.command(&action(None), t(0.0)).is_some());
    assert!(single.command(&action(Some("left")), t(0.0)).is_none());
    // The library decides for declared arms only: a whole two-arm run is checked in
    // `commands_name_their_arm_and_the_central_area_is_one_arm_at_a_time`.
}

#[test]
fn area_parameters_are_validated_naming_the_key() {
    let refused = |p: Params, key: &str| {
        let e = format!("{:#}", p.validate("cfg.yaml").expect_err(key));
        assert!(e.starts_with("cfg.yaml:") && e.contains(&format!("`{key}`")), "{key}: {e}");
    };
    for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for k in 0..2 {
            let mut p = Params::default();
            p.areas.central.x[k] = v;
            refused(p, "areas.central.x");
            let mut p = Params::default();
            p.areas.central.y[k] = v;
            refused(p, "areas.central.y");
        }
    }
    let mut p = Params::default();
    p.areas.central.x = [0.5, 0.5];
    refused(p, "areas.central.x");
    let mut p = Params::default();
    p.areas.central.y = [0.2, -0.2];
    refused(p, "areas.central.y");
    let mut p = Params::default();
    p.areas.frame = String::new();
    refused(p, "areas.frame");
    let mut p = Params::default();
    p.areas.base_link = "lwr base".into();
    refused(p, "areas.base_link");
    let mut p = Params::default();
    p.areas.right_arm = "left".into();
    refused(p, "areas.left_arm");
    let mut p = Params::default();
    p.attention.central_area = "left".into();
    refused(p, "attention.central_area");

    let a = AreaParams::default();
    a.check_arms("cfg.yaml", &["left".into(), "right".into()]).expect("the pizza arms");
    a.check_arms("cfg.yaml", &[]).expect("single arm: not used");
    let e = a.check_arms("cfg.yaml", &["arm1".into(), "arm2".into()]).expect_err("not the LTM's arms").to_string();
    assert!(e.contains("`areas.left_arm`") && e.contains("arm1, arm2"), "{e}");

    let yaml = "attentional_supervisor:\n  ros__parameters:\n    areas:\n      central:\n        x: [0.1, 0.5]\n";
    let p: Params = cowork_ros::params::from_str(yaml, "attentional_supervisor", "x.yaml").expect("partial block");
    assert_eq!((p.areas.central.x, p.areas.central.y, p.areas.frame.as_str()), ([0.1, 0.5], [-0.2, 0.2], "world"));
    let typo = "attentional_supervisor:\n  ros__parameters:\n    areas:\n      centre: {}\n";
    assert!(cowork_ros::params::from_str::<Params>(typo, "attentional_supervisor", "x.yaml").is_err());
    let file: Params = cowork_ros::params::load(&root().join("config/attentional_supervisor.yaml"), "attentional_supervisor").expect("file");
    assert_eq!(file.areas, AreaParams::default(), "the file holds the defaults");
}

#[test]
fn the_written_out_bases_and_objects_are_the_pizza_scene_s() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/scenes/pizza.yaml");
    let scene = cowork_sim::Scene::from_file(&path).expect("pizza scene");
    for base in BASES {
        let arm = scene.arms.iter().find(|a| a.name == base.arm).expect(base.arm);
        assert_eq!(arm.base.position, base.position, "{}", base.arm);
        let rpy = arm.base.rpy.expect("rpy");
        assert!(rpy.iter().zip(base.rpy).all(|(a, b)| (a - b).abs() < 1e-12), "{}: {rpy:?}", base.arm);
    }
    for (name, position) in OBJECTS {
        let o = scene.objects.iter().find(|o| o.name == name).expect(name);
        assert_eq!(o.pose.position, position, "{name}");
    }
}
