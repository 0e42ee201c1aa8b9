//! Bad input gets a clear error (files) or a warning decision (events), and the loop goes on.

mod common;

use common::*;
use cowork_supervisor::{Decision, Error, Event, Ltm, ObjectObs, Supervisor, SupervisorConfig, Warning};

fn err(text: &str) -> Error {
    Ltm::parse(text).expect_err("must be rejected")
}

#[test]
fn syntax_errors_name_line_and_column() {
    let cases = [
        ("schema(add(Obj), [(subtask(take,Obj), hand.free)] Obj.used).", 1, 51, "expected ',' before the post-condition"),
        ("objects([water]).\nschema(a, [], water.used)\nschema(b, [], true).", 3, 1, "expected '.' at the end of the clause"),
        ("schema(a, [(b, ~)], true).", 1, 17, "expected a state literal"),
        ("schema(a, [], true, fast).", 1, 21, "expected action kind"),
        ("schema(a, [], x.done) .\n  skema(b, [], true).", 2, 3, "expected 'schema', 'arms' or 'objects'"),
        ("schema(a, [], true & x.done).", 1, 15, "'true' cannot be combined"),
        ("schema(Add, [], true).", 1, 8, "expected a behaviour name"),
    ];
    for (text, line, column, msg) in cases {
        match err(text) {
            Error::Syntax { line: l, column: c, message } => {
                assert_eq!((l, c), (line, column), "{text}: {message}");
                assert!(message.contains(msg), "{text}: {message}");
            }
            other => panic!("{text}: {other}"),
        }
    }
    let shown = err("schema(a, [], true)").to_string();
    assert!(shown.starts_with("schema syntax error at line 1, column 20"), "{shown}");
}

#[test]
fn unbound_cyclic_unknown_are_rejected() {
    let e = err("schema(add(Obj), [(subtask(take,Obj), hand.free)], Thing.used).\nschema(subtask(take,O), [], O.taken).");
    assert!(matches!(&e, Error::UnboundVariable { variable, line: 1, .. } if variable == "Thing"), "{e}");
    let e = err("schema(add(Obj), [(subtask(take,X), X.free)], Obj.used).\nschema(subtask(take,O), [], O.taken).");
    assert!(matches!(&e, Error::UnboundVariable { variable, .. } if variable == "X"), "{e}");
    let e = err("schema(prepare, [(add(water), true)], water.added).\nschema(add(O), [(stir(O), true)], O.added).\nschema(stir(O), [(add(O), true)], O.stirred).");
    assert!(matches!(&e, Error::CyclicSchema { cycle } if cycle.len() == 3), "{e}");
    assert!(e.to_string().contains("add(O) -> stir(O) -> add(O)"), "{e}");
    let e = err("objects([water, cup]).\nschema(add(O), [(pour(O), cup.ready & ~wtaer.taken)], O.added).\nschema(pour(O), [], O.added).");
    assert!(matches!(&e, Error::UnknownObject { name, line: 2, column: 39, .. } if name == "wtaer"), "{e}");
    let e = err("schema(add(O), [(powr(O), true)], O.added).");
    assert!(matches!(&e, Error::UnknownBehaviour { behaviour, .. } if behaviour == "powr(O)"), "{e}");
    let e = err("schema(a, [], x.done).\nschema(a, [], y.done).");
    assert!(matches!(e, Error::DuplicateSchema { line: 2, first_line: 1, .. }), "{e}");
    let e = err("schema(foa1(w), [(x, true)], foa1.done, foa).\nschema(x, [], x.done).");
    assert!(matches!(e, Error::ActionWithChildren { .. }), "{e}");
}

#[test]
fn bad_tasks_and_files() {
    let kitchen = || ltm("kitchen.schema");
    for (task, want) in [("prepareCofee", "no schema"), ("add(Obj)", "variables"), ("add(watr)", "unknown object 'watr'"), ("add(", "syntax")] {
        let e = Supervisor::new(kitchen(), task, SupervisorConfig::default()).expect_err(task);
        assert!(e.to_string().contains(want), "{task}: {e}");
    }
    let e = Ltm::load(std::path::Path::new("/nonexistent/ltm.schema")).expect_err("missing");
    assert!(e.to_string().contains("/nonexistent/ltm.schema"), "{e}");
    let bad = SupervisorConfig { lambda_max_s: 0.01, ..SupervisorConfig::default() };
    assert!(Supervisor::new(kitchen(), "prepareCoffee", bad).is_err());
}

