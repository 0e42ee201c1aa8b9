//! A demonstration that does not reach a subtask's post-condition (issue #15 "bad input": a
//! demonstration that never closes the gripper; tea-reuse seed 2: the hand closed on nothing)
//! must not be learned as that subtask, nor declared accomplished: the subtask stays open, a
//! warning names it, and the LTM keeps no actions for it.

mod common;

use common::{ltm, run, warnings};
use cowork_supervisor::{Decision, Ltm, RunReport, parse_jsonl, runner, RunConfig, Supervisor, SupervisorConfig};

/// `pour_teach.jsonl` with the gripper line `"object":"water"` replaced (`None`: the
/// gripper lines removed, i.e. the teacher never closed or opened it).
fn pour_teach(close_on: Option<&str>) -> String {
    let text = std::fs::read_to_string(common::data("pour_teach.jsonl")).expect("script");
    text.lines()
        .filter(|l| close_on.is_some() || !l.contains("gripper"))
        .map(|l| match close_on {
            Some(o) => l.replace("\"object\":\"water\"", &format!("\"object\":{o}")),
            None => l.to_owned(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn teach(script: &str) -> (Supervisor, RunReport) {
    let mut sup = Supervisor::new(ltm("kitchen.schema"), "pourDrink", SupervisorConfig::default()).expect("task");
    let rep = runner::run(&mut sup, &parse_jsonl(script).expect("script"), &RunConfig::default(), |_, _, _, _| {});
    (sup, rep)
}

fn learned_actions(ltm: &Ltm, subtask: &str) -> Option<usize> {
    ltm.schemas().find(|(_, s)| s.kind.is_none() && s.head.to_string() == subtask).map(|(_, s)| s.list.len())
}

fn accomplished(rep: &RunReport, behaviour: &str) -> bool {
    common::accomplished_at(rep, behaviour).is_some()
}

#[test]
fn the_whole_demonstration_is_learned_as_before() {
    let (sup, rep) = run(ltm("kitchen.schema"), "pourDrink", "pour_teach.jsonl", None);
    assert!(warnings(&rep).is_empty(), "{:?}", warnings(&rep));
    assert!(accomplished(&rep, "subtask(take,water)") && accomplished(&rep, "pourDrink"));
    assert_eq!(learned_actions(sup.ltm(), "subtask(take,water)"), Some(3));
}

#[test]
fn a_hand_that_closed_on_nothing_has_not_taken_the_bottle() {
    let (sup, rep) = teach(&pour_teach(Some("null")));
    let w = warnings(&rep);
    assert!(!accomplished(&rep, "subtask(take,water)"), "take(water) accomplished with nothing in the hand; {w:?}");
    assert!(!accomplished(&rep, "pourDrink"));
    let named: Vec<&String> = w.iter().filter(|m| m.contains("subtask(take,water)") && m.contains("water.taken")).collect();
    assert!(!named.is_empty(), "no warning names take(water) and water.taken: {w:?}");
    // At `done` its actions are forgotten: the LTM keeps take(water) open.
    assert_eq!(learned_actions(sup.ltm(), "subtask(take,water)").unwrap_or(0), 0);
    assert!(w.iter().any(|m| m.contains("forgotten")), "{w:?}");
}

#[test]
fn a_demonstration_without_the_gripper_is_not_learned_as_a_take() {
    let (sup, rep) = teach(&pour_teach(None));
    let w = warnings(&rep);
    assert!(!accomplished(&rep, "subtask(take,water)"), "take(water) accomplished without a grasp; {w:?}");
    assert!(w.iter().any(|m| m.contains("subtask(take,water)") && m.contains("forgotten")), "{w:?}");
    assert_eq!(learned_actions(sup.ltm(), "subtask(take,water)").unwrap_or(0), 0);
    // It is open again: executing asks for a demonstration of it.
    let mut exec = Supervisor::new(sup.ltm().clone(), "pourDrink", SupervisorConfig::default()).expect("task");
    let d = exec.tick_vec(0.0);
    assert!(
        d.iter().any(|d| matches!(d, Decision::AwaitDemonstration { subtask, .. } if subtask == "subtask(take,water)")),
        "{d:?}"
    );
    assert!(!d.iter().any(|d| matches!(d, Decision::Action { .. })), "{d:?}");
}
