//! Helpers shared by the scenario and property tests.
#![allow(dead_code)]

use std::path::PathBuf;

use cowork_supervisor::{Decision, Ltm, RunConfig, RunReport, SimRobot, Supervisor, SupervisorConfig, TimedEvent, parse_jsonl, runner};

pub fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

pub fn task_file(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/tasks").join(name)
}

pub fn events(name: &str) -> Vec<TimedEvent> {
    let text = std::fs::read_to_string(data(name)).expect("read script");
    parse_jsonl(&text).expect("valid script")
}

pub fn ltm(name: &str) -> Ltm {
    Ltm::load(&task_file(name)).expect("valid LTM")
}

/// Runs a script; `robot` simulates the robot manager with that action duration (s).
pub fn run(ltm: Ltm, task: &str, script: &str, robot: Option<f64>) -> (Supervisor, RunReport) {
    let mut sup = Supervisor::new(ltm, task, SupervisorConfig::default()).expect("task");
    let cfg = RunConfig { robot: robot.map(|d| SimRobot { action_duration_s: d }), ..RunConfig::default() };
    let rep = runner::run(&mut sup, &events(script), &cfg, |_, _, _, _| {});
    (sup, rep)
}

/// Teaches with a script and returns the learned LTM after a save → load round trip.
pub fn learned(ltm: Ltm, task: &str, script: &str) -> Ltm {
    let (sup, rep) = run(ltm, task, script, None);
    assert_no_warnings(&rep);
    let dir = tempfile::tempdir().expect("tmp");
    let p = dir.path().join("learned.schema");
    sup.ltm().save(&p).expect("save");
    Ltm::load(&p).expect("reload")
}

pub fn warnings(rep: &RunReport) -> Vec<String> {
    rep.records
        .iter()
        .filter_map(|r| match &r.decision {
            Decision::Warning { message, .. } => Some(message.clone()),
            _ => None,
        })
        .collect()
}

pub fn assert_no_warnings(rep: &RunReport) {
    let w = warnings(rep);
    assert!(w.is_empty(), "unexpected warnings: {w:?}");
}

/// Index of the first record satisfying `f`.
pub fn first(rep: &RunReport, f: impl Fn(&Decision) -> bool) -> Option<usize> {
    rep.records.iter().position(|r| f(&r.decision))
}

pub fn accomplished_at(rep: &RunReport, behaviour: &str) -> Option<usize> {
    first(rep, |d| matches!(d, Decision::Accomplished { behaviour: b } if b == behaviour))
}

pub fn action_at(rep: &RunReport, label: &str) -> Option<usize> {
    first(rep, |d| matches!(d, Decision::Action { label: l, .. } if l == label))
}