#[test]
fn bad_events_warn_and_the_loop_continues() {
    let learned = learned(ltm("kitchen.schema"), "prepareCoffee", "coffee_teach.jsonl");
    let mut sup = Supervisor::new(learned, "prepareCoffee", SupervisorConfig::default()).expect("task");
    let first = sup.tick_vec(0.0);
    let running = first
        .iter()
        .find_map(|d| match d {
            Decision::Action { label, .. } => Some(label.clone()),
            _ => None,
        })
        .expect("executing");
    let bad = [
        Event::Speech { text: "make coffee please".into() },
        Event::Speech { text: "human make(sandwich)".into() },
        Event::Speech { text: "done".into() },
        Event::Objects {
            objects: vec![
                ObjectObs { name: "sugar".into(), distance: Some(0.3), arm_distances: Default::default(), visible: true, area: None },
                ObjectObs { name: "water".into(), distance: Some(f64::NAN), arm_distances: Default::default(), visible: true, area: None },
            ],
        },
        Event::ActionDone { arm: None, label: "noa99(cup)".into() },
        Event::Gripper { arm: Some("tentacle".into()), state: cowork_supervisor::GripperState::Close, object: None },
        Event::Segment { arm: None, label: "foa50(cup)".into(), kind: cowork_supervisor::ActionKind::Foa, object: None },
    ];
    for e in &bad {
        sup.handle(e, 0.1);
    }
    let d = sup.tick_vec(0.1);
    let warnings: Vec<&Warning> = d
        .iter()
        .filter_map(|d| match d {
            Decision::Warning { warning, .. } => Some(warning),
            _ => None,
        })
        .collect();
    assert!(matches!(warnings[0], Warning::UnknownSpeech { text } if text == "make coffee please"));
    assert!(matches!(warnings[1], Warning::UnknownSubtask { .. }));
    assert!(matches!(warnings[2], Warning::IgnoredSpeech { .. }));
    assert!(matches!(warnings[3], Warning::UnknownObject { name } if name == "sugar"));
    assert!(matches!(warnings[4], Warning::NonFinite { .. }));
    assert!(matches!(warnings[5], Warning::UnexpectedActionEvent { .. }));
    assert!(matches!(warnings[6], Warning::UnknownArm { .. }));
    assert!(matches!(warnings[7], Warning::SegmentOutsideTeaching { .. }));
    assert_eq!(warnings.len(), 8);
    // Nothing else changed: the same action is still running and finishing it moves on.
    assert_eq!(sup.running(0), Some(running.as_str()));
    sup.handle(&Event::ActionDone { arm: None, label: running.clone() }, 0.2);
    let d = sup.tick_vec(0.2);
    assert!(d.iter().any(|d| matches!(d, Decision::Action { label, .. } if *label != running)), "{d:?}");
}

#[test]
fn bad_event_script_lines_are_reported() {
    let e = cowork_supervisor::parse_jsonl("{\"t\":0,\"type\":\"speech\",\"text\":\"teach\"}\n{\"t\":1,\"type\":\"objects\",\"objects\":[{\"nam\":\"x\"}]}")
        .expect_err("bad");
    assert!(e.to_string().starts_with("event script line 2:"), "{e}");
}

#[test]
fn words_addressed_to_an_arm_of_the_ltm_are_taken_and_to_any_other_refused() {
    let mut sup = Supervisor::new(ltm("pizza.schema"), "pizza", SupervisorConfig::default()).expect("task");
    sup.tick_vec(0.0);
    sup.handle(&Event::Speech { text: "left: teach".into() }, 0.1);
    let d = sup.tick_vec(0.1);
    assert!(d.iter().any(|d| matches!(d, Decision::Mode { mode: cowork_supervisor::Mode::Teach })), "{d:?}");
    sup.handle(&Event::Speech { text: "left: gripper close".into() }, 0.2);
    sup.handle(&Event::Speech { text: "tentacle: done".into() }, 0.3);
    let d = sup.tick_vec(0.3);
    let warnings: Vec<String> = d
        .iter()
        .filter_map(|d| match d {
            Decision::Warning { warning, .. } => Some(warning.to_string()),
            _ => None,
        })
        .collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains("no arm `tentacle` in the LTM (arms: left, right)"), "{}", warnings[0]);
    assert!(!d.iter().any(|d| matches!(d, Decision::Mode { .. })), "still teaching: {d:?}");
    sup.handle(&Event::Speech { text: "right: done".into() }, 0.4);
    let d = sup.tick_vec(0.4);
    assert!(d.iter().any(|d| matches!(d, Decision::Mode { mode: cowork_supervisor::Mode::Execute })), "{d:?}");
}
